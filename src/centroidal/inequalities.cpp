#include "rollstep/centroidal/inequalities.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "rollstep/centroidal/precomputation.hpp"

namespace rollstep::centroidal {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Residual workspace of the terms that read the robot's kinematics: a cache of their own
/// for when the node has no shared one (ctx.cache == nullptr, e.g. a term evaluated alone),
/// none when made for nodes that always have one (makeFallbackCache).
struct KinematicResidualData : ocp::ResidualData {
  KinematicResidualData(int max_rows, const CentroidalRobot& robot, bool node_cache)
      : ocp::ResidualData(max_rows, robot.ndx(), robot.nu()),
        fallback(makeFallbackCache(robot, node_cache)) {}
  std::unique_ptr<CentroidalCache> fallback;
};

/// The region term's workspace: the region of each foot found by calc, reused by calcDiff
/// (called right after calc with the same arguments, ocp::Residual), -1 for none.
struct RegionResidualData final : KinematicResidualData {
  RegionResidualData(int max_rows, const CentroidalRobot& robot, bool node_cache)
      : KinematicResidualData(max_rows, robot, node_cache) {
    region.fill(-1);
  }
  std::array<int, kMaxContacts> region{};
};

/// The friction term's workspace: the 5 x 3 block of each stance foot (stacked in row
/// order), found by calc, reused by calcDiff.
struct FrictionResidualData final : ocp::ResidualData {
  FrictionResidualData(int max_rows, int ndx, int nu)
      : ocp::ResidualData(max_rows, ndx, nu), blocks(max_rows, 3) {
    blocks.setZero();
  }
  Eigen::Matrix<double, Eigen::Dynamic, 3> blocks;
};

/// The torque term's workspace: the joint torques and their Jacobians before row selection.
struct TorqueResidualData final : KinematicResidualData {
  TorqueResidualData(int max_rows, const CentroidalRobot& robot, bool node_cache)
      : KinematicResidualData(max_rows, robot, node_cache),
        tau(Eigen::VectorXd::Zero(robot.nj())),
        tau_dx(Eigen::MatrixXd::Zero(robot.nj(), robot.ndx())),
        tau_du(Eigen::MatrixXd::Zero(robot.nj(), robot.nu())) {}
  Eigen::VectorXd tau;
  Eigen::MatrixXd tau_dx, tau_du;
};

std::shared_ptr<const CentroidalRobot> checked(std::shared_ptr<const CentroidalRobot> robot,
                                               const char* who) {
  if (!robot) throw std::invalid_argument(std::string(who) + ": null robot");
  return robot;
}

int robotRows(const std::shared_ptr<const CentroidalRobot>& robot, int per_foot) {
  return robot ? robot->nc() * per_foot : 0;
}

std::string number(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return std::to_string(v);
}

}  // namespace

// ---- TerrainReferences -----------------------------------------------------------------------

int TerrainReferences::stanceRegion(const ocp::NodeContext& ctx, int foot) const {
  if (!CentroidalRobot::inStance(ctx.mode, foot)) return -1;
  if (terrain == nullptr || planner == nullptr || ctx.schedule == nullptr) return -1;
  return footReference(ctx, *planner, foot).region;
}

int TerrainReferences::swingRegion(const ocp::NodeContext& ctx, int foot) const {
  if (CentroidalRobot::inStance(ctx.mode, foot)) return -1;
  if (terrain == nullptr || planner == nullptr || ctx.schedule == nullptr) return -1;
  const planning::FootReference ref = footReference(ctx, *planner, foot);
  return ref.swing_region_active ? ref.swing_region : -1;
}

Eigen::Vector3d TerrainReferences::normal(const ocp::NodeContext& ctx, int foot) const {
  const int region = stanceRegion(ctx, foot);
  if (region < 0) return Eigen::Vector3d::UnitZ();
  return terrain->region(region).normal;
}

int TerrainReferences::maxRegionEdges() const {
  if (terrain == nullptr) return 0;
  int edges = 0;
  for (const planning::ConvexRegion& r : terrain->regions()) {
    edges = std::max(edges, static_cast<int>(r.A.rows()));
  }
  return edges;
}

// ---- StaticTorqueLimitResidual -----------------------------------------------------------------

StaticTorqueLimitResidual::StaticTorqueLimitResidual(std::shared_ptr<const CentroidalRobot> robot,
                                                     const TorqueLimitOptions& options)
    : ocp::Residual(robot ? robot->ndx() : 0, robot ? robot->nu() : 0, robot ? 2 * robot->nj() : 0),
      robot_(checked(std::move(robot), "StaticTorqueLimitResidual")),
      pre_(robot_),
      at_contact_point_(options.force_at_contact_point) {
  const int nj = robot_->nj();
  const model::Model& model = robot_->model();
  const char* who = "StaticTorqueLimitResidual: ";
  if (options.lower.size() != 0 || options.upper.size() != 0) {
    if (options.lower.size() != nj || options.upper.size() != nj) {
      throw std::invalid_argument(std::string(who) + "options.lower/upper have sizes " +
                                  std::to_string(options.lower.size()) + "/" +
                                  std::to_string(options.upper.size()) +
                                  ", expected nj = " + std::to_string(nj));
    }
    lower_ = options.lower;
    upper_ = options.upper;
  } else {
    if (!(options.scale > 0.0 && options.scale <= 1.0)) {
      throw std::invalid_argument(std::string(who) + "options.scale = " + number(options.scale) +
                                  ", expected in (0, 1]");
    }
    upper_.resize(nj);
    for (int j = 0; j < nj; ++j) {
      const double e = model.effortLimit[j];
      upper_[j] = (std::isfinite(e) && e > 0.0) ? options.scale * e : kInf;
    }
    lower_ = -upper_;
  }
  for (int j = 0; j < nj; ++j) {
    const std::string joint = model.jointNames[static_cast<size_t>(j)];
    if (std::isnan(lower_[j]) || std::isnan(upper_[j]) || lower_[j] > upper_[j] ||
        lower_[j] == kInf || upper_[j] == -kInf) {
      throw std::invalid_argument(std::string(who) + "torque limits of joint '" + joint +
                                  "' are [" + number(lower_[j]) + ", " + number(upper_[j]) +
                                  "], expected lower <= upper, not NaN");
    }
    if (std::isfinite(upper_[j])) upper_rows_.push_back(j);
    if (std::isfinite(lower_[j])) lower_rows_.push_back(j);
  }
}

int StaticTorqueLimitResidual::rows(const ocp::NodeContext& /*ctx*/) const {
  return static_cast<int>(upper_rows_.size() + lower_rows_.size());
}

int StaticTorqueLimitResidual::mirroredRows(const ocp::NodeContext& /*ctx*/) const {
  const auto nj = static_cast<std::size_t>(robot_->nj());
  return upper_rows_.size() == nj && lower_rows_.size() == nj ? robot_->nj() : 0;
}

std::unique_ptr<ocp::ResidualData> StaticTorqueLimitResidual::createData() const {
  return std::make_unique<TorqueResidualData>(maxRows(), *robot_, false);
}

std::unique_ptr<ocp::ResidualData> StaticTorqueLimitResidual::createDataWithNodeCache() const {
  return std::make_unique<TorqueResidualData>(maxRows(), *robot_, true);
}

// The force f_i at the contact point p_i - r e_z, seen as a point of contact i's body:
// its Jacobian is J_i + r [e_z]x J_w,i, so -J_pc^T f_i = -J_i^T f_i + r J_w,i^T (e_z x f_i).
// Column m of J_w,i is a_m, the world angular motion of a unit dq_m (the joint's world axis
// for a revolute joint, 0 for a prismatic one, R e_k for the base's angular coordinates),
// for m in the support of contact i. Derivatives: a_m turns with every support coordinate
// n before it (d a_m = a_n x a_m dq_n; the support columns are in tree order), so
// d (a_m . w) / dq_n = (a_m x w) . a_n with w = r e_z x f_i constant in q, and
// d (a_m . w) / df_i = r (a_m x e_z)^T.
void StaticTorqueLimitResidual::staticTorques(const CentroidalCache& c,
                                              Eigen::VectorXd& tau) const {
  const int base = robot_->model().nvBase;
  const int nj = robot_->nj();
  tau = c.nq.g.tail(nj) - c.nq.contactTorque.tail(nj);
  if (!at_contact_point_) return;
  const double r = robot_->contactOffset();
  for (int i = 0; i < robot_->nc(); ++i) {
    const Eigen::Vector3d w = r * Eigen::Vector3d::UnitZ().cross(c.force(i));
    for (int m : robot_->supportColumns(i)) {
      if (m >= base) tau[m - base] += c.data.J.block<3, 1>(3, m).dot(w);
    }
  }
}

Eigen::VectorXd StaticTorqueLimitResidual::torques(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                                   ocp::ConstVecRef u, ocp::ResidualData& d) const {
  auto& td = static_cast<TorqueResidualData&>(d);
  staticTorques(nodeCache(ctx, x, u, false, pre_, td.fallback.get()), td.tau);
  return td.tau;
}

std::string StaticTorqueLimitResidual::rowName(const ocp::NodeContext& ctx, int row) const {
  const auto r = static_cast<std::size_t>(row);
  const std::vector<std::string>& joints = robot_->model().jointNames;
  if (row >= 0 && r < upper_rows_.size()) {
    return joints[static_cast<std::size_t>(upper_rows_[r])] + ": torque upper limit";
  }
  if (row >= 0 && r < upper_rows_.size() + lower_rows_.size()) {
    return joints[static_cast<std::size_t>(lower_rows_[r - upper_rows_.size()])] +
           ": torque lower limit";
  }
  return Residual::rowName(ctx, row);
}

void StaticTorqueLimitResidual::calc(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                     ocp::ConstVecRef u, ocp::ResidualData& d) const {
  auto& td = static_cast<TorqueResidualData&>(d);
  staticTorques(nodeCache(ctx, x, u, false, pre_, td.fallback.get()), td.tau);
  int row = 0;
  for (int j : upper_rows_) d.r[row++] = upper_[j] - td.tau[j];
  for (int j : lower_rows_) d.r[row++] = td.tau[j] - lower_[j];
}

void StaticTorqueLimitResidual::calcDiff(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                         ocp::ConstVecRef u, ocp::ResidualData& d) const {
  const int n = rows(ctx);
  calcDiffInto(ctx, x, u, d, d.Rx.topRows(n), d.Ru.topRows(n));
}

void StaticTorqueLimitResidual::calcDiffInto(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                             ocp::ConstVecRef u, ocp::ResidualData& d,
                                             ocp::MatRef Rx, ocp::MatRef Ru) const {
  auto& td = static_cast<TorqueResidualData&>(d);
  const CentroidalCache& c = nodeCache(ctx, x, u, true, pre_, td.fallback.get());
  const int nj = robot_->nj();
  if (static_cast<int>(upper_rows_.size()) == nj && static_cast<int>(lower_rows_.size()) == nj) {
    // Every joint limited on both sides (Tachyon 3): the lower-limit rows are d tau itself,
    // written in place, and the upper-limit rows their negatives (no scratch, no gathering).
    auto lx = Rx.middleRows(nj, nj);
    auto lu = Ru.middleRows(nj, nj);
    torqueDerivatives(c, lx, lu);
    Rx.topRows(nj) = -lx;
    Ru.topRows(nj) = -lu;
    return;
  }
  torqueDerivatives(c, td.tau_dx, td.tau_du);
  int row = 0;
  for (int j : upper_rows_) {
    Rx.row(row) = -td.tau_dx.row(j);
    Ru.row(row++) = -td.tau_du.row(j);
  }
  for (int j : lower_rows_) {
    Rx.row(row) = td.tau_dx.row(j);
    Ru.row(row++) = td.tau_du.row(j);
  }
}

void StaticTorqueLimitResidual::torqueDerivatives(const CentroidalCache& c, ocp::MatRef tau_dx,
                                                  ocp::MatRef tau_du) const {
  const int base = robot_->model().nvBase;
  const int nv = robot_->nv();
  const int nj = robot_->nj();
  const int nc = robot_->nc();
  // d tau / dq = dg_dq - d(J^T f)/dq at fixed f; d tau / df_i = -J_i^T (actuated rows); the
  // torques do not depend on the momentum or the joint velocities.
  tau_dx.leftCols(nv) = c.nq.dg_dq.bottomRows(nj) - c.nq.dContactTorque_dq.bottomRows(nj);
  tau_dx.rightCols(tau_dx.cols() - nv).setZero();
  tau_du.leftCols(nj).setZero();
  for (int i = 0; i < nc; ++i) {
    tau_du.middleCols<3>(nj + 3 * i) = -c.nq.contactJacobians.block(3 * i, base, 3, nj).transpose();
  }
  if (at_contact_point_) {
    const double r = robot_->contactOffset();
    const Eigen::Vector3d ez = Eigen::Vector3d::UnitZ();
    for (int i = 0; i < nc; ++i) {
      const Eigen::Vector3d w = r * ez.cross(c.force(i));
      const std::vector<int>& support = robot_->supportColumns(i);
      for (std::size_t k = 0; k < support.size(); ++k) {
        const int m = support[k];
        if (m < base) continue;
        const Eigen::Vector3d a = c.data.J.block<3, 1>(3, m);
        const Eigen::Vector3d axw = a.cross(w);
        for (std::size_t l = 0; l < k; ++l) {
          tau_dx(m - base, support[l]) += axw.dot(c.data.J.block<3, 1>(3, support[l]));
        }
        tau_du.block<1, 3>(m - base, nj + 3 * i) += r * a.cross(ez).transpose();
      }
    }
  }
}

// ---- FrictionPyramidResidual -------------------------------------------------------------------

FrictionPyramidResidual::FrictionPyramidResidual(std::shared_ptr<const CentroidalRobot> robot,
                                                 TerrainReferences terrain,
                                                 const FrictionPyramidOptions& options)
    : ocp::Residual(robot ? robot->ndx() : 0, robot ? robot->nu() : 0,
                    robotRows(robot, kRowsPerFoot)),
      robot_(checked(std::move(robot), "FrictionPyramidResidual")),
      terrain_(terrain),
      options_(options) {
  if (!(std::isfinite(options.mu) && options.mu > 0.0)) {
    throw std::invalid_argument("FrictionPyramidResidual: options.mu = " + number(options.mu) +
                                ", expected finite and > 0");
  }
  if (!(std::isfinite(options.min_normal_force) && options.min_normal_force >= 0.0)) {
    throw std::invalid_argument("FrictionPyramidResidual: options.min_normal_force = " +
                                number(options.min_normal_force) + ", expected finite and >= 0");
  }
}

int FrictionPyramidResidual::rows(const ocp::NodeContext& ctx) const {
  int feet = 0;
  for (int i = 0; i < robot_->nc(); ++i) feet += CentroidalRobot::inStance(ctx.mode, i) ? 1 : 0;
  return kRowsPerFoot * feet;
}

std::string FrictionPyramidResidual::rowName(const ocp::NodeContext& ctx, int row) const {
  int first = 0;
  for (int i = 0; i < robot_->nc(); ++i) {
    if (!CentroidalRobot::inStance(ctx.mode, i)) continue;
    if (row < first + kRowsPerFoot) {
      return robot_->contact(i).frame + ": friction row " + std::to_string(row - first);
    }
    first += kRowsPerFoot;
  }
  return Residual::rowName(ctx, row);
}

Eigen::Matrix3d FrictionPyramidResidual::terrainFrame(const Eigen::Vector3d& normal) {
  const Eigen::Vector3d n = normal.normalized();
  // t1: world x projected onto the plane (world y if the plane is nearly vertical in x).
  Eigen::Vector3d t1 = Eigen::Vector3d::UnitX() - n.x() * n;
  if (t1.squaredNorm() < 1e-12) t1 = Eigen::Vector3d::UnitY() - n.y() * n;
  t1.normalize();
  Eigen::Matrix3d R;
  R.col(0) = t1;
  R.col(1) = n.cross(t1);
  R.col(2) = n;
  return R;
}

Eigen::Matrix<double, FrictionPyramidResidual::kRowsPerFoot, 3> FrictionPyramidResidual::block(
    const ocp::NodeContext& ctx, int foot) const {
  const Eigen::Matrix3d R = terrainFrame(terrain_.normal(ctx, foot));
  const double m = options_.inscribed ? options_.mu / std::sqrt(2.0) : options_.mu;
  const Eigen::RowVector3d t1 = R.col(0).transpose();
  const Eigen::RowVector3d t2 = R.col(1).transpose();
  const Eigen::RowVector3d n = R.col(2).transpose();
  Eigen::Matrix<double, kRowsPerFoot, 3> B;
  B.row(0) = m * n - t1;
  B.row(1) = m * n + t1;
  B.row(2) = m * n - t2;
  B.row(3) = m * n + t2;
  B.row(4) = n;
  return B;
}

std::unique_ptr<ocp::ResidualData> FrictionPyramidResidual::createData() const {
  return std::make_unique<FrictionResidualData>(maxRows(), ndx(), nu());
}

void FrictionPyramidResidual::calc(const ocp::NodeContext& ctx, ocp::ConstVecRef /*x*/,
                                   ocp::ConstVecRef u, ocp::ResidualData& d) const {
  auto& fd = static_cast<FrictionResidualData&>(d);
  int row = 0;
  for (int i = 0; i < robot_->nc(); ++i) {
    if (!CentroidalRobot::inStance(ctx.mode, i)) continue;
    const Eigen::Vector3d f = u.segment<3>(robot_->inputForceIndex(i));
    auto B = fd.blocks.middleRows<kRowsPerFoot>(row);
    B = block(ctx, i);
    d.r.segment<kRowsPerFoot>(row).noalias() = B * f;
    d.r[row + kRowsPerFoot - 1] -= options_.min_normal_force;
    row += kRowsPerFoot;
  }
}

void FrictionPyramidResidual::calcDiff(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                       ocp::ConstVecRef u, ocp::ResidualData& d) const {
  const int n = rows(ctx);
  calcDiffInto(ctx, x, u, d, d.Rx.topRows(n), d.Ru.topRows(n));
}

void FrictionPyramidResidual::calcDiffInto(const ocp::NodeContext& ctx, ocp::ConstVecRef /*x*/,
                                           ocp::ConstVecRef /*u*/, ocp::ResidualData& d,
                                           ocp::MatRef Rx, ocp::MatRef Ru) const {
  const auto& fd = static_cast<const FrictionResidualData&>(d);
  Rx.setZero();
  Ru.setZero();
  int row = 0;
  for (int i = 0; i < robot_->nc(); ++i) {
    if (!CentroidalRobot::inStance(ctx.mode, i)) continue;
    Ru.block<kRowsPerFoot, 3>(row, robot_->inputForceIndex(i)) =
        fd.blocks.middleRows<kRowsPerFoot>(row);
    row += kRowsPerFoot;
  }
}

// ---- FootRegionResidual ------------------------------------------------------------------------

namespace {
int regionCapacity(const TerrainReferences& terrain, int max_edges) {
  return max_edges > 0 ? max_edges : terrain.maxRegionEdges();
}
}  // namespace

FootRegionResidual::FootRegionResidual(std::shared_ptr<const CentroidalRobot> robot,
                                       TerrainReferences terrain, RegionUse use, int max_edges)
    : ocp::Residual(robot ? robot->ndx() : 0, robot ? robot->nu() : 0,
                    robotRows(robot, std::max(0, regionCapacity(terrain, max_edges)))),
      robot_(checked(std::move(robot), "FootRegionResidual")),
      pre_(robot_),
      terrain_(terrain),
      use_(use),
      max_edges_(std::max(0, regionCapacity(terrain, max_edges))) {
  if (max_edges < 0) {
    throw std::invalid_argument("FootRegionResidual: max_edges = " + std::to_string(max_edges) +
                                ", expected >= 0 (0: from the terrain model)");
  }
}

int FootRegionResidual::regionOf(const ocp::NodeContext& ctx, int foot) const {
  return use_ == RegionUse::Stance ? terrain_.stanceRegion(ctx, foot)
                                   : terrain_.swingRegion(ctx, foot);
}

int FootRegionResidual::rows(const ocp::NodeContext& ctx) const {
  int rows = 0;
  for (int i = 0; i < robot_->nc(); ++i) {
    const int region = regionOf(ctx, i);
    if (region < 0) continue;
    const int edges = static_cast<int>(terrain_.terrain->region(region).A.rows());
    if (edges > max_edges_) {
      throw std::length_error(
          "FootRegionResidual: region " + std::to_string(region) + " has " + std::to_string(edges) +
          " edges, more than max_edges = " + std::to_string(max_edges_) + " given at construction");
    }
    rows += edges;
  }
  return rows;
}

std::string FootRegionResidual::rowName(const ocp::NodeContext& ctx, int row) const {
  int first = 0;
  for (int i = 0; i < robot_->nc(); ++i) {
    const int region = regionOf(ctx, i);
    if (region < 0) continue;
    const int edges = static_cast<int>(terrain_.terrain->region(region).A.rows());
    if (row < first + edges) {
      return robot_->contact(i).frame + ": edge " + std::to_string(row - first) + " of region " +
             std::to_string(region);
    }
    first += edges;
  }
  return Residual::rowName(ctx, row);
}

std::unique_ptr<ocp::ResidualData> FootRegionResidual::createData() const {
  return std::make_unique<RegionResidualData>(maxRows(), *robot_, false);
}

std::unique_ptr<ocp::ResidualData> FootRegionResidual::createDataWithNodeCache() const {
  return std::make_unique<RegionResidualData>(maxRows(), *robot_, true);
}

void FootRegionResidual::calc(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
                              ocp::ResidualData& d) const {
  auto& kd = static_cast<RegionResidualData&>(d);
  const CentroidalCache* c = nullptr;
  int row = 0;
  for (int i = 0; i < robot_->nc(); ++i) {
    const int region = regionOf(ctx, i);
    kd.region[static_cast<std::size_t>(i)] = region;
    if (region < 0) continue;
    if (c == nullptr) c = &nodeCache(ctx, x, u, false, pre_, kd.fallback.get());
    const planning::ConvexRegion& reg = terrain_.terrain->region(region);
    const Eigen::Vector2d p = c->footPosition(i).head<2>();
    for (int k = 0; k < reg.A.rows(); ++k) {
      d.r[row++] = reg.A(k, 0) * p.x() + reg.A(k, 1) * p.y() + reg.b[k];
    }
  }
}

void FootRegionResidual::calcDiff(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                  ocp::ConstVecRef u, ocp::ResidualData& d) const {
  const auto& kd = static_cast<const RegionResidualData&>(d);
  int n = 0;  // the rows of the regions calc found
  for (int i = 0; i < robot_->nc(); ++i) {
    const int region = kd.region[static_cast<std::size_t>(i)];
    if (region >= 0) n += static_cast<int>(terrain_.terrain->region(region).A.rows());
  }
  calcDiffInto(ctx, x, u, d, d.Rx.topRows(n), d.Ru.topRows(n));
}

void FootRegionResidual::calcDiffInto(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                      ocp::ConstVecRef u, ocp::ResidualData& d, ocp::MatRef Rx,
                                      ocp::MatRef Ru) const {
  auto& kd = static_cast<RegionResidualData&>(d);
  const CentroidalCache* c = nullptr;
  int row = 0;
  for (int i = 0; i < robot_->nc(); ++i) {
    const int region = kd.region[static_cast<std::size_t>(i)];  // found by calc
    if (region < 0) continue;
    if (c == nullptr) c = &nodeCache(ctx, x, u, true, pre_, kd.fallback.get());
    const planning::ConvexRegion& reg = terrain_.terrain->region(region);
    const auto px = c->footPosition_dx.row(3 * i);
    const auto py = c->footPosition_dx.row(3 * i + 1);
    for (int k = 0; k < reg.A.rows(); ++k) {
      Rx.row(row) = reg.A(k, 0) * px + reg.A(k, 1) * py;
      Ru.row(row).setZero();
      ++row;
    }
  }
}

// ---- jointLimitBounds -------------------------------------------------------------------------

JointLimitBounds jointLimitBounds(const CentroidalRobot& robot,
                                  const JointLimitBoundOptions& options) {
  if (!(std::isfinite(options.position_margin) && options.position_margin >= 0.0)) {
    throw std::invalid_argument("jointLimitBounds: options.position_margin = " +
                                number(options.position_margin) + ", expected finite and >= 0");
  }
  if (!(options.velocity_scale > 0.0 && options.velocity_scale <= 1.0)) {
    throw std::invalid_argument("jointLimitBounds: options.velocity_scale = " +
                                number(options.velocity_scale) + ", expected in (0, 1]");
  }
  const model::Model& model = robot.model();
  const int nj = robot.nj();
  JointLimitBounds out;
  out.state_lower = Eigen::VectorXd::Constant(robot.ndx(), -kInf);
  out.state_upper = Eigen::VectorXd::Constant(robot.ndx(), kInf);
  out.input_lower = Eigen::VectorXd::Constant(robot.nu(), -kInf);
  out.input_upper = Eigen::VectorXd::Constant(robot.nu(), kInf);
  const double margin = options.position_margin;
  for (int j = 0; j < nj; ++j) {
    double lo = model.lowerPositionLimit[j];
    double hi = model.upperPositionLimit[j];
    if (std::isfinite(lo)) lo += margin;
    if (std::isfinite(hi)) hi -= margin;
    if (lo > hi) {
      throw std::invalid_argument(
          "jointLimitBounds: options.position_margin = " + number(margin) +
          " empties the range of joint '" + model.jointNames[static_cast<size_t>(j)] + "' [" +
          number(model.lowerPositionLimit[j]) + ", " + number(model.upperPositionLimit[j]) + "]");
    }
    out.state_lower[robot.tangentJointIndex() + j] = lo;
    out.state_upper[robot.tangentJointIndex() + j] = hi;
    const double v = model.velocityLimit[j];
    if (std::isfinite(v) && v > 0.0) {
      out.input_lower[robot.inputJointVelocityIndex() + j] = -options.velocity_scale * v;
      out.input_upper[robot.inputJointVelocityIndex() + j] = options.velocity_scale * v;
    }
  }
  return out;
}

}  // namespace rollstep::centroidal
