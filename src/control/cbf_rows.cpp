// The pieces of the CBF-QP (cbf_rows.hpp): contact kinematics with the analytic drift, the
// tracking cost, the contact rows, the joint bounds and each barrier family.
#include "rollstep/control/cbf_rows.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "rollstep/control/barriers.hpp"
#include "rollstep/control/cbf_qp.hpp"
#include "rollstep/model/center_of_mass.hpp"
#include "rollstep/model/kinematics.hpp"

namespace rollstep::control {

namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;
constexpr double kInf = std::numeric_limits<double>::infinity();
/// Prisms whose tops differ by less than this are level with each other [m].
constexpr double kObstacleStep = 1e-3;

/// Spatial cross product of motion vectors [linear; angular]: a x b.
Vector6d motionCross(const Vector6d& a, const Vector6d& b) {
  Vector6d r;
  r.head<3>() = a.tail<3>().cross(b.head<3>()) + a.head<3>().cross(b.tail<3>());
  r.tail<3>() = a.tail<3>().cross(b.tail<3>());
  return r;
}

}  // namespace

ContactKinematics::ContactKinematics(const centroidal::CentroidalRobot& robot)
    : jacobian(Eigen::MatrixXd::Zero(3 * robot.nc(), robot.nv())),
      position(Eigen::Matrix3Xd::Zero(3, robot.nc())),
      velocity(Eigen::Matrix3Xd::Zero(3, robot.nc())),
      drift(Eigen::Matrix3Xd::Zero(3, robot.nc())),
      lateral(Eigen::Matrix3Xd::Zero(3, robot.nc())),
      lateral_drift(Eigen::VectorXd::Zero(robot.nc())),
      body_drift(static_cast<size_t>(robot.model().nbodies()), Vector6d::Zero()),
      frame_jacobian(Eigen::MatrixXd::Zero(6, robot.nv())) {}

void computeContactKinematics(const centroidal::CentroidalRobot& robot, model::Data& data,
                              const Eigen::Ref<const Eigen::VectorXd>& q,
                              const Eigen::Ref<const Eigen::VectorXd>& v, ContactKinematics& out) {
  const model::Model& model = robot.model();
  model::forwardKinematics(model, data, q, v);
  // Spatial accelerations of the bodies at a = 0 (world axes, at the world origin): the
  // free flyer's column moves with the base, d/dt (Ad_oMb e_k) = ov_0 x (Ad_oMb e_k), which
  // times v_b is ov_0 x ov_0 = 0; joint k adds d/dt(S_k) v_k = ov_k x S_k v_k
  // = ov_parent x ov_k (since ov_k = ov_parent + S_k v_k). Bodies are in depth-first order.
  out.body_drift[0].setZero();
  for (int b = 1; b < model.nbodies(); ++b) {
    const size_t child = static_cast<size_t>(b);
    const size_t parent = static_cast<size_t>(model.bodies[child].parent);
    out.body_drift[child] = out.body_drift[parent] + motionCross(data.ov[parent], data.ov[child]);
  }
  for (int i = 0; i < robot.nc(); ++i) {
    const model::FrameIndex f = robot.frameIds()[static_cast<size_t>(i)];
    const size_t fi = static_cast<size_t>(f);
    const size_t body = static_cast<size_t>(model.frames[fi].body);
    model::updateFramePlacement(model, data, f);
    model::getFrameJacobian(model, data, f, model::ReferenceFrame::LOCAL_WORLD_ALIGNED,
                            out.frame_jacobian);
    out.jacobian.middleRows<3>(3 * i) = out.frame_jacobian.topRows<3>();
    const Eigen::Vector3d p = data.opf[fi];
    const Vector6d& ov = data.ov[body];
    const Eigen::Vector3d vp = ov.head<3>() + ov.tail<3>().cross(p);
    out.position.col(i) = p;
    out.velocity.col(i) = vp;
    // Classical acceleration of the point p at a = 0: d/dt (v_o + w x p)
    // = alpha_lin + alpha_ang x p + w x v_p.
    const Vector6d& alpha = out.body_drift[body];
    out.drift.col(i) = alpha.head<3>() + alpha.tail<3>().cross(p) + ov.tail<3>().cross(vp);
    if (robot.contact(i).drive_wheel) {
      // Yaw frame from the contact frame's x axis projected on the ground plane (as the
      // OCP's foot yaw); yaw_rate = d atan2(x_y, x_x)/dt with dx/dt = w x x.
      const Eigen::Vector3d ax = data.oRf[fi].col(0);
      const double n2 = ax.x() * ax.x() + ax.y() * ax.y();
      const double n = std::sqrt(n2);
      const Eigen::Vector3d dax = ov.tail<3>().cross(ax);
      const double yaw_rate = n2 > 0.0 ? (ax.x() * dax.y() - ax.y() * dax.x()) / n2 : 0.0;
      const Eigen::Vector3d e_lat =
          n > 0.0 ? Eigen::Vector3d(-ax.y() / n, ax.x() / n, 0.0) : Eigen::Vector3d::UnitY();
      const Eigen::Vector3d e_fwd(e_lat.y(), -e_lat.x(), 0.0);
      out.lateral.col(i) = e_lat;
      out.lateral_drift[i] = e_lat.dot(out.drift.col(i)) - yaw_rate * e_fwd.dot(vp);
    }
  }
}

void writeTrackingCost(const CbfQpSettings& s, const ContactKinematics& kin,
                       const AccelerationTargets& targets, int nj, DenseQpProblem& qp) {
  // 0.5 a^T H a + g^T a = 0.5 (sum of the weighted squares)
  auto H = qp.H();
  auto g = qp.g();
  H.setZero();
  g.setZero();
  H.diagonal().head<6>() = s.base_weight;
  g.head<6>() = -s.base_weight.cwiseProduct(targets.base);
  H.diagonal().tail(nj).setConstant(s.joint_weight);
  g.tail(nj) = -s.joint_weight * targets.joints;
  H.diagonal().array() += s.damping;
  for (int i = 0; i < kin.position.cols(); ++i) {
    const auto J = kin.jacobian.middleRows<3>(3 * i);
    H.noalias() += s.foot_weight * (J.transpose() * J);
    g.noalias() += s.foot_weight * (J.transpose() * (kin.drift.col(i) - targets.feet.col(i)));
  }
}

int writeContactRows(const centroidal::CentroidalRobot& robot, const CbfQpSettings& s,
                     const ContactKinematics& kin, int mode, bool lateral_rows,
                     Eigen::RowVectorXd& row, DenseQpProblem& qp, const Eigen::Matrix3Xd* normals) {
  // Row a = target: an equality, or the cost for freed rows.
  const double k = s.contact_gain;
  int eq = 0;
  auto H = qp.H();
  auto g = qp.g();
  auto Aeq = qp.Aeq();
  auto beq = qp.beq();
  auto addRow = [&](bool kept, double target) {
    if (kept) {
      Aeq.row(eq) = row;
      beq[eq] = target;
      ++eq;
    } else {
      H.noalias() += s.freed_contact_weight * (row.transpose() * row);
      g.noalias() -= (s.freed_contact_weight * target) * row.transpose();
    }
  };
  for (int i = 0; i < robot.nc(); ++i) {
    if (!centroidal::CentroidalRobot::inStance(mode, i)) continue;
    const bool kept = robot.keepsVelocityConstraints(mode, i);
    const auto J = kin.jacobian.middleRows<3>(3 * i);
    const Eigen::Vector3d n =
        normals != nullptr ? Eigen::Vector3d(normals->col(i)) : Eigen::Vector3d::UnitZ();
    if (n == Eigen::Vector3d::UnitZ()) {  // flat: the plain z rows
      row = J.row(2);
      addRow(kept, -k * kin.velocity(2, i) - kin.drift(2, i));
    } else {
      row.noalias() = n.transpose() * J;
      addRow(kept, -k * n.dot(kin.velocity.col(i)) - n.dot(kin.drift.col(i)));
    }
    // Skid steering (lateral_slip_weight > 0): the wheels must slide sideways to turn, the
    // MPC's plan weighs that slip; here the lateral rows are left out (an acceleration-level
    // row pulling the slip to zero would hold the commanded turn back).
    if (robot.contact(i).drive_wheel && lateral_rows) {
      const Eigen::Vector3d e_lat = kin.lateral.col(i);
      row.noalias() = e_lat.transpose() * J;
      addRow(kept, -k * e_lat.dot(kin.velocity.col(i)) - kin.lateral_drift[i]);
    }
  }
  return eq;
}

void writeJointBounds(const Eigen::Ref<const Eigen::VectorXd>& q,
                      const Eigen::Ref<const Eigen::VectorXd>& v, const Eigen::VectorXd& lower,
                      const Eigen::VectorXd& upper, const Eigen::VectorXd& vmax,
                      double position_gamma, double velocity_gamma, DenseQpProblem& qp) {
  auto lb = qp.lb();
  auto ub = qp.ub();
  lb.head<6>().setConstant(-kInf);
  ub.head<6>().setConstant(kInf);
  const double gp = position_gamma, gv = velocity_gamma;
  for (Eigen::Index j = 0; j < lower.size(); ++j) {
    const double qj = q[7 + j], vj = v[6 + j];
    const double lo = lower[j], up = upper[j], vm = vmax[j];
    const double Lp = std::isfinite(lo) ? -2.0 * gp * vj - gp * gp * (qj - lo) : -kInf;
    const double Up = std::isfinite(up) ? -2.0 * gp * vj + gp * gp * (up - qj) : kInf;
    const double Lv = std::isfinite(vm) ? -gv * (vm + vj) : -kInf;
    const double Uv = std::isfinite(vm) ? gv * (vm - vj) : kInf;
    // Conflicting barriers: the velocity interval wins (cbf_qp.hpp).
    lb[6 + j] = std::max(Lv, std::min(Lp, Uv));
    ub[6 + j] = std::min(Uv, std::max(Up, Lv));
  }
}

int writeRegionRows(const planning::ConvexRegion& region, const ContactKinematics& kin, int i,
                    double gamma, DenseQpProblem& qp, int row) {
  auto C = qp.C();
  auto l = qp.l();
  auto u = qp.u();
  const auto J = kin.jacobian.middleRows<3>(3 * i);
  const Eigen::Vector3d p = kin.position.col(i);
  const Eigen::Vector3d vp = kin.velocity.col(i);
  const Eigen::Vector3d d = kin.drift.col(i);
  const double gr = gamma;
  for (Eigen::Index e = 0; e < region.A.rows(); ++e) {
    const double ax = region.A(e, 0), ay = region.A(e, 1);
    const double h = ax * p.x() + ay * p.y() + region.b[e];
    const double hd = ax * vp.x() + ay * vp.y();
    C.row(row) = ax * J.row(0) + ay * J.row(1);
    l[row] = -(ax * d.x() + ay * d.y()) - 2.0 * gr * hd - gr * gr * h;
    u[row] = kInf;
    ++row;
  }
  return static_cast<int>(region.A.rows());
}

int writeClearanceRow(const planning::TerrainModel& terrain, double contact_offset,
                      double clearance, const ContactKinematics& kin, int i, double gamma,
                      DenseQpProblem& qp, int row) {
  const auto J = kin.jacobian.middleRows<3>(3 * i);
  const Eigen::Vector3d p = kin.position.col(i);
  const Eigen::Vector3d vp = kin.velocity.col(i);
  const Eigen::Vector3d d = kin.drift.col(i);
  // h = z - r - H(x, y) - clearance with H the plane of the region under the wheel.
  const Eigen::Vector2d pxy = p.head<2>();
  const int under = terrain.regionAt(pxy);
  double ground = 0.0, sx = 0.0, sy = 0.0;  // height and slope dH/dx, dH/dy
  if (under >= 0) {
    const planning::ConvexRegion& region = terrain.region(under);
    ground = region.heightAt(pxy);
    sx = -region.normal.x() / region.normal.z();
    sy = -region.normal.y() / region.normal.z();
  }
  const double gc = gamma;
  const double h = p.z() - contact_offset - ground - clearance;
  const double hd = vp.z() - sx * vp.x() - sy * vp.y();
  qp.C().row(row) = J.row(2) - sx * J.row(0) - sy * J.row(1);
  qp.l()[row] = -(d.z() - sx * d.x() - sy * d.y()) - 2.0 * gc * hd - gc * gc * h;
  qp.u()[row] = kInf;
  return 1;
}

bool isCollisionObstacle(const planning::TerrainModel& solids, int j, const Eigen::Vector3d& p,
                         int support_prism, double contact_offset, double range) {
  const int support = support_prism >= 0 && support_prism < solids.size()
                          ? support_prism
                          : solids.regionAt(p.head<2>());
  const planning::ConvexRegion& prism = solids.region(j);
  if (j == support ||
      (support >= 0 && std::abs(prism.height - solids.region(support).height) <= kObstacleStep)) {
    return false;
  }
  return prismFaceDistance(prism, p) - contact_offset <= range;
}

int writeCollisionRow(const planning::ConvexRegion& prism, double contact_offset, double clearance,
                      double sharpness, const ContactKinematics& kin, int i, double gamma,
                      DenseQpProblem& qp, int row) {
  // h = d(p) - r - clearance, h' = g . v, h'' = v^T H v + g . (J a + drift).
  const auto J = kin.jacobian.middleRows<3>(3 * i);
  const Eigen::Vector3d p = kin.position.col(i);
  const Eigen::Vector3d vp = kin.velocity.col(i);
  const Eigen::Vector3d d = kin.drift.col(i);
  const double gk = gamma;
  const SmoothDistance sd = smoothPrismDistance(prism, p, sharpness);
  const double h = sd.value - contact_offset - clearance;
  const double hd = sd.gradient.dot(vp);
  const Eigen::Vector3d& gr = sd.gradient;
  qp.C().row(row) = gr.x() * J.row(0) + gr.y() * J.row(1) + gr.z() * J.row(2);
  qp.l()[row] = -(sd.gradient.dot(d) + vp.dot(sd.hessian * vp)) - 2.0 * gk * hd - gk * gk * h;
  qp.u()[row] = kInf;
  return 1;
}

int supportHull(const ContactKinematics& kin, int nc, int support_mask,
                std::vector<Eigen::Vector2d>& xy, std::vector<int>& feet, std::vector<int>& hull) {
  int n = 0;
  for (int i = 0; i < nc; ++i) {
    if (!centroidal::CentroidalRobot::inStance(support_mask, i)) continue;
    xy[static_cast<size_t>(n)] = kin.position.col(i).head<2>();
    feet[static_cast<size_t>(n)] = i;
    ++n;
  }
  return convexHull(xy.data(), n, hull.data());
}

int writeSupportRows(const model::Model& model, model::Data& data,
                     const Eigen::Ref<const Eigen::VectorXd>& q, const ContactKinematics& kin,
                     const std::vector<int>& feet, const std::vector<int>& hull, int hull_size,
                     double margin, double gamma, DenseQpProblem& qp, int row) {
  auto C = qp.C();
  auto l = qp.l();
  auto u = qp.u();
  const Eigen::Matrix3Xd& Jcom = model::jacobianCenterOfMass(model, data, q);
  const Eigen::Vector3d com = data.com;
  // COM velocity and drift: mass-weighted over the bodies' COMs at a = 0.
  Eigen::Vector3d com_v = Eigen::Vector3d::Zero(), com_drift = Eigen::Vector3d::Zero();
  for (int b = 0; b < model.nbodies(); ++b) {
    const size_t bi = static_cast<size_t>(b);
    const double mb = model.bodies[bi].mass;
    const Eigen::Vector3d& c = data.ocom[bi];
    const Vector6d& ov = data.ov[bi];
    const Vector6d& alpha = kin.body_drift[bi];
    const Eigen::Vector3d vc = ov.head<3>() + ov.tail<3>().cross(c);
    com_v += mb * vc;
    com_drift += mb * (alpha.head<3>() + alpha.tail<3>().cross(c) + ov.tail<3>().cross(vc));
  }
  com_v /= model.totalMass;
  com_drift /= model.totalMass;
  const double gs = gamma;
  for (int e = 0; e < hull_size; ++e) {
    const int ia = feet[static_cast<size_t>(hull[static_cast<size_t>(e)])];
    const int ib = feet[static_cast<size_t>(hull[static_cast<size_t>((e + 1) % hull_size)])];
    const Eigen::Vector2d pa = kin.position.col(ia).head<2>();
    const Eigen::Vector2d pb = kin.position.col(ib).head<2>();
    const Eigen::Vector2d edge = pb - pa;
    const Eigen::Vector2d n = Eigen::Vector2d(-edge.y(), edge.x()) / edge.norm();  // inward
    const Eigen::Vector2d mid_v =
        0.5 * (kin.velocity.col(ia).head<2>() + kin.velocity.col(ib).head<2>());
    const Eigen::Vector2d mid_d = 0.5 * (kin.drift.col(ia).head<2>() + kin.drift.col(ib).head<2>());
    const double h = n.dot(com.head<2>() - 0.5 * (pa + pb)) - margin;
    const double hd = n.dot(com_v.head<2>() - mid_v);
    const Eigen::MatrixXd& Jf = kin.jacobian;
    C.row(row) = n.x() * (Jcom.row(0) - 0.5 * (Jf.row(3 * ia) + Jf.row(3 * ib))) +
                 n.y() * (Jcom.row(1) - 0.5 * (Jf.row(3 * ia + 1) + Jf.row(3 * ib + 1)));
    l[row] = -n.dot(com_drift.head<2>() - mid_d) - 2.0 * gs * hd - gs * gs * h;
    u[row] = kInf;
    ++row;
  }
  return hull_size;
}

}  // namespace rollstep::control
