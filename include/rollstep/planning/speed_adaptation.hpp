#pragma once
// The trot's timing and the base command adapted to the commanded speed.
//
// One continuous rule from the robot's limits, for every speed (no table of tested speeds):
// - A swing must lift a wheel over the tallest step it is timed for (`rise`: step height plus
//   clearance) while its apex comes at (1 - apex_margin) of the swing, on a cubic whose
//   steepest vertical speed is 1.5 times its mean: swing = 1.5 rise / ((1 - apex_margin)
//   knee_speed). It does not depend on the speed.
// - A stance foot that reaches a riser stops there (the wheel cannot roll into it) while the
//   body passes over it: its stance may last at most stance_stroke / speed (the hips' sweep).
//   At low speed the stance is max_duty / (1 - max_duty) swings long (the slow, well-overlapped
//   trot); faster, it shortens to stance_stroke / speed, and the duty with it, down to
//   min_duty (a trot keeps one group in stance: duty 1/2).
// - Faster than stance_stroke / (swing min_duty / (1 - min_duty)) no timing keeps the stance
//   within the stroke: that is the step speed limit. The gait is timed for it, and the base
//   command is slowed down to it near steps (limitSpeedAtSteps), and only there: on level
//   ground the stance wheels roll with the body, whatever the speed.
// - From rest and between commands the reference speed changes at most `max_acceleration`
//   (a staircase of short segments): a step in the command asks the body for an impulse that
//   pitches it and throws the swings.
// - The gait's waits at a step's edge (edge_holds.hpp) keep a foot at the edge while the body
//   passes: at most stance_stroke / speed.
// - The approach to the first step is timed to the gait (when the gait cannot wait at an edge:
//   a trot with no phase of every foot in stance, as at the step speed limit). The feet land
//   where the gait clock puts them, and a stance wheel that comes to a riser mid-stance stands
//   there while the body passes over it, until its swing. In a trot the touch-downs of the two
//   groups come half a period apart: when the first touch-down onto the step (any foot, up or
//   down) lands a distance d past the riser, a wheel of the other group in the same row, on
//   the floor, came down half a period's travel behind it and stands at the riser for d (plus
//   its foothold margin) of the body's travel. The rule: d at most a quarter period's travel
//   (speed x period / 4), half the spacing of the touch-downs. The gait clock runs from the
//   schedule's start, so the schedule is delayed instead: the speed dips to approach_dip of
//   itself (ramped within max_acceleration) and comes back, the dip ending a gait period
//   before that touch-down, by the least delay (less than half a period) that lands it within
//   1.05 times that distance. The path is the same; only the time along it changes.
//   With time_every_edge, each next row of feet meeting a riser (the hind row's climb, each
//   row's step down; a row: the feet at one body x) is timed the same way, by a dip that
//   begins after the touch-downs timed before (and the other trot group's, half a period
//   later) and ends before its own; where none fits, that edge is left as it comes. Every
//   edge timed (the first too) also lands no nearer than half its target past the riser:
//   nearer, the nominal foothold falls in the band beside the riser where the foothold
//   regions leave no room, and the wheel stalls at the riser as one that lands too far does.
//
// Everything here runs once, when a command schedule is set (it allocates); nothing is
// real-time.
#include <Eigen/Core>
#include <vector>

#include "rollstep/lie/se3.hpp"
#include "rollstep/planning/base_reference.hpp"
#include "rollstep/planning/terrain.hpp"

namespace rollstep::planning {

/// The robot's and the controller's numbers the rule needs.
struct SpeedAdaptationLimits {
  double knee_speed = 0.6;      ///< [m/s] vertical speed a swing may ask of a leg, > 0
  double rise = 0.23;           ///< [m] tallest rise a swing is timed for, > 0
  double apex_margin = 0.2;     ///< swing apex placement margin, in (0, 0.5]
  double stance_stroke = 0.21;  ///< [m] body travel over a stance foot held at a riser, > 0
  double max_duty = 0.6;        ///< stance share at low speed, in [min_duty, 1)
  double min_duty = 0.5;        ///< least stance share of the trot, in (0, 1)
};

/// The trot for one speed.
struct TrotTiming {
  double swing = 0.0;             ///< [s] swing duration
  double stance = 0.0;            ///< [s] stance duration
  double period = 0.0;            ///< [s] swing + stance
  double duty = 0.0;              ///< stance / period
  double step_speed_limit = 0.0;  ///< [m/s] the fastest a step can be crossed with this rule
  bool speed_limited = false;     ///< the speed asked exceeds step_speed_limit
  /// [s] The longest the gait may wait at a step's edge (every foot in stance while the body
  /// rolls on): a foot at the edge cannot roll on, so the body may pass over it for at most
  /// stance_stroke / speed (at the speed the gait is timed for: at most the step speed
  /// limit); infinite at speed 0.
  double max_edge_hold = 0.0;
};

/// The trot timed for `speed` [m/s] (its magnitude; the timing of speed 0 is the low-speed
/// trot). Throws std::invalid_argument naming a bad limit or a non-finite speed.
TrotTiming adaptTrotToSpeed(double speed, const SpeedAdaptationLimits& limits);

/// Planar speed of a command [m/s]: |(v_x, v_y)|, plus |yaw rate| times `turn_radius` (how
/// fast the feet farthest from the centre move when turning).
double commandSpeed(const BaseVelocityCommand& command, double turn_radius);

/// The fastest planar speed of a schedule (commandSpeed of each segment).
double maxCommandSpeed(const std::vector<TimedBaseCommand>& schedule, double turn_radius);

/// Where a schedule was slowed down at a step.
struct StepSlowdown {
  double start = 0.0;            ///< [s] from the schedule's start
  double end = 0.0;              ///< [s]
  double commanded_speed = 0.0;  ///< [m/s] planar speed asked
  double limited_speed = 0.0;    ///< [m/s] planar speed given
};

struct SpeedScheduleConfig {
  /// [m/s] planar speed limit near a step; <= 0: none.
  double step_speed_limit = 0.0;
  /// [m] a step counts when it lies within this distance ahead of or behind one of the
  /// sample points along the travel.
  double step_reach = 0.3;
  /// [m] height difference that counts as a step.
  double min_step = 0.03;
  /// [m/s^2] largest change of the planar speed (from rest at the start, between
  /// segments, into and out of a slowdown); <= 0: none.
  double max_acceleration = 0.0;
  /// [s] time resolution of the result (each speed is held at least this long).
  double resolution = 0.02;
  /// [s] how far past the last segment's start the terrain is scanned.
  double scan_time = 120.0;
  /// [m] the turn radius of commandSpeed().
  double turn_radius = 0.4;
  /// The approach timing (see the file comment); off when gait_period <= 0 or touchdowns is
  /// empty. [s] the gait's period.
  double gait_period = 0.0;
  /// [s] Per sample point (foot), the gait times of its touch-downs within a period, each in
  /// [0, gait_period).
  std::vector<std::vector<double>> touchdowns;
  /// [s] The gait time at the schedule's start (the clock runs with the schedule, no waits).
  double gait_time_at_start = 0.0;
  /// Share of the speed kept while the approach waits, in [0, 1).
  double approach_dip = 0.5;
  /// Every next row of feet meeting a riser is timed too (a dip between the touch-downs
  /// timed before and its own), and every edge timed lands at least half its target past
  /// the riser; false: the first touch-down onto a step only, at most 1.05 times its target.
  bool time_every_edge = true;
};

/// What the approach timing did at one edge (a row of feet meeting a riser).
struct EdgeTiming {
  double delay = 0.0;                     ///< [s] the time the schedule was delayed by there
  double dip_start = 0.0, dip_end = 0.0;  ///< [s] the dip, schedule times (delay > 0)
  double touchdown = 0.0;                 ///< [s] the row's first touch-down past the riser
  double target = 0.0;                    ///< [m] where it should land past the riser
  double before = 0.0;                    ///< [m] where it landed past the riser without the delay
  double after = 0.0;                     ///< [m] where it lands with it
  bool up = false;                        ///< onto a higher level
  bool fits = true;                       ///< the dip it needed fits (else it was left as it was)
};

/// What the approach timing did.
struct ApproachTiming {
  bool timed = false;                     ///< a touch-down onto a step was found and timed
  double delay = 0.0;                     ///< [s] the time the approach was delayed by
  double dip_start = 0.0, dip_end = 0.0;  ///< [s] the dip, schedule times
  double touchdown = 0.0;                 ///< [s] the timed touch-down onto the step, schedule time
  double target = 0.0;                    ///< [m] where it should land past the riser
  double before = 0.0;                    ///< [m] where it landed past the riser without the delay
  double after = 0.0;                     ///< [m] where it lands with it
  /// Every edge in the order met (the first is the one above); a later edge is delayed only
  /// where its dip fits between the touch-downs timed before it (and the other trot group's
  /// touch-down half a period after) and its own.
  std::vector<EdgeTiming> edges;
};

/// The schedule the base reference should follow: `schedule` (times from its start; the
/// first 0, increasing) with each command scaled down, direction kept, where the planar
/// path from `start` brings one of the body-frame `samples` within step_reach of a step of
/// `terrain` (so that the speed there is at most step_speed_limit), and with speed changes
/// spread at max_acceleration. The path is the same; only the time along it changes.
/// Appends every slowdown to `slowdowns` (if given). With the gait's timing in `config`, the
/// approach to the first step (and with time_every_edge every later edge) is timed to it (see
/// the file comment; what it did in `approach` if given). Throws std::invalid_argument for a bad
/// schedule or config.
std::vector<TimedBaseCommand> adaptScheduleToTerrain(const std::vector<TimedBaseCommand>& schedule,
                                                     const lie::SE3& start,
                                                     const TerrainModel& terrain,
                                                     const std::vector<Eigen::Vector2d>& samples,
                                                     const SpeedScheduleConfig& config,
                                                     std::vector<StepSlowdown>* slowdowns,
                                                     ApproachTiming* approach = nullptr);

}  // namespace rollstep::planning
