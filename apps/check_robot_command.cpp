// `rollstep check-robot DIR`: loads every file of a robot folder, cross-checks them, stands
// the robot in the simulator for a few seconds and reports (docs/ROBOTS.md).
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "cli_util.hpp"
#include "commands.hpp"
#include "rollstep/centroidal/loaded_robot.hpp"
#include "rollstep/centroidal/ocp_settings.hpp"
#include "rollstep/estimation/invariant_ekf.hpp"
#include "rollstep/sim/lidar.hpp"
#include "rollstep/sim/plant.hpp"
#include "rollstep/sim/robot_folder.hpp"
#include "rollstep/sim/scenario.hpp"
#include "rollstep/sim/sensor_model.hpp"
#include "rollstep/sim/simple_controllers.hpp"

namespace rollstep::apps {

namespace {

struct CheckRobotOptions {
  std::string robot;
  double duration = 3.0;
  double max_tilt_deg = 2.0;
  double max_sag = 0.03;
  double max_joint_error = 0.02;
};

/// What the stand test saw after the robot settled (the last half of the run).
struct StandResult {
  double start_height = 0.0, end_height = 0.0, min_height = 0.0;  // [m] base centre
  double max_tilt = 0.0;                                          // [rad] from upright
  double max_joint_error = 0.0;  // [rad or m] |measured - commanded|, after settling
  std::string worst_joint;
  double contact_fraction = 0.0;  // of the periods with every wheel in contact
  long body_contact_periods = 0;
  int warnings = 0;
};

StandResult standTest(sim::Plant& plant, double duration) {
  StandResult r;
  const sim::GroundTruth& t = plant.groundTruth();
  r.start_height = r.min_height = t.base_position.z();
  sim::StandController stand(plant.nominalCommand());
  sim::PlantCommand command = plant.nominalCommand();
  const long steps = std::max(1L, std::lround(duration / plant.controlPeriod()));
  long all_contact = 0;
  const sim::PlantLayout& layout = plant.layout();
  for (long k = 1; k <= steps; ++k) {
    stand.compute(plant.time(), plant.sensors(), command);
    plant.setCommand(command);
    plant.step();
    r.min_height = std::min(r.min_height, t.base_position.z());
    const double tilt =
        std::acos(std::clamp((t.base_orientation * Eigen::Vector3d::UnitZ()).z(), -1.0, 1.0));
    r.max_tilt = std::max(r.max_tilt, tilt);
    if (std::all_of(t.foot_contact.begin(), t.foot_contact.end(), [](bool c) { return c; })) {
      ++all_contact;
    }
    if (2 * k < steps) continue;  // settling
    for (int j = 0; j < layout.numJoints(); ++j) {
      const double e = std::abs(t.joint_position[j] - command.joint_position[j]);
      if (e > r.max_joint_error) {
        r.max_joint_error = e;
        r.worst_joint = layout.joints[static_cast<std::size_t>(j)].name;
      }
    }
  }
  r.end_height = t.base_position.z();
  r.contact_fraction = static_cast<double>(all_contact) / static_cast<double>(steps);
  r.body_contact_periods = t.body_contact_periods;
  r.warnings = plant.warningCount();
  return r;
}

int runCheckRobot(const CheckRobotOptions& o) {
  const sim::RobotFolder folder = sim::findRobotFolder(o.robot);
  std::printf("rollstep check-robot: %s\n", folder.directory.c_str());
  std::vector<std::string> problems;
  const auto attempt = [&](const char* what, const auto& load) {
    try {
      load();
      std::printf("  %-12s ok\n", what);
    } catch (const std::exception& e) {
      problems.push_back(e.what());
      std::printf("  %-12s FAILED\n", what);
    }
  };
  // The controllers' side: the description and its URDF (posture, servo stiffness, gait
  // groups), as the OCP and the pipelines load them.
  attempt("description",
          [&] { centroidal::loadRobot(centroidal::loadRobotOcpDescription(folder.description)); });
  if (!folder.estimation.empty()) {
    attempt("estimation", [&] { estimation::loadInekfSettings(folder.estimation); });
  }
  if (!folder.sensors.empty()) {
    attempt("sensors", [&] { sim::loadSensorNoiseConfig(folder.sensors); });
  }
  if (!folder.lidar.empty()) {
    attempt("lidar", [&] { sim::loadLidarSettings(folder.lidar); });
  }
  // The cross-check loads the description again: a problem found by both is listed once,
  // and a cross-check that stopped at it did not compare the files.
  std::size_t new_problems = 0;
  const std::vector<std::string> mismatches = sim::crossCheckRobotFolder(folder);
  for (const std::string& m : mismatches) {
    if (std::find(problems.begin(), problems.end(), m) != problems.end()) continue;
    problems.push_back(m);
    ++new_problems;
  }
  std::printf("  %-12s %s\n", "URDF = MJCF",
              mismatches.empty()  ? "ok"
              : new_problems == 0 ? "not checked: the description does not load"
                                  : "FAILED");
  if (!problems.empty()) {
    std::string text = "robot folder '" + folder.directory +
                       "': " + std::to_string(problems.size()) + " problem" +
                       (problems.size() > 1 ? "s" : "") + ":";
    for (const std::string& p : problems) text += "\n  " + p;
    throw InputError(text);
  }

  sim::Plant plant(sim::SceneConfig{}, sim::plantOptionsFor(folder));
  const sim::PlantLayout& layout = plant.layout();
  std::string legs;
  for (const sim::PlantLayout::Leg& leg : layout.legs) {
    legs += (legs.empty() ? "" : ", ") + leg.name + " (" + std::to_string(leg.joints.size()) +
            " joints" + (leg.drive_wheel >= 0 ? ", driven wheel)" : ")");
  }
  std::printf("  robot        %.3f kg, %d legs: %s\n", plant.totalMass(), layout.numLegs(),
              legs.c_str());
  const StandResult r = standTest(plant, o.duration);
  const double deg = 180.0 / M_PI;
  const double sag = r.start_height - r.end_height;
  std::printf(
      "  stand        %.1f s on flat ground at the nominal posture: base height %.4f m -> %.4f "
      "m (min %.4f m), tilt max %.3f deg, joint error max %.5f (%s) after settling, all wheels "
      "on the ground %.1f %% of the time, body contact %ld periods, MuJoCo warnings %d\n",
      o.duration, r.start_height, r.end_height, r.min_height, r.max_tilt * deg, r.max_joint_error,
      r.worst_joint.empty() ? "-" : r.worst_joint.c_str(), 100.0 * r.contact_fraction,
      r.body_contact_periods, r.warnings);
  std::vector<std::string> failures;
  if (r.body_contact_periods > 0) failures.push_back("the body touched the ground");
  if (r.max_tilt * deg > o.max_tilt_deg) {
    failures.push_back(
        formatText("tilted %.3f deg (--max-tilt %g)", r.max_tilt * deg, o.max_tilt_deg));
  }
  if (sag > o.max_sag) {
    failures.push_back(formatText("sank %.4f m (--max-sag %g)", sag, o.max_sag));
  }
  if (r.max_joint_error > o.max_joint_error) {
    failures.push_back(formatText("joint %s off its target by %.5f (--max-joint-error %g)",
                                  r.worst_joint.c_str(), r.max_joint_error, o.max_joint_error));
  }
  if (r.contact_fraction < 0.5) failures.push_back("not every wheel on the ground");
  if (r.warnings > 0) failures.push_back(std::to_string(r.warnings) + " MuJoCo warnings");
  if (failures.empty()) {
    std::printf("  result       ok: the robot stands\n");
    return 0;
  }
  std::string text;
  for (const std::string& f : failures) text += (text.empty() ? "" : "; ") + f;
  std::printf("  result       FAILED: %s\n", text.c_str());
  return 3;
}

}  // namespace

void registerCheckRobotCommand(CLI::App& app, int& exit_status) {
  auto o = std::make_shared<CheckRobotOptions>();
  CLI::App* cmd = app.add_subcommand(
      "check-robot",
      "Check a robot folder (docs/ROBOTS.md): load every file, cross-check the URDF and the "
      "MJCF (joints, types, axes, limits, masses) and the description (contact frames, "
      "posture, wheel radius), then stand the robot on flat ground in the simulator at its "
      "nominal posture and report its height, tilt and joint errors.");
  cmd->footer(
      "Exit status: 0 when the folder is consistent and the robot stands; 1 when a file is "
      "missing or the files disagree (every problem is listed, naming the file and the item); "
      "3 when it loads but does not stand (the report says what failed).");
  cmd->add_option("ROBOT", o->robot, "A robot name under robots/ or a robot folder path")
      ->required()
      ->check(kNotEmpty);
  cmd->add_option("--duration", o->duration, "Stand test length [s]")
      ->check(numberIn(0.1, 60.0, "s"))
      ->capture_default_str();
  cmd->add_option("--max-tilt", o->max_tilt_deg, "Largest tilt from upright [deg]")
      ->check(numberIn(0.0, 90.0, "deg"))
      ->capture_default_str();
  cmd->add_option("--max-sag", o->max_sag,
                  "Largest drop of the base from its start height [m] (contact penetration "
                  "and servo compliance)")
      ->check(numberIn(0.0, 1.0, "m"))
      ->capture_default_str();
  cmd->add_option("--max-joint-error", o->max_joint_error,
                  "Largest joint position error after settling [rad or m]")
      ->check(numberIn(0.0, 1.0, "rad or m"))
      ->capture_default_str();
  cmd->final_callback([o, &exit_status] { exit_status = runCheckRobot(*o); });
}

}  // namespace rollstep::apps
