// `rollstep sim`: the plant demo. Loads a scene with the Tachyon 3 MJCF, runs a controller
// (stand: hold the nominal posture; drive: hold it and roll on the drive wheels; nmpc: the
// full control pipeline, NMPC + CBF-QP + internal state integrator, on the ground-truth
// state; cbfqp: the CBF-QP baseline without MPC) for a duration, writes DIR/log.csv and
// DIR/summary.txt (nmpc also DIR/mpc.csv), prints the summary.
//
// Outputs rule (docs/USER_GUIDE.md): a run that fails on its inputs (options, scene config,
// robot file) writes nothing. Once the simulation starts, the previous run's log.csv,
// summary.txt and FAILED are removed; log.csv and summary.txt are written under
// temporary names with every write checked and renamed into place only when complete
// and the run succeeded; a run that fails after that point (divergence, full disk)
// leaves only DIR/FAILED holding the error, and exits non-zero.
#include <mujoco/mujoco.h>

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "cli_util.hpp"
#include "commands.hpp"
#include "experiments/replay.hpp"
#include "output_folder.hpp"
#include "rollstep/centroidal/centroidal_ocp.hpp"
#include "rollstep/common/interrupt.hpp"
#include "rollstep/common/number_text.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/common/yaml_tree.hpp"
#include "rollstep/control/control_settings.hpp"
#include "rollstep/perception/terrain_perception.hpp"
#include "rollstep/sim/cbfqp_controller.hpp"
#include "rollstep/sim/estimator_source.hpp"
#include "rollstep/sim/lidar.hpp"
#include "rollstep/sim/nmpc_controller.hpp"
#include "rollstep/sim/online_perception.hpp"
#include "rollstep/sim/plant.hpp"
#include "rollstep/sim/scenario.hpp"
#include "rollstep/sim/scene.hpp"
#include "rollstep/sim/scene_terrain.hpp"
#include "rollstep/sim/simple_controllers.hpp"

namespace rollstep::apps {

namespace {

namespace fs = std::filesystem;

// plan.csv keeps every 5th node of each plan (and the last): 20 of the 100 nodes, enough to
// draw the planned paths; about 160 kB per simulated second at the default 50 Hz MPC.
constexpr int kPlanNodeStride = 5;

struct SimOptions {
  std::string scene = "flat";
  std::string scene_config;
  std::string controller = "stand";
  double duration = 10.0;
  std::string out = "out/sim";
  double speed = 0.5;
  double turn_speed = 0.0;
  int log_every = 10;
  std::string robot;
  // nmpc only
  std::string gait = "standing";
  double vx = 0.0, vy = 0.0, yaw_rate = 0.0;
  std::string command_schedule;  // --command: "" = the constant --vx, --vy, --yaw-rate
  std::string control_config;
  std::string robot_description;
  std::string mpc_timing;  // "" = the config's
  std::string integrator;  // "" = the config's
  std::string terrain = "scene";
  std::string lidar_config, perception_config;  // "" = the built-in defaults
  std::string log_map;                          // "" = no map log
  std::string perception_timing;  // "" = the MPC's timing (nmpc), deterministic (cbfqp)
  double log_map_rate = 2.0;
  std::string state_source = "ground_truth";
  std::string estimator_config;  // "" = the defaults
  bool log_violations = false;   // DIR/mpc_violations.csv (deterministic timing)
  // any controller
  std::string sensor_config;  // "" = ideal sensors (inekf: the defaults)
};

/// Result files of a run in the output directory.
struct OutputFiles {
  fs::path log, summary, failed, mpc, violations, replay, plan, terrains;
  explicit OutputFiles(const fs::path& dir)
      : log(dir / "log.csv"),
        summary(dir / "summary.txt"),
        failed(dir / "FAILED"),
        mpc(dir / "mpc.csv"),
        violations(dir / "mpc_violations.csv"),
        replay(dir / "replay.json"),
        plan(dir / "plan.csv"),
        terrains(dir / "terrains.csv") {}
};

/// Creates the output directory if needed and removes the previous run's result files.
void prepareOutputDir(const std::string& dir, const OutputFiles& files) {
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) {
    throw OutputError("--out '" + dir + "': exists and is not a directory");
  }
  fs::create_directories(dir, ec);
  if (ec) throw OutputError("--out '" + dir + "': cannot create the directory: " + ec.message());
  for (const fs::path& p : {files.log, files.summary, files.failed, files.mpc, files.violations,
                            files.replay, files.plan, files.terrains}) {
    fs::remove(p, ec);
    if (ec) {
      throw OutputError("cannot remove the previous run's '" + p.string() + "': " + ec.message());
    }
  }
  removeStaleTemporaries(dir, {"log.csv", "summary.txt", "FAILED", "mpc.csv", "mpc_violations.csv",
                               "replay.json", "plan.csv", "terrains.csv"});
}

/// After a failure: no result files, and DIR/FAILED with the error (best effort: returns
/// false if FAILED could not be written either).
bool markFailed(const OutputFiles& files, const std::string& error) {
  std::error_code ec;
  fs::remove(files.log, ec);
  fs::remove(files.summary, ec);
  fs::remove(files.mpc, ec);
  fs::remove(files.violations, ec);
  fs::remove(files.replay, ec);
  fs::remove(files.plan, ec);
  fs::remove(files.terrains, ec);
  try {
    writeFileAtomically(files.failed.string(), "rollstep sim failed: " + error + "\n");
    return true;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rollstep: warning: %s\n", e.what());
    return false;
  }
}

/// --log-map DIR: refused before anything is written if it names something that is not a
/// directory (the map log's files would have nowhere to go).
void checkMapLogDir(const std::string& dir) {
  if (dir.empty()) return;
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) {
    throw OutputError("--log-map '" + dir +
                      "': cannot create the directory: exists and is not a directory");
  }
  fs::create_directories(dir, ec);
  if (ec)
    throw OutputError("--log-map '" + dir + "': cannot create the directory: " + ec.message());
}

/// After a failure: the map log's files of this run removed (its snapshots without their
/// index would be a log that is not whole); FAILED is in --out.
void discardMapLog(const std::string& dir) {
  if (dir.empty()) return;
  std::error_code ec;
  for (const char* name : {"maps.csv", "regions.csv", "footholds.csv"})
    fs::remove(fs::path(dir) / name, ec);
  std::vector<fs::path> snapshots;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("heights_", 0) == 0 && entry.path().extension() == ".npy") {
      snapshots.push_back(entry.path());
    }
  }
  for (const fs::path& p : snapshots) fs::remove(p, ec);
}

/// MuJoCo's warnings on stderr (its default handler also appends them to MUJOCO_LOG.TXT in
/// the working directory, a file nobody asked for).
void printMujocoWarning(const char* message) {
  std::fprintf(stderr, "rollstep: MuJoCo warning: %s\n", message);
}

/// The estimate's horizontal position and yaw errors against the plant's ground truth.
struct GroundTruthErrors {
  double position = 0.0, yaw_deg = 0.0;
};
GroundTruthErrors estimateErrors(const sim::EstimatorSource& e, const sim::GroundTruth& g) {
  const estimation::InvariantEkf& f = e.filter();
  GroundTruthErrors out;
  out.position = (f.position() - g.base_position).head<2>().norm();
  out.yaw_deg = std::abs(std::remainder(
                    sim::yawOf(f.orientation()) - sim::yawOf(g.base_orientation), 2.0 * M_PI)) *
                180.0 / M_PI;
  return out;
}

/// Parses --command "T:VX[:VY[:YAW]],...": one segment per comma, times [s] from the start
/// (the first 0, increasing), speeds within --vx's, --vy's and --yaw-rate's ranges.
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

/// The robot folder's own `file` (its controller defaults), else config/`file`.
std::string robotOrProjectFile(const sim::RobotFolder& robot, const char* file) {
  const std::string own = robot.optionalFile(file);
  return own.empty() ? configFile(file) : own;
}

/// A count in words up to twelve ("six"), else in digits.
std::string countText(int n) {
  static const char* const kWords[] = {"no",    "one",   "two",  "three", "four",   "five",  "six",
                                       "seven", "eight", "nine", "ten",   "eleven", "twelve"};
  return n >= 0 && n <= 12 ? kWords[n] : std::to_string(n);
}

/// The OCP's forces act contact_offset below the wheel centres: a description whose offset
/// is not the simulated wheels' radius plans every contact off the ground.
void checkContactOffset(const centroidal::RobotOcpDescription& robot,
                        const std::string& description, const sim::Plant& plant) {
  for (int leg = 0; leg < plant.layout().numLegs(); ++leg) {
    if (std::abs(robot.contact_offset - plant.wheelRadius(leg)) > 1e-4) {
      throw InputError("robot description '" + description +
                       "': contact_offset: " + numberText(robot.contact_offset) +
                       " m is not the wheel radius of the robot MJCF '" + plant.robotFile() +
                       "' (" + numberText(plant.wheelRadius(leg)) + " m, " +
                       plant.layout().legs[static_cast<std::size_t>(leg)].contact_frame + ")");
    }
  }
}

/// --controller cbfqp reads a control file's `baseline:` section: a file without one (an
/// NMPC behaviour file) would silently run the baseline on the defaults, not its tuning.
void requireBaselineSection(const std::string& path) {
  const std::string text = readTextFile(path, "control settings");
  const yaml::Document doc = yaml::Document::parse(text);
  const yaml::Node root = doc.root();
  for (std::size_t i = 0; root.isMapping() && i < root.size(); ++i) {
    if (root.key(i).scalar() == "baseline") return;
  }
  throw CLI::ValidationError(
      "--control-config",
      "'" + path +
          "' has no baseline: section, the cbfqp controller's tuning (an NMPC file? the "
          "baseline's is config/baseline.yaml; write 'baseline: {}' for its defaults)");
}

/// Perception in closed loop (--terrain perception): the sensor and perception settings,
/// started at the plant's pose (its first terrain built), with the map log if asked for.
std::unique_ptr<sim::OnlinePerception> startPerception(const SimOptions& o,
                                                       const sim::RobotFolder& robot,
                                                       const sim::Plant& plant,
                                                       bool asynchronous_default) {
  sim::OnlinePerceptionOptions options;
  options.asynchronous =
      o.perception_timing.empty() ? asynchronous_default : o.perception_timing == "asynchronous";
  if (!o.lidar_config.empty()) {
    options.lidar = sim::loadLidarSettings(o.lidar_config);
  } else if (!robot.lidar.empty()) {
    options.lidar = sim::loadLidarSettings(robot.lidar);
  }
  if (!o.perception_config.empty()) {
    options.perception = perception::loadPerceptionSettings(o.perception_config);
  }
  options.log_dir = o.log_map;
  options.log_rate = o.log_map_rate;
  auto p = std::make_unique<sim::OnlinePerception>(options);
  p->start(plant, plant.groundTruth().base_position, plant.groundTruth().base_orientation);
  return p;
}

/// The summary's perception line.
std::string perceptionText(const sim::OnlinePerception& p, std::uint64_t refused,
                           std::uint64_t in_use) {
  const sim::OnlinePerceptionCounters& c = p.counters();
  std::string text = format(
      "  perception %llu scans at %s Hz: %llu new terrains (%llu handed over, %llu refused), "
      "%llu kept the last (%llu no points, %llu no finite point, %llu bad pose, %llu no "
      "planar region); map update + segmentation mean %.1f ms, max %.1f ms; %d regions at "
      "the end\n",
      static_cast<unsigned long long>(c.scans), numberText(p.lidar().settings().rate).c_str(),
      static_cast<unsigned long long>(c.terrains), static_cast<unsigned long long>(in_use),
      static_cast<unsigned long long>(refused), static_cast<unsigned long long>(c.kept),
      static_cast<unsigned long long>(c.no_points), static_cast<unsigned long long>(c.non_finite),
      static_cast<unsigned long long>(c.invalid_pose),
      static_cast<unsigned long long>(c.no_planar_region),
      c.scans > c.superseded ? c.total_update_ms / static_cast<double>(c.scans - c.superseded)
                             : 0.0,
      c.max_update_ms, p.terrain().size());
  if (p.asynchronous()) {
    text += format(
        "  perception on its own thread: %llu scans superseded by a newer one before "
        "processing\n",
        static_cast<unsigned long long>(c.superseded));
  }
  if (p.snapshots() > 0) text += format("  map log    %d snapshots\n", p.snapshots());
  return text;
}

/// The summary's line on the speed rule: the trot's timing and where the command was slowed
/// down at a step (within the run's duration); empty without speed adaptation.
std::string speedRuleText(const sim::NmpcController& nmpc, double duration) {
  const control::ControlPipeline& pipeline = nmpc.pipeline();
  if (!pipeline.settings().ocp.speed_adaptation) return "";
  std::string text = "  speed      ";
  const planning::TrotTiming& t = nmpc.trotTiming();
  if (t.period > 0.0) {
    text += format("trot period %.2f s, duty %.2f (swing %.2f s); step speed limit %.2f m/s",
                   t.period, t.duty, t.swing, pipeline.stepSpeedLimit());
  } else {
    text += "no trot: the command ramped only";
  }
  int slowdowns = 0;
  for (const planning::StepSlowdown& d : pipeline.stepSlowdowns()) {
    if (d.start >= duration) continue;
    text += format("%s slowed down at a step from %.2f to %.2f m/s, %.2f-%.2f s",
                   slowdowns == 0 ? ";" : ",", d.commanded_speed, d.limited_speed, d.start,
                   std::min(d.end, duration));
    ++slowdowns;
  }
  if (slowdowns == 0 && t.period > 0.0) text += "; not slowed down";
  return text + "\n";
}

void runSim(const SimOptions& o) {
  mju_user_warning = printMujocoWarning;
  // Inputs: nothing is written before they have all loaded.
  const std::vector<planning::TimedBaseCommand> schedule =
      o.command_schedule.empty()
          ? std::vector<planning::TimedBaseCommand>{{0.0, {o.vx, o.vy, o.yaw_rate}}}
          : parseCommandSchedule(o.command_schedule, o.duration);
  const sim::SceneConfig scene =
      o.scene_config.empty() ? sim::loadScene(o.scene) : sim::loadSceneConfig(o.scene_config);

  // The robot folder, its files checked against each other before anything runs.
  const sim::RobotFolder robot_folder = robotFolderOption(o.robot);
  sim::PlantOptions plant_options = sim::plantOptionsFor(robot_folder);
  if (!o.sensor_config.empty()) {
    plant_options.sensor_noise = sim::loadSensorNoiseConfig(o.sensor_config);
  } else if (o.state_source == "inekf") {
    // An estimator reads real sensors: the robot's own (its sensors.yaml), else the defaults.
    plant_options.sensor_noise = robot_folder.sensors.empty()
                                     ? sim::SensorNoiseConfig{}
                                     : sim::loadSensorNoiseConfig(robot_folder.sensors);
  }
  sim::Plant plant(scene, plant_options);

  std::unique_ptr<sim::Controller> controller;
  sim::NmpcController* nmpc_controller = nullptr;
  sim::CbfQpController* cbfqp_controller = nullptr;
  std::string controller_text;
  // The foothold regions the replay page draws: those in use at the start.
  planning::TerrainModel replay_regions;
  std::string replay_regions_source = "none (this controller plans no footholds)";
  if (o.controller == "stand") {
    controller = std::make_unique<sim::StandController>(plant.nominalCommand());
    controller_text = "stand (nominal posture, wheels at rest)";
  } else if (o.controller == "nmpc") {
    const std::string& description = robot_folder.description;
    const centroidal::RobotOcpDescription robot = centroidal::loadRobotOcpDescription(description);
    checkContactOffset(robot, description, plant);
    // The robot folder's own file of the name, else the project's default (the library's
    // defaults on ground truth; config/nmpc_perception.yaml over them on perception).
    std::string settings_file = o.control_config;
    if (settings_file.empty()) {
      settings_file = robot_folder.optionalFile(o.terrain == "perception" ? "nmpc_perception.yaml"
                                                                          : "nmpc.yaml");
    }
    if (settings_file.empty()) settings_file = defaultNmpcConfig(o.terrain == "perception");
    control::ControlSettings settings = settings_file.empty()
                                            ? control::ControlSettings{}
                                            : control::loadControlSettings(settings_file);
    if (o.mpc_timing == "deterministic") settings.mpc.timing = control::MpcTiming::Deterministic;
    if (o.mpc_timing == "asynchronous") settings.mpc.timing = control::MpcTiming::Asynchronous;
    if (o.integrator == "internal") settings.integrator.mode = control::IntegratorMode::Internal;
    if (o.integrator == "naive") settings.integrator.mode = control::IntegratorMode::Naive;
    // The terrain source: the scene's ground truth, or perception in closed loop (the
    // LiDAR's view from the start pose first, then every scan), regions shrunk alike.
    const double margin = centroidal::footholdRegionMargin(robot, settings.ocp);
    planning::TerrainModel terrain;
    std::string terrain_text = "scene ground truth";
    std::unique_ptr<sim::OnlinePerception> online;
    int edge_capacity = 0;
    if (o.terrain == "perception") {
      online = startPerception(o, robot_folder, plant,
                               settings.mpc.timing == control::MpcTiming::Asynchronous);
      terrain = online->footholdTerrain(margin);
      edge_capacity = online->perception().settings().regions.directions;
      terrain_text = format(
          "perception in closed loop (%d convex regions at the start from %d "
          "LiDAR scans, then one terrain per scan)",
          terrain.size(), online->perception().settings().closed_loop.warmup_scans);
    } else {
      terrain = sim::terrainFromScene(scene, margin);
    }
    sim::StateSourceOptions source;
    source.kind = sim::stateSourceFromString(o.state_source);
    if (source.kind == sim::StateSourceKind::Inekf) {
      // The robot's tuning beside its description, unless another file is named.
      if (o.estimator_config.empty() && robot_folder.estimation.empty()) {
        throw InputError("robot folder '" + robot_folder.directory +
                         "': no estimation.yaml (the state estimator's tuning) for "
                         "--state-source inekf; add it or give --estimator-config");
      }
      const std::string tuning =
          o.estimator_config.empty() ? robot_folder.estimation : o.estimator_config;
      source.estimator = estimation::loadInekfSettings(tuning);
    }
    auto nmpc = std::make_unique<sim::NmpcController>(plant, robot, settings, terrain,
                                                      centroidal::gaitKindFromString(o.gait),
                                                      schedule, source, edge_capacity);
    if (online) nmpc->setPerception(std::move(online), margin);
    nmpc_controller = nmpc.get();
    nmpc->enablePlanLog(kPlanNodeStride, o.duration);
    if (o.terrain == "perception") nmpc->enableTerrainLog();
    replay_regions = terrain;
    replay_regions_source = o.terrain == "perception" ? "perception at the start" : "scene";
    if (o.log_violations) {
      if (settings.mpc.timing != control::MpcTiming::Deterministic) {
        throw std::invalid_argument("--log-violations needs --mpc-timing deterministic");
      }
      nmpc->enableViolationLog();
    }
    controller = std::move(nmpc);
    std::string command_text;
    for (const planning::TimedBaseCommand& c : schedule) {
      command_text +=
          format("%s(%s m/s, %s m/s, %s rad/s)%s", command_text.empty() ? "" : ", ",
                 numberText(c.command.v_x).c_str(), numberText(c.command.v_y).c_str(),
                 numberText(c.command.yaw_rate).c_str(),
                 schedule.size() > 1 ? (" from " + numberText(c.time) + " s").c_str() : "");
    }
    const solver::SolverStatus first = nmpc_controller->initialStatus();
    const control::MpcRunner& runner = nmpc_controller->pipeline().runner();
    controller_text = format(
        "nmpc (gait %s, command %s, MPC every %s s %s, N = %d, "
        "integrator %s, state %s; first solve %s in %d iterations)",
        o.gait.c_str(), command_text.c_str(), numberText(settings.mpc.period).c_str(),
        control::toString(settings.mpc.timing), settings.ocp.horizon,
        control::toString(settings.integrator.mode), o.state_source.c_str(),
        solver::toString(first), runner.initialIterations());
    controller_text += "; terrain " + terrain_text;
    if (first != solver::SolverStatus::Converged && first != solver::SolverStatus::Acceptable) {
      // Not an error (the real-time iterations go on from its iterate, the CBF-QP falls
      // back until their first usable solution), but the run's start is not what it seems.
      std::fprintf(stderr,
                   "rollstep sim: warning: the first MPC solve ended %s after %d iterations%s%s\n",
                   solver::toString(first), runner.initialIterations(),
                   runner.initialMessage().empty() ? "" : ": ", runner.initialMessage().c_str());
    }
  } else if (o.controller == "cbfqp") {
    const std::string& description = robot_folder.description;
    const centroidal::RobotOcpDescription robot = centroidal::loadRobotOcpDescription(description);
    checkContactOffset(robot, description, plant);
    const std::string config = o.control_config.empty()
                                   ? robotOrProjectFile(robot_folder, "baseline.yaml")
                                   : o.control_config;
    const control::ControlSettings settings = control::loadControlSettings(config);
    if (!o.control_config.empty()) requireBaselineSection(config);
    const planning::BaseVelocityCommand command{o.vx, o.vy, o.yaw_rate};
    std::unique_ptr<sim::CbfQpController> cbfqp;
    std::string terrain_text = "scene ground truth";
    if (o.terrain == "perception") {
      // Perceived surfaces: unshrunk as the collision solids, shrunk as the footholds.
      std::unique_ptr<sim::OnlinePerception> online =
          startPerception(o, robot_folder, plant, false);
      cbfqp = std::make_unique<sim::CbfQpController>(
          plant, robot, settings, online->footholdTerrain(settings.baseline.foothold_margin),
          online->terrain(), centroidal::gaitKindFromString(o.gait), command,
          online->perception().settings().regions.directions,
          online->perception().settings().closed_loop.collision_capacity);
      terrain_text = format(
          "perception in closed loop (%d regions at the start, then one "
          "terrain per scan)",
          online->terrain().size());
      cbfqp->setPerception(std::move(online));
      cbfqp->enableTerrainLog();
    } else {
      cbfqp = std::make_unique<sim::CbfQpController>(
          plant, robot, settings, sim::terrainFromScene(scene, settings.baseline.foothold_margin),
          sim::terrainFromScene(scene, 0.0), centroidal::gaitKindFromString(o.gait), command);
    }
    cbfqp_controller = cbfqp.get();
    if (o.terrain != "perception") {
      replay_regions = sim::terrainFromScene(scene, settings.baseline.foothold_margin);
      replay_regions_source = "scene";
    } else {
      replay_regions = cbfqp->pipeline().terrain();
      replay_regions_source = "perception at the start";
    }
    controller = std::move(cbfqp);
    controller_text = format(
        "cbfqp (CBF-QP baseline, no MPC; gait %s, command (%s m/s, %s m/s, %s rad/s), "
        "trot period %s s; %s)",
        o.gait.c_str(), numberText(o.vx).c_str(), numberText(o.vy).c_str(),
        numberText(o.yaw_rate).c_str(), numberText(settings.baseline.gait_period).c_str(),
        config.c_str());
    controller_text += "; terrain " + terrain_text;
  } else {
    // Each side's wheels run at speed -+ turn_speed: beyond the servos' limit they would
    // be clamped and the robot would not do what was asked.
    if (plant.layout().numDriveWheels() == 0) {
      throw CLI::ValidationError(
          "--controller", "drive: the robot '" + plant.robotFile() + "' has no drive wheels");
    }
    double radius = std::numeric_limits<double>::infinity();
    for (const int leg : plant.layout().drive_wheel_legs) {
      radius = std::min(radius, plant.wheelRadius(leg));
    }
    const double limit = plant.wheelSpeedLimit() * radius;
    const double needed = std::abs(o.speed) + std::abs(o.turn_speed);
    if (needed > limit) {
      char text[400];
      std::snprintf(text, sizeof text,
                    "%g with --turn-speed %g needs a wheel surface speed of %g m/s; the "
                    "drive wheels of this robot reach %.3f m/s (%g rad/s x %g m): valid range "
                    "|speed| + |turn-speed| <= %.3f m/s",
                    o.speed, o.turn_speed, needed, limit, plant.wheelSpeedLimit(), radius, limit);
      throw CLI::ValidationError("--speed", text);
    }
    sim::DriveController::Params p;
    p.speed = o.speed;
    p.turn_speed = o.turn_speed;
    controller = std::make_unique<sim::DriveController>(plant, p);
    std::ostringstream s;
    s << "drive (nominal posture, wheel surface speed " << o.speed << " m/s, turn " << o.turn_speed
      << " m/s)";
    controller_text = s.str();
  }

  // Outputs. From here an interrupt (SIGINT, SIGTERM) ends the run through the catch below:
  // temporary files removed, FAILED with the reason.
  checkMapLogDir(o.log_map);
  const OutputFiles files(o.out);
  deferInterrupts();
  throwIfInterrupted();
  prepareOutputDir(o.out, files);
  std::string text;
  try {
    if (nmpc_controller != nullptr && nmpc_controller->perception() != nullptr) {
      nmpc_controller->perception()->openLog();
    }
    if (cbfqp_controller != nullptr && cbfqp_controller->perception() != nullptr) {
      cbfqp_controller->perception()->openLog();
    }
    sim::CsvLog log(files.log.string(), plant.layout(), controller->logColumns());
    // A progress line on stderr for runs that take more than a few seconds.
    const auto progress = [](const sim::Progress& p) {
      if (p.wall_time < 3.0) return;
      std::fprintf(stderr, "rollstep sim: %.1f of %.1f s simulated (%.0f %%), %.1fx real time\n",
                   p.sim_time, p.duration, 100.0 * p.sim_time / p.duration,
                   p.sim_time / p.wall_time);
    };
    const sim::RunSummary s =
        sim::runScenario(plant, *controller, o.duration, &log, o.log_every, progress);
    // Asynchronous perception: its thread finishes (and reports a failure) before the
    // counters are read.
    if (nmpc_controller != nullptr && nmpc_controller->perception() != nullptr) {
      nmpc_controller->perception()->stop();
    }
    if (cbfqp_controller != nullptr && cbfqp_controller->perception() != nullptr) {
      cbfqp_controller->perception()->stop();
    }
    log.commit();
    writeFileAtomically(files.replay.string(),
                        experiments::replayModelJson(plant, replay_regions, replay_regions_source));
    if (nmpc_controller != nullptr && !nmpc_controller->terrainsCsv().empty()) {
      writeFileAtomically(files.terrains.string(), nmpc_controller->terrainsCsv());
    }
    if (cbfqp_controller != nullptr && !cbfqp_controller->terrainsCsv().empty()) {
      writeFileAtomically(files.terrains.string(), cbfqp_controller->terrainsCsv());
    }
    std::string mpc_text;
    if (nmpc_controller != nullptr) {
      writeFileAtomically(files.mpc.string(), nmpc_controller->mpcUpdatesCsv());
      writeFileAtomically(files.plan.string(), nmpc_controller->planCsv());
      if (o.log_violations) {
        writeFileAtomically(files.violations.string(), nmpc_controller->violationsCsv());
      }
      const control::PipelineCounters& c = nmpc_controller->pipeline().counters();
      const control::MpcRunner& runner = nmpc_controller->pipeline().runner();
      double solve_sum = 0.0, solve_max = 0.0;
      const auto& updates = nmpc_controller->mpcUpdates();
      for (size_t k = 1; k < updates.size(); ++k) {  // the first is the initial cold solve
        solve_sum += updates[k].solve_time_ms;
        solve_max = std::max(solve_max, updates[k].solve_time_ms);
      }
      const double updates_n = updates.size() > 1 ? static_cast<double>(updates.size() - 1) : 1.0;
      mpc_text = format(
          "  MPC        %zu solutions (%llu rejected), solve time mean %.2f ms, max %.2f ms; %s\n"
          "  CBF-QP     %llu fallbacks, %llu relaxed in %llu ticks\n",
          updates.size(), static_cast<unsigned long long>(c.solutions_rejected),
          solve_sum / updates_n, solve_max, files.mpc.c_str(),
          static_cast<unsigned long long>(c.qp_fallbacks),
          static_cast<unsigned long long>(c.qp_relaxations),
          static_cast<unsigned long long>(c.ticks));
      mpc_text += format("  watchdog   %llu trips, %llu ticks holding, %llu stale solutions\n",
                         static_cast<unsigned long long>(c.watchdog_trips),
                         static_cast<unsigned long long>(c.holding_ticks),
                         static_cast<unsigned long long>(c.stale_solutions));
      mpc_text += speedRuleText(*nmpc_controller, o.duration);
      if (runner.solveExceptions() > 0) {
        mpc_text += format("  MPC errors %llu solves failed on an exception, the first: %s\n",
                           static_cast<unsigned long long>(runner.solveExceptions()),
                           runner.firstSolveException());
      }
      if (c.late_touchdown_ticks > 0) {
        mpc_text += format("  landing    %llu ticks with a late touch-down under way\n",
                           static_cast<unsigned long long>(c.late_touchdown_ticks));
      }
      if (const sim::EstimatorSource* e = nmpc_controller->estimator(); e != nullptr) {
        const estimation::EstimatorCounters& k = e->filter().counters();
        const GroundTruthErrors err = estimateErrors(*e, plant.groundTruth());
        mpc_text += format(
            "  estimator  error at the end %.3f m, %.2f deg (ground truth); rejected samples: "
            "%llu IMU, %llu encoder, %llu time; contacts %llu used, %llu gated out\n",
            err.position, err.yaw_deg, static_cast<unsigned long long>(k.imu_rejected),
            static_cast<unsigned long long>(k.encoder_rejected),
            static_cast<unsigned long long>(k.time_rejected),
            static_cast<unsigned long long>(k.contacts_used),
            static_cast<unsigned long long>(k.contacts_rejected));
      }
      if (sim::OnlinePerception* p = nmpc_controller->perception(); p != nullptr) {
        p->closeLog();
        mpc_text += perceptionText(*p, nmpc_controller->terrainsRefused(),
                                   nmpc_controller->pipeline().counters().terrain_updates);
      }
    }

    if (cbfqp_controller != nullptr) {
      const control::PipelineCounters& c = cbfqp_controller->pipeline().counters();
      mpc_text = format("  CBF-QP     %llu fallbacks, %llu relaxed in %llu ticks\n",
                        static_cast<unsigned long long>(c.qp_fallbacks),
                        static_cast<unsigned long long>(c.qp_relaxations),
                        static_cast<unsigned long long>(c.ticks));
      if (sim::OnlinePerception* p = cbfqp_controller->perception(); p != nullptr) {
        p->closeLog();
        mpc_text += perceptionText(*p, cbfqp_controller->terrainsRefused(), c.terrain_updates);
      }
    }
    const double deg = 180.0 / M_PI;
    text = format(
        "rollstep sim: scene %s, controller %s\n"
        "  robot      %s\n"
        "  simulated  %.3f s at %.0f Hz in %.3f s wall time (%.1fx real time)\n"
        "  base       start (%.3f, %.3f, %.3f) m -> end (%.3f, %.3f, %.3f) m, distance %.3f m, "
        "yaw change %.2f deg\n"
        "  height     min %.4f m, max %.4f m; mean forward speed %.3f m/s\n"
        "  contacts   all %s wheels on the ground %.1f %% of the time\n"
        "  MuJoCo     %d warnings\n"
        "%s"
        "  outputs    %s (CSV, units in the header, every %d ms), %s\n",
        scene.name.c_str(), controller_text.c_str(), plant.robotFile().c_str(), s.sim_time,
        1.0 / plant.controlPeriod(), s.wall_time, s.real_time_factor, s.start_position.x(),
        s.start_position.y(), s.start_position.z(), s.end_position.x(), s.end_position.y(),
        s.end_position.z(), (s.end_position - s.start_position).head<2>().norm(),
        s.yaw_change * deg, s.min_base_height, s.max_base_height, s.mean_forward_speed,
        countText(plant.layout().numLegs()).c_str(), 100.0 * s.all_feet_contact_fraction,
        s.warnings, mpc_text.c_str(), files.log.c_str(),
        static_cast<int>(std::lround(o.log_every * plant.controlPeriod() * 1000.0)),
        files.summary.c_str());
    writeFileAtomically(files.summary.string(), text);
  } catch (const std::exception& e) {
    const bool marked = markFailed(files, e.what());
    discardMapLog(o.log_map);
    if (dynamic_cast<const Interrupted*>(&e) != nullptr) {
      std::fprintf(stderr, "rollstep sim: %s: no %s or %s is left%s\n", e.what(), files.log.c_str(),
                   files.summary.c_str(),
                   marked ? ("; the reason is in " + files.failed.string()).c_str() : "");
      throw;
    }
    const std::string message = std::string(e.what()) + "\n  the run failed: no " +
                                files.log.string() + " or " + files.summary.string() + " is left" +
                                (marked ? "; the error is in " + files.failed.string() : "");
    // Kept apart: an output that cannot be written ends the program with its own status.
    if (dynamic_cast<const OutputError*>(&e) != nullptr) throw OutputError(message);
    throw std::runtime_error(message);
  }
  std::fputs(text.c_str(), stdout);
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
    throw OutputError(std::string("cannot write the summary to standard output: ") +
                      std::strerror(errno));
  }
}

}  // namespace

void registerSimCommand(CLI::App& app) {
  auto options = std::make_shared<SimOptions>();
  CLI::App* cmd = app.add_subcommand(
      "sim",
      "Run the MuJoCo plant (a robot folder's robot in a scene) with a controller; write a CSV "
      "log (time, base pose and twist, joint positions, commands, contacts; units in the "
      "header) and a summary, and print the summary.");
  cmd->footer(
      "Numbers must be finite and within the ranges shown; --speed and --turn-speed only "
      "apply to --controller drive; --gait, --vx, --vy, --yaw-rate and --control-config "
      "only to --controller nmpc and cbfqp; --mpc-timing and "
      "--integrator only to --controller nmpc.\n"
      "Outputs: DIR/log.csv and DIR/summary.txt appear only complete and only when the run "
      "succeeds; a run that fails once started removes the previous run's files and leaves "
      "DIR/FAILED with the error. Exit status: 0 on success, non-zero on any error.\n"
      "Example scene file: config/scenes/step20_custom.yaml");
  CLI::Option* scene =
      cmd->add_option("--scene", options->scene,
                      "Scene: a name (" + sim::sceneNamesText() + ": the files NAME.yaml of " +
                          sim::scenesDirectory() +
                          ") or a scene file (a path with a '/' or ending in .yaml)")
          ->capture_default_str();
  CLI::Option* scene_config =
      cmd->add_option("--scene-config", options->scene_config,
                      "Scene file (boxes, ramps, friction and parameters; docs/USER_GUIDE.md "
                      "\"Scenes\"), e.g. config/scenes/step20_custom.yaml")
          ->check(kNotEmpty);
  scene->excludes(scene_config);
  cmd->add_option("--controller", options->controller,
                  "stand: hold the nominal posture; drive: hold it and roll on the four "
                  "drive wheels at --speed (turning with --turn-speed); nmpc: the control "
                  "pipeline (NMPC + CBF-QP + internal state integrator) on the ground-truth "
                  "state, with --gait and the base velocity command --vx, --vy, --yaw-rate; "
                  "cbfqp: the CBF-QP baseline (the paper's previous controller, a reactive "
                  "planner and the CBF-QP without MPC) with the same options")
      ->check(CLI::IsMember({"stand", "drive", "nmpc", "cbfqp"}))
      ->capture_default_str();
  std::vector<CLI::Option*> pipeline_only;  // nmpc and cbfqp
  std::vector<CLI::Option*> nmpc_only;
  pipeline_only.push_back(
      cmd->add_option("--gait", options->gait,
                      "nmpc, cbfqp only: standing, rolling, trot or static_walk (cbfqp: "
                      "standing, rolling or trot)")
          ->check(CLI::IsMember({"standing", "rolling", "trot", "static_walk"}))
          ->capture_default_str());
  pipeline_only.push_back(
      cmd->add_option("--vx", options->vx,
                      "nmpc, cbfqp only: forward base velocity command [m/s] (base frame)")
          ->check(numberIn(-1.0, 1.0, "m/s"))
          ->capture_default_str());
  pipeline_only.push_back(
      cmd->add_option("--vy", options->vy,
                      "nmpc, cbfqp only: lateral base velocity command [m/s] (base frame)")
          ->check(numberIn(-0.5, 0.5, "m/s"))
          ->capture_default_str());
  pipeline_only.push_back(
      cmd->add_option("--yaw-rate", options->yaw_rate, "nmpc, cbfqp only: yaw rate command [rad/s]")
          ->check(numberIn(-1.0, 1.0, "rad/s"))
          ->capture_default_str());
  CLI::Option* command_schedule =
      cmd->add_option("--command", options->command_schedule,
                      "nmpc only: a base velocity command schedule instead of the constant "
                      "--vx/--vy/--yaw-rate: T:VX[:VY[:YAW_RATE]],... each from T s on (the "
                      "first T 0, increasing; speeds in the ranges of --vx, --vy, --yaw-rate), "
                      "e.g. 0:0.15,32:-0.15 goes forward, then back")
          ->check(kNotEmpty);
  nmpc_only.push_back(command_schedule);
  pipeline_only.push_back(
      cmd->add_option("--control-config", options->control_config,
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
  CLI::Option* old_description =
      cmd->add_option("--robot-description", options->robot_description,
                      "Replaced by --robot NAME_OR_DIR (the robot folder holds the description)");
  nmpc_only.push_back(cmd->add_option("--mpc-timing", options->mpc_timing,
                                      "nmpc only: deterministic (a solve every MPC period of "
                                      "simulated time, reproducible) or asynchronous (a real "
                                      "MPC thread); default: the control settings'")
                          ->check(CLI::IsMember({"deterministic", "asynchronous"})));
  nmpc_only.push_back(cmd->add_flag("--log-violations", options->log_violations,
                                    "nmpc only, deterministic MPC timing: check every MPC "
                                    "solution against the problem it solved and write the "
                                    "largest violation of each constraint group and its node "
                                    "to DIR/mpc_violations.csv (slow; for analysis)"));
  CLI::Option* terrain_option =
      cmd->add_option("--terrain", options->terrain,
                      "nmpc, cbfqp only: scene (the scene's ground-truth regions) or perception "
                      "(perception in closed loop: the simulated LiDAR scans at its rate, each "
                      "scan is fused at the base pose the controller runs on and gives a new "
                      "terrain; a scan with a bad status keeps the last one)")
          ->check(CLI::IsMember({"scene", "perception"}))
          ->capture_default_str();
  pipeline_only.push_back(terrain_option);
  std::vector<CLI::Option*> perception_only;
  perception_only.push_back(
      cmd->add_option("--lidar-config", options->lidar_config,
                      "--terrain perception only: YAML LiDAR settings (config/lidar.yaml lists "
                      "every key; default: the robot folder's lidar.yaml, else the built-in "
                      "defaults)")
          ->check(kNotEmpty));
  perception_only.push_back(
      cmd->add_option("--perception-config", options->perception_config,
                      "--terrain perception only: YAML perception settings "
                      "(config/perception.yaml lists every key; default: its defaults)")
          ->check(kNotEmpty));
  perception_only.push_back(
      cmd->add_option("--log-map", options->log_map,
                      "--terrain perception only: write the elevation map, the terrain's "
                      "regions and the planned footholds into this directory at "
                      "--log-map-rate (docs/PERCEPTION.md: maps.csv, heights_NNNN.npy, "
                      "regions.csv, footholds.csv)")
          ->check(kNotEmpty));
  perception_only.push_back(
      cmd->add_option("--perception-timing", options->perception_timing,
                      "--terrain perception only: deterministic (map update, segmentation and "
                      "terrain in the simulation thread at each scan, reproducible) or "
                      "asynchronous (on their own thread, the scan handed over without "
                      "blocking the 1 kHz tick; no --log-map); default: the MPC's timing "
                      "(nmpc), deterministic (cbfqp)")
          ->check(CLI::IsMember({"deterministic", "asynchronous"})));
  perception_only.push_back(
      cmd->add_option("--log-map-rate", options->log_map_rate,
                      "--terrain perception only: map log snapshots per second")
          ->check(numberIn(0.01, 100.0, "Hz"))
          ->capture_default_str());
  nmpc_only.push_back(cmd->add_option("--integrator", options->integrator,
                                      "nmpc only: internal (the internal state integrator) or "
                                      "naive (naive state feedback); default: the control "
                                      "settings'")
                          ->check(CLI::IsMember({"internal", "naive"})));
  nmpc_only.push_back(cmd->add_option("--state-source", options->state_source,
                                      "nmpc only: ground_truth (the simulator's exact state) or "
                                      "inekf (the state estimator on the plant's noisy sensors)")
                          ->check(CLI::IsMember({"ground_truth", "inekf"}))
                          ->capture_default_str());
  CLI::Option* estimator_config =
      cmd->add_option("--estimator-config", options->estimator_config,
                      "nmpc only: YAML tuning of the state estimator "
                      "(default: the robot folder's estimation.yaml; "
                      "robots/tachyon3/estimation.yaml lists every key)")
          ->check(kNotEmpty);
  nmpc_only.push_back(estimator_config);
  cmd->add_option("--sensor-config", options->sensor_config,
                  "YAML sensor noise of the plant (robots/tachyon3/sensors.yaml lists every key "
                  "and its default); default: ideal sensors, or with --state-source inekf the "
                  "robot folder's sensors.yaml (the defaults if it has none)")
      ->check(kNotEmpty);
  cmd->add_option("--duration", options->duration, "Simulated time [s]")
      ->check(numberIn(0.001, 3600.0, "s"))
      ->capture_default_str();
  cmd->add_option("--out", options->out,
                  "Output directory (created if needed) for log.csv and summary.txt")
      ->check(kNotEmpty)
      ->capture_default_str();
  CLI::Option* speed =
      cmd->add_option("--speed", options->speed,
                      "drive only: forward wheel surface speed [m/s], ramped at 1 m/s^2")
          ->check(numberIn(-1.8, 1.8, "m/s"))
          ->capture_default_str();
  CLI::Option* turn_speed =
      cmd->add_option("--turn-speed", options->turn_speed,
                      "drive only: right minus left wheel surface speed, halved [m/s] (turn "
                      "in place with --speed 0)")
          ->check(numberIn(-1.0, 1.0, "m/s"))
          ->capture_default_str();
  cmd->add_option("--log-every", options->log_every,
                  "Write a log row every N control periods (1 ms each)")
      ->check(integerIn(1, 100000))
      ->capture_default_str();
  cmd->add_option("--robot", options->robot, kRobotOptionHelp)->check(kNotEmpty);
  cmd->final_callback([options, speed, turn_speed, nmpc_only, pipeline_only, perception_only,
                       command_schedule, estimator_config, old_description] {
    if (old_description->count() > 0) {
      throw CLI::ValidationError("--robot-description", kRobotDescriptionFolded);
    }
    if (options->terrain != "perception") {
      for (const CLI::Option* option : perception_only) {
        if (option->count() > 0) {
          throw CLI::ValidationError(option->get_name(),
                                     "is used only with --terrain perception (drop the option "
                                     "or add --terrain perception)");
        }
      }
    }
    if (options->controller != "nmpc" && options->controller != "cbfqp") {
      for (const CLI::Option* option : pipeline_only) {
        if (option->count() > 0) {
          throw CLI::ValidationError(option->get_name(),
                                     "is used only by --controller nmpc or cbfqp (drop the "
                                     "option or add --controller nmpc or cbfqp)");
        }
      }
    }
    if (options->controller == "cbfqp" && options->gait == "static_walk") {
      throw CLI::ValidationError("--gait",
                                 "static_walk is not a gait of the cbfqp baseline "
                                 "(standing, rolling or trot)");
    }
    // pipeline_only[1..3] are --vx, --vy and --yaw-rate: one command or the other.
    for (std::size_t k = 1; k <= 3 && command_schedule->count() > 0; ++k) {
      if (pipeline_only[k]->count() > 0) {
        throw CLI::ValidationError(pipeline_only[k]->get_name(),
                                   "and --command exclude each other (give the constant "
                                   "command in --command: 0:VX:VY:YAW_RATE)");
      }
    }
    if (options->controller != "nmpc") {
      for (const CLI::Option* option : nmpc_only) {
        if (option->count() > 0) {
          throw CLI::ValidationError(option->get_name(),
                                     "is used only by --controller nmpc (drop the option or add "
                                     "--controller nmpc)");
        }
      }
    }
    // perception_only[2], [4]: --log-map and --log-map-rate.
    if (perception_only[4]->count() > 0 && perception_only[2]->count() == 0) {
      throw CLI::ValidationError("--log-map-rate",
                                 "is used only with --log-map (no map log is written without "
                                 "it)");
    }
    if (estimator_config->count() > 0 && options->state_source != "inekf") {
      throw CLI::ValidationError("--estimator-config",
                                 "is read only with --state-source inekf (the state here is "
                                 "the simulator's ground truth)");
    }
    if (options->controller != "drive") {
      for (const CLI::Option* option : {speed, turn_speed}) {
        if (option->count() > 0) {
          throw CLI::ValidationError(
              option->get_name(), "is used only by --controller drive; the " + options->controller +
                                      " controller holds the wheels at rest (drop the "
                                      "option or add --controller drive)");
        }
      }
    }
    runSim(*options);
  });
}

}  // namespace rollstep::apps
