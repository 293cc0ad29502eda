#pragma once
// Forward kinematics, frame placements, frame velocities and frame Jacobians.
#include "rollstep/model/data.hpp"

namespace rollstep::model {

/// Body placements: fills data.oRb, data.opb.
void forwardKinematics(const Model& model, Data& data, const Eigen::Ref<const Eigen::VectorXd>& q);
/// Body placements and velocities: also fills data.ov and data.J.
void forwardKinematics(const Model& model, Data& data, const Eigen::Ref<const Eigen::VectorXd>& q,
                       const Eigen::Ref<const Eigen::VectorXd>& v);

/// Frame placements from the body placements: fills data.oRf, data.opf (all frames).
void updateFramePlacements(const Model& model, Data& data);
/// One frame only (data.oRf[f], data.opf[f]).
void updateFramePlacement(const Model& model, Data& data, FrameIndex frame);
/// World placement of a frame as an SE3 (after forwardKinematics).
lie::SE3 getFramePlacement(const Model& model, const Data& data, FrameIndex frame);

/// Spatial velocity [linear; angular] of a frame (after forwardKinematics(q, v)).
Vector6d getFrameVelocity(const Model& model, const Data& data, FrameIndex frame,
                          ReferenceFrame rf);

/// Placements and the world joint Jacobian data.J (6 x nv).
void computeJointJacobians(const Model& model, Data& data,
                           const Eigen::Ref<const Eigen::VectorXd>& q);
/// Frame Jacobian J (6 x nv, [linear; angular] rows) such that getFrameVelocity = J v
/// (after computeJointJacobians or forwardKinematics(q, v)). Columns outside the frame's
/// support are set to zero.
void getFrameJacobian(const Model& model, const Data& data, FrameIndex frame, ReferenceFrame rf,
                      Eigen::Ref<Eigen::MatrixXd> J);

}  // namespace rollstep::model
