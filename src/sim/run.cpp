#include "rollstep/sim/run.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>

#include "rollstep/centroidal/centroidal_ocp.hpp"
#include "rollstep/common/number_text.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/perception/terrain_perception.hpp"
#include "rollstep/sim/estimator_source.hpp"
#include "rollstep/sim/lidar.hpp"
#include "rollstep/sim/online_perception.hpp"
#include "rollstep/sim/scene_terrain.hpp"
#include "rollstep/sim/simple_controllers.hpp"

namespace rollstep::sim {

namespace {

/// The robot folder of the spec ("" = the default robot), its files checked against each
/// other.
RobotFolder robotFolderOf(const RunSpec& spec) {
  std::error_code ec;
  if (!spec.robot.empty() && std::filesystem::is_regular_file(spec.robot, ec)) {
    throw RunSpecError("robot", "'" + spec.robot +
                                    "' is a file; a robot is a name (robots/NAME) or a robot "
                                    "folder holding centroidal.yaml and the MJCF <folder "
                                    "name>.xml (docs/ROBOTS.md)");
  }
  RobotFolder folder = spec.robot.empty() ? defaultRobotFolder() : findRobotFolder(spec.robot);
  requireConsistentRobotFolder(folder);
  return folder;
}

/// The plant's sensors: the spec's file, else with the estimator the robot's own
/// (sensors.yaml, else the defaults), else ideal.
PlantOptions plantOptionsOf(const RunSpec& spec, const RobotFolder& robot) {
  PlantOptions options = plantOptionsFor(robot);
  if (!spec.sensor_config.empty()) {
    options.sensor_noise = loadSensorNoiseConfig(spec.sensor_config);
  } else if (spec.state_source == StateSourceKind::Inekf) {
    options.sensor_noise =
        robot.sensors.empty() ? SensorNoiseConfig{} : loadSensorNoiseConfig(robot.sensors);
  }
  return options;
}

/// The robot folder's OCP description, checked against the plant: the OCP's forces act
/// contact_offset below the wheel centres, so an offset that is not the simulated wheels'
/// radius would plan every contact off the ground.
centroidal::RobotOcpDescription loadCheckedDescription(const BuiltRun& run) {
  const std::string& description = run.robot.description;
  const Plant& plant = *run.plant;
  centroidal::RobotOcpDescription robot = centroidal::loadRobotOcpDescription(description);
  for (int leg = 0; leg < plant.layout().numLegs(); ++leg) {
    if (std::abs(robot.contact_offset - plant.wheelRadius(leg)) > 1e-4) {
      throw InputError("robot description '" + description +
                       "': contact_offset: " + shortestNumberText(robot.contact_offset) +
                       " m is not the wheel radius of the robot MJCF '" + plant.robotFile() +
                       "' (" + shortestNumberText(plant.wheelRadius(leg)) + " m, " +
                       plant.layout().legs[static_cast<std::size_t>(leg)].contact_frame + ")");
    }
  }
  return robot;
}

/// The cbfqp controller reads a control file's `baseline:` section: a file without one (an
/// NMPC behaviour file) would silently run the baseline on the defaults, not its tuning.
control::ControlSettings loadBaselineSettings(const std::string& path) {
  std::set<std::string> sections;
  control::ControlSettings settings = control::loadControlSettings(path, &sections);
  if (sections.count("baseline") == 0) {
    throw RunSpecError(
        "control_config",
        "'" + path +
            "' has no baseline: section, the cbfqp controller's tuning (an NMPC file? the "
            "baseline's is config/baseline.yaml; write 'baseline: {}' for its defaults)");
  }
  return settings;
}

/// The NMPC's control settings: the spec's file, else the robot folder's own of the name,
/// else the project's default (the library's on ground truth, config/nmpc_perception.yaml
/// over them on perception); the spec's timing and integrator over them.
control::ControlSettings nmpcSettings(const RunSpec& spec, const RobotFolder& robot) {
  const bool perception = spec.terrain == TerrainSource::Perception;
  control::ControlSettings settings;
  if (spec.control) {
    settings = *spec.control;
  } else {
    std::string file = spec.control_config;
    if (file.empty()) {
      file = robot.optionalFile(perception ? "nmpc_perception.yaml" : "nmpc.yaml");
    }
    if (file.empty() && perception) file = projectConfigFile("nmpc_perception.yaml");
    if (!file.empty()) settings = control::loadControlSettings(file);
  }
  if (spec.mpc_timing == TimingChoice::Deterministic) {
    settings.mpc.timing = control::MpcTiming::Deterministic;
  }
  if (spec.mpc_timing == TimingChoice::Asynchronous) {
    settings.mpc.timing = control::MpcTiming::Asynchronous;
  }
  if (spec.integrator == IntegratorChoice::Internal) {
    settings.integrator.mode = control::IntegratorMode::Internal;
  }
  if (spec.integrator == IntegratorChoice::Naive) {
    settings.integrator.mode = control::IntegratorMode::Naive;
  }
  return settings;
}

/// Perception in closed loop: the sensor and perception settings, started at the plant's
/// pose (its first terrain built), with the map log if asked for.
std::unique_ptr<OnlinePerception> startPerception(const RunSpec& spec, const RobotFolder& robot,
                                                  const Plant& plant, bool asynchronous_default) {
  OnlinePerceptionOptions options;
  options.asynchronous = spec.perception_timing == TimingChoice::Default
                             ? asynchronous_default
                             : spec.perception_timing == TimingChoice::Asynchronous;
  if (!spec.lidar_config.empty()) {
    options.lidar = loadLidarSettings(spec.lidar_config);
  } else if (!robot.lidar.empty()) {
    options.lidar = loadLidarSettings(robot.lidar);
  }
  if (!spec.perception_config.empty()) {
    options.perception = perception::loadPerceptionSettings(spec.perception_config);
  }
  options.log_dir = spec.map_log;
  options.log_rate = spec.map_log_rate;
  auto p = std::make_unique<OnlinePerception>(options);
  p->start(plant, plant.groundTruth().base_position, plant.groundTruth().base_orientation);
  return p;
}

/// The state the NMPC runs on: ground truth, or the estimator with its tuning (the spec's
/// file, else the robot folder's).
StateSourceOptions stateSourceOf(const RunSpec& spec, const RobotFolder& robot) {
  StateSourceOptions source;
  source.kind = spec.state_source;
  if (source.kind == StateSourceKind::Inekf) {
    if (spec.estimator_config.empty() && robot.estimation.empty()) {
      throw InputError("robot folder '" + robot.directory +
                       "': no estimation.yaml (the state estimator's tuning) for "
                       "state_source inekf (--state-source inekf); add it or give "
                       "estimator_config (--estimator-config)");
    }
    source.estimator = estimation::loadInekfSettings(
        spec.estimator_config.empty() ? robot.estimation : spec.estimator_config);
  }
  return source;
}

std::string commandText(const std::vector<planning::TimedBaseCommand>& schedule) {
  std::string out;
  for (const planning::TimedBaseCommand& c : schedule) {
    out += formatText(
        "%s(%s m/s, %s m/s, %s rad/s)%s", out.empty() ? "" : ", ",
        shortestNumberText(c.command.v_x).c_str(), shortestNumberText(c.command.v_y).c_str(),
        shortestNumberText(c.command.yaw_rate).c_str(),
        schedule.size() > 1 ? (" from " + shortestNumberText(c.time) + " s").c_str() : "");
  }
  return out;
}

void buildNmpc(BuiltRun& run) {
  const RunSpec& spec = run.spec;
  const Plant& plant = *run.plant;
  const centroidal::RobotOcpDescription robot = loadCheckedDescription(run);
  const control::ControlSettings settings = nmpcSettings(spec, run.robot);
  // The terrain source: the scene's ground truth, or perception in closed loop (the LiDAR's
  // view from the start pose first, then every scan), regions shrunk alike.
  const double margin = centroidal::footholdRegionMargin(robot, settings.ocp);
  const bool perception = spec.terrain == TerrainSource::Perception;
  planning::TerrainModel terrain;
  std::string terrain_text = "scene ground truth";
  std::unique_ptr<OnlinePerception> online;
  int edge_capacity = 0;
  if (perception) {
    online = startPerception(spec, run.robot, plant,
                             settings.mpc.timing == control::MpcTiming::Asynchronous);
    terrain = online->footholdTerrain(margin);
    edge_capacity = online->perception().settings().regions.directions;
    terrain_text = formatText(
        "perception in closed loop (%d convex regions at the start from %d "
        "LiDAR scans, then one terrain per scan)",
        terrain.size(), online->perception().settings().closed_loop.warmup_scans);
  } else {
    terrain = terrainFromScene(run.scene, margin);
  }
  auto nmpc =
      std::make_unique<NmpcController>(plant, robot, settings, terrain, spec.gait, spec.command,
                                       stateSourceOf(spec, run.robot), edge_capacity);
  if (online) nmpc->setPerception(std::move(online), margin);
  nmpc->enablePlanLog(kPlanNodeStride, spec.duration);
  nmpc->reserveUpdateLog(spec.duration);
  if (perception) nmpc->enableTerrainLog();
  run.start_regions = terrain;
  run.start_regions_source = perception ? "perception at the start" : "scene";
  if (spec.log_violations) {
    if (settings.mpc.timing != control::MpcTiming::Deterministic) {
      throw RunSpecError("log_violations", "needs deterministic MPC timing (mpc_timing)");
    }
    nmpc->enableViolationLog();
  }
  const solver::SolverStatus first = nmpc->initialStatus();
  const control::MpcRunner& runner = nmpc->pipeline().runner();
  run.controller_text = formatText(
      "nmpc (gait %s, command %s, MPC every %s s %s, N = %d, integrator %s, state %s; first "
      "solve %s in %d iterations); terrain %s",
      enumName(spec.gait), commandText(spec.command).c_str(),
      shortestNumberText(settings.mpc.period).c_str(), control::toString(settings.mpc.timing),
      settings.ocp.horizon, control::toString(settings.integrator.mode),
      enumName(spec.state_source), solver::toString(first), runner.initialIterations(),
      terrain_text.c_str());
  if (first != solver::SolverStatus::Converged && first != solver::SolverStatus::Acceptable) {
    // Not an error (the real-time iterations go on from its iterate, the CBF-QP falls back
    // until their first usable solution), but the run's start is not what it seems.
    std::fprintf(stderr,
                 "rollstep sim: warning: the first MPC solve ended %s after %d iterations%s%s\n",
                 solver::toString(first), runner.initialIterations(),
                 runner.initialMessage().empty() ? "" : ": ", runner.initialMessage().c_str());
  }
  run.nmpc = nmpc.get();
  run.controller = std::move(nmpc);
}

void buildCbfQp(BuiltRun& run) {
  const RunSpec& spec = run.spec;
  const Plant& plant = *run.plant;
  const centroidal::RobotOcpDescription robot = loadCheckedDescription(run);
  std::string config = spec.control_config;
  if (config.empty()) {
    config = run.robot.optionalFile("baseline.yaml");
    if (config.empty()) config = projectConfigFile("baseline.yaml");
  }
  control::ControlSettings settings;
  if (spec.control) {
    settings = *spec.control;
    config = "control settings given";
  } else if (!spec.control_config.empty()) {
    settings = loadBaselineSettings(config);
  } else {
    settings = control::loadControlSettings(config);
  }
  const planning::BaseVelocityCommand command = spec.command.front().command;
  std::unique_ptr<CbfQpController> cbfqp;
  std::string terrain_text = "scene ground truth";
  if (spec.terrain == TerrainSource::Perception) {
    // Perceived surfaces: unshrunk as the collision solids, shrunk as the footholds.
    std::unique_ptr<OnlinePerception> online = startPerception(spec, run.robot, plant, false);
    cbfqp = std::make_unique<CbfQpController>(
        plant, robot, settings, online->footholdTerrain(settings.baseline.foothold_margin),
        online->terrain(), spec.gait, command, online->perception().settings().regions.directions,
        online->perception().settings().closed_loop.collision_capacity);
    terrain_text =
        formatText("perception in closed loop (%d regions at the start, then one terrain per scan)",
                   online->terrain().size());
    cbfqp->setPerception(std::move(online));
    cbfqp->enableTerrainLog();
    run.start_regions = cbfqp->pipeline().terrain();
    run.start_regions_source = "perception at the start";
  } else {
    cbfqp = std::make_unique<CbfQpController>(
        plant, robot, settings, terrainFromScene(run.scene, settings.baseline.foothold_margin),
        terrainFromScene(run.scene, 0.0), spec.gait, command);
    run.start_regions = terrainFromScene(run.scene, settings.baseline.foothold_margin);
    run.start_regions_source = "scene";
  }
  run.controller_text = formatText(
      "cbfqp (CBF-QP baseline, no MPC; gait %s, command (%s m/s, %s m/s, %s rad/s), trot "
      "period %s s; %s); terrain %s",
      enumName(spec.gait), shortestNumberText(command.v_x).c_str(),
      shortestNumberText(command.v_y).c_str(), shortestNumberText(command.yaw_rate).c_str(),
      shortestNumberText(settings.baseline.gait_period).c_str(), config.c_str(),
      terrain_text.c_str());
  run.cbfqp = cbfqp.get();
  run.controller = std::move(cbfqp);
}

void buildDrive(BuiltRun& run) {
  const RunSpec& spec = run.spec;
  const Plant& plant = *run.plant;
  // Each side's wheels run at speed -+ turn_speed: beyond the servos' limit they would be
  // clamped and the robot would not do what was asked.
  if (plant.layout().numDriveWheels() == 0) {
    throw RunSpecError("controller",
                       "drive: the robot '" + plant.robotFile() + "' has no drive wheels");
  }
  double radius = std::numeric_limits<double>::infinity();
  for (const int leg : plant.layout().drive_wheel_legs) {
    radius = std::min(radius, plant.wheelRadius(leg));
  }
  const double limit = plant.wheelSpeedLimit() * radius;
  const double needed = std::abs(spec.drive_speed) + std::abs(spec.drive_turn_speed);
  if (needed > limit) {
    throw RunSpecError(
        "drive_speed",
        formatText("%g with turn speed %g needs a wheel surface speed of %g m/s; the drive wheels "
                   "of this robot reach %.3f m/s (%g rad/s x %g m): valid range |speed| + "
                   "|turn speed| <= %.3f m/s",
                   spec.drive_speed, spec.drive_turn_speed, needed, limit, plant.wheelSpeedLimit(),
                   radius, limit));
  }
  DriveController::Params p;
  p.speed = spec.drive_speed;
  p.turn_speed = spec.drive_turn_speed;
  run.controller = std::make_unique<DriveController>(plant, p);
  std::ostringstream s;
  s << "drive (nominal posture, wheel surface speed " << spec.drive_speed << " m/s, turn "
    << spec.drive_turn_speed << " m/s)";
  run.controller_text = s.str();
}

}  // namespace

OnlinePerception* BuiltRun::perception() const {
  if (nmpc != nullptr) return nmpc->perception();
  if (cbfqp != nullptr) return cbfqp->perception();
  return nullptr;
}

std::string projectConfigFile(const std::string& name) {
  if (const char* dir = std::getenv("ROLLSTEP_CONFIG_DIR"); dir != nullptr && *dir != '\0') {
    return std::string(dir) + "/" + name;
  }
  return std::string(ROLLSTEP_CONFIG_DIR) + "/" + name;
}

BuiltRun buildRun(const RunSpec& spec) {
  checkRunSpec(spec);
  BuiltRun run;
  run.spec = spec;
  run.scene = sceneOf(spec);
  // The robot folder, its files checked against each other before anything runs.
  run.robot = robotFolderOf(spec);
  run.plant = std::make_unique<Plant>(run.scene, plantOptionsOf(spec, run.robot));
  switch (spec.controller) {
    case ControllerKind::Stand:
      run.controller = std::make_unique<StandController>(run.plant->nominalCommand());
      run.controller_text = "stand (nominal posture, wheels at rest)";
      break;
    case ControllerKind::Nmpc:
      buildNmpc(run);
      break;
    case ControllerKind::CbfQp:
      buildCbfQp(run);
      break;
    case ControllerKind::Drive:
      buildDrive(run);
      break;
  }
  return run;
}

}  // namespace rollstep::sim
