#pragma once
// The contact schedule the OCP reads: a gait written into an ocp::ModeSchedule (mode id
// = contact mask, see gait.hpp) for a horizon starting at any t0, and the per-foot timing
// queries the OCP terms make at a node: stance or swing, and for a swing its lift-off
// and touch-down times and its phase.
//
// Real-time use: GaitScheduler is built once (allocates its buffers); fill() and
// footPhase() allocate nothing.
#include "rollstep/ocp/mode_schedule.hpp"
#include "rollstep/planning/gait.hpp"
#include "rollstep/planning/gait_clock.hpp"

namespace rollstep::planning {

/// Timing of one foot at one time.
struct FootPhase {
  bool stance = true;
  /// Swing only: lift-off and touch-down times [s]. -inf / +inf when the schedule does
  /// not contain them (the swing started before its first switch or ends after its last).
  double liftoff = 0.0;
  double touchdown = 0.0;
  /// Swing only: (t - liftoff) / (touchdown - liftoff) in [0, 1]; NaN if either end is
  /// unknown. Stance: 0.
  double phase = 0.0;
  bool bounded() const { return liftoff > -1e300 && touchdown < 1e300; }
};

/// Stance/swing timing of foot `foot` at time t from the switches of `schedule` (any
/// schedule whose modes are contact masks, periodic or not). O(switches), no allocation.
/// Mode m_i holds on [t_{i-1}, t_i) as in ocp::ModeSchedule.
FootPhase footPhase(const ocp::ModeSchedule& schedule, int foot, double t);

/// Late touch-down: foot `foot`'s stance that begins at the switch `touchdown` begins at
/// `landing` instead (its swing goes on until then), the other feet unchanged. Needs
/// touchdown < landing, the foot in stance on [touchdown, landing] and one free switch of
/// capacity (for `landing`); otherwise returns false and changes nothing. Never allocates.
bool delayTouchdown(ocp::ModeSchedule& schedule, int foot, double touchdown, double landing);

/// Writes a periodic gait into ModeSchedules.
class GaitScheduler {
 public:
  /// `max_horizon` [s]: the longest horizon fill() will be asked for (sizes the buffers).
  GaitScheduler(Gait gait, double max_horizon);
  const Gait& gait() const { return gait_; }
  double maxHorizon() const { return max_horizon_; }
  /// Capacity a ModeSchedule needs for fill() with any horizon <= maxHorizon().
  int requiredCapacity() const;
  /// Writes the gait's modes on [t0 - period, t0 + horizon + period] into `out`, so that
  /// every swing overlapping [t0, t0 + horizon] has its lift-off and touch-down in the
  /// schedule (a swing lasts less than a period). Throws std::invalid_argument for a
  /// non-finite t0 or horizon outside [0, maxHorizon()], or if `out`'s capacity is too
  /// small. No allocation.
  void fill(double t0, double horizon, ocp::ModeSchedule& out);
  /// The same with the gait read through `clock` (gait_clock.hpp): the switch at gait time
  /// tau happens at clock.loopTime(tau). Holds lie in all-stance phases, so a swing keeps
  /// its length and the window still holds every swing overlapping [t0, t0 + horizon].
  void fill(double t0, double horizon, ocp::ModeSchedule& out, const GaitClock& clock);

 private:
  Gait gait_;
  double max_horizon_;
  std::vector<double> times_;
  std::vector<int> modes_;
};

}  // namespace rollstep::planning
