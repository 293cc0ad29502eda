#include "rollstep/sim/sensor_model.hpp"

#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "rollstep/common/number_text.hpp"
#include "rollstep/common/settings_table.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/sim/plant.hpp"

namespace rollstep::sim {

namespace {

// The keys, in config/sensors.yaml's order, with their ranges.
const settings::Table<SensorNoiseConfig>& sensorTable() {
  using S = SensorNoiseConfig;
  using settings::Range;
  constexpr double kBig = 1e6;
  using T = settings::Table<S>;
  static const T table =
      T().field("seed", &S::seed, "", Range::closed(0.0, 9007199254740992.0))
          .group("imu", T().field("gyro_noise_density", &S::gyro_noise_density, "rad/s/sqrt(Hz)",
                                  Range::closed(0.0, 1.0))
                            .field("gyro_bias_random_walk", &S::gyro_bias_random_walk,
                                   "rad/s^2/sqrt(Hz)", Range::closed(0.0, 1.0))
                            .field("gyro_initial_bias", &S::gyro_initial_bias, "rad/s",
                                   Range::closed(0.0, 1.0))
                            .field("accel_noise_density", &S::accel_noise_density, "m/s^2/sqrt(Hz)",
                                   Range::closed(0.0, 10.0))
                            .field("accel_bias_random_walk", &S::accel_bias_random_walk,
                                   "m/s^3/sqrt(Hz)", Range::closed(0.0, 10.0))
                            .field("accel_initial_bias", &S::accel_initial_bias, "m/s^2",
                                   Range::closed(0.0, 10.0)))
          .group(
              "encoders",
              T().field("hip_resolution", &S::hip_resolution, "rad", Range::closed(0.0, 0.1))
                  .field("knee_resolution", &S::knee_resolution, "m", Range::closed(0.0, 0.01))
                  .field("joint_position_noise", &S::joint_position_noise, "rad or m",
                         Range::closed(0.0, 0.1))
                  .field("joint_velocity_noise", &S::joint_velocity_noise, "rad/s or m/s",
                         Range::closed(0.0, 10.0))
                  .field("wheel_resolution", &S::wheel_resolution, "rad", Range::closed(0.0, 1.0))
                  .field("wheel_velocity_noise", &S::wheel_velocity_noise, "rad/s",
                         Range::closed(0.0, 10.0)))
          .group("contact_flags",
                 T().field("force_threshold", &S::force_threshold, "N", Range::closed(0.0, kBig))
                     .field("force_noise", &S::force_noise, "N", Range::closed(0.0, kBig)));
  return table;
}

double quantise(double x, double resolution) {
  return resolution > 0.0 ? resolution * std::round(x / resolution) : x;
}

}  // namespace

std::string SensorNoiseConfig::toYaml() const { return sensorTable().write(*this); }

SensorNoiseConfig parseSensorNoiseConfig(const std::string& yaml_text, const std::string& source) {
  const SensorNoiseConfig c =
      settings::readDocument(yaml_text, sensorTable(), "sensor config '" + source + "': ");
  if (c.seed != std::floor(c.seed)) {
    throw std::runtime_error("sensor config '" + source +
                             "': seed: must be a non-negative integer, found " +
                             shortestNumberText(c.seed));
  }
  return c;
}

SensorNoiseConfig loadSensorNoiseConfig(const std::string& yaml_file) {
  return parseSensorNoiseConfig(readTextFile(yaml_file, "sensor config", std::size_t{1} << 20),
                                yaml_file);
}

SensorModel::SensorModel(const SensorNoiseConfig& config, double dt, const PlantLayout& layout)
    : config_(config), dt_(dt), num_wheels_(layout.numDriveWheels()) {
  for (const PlantLayout::Leg& leg : layout.legs) leg_joints_.push_back(leg.joints);
  for (const PlantLayout::Joint& joint : layout.joints) {
    joint_resolution_.push_back(joint.prismatic ? config.knee_resolution : config.hip_resolution);
  }
  if (!std::isfinite(dt) || !(dt > 0.0)) {
    throw std::invalid_argument("SensorModel: dt = " + shortestNumberText(dt) +
                                " s must be positive and finite");
  }
  reset();
}

void SensorModel::reset() {
  rng_.seed(static_cast<std::uint64_t>(config_.seed));
  normal_.reset();
  for (int i = 0; i < 3; ++i) gyro_bias_[i] = config_.gyro_initial_bias * gauss();
  for (int i = 0; i < 3; ++i) accel_bias_[i] = config_.accel_initial_bias * gauss();
}

void SensorModel::apply(SensorReadings& r) noexcept {
  const SensorNoiseConfig& c = config_;
  const double white = 1.0 / std::sqrt(dt_);  // density -> per-sample std dev
  const double walk = std::sqrt(dt_);         // random-walk density -> per-sample step
  for (int i = 0; i < 3; ++i) {
    gyro_bias_[i] += c.gyro_bias_random_walk * walk * gauss();
    accel_bias_[i] += c.accel_bias_random_walk * walk * gauss();
    r.imu_angular_velocity[i] += gyro_bias_[i] + c.gyro_noise_density * white * gauss();
    r.imu_acceleration[i] += accel_bias_[i] + c.accel_noise_density * white * gauss();
  }
  // Per leg: its joints' positions, then their velocities, then its contact flag.
  for (std::size_t leg = 0; leg < leg_joints_.size(); ++leg) {
    for (const int j : leg_joints_[leg]) {
      r.joint_position[j] = quantise(r.joint_position[j] + c.joint_position_noise * gauss(),
                                     joint_resolution_[static_cast<std::size_t>(j)]);
    }
    for (const int j : leg_joints_[leg]) r.joint_velocity[j] += c.joint_velocity_noise * gauss();
    const double force = r.foot_normal_force[leg] + c.force_noise * gauss();
    r.foot_contact[leg] = force > c.force_threshold;
  }
  for (int w = 0; w < num_wheels_; ++w) {
    r.wheel_position[w] = quantise(r.wheel_position[w], c.wheel_resolution);
    r.wheel_velocity[w] += c.wheel_velocity_noise * gauss();
  }
}

}  // namespace rollstep::sim
