// SwingForceResidual and StanceVelocityResidual (contact_equalities.hpp).
#include "rollstep/centroidal/contact_equalities.hpp"

#include <cmath>
#include <stdexcept>

namespace rollstep::centroidal {

namespace {
int stanceVelocityMaxRows(const CentroidalRobot& r) {
  int n = 0;
  for (int i = 0; i < r.nc(); ++i) n += r.contact(i).drive_wheel ? 2 : 1;
  return n;
}
const CentroidalRobot& robotOf(const std::shared_ptr<const CentroidalPrecomputation>& pre,
                               const char* who) {
  if (!pre) throw std::invalid_argument(std::string(who) + ": null precomputation");
  return pre->robot();
}
}  // namespace

// ---- SwingForceResidual ---------------------------------------------------------------

SwingForceResidual::SwingForceResidual(std::shared_ptr<const CentroidalRobot> robot)
    : ocp::Residual(robot ? robot->ndx() : 0, robot ? robot->nu() : 0, robot ? 3 * robot->nc() : 0),
      robot_(std::move(robot)) {
  if (!robot_) throw std::invalid_argument("SwingForceResidual: null robot");
}

int SwingForceResidual::rows(const ocp::NodeContext& ctx) const {
  int n = 0;
  for (int i = 0; i < robot_->nc(); ++i) n += CentroidalRobot::inStance(ctx.mode, i) ? 0 : 3;
  return n;
}

std::string SwingForceResidual::rowName(const ocp::NodeContext& ctx, int row) const {
  int first = 0;
  for (int i = 0; i < robot_->nc(); ++i) {
    if (CentroidalRobot::inStance(ctx.mode, i)) continue;
    if (row < first + 3) return robot_->contact(i).frame + ": f_" + "xyz"[row - first];
    first += 3;
  }
  return Residual::rowName(ctx, row);
}

void SwingForceResidual::calc(const ocp::NodeContext& ctx, ocp::ConstVecRef /*x*/,
                              ocp::ConstVecRef u, ocp::ResidualData& d) const {
  int row = 0;
  for (int i = 0; i < robot_->nc(); ++i) {
    if (CentroidalRobot::inStance(ctx.mode, i)) continue;
    d.r.segment<3>(row) = u.segment<3>(robot_->inputForceIndex(i));
    row += 3;
  }
}

void SwingForceResidual::calcDiff(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                  ocp::ConstVecRef u, ocp::ResidualData& d) const {
  const int n = rows(ctx);
  calcDiffInto(ctx, x, u, d, d.Rx.topRows(n), d.Ru.topRows(n));
}

void SwingForceResidual::calcDiffInto(const ocp::NodeContext& ctx, ocp::ConstVecRef /*x*/,
                                      ocp::ConstVecRef /*u*/, ocp::ResidualData& /*d*/,
                                      ocp::MatRef Rx, ocp::MatRef Ru) const {
  Rx.setZero();
  Ru.setZero();
  int row = 0;
  for (int i = 0; i < robot_->nc(); ++i) {
    if (CentroidalRobot::inStance(ctx.mode, i)) continue;
    Ru.block<3, 3>(row, robot_->inputForceIndex(i)).setIdentity();
    row += 3;
  }
}

// ---- StanceVelocityResidual -----------------------------------------------------------

StanceVelocityResidual::StanceVelocityResidual(std::shared_ptr<const CentroidalPrecomputation> pre,
                                               StanceRows rows, StanceComponents components,
                                               TerrainReferences terrain)
    : ocp::Residual(robotOf(pre, "StanceVelocityResidual").ndx(), pre ? pre->robot().nu() : 0,
                    pre ? stanceVelocityMaxRows(pre->robot()) : 0),
      pre_(std::move(pre)),
      which_(rows),
      components_(components),
      terrain_(terrain) {}

bool StanceVelocityResidual::lateral(int i) const {
  return components_ != StanceComponents::VerticalOnly && pre_->robot().contact(i).drive_wheel;
}

bool StanceVelocityResidual::selected(int mode, int i) const {
  if (which_ == StanceRows::All) return CentroidalRobot::inStance(mode, i);
  const bool kept = pre_->robot().keepsVelocityConstraints(mode, i);
  return which_ == StanceRows::Kept ? kept : CentroidalRobot::inStance(mode, i) && !kept;
}

int StanceVelocityResidual::rows(const ocp::NodeContext& ctx) const {
  const CentroidalRobot& r = pre_->robot();
  int n = 0;
  for (int i = 0; i < r.nc(); ++i) {
    if (selected(ctx.mode, i)) n += (vertical() ? 1 : 0) + (lateral(i) ? 1 : 0);
  }
  return n;
}

std::unique_ptr<ocp::ResidualData> StanceVelocityResidual::createData() const {
  return std::make_unique<CentroidalResidualData>(pre_->robot(), maxRows(), false);
}

std::unique_ptr<ocp::ResidualData> StanceVelocityResidual::createDataWithNodeCache() const {
  return std::make_unique<CentroidalResidualData>(pre_->robot(), maxRows(), true);
}

std::string StanceVelocityResidual::rowName(const ocp::NodeContext& ctx, int row) const {
  const CentroidalRobot& r = pre_->robot();
  int n = 0;
  for (int i = 0; i < r.nc(); ++i) {
    if (!selected(ctx.mode, i)) continue;
    if (vertical() && n++ == row) return r.contact(i).frame + ": normal velocity";
    if (lateral(i) && n++ == row) return r.contact(i).frame + ": lateral velocity";
  }
  return Residual::rowName(ctx, row);
}

void StanceVelocityResidual::calc(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                  ocp::ConstVecRef u, ocp::ResidualData& d) const {
  const CentroidalRobot& r = pre_->robot();
  if (rows(ctx) == 0) return;
  auto& data = static_cast<CentroidalResidualData&>(d);
  const CentroidalCache& c = nodeCache(ctx, x, u, false, *pre_, data.fallback.get());
  int row = 0;
  for (int i = 0; i < r.nc(); ++i) {
    if (!selected(ctx.mode, i)) continue;
    const auto v = c.footVelocity(i);
    if (vertical()) {
      // Flat ground keeps the plain z component (bit for bit what it was before slopes).
      const Eigen::Vector3d n = terrain_.normal(ctx, i);
      d.r[row++] = n == Eigen::Vector3d::UnitZ() ? v.z() : n.dot(v);
    }
    if (lateral(i)) {
      const double yaw = c.footYaw[i];
      d.r[row++] = -std::sin(yaw) * v.x() + std::cos(yaw) * v.y();
    }
  }
}

void StanceVelocityResidual::calcDiff(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                      ocp::ConstVecRef u, ocp::ResidualData& d) const {
  const int n = rows(ctx);
  if (n > 0) calcDiffInto(ctx, x, u, d, d.Rx.topRows(n), d.Ru.topRows(n));
}

void StanceVelocityResidual::calcDiffInto(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                          ocp::ConstVecRef u, ocp::ResidualData& d, ocp::MatRef Rx,
                                          ocp::MatRef Ru) const {
  const CentroidalRobot& r = pre_->robot();
  if (Rx.rows() == 0) return;
  auto& data = static_cast<CentroidalResidualData&>(d);
  const CentroidalCache& c = nodeCache(ctx, x, u, true, *pre_, data.fallback.get());
  const int nj = r.nj();
  const int nf = 3 * r.nc();
  int row = 0;
  for (int i = 0; i < r.nc(); ++i) {
    if (!selected(ctx.mode, i)) continue;
    const int k = 3 * i;
    if (vertical()) {
      // The region's normal is constant: the row is n^T dv_i.
      const Eigen::Vector3d n = terrain_.normal(ctx, i);
      if (n == Eigen::Vector3d::UnitZ()) {
        Rx.row(row) = c.footVelocity_dx.row(k + 2);
        Ru.row(row).head(nj) = c.footVelocity_du.row(k + 2).head(nj);
      } else {
        Rx.row(row) = n.transpose() * c.footVelocity_dx.middleRows<3>(k);
        Ru.row(row).head(nj) = n.transpose() * c.footVelocity_du.middleRows<3>(k).leftCols(nj);
      }
      Ru.row(row).tail(nf).setZero();
      ++row;
    }
    if (lateral(i)) {
      // r = e_lat . v, e_lat = (-sin yaw, cos yaw, 0); d r / d yaw = -(e_fwd . v).
      const double s = std::sin(c.footYaw[i]), co = std::cos(c.footYaw[i]);
      const auto v = c.footVelocity(i);
      const double dyaw = -(co * v.x() + s * v.y());
      Rx.row(row) = -s * c.footVelocity_dx.row(k) + co * c.footVelocity_dx.row(k + 1) +
                    dyaw * c.footYaw_dx.row(i);
      Ru.row(row).head(nj) =
          -s * c.footVelocity_du.row(k).head(nj) + co * c.footVelocity_du.row(k + 1).head(nj);
      Ru.row(row).tail(nf).setZero();
      ++row;
    }
  }
}

}  // namespace rollstep::centroidal
