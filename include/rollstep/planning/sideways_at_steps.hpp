#pragma once
// Sideways motion held back over steps.
//
// A leg without hip abduction reaches forwards, backwards and down, not sideways: a wheel
// cannot be set down beside its hip, and a foot that must cross an edge sideways (off the
// side of a block, or onto a riser it approaches at a slant) has nowhere to land but the
// edge itself. Such a robot moves sideways only by slip and yaw, and over a step that
// costs the footholds: the yaw turns the legs off their line across the edge. So the
// sideways part of a command (v_y) is held back wherever moving on would carry a foot across
// a step within `reach`: ahead along the travel, ahead along the body's x axis (the way
// v_x goes) or sideways (the way v_y goes). The forward part and the yaw rate are kept: the
// robot crosses the step straight and takes up its sideways motion again once every foot
// is `reach` clear of it. A command with no forward part stops beside such an edge (a
// sideways step off a block is not taken). The sideways speed changes at most
// max_acceleration.
//
// Runs once, when a command schedule is set (it allocates); nothing is real-time.
#include <Eigen/Core>
#include <vector>

#include "rollstep/lie/se3.hpp"
#include "rollstep/planning/base_reference.hpp"
#include "rollstep/planning/terrain.hpp"

namespace rollstep::planning {

struct SidewaysHoldConfig {
  /// [m] a step counts when a sample point would cross it within this distance.
  double reach = 0.3;
  /// [m] height difference that counts as a step.
  double min_step = 0.03;
  /// [m/s^2] largest change of the sideways speed; <= 0: none (held at once).
  double max_acceleration = 0.0;
  /// [s] time resolution of the result.
  double resolution = 0.02;
  /// [s] how far past the last segment's start the terrain is scanned.
  double scan_time = 120.0;
};

/// Where the sideways part of a command was held back.
struct SidewaysHold {
  double start = 0.0;  ///< [s] from the schedule's start
  double end = 0.0;    ///< [s]
};

/// `schedule` (times from its start; the first 0, increasing) with the sideways part v_y of
/// each command held back (see the file comment) where the path from `start` (the path of
/// the result, as BaseReference integrates it) would carry one of the body-frame `samples`
/// across a step of `terrain`. Unchanged without terrain regions or without a sideways
/// command. Appends each hold to `holds` (if given). Throws std::invalid_argument for a bad
/// schedule or config.
std::vector<TimedBaseCommand> holdSidewaysAtSteps(const std::vector<TimedBaseCommand>& schedule,
                                                  const lie::SE3& start,
                                                  const TerrainModel& terrain,
                                                  const std::vector<Eigen::Vector2d>& samples,
                                                  const SidewaysHoldConfig& config,
                                                  std::vector<SidewaysHold>* holds);

}  // namespace rollstep::planning
