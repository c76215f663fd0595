// The station's heap on transparent huge pages. The fusion core's maps (free-space grid, model store,
// live map, hash tables) are read at random, a cache miss per voxel; on 4 KiB pages each miss is also a
// TLB miss (dearer still under a hypervisor's nested paging) and every page of a growing map is a page
// fault. glibc (≥ 2.35) backs malloc's memory with THP when the tunable glibc.malloc.hugetlb=1 is set,
// but reads tunables only when a process starts: the station sets it (with a 32 MiB mmap threshold and a
// 512 MiB trim threshold, so large blocks are reused rather than faulted in afresh) and re-executes
// itself, once, first thing in main. Measured in docs/groundstation.md "Huge pages". An operator's own
// setting of glibc.malloc.hugetlb (either value) is kept, and then nothing is added.
#pragma once

#include <string>

namespace teamscan::station {

enum class HeapPages {
  Huge,           // the tunable was set by this function before the re-exec: THP for the heap
  OperatorSet,    // GLIBC_TUNABLES already names glibc.malloc.hugetlb: left as the operator set it
  ReexecFailed,   // execv failed: the process goes on with 4 KiB pages (error in `why`)
};

// Call first in main, before any thread exists. Does not return if it re-executes the process
// (/proc/self/exe with the same argv; the PID, and so systemd's view of the service, stays the same).
// The re-executed process returns Huge.
HeapPages use_huge_page_heap(char** argv, std::string* why = nullptr);

// The GLIBC_TUNABLES value that adds hugetlb=1 and its two companions to `existing` (null or empty:
// none), or "" if `existing` already names glibc.malloc.hugetlb. Pure: the rule itself, for the tests.
std::string tunables_with_huge_pages(const char* existing);

}  // namespace teamscan::station
