// Allocation counter for tests and benchmarks: link the object library teamscan_test_alloc_counter into
// a test binary and malloc/calloc/realloc/memalign/free of every thread are counted (they forward to
// glibc's __libc_* functions, DDS_SYSTEMD.md 1.8). Counts are per thread and process-wide. Not for
// sanitizer builds: AddressSanitizer owns malloc there (tests/hil/dds skips its allocation test).
#pragma once

#include <cstdint>

namespace teamscan::test {

struct AllocStats {
  std::uint64_t allocs = 0;   // malloc, calloc, realloc (non-null ptr or size>0), memalign family
  std::uint64_t frees = 0;    // free of a non-null pointer (realloc's implicit free not counted)
  std::uint64_t bytes = 0;    // bytes requested by the counted allocations
  friend AllocStats operator-(const AllocStats& a, const AllocStats& b) {
    return AllocStats{a.allocs - b.allocs, a.frees - b.frees, a.bytes - b.bytes};
  }
};

// Counts of the calling thread since it started.
[[nodiscard]] AllocStats thread_alloc_stats();
// Counts of all threads since the process started.
[[nodiscard]] AllocStats process_alloc_stats();
// True when the hooks are linked in and active (a test asserts this, so it cannot pass vacuously).
[[nodiscard]] bool alloc_counter_active();

// Start/stop measurement on the calling thread.
class AllocScope {
 public:
  AllocScope() : start_{thread_alloc_stats()} {}
  [[nodiscard]] AllocStats delta() const { return thread_alloc_stats() - start_; }
  void restart() { start_ = thread_alloc_stats(); }

 private:
  AllocStats start_;
};

}  // namespace teamscan::test
