#pragma once
// Perception in closed loop: the simulated LiDAR scans the scene at its rate
// and each scan is fused into the elevation map at the sensor pose computed from the base
// pose the controller uses (the state estimator's estimate, or the ground truth), then
// segmented into a new terrain (perception::TerrainPerception). A scan with a bad status
// (every ray missed, no finite point, a bad pose, no planar region) builds nothing: the
// last valid terrain stays. Each new terrain goes to a sink (connect(): the controllers hand
// it to their pipeline, ControlPipeline / BaselinePipeline::setTerrain).
//
// Timing: deterministic (the default): the map update, segmentation and terrain run in the
// caller's thread at the scan's time, in order (bitwise reproducible). Asynchronous
// (options.asynchronous, for runs whose MPC has its own thread): the caller only casts the
// rays and posts the scan (perception::PerceptionWorker: copied into a preallocated frame,
// never allocating, locking or waiting); the map update, segmentation, levelling and the
// sink run on the worker thread, which takes the newest scan (an older one still waiting is
// superseded).
//
// The terrain is built unshrunk (regions = the surfaces): a consumer shrinks it by its own
// foothold margin (footholdTerrain: planning::shrinkTerrain, seams between the convex
// pieces of one surface kept, so that no gap opens in the middle of a floor); the baseline
// also takes it unshrunk as its collision solids.
//
// Map log (`rollstep sim --log-map DIR`): at a chosen rate, DIR/maps.csv (one row per
// snapshot), DIR/heights_NNNN.npy (the elevation map, float32, NaN = empty, row r along
// world y, column c along world x, NumPy's .npy format version 1.0), DIR/regions.csv (the
// controller's foothold regions in use: every vertex of every region) and
// DIR/footholds.csv (the controller's planned footholds). docs/PERCEPTION.md documents the columns.
#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "rollstep/common/text_file.hpp"
#include "rollstep/perception/perception_worker.hpp"
#include "rollstep/perception/terrain_perception.hpp"
#include "rollstep/sim/lidar.hpp"
#include "rollstep/sim/plant.hpp"

namespace rollstep::sim {

struct OnlinePerceptionOptions {
  LidarSettings lidar;
  /// regions.margin is set to 0 (see above); closed_loop: the warm-up scans, the footprint
  /// fill, levelling and seams (config/perception.yaml).
  perception::PerceptionSettings perception;
  /// Fault drill: scans in [blind_from, blind_until) [s] return no point at all (a blinded
  /// or failed sensor: every ray a NaN).
  double blind_from = std::numeric_limits<double>::infinity();
  double blind_until = std::numeric_limits<double>::infinity();
  /// Map log: directory ("" = none) and snapshots per second (deterministic timing only).
  std::string log_dir;
  double log_rate = 2.0;
  /// The map update, segmentation and terrain on their own thread (see above).
  bool asynchronous = false;
};

/// Scans and their outcomes so far.
struct OnlinePerceptionCounters {
  std::uint64_t scans = 0;
  std::uint64_t terrains = 0;    ///< scans that built a new terrain (status ok)
  std::uint64_t kept = 0;        ///< scans with a bad status: the last terrain kept
  std::uint64_t no_points = 0;   ///< ... of them NoPoints
  std::uint64_t non_finite = 0;  ///< ... NonFinite
  std::uint64_t invalid_pose = 0;
  std::uint64_t no_planar_region = 0;
  std::uint64_t handed_over = 0;  ///< new terrains the sink accepted
  std::uint64_t refused = 0;      ///< ... and refused (the last one stays in use)
  std::uint64_t superseded = 0;   ///< asynchronous: scans replaced by a newer one unprocessed
  double max_update_ms = 0.0;     ///< wall time of the slowest scan's map update + segmentation
  double total_update_ms = 0.0;
};

class OnlinePerception {
 public:
  /// Receives each new terrain (terrain(), footholdTerrain() may be read in it), on the
  /// thread that built it; returns whether it was taken (counted: handed_over / refused).
  using TerrainSink = std::function<bool(const OnlinePerception& perception)>;

  /// Throws std::invalid_argument for bad settings (a map log with asynchronous timing
  /// too). Writes nothing (openLog does).
  explicit OnlinePerception(const OnlinePerceptionOptions& options);
  /// Map log (options.log_dir set): creates the directory, removes an earlier run's
  /// heights_*.npy and opens the CSV files; snapshots are written from then on. Call it when
  /// the run's outputs may be written (after its inputs loaded). Throws OutputError.
  void openLog();
  ~OnlinePerception();

  /// The first terrain: closed_loop.warmup_scans from the plant's current (ground-truth) sensor
  /// pose, fused at the pose of the given base pose, and the cells under the robot filled from its
  /// wheels' ground contacts. Throws std::runtime_error naming the status when no terrain comes
  /// out. Scans then continue every 1 / rate from the plant's time.
  void start(const Plant& plant, const Eigen::Vector3d& base_position,
             const Eigen::Quaterniond& base_orientation);
  /// Where new terrains go from now on (after start(); once). Asynchronous timing: starts
  /// the worker thread, which owns the map from then on.
  void connect(TerrainSink sink);
  /// True when a scan is due at time t (the LiDAR's rate).
  bool due(double t) const { return started_ && t >= next_scan_ - 1e-9; }
  /// One scan at time t (rays from the plant's true sensor pose), fused at the sensor pose
  /// of the given base pose (the controller's). Deterministic: fused, segmented and handed
  /// to the sink here; true if it built a new terrain. Asynchronous: posted to the worker
  /// (no allocation, lock or wait), false; throws the worker's error if it failed.
  bool step(double t, const Plant& plant, const Eigen::Vector3d& base_position,
            const Eigen::Quaterniond& base_orientation);
  /// Asynchronous: processes the scan still waiting, stops the worker and rethrows its
  /// error, if any. Call it before reading counters(), terrain() or the map after a run.
  /// Idempotent; nothing to do in deterministic timing.
  void stop();
  bool asynchronous() const { return options_.asynchronous; }

  /// The last valid terrain (unshrunk, levelled), and its count of updates (1: start()).
  /// Asynchronous timing: only in the sink or after stop().
  const planning::TerrainModel& terrain() const { return terrain_; }
  std::uint64_t terrainCount() const { return counters_.terrains; }
  /// The foothold regions of terrain(): shrunk by `margin` [m] except along the seams
  /// between pieces of one surface (planning::shrinkTerrain, probed closed_loop.
  /// seam_probe_cells map cells beyond each edge, heights within seam_height_tolerance).
  planning::TerrainModel footholdTerrain(double margin) const;
  perception::PerceptionStatus lastStatus() const { return perception_.lastStatus(); }
  /// Asynchronous timing: complete after stop().
  const OnlinePerceptionCounters& counters() const { return counters_; }
  const perception::TerrainPerception& perception() const { return perception_; }
  const Lidar& lidar() const { return lidar_; }

  /// Map log: true when a snapshot is due at t (after the scan that made it due).
  bool logDue(double t) const;
  /// Writes a snapshot at t: the map, `regions` (the controller's foothold regions in use),
  /// `footholds` (3 x n world points, the controller's planned footholds) and the base
  /// pose. Throws OutputError.
  void writeSnapshot(double t, const planning::TerrainModel& regions,
                     const Eigen::Matrix3Xd& footholds, const Eigen::Vector3d& base_position,
                     double base_yaw);
  /// Commits the map log's CSV files (throws OutputError); without it (a run that failed)
  /// they are discarded.
  void closeLog();
  int snapshots() const { return snapshots_; }

 private:
  planning::TerrainModel levelTerrain() const;
  /// After an update (either thread): the counters, the levelled terrain and the sink.
  bool handle(perception::PerceptionStatus status);

  OnlinePerceptionOptions options_;
  Lidar lidar_;
  perception::TerrainPerception perception_;
  OnlinePerceptionCounters counters_;
  planning::TerrainModel terrain_;
  std::vector<Eigen::Vector3d> blind_;  // a scan of NaN points (blind_from .. blind_until)
  TerrainSink sink_;
  std::unique_ptr<perception::PerceptionWorker> worker_;  // asynchronous timing
  bool started_ = false;
  double next_scan_ = 0.0, period_ = 0.1;
  // Map log.
  std::unique_ptr<AtomicFileWriter> maps_, regions_, footholds_;
  int snapshots_ = 0;
  double next_log_ = 0.0;
  bool scanned_since_log_ = false;
};

}  // namespace rollstep::sim
