#include "rollstep/perception/perception_worker.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>

namespace rollstep::perception {

ScanMailbox::ScanMailbox(int capacity) : capacity_(capacity) {
  if (capacity < 1) {
    throw std::invalid_argument("ScanMailbox: capacity " + std::to_string(capacity) +
                                " must be >= 1");
  }
  frames_.forEachSlot(
      [capacity](ScanFrame& f) { f.points.reserve(static_cast<std::size_t>(capacity)); });
}

bool ScanMailbox::publish(const std::vector<Eigen::Vector3d>& points,
                          const Eigen::Isometry3d& sensor_pose, double time) noexcept {
  if (points.size() > static_cast<std::size_t>(capacity_)) return false;
  ScanFrame& f = frames_.writable();
  // Within the reserved capacity: neither resize nor assign reallocates.
  f.points.resize(points.size());
  std::copy(points.begin(), points.end(), f.points.begin());
  f.sensor_pose = sensor_pose;
  f.time = time;
  f.sequence = frames_.published() + 1;  // the version publish() gives it
  frames_.publish();
  return true;
}

const ScanFrame* ScanMailbox::take() noexcept {
  return frames_.take() ? &frames_.current() : nullptr;
}

PerceptionWorker::PerceptionWorker(TerrainPerception& perception, int scan_capacity, Sink sink)
    : perception_(&perception), sink_(std::move(sink)), mailbox_(scan_capacity) {
  thread_ = std::thread([this] { run(); });
}

PerceptionWorker::~PerceptionWorker() {
  try {
    stop();
  } catch (...) {
    // Reported by an explicit stop(); a destructor must not throw.
  }
}

bool PerceptionWorker::post(const std::vector<Eigen::Vector3d>& points,
                            const Eigen::Isometry3d& sensor_pose, double time) noexcept {
  if (stopped_ || failed()) return false;
  if (!mailbox_.publish(points, sensor_pose, time)) return false;
  posted_.store(mailbox_.published(), std::memory_order_release);
  return true;
}

bool PerceptionWorker::idle() const noexcept {
  return done_.load(std::memory_order_acquire) == posted_.load(std::memory_order_acquire) ||
         failed();
}

bool PerceptionWorker::processOne() {
  const ScanFrame* frame = mailbox_.take();
  if (frame == nullptr) return false;
  const auto start = std::chrono::steady_clock::now();
  const PerceptionStatus status =
      perception_->update(frame->points, frame->sensor_pose, frame->time);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  max_ms_ = std::max(max_ms_, ms);
  total_ms_ += ms;
  ++processed_;
  if (sink_) sink_(*perception_, status, frame->time);
  last_sequence_ = frame->sequence;
  done_.store(frame->sequence, std::memory_order_release);
  return true;
}

void PerceptionWorker::run() {
  try {
    for (;;) {
      if (processOne()) continue;
      if (stop_.load(std::memory_order_acquire)) {
        // A scan posted just before stop() is processed too.
        while (processOne()) {
        }
        return;
      }
      // Nothing waiting: the LiDAR posts every 0.1 s; a 1 ms nap adds at most 1 % of that
      // to the latency, without a lock or a condition variable on the posting side.
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  } catch (...) {
    error_ = std::current_exception();
    failed_.store(true, std::memory_order_release);
  }
}

void PerceptionWorker::stop() {
  if (!stopped_) {
    stopped_ = true;
    stop_.store(true, std::memory_order_release);
    if (thread_.joinable()) thread_.join();
  }
  if (error_) {
    std::exception_ptr e = error_;
    error_ = nullptr;
    std::rethrow_exception(e);
  }
}

PerceptionWorkerCounters PerceptionWorker::counters() const {
  PerceptionWorkerCounters c;
  c.posted = posted_.load(std::memory_order_acquire);
  c.processed = processed_;
  c.superseded = last_sequence_ >= processed_ ? last_sequence_ - processed_ : 0;
  c.max_update_ms = max_ms_;
  c.total_update_ms = total_ms_;
  return c;
}

}  // namespace rollstep::perception
