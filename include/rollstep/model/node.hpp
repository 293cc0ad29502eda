#pragma once
// Everything one MPC node needs from the rigid-body model, in one call that shares passes.
#include <vector>

#include "rollstep/model/data.hpp"

namespace rollstep::model {

/// Outputs of computeNodeQuantities for a fixed set of contact frames (sized once here).
struct NodeQuantities {
  NodeQuantities(const Model& model, std::vector<FrameIndex> contact_frames);

  std::vector<FrameIndex> contactFrames;
  int nc() const { return static_cast<int>(contactFrames.size()); }

  Eigen::Matrix3Xd contactPositions;   ///< 3 x nc, world positions of the frame origins
  Eigen::Matrix3Xd contactVelocities;  ///< 3 x nc, world linear velocities
  /// 3nc x nv; rows 3c..3c+2: d p_c/dq = d v_c/dv (LOCAL_WORLD_ALIGNED linear Jacobian).
  Eigen::MatrixXd contactJacobians;
  Eigen::MatrixXd contactVelocityDerivatives;  ///< 3nc x nv, d v_c/dq
  Eigen::Vector3d com = Eigen::Vector3d::Zero();
  Eigen::Matrix3Xd comJacobian;       ///< 3 x nv, d com/dq
  Vector6d h = Vector6d::Zero();      ///< A(q) v, [linear; angular about com], world
  Matrix6Xd A;                        ///< 6 x nv, = dh/dv; A_b = A.leftCols(nvBase)
  Matrix6Xd dh_dq;                    ///< 6 x nv
  Eigen::VectorXd g;                  ///< nv generalized gravity
  Eigen::MatrixXd dg_dq;              ///< nv x nv
  Eigen::VectorXd contactTorque;      ///< nv, J^T f (static torque: S (g - J^T f))
  Eigen::MatrixXd dContactTorque_dq;  ///< nv x nv at fixed f
  Eigen::VectorXd v;                  ///< nv, the generalized velocity used

  // Filled by computeNodeQuantitiesFromMomentum only (free-flyer models).
  lie::Matrix6d AbInverse = lie::Matrix6d::Identity();  ///< A_b(q)^-1
  Matrix6Xd dvb_dq;   ///< 6 x nv, d v_b/dq at fixed h, v_J: -A_b^-1 dh_dq
  Matrix6Xd dvb_dvJ;  ///< 6 x nj, d v_b/dv_J at fixed q, h: -A_b^-1 A_J
};

/// Computes every NodeQuantities member at (q, v) with world contact forces `forces`
/// (3 * nc, stacked in contactFrames order). Allocation-free. Also leaves data's
/// placements, velocities, J, com quantities valid.
void computeNodeQuantities(const Model& model, Data& data,
                           const Eigen::Ref<const Eigen::VectorXd>& q,
                           const Eigen::Ref<const Eigen::VectorXd>& v,
                           const Eigen::Ref<const Eigen::VectorXd>& forces, NodeQuantities& out);

/// Full-centroidal variant: the base twist is not an input but follows from the centroidal
/// momentum, v_b = A_b(q)^-1 (h - A_J(q) v_J) (DESIGN.md section 2); then everything above
/// is computed at v = (v_b, v_J), and also out.AbInverse, out.dvb_dq, out.dvb_dvJ.
/// All derivatives in `out` other than dvb_* are partial derivatives at fixed v; the total
/// derivative of a velocity quantity y(q, v) w.r.t. q at fixed (h, v_J) is
/// dy/dq + dy/dv_b * dvb_dq. Requires a free-flyer model (throws std::invalid_argument).
void computeNodeQuantitiesFromMomentum(const Model& model, Data& data,
                                       const Eigen::Ref<const Eigen::VectorXd>& q,
                                       const Vector6d& h,
                                       const Eigen::Ref<const Eigen::VectorXd>& vJ,
                                       const Eigen::Ref<const Eigen::VectorXd>& forces,
                                       NodeQuantities& out);

}  // namespace rollstep::model
