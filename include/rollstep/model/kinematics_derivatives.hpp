#pragma once
// Derivatives of frame positions and frame linear velocities (world axes).
#include "rollstep/model/kinematics.hpp"

namespace rollstep::model {

/// Placements, velocities and joint Jacobians (same as forwardKinematics(q, v)); call it
/// before the getters below.
void computeForwardKinematicsDerivatives(const Model& model, Data& data,
                                         const Eigen::Ref<const Eigen::VectorXd>& q,
                                         const Eigen::Ref<const Eigen::VectorXd>& v);

/// d p_f / dq (3 x nv): world position of the frame origin w.r.t. the tangent dq. It equals
/// the linear rows of the LOCAL_WORLD_ALIGNED frame Jacobian.
void getFramePositionDerivative(const Model& model, const Data& data, FrameIndex frame,
                                Eigen::Ref<Eigen::MatrixXd> dp_dq);

/// Derivatives (3 x nv each) of the world linear velocity of the frame origin
/// v_f = J_lin(q) v w.r.t. q (tangent) and v.
void getFrameLinearVelocityDerivatives(const Model& model, const Data& data, FrameIndex frame,
                                       Eigen::Ref<Eigen::MatrixXd> dv_dq,
                                       Eigen::Ref<Eigen::MatrixXd> dv_dv);

}  // namespace rollstep::model
