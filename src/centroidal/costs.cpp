// BaseVelocityResidual, StateTrackingResidual, InputTrackingResidual (costs.hpp).
#include "rollstep/centroidal/costs.hpp"

#include <stdexcept>
#include <string>

namespace rollstep::centroidal {

// ---- BaseVelocityResidual -------------------------------------------------------------

BaseVelocityResidual::BaseVelocityResidual(std::shared_ptr<const CentroidalPrecomputation> pre,
                                           std::shared_ptr<const planning::BaseReference> base)
    : ocp::Residual(pre ? pre->robot().ndx() : 0, pre ? pre->robot().nu() : 0, 6),
      pre_(std::move(pre)),
      base_(std::move(base)) {
  if (!pre_) throw std::invalid_argument("BaseVelocityResidual: null precomputation");
}

lie::Vector6d BaseVelocityResidual::reference(const ocp::NodeContext& ctx) const {
  return base_ ? base_->velocityAt(ctx.time) : v_ref_;
}

std::unique_ptr<ocp::ResidualData> BaseVelocityResidual::createData() const {
  return std::make_unique<CentroidalResidualData>(pre_->robot(), maxRows(), false);
}

std::unique_ptr<ocp::ResidualData> BaseVelocityResidual::createDataWithNodeCache() const {
  return std::make_unique<CentroidalResidualData>(pre_->robot(), maxRows(), true);
}

void BaseVelocityResidual::calc(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
                                ocp::ResidualData& d) const {
  auto& data = static_cast<CentroidalResidualData&>(d);
  const CentroidalCache& c = nodeCache(ctx, x, u, false, *pre_, data.fallback.get());
  d.r.head<6>() = c.vb - reference(ctx);
}

void BaseVelocityResidual::calcDiff(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                    ocp::ConstVecRef u, ocp::ResidualData& d) const {
  auto& data = static_cast<CentroidalResidualData&>(d);
  const CentroidalCache& c = nodeCache(ctx, x, u, true, *pre_, data.fallback.get());
  d.Rx.topRows<6>() = c.dvb_dx;
  d.Ru.topRows<6>() = c.dvb_du;
}

// ---- StateTrackingResidual ------------------------------------------------------------

namespace {
Eigen::VectorXd stateReference(const std::shared_ptr<const CentroidalRobot>& robot,
                               const Eigen::VectorXd& joint_reference,
                               const lie::Vector7d& base_pose) {
  if (!robot) throw std::invalid_argument("StateTrackingResidual: null robot");
  if (joint_reference.size() != robot->nj()) {
    throw std::invalid_argument("StateTrackingResidual: joint reference of size " +
                                std::to_string(joint_reference.size()) + ", expected " +
                                std::to_string(robot->nj()));
  }
  if (!joint_reference.allFinite() || !base_pose.allFinite() ||
      std::abs(base_pose.tail<4>().norm() - 1.0) > 1e-9) {
    throw std::invalid_argument(
        "StateTrackingResidual: non-finite joint reference or base pose, or a base pose "
        "quaternion that is not of unit norm");
  }
  Eigen::VectorXd x(robot->nx());
  x << base_pose, joint_reference, lie::Vector6d::Zero();
  return x;
}
}  // namespace

StateTrackingResidual::StateTrackingResidual(std::shared_ptr<const CentroidalRobot> robot,
                                             const Eigen::VectorXd& joint_reference,
                                             std::shared_ptr<const planning::BaseReference> base,
                                             const lie::Vector7d& constant_base_pose)
    : ocp::StateErrorResidual(robot ? robot->space() : nullptr, robot ? robot->nu() : 0,
                              stateReference(robot, joint_reference, constant_base_pose)),
      base_(std::move(base)) {}

void StateTrackingResidual::reference(const ocp::NodeContext& ctx, ocp::VecRef x_ref) const {
  x_ref = x_ref_;
  if (base_) x_ref.head<7>() = base_->poseAt(ctx.time).coeffs();
}

// ---- InputTrackingResidual ------------------------------------------------------------

InputTrackingResidual::InputTrackingResidual(std::shared_ptr<const CentroidalRobot> robot)
    : ocp::InputErrorResidual(robot ? robot->ndx() : 0,
                              Eigen::VectorXd::Zero(robot ? robot->nu() : 0)),
      robot_(std::move(robot)) {
  if (!robot_) throw std::invalid_argument("InputTrackingResidual: null robot");
}

void setStanceForceReference(const CentroidalRobot& robot, int mode, ocp::VecRef u) {
  int n = 0;
  for (int i = 0; i < robot.nc(); ++i) n += CentroidalRobot::inStance(mode, i) ? 1 : 0;
  const Eigen::Vector3d f = n > 0 ? Eigen::Vector3d(-(robot.mass() / n) * robot.model().gravity)
                                  : Eigen::Vector3d::Zero();
  for (int i = 0; i < robot.nc(); ++i) {
    u.segment<3>(robot.inputForceIndex(i)) =
        CentroidalRobot::inStance(mode, i) ? f : Eigen::Vector3d::Zero();
  }
}

void InputTrackingResidual::reference(const ocp::NodeContext& ctx, ocp::VecRef u_ref) const {
  u_ref.setZero();
  setStanceForceReference(*robot_, ctx.mode, u_ref);
}

}  // namespace rollstep::centroidal
