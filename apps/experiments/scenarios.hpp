#pragma once
// The experiments as data (config/experiments.yaml): each scenario is a `rollstep sim` run
// (scene, controller, duration, its other options as they are typed) and the parts of the
// report it feeds; the pass criteria, the acceptance margins of the comparison and the
// ranges of the randomized trials. The report and the trials know nothing else about a
// controller: a new one is a new entry.
#include <string>
#include <vector>

#include "metrics.hpp"
#include "rollstep/sim/run_spec.hpp"

namespace rollstep::experiments {

/// The paper's Table 1 figures for one controller (NaN when the paper has none).
struct PaperFigures {
  double traverse_time = 0.0;  ///< [s]
  double mean_abs_vz = 0.0;    ///< [m/s]
  double mean_abs_wy = 0.0;    ///< [rad/s]
  bool given = false;
};

struct Scenario {
  std::string name;          ///< output folder name: letters, digits, '_' and '-'
  std::string title;         ///< shown in tables and legends
  std::string scene;         ///< a scene name (sim::sceneNames(); rollstep sim --scene)
  std::string scene_config;  ///< optional scene YAML (absolute, resolved from the file)
  std::string controller;    ///< rollstep sim --controller
  /// Optional control settings YAML (rollstep sim --control-config; absolute, resolved from
  /// the experiments file's folder like scene_config), e.g. behaviours/climb.yaml.
  std::string control_config;
  double duration = 10.0;         ///< [s]
  std::vector<std::string> args;  ///< the run's other `rollstep sim` options, as typed
  /// Terrain source: "scene" (the scene's ground-truth regions) or "perception" (rollstep
  /// sim --terrain perception: perception in closed loop).
  std::string terrain = "scene";
  bool traverse = false;  ///< must traverse the step(s) to pass
  /// Parts of the report: table1 (Table 1 and Fig. 2), fig4 (stairs histories), fig6 (MPC
  /// CPU time), fig8 (joint commands, integrator comparison), snapshots, map (top view of
  /// the perceived map, regions and footholds: terrain perception only; the run then logs
  /// its map, --log-map DIR/map).
  std::vector<std::string> figures;
  bool video = true;
  PaperFigures paper;
  /// [m/s] > 0: the run's command at this speed (specAtSpeed, trials.hpp): a trial's drawn
  /// speed, a sweep run's speed.
  double speed = 0.0;
  /// A run of the speed sweep: the scenario it repeats at sweep_speed (empty: not one).
  std::string sweep_of;
  double sweep_speed = 0.0;  ///< [m/s]

  bool feeds(const std::string& figure) const;
  /// "scene ground truth" or "perception (closed loop)".
  std::string terrainText() const;
  /// The run of this scenario with outputs in `out_dir` (its map log in out_dir/map when
  /// it feeds the map figure): its keys, and its args parsed as `rollstep sim` parses them
  /// (same checks), its command at `speed` when set. Throws std::invalid_argument naming a
  /// bad option of args.
  sim::RunSpec runSpec(const std::string& out_dir) const;
};

/// The acceptance of the paper's comparison: candidate beats baseline by at least these
/// relative changes (negative: a reduction; -0.2 = 20 % less).
struct Acceptance {
  std::string candidate, baseline;
  double traverse_time = -0.20;
  double mean_abs_vz = -0.50;
  double mean_abs_wy = -0.10;
  /// The least share of the candidate's randomized trials that must pass (checked when the
  /// report is given trial results of the candidate).
  double trial_success_rate = 0.95;
  bool given = false;
};

/// Whether `name` can name a drawn scene number in a trial's result.yaml: a letter, then
/// letters, digits and _ (at most 64), and not one of result.yaml's own keys.
bool isDrawName(const std::string& name);

/// A number of the scenario's scene file that trials draw (sim::setSceneNumber's key
/// paths: a parameter, friction, boxes[0].size[2], ...).
struct SceneDraw {
  std::string name;     ///< its key in a trial's result.yaml
  std::string key;      ///< its key path in the scene file
  bool offset = false;  ///< true: the draw is added to the file's value; false: replaces it
  double min = 0.0, max = 0.0;
};

/// Ranges of the randomized trials: each value is drawn uniformly in [min, max], the scene
/// numbers first (in their order), then the sensor noise and the speed.
struct TrialRanges {
  std::vector<SceneDraw> scene{
      {"step_height", "step1_height", false, 0.10, 0.20},  // [m] height of the first step
      {"friction", "friction", false, 0.6, 1.0},           // terrain friction
      {"start_offset", "start_x", true, -0.2, 0.2},        // [m] added to start_x
  };
  double sensor_noise_min = 0.5, sensor_noise_max = 1.5;  ///< scale of the sensor noise
  /// [m/s] The command speed (optional): each trial's --vx, or its --command schedule's
  /// speeds, scaled to a speed drawn here (trialScenario).
  bool has_speed = false;
  double speed_min = 0.05, speed_max = 0.5;
};

/// The speed sweep (`speed_sweep:`): each of `scenarios` run again at each of `speeds`
/// (its --vx or --command scaled to the speed as a trial's, trialScenario), and the
/// comparison of `candidate` against `baseline` (two of them) over the sweep: at each of
/// `compared_speeds` the candidate's mean |v_z| and mean |w_y| at most max_ratio times the
/// baseline's, and the candidate's traverse time at its fastest passing speed no longer
/// than the baseline's at its own.
struct SpeedSweep {
  std::vector<std::string> scenarios;
  std::vector<double> speeds;  ///< [m/s], increasing
  std::string candidate, baseline;
  std::vector<double> compared_speeds;  ///< [m/s], each one of speeds
  double max_ratio = 0.7;
  bool given = false;
};

/// The name of `scenario`'s sweep run at `speed`: "<scenario>_v030" for 0.30 m/s (cm/s).
std::string sweepRunName(const std::string& scenario, double speed);

struct ExperimentSet {
  std::string source;  ///< the file it came from
  std::string text;    ///< its text (the report quotes it)
  RunCriteria criteria;
  Acceptance acceptance;
  TrialRanges trials;
  SpeedSweep sweep;
  /// The file's scenarios, then the speed sweep's runs (scenario by scenario, speed by
  /// speed; Scenario::sweep_of set).
  std::vector<Scenario> scenarios;

  /// The scenario named `name`, or nullptr.
  const Scenario* find(const std::string& name) const;
};

/// Reads an experiments file. Throws std::runtime_error "experiments '<file>': line L:
/// <key>: <problem>" for unknown or repeated keys, wrong types, out-of-range numbers,
/// unknown scenes or figure names, repeated scenario names, an acceptance or a speed sweep
/// naming a scenario that is not there (or one without a forward command), and missing
/// required keys (name, scene, controller).
ExperimentSet loadExperimentSet(const std::string& file);
ExperimentSet parseExperimentSet(const std::string& text, const std::string& source,
                                 const std::string& base_dir);

}  // namespace rollstep::experiments
