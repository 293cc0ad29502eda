#pragma once
// Base reference q_b,ref(t) from a base velocity command and the terrain.
//
// The command (v_x, v_y, yaw rate) is a twist in the base LOCAL frame, held constant over
// each segment of a command schedule (one segment for a constant command), so the planar
// part of the reference is the SE(3) exponential of the twist (a straight line, or a
// circular arc with a turn): P(t) = P_k * Exp((t - t_k) [v_x, v_y, 0, 0, 0, w_z]) with
// P_0 the start pose reduced to x, y and yaw (rollstep/lie, LOCAL twist convention) and
// P_k the pose where segment k begins.
// The height follows the terrain: z(t) = terrain height + nominal height; roll and pitch
// are zero. The terrain height is, with height_reach = 0, the mean of the terrain heights
// under the configured body-frame sample points: with the single sample (0, 0) the height
// steps at a terrain edge; sampling under the feet spreads a step over the feet crossing
// it. With height_reach > 0 it is the highest TerrainModel::envelopeHeight of the sample
// points along the direction of travel: the body rises on a ramp of height_slope and is up
// when the first foot comes within height_reach of a step up, and comes down only after the
// last foot is height_reach past a step down, so the legs never have to lift a foot onto
// a step by retracting alone.
//
// The reference may be kept within a leash of the robot (follow(): the whole reference moved
// rigidly in the plane when the robot falls further behind, or strays further aside, than
// the leash), so that a robot held back at a step or thrown back is not asked to catch up
// with a reference that ran on without it; the motion is kept as correction() and can be
// handed to another copy of the same reference (setCorrection()).
//
// reset() with one command, follow() and the queries allocate nothing (a schedule of more segments
// than any before allocates in reset). The TerrainModel is held by pointer: it must
// outlive the reference (and may be updated in place between queries).
#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "rollstep/lie/se3.hpp"
#include "rollstep/planning/terrain.hpp"

namespace rollstep::planning {

/// Base velocity command in the base local frame: [m/s], [m/s], [rad/s].
struct BaseVelocityCommand {
  double v_x = 0.0;
  double v_y = 0.0;
  double yaw_rate = 0.0;
};

/// One segment of a command schedule: `command` from `time` [s] after the reset on.
struct TimedBaseCommand {
  double time = 0.0;
  BaseVelocityCommand command;
};

struct BaseReferenceConfig {
  /// Base frame height above the terrain [m] (robot-specific: from the robot's config).
  double nominal_height = 0.0;
  /// Body-frame (x, y) points [m] where the terrain height is sampled (averaged when
  /// height_reach = 0, the highest envelope otherwise).
  std::vector<Eigen::Vector2d> height_samples{Eigen::Vector2d::Zero()};
  /// [m] Distance ahead of and behind each sample, along the direction of travel, within
  /// which the terrain counts fully (TerrainModel::envelopeHeight); 0: the mean.
  double height_reach = 0.0;
  /// Height lost per metre beyond height_reach [-] (the ramp's grade), >= 0.
  double height_slope = 0.0;
  /// velocityAt() carries the rate of the height reference as its vertical velocity (with
  /// height_reach > 0 only: the mean of height_reach = 0 steps at an edge and has no rate).
  bool height_rate = false;
};

class BaseReference {
 public:
  /// Throws std::invalid_argument for a non-finite nominal height, no or non-finite
  /// samples (naming the parameter and value).
  BaseReference(const TerrainModel& terrain, BaseReferenceConfig config);

  /// Starts the reference at time t0 from `start` (its x, y and yaw) with `command`.
  /// Throws std::invalid_argument naming a non-finite argument.
  void reset(double t0, const lie::SE3& start, const BaseVelocityCommand& command);
  /// Same with a command schedule: segment k holds from t0 + schedule[k].time on. Throws
  /// std::invalid_argument naming the entry: an empty schedule, a first time other than 0,
  /// times not increasing, non-finite values.
  void resetSchedule(double t0, const lie::SE3& start,
                     const std::vector<TimedBaseCommand>& schedule);

  /// Keeps the reference within a leash of the robot at time t: when the planar reference
  /// pose at t lies further than max_distance [m] from `measured`'s x, y, or its yaw further
  /// than max_yaw [rad] from `measured`'s, the whole reference (every segment, past and
  /// future) is moved rigidly in the plane so that it lies exactly that far, in the same
  /// direction. max_distance or max_yaw 0 (or less) leaves that part free. Returns whether
  /// the reference moved. max_lateral > 0 keeps, before that, the sideways part of the
  /// offset (across the reference's heading at t) within max_lateral: a robot that falls
  /// behind its reference sideways is not asked to catch up across the terrain; 0 (or less)
  /// leaves it free. Throws std::invalid_argument for non-finite arguments.
  bool follow(double t, const lie::SE3& measured, double max_distance, double max_yaw,
              double max_lateral = 0.0);
  /// The planar rigid motion follow() has applied since the last reset (identity after it):
  /// poseAt(t) = correction() * (the pose of the reset's command schedule at t).
  const lie::SE3& correction() const { return correction_; }
  /// Sets that motion (e.g. the correction of another copy of this reference); it must be a
  /// planar motion (rotation about z). A non-finite one (or a zero quaternion) is refused:
  /// returns false and changes nothing.
  bool setCorrection(const lie::SE3& correction) noexcept;

  /// q_b,ref(t) (any t; before t0 the command is extrapolated backwards).
  lie::SE3 poseAt(double t) const;
  /// The planar pose (x, y, yaw; z = 0) at t.
  lie::SE3 planarPoseAt(double t) const;
  /// The local-frame velocity reference [v_x, v_y, 0, 0, 0, yaw rate] (linear first) at t.
  lie::Vector6d twistAt(double t) const;
  /// twistAt(startTime()): the first segment's.
  lie::Vector6d twist() const;
  /// The velocity of poseAt(t) in its own (local) frame: twistAt(t), plus the height
  /// reference's rate [m/s] as v_z when config().height_rate and height_reach > 0 (the
  /// reference has no roll or pitch, so its local z is the world's). The rate is a central
  /// difference over +-kRateStep: the height is piecewise linear along the travel, so it is
  /// exact except within kRateStep of a kink of the ramp.
  lie::Vector6d velocityAt(double t) const;
  /// [s] half step of velocityAt()'s difference.
  static constexpr double kRateStep = 0.01;
  /// World (x, y) of a body-frame (x, y) point at time t (nominal footholds).
  Eigen::Vector2d worldPoint(const Eigen::Vector2d& body_xy, double t) const;
  /// Averaged terrain height under the sample points at time t.
  double terrainHeightAt(double t) const;

  const BaseReferenceConfig& config() const { return config_; }
  /// The first segment's command.
  const BaseVelocityCommand& command() const { return segments_.front().command; }
  double startTime() const { return t0_; }

 private:
  struct Segment {
    double start_time;  // absolute [s]
    BaseVelocityCommand command;
    lie::SE3 start;  // planar pose at start_time
  };
  const Segment& segmentAt(double t) const;
  void resetSegments(double t0, const lie::SE3& start, const TimedBaseCommand* schedule,
                     std::size_t n);

  const TerrainModel* terrain_;
  BaseReferenceConfig config_;
  double t0_ = 0.0;
  std::vector<Segment> segments_;
  lie::SE3 correction_;  // follow()'s planar motion, applied after the segments
};

}  // namespace rollstep::planning
