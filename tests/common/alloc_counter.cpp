#include "common/alloc_counter.hpp"

#include <cstdlib>
#include <new>

#include "common/sanitized.hpp"

#if ROLLSTEP_SANITIZED
// Sanitizers interpose malloc: operator new goes through them (and malloc counting,
// see malloc_guard.cpp, is off).
#define ROLLSTEP_RAW_MALLOC(n) std::malloc(n)
#else
// Bypass the counting malloc of malloc_guard.cpp so that one new counts once.
extern "C" void* __libc_malloc(std::size_t);
#define ROLLSTEP_RAW_MALLOC(n) __libc_malloc(n)
#endif

namespace {
thread_local bool g_enabled = false;
thread_local std::size_t g_count = 0;

void* countedAlloc(std::size_t size) {
  if (g_enabled) ++g_count;
  if (size == 0) size = 1;
  if (void* p = ROLLSTEP_RAW_MALLOC(size)) return p;
  throw std::bad_alloc();
}

void* countedAlignedAlloc(std::size_t size, std::align_val_t align) {
  if (g_enabled) ++g_count;
  const std::size_t a = static_cast<std::size_t>(align);
  const std::size_t rounded = ((size == 0 ? 1 : size) + a - 1) / a * a;
  if (void* p = std::aligned_alloc(a, rounded)) return p;
  throw std::bad_alloc();
}
}  // namespace

namespace rollstep::test {
AllocationGuard::AllocationGuard() : start_(g_count), previous_enabled_(g_enabled) {
  g_enabled = true;
}
AllocationGuard::~AllocationGuard() { g_enabled = previous_enabled_; }
std::size_t AllocationGuard::count() const { return g_count - start_ + malloc_.count(); }
std::size_t allocationCount() { return g_count; }
}  // namespace rollstep::test

void* operator new(std::size_t size) { return countedAlloc(size); }
void* operator new[](std::size_t size) { return countedAlloc(size); }
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  try {
    return countedAlloc(size);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept {
  try {
    return countedAlloc(size);
  } catch (...) {
    return nullptr;
  }
}
void* operator new(std::size_t size, std::align_val_t al) { return countedAlignedAlloc(size, al); }
void* operator new[](std::size_t size, std::align_val_t al) {
  return countedAlignedAlloc(size, al);
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
