#include "rollstep/control/reference_trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace rollstep::control {

ReferenceTrajectory::ReferenceTrajectory(
    std::shared_ptr<const centroidal::CentroidalPrecomputation> pre,
    const RefinementSettings& settings, int horizon)
    : pre_(pre ? std::move(pre)
               : throw std::invalid_argument("ReferenceTrajectory: null precomputation")),
      dynamics_(pre_),
      settings_(settings),
      horizon_(horizon) {
  if (horizon < 1) throw std::invalid_argument("ReferenceTrajectory: horizon < 1");
  if (!(settings.horizon >= 0.0) || !std::isfinite(settings.horizon)) {
    throw std::invalid_argument("ReferenceTrajectory: refinement horizon must be finite and >= 0");
  }
  if (settings.substeps < 1) throw std::invalid_argument("ReferenceTrajectory: substeps < 1");
  const centroidal::CentroidalRobot& robot = pre_->robot();
  nq_ = robot.nq();
  nv_ = robot.nv();
  nx_ = robot.nx();
  ndx_ = robot.ndx();
  nc_ = robot.nc();
  nj_ = robot.nj();
  dyn_data_ = dynamics_.createData();
  cache_ = std::make_unique<centroidal::CentroidalCache>(robot);
  us_.assign(static_cast<size_t>(horizon), Eigen::VectorXd::Zero(robot.nu()));
  // From any time inside the solution's first node to its end: N substeps + 2 nodes.
  const int capacity = horizon * settings.substeps + 2;
  nodes_.resize(static_cast<size_t>(capacity));
  for (Node& n : nodes_) {
    n.x = Eigen::VectorXd::Zero(nx_);
    n.v = Eigen::VectorXd::Zero(nv_);
    n.xdot = Eigen::VectorXd::Zero(ndx_);
    n.p = Eigen::Matrix3Xd::Zero(3, nc_);
    n.pv = Eigen::Matrix3Xd::Zero(3, nc_);
    n.forces = Eigen::VectorXd::Zero(3 * nc_);
  }
  dx_ = Eigen::VectorXd::Zero(ndx_);
  x_interp_ = Eigen::VectorXd::Zero(nx_);
}

ReferenceSample ReferenceTrajectory::makeSample() const {
  ReferenceSample s;
  s.q = Eigen::VectorXd::Zero(nq_);
  s.v = Eigen::VectorXd::Zero(nv_);
  s.a = Eigen::VectorXd::Zero(nv_);
  s.foot_position = Eigen::Matrix3Xd::Zero(3, nc_);
  s.foot_velocity = Eigen::Matrix3Xd::Zero(3, nc_);
  s.foot_acceleration = Eigen::Matrix3Xd::Zero(3, nc_);
  s.forces = Eigen::VectorXd::Zero(3 * nc_);
  return s;
}

int ReferenceTrajectory::inputIndex(double t) const {
  const double k = std::floor((t - t0_) / dt_ + 1e-9);
  if (!(k > 0.0)) return 0;
  return static_cast<int>(std::min(k, static_cast<double>(horizon_ - 1)));
}

bool ReferenceTrajectory::computeNode(int j) {
  Node& n = nodes_[static_cast<size_t>(j)];
  const Eigen::VectorXd& u = us_[static_cast<size_t>(inputIndex(t_start_ + j * step_))];
  pre_->compute(n.x, u, false, *cache_);
  ocp::NodeContext ctx;
  ctx.node = 0;
  ctx.dt = step_;
  ctx.time = t_start_ + j * step_;
  ctx.cache = cache_.get();
  dynamics_.calc(ctx, n.x, u, *dyn_data_, n.xdot);
  n.v.head<6>() = cache_->vb;
  n.v.tail(nj_) = u.head(nj_);
  n.p = cache_->nq.contactPositions;
  n.pv = cache_->nq.contactVelocities;
  n.forces = u.tail(3 * nc_);
  return n.x.allFinite() && n.v.allFinite() && n.xdot.allFinite() && n.p.allFinite() &&
         n.pv.allFinite();
}

bool ReferenceTrajectory::refine(const MpcSolution& solution, double t_now,
                                 const Eigen::VectorXd& x_now) noexcept {
  if (solution.horizon() != horizon_ || !solution.usable() || x_now.size() != nx_ ||
      !x_now.allFinite() || !std::isfinite(t_now) || !(solution.dt > 0.0)) {
    return false;
  }
  for (int k = 0; k < horizon_; ++k) {
    if (solution.us[static_cast<size_t>(k)].size() != us_[0].size()) return false;
  }
  for (int k = 0; k < horizon_; ++k)
    us_[static_cast<size_t>(k)] = solution.us[static_cast<size_t>(k)];
  t0_ = solution.t0;
  dt_ = solution.dt;
  t_end_ = t0_ + horizon_ * dt_;
  t_start_ = std::min(t_now, t_end_);
  step_ = dt_ / settings_.substeps;
  nodes_[0].x = x_now;
  failed_ = !computeNode(0);
  count_ = 1;
  if (failed_) {
    count_ = 0;
    return false;
  }
  extendTo(t_now + settings_.horizon);
  return true;
}

void ReferenceTrajectory::extendTo(double t) {
  const int capacity = static_cast<int>(nodes_.size());
  const ocp::StateSpace& space = *pre_->robot().space();
  while (!failed_ && count_ < capacity) {
    const double t_last = t_start_ + (count_ - 1) * step_;
    if (t_last >= t || t_last >= t_end_ - 1e-12) break;
    const Node& prev = nodes_[static_cast<size_t>(count_ - 1)];
    Node& next = nodes_[static_cast<size_t>(count_)];
    dx_ = step_ * prev.xdot;
    space.integrate(prev.x, dx_, next.x);
    if (!computeNode(count_)) {
      failed_ = true;  // keep what was refined so far; it holds its last state
      break;
    }
    ++count_;
  }
}

void ReferenceTrajectory::sample(double t, ReferenceSample& out) noexcept {
  out.time = t;
  if (count_ == 0) return;
  if (!(t >= t_start_)) t = t_start_;  // also NaN
  extendTo(t + step_);
  const double s = (t - t_start_) / step_;
  const int j = static_cast<int>(std::min(std::floor(s), static_cast<double>(count_ - 1)));
  if (j + 1 < count_) {
    const Node& n0 = nodes_[static_cast<size_t>(j)];
    const Node& n1 = nodes_[static_cast<size_t>(j + 1)];
    const double alpha = std::clamp(s - j, 0.0, 1.0);
    const ocp::StateSpace& space = *pre_->robot().space();
    space.difference(n0.x, n1.x, dx_);
    dx_ *= alpha;
    space.integrate(n0.x, dx_, x_interp_);
    out.q = x_interp_.head(nq_);
    out.v = (1.0 - alpha) * n0.v + alpha * n1.v;
    out.a = (n1.v - n0.v) / step_;
    out.foot_position = (1.0 - alpha) * n0.p + alpha * n1.p;
    out.foot_velocity = (1.0 - alpha) * n0.pv + alpha * n1.pv;
    out.foot_acceleration = (n1.pv - n0.pv) / step_;
    out.forces = n0.forces;
  } else {
    // Beyond the solution (or a failed integration): hold the last state at rest.
    const Node& n = nodes_[static_cast<size_t>(count_ - 1)];
    out.q = n.x.head(nq_);
    out.v.setZero();
    out.a.setZero();
    out.foot_position = n.p;
    out.foot_velocity.setZero();
    out.foot_acceleration.setZero();
    out.forces = n.forces;
  }
}

}  // namespace rollstep::control
