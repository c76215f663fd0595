// Test helper for huge_page_heap_test: calls use_huge_page_heap first thing, as the station's main does,
// and prints what a test can check: one "start" line per execution (so a re-execution shows as two,
// with the same PID), the outcome, the tunables the process runs with, and how much of 64 MiB of
// touched heap the kernel backs with huge pages (AnonHugePages of the process).
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>

#include "groundstation/station/huge_page_heap.hpp"

int main(int, char** argv) {
  std::printf("start pid=%d\n", static_cast<int>(getpid()));
  std::fflush(stdout);
  std::string why;
  const auto heap = teamscan::station::use_huge_page_heap(argv, &why);
  const char* names[] = {"Huge", "OperatorSet", "ReexecFailed"};
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  std::printf("result=%s pid=%d tunables=%s marker=%s why=%s\n", names[static_cast<int>(heap)], static_cast<int>(getpid()),
              tunables ? tunables : "", std::getenv("TEAMSCAN_HUGE_PAGE_HEAP") ? "set" : "unset", why.c_str());
  constexpr std::size_t kBytes = std::size_t{64} << 20;
  auto* p = static_cast<char*>(std::malloc(kBytes));
  if (p == nullptr) return 1;
  std::memset(p, 1, kBytes);
  std::ifstream smaps("/proc/self/smaps_rollup");
  for (std::string line; std::getline(smaps, line);)
    if (line.rfind("AnonHugePages:", 0) == 0) std::printf("%s\n", line.c_str());
  std::free(p);
  return 0;
}
