#pragma once
// One `rollstep sim` run of a scenario: started as a child process into its own folder, then
// judged from what it wrote (log.csv, mpc.csv, summary.txt, FAILED) against the criteria.
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "log_table.hpp"
#include "metrics.hpp"
#include "rollstep/sim/robot_folder.hpp"
#include "rollstep/sim/run_spec.hpp"
#include "rollstep/sim/scene.hpp"
#include "scenarios.hpp"

namespace rollstep::experiments {

struct RunOutcome {
  std::string name;     ///< the scenario's name
  std::string dir;      ///< its output folder
  std::string command;  ///< the exact command that ran (shell-quoted)
  std::string spec;     ///< the run spec it was given (its spec.yaml's text)
  int exit_status = -1;
  std::string error;  ///< why the run itself failed (sim's FAILED or stderr), else empty
  std::optional<LogTable> log;
  std::optional<LogTable> mpc;
  std::string summary;  ///< summary.txt
  RunAssessment assessment;
  double up_height = 0.0;      ///< [m] traverse window threshold used
  TraverseLegs traverse_legs;  ///< the legs that open and close the traverse window
  bool passed() const { return error.empty() && log.has_value() && assessment.passed(); }
  /// The reasons it failed, joined ("" when it passed).
  std::string failureText() const;
};

/// The scene a scenario runs in (its scene_config file if any, the scene name on top).
sim::SceneConfig sceneOf(const Scenario& scenario);
/// The robot MJCF the run uses (its --robot option, or the default).
std::string robotOf(const Scenario& scenario);

/// The command's --robot (a robot name or folder) for every scenario of `set`, as its
/// `rollstep sim` option; "" leaves the set as it is. Throws InputError naming a scenario
/// whose args name a robot of their own.
void setRobot(ExperimentSet& set, const std::string& robot);

/// Plant options of a --robot value (a robot name or folder; "" = the default robot).
sim::PlantOptions plantOptionsOfRobot(const std::string& robot);

/// Joint limits of the robot's MJCF (the range of each joint of its legs); `robot` as
/// plantOptionsOfRobot.
std::vector<JointLimit> jointLimits(const sim::SceneConfig& scene, const std::string& robot);

/// Runs `rollstep sim --spec` for the scenario with the run spec `run` (its outputs in
/// run.out, created; the spec written there as spec.yaml); `on_progress(sim_time,
/// duration)` is called from the run's progress lines. Then judges it (judgeRun).
RunOutcome executeRun(const Scenario& scenario, const sim::RunSpec& run,
                      const sim::SceneConfig& scene, const RunCriteria& criteria,
                      const std::function<void(double, double)>& on_progress = {});

/// Judges the outputs in `dir` of a finished run (exit_status of the process).
RunOutcome judgeRun(const Scenario& scenario, const sim::SceneConfig& scene, const std::string& dir,
                    int exit_status, const RunCriteria& criteria);

}  // namespace rollstep::experiments
