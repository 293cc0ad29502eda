#include "rollstep/sim/online_perception.hpp"

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <system_error>

namespace rollstep::sim {

namespace {

/// The .npy bytes (format version 1.0) of a row-major float32 n x n array.
std::string npyFloatSquare(const std::vector<float>& values, int n) {
  std::string header = "{'descr': '<f4', 'fortran_order': False, 'shape': (" + std::to_string(n) +
                       ", " + std::to_string(n) + "), }";
  // Magic (6) + version (2) + length (2) + header + '\n', padded to a multiple of 64.
  const std::size_t unpadded = 10 + header.size() + 1;
  header.append((64 - unpadded % 64) % 64, ' ');
  header += '\n';
  std::string out("\x93NUMPY\x01\x00", 8);
  out += static_cast<char>(header.size() & 0xff);
  out += static_cast<char>((header.size() >> 8) & 0xff);
  out += header;
  // Little-endian float32 (the machines we build for are little-endian; checked below).
  static_assert(sizeof(float) == 4, "float32");
  const std::uint32_t probe = 1;
  if (*reinterpret_cast<const unsigned char*>(&probe) != 1) {
    throw std::runtime_error("map log: a big-endian machine is not supported");
  }
  out.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(float));
  return out;
}

}  // namespace

OnlinePerception::OnlinePerception(const OnlinePerceptionOptions& options)
    : options_(options), lidar_(options.lidar), perception_([&] {
        perception::PerceptionSettings s = options.perception;
        s.regions.margin = 0.0;
        return s;
      }()) {
  if (!options_.log_dir.empty() && options_.asynchronous) {
    throw std::invalid_argument(
        "--log-map needs deterministic perception timing (the map belongs to the perception "
        "thread in asynchronous runs)");
  }
  if (!options_.log_dir.empty() && !(options_.log_rate > 0.0 && options_.log_rate <= 100.0)) {
    throw std::invalid_argument("--log-map-rate " + std::to_string(options_.log_rate) +
                                ": must be in (0, 100] snapshots per second");
  }
  period_ = 1.0 / options_.lidar.rate;
  blind_.assign(static_cast<std::size_t>(options_.lidar.beams * options_.lidar.columns()),
                Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
}

void OnlinePerception::openLog() {
  if (options_.log_dir.empty() || maps_ != nullptr) return;
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(options_.log_dir, ec);
  if (ec || !fs::is_directory(options_.log_dir)) {
    throw OutputError("--log-map '" + options_.log_dir + "': cannot create the directory" +
                      (ec ? ": " + ec.message() : std::string()));
  }
  // Files of an earlier run would mix with this one's: its snapshots and its index (should
  // this run fail, the index of the earlier one would otherwise sit beside these snapshots).
  std::vector<fs::path> earlier;
  for (const auto& entry : fs::directory_iterator(options_.log_dir, ec)) {
    const std::string name = entry.path().filename().string();
    // ... and the temporaries of one that was killed (SIGKILL: it could not clean up).
    const bool stale = name.find(".tmp.") != std::string::npos &&
                       (name.rfind(".maps.csv", 0) == 0 || name.rfind(".regions.csv", 0) == 0 ||
                        name.rfind(".footholds.csv", 0) == 0 || name.rfind(".heights_", 0) == 0);
    if ((name.rfind("heights_", 0) == 0 && entry.path().extension() == ".npy") ||
        name == "maps.csv" || name == "regions.csv" || name == "footholds.csv" || stale) {
      earlier.push_back(entry.path());
    }
  }
  for (const fs::path& p : earlier) {
    fs::remove(p, ec);
    if (ec) {
      throw OutputError("--log-map: cannot remove the earlier run's '" + p.string() +
                        "': " + ec.message());
    }
  }
  const fs::path dir(options_.log_dir);
  maps_ = std::make_unique<AtomicFileWriter>((dir / "maps.csv").string());
  regions_ = std::make_unique<AtomicFileWriter>((dir / "regions.csv").string());
  footholds_ = std::make_unique<AtomicFileWriter>((dir / "footholds.csv").string());
  maps_->write(
      "snapshot[-],time[s],status,terrain_count[-],regions[-],origin_x[m],origin_y[m],"
      "resolution[m],size[-],base_x[m],base_y[m],base_yaw[rad],heights_file\n");
  regions_->write("snapshot[-],region[-],vertex[-],x[m],y[m],z[m]\n");
  footholds_->write("snapshot[-],foot[-],x[m],y[m],z[m]\n");
}

OnlinePerception::~OnlinePerception() {
  try {
    stop();
  } catch (...) {
    // The worker's error was the run's to report (stop()); a destructor must not throw.
  }
}

void OnlinePerception::connect(TerrainSink sink) {
  if (!started_) throw std::logic_error("OnlinePerception::connect: call start() first");
  if (sink_ || worker_) throw std::logic_error("OnlinePerception::connect: connected already");
  sink_ = std::move(sink);
  if (options_.asynchronous) {
    worker_ = std::make_unique<perception::PerceptionWorker>(
        perception_, static_cast<int>(blind_.size()),
        [this](const perception::TerrainPerception&, perception::PerceptionStatus status, double) {
          handle(status);
        });
  }
}

void OnlinePerception::stop() {
  if (worker_ == nullptr) return;
  const auto merge = [this] {
    const perception::PerceptionWorkerCounters w = worker_->counters();
    counters_.superseded = w.superseded;
    counters_.max_update_ms = w.max_update_ms;
    counters_.total_update_ms = w.total_update_ms;
  };
  try {
    worker_->stop();
  } catch (...) {
    merge();
    throw;
  }
  merge();
}

void OnlinePerception::start(const Plant& plant, const Eigen::Vector3d& base_position,
                             const Eigen::Quaterniond& base_orientation) {
  const double t0 = plant.time();
  const perception::ClosedLoopSettings& cl = perception_.settings().closed_loop;
  for (int k = 0; k < cl.warmup_scans; ++k) {
    const std::vector<Eigen::Vector3d>& points = lidar_.scan(plant);
    perception_.map().moveTo(
        lidar_.sensorPose(base_position, base_orientation).translation().head<2>());
    perception_.map().update(points, lidar_.sensorPose(base_position, base_orientation));
  }
  // Under the robot and in the LiDAR's blind zone the sensor sees nothing: the wheels'
  // ground contacts fill them.
  const int legs = plant.layout().numLegs();
  std::vector<Eigen::Vector3d> contacts(static_cast<std::size_t>(legs));
  for (int leg = 0; leg < legs; ++leg) {
    contacts[static_cast<std::size_t>(leg)] =
        plant.groundTruth().wheel_center[static_cast<std::size_t>(leg)] -
        plant.wheelRadius(leg) * Eigen::Vector3d::UnitZ();
  }
  perception_.fillStartArea(contacts.data(), legs,
                            lidar_.sensorPose(base_position, base_orientation).translation());
  const perception::PerceptionStatus status = perception_.rebuild();
  if (!perception_.hasTerrain()) {
    throw std::runtime_error(std::string("perception: no terrain from the LiDAR at the start "
                                         "pose: ") +
                             perception::toString(status));
  }
  terrain_ = levelTerrain();
  counters_.terrains = 1;
  started_ = true;
  next_scan_ = t0 + period_;
  next_log_ = t0;
  scanned_since_log_ = true;
}

bool OnlinePerception::step(double t, const Plant& plant, const Eigen::Vector3d& base_position,
                            const Eigen::Quaterniond& base_orientation) {
  if (!started_) return false;
  // The next scan a period on (more than one behind: the grid point after t).
  next_scan_ += period_;
  if (next_scan_ <= t) next_scan_ = t + period_;
  ++counters_.scans;
  const bool blind = t >= options_.blind_from && t < options_.blind_until;
  const std::vector<Eigen::Vector3d>& points = blind ? blind_ : lidar_.scan(plant);
  const Eigen::Isometry3d pose = lidar_.sensorPose(base_position, base_orientation);
  if (worker_ != nullptr) {
    // The scan has the LiDAR's fixed size, which the worker's frames hold: post() refuses
    // only after a failure, which stop() reports.
    if (!worker_->post(points, pose, t)) stop();
    return false;
  }
  scanned_since_log_ = true;
  const auto start = std::chrono::steady_clock::now();
  const perception::PerceptionStatus status = perception_.update(points, pose, t);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  counters_.max_update_ms = std::max(counters_.max_update_ms, ms);
  counters_.total_update_ms += ms;
  return handle(status);
}

bool OnlinePerception::handle(perception::PerceptionStatus status) {
  switch (status) {
    case perception::PerceptionStatus::Ok:
      ++counters_.terrains;
      terrain_ = levelTerrain();
      if (sink_) ++(sink_(*this) ? counters_.handed_over : counters_.refused);
      return true;
    case perception::PerceptionStatus::NoPoints:
      ++counters_.no_points;
      break;
    case perception::PerceptionStatus::NonFinite:
      ++counters_.non_finite;
      break;
    case perception::PerceptionStatus::InvalidPose:
      ++counters_.invalid_pose;
      break;
    case perception::PerceptionStatus::NoPlanarRegion:
      ++counters_.no_planar_region;
      break;
  }
  ++counters_.kept;
  return false;
}

planning::TerrainModel OnlinePerception::levelTerrain() const {
  const perception::ClosedLoopSettings& cl = perception_.settings().closed_loop;
  return planning::levelTerrain(perception_.terrain(), cl.level_max_tilt_deg * M_PI / 180.0,
                                cl.level_height_tolerance);
}

planning::TerrainModel OnlinePerception::footholdTerrain(double margin) const {
  const perception::ClosedLoopSettings& cl = perception_.settings().closed_loop;
  return planning::shrinkTerrain(terrain_, margin,
                                 cl.seam_probe_cells * perception_.map().resolution(),
                                 cl.seam_height_tolerance);
}

bool OnlinePerception::logDue(double t) const {
  return maps_ != nullptr && started_ && scanned_since_log_ && t >= next_log_ - 1e-9;
}

void OnlinePerception::writeSnapshot(double t, const planning::TerrainModel& regions,
                                     const Eigen::Matrix3Xd& footholds,
                                     const Eigen::Vector3d& base_position, double base_yaw) {
  if (maps_ == nullptr) return;
  const int k = snapshots_++;
  next_log_ = std::max(next_log_ + 1.0 / options_.log_rate, t + 0.5 / options_.log_rate);
  scanned_since_log_ = false;
  char name[64];
  std::snprintf(name, sizeof name, "heights_%04d.npy", k);
  const perception::ElevationMap& map = perception_.map();
  writeFileAtomically((std::filesystem::path(options_.log_dir) / name).string(),
                      npyFloatSquare(map.heights(), map.size()));
  const planning::TerrainModel& terrain = regions;
  maps_->printf("%d,%.4f,%s,%llu,%d,%.4f,%.4f,%.4f,%d,%.4f,%.4f,%.5f,%s\n", k, t,
                perception::toString(perception_.lastStatus()),
                static_cast<unsigned long long>(counters_.terrains), terrain.size(),
                map.origin().x(), map.origin().y(), map.resolution(), map.size(), base_position.x(),
                base_position.y(), base_yaw, name);
  for (int r = 0; r < terrain.size(); ++r) {
    const planning::ConvexRegion& region = terrain.region(r);
    for (std::size_t v = 0; v < region.vertices.size(); ++v) {
      const Eigen::Vector2d& p = region.vertices[v];
      regions_->printf("%d,%d,%zu,%.4f,%.4f,%.4f\n", k, r, v, p.x(), p.y(), region.heightAt(p));
    }
  }
  for (Eigen::Index i = 0; i < footholds.cols(); ++i) {
    footholds_->printf("%d,%lld,%.4f,%.4f,%.4f\n", k, static_cast<long long>(i), footholds(0, i),
                       footholds(1, i), footholds(2, i));
  }
}

void OnlinePerception::closeLog() {
  if (maps_ == nullptr || maps_->committed()) return;
  maps_->commit();
  regions_->commit();
  footholds_->commit();
}

}  // namespace rollstep::sim
