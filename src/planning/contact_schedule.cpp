#include "rollstep/planning/contact_schedule.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include "check.hpp"

namespace rollstep::planning {

FootPhase footPhase(const ocp::ModeSchedule& schedule, int foot, double t) {
  const std::vector<double>& times = schedule.switchingTimes();
  const std::vector<int>& modes = schedule.modes();
  const int p = schedule.phaseAt(t);
  FootPhase r;
  if (inContact(modes[static_cast<std::size_t>(p)], foot)) return r;
  r.stance = false;
  r.liftoff = -std::numeric_limits<double>::infinity();
  r.touchdown = std::numeric_limits<double>::infinity();
  // Lift-off: the switch out of the last stance phase before p.
  for (int j = p - 1; j >= 0; --j) {
    if (inContact(modes[static_cast<std::size_t>(j)], foot)) {
      r.liftoff = times[static_cast<std::size_t>(j)];
      break;
    }
  }
  // Touch-down: the switch into the first stance phase after p.
  for (int j = p + 1; j < static_cast<int>(modes.size()); ++j) {
    if (inContact(modes[static_cast<std::size_t>(j)], foot)) {
      r.touchdown = times[static_cast<std::size_t>(j) - 1];
      break;
    }
  }
  if (r.bounded()) {
    r.phase = std::clamp((t - r.liftoff) / (r.touchdown - r.liftoff), 0.0, 1.0);
  } else {
    r.phase = std::numeric_limits<double>::quiet_NaN();
  }
  return r;
}

bool delayTouchdown(ocp::ModeSchedule& schedule, int foot, double touchdown, double landing) {
  if (foot < 0 || !std::isfinite(touchdown) || !std::isfinite(landing) || landing <= touchdown) {
    return false;
  }
  const std::vector<double>& times = schedule.switchingTimes();
  const int first = schedule.phaseAt(touchdown);
  // touchdown must be the switch that begins the stance, and the stance must last past landing.
  if (first == 0 || std::abs(times[static_cast<std::size_t>(first) - 1] - touchdown) > 1e-9) {
    return false;
  }
  if (inContact(schedule.modes()[static_cast<std::size_t>(first) - 1], foot)) return false;
  for (int p = first; p <= schedule.phaseAt(landing); ++p) {
    if (!inContact(schedule.modes()[static_cast<std::size_t>(p)], foot)) return false;
  }
  if (!schedule.split(landing)) return false;
  const int last = schedule.phaseAt(landing + 1e-9);  // the phase landing begins
  for (int p = first; p < last; ++p) {
    schedule.setMode(p, schedule.modes()[static_cast<std::size_t>(p)] & ~(1 << foot));
  }
  return true;
}

GaitScheduler::GaitScheduler(Gait gait, double max_horizon)
    : gait_(std::move(gait)), max_horizon_(max_horizon) {
  detail::checkNonNegative("GaitScheduler", "max_horizon", max_horizon);
  times_.reserve(static_cast<std::size_t>(requiredCapacity()));
  modes_.reserve(static_cast<std::size_t>(requiredCapacity()) + 1);
}

int GaitScheduler::requiredCapacity() const {
  const int per_period = gait_.switchesPerPeriod();
  return per_period * (static_cast<int>(std::ceil(max_horizon_ / gait_.period())) + 3);
}

void GaitScheduler::fill(double t0, double horizon, ocp::ModeSchedule& out) {
  fill(t0, horizon, out, GaitClock{});
}

void GaitScheduler::fill(double t0, double horizon, ocp::ModeSchedule& out,
                         const GaitClock& clock) {
  detail::checkFinite("GaitScheduler::fill", "t0", t0);
  if (!std::isfinite(horizon) || horizon < 0.0 || horizon > max_horizon_) {
    detail::fail("GaitScheduler::fill", "horizon", horizon, "must be in [0, max_horizon]");
  }
  const double period = gait_.period();
  // In gait time (a hold only shortens the span: the capacity holds).
  const double t_begin = clock.gaitTime(t0) - period;
  const double t_end = clock.gaitTime(t0 + horizon) + period;
  int last = gait_.modeAt(t_begin);
  if (gait_.switchesPerPeriod() == 0) {
    out.setConstant(last);
    return;
  }
  times_.clear();
  modes_.clear();
  modes_.push_back(last);
  const std::vector<double>& starts = gait_.phaseStarts();
  const std::vector<int>& modes = gait_.phaseModes();
  for (double k = std::floor(t_begin / period);; k += 1.0) {
    const double base = k * period;
    if (base > t_end) break;
    for (std::size_t j = 0; j < starts.size(); ++j) {
      const double time = base + starts[j];
      if (time <= t_begin || time > t_end || modes[j] == last) continue;
      times_.push_back(clock.loopTime(time));
      modes_.push_back(modes[j]);
      last = modes[j];
    }
  }
  out.set(times_, modes_);
}

}  // namespace rollstep::planning
