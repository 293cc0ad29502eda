#pragma once
// A small persistent pool for static partitions of node ranges, built for the real-time
// path: run() publishes a job through atomics and neither allocates nor locks while the
// workers are awake. After each job a worker spins (with a pause instruction) for up to
// `spin` on the job counter, so the back-to-back phases of one solver iteration (they
// are separated by the sequential Riccati sweeps, well under a millisecond) start on all
// threads at once. Past that window the worker blocks on a condition variable, so an idle
// controller does not burn a core; only then does run() take the mutex, to wake it.
// An exception thrown by a job (a problem's callback) is caught on the thread that threw
// it and rethrown by run() on the caller once every chunk has finished, as with one thread.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>
#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace rollstep::solver::detail {

/// Tells the core that this thread is spinning (frees resources for a sibling
/// hyperthread, lowers the cost of the loop exit).
inline void cpuRelax() {
#if defined(__x86_64__) || defined(__i386__)
  _mm_pause();
#elif defined(__aarch64__)
  asm volatile("yield" ::: "memory");
#endif
}

class ThreadPool {
 public:
  /// `threads` >= 1 (the caller is thread 0); `spin`: how long an idle worker polls for
  /// the next job before it blocks (zero: block at once).
  ThreadPool(int threads, std::chrono::microseconds spin)
      : threads_(threads < 1 ? 1 : threads), spin_(spin) {
    workers_.reserve(static_cast<std::size_t>(threads_ - 1));
    for (int i = 1; i < threads_; ++i) workers_.emplace_back([this, i] { loop(i); });
  }
  ~ThreadPool() {
    stop_.store(true);
    generation_.fetch_add(1);
    { std::lock_guard<std::mutex> lock(mutex_); }  // a worker between its check and its wait
    wake_.notify_all();
    for (auto& t : workers_) t.join();
  }
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int size() const { return threads_; }

  /// One step of a polling loop: a pause instruction, and every kYieldEvery steps a
  /// yield, so that on an oversubscribed machine (tests run in parallel, a worker that
  /// lost its core) the poller hands its core to a runnable thread instead of spinning
  /// against it; with a core to itself the yield returns at once.
  static void pause(int i) {
    cpuRelax();
    if (i % kYieldEvery == 0) std::this_thread::yield();
  }

  /// First index of chunk id (0..size()) of the static partition of [0, n) that run uses.
  int chunkBegin(int n, int id) const {
    return static_cast<int>(static_cast<long>(n) * id / threads_);
  }

  /// Calls f(begin, end) on the static partition of [0, n) into size() contiguous chunks;
  /// chunk 0 runs on the calling thread. Returns when all chunks are done; then rethrows
  /// the first exception a chunk threw, if any (the other chunks ran to their end: f must
  /// not wait for another chunk's progress if it can throw). One caller at a time.
  template <class F>
  void run(int n, F& f) {
    if (threads_ == 1 || n <= 1) {
      f(0, n);
      return;
    }
    // Plain writes, published by the increment of generation_ (the workers read them
    // after loading the new generation) and not touched again before every worker has
    // reported back through pending_.
    fn_ = [](void* ctx, int b, int e) { (*static_cast<F*>(ctx))(b, e); };
    ctx_ = &f;
    n_ = n;
    pending_.store(threads_ - 1, std::memory_order_relaxed);
    generation_.fetch_add(1);  // sequentially consistent: ordered before the sleepers_ load
    if (sleepers_.load() > 0) {
      { std::lock_guard<std::mutex> lock(mutex_); }
      wake_.notify_all();
    }
    try {
      f(0, chunkBegin(n, 1));
    } catch (...) {
      keepFirstError();
    }
    for (int i = 1; pending_.load(std::memory_order_acquire) != 0; ++i) pause(i);
    // error_ was written before its thread's release of pending_ (or on this thread).
    if (failed_.load(std::memory_order_relaxed)) {
      failed_.store(false, std::memory_order_relaxed);
      std::exception_ptr e = error_;
      error_ = nullptr;
      std::rethrow_exception(e);
    }
  }

 private:
  static constexpr int kYieldEvery = 64;

  /// Waits for a generation other than `seen` (or stop); returns it.
  std::uint64_t waitForJob(std::uint64_t seen) {
    using Clock = std::chrono::steady_clock;
    const auto start = Clock::now();
    for (int i = 1;; ++i) {
      const std::uint64_t g = generation_.load(std::memory_order_acquire);
      if (g != seen) return g;
      pause(i);
      if (i % kYieldEvery == 0 && Clock::now() - start >= spin_) break;
    }
    // Block. The sequentially consistent pair (sleepers_ here, generation_ in run) means
    // either run() sees this sleeper and notifies under the mutex, or this thread sees
    // the new generation in the predicate: no lost wake-up.
    sleepers_.fetch_add(1);
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] { return generation_.load() != seen; });
    }
    sleepers_.fetch_sub(1);
    return generation_.load(std::memory_order_acquire);
  }

  /// Keeps the exception being handled unless another chunk of the job threw first (an
  /// exception escaping a worker would end the process).
  void keepFirstError() {
    if (!failed_.exchange(true)) error_ = std::current_exception();
  }

  void loop(int id) {
    std::uint64_t seen = 0;
    for (;;) {
      seen = waitForJob(seen);
      if (stop_.load()) return;
      const int n = n_;
      try {
        fn_(ctx_, chunkBegin(n, id), chunkBegin(n, id + 1));
      } catch (...) {
        keepFirstError();
      }
      pending_.fetch_sub(1, std::memory_order_release);
    }
  }

  const int threads_;
  const std::chrono::microseconds spin_;
  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::atomic<std::uint64_t> generation_{0};
  std::atomic<int> pending_{0};
  std::atomic<int> sleepers_{0};
  std::atomic<bool> stop_{false};
  std::atomic<bool> failed_{false};  // a chunk of the current job threw
  std::exception_ptr error_;         // its exception (the first one)
  void (*fn_)(void*, int, int) = nullptr;
  void* ctx_ = nullptr;
  int n_ = 0;
};

}  // namespace rollstep::solver::detail
