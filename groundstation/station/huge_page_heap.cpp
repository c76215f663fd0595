// use_huge_page_heap: set glibc.malloc.hugetlb=1 and re-execute (huge_page_heap.hpp).
#include "groundstation/station/huge_page_heap.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

namespace teamscan::station {

namespace {
constexpr const char* kTunable = "glibc.malloc.hugetlb";
// With the heap on huge pages, memory that glibc maps and unmaps per allocation (by default anything
// from 128 KiB up: a model write's snapshot, a hash table's rehash) is faulted in and zeroed afresh in
// 2 MiB pages every time. Below 32 MiB (glibc's largest mmap threshold) such blocks come from the heap
// and its free memory is kept (trimmed only past 512 MiB), so the pages are reused (the loop's p99 with
// and without them: docs/groundstation.md "Huge pages").
constexpr const char* kCompanions = "glibc.malloc.mmap_threshold=33554432:glibc.malloc.trim_threshold=536870912";
// Set by this function before it re-executes: the new process knows it is the re-executed one.
constexpr const char* kMarker = "TEAMSCAN_HUGE_PAGE_HEAP";
}  // namespace

std::string tunables_with_huge_pages(const char* existing) {
  const std::string now = existing ? existing : "";
  if (now.find(kTunable) != std::string::npos) return "";
  const std::string ours = std::string{kTunable} + "=1:" + kCompanions;
  return now.empty() ? ours : now + ":" + ours;
}

HeapPages use_huge_page_heap(char** argv, std::string* why) {
  if (std::getenv(kMarker) != nullptr) {
    unsetenv(kMarker);  // not passed on to the station's children
    return HeapPages::Huge;
  }
  const std::string tunables = tunables_with_huge_pages(std::getenv("GLIBC_TUNABLES"));
  if (tunables.empty()) return HeapPages::OperatorSet;
  setenv("GLIBC_TUNABLES", tunables.c_str(), 1);
  setenv(kMarker, "1", 1);
  execv("/proc/self/exe", argv);
  const int error = errno;  // only reached when execv failed: undo, go on with 4 KiB pages
  unsetenv(kMarker);
  if (why) *why = std::string{"execv(/proc/self/exe): "} + std::strerror(error);
  return HeapPages::ReexecFailed;
}

}  // namespace teamscan::station
