#include "acceptance.hpp"

#include "metrics.hpp"
#include "speed_sweep.hpp"
#include "trials.hpp"

namespace rollstep::experiments {

ReportVerdict judgeAcceptance(const ReportInputs& in, const std::vector<RunOutcome>& outcomes) {
  const ExperimentSet& set = in.set;
  ReportVerdict v;
  v.runs_given = set.acceptance.given;
  if (v.runs_given) {
    const Acceptance& a = set.acceptance;
    for (std::size_t i = 0; i < set.scenarios.size(); ++i) {
      if (set.scenarios[i].name == a.candidate) v.candidate = i;
      if (set.scenarios[i].name == a.baseline) v.baseline = i;
    }
    const RunOutcome& c = outcomes[v.candidate];
    const RunOutcome& b = outcomes[v.baseline];
    v.runs_compared = c.passed() && b.passed() && c.assessment.metrics && b.assessment.metrics;
    if (!v.runs_compared) {
      v.runs_met = false;
    } else {
      const Table1Metrics& cm = *c.assessment.metrics;
      const Table1Metrics& bm = *b.assessment.metrics;
      const auto margin = [&](const char* metric, double cv, double bv, double need) {
        const double change = relativeChange(cv, bv);
        const bool ok = meetsMargin(change, need);
        v.runs_met = v.runs_met && ok;
        v.margins.push_back({metric, change, need, ok});
      };
      margin("traverse time", cm.traverse_time, bm.traverse_time, a.traverse_time);
      margin("mean |v_z|", cm.mean_abs_vz, bm.mean_abs_vz, a.mean_abs_vz);
      margin("mean |w_y|", cm.mean_abs_wy, bm.mean_abs_wy, a.mean_abs_wy);
    }
  }
  v.sweep_series = sweepSeries(set, outcomes);
  v.sweep = judgeSpeedSweep(set.sweep, v.sweep_series);
  v.trials_judged = !in.trial_dirs.empty() && in.file_acceptance.given;
  if (v.trials_judged) {
    const Acceptance& a = in.file_acceptance;
    v.trials = compareTrials(in.trials.results, a.candidate, a.baseline);
    v.trials_met =
        v.trials.candidate_trials > 0 && v.trials.candidateSuccessRate() >= a.trial_success_rate;
  }
  return v;
}

}  // namespace rollstep::experiments
