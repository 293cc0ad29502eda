// The CBF-QP safety filter (cbf_qp.hpp): input checks, the QP assembled from its pieces
// (cbf_rows.hpp), the solve, the relaxation, the fallback.
#include "rollstep/control/cbf_qp.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "rollstep/control/barriers.hpp"
#include "rollstep/control/cbf_rows.hpp"

namespace rollstep::control {

namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;
constexpr double kInf = std::numeric_limits<double>::infinity();
/// Regions are sized for at least this many edges (a terrain from perception may change).
constexpr int kMinRegionEdges = 8;
/// The most feet the support polygon takes (convexHull's limit).
constexpr int kMaxContactsForHull = 64;
/// |quaternion norm - 1| above this is refused as InvalidInput.
constexpr double kQuaternionNormTolerance = 1e-3;

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

const char* toString(CbfQpStatus status) { return enumName(status, "Unknown"); }

// ---- workspace ------------------------------------------------------------------------

struct CbfQpFilter::Work {
  Work(const centroidal::CentroidalRobot& robot, const DenseQpDims& dims)
      : data(robot.model()),
        kin(robot),
        row(Eigen::RowVectorXd::Zero(robot.nv())),
        normals(Eigen::Matrix3Xd::Zero(3, robot.nc())),
        joint_lower(Eigen::VectorXd::Zero(robot.nj())),
        joint_upper(Eigen::VectorXd::Zero(robot.nj())),
        joint_vmax(Eigen::VectorXd::Zero(robot.nj())),
        support_xy(static_cast<size_t>(robot.nc())),
        hull(static_cast<size_t>(robot.nc()) + 1),
        support_feet(static_cast<size_t>(robot.nc())),
        free_qp({dims.n, dims.n_eq, 0}),
        free_solver({dims.n, dims.n_eq, 0}),
        relaxed_qp({dims.n + dims.n_ineq, dims.n_eq, dims.n_ineq}),
        relaxed_solver({dims.n + dims.n_ineq, dims.n_eq, dims.n_ineq}),
        row_owner(static_cast<std::size_t>(dims.n_ineq), kSupportRow) {}

  model::Data data;
  ContactKinematics kin;
  Eigen::RowVectorXd row;                    ///< a contact row (scratch)
  Eigen::Matrix3Xd normals;                  ///< terrain normal under each stance foot
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
  /// Whose each inequality row is: 8 foot + its barrier kind's bit index (BarrierKind), or
  /// kSupportRow for the support polygon's edges.
  static constexpr int kSupportRow = -1;
  std::vector<int> row_owner;
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
  require(robot_->nc() * kBarrierBitsPerFoot <= 64, "too many contacts for the barrier log");
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

const Eigen::MatrixXd& CbfQpFilter::footJacobians() const { return work_->kin.jacobian; }
const Eigen::Matrix3Xd& CbfQpFilter::footDrift() const { return work_->kin.drift; }

// ---- filter ---------------------------------------------------------------------------

void CbfQpFilter::writeFallback(const Eigen::Ref<const Eigen::VectorXd>& v,
                                Eigen::Ref<Eigen::VectorXd> a) const noexcept {
  const int nj = robot_->nj();
  a.head<6>().setZero();
  const bool have_v = v.size() == robot_->nv();
  for (int j = 0; j < nj; ++j) {
    const double vj = have_v ? v[6 + j] : 0.0;
    a[6 + j] = std::isfinite(vj) ? -vj / settings_.fallback_brake_time : 0.0;
  }
}

bool CbfQpFilter::acceptsInput(const Eigen::Ref<const Eigen::VectorXd>& q,
                               const Eigen::Ref<const Eigen::VectorXd>& v, int mode,
                               const FootRegionPlan* regions, const AccelerationTargets& targets,
                               Eigen::Index a_size) const noexcept {
  const centroidal::CentroidalRobot& robot = *robot_;
  const int nv = robot.nv(), nj = robot.nj(), nc = robot.nc();
  if (a_size != nv || q.size() != robot.nq() || v.size() != nv) return false;
  if (!allFinite(q) || !allFinite(v)) return false;
  if (std::abs(q.segment<4>(3).norm() - 1.0) > kQuaternionNormTolerance) return false;
  if (mode < 0 || (nc < 31 && mode >= (1 << nc))) return false;
  if (targets.feet.cols() != nc || targets.joints.size() != nj) return false;
  if (!allFinite(targets.base) || !allFinite(targets.feet) || !allFinite(targets.joints)) {
    return false;
  }
  auto regionOk = [&](int r) {
    return r < 0 || (r < terrain_->size() && terrain_->region(r).A.rows() <= max_region_edges_);
  };
  if (regions != nullptr) {
    for (int i = 0; i < nc; ++i) {
      if (!regionOk(regions[i].region) || !regionOk(regions[i].swing_region)) return false;
    }
  }
  return true;
}

int CbfQpFilter::barrierRegion(int mode, const FootRegionPlan* regions, int i) noexcept {
  if (regions == nullptr) return -1;
  const FootRegionPlan& plan = regions[i];
  if (centroidal::CentroidalRobot::inStance(mode, i)) return plan.region;
  return plan.swing_region_active ? plan.swing_region : -1;
}

bool CbfQpFilter::collisionObstacle(const FootRegionPlan* regions, int i, int j) const noexcept {
  const int given = regions != nullptr ? regions[i].support_prism : -1;
  return isCollisionObstacle(*collision_terrain_, j, work_->kin.position.col(i), given,
                             robot_->contactOffset(), settings_.collision_range);
}

int CbfQpFilter::writeFootBarriers(int mode, const FootRegionPlan* regions, int i,
                                   int row) noexcept {
  const CbfQpSettings& s = settings_;
  const ContactKinematics& kin = work_->kin;
  const double offset = robot_->contactOffset();
  const int first = row;
  std::vector<int>& owner = work_->row_owner;
  const auto tag = [&](int from, int kind_bit) {
    for (int k = from; k < row; ++k) owner[static_cast<std::size_t>(k)] = 8 * i + kind_bit;
  };
  const int r = barrierRegion(mode, regions, i);
  if (r >= 0) row += writeRegionRows(terrain_->region(r), kin, i, s.region_gamma, qp_, row);
  tag(first, kRegionBarrier);
  if (s.clearance_gamma > 0.0 && !centroidal::CentroidalRobot::inStance(mode, i)) {
    const int at = row;
    row += writeClearanceRow(*terrain_, offset, s.clearance, kin, i, s.clearance_gamma, qp_, row);
    tag(at, kClearanceBarrier);
  }
  if (s.collision_gamma > 0.0) {
    const int at = row;
    const planning::TerrainModel& solids = *collision_terrain_;
    for (int j = 0; j < solids.size(); ++j) {
      if (!collisionObstacle(regions, i, j)) continue;
      row += writeCollisionRow(solids.region(j), offset, s.collision_clearance,
                               s.collision_sharpness, kin, i, s.collision_gamma, qp_, row);
    }
    tag(at, kCollisionBarrier);
  }
  return row - first;
}

int CbfQpFilter::countFootBarriers(int mode, const FootRegionPlan* regions, int i) const noexcept {
  const CbfQpSettings& s = settings_;
  int n = 0;
  const int r = barrierRegion(mode, regions, i);
  if (r >= 0) n += static_cast<int>(terrain_->region(r).A.rows());
  if (s.clearance_gamma > 0.0 && !centroidal::CentroidalRobot::inStance(mode, i)) ++n;
  if (s.collision_gamma > 0.0) {
    for (int j = 0; j < collision_terrain_->size(); ++j)
      n += collisionObstacle(regions, i, j) ? 1 : 0;
  }
  return n;
}

CbfQpStatus CbfQpFilter::solve(int n_eq, int n_ineq, Eigen::Ref<Eigen::VectorXd> a,
                               const Eigen::Ref<const Eigen::VectorXd>& v) noexcept {
  const int nv = robot_->nv();
  const CbfQpSettings& s = settings_;
  Work& w = *work_;
  const DenseQpStatus st = qp_solver_.solve(qp_);
  qp_status_ = st;
  qp_iterations_ = qp_solver_.iterations();
  active_barriers_ = st == DenseQpStatus::Optimal ? qp_solver_.numActiveInequalities() : 0;
  clearActiveBarriers();
  if (st == DenseQpStatus::Optimal) tallyActiveBarriers(qp_solver_, n_ineq);
  auto brake = [&]() {
    correction_ = kInf;
    writeFallback(v, a);
    return CbfQpStatus::Fallback;
  };
  CbfQpStatus result = CbfQpStatus::Optimal;
  if (st == DenseQpStatus::Optimal) {
    a = qp_solver_.x();
  } else if (st != DenseQpStatus::InvalidInput && n_ineq > 0 && s.relaxation_weight > 0.0) {
    if (!solveRelaxed(n_eq, n_ineq, a)) return brake();
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

bool CbfQpFilter::solveRelaxed(int n_eq, int n_ineq, Eigen::Ref<Eigen::VectorXd> a) noexcept {
  // The barriers have no common point (or the active-set cap was hit): the same QP with
  // one slack per barrier row, C a + s >= l, s >= 0, cost + 0.5 w |s|^2. The contact rows
  // and the joint bounds stay exact; if they alone are inconsistent, brake.
  const int nv = robot_->nv();
  Work& w = *work_;
  const int nr = nv + n_ineq;
  DenseQpProblem& rq = w.relaxed_qp;
  rq.setDimensions(nr, n_eq, n_ineq);
  rq.clear();
  rq.H().topLeftCorner(nv, nv) = qp_.H();
  rq.H().diagonal().tail(n_ineq).setConstant(settings_.relaxation_weight);
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
  if (w.relaxed_solver.solve(rq) != DenseQpStatus::Optimal) return false;
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
  clearActiveBarriers();
  tallyActiveBarriers(w.relaxed_solver, n_ineq);
  return true;
}

void CbfQpFilter::clearActiveBarriers() noexcept {
  active_foot_barriers_ = 0;
  active_joint_limits_ = 0;
  active_support_edges_ = 0;
}

void CbfQpFilter::tallyActiveBarriers(const DenseQpSolver& solver, int n_ineq) noexcept {
  const std::vector<int>& owner = work_->row_owner;
  for (int r = 0; r < n_ineq; ++r) {
    if (solver.rowSide(r) == ActiveSide::Inactive) continue;
    const int o = owner[static_cast<std::size_t>(r)];
    if (o == Work::kSupportRow) {
      ++active_support_edges_;
    } else {
      active_foot_barriers_ |= std::uint64_t{1} << (kBarrierBitsPerFoot * (o / 8) + o % 8);
    }
  }
  for (int j = 6; j < robot_->nv(); ++j) {
    active_joint_limits_ += solver.boundSide(j) != ActiveSide::Inactive ? 1 : 0;
  }
}

CbfQpStatus CbfQpFilter::filter(const Eigen::Ref<const Eigen::VectorXd>& q,
                                const Eigen::Ref<const Eigen::VectorXd>& v, int mode,
                                const FootRegionPlan* regions, const AccelerationTargets& targets,
                                Eigen::Ref<Eigen::VectorXd> a) noexcept {
  const centroidal::CentroidalRobot& robot = *robot_;
  const int nv = robot.nv(), nc = robot.nc();
  const CbfQpSettings& s = settings_;
  Work& w = *work_;
  relaxation_ = 0.0;
  if (!acceptsInput(q, v, mode, regions, targets, a.size())) {
    qp_status_ = DenseQpStatus::InvalidInput;
    qp_iterations_ = 0;
    active_barriers_ = 0;
    clearActiveBarriers();
    correction_ = kInf;
    if (a.size() == nv) writeFallback(v, a);
    return CbfQpStatus::InvalidInput;
  }
  computeContactKinematics(robot, w.data, q, v, w.kin);

  // Sizes: the contact rows kept, each foot's barriers, the support polygon's edges.
  const bool lateral_rows = lateral_slip_weight_ == 0.0;
  int n_eq = 0, n_ineq = 0;
  for (int i = 0; i < nc; ++i) {
    if (robot.keepsVelocityConstraints(mode, i)) {
      n_eq += robot.contact(i).drive_wheel && lateral_rows ? 2 : 1;
    }
    n_ineq += countFootBarriers(mode, regions, i);
  }
  w.hull_size = 0;
  if (s.support_gamma > 0.0) {
    const int support = support_mask_ >= 0 ? support_mask_ : mode;
    w.hull_size = supportHull(w.kin, nc, support, w.support_xy, w.support_feet, w.hull);
    n_ineq += w.hull_size;
  }
  qp_.setDimensions(nv, n_eq, n_ineq);

  writeTrackingCost(s, w.kin, targets, robot.nj(), qp_);
  for (int i = 0; i < nc; ++i) {
    const int r = regions != nullptr && centroidal::CentroidalRobot::inStance(mode, i)
                      ? regions[i].region
                      : -1;
    w.normals.col(i) = r >= 0 ? terrain_->region(r).normal : Eigen::Vector3d::UnitZ();
  }
  writeContactRows(robot, s, w.kin, mode, lateral_rows, w.row, qp_, &w.normals);
  writeJointBounds(q, v, w.joint_lower, w.joint_upper, w.joint_vmax, s.joint_position_gamma,
                   s.joint_velocity_gamma, qp_);
  int row = 0;
  for (int i = 0; i < nc; ++i) row += writeFootBarriers(mode, regions, i, row);
  for (int k = row; k < n_ineq; ++k) w.row_owner[static_cast<std::size_t>(k)] = Work::kSupportRow;
  if (w.hull_size >= 3) {
    writeSupportRows(robot.model(), w.data, q, w.kin, w.support_feet, w.hull, w.hull_size,
                     s.support_margin, s.support_gamma, qp_, row);
  }
  return solve(n_eq, n_ineq, a, v);
}

}  // namespace rollstep::control
