#include "rollstep/sim/lidar.hpp"

#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>

#include "rollstep/common/number_text.hpp"
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

LidarSettings parseLidarSettings(std::string_view text, const std::string& source) {
  const std::string head = "lidar settings '" + source + "': ";
  const auto fail = [&](const yaml::Node& node, const std::string& what) {
    throw std::runtime_error(head + "line " + std::to_string(node.line()) + ": " + what);
  };
  yaml::Document doc = yaml::parseDocument(text, head);
  LidarSettings s;
  const yaml::Node root = doc.root();
  if (root.isNull()) return s;
  if (!root.isMapping()) fail(root, std::string("expected a mapping, got ") + root.kindName());
  struct Key {
    const char* name;
    double* number;
    int* integer;
  };
  const Key keys[] = {
      {"mount_pitch_deg", &s.mount_pitch_deg, nullptr},
      {"beams", nullptr, &s.beams},
      {"min_elevation_deg", &s.min_elevation_deg, nullptr},
      {"max_elevation_deg", &s.max_elevation_deg, nullptr},
      {"horizontal_fov_deg", &s.horizontal_fov_deg, nullptr},
      {"horizontal_resolution_deg", &s.horizontal_resolution_deg, nullptr},
      {"rate", &s.rate, nullptr},
      {"max_range", &s.max_range, nullptr},
      {"range_noise", &s.range_noise, nullptr},
      {"dropout", &s.dropout, nullptr},
      {"seed", nullptr, &s.seed},
  };
  const std::string known =
      "mount_position, mount_pitch_deg, beams, min_elevation_deg, max_elevation_deg, "
      "horizontal_fov_deg, horizontal_resolution_deg, rate, max_range, range_noise, dropout, seed";
  std::map<std::string, int> lines;
  for (std::size_t item = 0; item < root.size(); ++item) {
    const yaml::Node key = root.key(item), value = root.value(item);
    const std::string k = key.isScalar() ? key.scalar() : std::string("<key>");
    if (const auto it = lines.find(k); it != lines.end()) {
      fail(key, k + ": given twice (first on line " + std::to_string(it->second) + ")");
    }
    lines.emplace(k, key.line());
    const std::string got = value.isScalar() ? "'" + value.scalar() + "'" : value.kindName();
    if (k == "mount_position") {
      if (!value.isSequence() || value.size() != 3) {
        fail(value, k + ": expected a list of 3 numbers [x, y, z], got " + got);
      }
      for (std::size_t i = 0; i < 3; ++i) {
        double v = 0;
        if (!value.item(i).toDouble(v)) fail(value.item(i), k + ": expected a number");
        s.mount_position[static_cast<Eigen::Index>(i)] = v;
      }
      continue;
    }
    const Key* found = nullptr;
    for (const Key& c : keys) {
      if (k == c.name) found = &c;
    }
    if (found == nullptr) fail(key, "unknown key '" + k + "' (known: " + known + ")");
    if (found->number != nullptr) {
      if (!value.isScalar() || !value.toDouble(*found->number) || !std::isfinite(*found->number)) {
        fail(value, k + ": expected a finite number, got " + got);
      }
    } else if (!value.isScalar() || !value.toInt(*found->integer)) {
      fail(value, k + ": expected an integer, got " + got);
    }
  }
  try {
    s.validate();
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    int line = 0;
    for (const auto& [k, l] : lines) {
      if (what.find(": " + k + " = ") != std::string::npos) line = l;
    }
    throw std::runtime_error(head + (line > 0 ? "line " + std::to_string(line) + ": " : "") +
                             what.substr(what.find(": ") + 2));
  }
  return s;
}

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
