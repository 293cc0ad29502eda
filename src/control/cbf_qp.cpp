// The CBF-QP safety filter (cbf_qp.hpp): kinematics of the contact frames (Jacobians,
// analytic drift), the QP's cost, contact-consistency equalities, joint bounds and barrier
// rows, the solve, the fallback.
#include "rollstep/control/cbf_qp.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "rollstep/control/barriers.hpp"
#include "rollstep/model/center_of_mass.hpp"
#include "rollstep/model/kinematics.hpp"

namespace rollstep::control {

namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;
constexpr double kInf = std::numeric_limits<double>::infinity();
/// Regions are sized for at least this many edges (a terrain from perception may change).
constexpr int kMinRegionEdges = 8;
/// The most feet the support polygon takes (convexHull's limit).
constexpr int kMaxContactsForHull = 64;
/// Prisms whose tops differ by less than this are level with each other [m].
constexpr double kObstacleStep = 1e-3;
/// |quaternion norm - 1| above this is refused as InvalidInput.
constexpr double kQuaternionNormTolerance = 1e-3;

/// Spatial cross product of motion vectors [linear; angular]: a x b.
Vector6d motionCross(const Vector6d& a, const Vector6d& b) {
  Vector6d r;
  r.head<3>() = a.tail<3>().cross(b.head<3>()) + a.head<3>().cross(b.tail<3>());
  r.tail<3>() = a.tail<3>().cross(b.tail<3>());
  return r;
}

template <typename Mat>
bool allFinite(const Mat& m) {
  return m.size() == 0 || (m.array() * 0.0).sum() == 0.0;
}

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("CbfQpFilter: " + what);
}

std::string fieldValue(const char* field, double value) {
  return std::string("settings.") + field + " = " + std::to_string(value);
}

void checkCbfSettings(const CbfQpSettings& s, const model::Model& model) {
  for (int k = 0; k < 6; ++k) {
    require(std::isfinite(s.base_weight[k]) && s.base_weight[k] >= 0.0,
            "settings.base_weight[" + std::to_string(k) +
                "] = " + std::to_string(s.base_weight[k]) + " must be finite and >= 0");
  }
  auto nonNegative = [](const char* field, double value) {
    require(std::isfinite(value) && value >= 0.0,
            fieldValue(field, value) + " must be finite and >= 0");
  };
  auto positive = [](const char* field, double value) {
    require(std::isfinite(value) && value > 0.0,
            fieldValue(field, value) + " must be finite and > 0");
  };
  nonNegative("foot_weight", s.foot_weight);
  nonNegative("joint_weight", s.joint_weight);
  nonNegative("damping", s.damping);
  nonNegative("contact_gain", s.contact_gain);
  nonNegative("freed_contact_weight", s.freed_contact_weight);
  positive("joint_position_gamma", s.joint_position_gamma);
  nonNegative("joint_position_margin", s.joint_position_margin);
  positive("joint_velocity_gamma", s.joint_velocity_gamma);
  require(std::isfinite(s.velocity_limit_scale) && s.velocity_limit_scale > 0.0 &&
              s.velocity_limit_scale <= 1.0,
          fieldValue("velocity_limit_scale", s.velocity_limit_scale) + " must be in (0, 1]");
  positive("region_gamma", s.region_gamma);
  nonNegative("clearance_gamma", s.clearance_gamma);  // 0: off
  nonNegative("clearance", s.clearance);
  positive("fallback_brake_time", s.fallback_brake_time);
  nonNegative("relaxation_weight", s.relaxation_weight);  // 0: brake at once
  nonNegative("support_gamma", s.support_gamma);          // 0: off
  nonNegative("support_margin", s.support_margin);
  nonNegative("collision_gamma", s.collision_gamma);  // 0: off
  positive("collision_sharpness", s.collision_sharpness);
  nonNegative("collision_clearance", s.collision_clearance);
  positive("collision_range", s.collision_range);
  require(s.max_iterations >= 1,
          "settings.max_iterations = " + std::to_string(s.max_iterations) + " must be >= 1");
  // The cost must be strictly convex: the damping, or every base and joint weight.
  require(s.damping > 0.0 || (s.base_weight.minCoeff() > 0.0 && s.joint_weight > 0.0),
          "the cost is not strictly convex: settings.damping = 0 needs every base_weight and "
          "joint_weight > 0");
  for (int j = 0; j < model.nj; ++j) {
    const double lo = model.lowerPositionLimit[j], up = model.upperPositionLimit[j];
    if (!std::isfinite(lo) || !std::isfinite(up)) continue;
    require(up - lo >= 2.0 * s.joint_position_margin,
            fieldValue("joint_position_margin", s.joint_position_margin) +
                " leaves no range for joint '" + model.jointNames[static_cast<size_t>(j)] +
                "' (limits " + std::to_string(lo) + ", " + std::to_string(up) + ")");
  }
}

int terrainMaxEdges(const planning::TerrainModel& terrain) {
  int edges = kMinRegionEdges;
  for (const planning::ConvexRegion& r : terrain.regions()) {
    edges = std::max(edges, static_cast<int>(r.A.rows()));
  }
  return edges;
}

int maxEqualities(const centroidal::CentroidalRobot& robot) {
  int n = 0;
  for (int i = 0; i < robot.nc(); ++i) n += robot.contact(i).drive_wheel ? 2 : 1;
  return n;
}

}  // namespace

const char* toString(CbfQpStatus status) {
  switch (status) {
    case CbfQpStatus::Optimal:
      return "Optimal";
    case CbfQpStatus::Relaxed:
      return "Relaxed";
    case CbfQpStatus::Fallback:
      return "Fallback";
    case CbfQpStatus::InvalidInput:
      return "InvalidInput";
  }
  return "Unknown";
}

// ---- workspace ------------------------------------------------------------------------

struct CbfQpFilter::Work {
  Work(const centroidal::CentroidalRobot& robot, const DenseQpDims& dims)
      : data(robot.model()),
        frame_jacobian(Eigen::MatrixXd::Zero(6, robot.nv())),
        foot_jacobian(Eigen::MatrixXd::Zero(3 * robot.nc(), robot.nv())),
        foot_position(Eigen::Matrix3Xd::Zero(3, robot.nc())),
        foot_velocity(Eigen::Matrix3Xd::Zero(3, robot.nc())),
        foot_drift(Eigen::Matrix3Xd::Zero(3, robot.nc())),
        body_drift(static_cast<size_t>(robot.model().nbodies()), Vector6d::Zero()),
        lateral(Eigen::Matrix3Xd::Zero(3, robot.nc())),
        lateral_drift(Eigen::VectorXd::Zero(robot.nc())),
        row(Eigen::RowVectorXd::Zero(robot.nv())),
        joint_lower(Eigen::VectorXd::Zero(robot.nj())),
        joint_upper(Eigen::VectorXd::Zero(robot.nj())),
        joint_vmax(Eigen::VectorXd::Zero(robot.nj())),
        support_xy(static_cast<size_t>(robot.nc())),
        hull(static_cast<size_t>(robot.nc()) + 1),
        support_feet(static_cast<size_t>(robot.nc())),
        free_qp({dims.n, dims.n_eq, 0}),
        free_solver({dims.n, dims.n_eq, 0}),
        relaxed_qp({dims.n + dims.n_ineq, dims.n_eq, dims.n_ineq}),
        relaxed_solver({dims.n + dims.n_ineq, dims.n_eq, dims.n_ineq}) {}

  model::Data data;
  Eigen::MatrixXd frame_jacobian;  ///< 6 x nv scratch
  Eigen::MatrixXd foot_jacobian;   ///< 3 nc x nv
  Eigen::Matrix3Xd foot_position, foot_velocity, foot_drift;
  std::vector<Vector6d> body_drift;  ///< spatial acceleration of each body at a = 0
  Eigen::Matrix3Xd lateral;          ///< e_lat of each drive wheel
  /// a_lat = e_lat . (J a) + lateral_drift: e_lat . dJ v - yaw_rate (e_fwd . v_i).
  Eigen::VectorXd lateral_drift;
  Eigen::RowVectorXd row;
  Eigen::VectorXd joint_lower, joint_upper;  ///< position limits with the margin (+-inf: none)
  Eigen::VectorXd joint_vmax;                ///< scaled velocity limits (+inf: none)
  std::vector<Eigen::Vector2d> support_xy;   ///< (x, y) of the support feet
  std::vector<int> hull;                     ///< support polygon: indices into support_xy
  std::vector<int> support_feet;             ///< foot of each support_xy entry
  int hull_size = 0;
  DenseQpProblem free_qp;  ///< same cost and equalities, no inequality: correction()
  DenseQpSolver free_solver;
  /// The barriers relaxed by one slack per row (CbfQpSettings::relaxation_weight).
  DenseQpProblem relaxed_qp;
  DenseQpSolver relaxed_solver;
};

CbfQpFilter::CbfQpFilter(std::shared_ptr<const centroidal::CentroidalRobot> robot,
                         const planning::TerrainModel& terrain, const CbfQpSettings& settings,
                         double lateral_slip_weight,
                         const planning::TerrainModel* collision_terrain,
                         int collision_prism_capacity)
    : robot_(std::move(robot)),
      terrain_(&terrain),
      collision_terrain_(collision_terrain != nullptr ? collision_terrain : &terrain),
      settings_(settings),
      lateral_slip_weight_(lateral_slip_weight),
      qp_({0, 0, 0}),
      qp_solver_({0, 0, 0}) {
  require(robot_ != nullptr, "null robot");
  const model::Model& model = robot_->model();
  checkCbfSettings(settings_, model);
  max_region_edges_ = terrainMaxEdges(terrain);
  require(robot_->nc() <= kMaxContactsForHull, "too many contacts for the support polygon");
  const int support_rows = settings_.support_gamma > 0.0 ? robot_->nc() : 0;
  require(collision_prism_capacity >= 0, "negative collision_prism_capacity");
  max_collision_prisms_ = std::max(collision_prism_capacity, collision_terrain_->size());
  const int collision_rows =
      settings_.collision_gamma > 0.0 ? robot_->nc() * max_collision_prisms_ : 0;
  const DenseQpDims dims{robot_->nv(), maxEqualities(*robot_),
                         robot_->nc() * (max_region_edges_ + 1) + support_rows + collision_rows};
  qp_ = DenseQpProblem(dims);
  DenseQpSettings qp_settings;
  qp_settings.max_iterations = settings_.max_iterations;
  qp_solver_ = DenseQpSolver(dims, qp_settings);
  work_ = std::make_unique<Work>(*robot_, dims);
  Work& w = *work_;
  w.free_solver.settings().max_iterations = std::max(settings_.max_iterations, 2 * dims.n_eq + 10);
  // Every slack may enter and leave the active set once on a cold start.
  w.relaxed_solver.settings().max_iterations =
      std::max(settings_.max_iterations, 2 * (dims.n + 2 * dims.n_ineq) + 10);
  for (int j = 0; j < robot_->nj(); ++j) {
    const double lo = model.lowerPositionLimit[j], up = model.upperPositionLimit[j];
    w.joint_lower[j] = std::isfinite(lo) ? lo + settings_.joint_position_margin : -kInf;
    w.joint_upper[j] = std::isfinite(up) ? up - settings_.joint_position_margin : kInf;
    const double vmax = model.velocityLimit[j];
    w.joint_vmax[j] = vmax > 0.0 ? settings_.velocity_limit_scale * vmax : kInf;
  }
}

CbfQpFilter::~CbfQpFilter() = default;
CbfQpFilter::CbfQpFilter(CbfQpFilter&&) noexcept = default;
CbfQpFilter& CbfQpFilter::operator=(CbfQpFilter&&) noexcept = default;

AccelerationTargets CbfQpFilter::makeTargets() const {
  AccelerationTargets t;
  t.base.setZero();
  t.feet = Eigen::Matrix3Xd::Zero(3, robot_->nc());
  t.joints = Eigen::VectorXd::Zero(robot_->nj());
  return t;
}

const Eigen::MatrixXd& CbfQpFilter::footJacobians() const { return work_->foot_jacobian; }
const Eigen::Matrix3Xd& CbfQpFilter::footDrift() const { return work_->foot_drift; }

// ---- filter ---------------------------------------------------------------------------

CbfQpStatus CbfQpFilter::filter(const Eigen::Ref<const Eigen::VectorXd>& q,
                                const Eigen::Ref<const Eigen::VectorXd>& v, int mode,
                                const FootRegionPlan* regions, const AccelerationTargets& targets,
                                Eigen::Ref<Eigen::VectorXd> a) noexcept {
  const centroidal::CentroidalRobot& robot = *robot_;
  const model::Model& model = robot.model();
  const int nv = robot.nv(), nj = robot.nj(), nc = robot.nc();
  const CbfQpSettings& s = settings_;
  Work& w = *work_;

  auto writeFallback = [&]() {
    a.head<6>().setZero();
    const bool have_v = v.size() == nv;
    for (int j = 0; j < nj; ++j) {
      const double vj = have_v ? v[6 + j] : 0.0;
      a[6 + j] = std::isfinite(vj) ? -vj / s.fallback_brake_time : 0.0;
    }
  };
  relaxation_ = 0.0;
  auto refuse = [&]() {
    qp_status_ = DenseQpStatus::InvalidInput;
    qp_iterations_ = 0;
    active_barriers_ = 0;
    correction_ = kInf;
    if (a.size() == nv) writeFallback();
    return CbfQpStatus::InvalidInput;
  };

  // ---- input checks
  if (a.size() != nv || q.size() != robot.nq() || v.size() != nv) return refuse();
  if (!allFinite(q) || !allFinite(v)) return refuse();
  if (std::abs(q.segment<4>(3).norm() - 1.0) > kQuaternionNormTolerance) return refuse();
  if (mode < 0 || (nc < 31 && mode >= (1 << nc))) return refuse();
  if (targets.feet.cols() != nc || targets.joints.size() != nj) return refuse();
  if (!allFinite(targets.base) || !allFinite(targets.feet) || !allFinite(targets.joints)) {
    return refuse();
  }
  auto regionOk = [&](int r) {
    return r < 0 || (r < terrain_->size() && terrain_->region(r).A.rows() <= max_region_edges_);
  };
  if (regions != nullptr) {
    for (int i = 0; i < nc; ++i) {
      if (!regionOk(regions[i].region) || !regionOk(regions[i].swing_region)) return refuse();
    }
  }

  // ---- kinematics: placements, body velocities, world joint Jacobians
  model::forwardKinematics(model, w.data, q, v);
  // Spatial accelerations of the bodies at a = 0 (world axes, at the world origin): the
  // free flyer's column moves with the base, d/dt (Ad_oMb e_k) = ov_0 x (Ad_oMb e_k), which
  // times v_b is ov_0 x ov_0 = 0; joint k adds d/dt(S_k) v_k = ov_k x S_k v_k
  // = ov_parent x ov_k (since ov_k = ov_parent + S_k v_k). Bodies are in depth-first order.
  w.body_drift[0].setZero();
  for (int b = 1; b < model.nbodies(); ++b) {
    const size_t child = static_cast<size_t>(b);
    const size_t parent = static_cast<size_t>(model.bodies[child].parent);
    w.body_drift[child] = w.body_drift[parent] + motionCross(w.data.ov[parent], w.data.ov[child]);
  }
  for (int i = 0; i < nc; ++i) {
    const model::FrameIndex f = robot.frameIds()[static_cast<size_t>(i)];
    const size_t fi = static_cast<size_t>(f);
    const size_t body = static_cast<size_t>(model.frames[fi].body);
    model::updateFramePlacement(model, w.data, f);
    model::getFrameJacobian(model, w.data, f, model::ReferenceFrame::LOCAL_WORLD_ALIGNED,
                            w.frame_jacobian);
    w.foot_jacobian.middleRows<3>(3 * i) = w.frame_jacobian.topRows<3>();
    const Eigen::Vector3d p = w.data.opf[fi];
    const Vector6d& ov = w.data.ov[body];
    const Eigen::Vector3d vp = ov.head<3>() + ov.tail<3>().cross(p);
    w.foot_position.col(i) = p;
    w.foot_velocity.col(i) = vp;
    // Classical acceleration of the point p at a = 0: d/dt (v_o + w x p)
    // = alpha_lin + alpha_ang x p + w x v_p.
    const Vector6d& alpha = w.body_drift[body];
    w.foot_drift.col(i) = alpha.head<3>() + alpha.tail<3>().cross(p) + ov.tail<3>().cross(vp);
    if (robot.contact(i).drive_wheel) {
      // Yaw frame from the contact frame's x axis projected on the ground plane (as the
      // OCP's foot yaw); yaw_rate = d atan2(x_y, x_x)/dt with dx/dt = w x x.
      const Eigen::Vector3d ax = w.data.oRf[fi].col(0);
      const double n2 = ax.x() * ax.x() + ax.y() * ax.y();
      const double n = std::sqrt(n2);
      const Eigen::Vector3d dax = ov.tail<3>().cross(ax);
      const double yaw_rate = n2 > 0.0 ? (ax.x() * dax.y() - ax.y() * dax.x()) / n2 : 0.0;
      const Eigen::Vector3d e_lat =
          n > 0.0 ? Eigen::Vector3d(-ax.y() / n, ax.x() / n, 0.0) : Eigen::Vector3d::UnitY();
      const Eigen::Vector3d e_fwd(e_lat.y(), -e_lat.x(), 0.0);
      w.lateral.col(i) = e_lat;
      w.lateral_drift[i] = e_lat.dot(w.foot_drift.col(i)) - yaw_rate * e_fwd.dot(vp);
    }
  }

  // ---- sizes
  auto regionOf = [&](int i) {
    if (regions == nullptr) return -1;
    const FootRegionPlan& plan = regions[i];
    if (centroidal::CentroidalRobot::inStance(mode, i)) return plan.region;
    return plan.swing_region_active ? plan.swing_region : -1;
  };
  const bool clearance_on = s.clearance_gamma > 0.0;
  // Collision: prism j is an obstacle of foot i (cbf_qp.hpp) when it rises above the ground
  // under the wheel and is within range.
  const planning::TerrainModel& solids = *collision_terrain_;
  auto obstacle = [&](int i, int j) {
    const Eigen::Vector3d p = w.foot_position.col(i);
    const int given = regions != nullptr ? regions[i].support_prism : -1;
    const int support = given >= 0 && given < solids.size() ? given : solids.regionAt(p.head<2>());
    const planning::ConvexRegion& prism = solids.region(j);
    if (j == support ||
        (support >= 0 && std::abs(prism.height - solids.region(support).height) <= kObstacleStep)) {
      return false;
    }
    return prismFaceDistance(prism, p) - robot.contactOffset() <= s.collision_range;
  };
  int n_eq = 0, n_ineq = 0;
  for (int i = 0; i < nc; ++i) {
    if (robot.keepsVelocityConstraints(mode, i)) {
      n_eq += robot.contact(i).drive_wheel && lateral_slip_weight_ == 0.0 ? 2 : 1;
    }
    const int r = regionOf(i);
    if (r >= 0) n_ineq += static_cast<int>(terrain_->region(r).A.rows());
    if (clearance_on && !centroidal::CentroidalRobot::inStance(mode, i)) ++n_ineq;
    if (s.collision_gamma > 0.0) {
      for (int j = 0; j < solids.size(); ++j) n_ineq += obstacle(i, j) ? 1 : 0;
    }
  }
  w.hull_size = 0;
  if (s.support_gamma > 0.0) {
    const int support = support_mask_ >= 0 ? support_mask_ : mode;
    int n = 0;
    for (int i = 0; i < nc; ++i) {
      if (!centroidal::CentroidalRobot::inStance(support, i)) continue;
      w.support_xy[static_cast<size_t>(n)] = w.foot_position.col(i).head<2>();
      w.support_feet[static_cast<size_t>(n)] = i;
      ++n;
    }
    w.hull_size = convexHull(w.support_xy.data(), n, w.hull.data());
    n_ineq += w.hull_size;
  }
  qp_.setDimensions(nv, n_eq, n_ineq);

  // ---- cost: 0.5 a^T H a + g^T a = 0.5 (sum of the weighted squares)
  auto H = qp_.H();
  auto g = qp_.g();
  H.setZero();
  g.setZero();
  H.diagonal().head<6>() = s.base_weight;
  g.head<6>() = -s.base_weight.cwiseProduct(targets.base);
  H.diagonal().tail(nj).setConstant(s.joint_weight);
  g.tail(nj) = -s.joint_weight * targets.joints;
  H.diagonal().array() += s.damping;
  for (int i = 0; i < nc; ++i) {
    const auto J = w.foot_jacobian.middleRows<3>(3 * i);
    H.noalias() += s.foot_weight * (J.transpose() * J);
    g.noalias() += s.foot_weight * (J.transpose() * (w.foot_drift.col(i) - targets.feet.col(i)));
  }

  // ---- contact consistency: row a = target (equality, or cost for freed rows)
  const double k = s.contact_gain;
  int eq = 0;
  auto Aeq = qp_.Aeq();
  auto beq = qp_.beq();
  auto addRow = [&](bool kept, double target) {
    if (kept) {
      Aeq.row(eq) = w.row;
      beq[eq] = target;
      ++eq;
    } else {
      H.noalias() += s.freed_contact_weight * (w.row.transpose() * w.row);
      g.noalias() -= (s.freed_contact_weight * target) * w.row.transpose();
    }
  };
  for (int i = 0; i < nc; ++i) {
    if (!centroidal::CentroidalRobot::inStance(mode, i)) continue;
    const bool kept = robot.keepsVelocityConstraints(mode, i);
    const auto J = w.foot_jacobian.middleRows<3>(3 * i);
    w.row = J.row(2);
    addRow(kept, -k * w.foot_velocity(2, i) - w.foot_drift(2, i));
    // Skid steering (lateral_slip_weight > 0): the wheels must slide sideways to turn, the
    // MPC's plan weighs that slip; here the lateral rows are left out (an acceleration-level
    // row pulling the slip to zero would hold the commanded turn back).
    if (robot.contact(i).drive_wheel && lateral_slip_weight_ == 0.0) {
      const Eigen::Vector3d e_lat = w.lateral.col(i);
      w.row.noalias() = e_lat.transpose() * J;
      addRow(kept, -k * e_lat.dot(w.foot_velocity.col(i)) - w.lateral_drift[i]);
    }
  }

  // ---- joint bounds: second-order position and first-order velocity barriers
  auto lb = qp_.lb();
  auto ub = qp_.ub();
  lb.head<6>().setConstant(-kInf);
  ub.head<6>().setConstant(kInf);
  {
    const double gp = s.joint_position_gamma, gv = s.joint_velocity_gamma;
    for (int j = 0; j < nj; ++j) {
      const double qj = q[7 + j], vj = v[6 + j];
      const double lo = w.joint_lower[j], up = w.joint_upper[j], vmax = w.joint_vmax[j];
      const double Lp = std::isfinite(lo) ? -2.0 * gp * vj - gp * gp * (qj - lo) : -kInf;
      const double Up = std::isfinite(up) ? -2.0 * gp * vj + gp * gp * (up - qj) : kInf;
      const double Lv = std::isfinite(vmax) ? -gv * (vmax + vj) : -kInf;
      const double Uv = std::isfinite(vmax) ? gv * (vmax - vj) : kInf;
      // Conflicting barriers: the velocity interval wins (cbf_qp.hpp).
      lb[6 + j] = std::max(Lv, std::min(Lp, Uv));
      ub[6 + j] = std::min(Uv, std::max(Up, Lv));
    }
  }

  // ---- barrier rows: regions (per edge) and clearance of swing wheels
  auto C = qp_.C();
  auto l = qp_.l();
  auto u = qp_.u();
  int row = 0;
  for (int i = 0; i < nc; ++i) {
    const auto J = w.foot_jacobian.middleRows<3>(3 * i);
    const Eigen::Vector3d p = w.foot_position.col(i);
    const Eigen::Vector3d vp = w.foot_velocity.col(i);
    const Eigen::Vector3d d = w.foot_drift.col(i);
    const int r = regionOf(i);
    if (r >= 0) {
      const planning::ConvexRegion& region = terrain_->region(r);
      const double gr = s.region_gamma;
      for (Eigen::Index e = 0; e < region.A.rows(); ++e) {
        const double ax = region.A(e, 0), ay = region.A(e, 1);
        const double h = ax * p.x() + ay * p.y() + region.b[e];
        const double hd = ax * vp.x() + ay * vp.y();
        C.row(row) = ax * J.row(0) + ay * J.row(1);
        l[row] = -(ax * d.x() + ay * d.y()) - 2.0 * gr * hd - gr * gr * h;
        u[row] = kInf;
        ++row;
      }
    }
    if (clearance_on && !centroidal::CentroidalRobot::inStance(mode, i)) {
      // h = z - r - H(x, y) - clearance with H the plane of the region under the wheel.
      const Eigen::Vector2d pxy = p.head<2>();
      const int under = terrain_->regionAt(pxy);
      double ground = 0.0, sx = 0.0, sy = 0.0;  // height and slope dH/dx, dH/dy
      if (under >= 0) {
        const planning::ConvexRegion& region = terrain_->region(under);
        ground = region.heightAt(pxy);
        sx = -region.normal.x() / region.normal.z();
        sy = -region.normal.y() / region.normal.z();
      }
      const double gc = s.clearance_gamma;
      const double h = p.z() - robot.contactOffset() - ground - s.clearance;
      const double hd = vp.z() - sx * vp.x() - sy * vp.y();
      C.row(row) = J.row(2) - sx * J.row(0) - sy * J.row(1);
      l[row] = -(d.z() - sx * d.x() - sy * d.y()) - 2.0 * gc * hd - gc * gc * h;
      u[row] = kInf;
      ++row;
    }
    if (s.collision_gamma > 0.0) {
      // h = d(p) - r - clearance, h' = g . v, h'' = v^T H v + g . (J a + drift).
      const double gk = s.collision_gamma;
      for (int j = 0; j < solids.size(); ++j) {
        if (!obstacle(i, j)) continue;
        const SmoothDistance sd = smoothPrismDistance(solids.region(j), p, s.collision_sharpness);
        const double h = sd.value - robot.contactOffset() - s.collision_clearance;
        const double hd = sd.gradient.dot(vp);
        const Eigen::Vector3d& gr = sd.gradient;
        C.row(row) = gr.x() * J.row(0) + gr.y() * J.row(1) + gr.z() * J.row(2);
        l[row] = -(sd.gradient.dot(d) + vp.dot(sd.hessian * vp)) - 2.0 * gk * hd - gk * gk * h;
        u[row] = kInf;
        ++row;
      }
    }
  }

  // ---- support polygon: h = n . (c - m) - margin per hull edge (cbf_qp.hpp)
  if (w.hull_size >= 3) {
    const Eigen::Matrix3Xd& Jcom = model::jacobianCenterOfMass(model, w.data, q);
    const Eigen::Vector3d com = w.data.com;
    // COM velocity and drift: mass-weighted over the bodies' COMs at a = 0.
    Eigen::Vector3d com_v = Eigen::Vector3d::Zero(), com_drift = Eigen::Vector3d::Zero();
    for (int b = 0; b < model.nbodies(); ++b) {
      const size_t bi = static_cast<size_t>(b);
      const double mb = model.bodies[bi].mass;
      const Eigen::Vector3d& c = w.data.ocom[bi];
      const Vector6d& ov = w.data.ov[bi];
      const Vector6d& alpha = w.body_drift[bi];
      const Eigen::Vector3d vc = ov.head<3>() + ov.tail<3>().cross(c);
      com_v += mb * vc;
      com_drift += mb * (alpha.head<3>() + alpha.tail<3>().cross(c) + ov.tail<3>().cross(vc));
    }
    com_v /= model.totalMass;
    com_drift /= model.totalMass;
    const double gs = s.support_gamma;
    for (int e = 0; e < w.hull_size; ++e) {
      const int ia = w.support_feet[static_cast<size_t>(w.hull[static_cast<size_t>(e)])];
      const int ib =
          w.support_feet[static_cast<size_t>(w.hull[static_cast<size_t>((e + 1) % w.hull_size)])];
      const Eigen::Vector2d pa = w.foot_position.col(ia).head<2>();
      const Eigen::Vector2d pb = w.foot_position.col(ib).head<2>();
      const Eigen::Vector2d edge = pb - pa;
      const Eigen::Vector2d n = Eigen::Vector2d(-edge.y(), edge.x()) / edge.norm();  // inward
      const Eigen::Vector2d mid_v =
          0.5 * (w.foot_velocity.col(ia).head<2>() + w.foot_velocity.col(ib).head<2>());
      const Eigen::Vector2d mid_d =
          0.5 * (w.foot_drift.col(ia).head<2>() + w.foot_drift.col(ib).head<2>());
      const double h = n.dot(com.head<2>() - 0.5 * (pa + pb)) - s.support_margin;
      const double hd = n.dot(com_v.head<2>() - mid_v);
      const Eigen::MatrixXd& Jf = w.foot_jacobian;
      C.row(row) = n.x() * (Jcom.row(0) - 0.5 * (Jf.row(3 * ia) + Jf.row(3 * ib))) +
                   n.y() * (Jcom.row(1) - 0.5 * (Jf.row(3 * ia + 1) + Jf.row(3 * ib + 1)));
      l[row] = -n.dot(com_drift.head<2>() - mid_d) - 2.0 * gs * hd - gs * gs * h;
      u[row] = kInf;
      ++row;
    }
  }

  // ---- solve
  const DenseQpStatus st = qp_solver_.solve(qp_);
  qp_status_ = st;
  qp_iterations_ = qp_solver_.iterations();
  active_barriers_ = st == DenseQpStatus::Optimal ? qp_solver_.numActiveInequalities() : 0;
  auto brake = [&]() {
    correction_ = kInf;
    writeFallback();
    return CbfQpStatus::Fallback;
  };
  CbfQpStatus result = CbfQpStatus::Optimal;
  if (st == DenseQpStatus::Optimal) {
    a = qp_solver_.x();
  } else if (st != DenseQpStatus::InvalidInput && n_ineq > 0 && s.relaxation_weight > 0.0) {
    // The barriers have no common point (or the active-set cap was hit): the same QP with
    // one slack per barrier row, C a + s >= l, s >= 0, cost + 0.5 w |s|^2. The contact rows
    // and the joint bounds stay exact; if they alone are inconsistent, brake.
    const int nr = nv + n_ineq;
    DenseQpProblem& rq = w.relaxed_qp;
    rq.setDimensions(nr, n_eq, n_ineq);
    rq.clear();
    rq.H().topLeftCorner(nv, nv) = qp_.H();
    rq.H().diagonal().tail(n_ineq).setConstant(s.relaxation_weight);
    rq.g().head(nv) = qp_.g();
    rq.Aeq().leftCols(nv) = qp_.Aeq();
    rq.beq() = qp_.beq();
    rq.C().leftCols(nv) = qp_.C();
    rq.C().rightCols(n_ineq).setIdentity();
    rq.l() = qp_.l();
    rq.u() = qp_.u();
    rq.lb().head(nv) = qp_.lb();
    rq.ub().head(nv) = qp_.ub();
    rq.lb().tail(n_ineq).setZero();
    if (w.relaxed_solver.solve(rq) != DenseQpStatus::Optimal) return brake();
    a = w.relaxed_solver.x().head(nv);
    relaxation_ = w.relaxed_solver.x().tail(n_ineq).maxCoeff();
    qp_iterations_ += w.relaxed_solver.iterations();
    active_barriers_ = 0;
    for (int r = 0; r < n_ineq; ++r) {
      active_barriers_ += w.relaxed_solver.rowSide(r) != ActiveSide::Inactive ? 1 : 0;
    }
    for (int j = 0; j < nv; ++j) {
      active_barriers_ += w.relaxed_solver.boundSide(j) != ActiveSide::Inactive ? 1 : 0;
    }
    result = CbfQpStatus::Relaxed;
  } else {
    return brake();
  }
  correction_ = 0.0;
  if (active_barriers_ > 0) {
    // The minimiser of the same cost and equalities without the barriers.
    w.free_qp.setDimensions(nv, n_eq, 0);
    w.free_qp.H() = qp_.H();
    w.free_qp.g() = qp_.g();
    w.free_qp.Aeq() = qp_.Aeq();
    w.free_qp.beq() = qp_.beq();
    correction_ = w.free_solver.solve(w.free_qp) == DenseQpStatus::Optimal
                      ? (a - w.free_solver.x()).lpNorm<Eigen::Infinity>()
                      : kInf;
  }
  return result;
}

}  // namespace rollstep::control
