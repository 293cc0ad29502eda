#include "rollstep/ocp/dynamics.hpp"

#include <stdexcept>

#include "rollstep/ocp/small_products.hpp"

namespace rollstep::ocp {

namespace {

struct EulerData final : DynamicsData {
  EulerData(std::unique_ptr<DynamicsData> c, int ndx, int nu)
      : cont(std::move(c)),
        v(VectorXd::Zero(ndx)),
        fx(MatrixXd::Zero(ndx, ndx)),
        fu(MatrixXd::Zero(ndx, nu)),
        Jx(MatrixXd::Zero(ndx, ndx)),
        Jv(MatrixXd::Zero(ndx, ndx)) {}
  std::unique_ptr<DynamicsData> cont;
  VectorXd v;       // dt * f(x, u)
  MatrixXd fx, fu;  // continuous Jacobians
  MatrixXd Jx, Jv;  // Jacobians of integrate(x, v)
};

struct Rk4Data final : DynamicsData {
  Rk4Data(const ContinuousDynamics& f, int n, int nu) {
    for (int i = 0; i < 4; ++i) {
      cont[i] = f.createData();
      xs[i] = VectorXd::Zero(n);
      k[i] = VectorXd::Zero(n);
      kx[i] = MatrixXd::Zero(n, n);
      ku[i] = MatrixXd::Zero(n, nu);
    }
    fx = MatrixXd::Zero(n, n);
    fu = MatrixXd::Zero(n, nu);
    tx = MatrixXd::Zero(n, n);
  }
  // One continuous workspace per stage, so that calcDiff differentiates the stages calc
  // evaluated instead of evaluating them again.
  std::unique_ptr<DynamicsData> cont[4];
  VectorXd xs[4];         // stage points
  VectorXd k[4];          // stage slopes
  MatrixXd kx[4], ku[4];  // stage slope Jacobians
  MatrixXd fx, fu, tx;    // scratch
};

}  // namespace

// ---- explicit Euler on the manifold ------------------------------------------------------

ExplicitEuler::ExplicitEuler(std::shared_ptr<const ContinuousDynamics> f)
    : Dynamics(f ? f->spacePtr() : nullptr, f ? f->nu() : 0), f_(std::move(f)) {
  if (!f_) throw std::invalid_argument("ExplicitEuler: null continuous dynamics");
}

std::unique_ptr<DynamicsData> ExplicitEuler::createData() const {
  return std::make_unique<EulerData>(f_->createData(), space().ndx(), nu());
}

std::unique_ptr<DynamicsData> ExplicitEuler::createDataWithNodeCache() const {
  return std::make_unique<EulerData>(f_->createDataWithNodeCache(), space().ndx(), nu());
}

void ExplicitEuler::calc(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, DynamicsData& d,
                         VecRef xnext) const {
  auto& e = static_cast<EulerData&>(d);
  f_->calc(ctx, x, u, *e.cont, e.v);
  e.v *= ctx.dt;
  space().integrate(x, e.v, xnext);
}

void ExplicitEuler::calcDiff(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, DynamicsData& d,
                             MatRef Fx, MatRef Fu) const {
  auto& e = static_cast<EulerData&>(d);
  // calc() left e.v = dt f(x, u) and the continuous data ready for calcDiff.
  f_->calcDiff(ctx, x, u, *e.cont, e.fx, e.fu);
  if (space().isEuclidean()) {
    Fx.setIdentity();
    Fx.noalias() += ctx.dt * e.fx;
    Fu.noalias() = ctx.dt * e.fu;
    return;
  }
  // Jx and Jv are block-diagonal [b x b block, identity] with b = euclideanTangentOffset()
  // (the Euclidean tail integrates by addition): only the top b rows of Fx, Fu mix.
  const int b = space().euclideanTangentOffset(), n = space().ndx() - b;
  space().integrateJacobiansHead(x, e.v, e.Jx.topLeftCorner(b, b), e.Jv.topLeftCorner(b, b));
  const double dt = ctx.dt;
  smallDepthProduct(Fx.topRows(b), e.Jv.topLeftCorner(b, b), e.fx.topRows(b), dt, false);
  Fx.topLeftCorner(b, b) += e.Jx.topLeftCorner(b, b);
  Fx.bottomRows(n) = dt * e.fx.bottomRows(n);
  Fx.bottomRightCorner(n, n).diagonal().array() += 1.0;
  smallDepthProduct(Fu.topRows(b), e.Jv.topLeftCorner(b, b), e.fu.topRows(b), dt, false);
  Fu.bottomRows(n) = dt * e.fu.bottomRows(n);
}

// ---- RK4 (Euclidean) ------------------------------------------------------------------------

RungeKutta4::RungeKutta4(std::shared_ptr<const ContinuousDynamics> f)
    : Dynamics(f ? f->spacePtr() : nullptr, f ? f->nu() : 0), f_(std::move(f)) {
  if (!f_) throw std::invalid_argument("RungeKutta4: null continuous dynamics");
  if (!f_->space().isEuclidean()) {
    throw std::invalid_argument("RungeKutta4: only Euclidean state spaces (use ExplicitEuler)");
  }
}

std::unique_ptr<DynamicsData> RungeKutta4::createData() const {
  return std::make_unique<Rk4Data>(*f_, space().ndx(), nu());
}

void RungeKutta4::calc(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, DynamicsData& d,
                       VecRef xnext) const {
  auto& r = static_cast<Rk4Data&>(d);
  const double h = ctx.dt;
  static constexpr double c[4] = {0.0, 0.5, 0.5, 1.0};
  for (int i = 0; i < 4; ++i) {
    if (i == 0) {
      r.xs[i] = x;
    } else {
      r.xs[i] = x + (c[i] * h) * r.k[i - 1];
    }
    NodeContext sctx = ctx;
    sctx.time = ctx.time + c[i] * h;
    f_->calc(sctx, r.xs[i], u, *r.cont[i], r.k[i]);
  }
  xnext = x + (h / 6.0) * (r.k[0] + 2.0 * r.k[1] + 2.0 * r.k[2] + r.k[3]);
}

void RungeKutta4::calcDiff(const NodeContext& ctx, ConstVecRef /*x*/, ConstVecRef u,
                           DynamicsData& d, MatRef Fx, MatRef Fu) const {
  auto& r = static_cast<Rk4Data&>(d);
  const double h = ctx.dt;
  static constexpr double c[4] = {0.0, 0.5, 0.5, 1.0};
  // Stage i: k_i = f(x + c_i h k_{i-1}, u); dk_i = f_x (I dx + c_i h dk_{i-1}) + f_u du.
  // The stage points and workspaces are those of the calc just before (the contract).
  for (int i = 0; i < 4; ++i) {
    NodeContext sctx = ctx;
    sctx.time = ctx.time + c[i] * h;
    f_->calcDiff(sctx, r.xs[i], u, *r.cont[i], r.fx, r.fu);
    if (i == 0) {
      r.kx[0] = r.fx;
      r.ku[0] = r.fu;
    } else {
      r.tx.setIdentity();
      r.tx.noalias() += (c[i] * h) * r.kx[i - 1];
      r.kx[i].noalias() = r.fx * r.tx;
      r.ku[i] = r.fu;
      r.ku[i].noalias() += (c[i] * h) * (r.fx * r.ku[i - 1]);
    }
  }
  Fx.setIdentity();
  Fx += (h / 6.0) * (r.kx[0] + 2.0 * r.kx[1] + 2.0 * r.kx[2] + r.kx[3]);
  Fu = (h / 6.0) * (r.ku[0] + 2.0 * r.ku[1] + 2.0 * r.ku[2] + r.ku[3]);
}

}  // namespace rollstep::ocp
