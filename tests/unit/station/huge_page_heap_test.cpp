// use_huge_page_heap (groundstation/station/huge_page_heap.hpp): the station re-executes itself once
// with glibc.malloc.hugetlb=1 added to GLIBC_TUNABLES, keeps an operator's own tunables, and leaves an
// operator's choice of the tunable alone. Runs the probe (huge_page_heap_probe.cpp) as a child.
#include "groundstation/station/huge_page_heap.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

namespace teamscan::station {
namespace {

TEST(HugePageHeap, TheTunableIsAddedToWhatIsThereUnlessItIsNamed) {
  const std::string ours = "glibc.malloc.hugetlb=1:glibc.malloc.mmap_threshold=33554432:glibc.malloc.trim_threshold=536870912";
  EXPECT_EQ(tunables_with_huge_pages(nullptr), ours);
  EXPECT_EQ(tunables_with_huge_pages(""), ours);
  EXPECT_EQ(tunables_with_huge_pages("glibc.malloc.check=0"), "glibc.malloc.check=0:" + ours);
  EXPECT_EQ(tunables_with_huge_pages("glibc.malloc.hugetlb=0"), "");
  EXPECT_EQ(tunables_with_huge_pages("glibc.malloc.check=0:glibc.malloc.hugetlb=2"), "");
}

std::vector<std::string> run_probe(const std::string& env) {
  const std::string command = "env -u TEAMSCAN_HUGE_PAGE_HEAP -u GLIBC_TUNABLES " + env + " " TEAMSCAN_PROBE;
  std::vector<std::string> lines;
  FILE* f = popen(command.c_str(), "r");
  if (f == nullptr) return lines;
  char buf[512];
  while (std::fgets(buf, sizeof buf, f)) {
    std::string line{buf};
    if (!line.empty() && line.back() == '\n') line.pop_back();
    lines.push_back(line);
  }
  EXPECT_EQ(pclose(f), 0);
  return lines;
}

TEST(HugePageHeap, TheProcessReexecutesOnceWithTheTunableAndTheSamePid) {
  const auto lines = run_probe("GLIBC_TUNABLES=glibc.malloc.check=0");
  ASSERT_GE(lines.size(), 3u);
  ASSERT_EQ(lines[0].rfind("start pid=", 0), 0u);
  EXPECT_EQ(lines[1], lines[0]) << "two executions of one process (the PID stays)";
  const std::string pid = lines[0].substr(std::string{"start "}.size());
  EXPECT_EQ(lines[2], "result=Huge " + pid + " tunables=glibc.malloc.check=0:" + tunables_with_huge_pages(nullptr) +
                          " marker=unset why=");
  for (const auto& l : lines) std::printf("probe: %s\n", l.c_str());  // AnonHugePages: informative only
}

TEST(HugePageHeap, AnOperatorsChoiceOfTheTunableIsKeptWithoutReexecution) {
  const auto lines = run_probe("GLIBC_TUNABLES=glibc.malloc.hugetlb=0");
  ASSERT_GE(lines.size(), 2u);
  ASSERT_EQ(lines[0].rfind("start pid=", 0), 0u);
  const std::string pid = lines[0].substr(std::string{"start "}.size());
  EXPECT_EQ(lines[1], "result=OperatorSet " + pid + " tunables=glibc.malloc.hugetlb=0 marker=unset why=");
}

}  // namespace
}  // namespace teamscan::station
