#pragma once
// Small helpers on base commands and poses shared by the planning sources that follow a
// command schedule (base reference, speed rule, sideways hold).
#include <Eigen/Geometry>
#include <cmath>

#include "rollstep/lie/se3.hpp"
#include "rollstep/planning/base_reference.hpp"

namespace rollstep::planning::detail {

/// The body twist of a planar command (v_x, v_y, yaw rate).
inline lie::Vector6d twistOf(const BaseVelocityCommand& c) {
  lie::Vector6d v;
  v << c.v_x, c.v_y, 0.0, 0.0, 0.0, c.yaw_rate;
  return v;
}

inline bool sameCommand(const BaseVelocityCommand& a, const BaseVelocityCommand& b) {
  return a.v_x == b.v_x && a.v_y == b.v_y && a.yaw_rate == b.yaw_rate;
}

/// The heading of an orientation (rotation about the world z axis of its x axis).
inline double yawOf(const Eigen::Quaterniond& q) {
  const Eigen::Matrix3d r = q.toRotationMatrix();
  return std::atan2(r(1, 0), r(0, 0));
}

}  // namespace rollstep::planning::detail
