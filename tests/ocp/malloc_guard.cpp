#include "malloc_guard.hpp"

#include <cstddef>

extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void __libc_free(void*);
}

namespace {
thread_local bool g_on = false;
thread_local std::size_t g_n = 0;
}  // namespace

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

namespace rollstep::test {
MallocGuard::MallocGuard() : start_(g_n), previous_(g_on) { g_on = true; }
MallocGuard::~MallocGuard() { g_on = previous_; }
std::size_t MallocGuard::count() const { return g_n - start_; }
}  // namespace rollstep::test
