#pragma once
// Counts heap allocations made by this thread, to prove that real-time paths
// allocate nothing after initialisation.
//
//   rollstep::test::AllocationGuard guard;   // starts counting
//   solver.update(...);
//   EXPECT_EQ(guard.count(), 0u);
//
// Works by replacing the global operator new/delete of the test executable
// (alloc_counter.cpp); counting is per thread so worker threads of the code under
// test do not disturb it, and is off unless a guard is alive.
#include <cstddef>

namespace rollstep::test {

class AllocationGuard {
 public:
  AllocationGuard();
  ~AllocationGuard();
  AllocationGuard(const AllocationGuard&) = delete;
  AllocationGuard& operator=(const AllocationGuard&) = delete;

  /// Number of calls to operator new (any form) on this thread since construction.
  std::size_t count() const;

 private:
  std::size_t start_;
  bool previous_enabled_;
};

/// Total allocations counted on this thread while some guard was alive.
std::size_t allocationCount();

}  // namespace rollstep::test
