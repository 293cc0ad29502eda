#pragma once
// Centre of mass and its Jacobian (= its derivative w.r.t. the tangent dq).
#include "rollstep/model/data.hpp"

namespace rollstep::model {

/// World centre of mass; fills data.com, data.ocom, data.subtreeMoment and placements.
const Eigen::Vector3d& centerOfMass(const Model& model, Data& data,
                                    const Eigen::Ref<const Eigen::VectorXd>& q);
/// d com/dq = d com_dot/dv (3 x nv); fills data.Jcom, data.com and data.J.
const Eigen::Matrix3Xd& jacobianCenterOfMass(const Model& model, Data& data,
                                             const Eigen::Ref<const Eigen::VectorXd>& q);

}  // namespace rollstep::model
