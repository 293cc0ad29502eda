#pragma once
// The MuJoCo plant: the Tachyon 3 MJCF (robots/tachyon3/tachyon3.xml) in a scene,
// stepped at the control rate (1 kHz), driven by hip/knee position targets and
// drive-wheel velocity targets, read through its sensors and through ground truth.
//
// Conventions used by the whole project:
//  - Legs in the URDF order: LF, MF, RF, LR, MR, RR (kLegNames, leg index 0..5).
//  - Joint vectors (12) in URDF depth-first order, per leg:
//      LF_hip, LF_knee, MF_hip, MF_knee, RF_hip, RF_knee, LR_hip, LR_knee,
//      MR_hip, MR_knee, RR_hip, RR_knee.
//    Hips in rad (positive about base +y), knees in m (positive = leg extends down).
//  - Drive wheels (4) in the order LF, RF, LR, RR (kDriveWheelLegs); wheel angles in
//    rad about the axle (+y of the shank), positive = rolls the robot forward (+x).
//  - Quaternions are Eigen::Quaterniond, rotating body-frame vectors into the world.
//
// Threading: a Plant is not thread-safe; one thread steps it.
// Memory: everything is allocated at construction; step(), setCommand(), sensors(),
// groundTruth() and raycast() do not allocate.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "rollstep/sim/scene.hpp"
#include "rollstep/sim/sensor_model.hpp"

struct mjModel_;
struct mjData_;

namespace rollstep::sim {

inline constexpr int kNumLegs = 6;
inline constexpr int kNumJoints = 12;
inline constexpr int kNumDriveWheels = 4;
inline constexpr std::array<const char*, kNumLegs> kLegNames{"LF", "MF", "RF", "LR", "MR", "RR"};
/// Leg index of each drive wheel (LF, RF, LR, RR).
inline constexpr std::array<int, kNumDriveWheels> kDriveWheelLegs{0, 2, 3, 5};
/// Index of a leg's hip / knee in a joint vector.
constexpr int hipIndex(int leg) { return 2 * leg; }
constexpr int kneeIndex(int leg) { return 2 * leg + 1; }

using JointVector = Eigen::Matrix<double, kNumJoints, 1>;
using WheelVector = Eigen::Matrix<double, kNumDriveWheels, 1>;
using FootFlags = std::array<bool, kNumLegs>;

/// Error loading or running the plant; the message names the file and the problem.
class SimError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Targets of the actuators. Values outside the actuator ranges are clamped by MuJoCo
/// (hips/knees to the joint range, wheels to +-25 rad/s).
struct PlantCommand {
  JointVector joint_position = JointVector::Zero();  ///< hip [rad] / knee [m] targets
  WheelVector wheel_velocity = WheelVector::Zero();  ///< drive wheels [rad/s]
};

/// What the robot's own sensors report. Sampled at the start of the last physics step
/// (one physics step, 1 ms, old), like a sampled sensor.
struct SensorReadings {
  JointVector joint_position = JointVector::Zero();  ///< encoders
  JointVector joint_velocity = JointVector::Zero();
  WheelVector wheel_position = WheelVector::Zero();
  WheelVector wheel_velocity = WheelVector::Zero();
  /// IMU at the base centre, IMU (= base) frame: specific force [m/s^2] (reads +g up
  /// when at rest) and angular velocity [rad/s]; orientation as a fused IMU would give.
  Eigen::Vector3d imu_acceleration = Eigen::Vector3d::Zero();
  Eigen::Vector3d imu_angular_velocity = Eigen::Vector3d::Zero();
  Eigen::Quaterniond imu_orientation = Eigen::Quaterniond::Identity();
  /// Foot contact sensors: summed normal force [N] at each wheel and the flag
  /// force > PlantOptions::contact_threshold.
  std::array<double, kNumLegs> foot_normal_force{};
  FootFlags foot_contact{};
};

/// The simulator's exact state, for tests, logs and estimator-free controllers.
struct GroundTruth {
  double time = 0.0;                                                     ///< [s]
  Eigen::Vector3d base_position = Eigen::Vector3d::Zero();               ///< world [m]
  Eigen::Quaterniond base_orientation = Eigen::Quaterniond::Identity();  ///< base->world
  Eigen::Vector3d base_linear_velocity = Eigen::Vector3d::Zero();        ///< WORLD frame
  Eigen::Vector3d base_angular_velocity = Eigen::Vector3d::Zero();       ///< LOCAL (base)
  JointVector joint_position = JointVector::Zero();
  JointVector joint_velocity = JointVector::Zero();
  WheelVector wheel_position = WheelVector::Zero();
  WheelVector wheel_velocity = WheelVector::Zero();
  std::array<Eigen::Vector3d, kNumLegs> wheel_center{};  ///< world [m]
  /// Per wheel: in contact with anything, and the total contact force the
  /// environment exerts on the wheel, world frame [N] (sum over its contacts).
  FootFlags foot_contact{};
  std::array<Eigen::Vector3d, kNumLegs> foot_force{};
  /// A robot geom other than a wheel (base, hip, shank) touches the terrain now.
  bool body_contact = false;
  /// Control periods since reset() that ended with body_contact (the experiments' pass
  /// criterion "the body never touched the terrain" reads it from the log: a touch between
  /// two log rows still shows as an increase).
  long body_contact_periods = 0;
};

struct PlantOptions {
  /// Robot MJCF; empty = defaultRobotFile().
  std::string robot_file;
  /// The text of the robot MJCF, if not empty: used instead of reading robot_file, which
  /// then only names it in messages and gives the directory of its relative paths.
  std::string robot_xml;
  /// Control period [s]: one step() advances this much time, in physics steps of the
  /// model's timestep (must divide it).
  double control_period = 0.001;
  /// Touch sensor threshold [N] for SensorReadings::foot_contact.
  double contact_threshold = 1.0;
  /// Sensor noise (sensor_model.hpp): unset = the ideal readings above; set = sensors()
  /// are corrupted by a SensorModel seeded by it (reset() restarts its draws).
  std::optional<SensorNoiseConfig> sensor_noise;
};

/// The Tachyon 3 MJCF shipped with the project: $ROLLSTEP_ROBOTS_DIR/tachyon3/tachyon3.xml
/// if that environment variable is set, else the source tree's robots/ folder.
std::string defaultRobotFile();

class Plant {
 public:
  /// Loads the robot into the scene and resets to the nominal posture. The scene is an
  /// MJCF that <include>s the robot file (parsed by MuJoCo as XML, never edited as
  /// text) and adds the terrain in its own <worldbody>.
  /// Throws SimError naming the file and the problem if the robot file is missing, not
  /// a regular file, malformed (MuJoCo's message), or lacks an element the plant needs
  /// or has it of the wrong kind (joints, actuators, sensors, wheel geoms, keyframe
  /// "nominal"); if a scene parameter is invalid; if the first block is not clear of
  /// the robot's front (a box or ramp within minStartX() of the start, solidAtStart); or
  /// if an option is not finite.
  /// MuJoCo's virtual file system finds files by name without directories: a robot file
  /// that includes a file of its own name from another directory is refused ("already
  /// included").
  explicit Plant(const SceneConfig& scene, const PlantOptions& options = {});
  ~Plant();
  Plant(const Plant&) = delete;
  Plant& operator=(const Plant&) = delete;

  /// Back to time 0, at rest in the nominal posture (keyframe "nominal" of the MJCF),
  /// base at (x, y) facing `yaw` [rad], wheels touching flat ground at z = 0 (or
  /// `lift` [m] above it), commands = nominal.
  /// Throws std::invalid_argument if an argument is not finite.
  void reset(double x = 0.0, double y = 0.0, double yaw = 0.0, double lift = 0.0);

  /// Throws std::invalid_argument, naming the entry and keeping the previous command, if
  /// a target is NaN or infinite (MuJoCo would silently zero every control).
  void setCommand(const PlantCommand& command);
  const PlantCommand& command() const { return command_; }

  /// Advances one control period, then updates sensors() and groundTruth(). Throws
  /// SimError if the simulation diverges (MuJoCo then resets the state; reset() before
  /// stepping again).
  void step();

  double time() const;
  const SensorReadings& sensors() const { return sensors_; }
  const GroundTruth& groundTruth() const { return truth_; }
  /// The sensor noise model, or null when the readings are ideal (for tests and logs:
  /// its true biases).
  const SensorModel* sensorModel() const { return sensor_model_.get(); }

  /// Distance [m] along the unit direction `direction` from `origin` (world) to the
  /// first terrain surface (robot geoms are ignored), or -1 if nothing is hit within
  /// max_range.
  double raycast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                 double max_range) const;

  /// Nominal posture (hips/knees) and zero wheel speeds, from the MJCF keyframe.
  const PlantCommand& nominalCommand() const { return nominal_command_; }
  /// Radius [m] of a leg's wheel geom.
  double wheelRadius(int leg) const { return wheel_radius_[static_cast<std::size_t>(leg)]; }
  /// Largest wheel speed [rad/s] every drive wheel servo can be commanded (the smallest
  /// bound of their ctrlrange; infinity if unlimited). Faster commands are clamped.
  double wheelSpeedLimit() const { return wheel_speed_limit_; }
  /// Hip joint origin of a leg in the base frame [m].
  const Eigen::Vector3d& hipPosition(int leg) const {
    return hip_position_[static_cast<std::size_t>(leg)];
  }
  double totalMass() const { return total_mass_; }
  /// Largest world x [m] of the robot's geoms at the nominal posture with the base at
  /// x = 0 (the front of its wheels for Tachyon 3).
  double frontExtent() const { return front_extent_; }
  /// Clearance [m] between the robot's front and the first block, at the least.
  static constexpr double kStartClearance = 0.05;
  /// Smallest valid SceneConfig::start_x [m] for this robot: frontExtent() +
  /// kStartClearance (the robot starts clear of the first block).
  double minStartX() const { return front_extent_ + kStartClearance; }
  const SceneConfig& scene() const { return scene_; }
  const std::string& robotFile() const { return robot_file_; }
  double controlPeriod() const { return control_period_; }
  int physicsStepsPerControl() const { return substeps_; }
  /// Number of MuJoCo warnings (bad accelerations, contact buffer full, ...) since
  /// reset; a healthy run has 0.
  int warningCount() const;

  /// Raw MuJoCo access for tests and tools (do not change the model structure).
  const mjModel_* mujocoModel() const { return model_; }
  mjData_* mujocoData() { return data_; }
  const mjData_* mujocoData() const { return data_; }

 private:
  void updateReadings();
  void checkStructure();          // resolves and checks the indices below
  void checkStartPosition();      // sets front_extent_, checks the scene's start_x
  std::string sceneName() const;  // "step20 of scene config 'FILE'" for messages

  SceneConfig scene_;
  std::string robot_file_;
  double control_period_;
  double contact_threshold_;
  int substeps_ = 1;
  mjModel_* model_ = nullptr;
  mjData_* data_ = nullptr;
  PlantCommand command_;
  PlantCommand nominal_command_;
  SensorReadings sensors_;
  std::unique_ptr<SensorModel> sensor_model_;
  GroundTruth truth_;
  double total_mass_ = 0.0;
  double front_extent_ = 0.0;
  double wheel_speed_limit_ = 0.0;
  int key_nominal_ = -1;

  // Indices resolved once at load.
  std::array<int, kNumJoints> joint_qpos_{}, joint_qvel_{}, joint_ctrl_{};
  std::array<int, kNumJoints> sensor_jpos_{}, sensor_jvel_{};
  std::array<int, kNumDriveWheels> wheel_qpos_{}, wheel_qvel_{}, wheel_ctrl_{};
  std::array<int, kNumDriveWheels> sensor_wpos_{}, sensor_wvel_{};
  std::array<int, kNumLegs> wheel_body_{}, wheel_geom_{}, sensor_touch_{};
  std::array<double, kNumLegs> wheel_radius_{};
  std::array<Eigen::Vector3d, kNumLegs> hip_position_{};
  int sensor_acc_ = -1, sensor_gyro_ = -1, sensor_quat_ = -1;
  int base_qpos_ = 0, base_qvel_ = 0;
  std::vector<int> geom_leg_;  // geom id -> leg index whose wheel it is, or -1
};

}  // namespace rollstep::sim
