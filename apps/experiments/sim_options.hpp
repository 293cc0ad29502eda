#pragma once
// The options of `rollstep sim` and the run spec they give (sim::RunSpec). `rollstep sim`
// registers them; the report and the trials parse a scenario's options with them once, in
// their own process, and hand the child run the spec file.
#include <CLI/CLI.hpp>
#include <memory>
#include <string>
#include <vector>

#include "rollstep/sim/run_spec.hpp"

namespace rollstep::apps {

/// The options as typed (the spec's defaults where a value is not given).
struct SimOptions {
  std::string spec;  ///< --spec FILE: the whole run from a file
  std::string scene = "flat";
  std::string scene_config;
  std::string controller = "stand";
  double duration = 10.0;
  std::string out = "out/sim";
  double speed = 0.5;
  double turn_speed = 0.0;
  int log_every = 10;
  std::string robot;
  std::string gait = "standing";
  double vx = 0.0, vy = 0.0, yaw_rate = 0.0;
  std::string command_schedule;  ///< --command: "" = the constant --vx, --vy, --yaw-rate
  std::string control_config;
  std::string robot_description;  ///< refused: folded into --robot
  std::string mpc_timing;         ///< "" = the control settings'
  std::string integrator;         ///< "" = the control settings'
  std::string terrain = "scene";
  std::string lidar_config, perception_config;
  std::string log_map;
  std::string perception_timing;
  double log_map_rate = 2.0;
  std::string state_source = "ground_truth";
  std::string estimator_config;
  bool log_violations = false;
  std::string sensor_config;
};

/// The registered options of one command (for the checks of which go together).
class SimOptionSet {
 public:
  /// Adds every `rollstep sim` option to `cmd`, parsed into `options`.
  SimOptionSet(CLI::App& cmd, SimOptions& options);
  /// The checks of options that only apply together (throws CLI::ValidationError naming
  /// the option), then the run spec they give.
  sim::RunSpec runSpec() const;

 private:
  void addSceneOptions(CLI::App& cmd);
  void addCommandOptions(CLI::App& cmd);
  void addTerrainOptions(CLI::App& cmd);
  void addStateOptions(CLI::App& cmd);
  void addRunOptions(CLI::App& cmd);
  void checkCombinations() const;
  void checkSpecAlone() const;

  SimOptions* o_;
  CLI::App* cmd_;
  CLI::Option* spec_ = nullptr;
  CLI::Option* out_ = nullptr;
  CLI::Option* speed_ = nullptr;
  CLI::Option* turn_speed_ = nullptr;
  CLI::Option* command_ = nullptr;
  CLI::Option* estimator_config_ = nullptr;
  CLI::Option* old_description_ = nullptr;
  CLI::Option* log_map_ = nullptr;
  CLI::Option* log_map_rate_ = nullptr;
  std::vector<CLI::Option*> constant_command_;  ///< --vx, --vy, --yaw-rate
  std::vector<CLI::Option*> pipeline_only_;     ///< nmpc and cbfqp
  std::vector<CLI::Option*> nmpc_only_;
  std::vector<CLI::Option*> perception_only_;
};

/// Parses --command "T:VX[:VY[:YAW]],...": one segment per comma, times [s] from the start
/// (the first 0, increasing, before `duration`), speeds within --vx's, --vy's and
/// --yaw-rate's ranges. Throws CLI::ValidationError naming --command.
std::vector<planning::TimedBaseCommand> parseCommandSchedule(const std::string& text,
                                                             double duration);

/// The run spec of `rollstep sim` options given as words (no program name, no "sim"), e.g.
/// a scenario's: the same parsing and checks as the command line. Throws
/// std::invalid_argument with CLI11's message naming the option.
sim::RunSpec runSpecFromSimArgs(const std::vector<std::string>& args);

}  // namespace rollstep::apps
