#pragma once
// Perception on its own thread (asynchronous runs): the real-time side posts each scan
// (points, sensor pose, time) and goes on; a worker thread fuses it into the elevation map,
// segments it and builds the terrain (TerrainPerception::update, 10-30 ms), then hands the
// outcome to a sink on that thread (e.g. the control pipeline's setTerrain, which is made
// to be called from outside the real-time loop).
//
// The hand-over is a mailbox of the newest scan: three frames preallocated for the scan's
// size, the producer copies into its own frame and publishes it with one atomic index
// exchange, the worker takes the newest published frame the same way. The producer never
// allocates, locks or waits; a scan posted while the worker is still busy with an earlier
// one supersedes any scan posted before it that the worker has not taken (only the newest
// counts, as for a map that must follow the robot).
#include <Eigen/Geometry>
#include <array>
#include <atomic>
#include <cstdint>
#include <exception>
#include <functional>
#include <thread>
#include <vector>

#include "rollstep/common/latest_value_mailbox.hpp"
#include "rollstep/perception/terrain_perception.hpp"

namespace rollstep::perception {

/// One scan as posted: points in the sensor frame (NaN for misses), the sensor's pose in
/// the world, the scan's time [s].
struct ScanFrame {
  std::vector<Eigen::Vector3d> points;
  Eigen::Isometry3d sensor_pose = Eigen::Isometry3d::Identity();
  double time = 0.0;
  std::uint64_t sequence = 0;  ///< 1, 2, ... in posting order
};

/// Single-producer single-consumer mailbox of the newest scan (a LatestValueMailbox of
/// frames), frames of at most `capacity` points allocated at construction.
class ScanMailbox {
 public:
  explicit ScanMailbox(int capacity);

  /// Producer: copies the scan into its frame and publishes it. False (nothing published)
  /// for more than capacity() points. Never allocates, locks or waits.
  bool publish(const std::vector<Eigen::Vector3d>& points, const Eigen::Isometry3d& sensor_pose,
               double time) noexcept;
  /// Consumer: the newest frame published since the last take(), or nullptr. The frame
  /// stays the consumer's (the producer does not touch it) until the next take().
  const ScanFrame* take() noexcept;
  /// Consumer: whether a frame is waiting.
  bool pending() const noexcept { return frames_.pending(); }

  int capacity() const { return capacity_; }
  /// Producer: frames published so far.
  std::uint64_t published() const { return frames_.published(); }

 private:
  int capacity_;
  LatestValueMailbox<ScanFrame> frames_;
};

/// Counts of a worker (consistent once stop() has returned).
struct PerceptionWorkerCounters {
  std::uint64_t posted = 0;      ///< scans published by post()
  std::uint64_t processed = 0;   ///< scans the worker ran update() on
  std::uint64_t superseded = 0;  ///< posted scans replaced by a newer one before processing
  double max_update_ms = 0.0;    ///< wall time of the slowest update() [ms]
  double total_update_ms = 0.0;
};

class PerceptionWorker {
 public:
  /// Called on the worker thread after each update(): the perception (its terrain, map and
  /// status may be read there), the update's status and the scan's time. An exception from
  /// it (or from update) stops the worker; stop() rethrows it.
  using Sink = std::function<void(const TerrainPerception& perception, PerceptionStatus status,
                                  double time)>;

  /// Starts the worker thread on `perception`, which only that thread touches until stop()
  /// returns (the caller keeps it alive that long). Scans of up to `scan_capacity` points.
  PerceptionWorker(TerrainPerception& perception, int scan_capacity, Sink sink);
  /// Stops the thread (exceptions from the worker are dropped here: call stop() to see them).
  ~PerceptionWorker();
  PerceptionWorker(const PerceptionWorker&) = delete;
  PerceptionWorker& operator=(const PerceptionWorker&) = delete;

  /// Real-time side (one thread): hands a scan to the worker. Never allocates, locks or
  /// waits. False (nothing posted) for more points than the capacity, after stop() or
  /// when the worker failed.
  bool post(const std::vector<Eigen::Vector3d>& points, const Eigen::Isometry3d& sensor_pose,
            double time) noexcept;
  /// Whether every scan posted so far has been processed or superseded (the worker idle).
  bool idle() const noexcept;
  /// True once the worker stopped on an exception.
  bool failed() const noexcept { return failed_.load(std::memory_order_acquire); }

  /// Processes the scan still waiting (if any), stops and joins the thread; rethrows an
  /// exception the worker stopped on. Idempotent (rethrows once).
  void stop();
  /// The counts (call after stop(); while running they may lag).
  PerceptionWorkerCounters counters() const;

 private:
  void run();
  bool processOne();

  TerrainPerception* perception_;
  Sink sink_;
  ScanMailbox mailbox_;
  std::atomic<std::uint64_t> posted_{0}, done_{0};  // done: processed or superseded
  std::atomic<bool> stop_{false}, failed_{false};
  std::uint64_t processed_ = 0, last_sequence_ = 0;  // worker's
  double max_ms_ = 0.0, total_ms_ = 0.0;             // worker's
  std::exception_ptr error_;                         // worker's until joined
  bool stopped_ = false;
  std::thread thread_;
};

}  // namespace rollstep::perception
