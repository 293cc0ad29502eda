#include "common/malloc_guard.hpp"

#include <cstddef>

#include "common/sanitized.hpp"

// Sanitizers interpose malloc themselves: counting is disabled (count() stays 0).
#if ROLLSTEP_SANITIZED
#define ROLLSTEP_MALLOC_GUARD_DISABLED 1
#endif

namespace {
thread_local bool g_on = false;
thread_local std::size_t g_n = 0;
}  // namespace

#ifndef ROLLSTEP_MALLOC_GUARD_DISABLED
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void __libc_free(void*);
}

extern "C" {
void* malloc(std::size_t n) {
  if (g_on) ++g_n;
  return __libc_malloc(n);
}
void* calloc(std::size_t a, std::size_t b) {
  if (g_on) ++g_n;
  return __libc_calloc(a, b);
}
void* realloc(void* p, std::size_t n) {
  if (g_on) ++g_n;
  return __libc_realloc(p, n);
}
void free(void* p) { __libc_free(p); }
}
#endif

namespace rollstep::test {
MallocGuard::MallocGuard() : start_(g_n), previous_(g_on) { g_on = true; }
MallocGuard::~MallocGuard() { g_on = previous_; }
std::size_t MallocGuard::count() const { return g_n - start_; }
bool MallocGuard::enabled() {
#ifdef ROLLSTEP_MALLOC_GUARD_DISABLED
  return false;
#else
  return true;
#endif
}
}  // namespace rollstep::test
