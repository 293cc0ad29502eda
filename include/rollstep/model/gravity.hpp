#pragma once
// Static generalized forces.
//  g(q) = - sum_i J_com_i^T m_i gravity: the gravity term of the equations of motion
//  (the generalized force that holds the robot against gravity), nv, free-flyer part in the
//  base LOCAL frame [force; torque about the base origin].
//  tauContact = sum_c J_c(q)^T f_c: f_c a world-frame force applied at the origin of frame c,
//  J_c the linear rows of its LOCAL_WORLD_ALIGNED Jacobian.
//  Static torque: with f the contact forces acting ON the robot (as in the centroidal
//  dynamics h_lin' = sum f + m gravity), static equilibrium M(q) 0 + g(q) = S^T tau + J^T f
//  gives the joint torques tau = S (g(q) - J(q)^T f): the actuated rows are the last nj,
//  i.e. tauStatic.tail(model.nj). (The paper's S (g + J^T f) uses g = gravity force = -g
//  here; with symmetric limits both give the same constraint.)
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
/// Fills data.tauStatic = g(q) - J(q)^T f, f acting on the robot (and data.g,
/// data.tauContact = J^T f). Its base rows vanish at a static equilibrium.
const Eigen::VectorXd& computeStaticTorque(const Model& model, Data& data,
                                           const Eigen::Ref<const Eigen::VectorXd>& q,
                                           const std::vector<FrameIndex>& frames,
                                           const Eigen::Ref<const Eigen::VectorXd>& forces);

}  // namespace rollstep::model
