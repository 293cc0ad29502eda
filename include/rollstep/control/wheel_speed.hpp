#pragma once
// Drive-wheel speed commands from a commanded state (pipeline.hpp, "Drive-wheel speed"),
// shared by the NMPC pipeline and the CBF-QP baseline: each drive wheel's speed relative to
// its shank is the wheel centre's velocity along the wheel's heading (the contact frame's x
// axis projected on the ground) over the wheel radius (the robot's contact offset), minus
// the shank's own rotation rate about the axle (the contact frame's y axis); plus the
// ground speed a yaw rate `extra_yaw_rate` (world z) about the base origin gives the wheel
// centre along its heading, over the radius (skid-steering compensation; 0: none); plus
// `extra_velocity` (world x, y) along its heading over the radius (the skid-steering
// velocity feedback; zero: none).
// A non-finite speed is written as 0. Never allocates, locks or throws.
#include <Eigen/Core>
#include <vector>

#include "rollstep/centroidal/robot.hpp"
#include "rollstep/model/data.hpp"

namespace rollstep::control {

/// `out[w]` for the contact drive_wheels[w]; runs forward kinematics of (q, v) in `data`.
void computeDriveWheelSpeeds(const centroidal::CentroidalRobot& robot, model::Data& data,
                             const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                             const std::vector<int>& drive_wheels, double extra_yaw_rate,
                             const Eigen::Vector2d& extra_velocity,
                             Eigen::Ref<Eigen::VectorXd> out) noexcept;

}  // namespace rollstep::control
