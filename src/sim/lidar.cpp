#include "rollstep/sim/lidar.hpp"

#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>

#include "rollstep/common/number_text.hpp"
#include "rollstep/common/settings_table.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/common/yaml_tree.hpp"

namespace rollstep::sim {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

void require(bool ok, const char* name, double value, const char* what) {
  if (!ok) {
    throw std::invalid_argument(std::string("lidar: ") + name + " = " + shortestNumberText(value) +
                                ": " + what);
  }
}

}  // namespace

void LidarSettings::validate() const {
  for (int i = 0; i < 3; ++i) {
    require(std::isfinite(mount_position[i]) && std::abs(mount_position[i]) <= 10, "mount_position",
            mount_position[i], "must be finite, within 10 m of the base");
  }
  require(std::isfinite(mount_pitch_deg) && std::abs(mount_pitch_deg) <= 90, "mount_pitch_deg",
          mount_pitch_deg, "must be in [-90, 90]");
  require(beams >= 1 && beams <= 256, "beams", beams, "must be 1 to 256");
  require(std::isfinite(min_elevation_deg) && min_elevation_deg >= -90, "min_elevation_deg",
          min_elevation_deg, "must be >= -90");
  require(std::isfinite(max_elevation_deg) && max_elevation_deg <= 90 &&
              max_elevation_deg >= min_elevation_deg,
          "max_elevation_deg", max_elevation_deg, "must be in [min_elevation_deg, 90]");
  require(std::isfinite(horizontal_fov_deg) && horizontal_fov_deg > 0 && horizontal_fov_deg <= 360,
          "horizontal_fov_deg", horizontal_fov_deg, "must be in (0, 360]");
  require(std::isfinite(horizontal_resolution_deg) && horizontal_resolution_deg >= 0.05 &&
              horizontal_resolution_deg <= horizontal_fov_deg,
          "horizontal_resolution_deg", horizontal_resolution_deg,
          "must be in [0.05, horizontal_fov_deg]");
  require(std::isfinite(rate) && rate > 0 && rate <= 1000, "rate", rate, "must be in (0, 1000] Hz");
  require(std::isfinite(max_range) && max_range > 0 && max_range <= 1000, "max_range", max_range,
          "must be in (0, 1000] m");
  require(std::isfinite(range_noise) && range_noise >= 0 && range_noise <= 1, "range_noise",
          range_noise, "must be in [0, 1] m");
  require(std::isfinite(dropout) && dropout >= 0 && dropout <= 1, "dropout", dropout,
          "must be in [0, 1]");
  require(seed >= 0, "seed", seed, "must be >= 0");
}

int LidarSettings::columns() const {
  return std::max(1, static_cast<int>(std::lround(horizontal_fov_deg / horizontal_resolution_deg)));
}

namespace {

// The keys, in config/lidar.yaml's order (ranges: validate(), which names the key; the
// table refuses what is not a finite number).
const settings::Table<LidarSettings>& lidarTable() {
  using S = LidarSettings;
  static const settings::Table<S> table =
      settings::Table<S>()
          .field("mount_position", &S::mount_position, "m")
          .field("mount_pitch_deg", &S::mount_pitch_deg, "deg")
          .field("beams", &S::beams)
          .field("min_elevation_deg", &S::min_elevation_deg, "deg")
          .field("max_elevation_deg", &S::max_elevation_deg, "deg")
          .field("horizontal_fov_deg", &S::horizontal_fov_deg, "deg")
          .field("horizontal_resolution_deg", &S::horizontal_resolution_deg, "deg")
          .field("rate", &S::rate, "Hz")
          .field("max_range", &S::max_range, "m")
          .field("range_noise", &S::range_noise, "m")
          .field("dropout", &S::dropout)
          .field("seed", &S::seed);
  return table;
}

}  // namespace

LidarSettings parseLidarSettings(std::string_view text, const std::string& source) {
  const std::string head = "lidar settings '" + source + "': ";
  const yaml::Document doc = yaml::parseDocument(text, head);
  LidarSettings s;
  settings::Reader reader(head);
  lidarTable().read(doc.root(), s, reader);
  try {
    s.validate();
  } catch (const std::invalid_argument& e) {
    // what: "lidar: <key> = <value>: <problem>", reported at the key's line.
    const std::string named = std::string(e.what()).substr(std::string(e.what()).find(": ") + 2);
    const settings::Reader::Seen* seen = reader.seen(named.substr(0, named.find(" = ")));
    if (seen != nullptr) reader.failAtLine(seen->line, named);
    throw std::runtime_error(head + named);
  }
  return s;
}

std::string toYaml(const LidarSettings& settings) { return lidarTable().write(settings); }

LidarSettings loadLidarSettings(const std::string& path) {
  return parseLidarSettings(readTextFile(path, "lidar settings", std::size_t{1} << 20), path);
}

Lidar::Lidar(const LidarSettings& settings)
    : settings_(settings),
      rng_(static_cast<std::mt19937::result_type>(settings.seed)),
      noise_(0.0, 1.0) {
  settings_.validate();
  mount_ = Eigen::Isometry3d::Identity();
  mount_.translation() = settings_.mount_position;
  mount_.linear() = Eigen::AngleAxisd(settings_.mount_pitch_deg * kDeg, Eigen::Vector3d::UnitY())
                        .toRotationMatrix();
  const int cols = settings_.columns();
  const double fov = settings_.horizontal_fov_deg * kDeg;
  for (int c = 0; c < cols; ++c) {
    const double az =
        (settings_.horizontal_fov_deg >= 360.0 ? -0.5 * fov + fov * c / cols
                                               : -0.5 * fov + fov * c / std::max(1, cols - 1));
    for (int b = 0; b < settings_.beams; ++b) {
      const double el =
          (settings_.beams == 1 ? settings_.min_elevation_deg
                                : settings_.min_elevation_deg +
                                      (settings_.max_elevation_deg - settings_.min_elevation_deg) *
                                          b / (settings_.beams - 1)) *
          kDeg;
      directions_.emplace_back(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                               std::sin(el));
    }
  }
  points_.assign(directions_.size(), Eigen::Vector3d::Zero());
}

Eigen::Isometry3d Lidar::sensorPose(const Eigen::Vector3d& base_position,
                                    const Eigen::Quaterniond& base_orientation) const {
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translation() = base_position;
  base.linear() = base_orientation.normalized().toRotationMatrix();
  return base * mount_;
}

const std::vector<Eigen::Vector3d>& Lidar::scan(const Plant& plant) {
  const GroundTruth& truth = plant.groundTruth();
  return scanFrom(plant, truth.base_position, truth.base_orientation);
}

const std::vector<Eigen::Vector3d>& Lidar::scanFrom(const Plant& plant,
                                                    const Eigen::Vector3d& base_position,
                                                    const Eigen::Quaterniond& base_orientation) {
  pose_ = sensorPose(base_position, base_orientation);
  const Eigen::Matrix3d R = pose_.linear();
  const Eigen::Vector3d origin = pose_.translation();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  hits_ = 0;
  for (std::size_t i = 0; i < directions_.size(); ++i) {
    const double d = plant.raycast(origin, R * directions_[i], settings_.max_range);
    // Both drawn for every ray: the stream does not depend on what was hit.
    const double drop = uniform_(rng_), dn = settings_.range_noise * noise_(rng_);
    if (d < 0 || drop < settings_.dropout) {
      points_[i] = Eigen::Vector3d::Constant(nan);
      continue;
    }
    points_[i] = (d + dn) * directions_[i];
    ++hits_;
  }
  return points_;
}

}  // namespace rollstep::sim
