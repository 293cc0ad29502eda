#pragma once
// A small persistent pool for static partitions of node ranges. Created once; run()
// wakes the workers through a condition variable and never allocates.
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

namespace rollstep::solver::detail {

class ThreadPool {
 public:
  explicit ThreadPool(int threads) : threads_(threads < 1 ? 1 : threads) {
    workers_.reserve(static_cast<std::size_t>(threads_ - 1));
    for (int i = 1; i < threads_; ++i) workers_.emplace_back([this, i] { loop(i); });
  }
  ~ThreadPool() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (auto& t : workers_) t.join();
  }
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int size() const { return threads_; }

  /// Calls f(begin, end) on the static partition of [0, n) into size() contiguous chunks;
  /// chunk 0 runs on the calling thread. Returns when all chunks are done.
  template <class F>
  void run(int n, F& f) {
    if (threads_ == 1 || n <= 1) {
      f(0, n);
      return;
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      fn_ = [](void* ctx, int b, int e) { (*static_cast<F*>(ctx))(b, e); };
      ctx_ = &f;
      n_ = n;
      pending_ = threads_ - 1;
      ++generation_;
    }
    wake_.notify_all();
    f(0, n / threads_);
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this] { return pending_ == 0; });
  }

 private:
  void loop(int id) {
    std::uint64_t seen = 0;
    for (;;) {
      void (*fn)(void*, int, int) = nullptr;
      void* ctx = nullptr;
      int n = 0;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
        if (stop_) return;
        seen = generation_;
        fn = fn_;
        ctx = ctx_;
        n = n_;
      }
      fn(ctx, static_cast<int>(static_cast<long>(n) * id / threads_),
         static_cast<int>(static_cast<long>(n) * (id + 1) / threads_));
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (--pending_ == 0) done_.notify_one();
      }
    }
  }

  int threads_;
  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  std::uint64_t generation_ = 0;
  int pending_ = 0;
  bool stop_ = false;
  void (*fn_)(void*, int, int) = nullptr;
  void* ctx_ = nullptr;
  int n_ = 0;
};

}  // namespace rollstep::solver::detail
