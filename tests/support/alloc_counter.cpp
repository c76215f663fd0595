// malloc-family hooks: the definitions below replace glibc's in a binary that links this object, and
// forward to the __libc_* implementations. Nothing here may allocate.
#include "tests/support/alloc_counter.hpp"

#include <atomic>
#include <cerrno>
#include <cstddef>

extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t n, std::size_t size);
void* __libc_realloc(void* p, std::size_t size);
void* __libc_memalign(std::size_t alignment, std::size_t size);
void __libc_free(void* p);
}

namespace {

// Initial-exec TLS in the executable: reading it never calls malloc (no lazy TLS allocation).
thread_local std::uint64_t t_allocs = 0;
thread_local std::uint64_t t_frees = 0;
thread_local std::uint64_t t_bytes = 0;
std::atomic<std::uint64_t> g_allocs{0};
std::atomic<std::uint64_t> g_frees{0};
std::atomic<std::uint64_t> g_bytes{0};

inline void count_alloc(std::size_t size) {
  ++t_allocs;
  t_bytes += size;
  g_allocs.fetch_add(1, std::memory_order_relaxed);
  g_bytes.fetch_add(size, std::memory_order_relaxed);
}
inline void count_free() {
  ++t_frees;
  g_frees.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace

extern "C" {

void* malloc(std::size_t size) {
  count_alloc(size);
  return __libc_malloc(size);
}

void* calloc(std::size_t n, std::size_t size) {
  count_alloc(n * size);
  return __libc_calloc(n, size);
}

void* realloc(void* p, std::size_t size) {
  if (p != nullptr || size != 0) count_alloc(size);
  return __libc_realloc(p, size);
}

void free(void* p) {
  if (p != nullptr) count_free();
  __libc_free(p);
}

void* memalign(std::size_t alignment, std::size_t size) {
  count_alloc(size);
  return __libc_memalign(alignment, size);
}

void* aligned_alloc(std::size_t alignment, std::size_t size) {
  count_alloc(size);
  return __libc_memalign(alignment, size);
}

int posix_memalign(void** out, std::size_t alignment, std::size_t size) {
  if (alignment < sizeof(void*) || (alignment & (alignment - 1)) != 0) return EINVAL;
  count_alloc(size);
  void* p = __libc_memalign(alignment, size);
  if (p == nullptr) return ENOMEM;
  *out = p;
  return 0;
}

}  // extern "C"

namespace teamscan::test {

AllocStats thread_alloc_stats() { return AllocStats{t_allocs, t_frees, t_bytes}; }

AllocStats process_alloc_stats() {
  return AllocStats{g_allocs.load(std::memory_order_relaxed), g_frees.load(std::memory_order_relaxed),
                    g_bytes.load(std::memory_order_relaxed)};
}

bool alloc_counter_active() {
  const std::uint64_t before = t_allocs;
  // volatile: the compiler may not elide the malloc/free pair.
  void* volatile p = malloc(16);
  free(p);
  return t_allocs == before + 1;
}

}  // namespace teamscan::test
