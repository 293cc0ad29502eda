#include "rollstep/sim/sensor_model.hpp"

#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "rollstep/common/number_text.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/common/yaml_sections.hpp"
#include "rollstep/sim/plant.hpp"

namespace rollstep::sim {

namespace {

std::vector<yaml::NumberSection> sectionsOf(SensorNoiseConfig& c) {
  constexpr double kBig = 1e6;
  return {
      {"", {{"seed", &c.seed, 0.0, 9007199254740992.0}}},
      {"imu",
       {{"gyro_noise_density", &c.gyro_noise_density, 0.0, 1.0},
        {"gyro_bias_random_walk", &c.gyro_bias_random_walk, 0.0, 1.0},
        {"gyro_initial_bias", &c.gyro_initial_bias, 0.0, 1.0},
        {"accel_noise_density", &c.accel_noise_density, 0.0, 10.0},
        {"accel_bias_random_walk", &c.accel_bias_random_walk, 0.0, 10.0},
        {"accel_initial_bias", &c.accel_initial_bias, 0.0, 10.0}}},
      {"encoders",
       {{"hip_resolution", &c.hip_resolution, 0.0, 0.1},
        {"knee_resolution", &c.knee_resolution, 0.0, 0.01},
        {"joint_position_noise", &c.joint_position_noise, 0.0, 0.1},
        {"joint_velocity_noise", &c.joint_velocity_noise, 0.0, 10.0},
        {"wheel_resolution", &c.wheel_resolution, 0.0, 1.0},
        {"wheel_velocity_noise", &c.wheel_velocity_noise, 0.0, 10.0}}},
      {"contact_flags",
       {{"force_threshold", &c.force_threshold, 0.0, kBig},
        {"force_noise", &c.force_noise, 0.0, kBig}}},
  };
}

double quantise(double x, double resolution) {
  return resolution > 0.0 ? resolution * std::round(x / resolution) : x;
}

}  // namespace

std::string SensorNoiseConfig::toYaml() const {
  SensorNoiseConfig copy = *this;
  std::string out;
  for (const yaml::NumberSection& s : sectionsOf(copy)) {
    const bool top = s.key[0] == '\0';
    if (!top) out += std::string(s.key) + ":\n";
    for (const yaml::NumberField& f : s.fields) {
      out += (top ? "" : "  ") + std::string(f.key) + ": " + shortestNumberText(*f.value) + "\n";
    }
  }
  return out;
}

SensorNoiseConfig parseSensorNoiseConfig(const std::string& yaml_text, const std::string& source) {
  SensorNoiseConfig c;
  yaml::readNumberSections(yaml_text, "sensor config '" + source + "'", sectionsOf(c));
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
