#pragma once
// A simulation run as data: the robot, the scene, the controller and its inputs, the
// terrain and state sources, the sensors and the outputs. `rollstep sim` turns its options
// into one (or reads one with --spec FILE) and writes the one it ran to DIR/run.yaml;
// `rollstep report` and `rollstep trials` hand their child runs a spec file; the Python
// Simulation builds its run from one (buildRun, run.hpp).
//
// The YAML keys are the members' names; every key has its documented default
// (runSpecDefaults()), unknown keys are errors, and a file gives only what differs:
//
//   scene: step20
//   controller: nmpc
//   duration: 8
//   gait: trot
//   command: [[0, 0.15, 0, 0]]     # [time s, vx m/s, vy m/s, yaw rate rad/s] from time on
//   mpc_timing: deterministic
//   scene_parameters:              # the scene's numbers for this run
//     step1_height: 0.15
//   control:                       # the control settings inline (else control_config)
//     mpc: {period: 0.02}
#include <array>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "rollstep/common/enum_names.hpp"
#include "rollstep/control/control_settings.hpp"
#include "rollstep/planning/base_reference.hpp"
#include "rollstep/planning/gait.hpp"
#include "rollstep/sim/nmpc_controller.hpp"
#include "rollstep/sim/scene.hpp"

namespace rollstep::sim {

/// stand: hold the nominal posture; drive: hold it and roll on the drive wheels; nmpc: the
/// control pipeline (NMPC + CBF-QP + state integrator); cbfqp: the CBF-QP baseline.
enum class ControllerKind { Stand, Drive, Nmpc, CbfQp };
constexpr std::array<EnumName<ControllerKind>, 4> enumNames(ControllerKind) {
  return {{{ControllerKind::Stand, "stand"},
           {ControllerKind::Drive, "drive"},
           {ControllerKind::Nmpc, "nmpc"},
           {ControllerKind::CbfQp, "cbfqp"}}};
}

/// Where the controller's foothold regions come from: the scene's ground truth, or
/// perception in closed loop (the simulated LiDAR, the elevation map, its segmentation).
enum class TerrainSource { Scene, Perception };
constexpr std::array<EnumName<TerrainSource>, 2> enumNames(TerrainSource) {
  return {{{TerrainSource::Scene, "scene"}, {TerrainSource::Perception, "perception"}}};
}

/// A timing given by the run, or `default`: the control settings' (MPC), the MPC's timing
/// for the NMPC's perception and deterministic for the baseline's.
enum class TimingChoice { Default, Deterministic, Asynchronous };
constexpr std::array<EnumName<TimingChoice>, 3> enumNames(TimingChoice) {
  return {{{TimingChoice::Default, "default"},
           {TimingChoice::Deterministic, "deterministic"},
           {TimingChoice::Asynchronous, "asynchronous"}}};
}

/// The NMPC's state integrator given by the run, or `default`: the control settings'.
enum class IntegratorChoice { Default, Internal, Naive };
constexpr std::array<EnumName<IntegratorChoice>, 3> enumNames(IntegratorChoice) {
  return {{{IntegratorChoice::Default, "default"},
           {IntegratorChoice::Internal, "internal"},
           {IntegratorChoice::Naive, "naive"}}};
}

/// A number of the scene set by a run (RunSpec::scene_parameters).
struct SceneNumberValue {
  std::string name;  ///< a parameter, friction or a key path
  double value = 0.0;
  bool operator==(const SceneNumberValue& o) const { return name == o.name && value == o.value; }
};

/// One run. Paths: "" is the default named beside each; in a spec file a relative path is
/// relative to the file's folder (a robot or scene given by name is a name).
struct RunSpec {
  /// A robot name (robots/NAME) or a robot folder (a path with a '/'); "" = tachyon3.
  std::string robot;
  /// A scene name (config/scenes/NAME.yaml) or a scene file (a path with a '/' or ending
  /// in .yaml).
  std::string scene = "flat";
  /// A scene file run instead of `scene` (the two exclude each other); "" = none.
  std::string scene_file;
  /// The scene itself instead of a file (scene_file: the two exclude each other), `scene`
  /// then only its name: a mapping of a scene file's keys (base: excepted). A run given its
  /// scene in code (the Python Simulation) writes it here whole, so that its run.yaml runs
  /// it again. None (null): the scene's file.
  std::optional<SceneConfig> inline_scene;
  /// Numbers of the scene set for this run, in order: each a parameter the scene declares
  /// (its `parameters:`), its friction, or a number's key path (boxes[0].size[2]; see
  /// sim::setSceneNumber). Randomized trials give the numbers they draw here.
  std::vector<SceneNumberValue> scene_parameters;
  ControllerKind controller = ControllerKind::Stand;
  double duration = 10.0;  ///< [s] simulated time
  /// nmpc, cbfqp: the gait (cbfqp: standing, rolling or trot).
  planning::GaitKind gait = planning::GaitKind::Standing;
  /// nmpc, cbfqp: the base velocity command, each entry from its time on (the first at 0,
  /// times increasing and before the end; cbfqp: one entry). Base frame: vx, vy [m/s],
  /// yaw rate [rad/s].
  std::vector<planning::TimedBaseCommand> command{{0.0, {0.0, 0.0, 0.0}}};
  /// drive: forward wheel surface speed [m/s] (ramped at 1 m/s^2) and the right minus
  /// left surface speed, halved [m/s].
  double drive_speed = 0.5;
  double drive_turn_speed = 0.0;
  /// nmpc, cbfqp: control settings file; "" = the robot folder's nmpc.yaml
  /// (nmpc_perception.yaml on perception) or baseline.yaml, else the project's default
  /// (the library's defaults; config/nmpc_perception.yaml; config/baseline.yaml).
  std::string control_config;
  /// nmpc, cbfqp: the control settings themselves instead of a file (control_config; the
  /// two exclude each other): a mapping of a control settings file's keys
  /// (config/control.yaml) over the library's defaults, `extends:` relative to the spec
  /// file's folder. A run given its settings in code (the Python Simulation) writes them
  /// here whole, so that its run.yaml runs it again. None (null): control_config.
  std::optional<control::ControlSettings> control;
  TimingChoice mpc_timing = TimingChoice::Default;          ///< nmpc only
  IntegratorChoice integrator = IntegratorChoice::Default;  ///< nmpc only
  TerrainSource terrain = TerrainSource::Scene;             ///< nmpc, cbfqp
  /// terrain perception only: LiDAR settings file ("" = the robot folder's lidar.yaml,
  /// else the built-in defaults), perception settings file ("" = the defaults), timing.
  std::string lidar_config;
  std::string perception_config;
  TimingChoice perception_timing = TimingChoice::Default;
  StateSourceKind state_source = StateSourceKind::GroundTruth;  ///< nmpc only
  /// state_source inekf only: the estimator's tuning ("" = the robot folder's).
  std::string estimator_config;
  /// The plant's sensor noise file; "" = ideal sensors, or with state_source inekf the
  /// robot folder's sensors.yaml (the defaults if it has none).
  std::string sensor_config;
  /// Outputs: the folder of log.csv, summary.txt, run.yaml (mpc.csv, plan.csv.gz, ... for
  /// nmpc); a log row every log_every control periods.
  std::string out = "out/sim";
  int log_every = 10;
  /// terrain perception only: the map log's folder ("" = none) and its snapshot rate [Hz].
  std::string map_log;
  double map_log_rate = 2.0;
  /// nmpc, deterministic MPC timing: DIR/mpc_violations.csv (slow; for analysis).
  bool log_violations = false;

  bool operator==(const RunSpec& other) const;
  bool operator!=(const RunSpec& other) const { return !(*this == other); }
};

/// A run spec that is not valid: `key` (its YAML key) and what is wrong.
class RunSpecError : public std::invalid_argument {
 public:
  RunSpecError(std::string key, const std::string& what)
      : std::invalid_argument(key + ": " + what), key_(std::move(key)), what_(what) {}
  const std::string& key() const { return key_; }
  /// The problem without the key.
  const std::string& problem() const { return what_; }

 private:
  std::string key_;
  std::string what_;
};

/// Checks a spec made in code: each value in its range, and the keys that only apply to
/// some controllers or terrains left at their defaults elsewhere. Throws RunSpecError.
void checkRunSpec(const RunSpec& spec);

/// Reads a spec file (strict: unknown or repeated keys, wrong types, values out of range
/// and the checks of checkRunSpec). Errors: std::runtime_error
/// "run spec '<file>': line L: <key>: <problem>".
RunSpec loadRunSpec(const std::string& file);
/// Same, from text, over `base` (the keys the text gives replace its values); relative
/// paths resolved against `base_dir` ("" = kept as they are).
RunSpec parseRunSpec(const std::string& text, const std::string& source,
                     const std::string& base_dir = "", const RunSpec& base = RunSpec{});
/// Every key with its value; parseRunSpec reads it back equal.
std::string toYaml(const RunSpec& spec);
/// The spec with every path made absolute (against the working directory): a file that
/// reads the same from any folder.
RunSpec withAbsolutePaths(const RunSpec& spec);
/// Every key with its default, unit and range (for documentation).
std::string runSpecDefaults();

/// The scene of the run: its scene or scene_file loaded, with its scene_parameters set.
/// Throws RunSpecError("scene_parameters", ...) naming a number the scene does not have
/// (and the ones it has) or a value its checks refuse, std::invalid_argument or
/// std::runtime_error for a scene that cannot be loaded.
SceneConfig sceneOf(const RunSpec& spec);
/// `scene` with the numbers of `values` set (the same errors as sceneOf).
SceneConfig withSceneNumbers(SceneConfig scene, const std::vector<SceneNumberValue>& values);

}  // namespace rollstep::sim
