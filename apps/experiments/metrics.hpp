#pragma once
// The paper's Table 1 metrics and the experiments' pass criteria, computed from a
// `rollstep sim` log.csv (LogTable), whatever controller produced it.
//
// Traverse window (paper Sec. 4, Fig. 2): from the climbing leg's lift-off for the climb to
// the descending leg's touch-down after the descent (Tachyon 3: MF and MR, the middle legs;
// any robot: traverseLegs). A wheel is "up" when its centre is above up_height (the wheel
// radius + half the first step's height: above the step's middle).
//   start: the last climbing-leg lift-off (contact 1 -> 0) before the first row where that
//          leg is in contact and up (landed on the step);
//   end:   the first descending-leg touch-down (contact 0 -> 1, not up) after the last row
//          where that leg is in contact and up (the touch-down that brings it back to the
//          floor).
// Means over the window: |v_z| and |w_y| in the base (local) frame, averaged over the log
// rows inside [start, end] (rows are evenly spaced).
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "log_table.hpp"

namespace rollstep::experiments {

struct TraverseWindow {
  bool found = false;
  double start = 0.0;  ///< [s] the climbing leg's lift-off for the climb
  double end = 0.0;    ///< [s] the descending leg's touch-down after the descent
  std::string reason;  ///< why not found (empty when found)
};

/// The legs (log names, e.g. "MF") whose wheels open and close the traverse window.
struct TraverseLegs {
  std::string climb;    ///< the first leg up the step: the front leg nearest the middle
  std::string descent;  ///< the last leg down: the hind leg nearest the middle
};

/// The traverse legs of a robot from its legs' names and hip positions in the base frame
/// (x forward, y left): climb = the largest x, descent = the smallest x, ties (within
/// 1 mm) to the smaller |y|, then to the earlier leg. Tachyon 3: MF and MR. Throws
/// std::invalid_argument if there is no leg or the sizes differ.
TraverseLegs traverseLegs(const std::vector<std::string>& names, const std::vector<double>& hip_x,
                          const std::vector<double>& hip_y);

/// Contacts are 0/1 (a value > 0.5 is contact); heights are wheel centre heights [m]; the
/// legs' names only for the reasons. All vectors have the size of t. Throws
/// std::invalid_argument if they do not.
TraverseWindow findTraverseWindow(const std::vector<double>& t, const std::vector<double>& climb_z,
                                  const std::vector<double>& climb_contact,
                                  const std::vector<double>& descent_z,
                                  const std::vector<double>& descent_contact,
                                  const TraverseLegs& legs, double up_height);
/// Same from a log (columns time[s], foot_z_<leg>[m], contact_<leg>[0/1] of both legs).
TraverseWindow findTraverseWindow(const LogTable& log, const TraverseLegs& legs, double up_height);

struct Table1Metrics {
  double traverse_time = 0.0;  ///< [s]
  double mean_abs_vz = 0.0;    ///< [m/s] base local
  double mean_abs_wy = 0.0;    ///< [rad/s] base local
  int samples = 0;             ///< log rows in the window
  double distance = 0.0;       ///< [m] horizontal base travel from the window's start to end
};

/// Base local linear velocity z of every row: R(q)^T v_world (columns base_q*, base_v*).
std::vector<double> localVz(const LogTable& log);
/// The metrics over a found window (std::invalid_argument if `window` is not found).
Table1Metrics table1Metrics(const LogTable& log, const TraverseWindow& window);

/// Pass criteria of a run (config/experiments.yaml, `criteria:`).
struct RunCriteria {
  double max_tilt = 0.785398;           ///< [rad] base tilt from upright beyond which it fell
  double joint_limit_tolerance = 0.01;  ///< [rad or m] allowed overshoot of a joint limit
};

struct JointLimit {
  std::string name;  ///< "LF_hip": the log column is q_<name>[unit]
  double lower = 0.0, upper = 0.0;
};

/// What a run did against the criteria. passed() when every check could be made and held.
struct RunAssessment {
  TraverseWindow window;
  std::optional<Table1Metrics> metrics;  ///< when the window was found
  double duration = 0.0;                 ///< [s] logged time
  double max_tilt = 0.0;                 ///< [rad]
  long body_contact_periods = -1;        ///< -1: the log does not say
  std::vector<std::string> failures;     ///< one sentence per failed criterion
  bool passed() const { return failures.empty(); }
};

/// Checks a completed run's log: no fall (tilt <= max_tilt), the body never touched the
/// terrain (body_contact_periods stays 0), every joint inside [lower - tol, upper + tol],
/// and, if traverse_required, the traverse window exists (its reason otherwise).
RunAssessment assessRun(const LogTable& log, const std::vector<JointLimit>& limits,
                        const RunCriteria& criteria, bool traverse_required,
                        const TraverseLegs& legs, double up_height);

/// Relative change (candidate - baseline) / baseline; NaN when baseline is 0.
double relativeChange(double candidate, double baseline);
/// Whether a relative change meets a margin: finite and at most `margin` (margins are
/// negative: -0.2 asks for at least 20 % less).
inline bool meetsMargin(double change, double margin) {
  return std::isfinite(change) && change <= margin;
}

}  // namespace rollstep::experiments
