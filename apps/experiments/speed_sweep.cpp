#include "speed_sweep.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace rollstep::experiments {

namespace {

bool sameSpeed(double a, double b) { return std::abs(a - b) < 1e-9; }

const SweepSeries* seriesOf(const std::vector<SweepSeries>& series, const std::string& name) {
  for (const SweepSeries& s : series) {
    if (s.scenario == name) return &s;
  }
  return nullptr;
}

}  // namespace

const SweepPoint* SweepSeries::fastestPassing() const {
  const SweepPoint* best = nullptr;
  for (const SweepPoint& p : points) {
    if (p.passed && p.metrics && (best == nullptr || p.speed > best->speed)) best = &p;
  }
  return best;
}

const SweepPoint* SweepSeries::at(double speed) const {
  for (const SweepPoint& p : points) {
    if (sameSpeed(p.speed, speed)) return &p;
  }
  return nullptr;
}

std::vector<SweepSeries> sweepSeries(const ExperimentSet& set,
                                     const std::vector<RunOutcome>& outcomes) {
  std::vector<SweepSeries> series;
  if (!set.sweep.given) return series;
  for (const std::string& name : set.sweep.scenarios) {
    SweepSeries s;
    s.scenario = name;
    // The file's scenario may be left out by --only: its title from its first sweep run.
    if (const Scenario* base = set.find(name)) s.title = base->title;
    for (std::size_t i = 0; i < set.scenarios.size() && i < outcomes.size(); ++i) {
      const Scenario& run = set.scenarios[i];
      if (run.sweep_of != name) continue;
      if (s.title.empty()) s.title = name;
      SweepPoint p;
      p.speed = run.sweep_speed;
      p.run = i;
      p.passed = outcomes[i].passed();
      p.metrics = outcomes[i].assessment.metrics;
      p.failure = outcomes[i].failureText();
      s.points.push_back(p);
    }
    std::sort(s.points.begin(), s.points.end(),
              [](const SweepPoint& a, const SweepPoint& b) { return a.speed < b.speed; });
    series.push_back(std::move(s));
  }
  return series;
}

bool SweepVerdict::met() const {
  if (!judged) return true;
  if (!fastest_met) return false;
  return std::all_of(ratios.begin(), ratios.end(), [](const SweepRatio& r) { return r.met; });
}

SweepVerdict judgeSpeedSweep(const SpeedSweep& sweep, const std::vector<SweepSeries>& series) {
  SweepVerdict v;
  if (!sweep.given || sweep.candidate.empty()) return v;
  const SweepSeries* c = seriesOf(series, sweep.candidate);
  const SweepSeries* b = seriesOf(series, sweep.baseline);
  if (c == nullptr || b == nullptr || c->points.empty() || b->points.empty()) return v;
  v.judged = true;
  for (double speed : sweep.compared_speeds) {
    const SweepPoint* cp = c->at(speed);
    const SweepPoint* bp = b->at(speed);
    const bool compared =
        cp != nullptr && bp != nullptr && cp->passed && bp->passed && cp->metrics && bp->metrics;
    for (const bool vz : {true, false}) {
      SweepRatio r;
      r.speed = speed;
      r.metric = vz ? "mean |v_z|" : "mean |w_y|";
      r.compared = compared;
      if (compared) {
        r.candidate = vz ? cp->metrics->mean_abs_vz : cp->metrics->mean_abs_wy;
        r.baseline = vz ? bp->metrics->mean_abs_vz : bp->metrics->mean_abs_wy;
        r.ratio =
            r.baseline > 0.0 ? r.candidate / r.baseline : std::numeric_limits<double>::quiet_NaN();
        r.met = std::isfinite(r.ratio) && r.ratio <= sweep.max_ratio;
      }
      v.ratios.push_back(r);
    }
  }
  const SweepPoint* cf = c->fastestPassing();
  const SweepPoint* bf = b->fastestPassing();
  v.fastest_compared = cf != nullptr && bf != nullptr;
  if (cf != nullptr) {
    v.candidate_speed = cf->speed;
    v.candidate_time = cf->metrics->traverse_time;
  }
  if (bf != nullptr) {
    v.baseline_speed = bf->speed;
    v.baseline_time = bf->metrics->traverse_time;
  }
  // A baseline that never passes leaves the candidate's fastest run unbeaten.
  v.fastest_met = cf != nullptr && (bf == nullptr || v.candidate_time <= v.baseline_time);
  return v;
}

}  // namespace rollstep::experiments
