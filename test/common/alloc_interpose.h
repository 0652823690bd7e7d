// Heap-allocation counter for the allocation-guard tests: replaces every operator new / delete of the
// program and (outside sanitizer builds, whose runtimes own malloc) interposes malloc, calloc, realloc
// and the aligned allocations, counting each call while armed.
//
// Include in exactly ONE translation unit of a test program: it defines the replacement functions.
// Arm with allocguard::arm(this_thread_only), read with allocguard::disarm(). With this_thread_only,
// only allocations of the arming thread count (a worker thread may allocate freely meanwhile).
#pragma once

#include <atomic>
#include <cstdlib>
#include <new>

// The sanitizers own malloc: GCC says so with __SANITIZE_*__, clang with __has_feature.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define BORESIGHT_NO_MALLOC_INTERPOSE 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define BORESIGHT_NO_MALLOC_INTERPOSE 1
#endif
#endif

namespace allocguard {
inline std::atomic<bool> g_armed{false};
inline std::atomic<bool> g_this_thread_only{false};
inline std::atomic<long> g_allocs{0};
inline thread_local bool t_counting = false;  // read only while armed (long after the thread's TLS exists)

inline void note() {
  if (!g_armed.load(std::memory_order_relaxed)) return;
  if (g_this_thread_only.load(std::memory_order_relaxed) && !t_counting) return;
  g_allocs.fetch_add(1, std::memory_order_relaxed);
}
/// Starts counting from zero.
inline void arm(bool this_thread_only = false) {
  t_counting = true;
  g_this_thread_only = this_thread_only;
  g_allocs = 0;
  g_armed = true;
}
/// Stops counting; the number of allocations since arm().
inline long disarm() {
  g_armed = false;
  t_counting = false;
  return g_allocs.load();
}
/// The count so far (armed or not).
inline long count() { return g_allocs.load(); }
}  // namespace allocguard

#ifndef BORESIGHT_NO_MALLOC_INTERPOSE
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
void __libc_free(void*);
void* malloc(std::size_t n) {
  allocguard::note();
  return __libc_malloc(n);
}
void* calloc(std::size_t n, std::size_t s) {
  allocguard::note();
  return __libc_calloc(n, s);
}
void* realloc(void* p, std::size_t n) {
  allocguard::note();
  return __libc_realloc(p, n);
}
void* aligned_alloc(std::size_t a, std::size_t n) {
  allocguard::note();
  return __libc_memalign(a, n);
}
int posix_memalign(void** p, std::size_t a, std::size_t n) {
  allocguard::note();
  *p = __libc_memalign(a, n);
  return *p ? 0 : 12;
}
void free(void* p) { __libc_free(p); }
}
#endif

// The replacements below pair operator new with malloc and operator delete with free on purpose;
// GCC cannot see that through inlining and warns about a mismatch.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#endif

void* operator new(std::size_t n) {
  allocguard::note();
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) { return operator new(n); }
void* operator new(std::size_t n, std::align_val_t a) {
  allocguard::note();
  void* p = nullptr;
  const std::size_t al = static_cast<std::size_t>(a) < sizeof(void*) ? sizeof(void*) : static_cast<std::size_t>(a);
  if (posix_memalign(&p, al, n ? n : 1) != 0) throw std::bad_alloc();
  return p;
}
void* operator new[](std::size_t n, std::align_val_t a) { return operator new(n, a); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
