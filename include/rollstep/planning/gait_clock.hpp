#pragma once
// A gait's clock that can stand still.
//
// GaitClock maps loop time t to gait time tau (the time the periodic Gait is evaluated at):
// tau advances with t except during holds, intervals [start, start + duration) of loop
// time in which it stands still. GaitScheduler::fill writes a gait through a clock; holds
// belong in all-stance phases (every foot on the ground, rolling with the base), where they
// lengthen no swing. edge_holds.hpp decides them.
//
// Real-time use: fixed capacity, no allocation, nothing throws.
#include <array>

namespace rollstep::planning {

class GaitClock {
 public:
  static constexpr int kMaxHolds = 16;
  struct Hold {
    double start = 0.0;     ///< [s] loop time at which the gait's clock stops
    double duration = 0.0;  ///< [s] how long it stands still
    double end() const { return start + duration; }
  };

  /// Gait time at loop time t (t itself for a clock without holds).
  double gaitTime(double t) const noexcept;
  /// The earliest loop time at which the gait time reaches tau (a switch at the gait time
  /// where a hold begins happens at the hold's start).
  double loopTime(double tau) const noexcept;
  /// Appends a hold at `start` (>= the last hold's end; one beginning at that end extends
  /// it). False, and no change, for a non-finite or negative value, a start before the last
  /// hold's end or no capacity left.
  bool addHold(double start, double duration) noexcept;
  /// Removes the holds that begin after t.
  void dropHoldsAfter(double t) noexcept;
  /// Folds the holds that end at or before t into a constant offset (gaitTime and loopTime
  /// are unchanged at and after t), freeing their capacity.
  void forgetBefore(double t) noexcept;
  void clear() noexcept;

  int size() const noexcept { return size_; }
  const Hold& hold(int i) const noexcept { return holds_[static_cast<std::size_t>(i)]; }
  /// Loop time minus gait time after every hold: the held time in all.
  double totalHeld() const noexcept;

 private:
  std::array<Hold, kMaxHolds> holds_{};
  int size_ = 0;
  double offset_ = 0.0;  ///< held time of the forgotten holds
};

}  // namespace rollstep::planning
