#include "sim_options.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "cli_util.hpp"
#include "rollstep/common/enum_names.hpp"
#include "rollstep/sim/scene.hpp"

namespace rollstep::apps {

/// Parses --command "T:VX[:VY[:YAW]],...".
std::vector<planning::TimedBaseCommand> parseCommandSchedule(const std::string& text,
                                                             double duration) {
  const auto fail = [&](const std::string& what) -> std::vector<planning::TimedBaseCommand> {
    throw CLI::ValidationError("--command", "'" + text + "': " + what +
                                                " (expected T:VX[:VY[:YAW_RATE]],... with T in "
                                                "s from 0, increasing)");
  };
  std::vector<planning::TimedBaseCommand> out;
  std::stringstream entries(text);
  std::string entry;
  while (std::getline(entries, entry, ',')) {
    if (entry.empty() || entry.front() == ':' || entry.back() == ':' ||
        entry.find("::") != std::string::npos) {
      return fail("entry '" + entry + "' has an empty number");
    }
    std::vector<double> v;
    std::stringstream fields(entry);
    std::string field;
    while (std::getline(fields, field, ':')) {
      double x = 0.0;
      bool non_finite = false;
      if (!parseDecimal(field, x, non_finite) || non_finite) {
        return fail("'" + field + "' is not a finite decimal number");
      }
      v.push_back(x);
    }
    if (v.size() < 2 || v.size() > 4) return fail("entry '" + entry + "' needs 2 to 4 numbers");
    v.resize(4, 0.0);
    const std::size_t k = out.size();
    if (k == 0 && v[0] != 0.0) return fail("the first time must be 0");
    if (k > 0 && !(v[0] > out.back().time)) return fail("times must increase");
    if (v[0] > 3600.0) return fail("time " + numberText(v[0]) + " s beyond 3600 s");
    if (k > 0 && v[0] >= duration) {
      return fail("time " + numberText(v[0]) + " s is not before the run's end (--duration " +
                  numberText(duration) + " s): the entry would never apply");
    }
    if (std::abs(v[1]) > 1.0) return fail("vx " + numberText(v[1]) + " outside [-1, 1] m/s");
    if (std::abs(v[2]) > 0.5) return fail("vy " + numberText(v[2]) + " outside [-0.5, 0.5] m/s");
    if (std::abs(v[3]) > 1.0) {
      return fail("yaw rate " + numberText(v[3]) + " outside [-1, 1] rad/s");
    }
    out.push_back({v[0], {v[1], v[2], v[3]}});
  }
  if (out.empty() || text.back() == ',') return fail("empty entry");
  return out;
}

SimOptionSet::SimOptionSet(CLI::App& cmd, SimOptions& options) : o_(&options), cmd_(&cmd) {
  addSceneOptions(cmd);
  addCommandOptions(cmd);
  addTerrainOptions(cmd);
  addStateOptions(cmd);
  addRunOptions(cmd);
  constant_command_ = {pipeline_only_[1], pipeline_only_[2], pipeline_only_[3]};
  log_map_ = perception_only_[2];
  log_map_rate_ = perception_only_[4];
}

/// The scene and the controller (and the help's footer).
void SimOptionSet::addSceneOptions(CLI::App& cmd) {
  cmd.footer(
      "Numbers must be finite and within the ranges shown; --speed and --turn-speed only "
      "apply to --controller drive; --gait, --vx, --vy, --yaw-rate and --control-config "
      "only to --controller nmpc and cbfqp; --mpc-timing and "
      "--integrator only to --controller nmpc.\n"
      "Outputs: DIR/log.csv and DIR/summary.txt appear only complete and only when the run "
      "succeeds; a run that fails once started removes the previous run's files and leaves "
      "DIR/FAILED with the error. Exit status: 0 on success, non-zero on any error.\n"
      "Example scene file: config/scenes/step20_custom.yaml");
  CLI::Option* scene =
      cmd.add_option("--scene", o_->scene,
                     "Scene: a name (" + sim::sceneNamesText() + ": the files NAME.yaml of " +
                         sim::scenesDirectory() +
                         ") or a scene file (a path with a '/' or ending in .yaml)")
          ->capture_default_str();
  CLI::Option* scene_config =
      cmd.add_option("--scene-config", o_->scene_config,
                     "Scene file (boxes, ramps, friction and parameters; docs/USER_GUIDE.md "
                     "\"Scenes\"), e.g. config/scenes/step20_custom.yaml")
          ->check(kNotEmpty);
  scene->excludes(scene_config);
  cmd.add_option("--controller", o_->controller,
                 "stand: hold the nominal posture; drive: hold it and roll on the four "
                 "drive wheels at --speed (turning with --turn-speed); nmpc: the control "
                 "pipeline (NMPC + CBF-QP + internal state integrator) on the ground-truth "
                 "state, with --gait and the base velocity command --vx, --vy, --yaw-rate; "
                 "cbfqp: the CBF-QP baseline (the paper's previous controller, a reactive "
                 "planner and the CBF-QP without MPC) with the same options")
      ->check(CLI::IsMember({"stand", "drive", "nmpc", "cbfqp"}))
      ->capture_default_str();
}

/// What nmpc and cbfqp are given: gait, command, control settings, MPC timing.
void SimOptionSet::addCommandOptions(CLI::App& cmd) {
  pipeline_only_.push_back(
      cmd.add_option("--gait", o_->gait,
                     "nmpc, cbfqp only: standing, rolling, trot or static_walk (cbfqp: "
                     "standing, rolling or trot)")
          ->check(CLI::IsMember({"standing", "rolling", "trot", "static_walk"}))
          ->capture_default_str());
  pipeline_only_.push_back(
      cmd.add_option("--vx", o_->vx,
                     "nmpc, cbfqp only: forward base velocity command [m/s] (base frame)")
          ->check(numberIn(-1.0, 1.0, "m/s"))
          ->capture_default_str());
  pipeline_only_.push_back(
      cmd.add_option("--vy", o_->vy,
                     "nmpc, cbfqp only: lateral base velocity command [m/s] (base frame)")
          ->check(numberIn(-0.5, 0.5, "m/s"))
          ->capture_default_str());
  pipeline_only_.push_back(
      cmd.add_option("--yaw-rate", o_->yaw_rate, "nmpc, cbfqp only: yaw rate command [rad/s]")
          ->check(numberIn(-1.0, 1.0, "rad/s"))
          ->capture_default_str());
  command_ =
      cmd.add_option("--command", o_->command_schedule,
                     "nmpc only: a base velocity command schedule instead of the constant "
                     "--vx/--vy/--yaw-rate: T:VX[:VY[:YAW_RATE]],... each from T s on (the "
                     "first T 0, increasing; speeds in the ranges of --vx, --vy, --yaw-rate), "
                     "e.g. 0:0.15,32:-0.15 goes forward, then back")
          ->check(kNotEmpty);
  nmpc_only_.push_back(command_);
  pipeline_only_.push_back(
      cmd.add_option("--control-config", o_->control_config,
                     "nmpc, cbfqp only: YAML control settings (config/control.yaml lists every "
                     "key and its default; the OCP's and the solver's keys nest in it). nmpc "
                     "default: those defaults (with --terrain perception "
                     "config/nmpc_perception.yaml over them): walks and climbs steps at any "
                     "speed, the trot timed for the command; cbfqp default: "
                     "config/baseline.yaml (the baseline's tuning); $ROLLSTEP_CONFIG_DIR/... "
                     "if set; a robot folder holding nmpc.yaml, nmpc_perception.yaml or "
                     "baseline.yaml gives its own default")
          ->check(kNotEmpty));
  // Folded into --robot: a clear error instead of "unknown option" for old command lines.
  old_description_ =
      cmd.add_option("--robot-description", o_->robot_description,
                     "Replaced by --robot NAME_OR_DIR (the robot folder holds the description)");
  nmpc_only_.push_back(cmd.add_option("--mpc-timing", o_->mpc_timing,
                                      "nmpc only: deterministic (a solve every MPC period of "
                                      "simulated time, reproducible) or asynchronous (a real "
                                      "MPC thread); default: the control settings'")
                           ->check(CLI::IsMember({"deterministic", "asynchronous"})));
  nmpc_only_.push_back(cmd.add_flag("--log-violations", o_->log_violations,
                                    "nmpc only, deterministic MPC timing: check every MPC "
                                    "solution against the problem it solved and write the "
                                    "largest violation of each constraint group and its node "
                                    "to DIR/mpc_violations.csv (slow; for analysis)"));
}

/// The terrain source and perception's settings and map log.
void SimOptionSet::addTerrainOptions(CLI::App& cmd) {
  CLI::Option* terrain_option =
      cmd.add_option("--terrain", o_->terrain,
                     "nmpc, cbfqp only: scene (the scene's ground-truth regions) or perception "
                     "(perception in closed loop: the simulated LiDAR scans at its rate, each "
                     "scan is fused at the base pose the controller runs on and gives a new "
                     "terrain; a scan with a bad status keeps the last one)")
          ->check(CLI::IsMember({"scene", "perception"}))
          ->capture_default_str();
  pipeline_only_.push_back(terrain_option);
  perception_only_.push_back(
      cmd.add_option("--lidar-config", o_->lidar_config,
                     "--terrain perception only: YAML LiDAR settings (config/lidar.yaml lists "
                     "every key; default: the robot folder's lidar.yaml, else the built-in "
                     "defaults)")
          ->check(kNotEmpty));
  perception_only_.push_back(
      cmd.add_option("--perception-config", o_->perception_config,
                     "--terrain perception only: YAML perception settings "
                     "(config/perception.yaml lists every key; default: its defaults)")
          ->check(kNotEmpty));
  perception_only_.push_back(
      cmd.add_option("--log-map", o_->log_map,
                     "--terrain perception only: write the elevation map, the terrain's "
                     "regions and the planned footholds into this directory at "
                     "--log-map-rate (docs/PERCEPTION.md: maps.csv, heights_NNNN.npy, "
                     "regions.csv, footholds.csv)")
          ->check(kNotEmpty));
  perception_only_.push_back(
      cmd.add_option("--perception-timing", o_->perception_timing,
                     "--terrain perception only: deterministic (map update, segmentation and "
                     "terrain in the simulation thread at each scan, reproducible) or "
                     "asynchronous (on their own thread, the scan handed over without "
                     "blocking the 1 kHz tick; no --log-map); default: the MPC's timing "
                     "(nmpc), deterministic (cbfqp)")
          ->check(CLI::IsMember({"deterministic", "asynchronous"})));
  perception_only_.push_back(
      cmd.add_option("--log-map-rate", o_->log_map_rate,
                     "--terrain perception only: map log snapshots per second")
          ->check(numberIn(0.01, 100.0, "Hz"))
          ->capture_default_str());
}

/// The state the NMPC runs on and the plant's sensors.
void SimOptionSet::addStateOptions(CLI::App& cmd) {
  nmpc_only_.push_back(cmd.add_option("--integrator", o_->integrator,
                                      "nmpc only: internal (the internal state integrator) or "
                                      "naive (naive state feedback); default: the control "
                                      "settings'")
                           ->check(CLI::IsMember({"internal", "naive"})));
  nmpc_only_.push_back(cmd.add_option("--state-source", o_->state_source,
                                      "nmpc only: ground_truth (the simulator's exact state) or "
                                      "inekf (the state estimator on the plant's noisy sensors)")
                           ->check(CLI::IsMember({"ground_truth", "inekf"}))
                           ->capture_default_str());
  estimator_config_ = cmd.add_option("--estimator-config", o_->estimator_config,
                                     "nmpc only: YAML tuning of the state estimator "
                                     "(default: the robot folder's estimation.yaml; "
                                     "robots/tachyon3/estimation.yaml lists every key)")
                          ->check(kNotEmpty);
  nmpc_only_.push_back(estimator_config_);
  cmd.add_option("--sensor-config", o_->sensor_config,
                 "YAML sensor noise of the plant (robots/tachyon3/sensors.yaml lists every key "
                 "and its default); default: ideal sensors, or with --state-source inekf the "
                 "robot folder's sensors.yaml (the defaults if it has none)")
      ->check(kNotEmpty);
}

/// Duration, outputs, the drive controller's speeds, the robot, --spec.
void SimOptionSet::addRunOptions(CLI::App& cmd) {
  cmd.add_option("--duration", o_->duration, "Simulated time [s]")
      ->check(numberIn(0.001, 3600.0, "s"))
      ->capture_default_str();
  out_ = cmd.add_option("--out", o_->out,
                        "Output directory (created if needed) for log.csv and summary.txt")
             ->check(kNotEmpty)
             ->capture_default_str();
  speed_ = cmd.add_option("--speed", o_->speed,
                          "drive only: forward wheel surface speed [m/s], ramped at 1 m/s^2")
               ->check(numberIn(-1.8, 1.8, "m/s"))
               ->capture_default_str();
  turn_speed_ =
      cmd.add_option("--turn-speed", o_->turn_speed,
                     "drive only: right minus left wheel surface speed, halved [m/s] (turn "
                     "in place with --speed 0)")
          ->check(numberIn(-1.0, 1.0, "m/s"))
          ->capture_default_str();
  cmd.add_option("--log-every", o_->log_every,
                 "Write a log row every N control periods (1 ms each)")
      ->check(integerIn(1, 100000))
      ->capture_default_str();
  cmd.add_option("--robot", o_->robot, kRobotOptionHelp)->check(kNotEmpty);
  spec_ = cmd.add_option("--spec", o_->spec,
                         "A run spec file (YAML: every key of a run with its default in "
                         "docs/USER_GUIDE.md \"Run specs\"; DIR/run.yaml of a run is one) "
                         "instead of the options above; only --out may be given with it")
              ->check(kNotEmpty);
}

void SimOptionSet::checkSpecAlone() const {
  for (const CLI::Option* option : cmd_->get_options()) {
    if (option == spec_ || option == out_ || option->count() == 0) continue;
    if (option->get_name() == "--help") continue;
    throw CLI::ValidationError(option->get_name(),
                               "and --spec exclude each other (the spec file gives the whole "
                               "run; only --out may be given with it)");
  }
}

void SimOptionSet::checkCombinations() const {
  const SimOptions& o = *o_;
  if (old_description_->count() > 0) {
    throw CLI::ValidationError("--robot-description", kRobotDescriptionFolded);
  }
  if (o.terrain != "perception") {
    for (const CLI::Option* option : perception_only_) {
      if (option->count() > 0) {
        throw CLI::ValidationError(option->get_name(),
                                   "is used only with --terrain perception (drop the option "
                                   "or add --terrain perception)");
      }
    }
  }
  if (o.controller != "nmpc" && o.controller != "cbfqp") {
    for (const CLI::Option* option : pipeline_only_) {
      if (option->count() > 0) {
        throw CLI::ValidationError(option->get_name(),
                                   "is used only by --controller nmpc or cbfqp (drop the "
                                   "option or add --controller nmpc or cbfqp)");
      }
    }
  }
  if (o.controller == "cbfqp" && o.gait == "static_walk") {
    throw CLI::ValidationError("--gait",
                               "static_walk is not a gait of the cbfqp baseline "
                               "(standing, rolling or trot)");
  }
  for (const CLI::Option* option : constant_command_) {
    if (command_->count() > 0 && option->count() > 0) {
      throw CLI::ValidationError(option->get_name(),
                                 "and --command exclude each other (give the constant "
                                 "command in --command: 0:VX:VY:YAW_RATE)");
    }
  }
  if (o.controller != "nmpc") {
    for (const CLI::Option* option : nmpc_only_) {
      if (option->count() > 0) {
        throw CLI::ValidationError(option->get_name(),
                                   "is used only by --controller nmpc (drop the option or add "
                                   "--controller nmpc)");
      }
    }
  }
  if (log_map_rate_->count() > 0 && log_map_->count() == 0) {
    throw CLI::ValidationError("--log-map-rate",
                               "is used only with --log-map (no map log is written without "
                               "it)");
  }
  if (estimator_config_->count() > 0 && o.state_source != "inekf") {
    throw CLI::ValidationError("--estimator-config",
                               "is read only with --state-source inekf (the state here is "
                               "the simulator's ground truth)");
  }
  if (o.controller != "drive") {
    for (const CLI::Option* option : {speed_, turn_speed_}) {
      if (option->count() > 0) {
        throw CLI::ValidationError(option->get_name(),
                                   "is used only by --controller drive; the " + o.controller +
                                       " controller holds the wheels at rest (drop the "
                                       "option or add --controller drive)");
      }
    }
  }
}

namespace {

/// A choice the option's check has already let through.
template <typename E>
E choice(const std::string& name) {
  const std::optional<E> e = enumFromName<E>(name);
  if (!e) throw std::logic_error("rollstep sim: unchecked choice '" + name + "'");
  return *e;
}

}  // namespace

sim::RunSpec SimOptionSet::runSpec() const {
  if (spec_->count() > 0) {
    checkSpecAlone();
    sim::RunSpec spec = sim::loadRunSpec(o_->spec);
    if (out_->count() > 0) spec.out = o_->out;
    return spec;
  }
  checkCombinations();
  const SimOptions& o = *o_;
  sim::RunSpec s;
  s.robot = o.robot;
  s.scene = o.scene;
  s.scene_file = o.scene_config;
  s.controller = choice<sim::ControllerKind>(o.controller);
  s.duration = o.duration;
  s.gait = choice<planning::GaitKind>(o.gait);
  s.command = o.command_schedule.empty()
                  ? std::vector<planning::TimedBaseCommand>{{0.0, {o.vx, o.vy, o.yaw_rate}}}
                  : parseCommandSchedule(o.command_schedule, o.duration);
  s.drive_speed = o.speed;
  s.drive_turn_speed = o.turn_speed;
  s.control_config = o.control_config;
  if (!o.mpc_timing.empty()) s.mpc_timing = choice<sim::TimingChoice>(o.mpc_timing);
  if (!o.integrator.empty()) s.integrator = choice<sim::IntegratorChoice>(o.integrator);
  s.terrain = choice<sim::TerrainSource>(o.terrain);
  s.lidar_config = o.lidar_config;
  s.perception_config = o.perception_config;
  if (!o.perception_timing.empty()) {
    s.perception_timing = choice<sim::TimingChoice>(o.perception_timing);
  }
  s.state_source = choice<sim::StateSourceKind>(o.state_source);
  s.estimator_config = o.estimator_config;
  s.sensor_config = o.sensor_config;
  s.out = o.out;
  s.log_every = o.log_every;
  s.map_log = o.log_map;
  s.map_log_rate = o.log_map_rate;
  s.log_violations = o.log_violations;
  return s;
}

sim::RunSpec runSpecFromSimArgs(const std::vector<std::string>& args) {
  CLI::App app("rollstep sim", "sim");
  SimOptions options;
  const SimOptionSet set(app, options);
  try {
    std::vector<std::string> reversed(args.rbegin(), args.rend());
    app.parse(reversed);
    return set.runSpec();
  } catch (const CLI::Error& e) {
    throw std::invalid_argument(std::string("rollstep sim ") + e.what());
  }
}

}  // namespace rollstep::apps
