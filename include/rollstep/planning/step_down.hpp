#pragma once
// Gait timing that waits at a step down.
//
// A periodic gait places its swings by the clock, not by the terrain: a swing whose
// touch-down falls just short of a step down puts the foot on the brink (a short step), and
// the foot comes down one whole cycle later, from a leg stretched back towards its hip
// limit. A wheeled-legged robot can instead wait: every foot stays in stance and rolls with
// the base, and the gait's clock stands still (a GaitClock hold), until that swing's
// touch-down has moved past the brink and the foot steps down at once.
//
// planStepDownHolds() decides the holds from the foot references (base reference, terrain,
// foothold rule): a swing whose nominal touch-down foothold is inside a region that the
// travel leaves, within max_hold of travel, onto a lower one (the region the foothold rule
// gives just past the edge) is preceded by a hold, in the all-stance phase before its
// lift-off, long enough for the foothold to pass that edge by `overshoot`. With
// foothold_gap_reach shorter than the gap the rule puts a foothold just past the edge back
// on the brink, and nothing is held. Holds begin no sooner than `lead` after the planning
// time, so a plan's clock reaches the real-time side before it matters; later holds are
// planned again at every call (the same inputs give the same holds).
//
// Real-time use: no allocation, nothing throws.
#include "rollstep/planning/foot_reference.hpp"
#include "rollstep/planning/gait.hpp"
#include "rollstep/planning/gait_clock.hpp"

namespace rollstep::planning {

struct StepDownHoldConfig {
  /// [s] longest hold; 0: never hold (the gait runs on the loop's clock).
  double max_hold = 0.0;
  /// [s] a hold begins at least this long after the planning time.
  double lead = 0.2;
  /// [m] how far past the brink region's edge the held touch-down foothold goes.
  double overshoot = 0.05;
  /// [m] height difference below which the next region is not a step down.
  double level_tolerance = 1e-3;
};

/// Plans the holds of `clock` for the swings lifting off in [t0 + config.lead, t0 +
/// lookahead] (see the file comment): forgets holds that ended a gait period before t0,
/// drops the ones beginning after t0 + lead and plans them again, in lift-off order. A
/// gait with no all-stance phase before a lift-off is never held there. No allocation.
void planStepDownHolds(const Gait& gait, const FootReferencePlanner& feet,
                       const StepDownHoldConfig& config, double t0, double lookahead,
                       GaitClock& clock) noexcept;

}  // namespace rollstep::planning
