#pragma once
// The robot-size linear-quadratic problem of the solver benchmarks (bench_solver) and of
// the iteration-count test: the Tachyon 3 OCP's dimensions (nx = 24, nu = 30, N = 100,
// 15 equality rows per node, 30 input bounds and 12 state bounds on both sides, 16
// general rows: 100 inequality rows per node), random data from a fixed seed.
#include <memory>
#include <random>

#include "lq_problems.hpp"
#include "rollstep/ocp/cost.hpp"
#include "rollstep/ocp/problem.hpp"
#include "rollstep/ocp/residuals.hpp"
#include "test_models.hpp"

namespace rollstep::robotlq {

using ocp::MatrixXd;
using ocp::VectorXd;

constexpr int kNx = 24, kNu = 30, kN = 100, kNe = 15, kNbu = 30, kNbx = 12, kNg = 16;

using lqtest::randn;

struct Data {
  MatrixXd A, B, Cx, Cu, Ex, Eu, Gx, Gu;
  VectorXd c, cr, e, g, x0;
  VectorXd x_ref = VectorXd::Zero(kNx), u_ref = VectorXd::Zero(kNu);  ///< tracking targets
  double input_weight = 0.1;
};

inline Data makeData() {
  std::mt19937 rng(2026);
  Data d;
  d.A = MatrixXd::Identity(kNx, kNx) + randn(kNx, kNx, rng, 0.02);
  d.B = randn(kNx, kNu, rng, 0.05);
  d.c = randn(kNx, 1, rng, 0.01);
  const int nr = kNx + kNu;
  d.Cx = randn(nr, kNx, rng, 0.2);
  d.Cx.topRows(kNx) += MatrixXd::Identity(kNx, kNx);
  d.Cu = randn(nr, kNu, rng, 0.2);
  d.Cu.bottomRows(kNu) += MatrixXd::Identity(kNu, kNu);
  d.cr = randn(nr, 1, rng, 0.3);
  d.Ex = randn(kNe, kNx, rng, 0.1);
  d.Eu = randn(kNe, kNu, rng, 0.3);
  d.Eu.leftCols(kNe) += MatrixXd::Identity(kNe, kNe);
  d.e = randn(kNe, 1, rng, 0.05);
  d.Gx = randn(kNg, kNx, rng, 0.1);
  d.Gu = randn(kNg, kNu, rng, 0.1);
  d.g = VectorXd::Constant(kNg, 2.0);
  d.x0 = randn(kNx, 1, rng, 0.1);
  return d;
}

/// The same sizes with targets beyond the bounds, so that about 720 of the 10,000
/// inequality rows are active at the optimum (input bounds, state bounds, general rows;
/// about half of the 1,500 reduced inputs): the hard case of an interior-point method's
/// iteration count.
inline Data makeActiveData(unsigned seed = 2027) {
  Data d = makeData();
  std::mt19937 rng(seed);
  d.g = VectorXd::Constant(kNg, 0.4) + randn(kNg, 1, rng, 0.1);
  d.Gx = randn(kNg, kNx, rng, 0.3);
  d.Gu = randn(kNg, kNu, rng, 0.3);
  for (int i = 0; i < kNu; ++i) d.u_ref(i) = (i % 3 == 0 ? 4.0 : -4.0);
  for (int i = 0; i < kNbx; ++i) d.x_ref(i) = (i % 2 == 0 ? 3.0 : -3.0);
  d.x0 = randn(kNx, 1, rng, 0.3);
  d.input_weight = 1.0;
  return d;
}

inline std::shared_ptr<ocp::OptimalControlProblem> makeProblem(const Data& d) {
  auto dyn = std::make_shared<testmodels::LinearDynamics>(d.A, d.B, d.c);
  auto p = std::make_shared<ocp::OptimalControlProblem>(dyn, kN, 0.015);
  auto s = dyn->spacePtr();
  const VectorXd zx = VectorXd::Zero(kNx);
  // Like the Tachyon 3 OCP: state and input tracking (identity Jacobians) plus a small
  // dense residual (the base-velocity tracking, 6 rows).
  p->addCost("state", std::make_shared<ocp::LeastSquaresCost>(
                          std::make_shared<ocp::StateErrorResidual>(s, kNu, d.x_ref),
                          VectorXd::Constant(kNx, 1.0)));
  p->addCost("input", std::make_shared<ocp::LeastSquaresCost>(
                          std::make_shared<ocp::InputErrorResidual>(kNx, d.u_ref),
                          VectorXd::Constant(kNu, d.input_weight)));
  p->addCost("velocity", std::make_shared<ocp::LeastSquaresCost>(
                             std::make_shared<ocp::AffineResidual>(s, zx, d.Cx.topRows(6),
                                                                   d.Cu.topRows(6), d.cr.head(6)),
                             VectorXd::Constant(6, 5.0)));
  p->addCost(
      "terminal",
      std::make_shared<ocp::LeastSquaresCost>(std::make_shared<ocp::StateErrorResidual>(s, kNu, zx),
                                              VectorXd::Constant(kNx, 10.0)),
      ocp::Stage::Terminal);
  p->addEquality("eq", std::make_shared<ocp::AffineResidual>(s, zx, d.Ex, d.Eu, d.e));
  p->addInequality("general", std::make_shared<ocp::AffineResidual>(s, zx, d.Gx, d.Gu, d.g));
  p->setInputBounds(VectorXd::Constant(kNu, -1.0), VectorXd::Constant(kNu, 1.0));
  VectorXd lo = VectorXd::Constant(kNx, -ocp::OptimalControlProblem::kInfinity);
  VectorXd hi = VectorXd::Constant(kNx, ocp::OptimalControlProblem::kInfinity);
  lo.head(kNbx).setConstant(-1.0);
  hi.head(kNbx).setConstant(1.0);
  p->setStateBounds(lo, hi);
  return p;
}

}  // namespace rollstep::robotlq
