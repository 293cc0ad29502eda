#pragma once
// The state the control pipeline runs on: what the state estimator or the
// simulator's ground truth provides, in the model's conventions. The pipeline takes its
// state through this one struct, so an estimator can be swapped in for ground truth.
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "rollstep/model/model.hpp"

namespace rollstep::control {

struct RobotState {
  double time = 0.0;                                                     ///< [s]
  Eigen::Vector3d base_position = Eigen::Vector3d::Zero();               ///< world [m]
  Eigen::Quaterniond base_orientation = Eigen::Quaterniond::Identity();  ///< base -> world
  Eigen::Vector3d base_linear_velocity = Eigen::Vector3d::Zero();        ///< WORLD frame [m/s]
  Eigen::Vector3d base_angular_velocity = Eigen::Vector3d::Zero();       ///< LOCAL [rad/s]
  Eigen::VectorXd joint_position;  ///< nj, the model's joint order (Model::jointNames)
  Eigen::VectorXd joint_velocity;  ///< nj

  /// Sized for `nj` joints, at rest at the origin.
  static RobotState zero(int nj) {
    RobotState s;
    s.joint_position = Eigen::VectorXd::Zero(nj);
    s.joint_velocity = Eigen::VectorXd::Zero(nj);
    return s;
  }
  /// True if every entry is finite, the quaternion has unit norm within 1e-6 and the joint
  /// vectors have nj entries.
  bool valid(int nj) const;
};

/// The model's configuration q = [p, quat (x y z w), q_J] (nq) and velocity
/// v = [v_lin LOCAL, omega LOCAL, v_J] (nv) of a free-flyer model. Sizes must match; no
/// allocation.
void toModelState(const RobotState& state, Eigen::Ref<Eigen::VectorXd> q,
                  Eigen::Ref<Eigen::VectorXd> v);
/// The inverse of toModelState (the quaternion is normalised); `state` must be sized.
void fromModelState(double time, const Eigen::Ref<const Eigen::VectorXd>& q,
                    const Eigen::Ref<const Eigen::VectorXd>& v, RobotState& state);

}  // namespace rollstep::control
