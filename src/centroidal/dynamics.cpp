#include "rollstep/centroidal/dynamics.hpp"

#include <stdexcept>

#include "rollstep/lie/so3.hpp"

namespace rollstep::centroidal {

namespace {
struct CentroidalDynamicsData final : ocp::DynamicsData {
  CentroidalDynamicsData(const CentroidalRobot& robot, bool node_cache)
      : fallback(makeFallbackCache(robot, node_cache)), angular_dq(3, robot.nv()) {}
  std::unique_ptr<CentroidalCache> fallback;  ///< used when the node has no shared cache
  Eigen::Matrix3Xd angular_dq;                ///< d(sum of contact torques)/dq
};
}  // namespace

CentroidalDynamics::CentroidalDynamics(std::shared_ptr<const CentroidalPrecomputation> pre)
    : ocp::ContinuousDynamics(pre ? pre->robot().space() : nullptr, pre ? pre->robot().nu() : 0),
      pre_(std::move(pre)) {
  if (!pre_) throw std::invalid_argument("CentroidalDynamics: null precomputation");
}

std::unique_ptr<ocp::DynamicsData> CentroidalDynamics::createData() const {
  return std::make_unique<CentroidalDynamicsData>(robot(), false);
}

std::unique_ptr<ocp::DynamicsData> CentroidalDynamics::createDataWithNodeCache() const {
  return std::make_unique<CentroidalDynamicsData>(robot(), true);
}

void CentroidalDynamics::calc(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
                              ocp::DynamicsData& d, ocp::VecRef xdot) const {
  auto& data = static_cast<CentroidalDynamicsData&>(d);
  const CentroidalCache& c = nodeCache(ctx, x, u, false, *pre_, data.fallback.get());
  const CentroidalRobot& r = robot();
  const int nj = r.nj();
  const int ih = r.tangentMomentumIndex();
  xdot.head<6>() = c.vb;
  xdot.segment(6, nj) = u.head(nj);
  Eigen::Vector3d force = r.mass() * r.model().gravity;
  Eigen::Vector3d torque = Eigen::Vector3d::Zero();
  const Eigen::Vector3d lever0 = c.nq.com + r.contactOffset() * Eigen::Vector3d::UnitZ();
  for (int i = 0; i < r.nc(); ++i) {
    const Eigen::Vector3d fi = u.segment<3>(r.inputForceIndex(i));
    force += fi;
    torque += (c.footPosition(i) - lever0).cross(fi);
  }
  xdot.segment<3>(ih) = force;
  xdot.segment<3>(ih + 3) = torque;
}

void CentroidalDynamics::calcDiff(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                  ocp::ConstVecRef u, ocp::DynamicsData& d, ocp::MatRef fx,
                                  ocp::MatRef fu) const {
  auto& data = static_cast<CentroidalDynamicsData&>(d);
  const CentroidalCache& c = nodeCache(ctx, x, u, true, *pre_, data.fallback.get());
  const CentroidalRobot& r = robot();
  const int nj = r.nj();
  const int nv = r.nv();
  const int ih = r.tangentMomentumIndex();
  fx.setZero();
  fu.setZero();
  // Base twist.
  fx.topRows<6>() = c.dvb_dx;
  fu.topRows<6>() = c.dvb_du;
  // Joint positions.
  fu.block(6, 0, nj, nj).setIdentity();
  // Momentum: d/dq of sum_i (p_i - d e_z - c) x f_i = -sum_i hat(f_i) (J_i - J_com),
  // each J_i non-zero on its support columns only.
  Eigen::Matrix3Xd& ang_dq = data.angular_dq;
  ang_dq.setZero();
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  const Eigen::Vector3d lever0 = c.nq.com + r.contactOffset() * Eigen::Vector3d::UnitZ();
  for (int i = 0; i < r.nc(); ++i) {
    const int iu = r.inputForceIndex(i);
    const Eigen::Vector3d fi = u.segment<3>(iu);
    total += fi;
    const auto Ji = c.nq.contactJacobians.middleRows<3>(3 * i);
    for (int col : r.supportColumns(i)) ang_dq.col(col).noalias() -= fi.cross(Ji.col(col));
    fu.block<3, 3>(ih, iu).setIdentity();
    fu.block<3, 3>(ih + 3, iu) = lie::hat(c.footPosition(i) - lever0);
  }
  // + hat(sum f) J_com: hat(F) J = F x J column-wise.
  for (int col = 0; col < nv; ++col) {
    ang_dq.col(col) += total.cross(c.nq.comJacobian.col(col));
  }
  fx.block(ih + 3, 0, 3, nv) = ang_dq;
}

}  // namespace rollstep::centroidal
