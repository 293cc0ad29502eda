#pragma once
// Counts heap allocations made by this thread, to prove that real-time paths
// allocate nothing after initialisation.
//
//   rollstep::test::AllocationGuard guard;   // starts counting
//   solver.update(...);
//   EXPECT_EQ(guard.count(), 0u);
//
// Works by replacing the global operator new/delete of the test executable
// (alloc_counter.cpp) and, outside sanitizer builds, malloc/calloc/realloc (Eigen's
// aligned allocator calls std::malloc directly; malloc_guard.cpp); counting is per thread so worker
// threads of the code under test do not disturb it, and is off unless a guard is alive.
#include <cstddef>

#include "common/malloc_guard.hpp"

namespace rollstep::test {

class AllocationGuard {
 public:
  AllocationGuard();
  ~AllocationGuard();
  AllocationGuard(const AllocationGuard&) = delete;
  AllocationGuard& operator=(const AllocationGuard&) = delete;

  /// Heap allocations (operator new of any form, malloc, calloc, realloc) made on this
  /// thread since construction.
  std::size_t count() const;

 private:
  MallocGuard malloc_;
  std::size_t start_;
  bool previous_enabled_;
};

/// Total allocations counted on this thread while some guard was alive.
std::size_t allocationCount();

}  // namespace rollstep::test
