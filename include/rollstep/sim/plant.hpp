#pragma once
// The MuJoCo plant: a robot's MJCF (robots/<name>/<name>.xml) in a scene, stepped at the
// control rate (1 kHz), driven by joint position targets and drive-wheel velocity targets,
// read through its sensors and through ground truth.
//
// The robot's layout (PlantLayout) comes from the MJCF and the robot description's contact
// frames, never from names in the code:
//  - Legs in the order of the description's contact_frames; each contact frame is the MJCF
//    body of the leg's wheel. A leg's name is its contact frame's without a trailing
//    "_wheel" (LF_wheel -> LF).
//  - Joint vectors: per leg, the hinge and slide joints from the base down to the wheel
//    body (not the wheel's own joint), in the tree's order; hinges in rad, slides in m.
//  - Drive wheels: the legs whose contact frame is in the description's drive_wheels, in
//    leg order; each wheel body has one hinge (the axle), angles in rad, positive = rolls
//    the robot forward (+x).
//  - Actuators and sensors are found by what they act on: one actuator per joint and drive
//    wheel, a jointpos and a jointvel sensor of each, a touch sensor on a site of each wheel
//    body, one accelerometer, one gyro and one framequat sensor (the IMU).
//  - Quaternions are Eigen::Quaterniond, rotating body-frame vectors into the world.
//
// Threading: a Plant is not thread-safe; one thread steps it.
// Memory: everything is allocated at construction; step(), setCommand(), sensors(),
// groundTruth() and raycast() do not allocate.
#include <Eigen/Core>
#include <Eigen/Geometry>
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

using JointVector = Eigen::VectorXd;  ///< one entry per plant joint (PlantLayout::joints)
using WheelVector = Eigen::VectorXd;  ///< one entry per drive wheel
using FootFlags = std::vector<bool>;  ///< one entry per leg

/// The legs, joints and drive wheels of the plant's robot, in the plant's order.
struct PlantLayout {
  struct Joint {
    std::string name;        ///< the MJCF (and URDF) joint name
    bool prismatic = false;  ///< slide joint [m]; else hinge [rad]
    int leg = -1;
  };
  struct Leg {
    std::string name;           ///< for logs: the contact frame without "_wheel"
    std::string contact_frame;  ///< the wheel body
    std::vector<int> joints;    ///< plant joint indices, base to wheel
    int drive_wheel = -1;       ///< index among the drive wheels, -1: not driven
  };
  std::vector<Joint> joints;
  std::vector<Leg> legs;
  std::vector<int> drive_wheel_legs;  ///< leg of each drive wheel

  int numJoints() const { return static_cast<int>(joints.size()); }
  int numLegs() const { return static_cast<int>(legs.size()); }
  int numDriveWheels() const { return static_cast<int>(drive_wheel_legs.size()); }
  /// Plant index of the joint named `name`, -1 if none.
  int jointIndex(const std::string& name) const;
  /// Leg whose contact frame is `frame`, -1 if none.
  int legOfContactFrame(const std::string& frame) const;
  /// "m" for a prismatic joint, "rad" for a revolute one.
  const char* jointUnit(int joint) const {
    return joints[static_cast<std::size_t>(joint)].prismatic ? "m" : "rad";
  }
};

/// Leg name of a contact frame: the frame without a trailing "_wheel".
std::string legNameOfContactFrame(const std::string& frame);

/// Error loading or running the plant; the message names the file and the problem.
class SimError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Targets of the actuators (sized by the plant: copy Plant::nominalCommand()). Values
/// outside the actuator ranges are clamped by MuJoCo.
struct PlantCommand {
  JointVector joint_position;  ///< joint targets [rad or m]
  WheelVector wheel_velocity;  ///< drive wheels [rad/s]
};

/// What the robot's own sensors report. Sampled at the start of the last physics step
/// (one physics step, 1 ms, old), like a sampled sensor.
struct SensorReadings {
  JointVector joint_position;  ///< encoders
  JointVector joint_velocity;
  WheelVector wheel_position;
  WheelVector wheel_velocity;
  /// IMU at the base centre, IMU (= base) frame: specific force [m/s^2] (reads +g up
  /// when at rest) and angular velocity [rad/s]; orientation as a fused IMU would give.
  Eigen::Vector3d imu_acceleration = Eigen::Vector3d::Zero();
  Eigen::Vector3d imu_angular_velocity = Eigen::Vector3d::Zero();
  Eigen::Quaterniond imu_orientation = Eigen::Quaterniond::Identity();
  /// Foot contact sensors: summed normal force [N] at each wheel and the flag
  /// force > PlantOptions::contact_threshold.
  std::vector<double> foot_normal_force;
  FootFlags foot_contact;

  /// Sized for `layout`, all zero.
  void resize(const PlantLayout& layout);
};

/// The simulator's exact state, for tests, logs and estimator-free controllers.
struct GroundTruth {
  double time = 0.0;                                                     ///< [s]
  Eigen::Vector3d base_position = Eigen::Vector3d::Zero();               ///< world [m]
  Eigen::Quaterniond base_orientation = Eigen::Quaterniond::Identity();  ///< base->world
  Eigen::Vector3d base_linear_velocity = Eigen::Vector3d::Zero();        ///< WORLD frame
  Eigen::Vector3d base_angular_velocity = Eigen::Vector3d::Zero();       ///< LOCAL (base)
  JointVector joint_position;
  JointVector joint_velocity;
  WheelVector wheel_position;
  WheelVector wheel_velocity;
  std::vector<Eigen::Vector3d> wheel_center;  ///< per leg, world [m]
  /// Per wheel: in contact with anything, and the total contact force the
  /// environment exerts on the wheel, world frame [N] (sum over its contacts).
  FootFlags foot_contact;
  std::vector<Eigen::Vector3d> foot_force;
  /// Per wheel: where the environment pushes it, world [m]: the mean of its contact points
  /// weighted by their normal forces (an edge strike shows at the edge); the wheel centre
  /// when it touches nothing.
  std::vector<Eigen::Vector3d> contact_point;
  /// A robot geom other than a wheel (base, hip, shank) touches the terrain now.
  bool body_contact = false;
  /// Control periods since reset() that ended with body_contact (the experiments' pass
  /// criterion "the body never touched the terrain" reads it from the log: a touch between
  /// two log rows still shows as an increase).
  long body_contact_periods = 0;

  /// Sized for `layout`, all zero.
  void resize(const PlantLayout& layout);
};

struct PlantOptions {
  /// Robot MJCF; empty = defaultRobotFile().
  std::string robot_file;
  /// The robot description's contact_frames (the wheel bodies of the MJCF, one per leg) and
  /// drive_wheels (centroidal.yaml); empty contact_frames = those of the default robot's
  /// description (defaultRobotDescriptionFile()).
  std::vector<std::string> contact_frames;
  std::vector<std::string> drive_wheels;
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

/// The robots folder: $ROLLSTEP_ROBOTS_DIR if that environment variable is set, else the
/// source tree's robots/ folder.
std::string robotsDirectory();
/// The default robot's MJCF and description (robotsDirectory()/tachyon3/).
std::string defaultRobotFile();
std::string defaultRobotDescriptionFile();

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
  /// The robot's legs, joints and drive wheels.
  const PlantLayout& layout() const { return layout_; }
  /// Radius [m] of a leg's wheel geom.
  double wheelRadius(int leg) const { return wheel_radius_[static_cast<std::size_t>(leg)]; }
  /// Largest wheel speed [rad/s] every drive wheel servo can be commanded (the smallest
  /// bound of their ctrlrange; infinity if unlimited). Faster commands are clamped.
  double wheelSpeedLimit() const { return wheel_speed_limit_; }
  /// Origin of a leg's first joint in the base frame at the nominal posture [m].
  const Eigen::Vector3d& hipPosition(int leg) const {
    return hip_position_[static_cast<std::size_t>(leg)];
  }
  double totalMass() const { return total_mass_; }
  /// Largest world x [m] of the robot's geoms at the nominal posture with the base at
  /// x = 0.
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

  PlantLayout layout_;
  std::vector<std::string> contact_frames_, drive_wheels_;
  // Indices resolved once at load.
  std::vector<int> joint_qpos_, joint_qvel_, joint_ctrl_;
  std::vector<int> sensor_jpos_, sensor_jvel_;
  std::vector<int> wheel_qpos_, wheel_qvel_, wheel_ctrl_;
  std::vector<int> sensor_wpos_, sensor_wvel_;
  std::vector<int> wheel_body_, wheel_geom_, sensor_touch_;
  std::vector<double> wheel_radius_;
  std::vector<Eigen::Vector3d> hip_position_;
  int base_body_ = -1;
  int sensor_acc_ = -1, sensor_gyro_ = -1, sensor_quat_ = -1;
  int base_qpos_ = 0, base_qvel_ = 0;
  std::vector<int> geom_leg_;           // geom id -> leg index whose wheel it is, or -1
  std::vector<double> contact_weight_;  // per leg: summed normal force of its contact points
};

}  // namespace rollstep::sim
