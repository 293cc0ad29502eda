#pragma once
// Base reference q_b,ref(t) from a base velocity command and the terrain.
//
// The command (v_x, v_y, yaw rate) is a twist in the base LOCAL frame, held constant, so
// the planar part of the reference is the SE(3) exponential of the twist (a straight
// line, or a circular arc with a turn): P(t) = P0 * Exp((t - t0) [v_x, v_y, 0, 0, 0, w_z])
// with P0 the start pose reduced to x, y and yaw (rollstep/lie, LOCAL twist convention).
// The height follows the terrain: z(t) = mean of the terrain heights under the
// configured body-frame sample points + nominal height; roll and pitch are zero. With
// the single sample (0, 0) the height steps at a terrain edge; sampling under the feet
// spreads a step over the feet crossing it.
//
// reset() and the queries allocate nothing. The TerrainModel is held by pointer: it must
// outlive the reference (and may be updated in place between queries).
#include <Eigen/Core>
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

struct BaseReferenceConfig {
  /// Base frame height above the terrain [m] (robot-specific: from the robot's config).
  double nominal_height = 0.0;
  /// Body-frame (x, y) points [m] where the terrain height is sampled and averaged.
  std::vector<Eigen::Vector2d> height_samples{Eigen::Vector2d::Zero()};
};

class BaseReference {
 public:
  /// Throws std::invalid_argument for a non-finite nominal height, no or non-finite
  /// samples (naming the parameter and value).
  BaseReference(const TerrainModel& terrain, BaseReferenceConfig config);

  /// Starts the reference at time t0 from `start` (its x, y and yaw) with `command`.
  /// Throws std::invalid_argument naming a non-finite argument.
  void reset(double t0, const lie::SE3& start, const BaseVelocityCommand& command);

  /// q_b,ref(t) (any t; before t0 the command is extrapolated backwards).
  lie::SE3 poseAt(double t) const;
  /// The planar pose (x, y, yaw; z = 0) at t.
  lie::SE3 planarPoseAt(double t) const;
  /// The local-frame velocity reference [v_x, v_y, 0, 0, 0, yaw rate] (linear first).
  lie::Vector6d twist() const;
  /// World (x, y) of a body-frame (x, y) point at time t (nominal footholds).
  Eigen::Vector2d worldPoint(const Eigen::Vector2d& body_xy, double t) const;
  /// Averaged terrain height under the sample points at time t.
  double terrainHeightAt(double t) const;

  const BaseReferenceConfig& config() const { return config_; }
  const BaseVelocityCommand& command() const { return command_; }
  double startTime() const { return t0_; }

 private:
  const TerrainModel* terrain_;
  BaseReferenceConfig config_;
  BaseVelocityCommand command_;
  double t0_ = 0.0;
  lie::SE3 start_;  // planar
};

}  // namespace rollstep::planning
