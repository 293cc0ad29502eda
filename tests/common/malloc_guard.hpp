#pragma once
// Counts calls to malloc/calloc/realloc on this thread (Eigen's aligned allocator calls
// std::malloc directly, so operator-new counting alone would not see it). Link
// malloc_guard.cpp into the test executable; glibc only (wraps __libc_malloc). Under
// ASan/TSan (which interpose malloc) counting is disabled: enabled() is false.
//
//   rollstep::test::MallocGuard guard;
//   solver.solve(x0);
//   EXPECT_EQ(guard.count(), 0u);
#include <cstddef>

namespace rollstep::test {

class MallocGuard {
 public:
  MallocGuard();
  ~MallocGuard();
  MallocGuard(const MallocGuard&) = delete;
  MallocGuard& operator=(const MallocGuard&) = delete;
  std::size_t count() const;
  static bool enabled();

 private:
  std::size_t start_;
  bool previous_;
};

}  // namespace rollstep::test
