// SwingHeightResidual (swing_height.hpp).
#include "rollstep/centroidal/swing_height.hpp"

#include <cmath>
#include <stdexcept>

namespace rollstep::centroidal {

SwingHeightResidual::SwingHeightResidual(
    std::shared_ptr<const CentroidalPrecomputation> pre,
    std::shared_ptr<const planning::FootReferencePlanner> planner, double kp, double max_correction)
    : ocp::Residual(pre ? pre->robot().ndx() : 0, pre ? pre->robot().nu() : 0,
                    pre ? pre->robot().nc() : 0),
      pre_(std::move(pre)),
      planner_(std::move(planner)),
      kp_(kp),
      max_correction_(max_correction) {
  if (!pre_) throw std::invalid_argument("SwingHeightResidual: null precomputation");
  if (!planner_) throw std::invalid_argument("SwingHeightResidual: null foot reference planner");
  if (planner_->numFeet() != pre_->robot().nc()) {
    throw std::invalid_argument("SwingHeightResidual: the planner has " +
                                std::to_string(planner_->numFeet()) + " feet, the robot " +
                                std::to_string(pre_->robot().nc()) + " contacts");
  }
  if (!std::isfinite(kp_) || kp_ < 0.0) {
    throw std::invalid_argument("SwingHeightResidual: kp = " + std::to_string(kp_) +
                                ", expected a finite value >= 0");
  }
  if (!std::isfinite(max_correction_) || max_correction_ < 0.0) {
    throw std::invalid_argument("SwingHeightResidual: max_correction = " +
                                std::to_string(max_correction_) + ", expected a finite value >= 0");
  }
}

double SwingHeightResidual::correction(double e) const {
  if (max_correction_ <= 0.0) return kp_ * e;
  return max_correction_ * std::tanh(kp_ * e / max_correction_);
}

double SwingHeightResidual::correctionSlope(double e) const {
  if (max_correction_ <= 0.0) return kp_;
  const double th = std::tanh(kp_ * e / max_correction_);
  return kp_ * (1.0 - th * th);
}

int SwingHeightResidual::rows(const ocp::NodeContext& ctx) const {
  int n = 0;
  for (int i = 0; i < pre_->robot().nc(); ++i) n += CentroidalRobot::inStance(ctx.mode, i) ? 0 : 1;
  return n;
}

std::unique_ptr<ocp::ResidualData> SwingHeightResidual::createData() const {
  return std::make_unique<CentroidalResidualData>(pre_->robot(), maxRows(), false);
}

std::unique_ptr<ocp::ResidualData> SwingHeightResidual::createDataWithNodeCache() const {
  return std::make_unique<CentroidalResidualData>(pre_->robot(), maxRows(), true);
}

std::string SwingHeightResidual::rowName(const ocp::NodeContext& ctx, int row) const {
  int n = 0;
  for (int i = 0; i < pre_->robot().nc(); ++i) {
    if (CentroidalRobot::inStance(ctx.mode, i)) continue;
    if (n++ == row) return pre_->robot().contact(i).frame + ": swing height";
  }
  return Residual::rowName(ctx, row);
}

void SwingHeightResidual::calc(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
                               ocp::ResidualData& d) const {
  if (rows(ctx) == 0) return;
  if (ctx.schedule == nullptr) {
    throw std::invalid_argument("SwingHeightResidual: the node context has no mode schedule");
  }
  const CentroidalRobot& r = pre_->robot();
  auto& data = static_cast<CentroidalResidualData&>(d);
  const CentroidalCache& c = nodeCache(ctx, x, u, false, *pre_, data.fallback.get());
  int row = 0;
  for (int i = 0; i < r.nc(); ++i) {
    if (CentroidalRobot::inStance(ctx.mode, i)) continue;
    const planning::FootReference ref = footReference(ctx, *planner_, i);
    d.r[row++] =
        c.footVelocity(i).z() - ref.z_dot_ref + correction(c.footPosition(i).z() - ref.z_ref);
  }
}

void SwingHeightResidual::calcDiff(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                   ocp::ConstVecRef u, ocp::ResidualData& d) const {
  const int n = rows(ctx);
  if (n > 0) calcDiffInto(ctx, x, u, d, d.Rx.topRows(n), d.Ru.topRows(n));
}

void SwingHeightResidual::calcDiffInto(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                       ocp::ConstVecRef u, ocp::ResidualData& d, ocp::MatRef Rx,
                                       ocp::MatRef Ru) const {
  if (Rx.rows() == 0) return;
  const CentroidalRobot& r = pre_->robot();
  auto& data = static_cast<CentroidalResidualData&>(d);
  const CentroidalCache& c = nodeCache(ctx, x, u, true, *pre_, data.fallback.get());
  const int nj = r.nj();
  const int nf = 3 * r.nc();
  int row = 0;
  for (int i = 0; i < r.nc(); ++i) {
    if (CentroidalRobot::inStance(ctx.mode, i)) continue;
    const int k = 3 * i + 2;
    double slope = kp_;
    if (max_correction_ > 0.0) {
      const planning::FootReference ref = footReference(ctx, *planner_, i);
      slope = correctionSlope(c.footPosition(i).z() - ref.z_ref);
    }
    Rx.row(row) = c.footVelocity_dx.row(k) + slope * c.footPosition_dx.row(k);
    Ru.row(row).head(nj) = c.footVelocity_du.row(k).head(nj);
    Ru.row(row).tail(nf).setZero();
    ++row;
  }
}

}  // namespace rollstep::centroidal
