#include "rollstep/centroidal/stance_slip.hpp"

#include <cmath>
#include <stdexcept>

namespace rollstep::centroidal {

namespace {
const CentroidalRobot& robotOf(const std::shared_ptr<const CentroidalPrecomputation>& pre) {
  if (!pre) throw std::invalid_argument("FreedStanceVelocityResidual: null precomputation");
  return pre->robot();
}
int maxFreedRows(const CentroidalRobot& r) {
  int n = 0;
  for (int i = 0; i < r.nc(); ++i) n += r.contact(i).drive_wheel ? 2 : 1;
  return n;
}
}  // namespace

FreedStanceVelocityResidual::FreedStanceVelocityResidual(
    std::shared_ptr<const CentroidalPrecomputation> pre)
    : ocp::Residual(robotOf(pre).ndx(), robotOf(pre).nu(), maxFreedRows(robotOf(pre))),
      pre_(std::move(pre)) {}

bool FreedStanceVelocityResidual::freed(int mode, int i) const {
  return CentroidalRobot::inStance(mode, i) && !pre_->robot().keepsVelocityConstraints(mode, i);
}

int FreedStanceVelocityResidual::rows(const ocp::NodeContext& ctx) const {
  const CentroidalRobot& r = pre_->robot();
  int n = 0;
  for (int i = 0; i < r.nc(); ++i) {
    if (freed(ctx.mode, i)) n += r.contact(i).drive_wheel ? 2 : 1;
  }
  return n;
}

std::unique_ptr<ocp::ResidualData> FreedStanceVelocityResidual::createData() const {
  return std::make_unique<CentroidalResidualData>(pre_->robot(), maxRows());
}

void FreedStanceVelocityResidual::calc(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                       ocp::ConstVecRef u, ocp::ResidualData& d) const {
  const CentroidalRobot& r = pre_->robot();
  if (rows(ctx) == 0) return;
  auto& data = static_cast<CentroidalResidualData&>(d);
  const CentroidalCache& c = nodeCache(ctx, x, u, false, *pre_, data.fallback);
  int row = 0;
  for (int i = 0; i < r.nc(); ++i) {
    if (!freed(ctx.mode, i)) continue;
    const auto v = c.footVelocity(i);
    d.r[row++] = v.z();
    if (r.contact(i).drive_wheel) {
      const double yaw = c.footYaw[i];
      d.r[row++] = -std::sin(yaw) * v.x() + std::cos(yaw) * v.y();
    }
  }
}

void FreedStanceVelocityResidual::calcDiff(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                           ocp::ConstVecRef u, ocp::ResidualData& d) const {
  const CentroidalRobot& r = pre_->robot();
  if (rows(ctx) == 0) return;
  auto& data = static_cast<CentroidalResidualData&>(d);
  const CentroidalCache& c = nodeCache(ctx, x, u, true, *pre_, data.fallback);
  const int nj = r.nj();
  const int nf = 3 * r.nc();
  int row = 0;
  for (int i = 0; i < r.nc(); ++i) {
    if (!freed(ctx.mode, i)) continue;
    const int k = 3 * i;
    d.Rx.row(row) = c.footVelocity_dx.row(k + 2);
    d.Ru.row(row).head(nj) = c.footVelocity_du.row(k + 2).head(nj);
    d.Ru.row(row).tail(nf).setZero();
    ++row;
    if (r.contact(i).drive_wheel) {
      // r = e_lat . v with e_lat = (-sin yaw, cos yaw, 0); d r / d yaw = -(e_fwd . v).
      const double s = std::sin(c.footYaw[i]), co = std::cos(c.footYaw[i]);
      const auto v = c.footVelocity(i);
      const double dyaw = -(co * v.x() + s * v.y());
      d.Rx.row(row) = -s * c.footVelocity_dx.row(k) + co * c.footVelocity_dx.row(k + 1) +
                      dyaw * c.footYaw_dx.row(i);
      d.Ru.row(row).head(nj) =
          -s * c.footVelocity_du.row(k).head(nj) + co * c.footVelocity_du.row(k + 1).head(nj);
      d.Ru.row(row).tail(nf).setZero();
      ++row;
    }
  }
}

}  // namespace rollstep::centroidal
