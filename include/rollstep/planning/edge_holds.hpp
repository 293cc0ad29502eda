#pragma once
// Gait timing that waits for the terrain's edges.
//
// A periodic gait places its swings by the clock, not by the terrain. At a step down a
// swing can touch down just short of the edge (a short step onto the brink), and the foot
// comes down one whole cycle later, its leg stretched back towards its hip limit. Before a
// step up a swing can touch down well short of the riser, and the next one must then climb
// from far back, lifting off early, or it lands in the gap and climbs with a long reach. A
// wheeled-legged robot can instead wait: every foot stays in stance and rolls with the
// base (the base does not slow down), and the gait's clock stands still (a GaitClock hold).
//
// planEdgeHolds() decides the holds from the foot references (base reference, terrain,
// foothold rule), for each swing whose nominal touch-down foothold lies at an edge: inside
// a region the travel leaves, or in the gap just past it (the next region within 0.5 m
// past its end):
// - onto a lower region: a hold until the foothold is past the end of the surface it
//   leaves and at most `reach` short of where the lower one begins: the foothold rule puts
//   it on the step below (needs foothold_gap_reach across the gap; with a shorter reach the
//   rule would put it back on the brink, and nothing is held) and the leg reaches no
//   further forward and down than `reach` ahead of its nominal position. The gap is wide
//   where a perceived floor beyond a drop is still hidden behind its edge; at most
//   max_down_hold;
// - onto a higher one: a hold until the foothold is `setback` short of the region's end,
//   so that it lands close up to the riser and the next swing climbs from there; from the
//   gap before the riser (the foothold rule sends it up onto the step), until it is at
//   most `up_reach` short of the step's region: a leg that must clear the riser first
//   cannot reach far ahead of its hip, and one sent further lands short, on the corner
//   (off unless up_reach > 0); at most max_up_hold. None for a touch-down whose next one
//   (a gait period later) still lands short of the region's end: that next swing climbs,
//   from nearer the riser, and is held if it needs to be (a trot whose stride is short
//   against max_up_hold's travel would otherwise stand every foot for more than a stride).
// A hold lengthens the stance of every foot standing through it, and a stance foot that
// meets a riser ahead of it stands there while the body passes over it (its wheel cannot
// roll into the step): no hold is made that would carry the body more than `stance_stroke`
// over such a foot before its lift-off (the rear feet waiting at a step up while a front
// swing would be held for the step down at the far end of a short block).
// The hold goes in the middle of the all-stance phase before that swing's lift-off (as
// long as the lift-off group's longest wait). Holds begin no sooner than `lead` after the
// planning time, so a plan's clock reaches the real-time side before it matters; later
// holds are planned again at every call (the same inputs give the same holds).
//
// Real-time use: no allocation, nothing throws.
#include "rollstep/planning/foot_reference.hpp"
#include "rollstep/planning/gait.hpp"
#include "rollstep/planning/gait_clock.hpp"

namespace rollstep::planning {

struct EdgeHoldConfig {
  /// [s] longest hold before a step down; 0: never.
  double max_down_hold = 0.0;
  /// [s] a hold begins at least this long after the planning time.
  double lead = 0.2;
  /// [m] how far short of the lower region's start a touch-down held before a step down may
  /// have its nominal foothold (the leg reaches that far ahead of it, down onto the step).
  double reach = 0.12;
  /// [s] longest hold before a step up; 0: never.
  double max_up_hold = 0.0;
  /// [m] how far short of the end of its region a touch-down held before a step up lands.
  double setback = 0.02;
  /// [m] how far short of the step's region a touch-down from the gap before a riser may
  /// have its nominal foothold; 0: no such hold (the foothold rule alone decides).
  double up_reach = 0.0;
  /// [m] height difference below which the next region is not a step (no hold): the
  /// regions perception makes of one floor differ by up to a few centimetres.
  double min_step = 0.03;
  /// [m] the most body travel over a stance foot stopped at a riser ahead of it (from the
  /// end of its foothold region to its lift-off) that a hold may bring about; 0: unchecked.
  double stance_stroke = 0.0;
};

/// Plans the holds of `clock` for the swings lifting off in [t0 + config.lead, t0 +
/// lookahead] (see the file comment): forgets holds that ended a gait period before t0,
/// drops the ones beginning after t0 + lead and plans them again, in lift-off order. A
/// gait with no all-stance phase before a lift-off is never held there. No allocation.
void planEdgeHolds(const Gait& gait, const FootReferencePlanner& feet, const EdgeHoldConfig& config,
                   double t0, double lookahead, GaitClock& clock) noexcept;

}  // namespace rollstep::planning
