#pragma once
// The speed sweep of the experiments file (`speed_sweep:`): its runs gathered per scenario
// in speed order, and the comparison of its candidate against its baseline over the sweep,
// computed from the runs' outcomes.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "metrics.hpp"
#include "runs.hpp"
#include "scenarios.hpp"

namespace rollstep::experiments {

/// One sweep run as the table and the figure show it.
struct SweepPoint {
  double speed = 0.0;   ///< [m/s] commanded
  std::size_t run = 0;  ///< index in the set's scenarios and the outcomes
  bool passed = false;
  std::optional<Table1Metrics> metrics;  ///< when the traverse window was found
  std::string failure;                   ///< why it failed ("" when it passed)
};

/// The sweep runs of one scenario of the sweep, by increasing speed (those that were run).
struct SweepSeries {
  std::string scenario;
  std::string title;
  std::vector<SweepPoint> points;
  /// The fastest passing point with metrics, or nullptr.
  const SweepPoint* fastestPassing() const;
  /// The point at `speed`, or nullptr.
  const SweepPoint* at(double speed) const;
};

/// The sweep's runs among `outcomes` (outcomes[i] is set.scenarios[i]), one series per
/// scenario of set.sweep, in its order.
std::vector<SweepSeries> sweepSeries(const ExperimentSet& set,
                                     const std::vector<RunOutcome>& outcomes);

/// The candidate's metric against the baseline's at one compared speed.
struct SweepRatio {
  double speed = 0.0;     ///< [m/s]
  std::string metric;     ///< "mean |v_z|" or "mean |w_y|"
  bool compared = false;  ///< both ran, passed and have metrics
  double candidate = 0.0, baseline = 0.0, ratio = 0.0;
  bool met = false;
};

/// The sweep's acceptance: every ratio at most max_ratio, and the candidate's traverse time
/// at its fastest passing speed at most the baseline's at its own.
struct SweepVerdict {
  bool judged = false;  ///< the sweep names a candidate and a baseline and both were run
  std::vector<SweepRatio> ratios;
  bool fastest_compared = false;  ///< both have a passing run
  double candidate_speed = 0.0, candidate_time = 0.0;
  double baseline_speed = 0.0, baseline_time = 0.0;
  bool fastest_met = false;
  bool met() const;
};

SweepVerdict judgeSpeedSweep(const SpeedSweep& sweep, const std::vector<SweepSeries>& series);

}  // namespace rollstep::experiments
