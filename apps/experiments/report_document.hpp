#pragma once
// What `rollstep report` says: the inputs its stages share, what each stage left (the runs'
// outcomes, the figures, pictures and replay pages made or why not, the acceptance verdict),
// and the document composed from them, section by section. Nothing is run or drawn here (the
// composition reads only which figure files exist and figures.err): the document shows what
// the stages made, so that it cannot claim more than they did.
#include <cstddef>
#include <string>
#include <vector>

#include "document.hpp"
#include "rollstep/sim/scene.hpp"
#include "runs.hpp"
#include "scenarios.hpp"
#include "speed_sweep.hpp"
#include "trials.hpp"

namespace rollstep::experiments {

/// What every stage of the report reads: the experiments after --only, the trial results
/// given, where the report goes and the command that made it.
struct ReportInputs {
  ExperimentSet set;  ///< the scenarios to run (--only applied)
  /// The file's acceptance whatever --only kept: its trial part is judged on trial results.
  Acceptance file_acceptance;
  std::vector<sim::SceneConfig> scenes;  ///< scenes[i]: where set.scenarios[i] runs
  std::vector<std::string> trial_dirs;   ///< --trials, as given
  TrialCollection trials;                ///< the results found under trial_dirs
  std::vector<TrialAggregate> trial_aggregates;
  std::string out;                ///< the report's folder (absolute)
  std::vector<std::string> argv;  ///< the command, as the report quotes it
  bool videos = true;             ///< false with --no-videos
};

/// A file of the report beside report.md and what the document says of it.
struct ReportFile {
  std::string file;     ///< relative to the report's folder
  std::string caption;  ///< a caption, or a replay page's title
};

/// Snapshots and videos made, or why not.
struct ReportPictures {
  std::string render_gap;  ///< why nothing could be rendered, or ""
  std::string video_gap;   ///< why no video was made, or ""
  std::vector<ReportFile> snapshots, videos;
  std::vector<std::string> failures;  ///< "scenario: reason" of the runs whose pictures failed
};

/// The interactive replay pages made, and the runs whose page failed.
struct ReportReplays {
  std::vector<ReportFile> pages;
  std::vector<std::string> failures;  ///< "scenario: reason"
};

/// One Table 1 margin of the acceptance: the candidate's relative change against the baseline.
struct MarginVerdict {
  std::string metric;  ///< "traverse time", "mean |v_z|", "mean |w_y|"
  double change = 0.0;
  double margin = 0.0;  ///< the largest change allowed
  bool met = false;
};

/// The acceptance criteria of the experiments file, judged on the runs and on the trials.
struct ReportVerdict {
  // On the runs: the candidate against the baseline (when both were run).
  bool runs_given = false;
  std::size_t candidate = 0, baseline = 0;  ///< their indices in the outcomes
  bool runs_compared = false;               ///< both passed with metrics: margins judged
  std::vector<MarginVerdict> margins;
  bool runs_met = true;
  // On the trials (when trial results were given): the candidate's success rate.
  bool trials_judged = false;
  PairedComparison trials;
  bool trials_met = true;
  // The speed sweep (when the experiments file has one): its runs and its comparison.
  std::vector<SweepSeries> sweep_series;
  SweepVerdict sweep;

  bool judged() const { return runs_given || trials_judged || sweep.judged; }
  bool met() const { return runs_met && trials_met && sweep.met(); }
};

/// What the report's stages made, in the order they ran.
struct ReportResults {
  std::vector<RunOutcome> outcomes;  ///< outcomes[i]: set.scenarios[i]
  std::string figures_gap;           ///< why no figure could be drawn, or ""
  ReportPictures pictures;
  ReportReplays replays;
  ReportVerdict verdict;
};

/// The document and the warnings composing it raised (a figure the script did not draw).
struct ComposedReport {
  Document document;
  std::vector<std::string> warnings;
};

/// report.md and report.html's content: the introduction, the runs, Table 1 and the
/// acceptance, the figures, snapshots, videos and replays, the trials, how each run was made
/// and the experiments file.
ComposedReport composeReport(const ReportInputs& in, const ReportResults& results);

/// `v` with `digits` decimals, "-" when not finite.
std::string decimalText(double v, int digits);
/// `v` as a signed whole percentage ("+12 %"), "-" when not finite.
std::string percentText(double v);

}  // namespace rollstep::experiments
