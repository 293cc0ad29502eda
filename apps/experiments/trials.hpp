#pragma once
// Randomized trials: every random quantity of a trial is drawn from its seed alone
// (splitmix64, the same numbers on any machine and compiler), so that a trial is one
// self-contained command and its result file can be written anywhere and collected later.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "rollstep/sim/run_spec.hpp"
#include "rollstep/sim/scene.hpp"
#include "rollstep/sim/sensor_model.hpp"
#include "scenarios.hpp"

namespace rollstep::experiments {

struct TrialParameters {
  std::uint64_t seed = 0;
  /// The scene numbers drawn (TrialRanges::scene's names and values, in its order; a
  /// result read back from its file has no key paths).
  struct SceneValue {
    std::string name;
    std::string key;
    bool offset = false;
    double value = 0.0;
  };
  std::vector<SceneValue> scene;
  /// The drawn value named `name`; throws std::out_of_range when there is none.
  double sceneValue(const std::string& name) const;
  /// Scale of the sensor noise: every white-noise density, bias random walk and initial
  /// bias of sim::SensorNoiseConfig's defaults times this (trialSensorNoise); encoder
  /// resolutions and the contact-flag threshold stay as they are.
  double sensor_noise = 0.0;
  /// [m/s] The command speed, drawn after the others (the same terrains as without it);
  /// 0: not drawn (the experiments file gives no speed range).
  double speed = 0.0;
};

/// The parameters of trial `seed`: each uniform in its range of `ranges`.
TrialParameters drawTrial(std::uint64_t seed, const TrialRanges& ranges);
/// The scenario a trial runs: `s` with its command at the trial's speed when one was drawn
/// (Scenario::speed; its run spec is then specAtSpeed's).
Scenario trialScenario(const Scenario& s, const TrialParameters& p);
/// `spec` with its command at `speed` [m/s] (0: as it is). One constant command: its v_x
/// set to the speed (sign kept), the duration scaled by |v_x| / speed; a schedule: every
/// speed scaled by the speed over the schedule's largest |v_x| (direction and sign kept), its
/// times and the duration by the inverse (the same path; entries rounded to 1e-4). Both plus
/// kTrialSpeedMargin seconds (the ramp from rest and slowdowns at steps). A spec with no
/// forward command is returned as it is.
sim::RunSpec specAtSpeed(const sim::RunSpec& spec, double speed);
inline constexpr double kTrialSpeedMargin = 6.0;  ///< [s]
/// `base` with the trial's scene numbers (each replacing the file's number, or added to it);
/// a number the scene does not have (the step height of the flat floor) is left out
/// (`rollstep trials` says so before the trials start).
sim::SceneConfig trialScene(const sim::SceneConfig& base, const TrialParameters& p);
/// The same as the numbers a run spec sets (RunSpec::scene_parameters): key path and value.
std::vector<sim::SceneNumberValue> trialSceneNumbers(const sim::SceneConfig& base,
                                                     const TrialParameters& p);
/// The trial's sensor noise: the defaults scaled by p.sensor_noise, seeded with p.seed.
sim::SensorNoiseConfig trialSensorNoise(const TrialParameters& p);
/// Whether a scenario's controller reads the (noisy) sensors: `--state-source inekf`
/// (the others run on ground truth, so a trial's sensor noise does not reach them).
bool readsSensors(const Scenario& s);

/// "0-29", "7", "1,5,9-12" -> the seeds in order; throws std::invalid_argument naming the text.
std::vector<std::uint64_t> parseSeeds(const std::string& text);

/// One trial's result (result.yaml).
struct TrialResult {
  std::string scenario, controller;
  TrialParameters parameters;
  bool sensor_noise_applied = false;
  bool passed = false;
  std::string failure;  ///< why not passed
  std::optional<double> traverse_time, mean_abs_vz, mean_abs_wy;
  std::string command;  ///< the command that reproduces it
  std::string source;   ///< file it was read from
};

std::string toYaml(const TrialResult& r);
/// Throws std::runtime_error "<source>: line L: <key>: <problem>" for malformed files.
TrialResult parseTrialResult(const std::string& text, const std::string& source);

/// Statistics of one metric over the passed trials.
struct Spread {
  int n = 0;
  double mean = 0.0, stddev = 0.0, min = 0.0, max = 0.0;
};
Spread spreadOf(const std::vector<double>& values);

/// Aggregate of the results of one scenario.
struct TrialAggregate {
  std::string scenario, controller;
  int trials = 0, passed = 0;
  Spread traverse_time, mean_abs_vz, mean_abs_wy;
  std::vector<std::string> failures;  ///< "seed 7: <reason>"
  double successRate() const { return trials > 0 ? static_cast<double>(passed) / trials : 0.0; }
};

/// Results grouped by scenario (in order of first appearance), seeds sorted; a seed given
/// twice for the same scenario is an error naming both files.
std::vector<TrialAggregate> aggregate(std::vector<TrialResult> results);
/// A trial folder found without a result that can be counted.
struct UncountedTrial {
  std::string dir;
  std::string reason;       ///< e.g. "unfinished: rollstep trials failed: interrupted by SIGINT"
  bool unreadable = false;  ///< a result.yaml that is there but is not a valid result
};
/// What the trial folders under some folders hold.
struct TrialCollection {
  std::vector<TrialResult> results;
  std::vector<UncountedTrial> uncounted;  ///< unfinished or unreadable, sorted by path
  int folders = 0;                        ///< trial folders found: results + uncounted
};
/// Every trial folder under the folders, recursively (symbolic links to folders followed,
/// each folder once): a folder holding a result.yaml, or named <scenario>_seed<digits> as
/// `rollstep trials` names them. A folder without a readable result.yaml is uncounted, with
/// the reason: unfinished (its FAILED, or no result.yaml: the trial never ended) or
/// unreadable (not a regular file, malformed, a field out of its range). Throws InputError
/// for a folder given that is not one.
TrialCollection collectTrials(const std::vector<std::string>& dirs);
/// collectTrials, but every uncounted folder is an error: throws std::runtime_error naming
/// the first one and why (the results of an unfinished run would be counted as a whole).
std::vector<TrialResult> collectResults(const std::vector<std::string>& dirs);
/// Two scenarios' trials compared seed by seed: the means of each Table 1 metric over the
/// seeds that both passed (the same step height, friction and start offset for both), so
/// that the draw of the terrain does not weigh on one side only.
struct PairedComparison {
  std::string candidate, baseline;
  int candidate_trials = 0, baseline_trials = 0;  ///< results found of each
  int candidate_passed = 0, baseline_passed = 0;
  int common = 0;  ///< seeds both ran
  int paired = 0;  ///< seeds both passed, with all three metrics: the means below
  double candidate_traverse_time = 0.0, baseline_traverse_time = 0.0;
  double candidate_mean_abs_vz = 0.0, baseline_mean_abs_vz = 0.0;
  double candidate_mean_abs_wy = 0.0, baseline_mean_abs_wy = 0.0;
  double candidateSuccessRate() const {
    return candidate_trials > 0 ? static_cast<double>(candidate_passed) / candidate_trials : 0.0;
  }
  double baselineSuccessRate() const {
    return baseline_trials > 0 ? static_cast<double>(baseline_passed) / baseline_trials : 0.0;
  }
};
/// The comparison of the results of scenario `candidate` against those of `baseline`.
PairedComparison compareTrials(const std::vector<TrialResult>& results,
                               const std::string& candidate, const std::string& baseline);

/// Markdown text of the aggregates.
std::string aggregateMarkdown(const std::vector<TrialAggregate>& aggregates);

}  // namespace rollstep::experiments
