#pragma once
// Residuals of the centroidal OCP's costs (paper Sec. 2.5, DESIGN.md section 3); wrap each
// in an ocp::LeastSquaresCost with its weights.
//
//  - BaseVelocityResidual: v_b(x, u) - v_ref (6 rows), v_b = A_b^-1 (h - A_J v_J) the base
//    twist in the base LOCAL frame [linear; angular]; v_ref = BaseReference::velocityAt(t)
//    when a base reference is given (the command's twist, plus the height ramp's rate as
//    v_z with ocp.base_height_rate), else the constant set by setReference (default 0).
//  - StateTrackingResidual: x (-) x_ref(t), x_ref(t) = (q_b,ref(t) = BaseReference::poseAt(t),
//    q_J,ref, h = 0); without a base reference the base pose reference is constant.
//  - InputTrackingResidual: u - u_ref(t), u_ref zero except the stance contacts' forces,
//    -m g / (number of stance contacts) each (world z: total weight / n), from ctx.mode.
//
// The tracking residuals only override reference(), so LeastSquaresCost takes its
// structured (identity-Jacobian) path for them. Nothing here allocates after construction.
#include <memory>

#include "rollstep/centroidal/residual_data.hpp"
#include "rollstep/ocp/residuals.hpp"
#include "rollstep/planning/base_reference.hpp"

namespace rollstep::centroidal {

class BaseVelocityResidual final : public ocp::Residual {
 public:
  /// `base` may be null (constant reference). Throws std::invalid_argument for a null
  /// precomputation.
  BaseVelocityResidual(std::shared_ptr<const CentroidalPrecomputation> pre,
                       std::shared_ptr<const planning::BaseReference> base = nullptr);
  /// Constant reference used when no base reference is given.
  void setReference(const lie::Vector6d& v_ref) { v_ref_ = v_ref; }
  /// The reference at this node.
  lie::Vector6d reference(const ocp::NodeContext& ctx) const;
  std::unique_ptr<ocp::ResidualData> createData() const override;
  std::unique_ptr<ocp::ResidualData> createDataWithNodeCache() const override;
  void calc(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
            ocp::ResidualData& d) const override;
  void calcDiff(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
                ocp::ResidualData& d) const override;

 private:
  std::shared_ptr<const CentroidalPrecomputation> pre_;
  std::shared_ptr<const planning::BaseReference> base_;
  lie::Vector6d v_ref_ = lie::Vector6d::Zero();
};

class StateTrackingResidual final : public ocp::StateErrorResidual {
 public:
  /// @param joint_reference q_J,ref (nj). @param base null: the base pose reference is
  /// `constant_base_pose` (x, y, z, qx, qy, qz, qw; default identity at the origin).
  /// Throws std::invalid_argument for a null robot or wrong sizes.
  StateTrackingResidual(std::shared_ptr<const CentroidalRobot> robot,
                        const Eigen::VectorXd& joint_reference,
                        std::shared_ptr<const planning::BaseReference> base = nullptr,
                        const lie::Vector7d& constant_base_pose = identityPose());
  void reference(const ocp::NodeContext& ctx, ocp::VecRef x_ref) const override;
  static lie::Vector7d identityPose() { return lie::SE3::Identity().coeffs(); }

 private:
  std::shared_ptr<const planning::BaseReference> base_;
};

/// The paper's reference contact forces of `mode`: the stance contacts share the weight
/// (-m g / n each, world frame), swing contacts carry none. Writes only the force entries
/// of u (robot.inputForceIndex); joint velocities are left as they are.
void setStanceForceReference(const CentroidalRobot& robot, int mode, ocp::VecRef u);

class InputTrackingResidual final : public ocp::InputErrorResidual {
 public:
  /// Throws std::invalid_argument for a null robot.
  explicit InputTrackingResidual(std::shared_ptr<const CentroidalRobot> robot);
  void reference(const ocp::NodeContext& ctx, ocp::VecRef u_ref) const override;

 private:
  std::shared_ptr<const CentroidalRobot> robot_;
};

}  // namespace rollstep::centroidal
