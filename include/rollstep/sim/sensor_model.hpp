#pragma once
// The robot's sensors as a real robot has them: the plant's ideal readings (MuJoCo's
// sensors, sampled every control period, 1 kHz) corrupted by a seeded noise model.
//
//  - IMU (accelerometer, gyroscope; base frame): white noise of a density [unit/sqrt(Hz)]
//    (per-sample standard deviation density / sqrt(dt)) plus a bias that starts at a
//    random value (initial_bias standard deviation per axis) and walks (random walk
//    density [unit/s/sqrt(Hz)], per-sample increment rw * sqrt(dt)).
//  - Joint encoders: quantised to a resolution (revolute joints: hip_resolution [rad],
//    prismatic joints: knee_resolution [m]) after white noise;
//    joint velocities (the drives' own estimate) with white noise.
//  - Drive-wheel encoders: angle quantised to a resolution, speed with white noise.
//  - Contact flags: the summed normal force plus white noise compared with a threshold:
//    near the threshold the flag chatters, as a force sensor's does.
//  - The AHRS orientation of SensorReadings is left as the plant gives it (the state
//    estimator does not read it).
// Every number lives in a YAML file (robots/tachyon3/sensors.yaml documents each with its
// default); the seed makes runs reproducible. Allocation-free after construction.
#include <Eigen/Core>
#include <random>
#include <string>
#include <vector>

namespace rollstep::sim {

struct SensorReadings;  // plant.hpp
struct PlantLayout;     // plant.hpp

struct SensorNoiseConfig {
  double seed = 1.0;  ///< integer seed of the noise generator (YAML `seed`)
  // imu:
  double gyro_noise_density = 2.4e-4;      ///< [rad/s/sqrt(Hz)]
  double gyro_bias_random_walk = 2.0e-5;   ///< [rad/s^2/sqrt(Hz)]
  double gyro_initial_bias = 0.005;        ///< [rad/s] std dev per axis
  double accel_noise_density = 2.0e-3;     ///< [m/s^2/sqrt(Hz)]
  double accel_bias_random_walk = 3.0e-4;  ///< [m/s^3/sqrt(Hz)]
  double accel_initial_bias = 0.05;        ///< [m/s^2] std dev per axis
  // encoders:
  /// [rad] revolute joints (16-bit turn)
  double hip_resolution = 2.0 * 3.14159265358979323846 / 65536.0;
  double knee_resolution = 1.0e-5;     ///< [m] prismatic joints
  double joint_position_noise = 0.0;   ///< [rad or m] std dev before quantisation
  double joint_velocity_noise = 0.01;  ///< [rad/s or m/s] std dev
  double wheel_resolution = 2.0 * 3.14159265358979323846 / 4096.0;  ///< [rad]
  double wheel_velocity_noise = 0.02;                               ///< [rad/s] std dev
  // contact_flags:
  double force_threshold = 15.0;  ///< [N]
  double force_noise = 4.0;       ///< [N] std dev of the force the flag compares

  /// The sections of the YAML file, each key bound to this config's member.
  std::string toYaml() const;
};

/// Reads a sensor YAML file (sections imu, encoders, contact_flags, and `seed`; keys as
/// the members above): absent keys keep their defaults; errors (std::runtime_error) name
/// the file, line and key (unknown or repeated key, not a number, out of range, a seed
/// that is not a non-negative integer).
SensorNoiseConfig loadSensorNoiseConfig(const std::string& yaml_file);
SensorNoiseConfig parseSensorNoiseConfig(const std::string& yaml_text, const std::string& source);

class SensorModel {
 public:
  /// For the plant's `layout` (its joints' kinds, legs and drive wheels). Throws
  /// std::invalid_argument if dt is not positive and finite.
  SensorModel(const SensorNoiseConfig& config, double dt, const PlantLayout& layout);
  /// Back to the seed's first draw (new initial biases drawn from it).
  void reset();
  /// Corrupts ideal readings in place (one sample). Never allocates or throws.
  void apply(SensorReadings& readings) noexcept;

  /// The current true biases (for tests and logs only).
  const Eigen::Vector3d& gyroBias() const { return gyro_bias_; }
  const Eigen::Vector3d& accelBias() const { return accel_bias_; }
  const SensorNoiseConfig& config() const { return config_; }

 private:
  double gauss() noexcept { return normal_(rng_); }
  SensorNoiseConfig config_;
  double dt_;
  std::vector<std::vector<int>> leg_joints_;  // plant joint indices of each leg
  std::vector<double> joint_resolution_;      // per plant joint
  int num_wheels_ = 0;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_;
  Eigen::Vector3d gyro_bias_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias_ = Eigen::Vector3d::Zero();
};

}  // namespace rollstep::sim
