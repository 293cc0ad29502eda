// The solver's node-parallel thread pool (src/solver/thread_pool.hpp): every index of
// every job runs exactly once, on the static partition, whether the workers are polling
// (back-to-back jobs inside the spin window) or asleep (spin 0, or a pause longer than
// the window), nothing is allocated per job, and an exception a chunk throws reaches the
// caller once every chunk has ended (it would end the process on a worker). Run under
// ThreadSanitizer by the `sanitizer.thread` test.
#include "thread_pool.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "common/alloc_counter.hpp"

namespace rollstep::solver::detail {
namespace {

using std::chrono::microseconds;

/// Runs `jobs` jobs over [0, n) and checks that each index ran once per job, from the
/// chunk the static partition gives it (chunk 0 on the calling thread).
void runJobs(ThreadPool& pool, int n, int jobs, microseconds pause_between) {
  std::vector<int> hits(static_cast<std::size_t>(n), 0);
  std::vector<std::thread::id> owner(static_cast<std::size_t>(n));
  const auto caller = std::this_thread::get_id();
  for (int j = 0; j < jobs; ++j) {
    auto body = [&](int b, int e) {
      for (int k = b; k < e; ++k) {
        ++hits[static_cast<std::size_t>(k)];
        owner[static_cast<std::size_t>(k)] = std::this_thread::get_id();
      }
    };
    pool.run(n, body);
    for (int k = 0; k < n; ++k) {
      ASSERT_EQ(hits[static_cast<std::size_t>(k)], j + 1) << "index " << k << ", job " << j;
      // Chunk 0 = [0, n / threads) runs on the caller, the rest elsewhere (all of it on
      // the caller with one thread or n <= 1).
      const bool on_caller = pool.size() == 1 || n <= 1 || k < n / pool.size();
      EXPECT_EQ(owner[static_cast<std::size_t>(k)] == caller, on_caller) << k;
    }
    if (pause_between.count() > 0) std::this_thread::sleep_for(pause_between);
  }
}

TEST(ThreadPool, BackToBackJobsWhileTheWorkersPoll) {
  ThreadPool pool(2, microseconds(200000));
  runJobs(pool, 101, 500, microseconds(0));
}

TEST(ThreadPool, JobsWakeSleepingWorkers) {
  ThreadPool never_spins(2, microseconds(0));
  runJobs(never_spins, 101, 200, microseconds(0));
  // A pause longer than the spin window between every job: each run() wakes a sleeper.
  ThreadPool short_spin(3, microseconds(100));
  runJobs(short_spin, 37, 20, microseconds(2000));
}

TEST(ThreadPool, SmallRangesAndOneThread) {
  ThreadPool one(1, microseconds(0));
  runJobs(one, 5, 3, microseconds(0));
  ThreadPool two(2, microseconds(1000));
  runJobs(two, 1, 3, microseconds(0));  // n <= 1: the caller does it alone
  runJobs(two, 2, 3, microseconds(0));
}

TEST(ThreadPool, RunDoesNotAllocate) {
  ThreadPool pool(2, microseconds(0));
  std::atomic<int> sum{0};
  auto body = [&](int b, int e) { sum.fetch_add(e - b); };
  pool.run(64, body);  // workers started and asleep
  test::AllocationGuard guard;
  for (int j = 0; j < 50; ++j) pool.run(64, body);
  EXPECT_EQ(guard.count(), 0u);
  EXPECT_EQ(sum.load(), 51 * 64);
}

/// Runs one job over [0, n) whose chunks in `throwing` (by chunk id) throw after doing
/// their work; returns the message run() rethrew ("" when none).
std::string runThrowing(ThreadPool& pool, int n, const std::vector<int>& throwing,
                        std::vector<int>& hits) {
  hits.assign(static_cast<std::size_t>(n), 0);
  auto body = [&](int b, int e) {
    for (int k = b; k < e; ++k) ++hits[static_cast<std::size_t>(k)];
    for (int t : throwing) {
      if (b == pool.chunkBegin(n, t)) throw std::runtime_error("chunk " + std::to_string(t));
    }
  };
  try {
    pool.run(n, body);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(ThreadPool, AChunksExceptionReachesTheCallerAfterEveryChunkEnded) {
  const int n = 12;
  std::vector<int> hits;
  for (int threads : {1, 2, 3}) {
    for (auto spin : {microseconds(0), microseconds(100000)}) {
      ThreadPool pool(threads, spin);
      for (int t = 0; t < threads; ++t) {
        // On the caller's chunk or a worker's: rethrown by run(), every index done once.
        EXPECT_EQ(runThrowing(pool, n, {t}, hits), "chunk " + std::to_string(t)) << threads;
        for (int k = 0; k < n; ++k) EXPECT_EQ(hits[static_cast<std::size_t>(k)], 1) << k;
        // The pool is as good as new: the next jobs run whole, nothing rethrown again.
        EXPECT_EQ(runThrowing(pool, n, {}, hits), "");
        runJobs(pool, n, 3, microseconds(0));
      }
      // Every chunk throws: one exception reaches the caller, the others are dropped.
      std::vector<int> all;
      for (int t = 0; t < threads; ++t) all.push_back(t);
      EXPECT_EQ(runThrowing(pool, n, all, hits).rfind("chunk ", 0), 0u);
      EXPECT_EQ(runThrowing(pool, n, {}, hits), "");
    }
  }
}

}  // namespace
}  // namespace rollstep::solver::detail
