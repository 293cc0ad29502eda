#pragma once
// Static generalized forces.
//  g(q) = - sum_i J_com_i^T m_i gravity: the gravity term of the equations of motion
//  (the generalized force that holds the robot against gravity), nv, free-flyer part in the
//  base LOCAL frame [force; torque about the base origin].
//  tauContact = sum_c J_c(q)^T f_c: f_c a world-frame force applied at the origin of frame c,
//  J_c the linear rows of its LOCAL_WORLD_ALIGNED Jacobian.
//  S (g + J^T f): the actuated rows are the last nj, i.e. tau.tail(model.nj).
#include <vector>

#include "rollstep/model/data.hpp"

namespace rollstep::model {

/// Fills data.g.
const Eigen::VectorXd& computeGeneralizedGravity(const Model& model, Data& data,
                                                 const Eigen::Ref<const Eigen::VectorXd>& q);
/// Fills data.tauContact. `forces` stacks the 3D world forces (3 * frames.size()).
const Eigen::VectorXd& computeContactTorque(const Model& model, Data& data,
                                            const Eigen::Ref<const Eigen::VectorXd>& q,
                                            const std::vector<FrameIndex>& frames,
                                            const Eigen::Ref<const Eigen::VectorXd>& forces);
/// Fills data.tauStatic = g(q) + J(q)^T f (and data.g, data.tauContact).
const Eigen::VectorXd& computeStaticTorque(const Model& model, Data& data,
                                           const Eigen::Ref<const Eigen::VectorXd>& q,
                                           const std::vector<FrameIndex>& frames,
                                           const Eigen::Ref<const Eigen::VectorXd>& forces);

}  // namespace rollstep::model
