#pragma once
// Periodic gaits: which feet are in stance at each time.
//
// Mode convention (binding for the planning and centroidal layers): a contact mode id is
// a contact mask, bit i set <=> foot i is in stance. Foot indices are the order of the
// robot's contact list given by the caller (for Tachyon 3 in the order LF MF RF LR MR RR
// of robot/tachyon3.md, bits 0..5, "all six in stance" is mode 63); the library never
// assumes a robot. The same id is what ocp::ModeSchedule stores and what the OCP's
// NodeContext.mode carries, so a term reads its contact flags with inContact(mode, i).
//
// A Gait is immutable: one period of phases (start time within the period, mode), built
// once by a factory (these may allocate and throw std::invalid_argument naming the bad
// parameter and its value). The gait cycle starts at t = 0 and repeats for every real t;
// queries allocate nothing.
#include <array>
#include <string>
#include <vector>

#include "rollstep/common/enum_names.hpp"

namespace rollstep::planning {

/// Largest number of feet a mask can describe.
inline constexpr int kMaxFeet = 16;

/// True if foot `foot` is in stance in mode (= contact mask) `mode`.
inline bool inContact(int mode, int foot) { return ((mode >> foot) & 1) != 0; }
/// Number of feet in stance in `mode`.
int contactCount(int mode);
/// Mask with the `num_feet` lowest bits set (every foot in stance).
int allFeetMask(int num_feet);
/// Mask of the named feet, each looked up in `foot_names` (the robot's contact order).
/// Throws std::invalid_argument for an unknown or repeated name.
int contactMask(const std::vector<std::string>& foot_names,
                const std::vector<std::string>& in_stance);

enum class GaitKind { Standing, Rolling, Trot, StaticWalk, Custom };
constexpr std::array<EnumName<GaitKind>, 5> enumNames(GaitKind) {
  return {{{GaitKind::Standing, "standing"},
           {GaitKind::Rolling, "rolling"},
           {GaitKind::Trot, "trot"},
           {GaitKind::StaticWalk, "static_walk"},
           {GaitKind::Custom, "custom"}}};
}

/// One row of a custom gait table: `duration` [s] of a phase with contact mask `mode`.
struct GaitPhase {
  double duration = 0.0;
  int mode = 0;
};

class Gait {
 public:
  /// Every foot in stance, the base still (`period` only sets the schedule's bookkeeping).
  static Gait standing(int num_feet, double period = 1.0);
  /// Every foot in stance, the wheels rolling: contact-wise the same as standing (the
  /// difference is the base velocity command); kind() tells them apart.
  static Gait rolling(int num_feet, double period = 1.0);
  /// Two alternating groups: `group_a` in stance on [0, duty T), `group_b` on
  /// [T/2, T/2 + duty T) (mod T). duty > 1/2 gives all-stance overlaps, duty < 1/2 flight
  /// phases. Feet in neither group stay in stance. The paper's trot is
  /// group_a = [LF, RF, MR], group_b = [MF, LR, RR].
  static Gait trot(int num_feet, double period, double duty, int group_a, int group_b);
  /// One foot at a time in the order given: foot order[k] swings on
  /// [k T/n, k T/n + (1 - duty) T), n = order.size(), and is in stance otherwise. Needs
  /// 1 - duty <= 1/n (else two feet would swing together). Feet not in `order` stay in
  /// stance.
  static Gait staticWalk(int num_feet, double period, double duty, const std::vector<int>& order);
  /// Any other pattern: the phases of one period in order; period = sum of durations.
  static Gait fromTable(int num_feet, const std::vector<GaitPhase>& phases);

  GaitKind kind() const { return kind_; }
  int numFeet() const { return num_feet_; }
  double period() const { return period_; }
  /// Phases of one period after merging equal neighbours: start times in [0, period).
  const std::vector<double>& phaseStarts() const { return starts_; }
  const std::vector<int>& phaseModes() const { return modes_; }

  /// Contact mask at time t (any real t; the gait repeats with its period).
  int modeAt(double t) const;
  bool inStance(int foot, double t) const { return inContact(modeAt(t), foot); }
  /// Fraction of the period foot `foot` spends in stance.
  double dutyOf(int foot) const;
  /// Mode switches per period (0 for a constant gait).
  int switchesPerPeriod() const;

 private:
  Gait(GaitKind kind, int num_feet, double period, std::vector<double> starts,
       std::vector<int> modes);
  GaitKind kind_;
  int num_feet_;
  double period_;
  std::vector<double> starts_;  // sorted, starts_[0] == 0
  std::vector<int> modes_;
};

}  // namespace rollstep::planning
