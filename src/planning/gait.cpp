#include "rollstep/planning/gait.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "check.hpp"

namespace rollstep::planning {

int contactCount(int mode) {
  int n = 0;
  for (unsigned m = static_cast<unsigned>(mode); m != 0u; m >>= 1u) n += static_cast<int>(m & 1u);
  return n;
}

int allFeetMask(int num_feet) {
  detail::checkNumFeet("allFeetMask", num_feet);
  return static_cast<int>((1u << static_cast<unsigned>(num_feet)) - 1u);
}

int contactMask(const std::vector<std::string>& foot_names,
                const std::vector<std::string>& in_stance) {
  int mask = 0;
  for (const std::string& name : in_stance) {
    const auto it = std::find(foot_names.begin(), foot_names.end(), name);
    if (it == foot_names.end()) {
      throw std::invalid_argument("contactMask: unknown foot name '" + name + "'");
    }
    const int bit = 1 << static_cast<int>(it - foot_names.begin());
    if ((mask & bit) != 0) {
      throw std::invalid_argument("contactMask: foot '" + name + "' named twice");
    }
    mask |= bit;
  }
  return mask;
}

namespace {

void checkMask(const char* where, const char* name, int mask, int num_feet) {
  if (mask < 0 || (mask & ~allFeetMask(num_feet)) != 0) {
    std::ostringstream os;
    os << where << ": " << name << " = " << mask << " has bits beyond the " << num_feet << " feet";
    throw std::invalid_argument(os.str());
  }
}

/// Builds the phase table of one period (fractions in [0, 1)) from per-foot stance
/// intervals [begin, begin + length) mod 1; feet without an interval stay in stance.
struct StanceInterval {
  int foot;
  double begin;   // fraction of the period, in [0, 1)
  double length;  // fraction, in (0, 1]
};

bool covers(const StanceInterval& s, double x) {
  double d = x - s.begin;
  d -= std::floor(d);
  return d < s.length;
}

void buildFromIntervals(int num_feet, const std::vector<StanceInterval>& intervals,
                        std::vector<double>& starts, std::vector<int>& modes) {
  std::vector<double> cuts{0.0};
  for (const StanceInterval& s : intervals) {
    for (double c : {s.begin, s.begin + s.length}) {
      c -= std::floor(c);
      if (c >= 1.0 - 1e-12) c = 0.0;
      cuts.push_back(c);
    }
  }
  std::sort(cuts.begin(), cuts.end());
  cuts.erase(std::unique(cuts.begin(), cuts.end(),
                         [](double a, double b) { return std::abs(a - b) < 1e-12; }),
             cuts.end());
  int constrained = 0;
  for (const StanceInterval& s : intervals) constrained |= 1 << s.foot;
  const int free_feet = allFeetMask(num_feet) & ~constrained;
  starts.clear();
  modes.clear();
  for (std::size_t k = 0; k < cuts.size(); ++k) {
    const double end = k + 1 < cuts.size() ? cuts[k + 1] : 1.0;
    const double mid = 0.5 * (cuts[k] + end);
    int mode = free_feet;
    for (const StanceInterval& s : intervals) {
      if (covers(s, mid)) mode |= 1 << s.foot;
    }
    starts.push_back(cuts[k]);
    modes.push_back(mode);
  }
}

}  // namespace

Gait::Gait(GaitKind kind, int num_feet, double period, std::vector<double> starts,
           std::vector<int> modes)
    : kind_(kind), num_feet_(num_feet), period_(period) {
  // Merge equal neighbours (not across the period boundary: starts_[0] stays 0).
  for (std::size_t k = 0; k < starts.size(); ++k) {
    if (!modes_.empty() && modes_.back() == modes[k]) continue;
    starts_.push_back(starts[k] * period);
    modes_.push_back(modes[k]);
  }
  for (int f = 0; f < num_feet_; ++f) {
    if (dutyOf(f) <= 0.0) {
      throw std::invalid_argument("Gait: foot " + std::to_string(f) +
                                  " is never in stance (every foot needs a stance phase)");
    }
  }
}

Gait Gait::standing(int num_feet, double period) {
  detail::checkNumFeet("Gait::standing", num_feet);
  detail::checkPositive("Gait::standing", "period", period);
  return Gait(GaitKind::Standing, num_feet, period, {0.0}, {allFeetMask(num_feet)});
}

Gait Gait::rolling(int num_feet, double period) {
  detail::checkNumFeet("Gait::rolling", num_feet);
  detail::checkPositive("Gait::rolling", "period", period);
  return Gait(GaitKind::Rolling, num_feet, period, {0.0}, {allFeetMask(num_feet)});
}

Gait Gait::trot(int num_feet, double period, double duty, int group_a, int group_b) {
  const char* where = "Gait::trot";
  detail::checkNumFeet(where, num_feet);
  detail::checkPositive(where, "period", period);
  detail::checkOpenUnit(where, "duty", duty);
  checkMask(where, "group_a", group_a, num_feet);
  checkMask(where, "group_b", group_b, num_feet);
  if ((group_a & group_b) != 0 || group_a == 0 || group_b == 0) {
    std::ostringstream os;
    os << where << ": group_a = " << group_a << " and group_b = " << group_b
       << " must be non-empty and disjoint";
    throw std::invalid_argument(os.str());
  }
  std::vector<StanceInterval> iv;
  for (int f = 0; f < num_feet; ++f) {
    if (inContact(group_a, f)) iv.push_back({f, 0.0, duty});
    if (inContact(group_b, f)) iv.push_back({f, 0.5, duty});
  }
  std::vector<double> starts;
  std::vector<int> modes;
  buildFromIntervals(num_feet, iv, starts, modes);
  return Gait(GaitKind::Trot, num_feet, period, std::move(starts), std::move(modes));
}

Gait Gait::staticWalk(int num_feet, double period, double duty, const std::vector<int>& order) {
  const char* where = "Gait::staticWalk";
  detail::checkNumFeet(where, num_feet);
  detail::checkPositive(where, "period", period);
  detail::checkOpenUnit(where, "duty", duty);
  if (order.empty()) throw std::invalid_argument(std::string(where) + ": order is empty");
  const int n = static_cast<int>(order.size());
  int seen = 0;
  for (int f : order) {
    if (f < 0 || f >= num_feet || (seen & (1 << f)) != 0) {
      throw std::invalid_argument(std::string(where) + ": order has a bad or repeated foot " +
                                  std::to_string(f));
    }
    seen |= 1 << f;
  }
  const double swing = 1.0 - duty;
  if (swing > 1.0 / n + 1e-12) {
    std::ostringstream os;
    os << where << ": duty = " << duty
       << " lets two feet swing at once (need duty >= " << 1.0 - 1.0 / n << " for " << n
       << " feet)";
    throw std::invalid_argument(os.str());
  }
  std::vector<StanceInterval> iv;
  for (int k = 0; k < n; ++k) {
    iv.push_back({order[static_cast<std::size_t>(k)], static_cast<double>(k) / n + swing, duty});
  }
  std::vector<double> starts;
  std::vector<int> modes;
  buildFromIntervals(num_feet, iv, starts, modes);
  return Gait(GaitKind::StaticWalk, num_feet, period, std::move(starts), std::move(modes));
}

Gait Gait::fromTable(int num_feet, const std::vector<GaitPhase>& phases) {
  const char* where = "Gait::fromTable";
  detail::checkNumFeet(where, num_feet);
  if (phases.empty()) throw std::invalid_argument(std::string(where) + ": phases is empty");
  double period = 0.0;
  for (std::size_t k = 0; k < phases.size(); ++k) {
    const std::string name = "phases[" + std::to_string(k) + "]";
    detail::checkPositive(where, (name + ".duration").c_str(), phases[k].duration);
    checkMask(where, (name + ".mode").c_str(), phases[k].mode, num_feet);
    period += phases[k].duration;
  }
  std::vector<double> starts;
  std::vector<int> modes;
  double t = 0.0;
  for (const GaitPhase& p : phases) {
    starts.push_back(t / period);
    modes.push_back(p.mode);
    t += p.duration;
  }
  return Gait(GaitKind::Custom, num_feet, period, std::move(starts), std::move(modes));
}

int Gait::modeAt(double t) const {
  double tau = t - period_ * std::floor(t / period_);
  // Rounding at the boundary: t just below a multiple of the period can give tau == period,
  // and a negative t just below one can give tau a hair below 0 (before the first phase).
  if (tau >= period_ || tau < 0.0) tau = 0.0;
  const auto it = std::upper_bound(starts_.begin(), starts_.end(), tau);
  return modes_[static_cast<std::size_t>(it - starts_.begin()) - 1];
}

double Gait::dutyOf(int foot) const {
  double stance = 0.0;
  for (std::size_t k = 0; k < starts_.size(); ++k) {
    const double end = k + 1 < starts_.size() ? starts_[k + 1] : period_;
    if (inContact(modes_[k], foot)) stance += end - starts_[k];
  }
  return stance / period_;
}

int Gait::switchesPerPeriod() const {
  const int n = static_cast<int>(modes_.size());
  if (n == 1) return 0;
  return modes_.back() == modes_.front() ? n - 1 : n;
}

}  // namespace rollstep::planning
