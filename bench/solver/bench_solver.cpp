// Search direction and Newton step of the interior-point solver at the sizes of the
// Tachyon 3 OCP: nx = 24, nu = 30, N = 100, 15 equality rows per node, 100 inequality
// rows per node (30 input bounds and 12 state bounds on both sides, 16 general rows).
//
//   BM_RiccatiN100          backward + forward Riccati sweeps alone, on the projected
//                           stages (15 reduced inputs).
//   BM_RiccatiUnconstrainedN100  the same with no equalities (30 inputs in the
//                           recursion): comparable to HPIPM's unconstrained sweep.
//   BM_ProjectionN100       the equality projection of every running stage.
//   BM_SearchDirectionN100  projection + sweeps + recovery of du and the multipliers.
//   BM_NewtonStepN100       barrier condensing + projection + Riccati + slack/dual step +
//                           fraction to boundary + update, timed by the solver's own
//                           timers inside one real-time iteration (linearisation excluded).
//   BM_RealTimeIterationN100  the whole real-time iteration, linearisation included
//                           (single thread; /2Threads variant, wall time).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <random>
#include <vector>

#include "robot_size_lq.hpp"
#include "rollstep/ocp/cost.hpp"
#include "rollstep/ocp/problem.hpp"
#include "rollstep/ocp/residuals.hpp"
#include "rollstep/solver/riccati.hpp"
#include "rollstep/solver/solver.hpp"

namespace {

using namespace rollstep;
using ocp::MatrixXd;
using ocp::VectorXd;

using namespace robotlq;

/// Flops of one running stage (multiply and add counted separately).
double projectionFlops(int nx, int nu, int ne) {
  const int nw = nu - ne, nz = nw + nx, ncols = nu + nx + 1;
  double f = 0.0;
  for (int j = 0; j < ne; ++j) {
    const int m = ne - j - 1;
    f += 1.0 * m + 2.0 * m * (ncols - j - 1);  // LU step on [Eu Ex e]
  }
  f += 1.0 * ne * ne * (nz + 1);        // U11^-1 [U12 L^-1 Pi Ex L^-1 Pi e]
  f += 2.0 * ne * ne * (nz + 1);        // Y = H_Dv + 0.5 H_DD T
  f += 2.0 * (nz + 1) * (nz + 2) * ne;  // lower(T^T Y + Y^T T)
  f += 2.0 * nx * ne * (nz + 1);        // B_D T
  return f;
}
double backwardFlops(int nx, int nw) {
  const int nz = nx + nw;
  double f = 2.0 * nx * nx * nz;                  // P [B A] (symmetric product, full)
  f += 1.0 * nz * (nz + 1) * nx;                  // lower triangle of [B A]^T P [B A]
  f += 2.0 * nx * nx + 2.0 * nz * nx;             // gradient
  f += nw * nw * nw / 3.0;                        // Cholesky
  f += 1.0 * nx * nw * nw + nw * nw;              // triangular solves
  f += 1.0 * nx * (nx + 1) * nw + 2.0 * nx * nw;  // P update (syrk) and p
  return f;
}
double forwardFlops(int nx, int nw) {
  return 2.0 * nw * nx + nw * nw + 2.0 * nx * nx + 2.0 * nx * (nw + nx);
}
double recoverFlops(int nx, int nu, int ne) {
  const int nz = nu - ne + nx;
  // du_D = T [w; dx; 1], rho_D from W, H_DD and B_D, two triangular solves.
  return 4.0 * ne * (nz + 1) + 2.0 * ne * ne + 2.0 * nx * ne + 2.0 * ne * ne;
}

void fillStages(solver::RiccatiSolver& r, const Data& d, int ne) {
  std::mt19937 rng(7);
  const int nr = kNx + kNu;
  MatrixXd C(nr, kNx + kNu);
  C << d.Cx, d.Cu;
  const MatrixXd H = 0.015 * C.transpose() * C;
  for (int k = 0; k <= kN; ++k) {
    auto& s = r.stage(k);
    s.Q = H.topLeftCorner(kNx, kNx);
    s.R = H.bottomRightCorner(kNu, kNu);
    s.S = H.bottomLeftCorner(kNu, kNx);
    // Barrier terms: diagonal (bounds) plus a rank-16 update (general rows).
    const VectorXd wb = randn(kNu, 1, rng, 1.0).cwiseAbs();
    s.R.diagonal() += wb;
    s.Q.diagonal().head(kNbx) += randn(kNbx, 1, rng, 1.0).cwiseAbs();
    s.Q += d.Gx.transpose() * d.Gx;
    s.R += d.Gu.transpose() * d.Gu;
    s.S += d.Gu.transpose() * d.Gx;
    s.q = randn(kNx, 1, rng, 1.0);
    s.r = randn(kNu, 1, rng, 1.0);
    s.A = d.A;
    s.B = d.B;
    s.b = randn(kNx, 1, rng, 0.01);
    s.ne = (k < kN) ? ne : 0;
    if (ne > 0) {
      s.Ex = d.Ex;
      s.Eu = d.Eu;
      s.e = d.e;
    }
  }
}

void setFlops(benchmark::State& state, double flops) {
  state.counters["MFLOP"] = flops * 1e-6;
  state.counters["GFLOP/s"] =
      benchmark::Counter(flops * 1e-9, benchmark::Counter::kIsIterationInvariantRate);
}

// The backward and forward Riccati sweeps alone, on the projected stages.
void BM_RiccatiN100(benchmark::State& state) {
  const Data d = makeData();
  solver::RiccatiSolver r(kN, kNx, kNu, kNe);
  fillStages(r, d, kNe);
  for (int k = 0; k < kN; ++k) r.projectStage(k, 1e-9);
  const VectorXd dx0 = d.x0;
  for (auto _ : state) {
    r.backward();
    r.forward(dx0);
    benchmark::DoNotOptimize(r.dx(kN).data());
  }
  const int nw = kNu - kNe;
  setFlops(state, kN * (backwardFlops(kNx, nw) + forwardFlops(kNx, nw)));
}
BENCHMARK(BM_RiccatiN100)->Unit(benchmark::kMillisecond);

// The equality projection of every running stage.
void BM_ProjectionN100(benchmark::State& state) {
  const Data d = makeData();
  solver::RiccatiSolver r(kN, kNx, kNu, kNe);
  fillStages(r, d, kNe);
  for (auto _ : state) {
    for (int k = 0; k < kN; ++k) r.projectStage(k, 1e-9);
    benchmark::DoNotOptimize(r.stage(0).Q.data());
  }
  setFlops(state, kN * projectionFlops(kNx, kNu, kNe));
}
BENCHMARK(BM_ProjectionN100)->Unit(benchmark::kMillisecond);

// The whole search direction from the condensed stages: projection, sweeps, recovery of
// du and the equality multipliers.
void BM_SearchDirectionN100(benchmark::State& state) {
  const Data d = makeData();
  solver::RiccatiSolver r(kN, kNx, kNu, kNe);
  fillStages(r, d, kNe);
  const VectorXd dx0 = d.x0;
  for (auto _ : state) {
    for (int k = 0; k < kN; ++k) r.projectStage(k, 1e-9);
    r.backward();
    r.forward(dx0);
    for (int k = 0; k < kN; ++k) r.recoverStage(k);
    benchmark::DoNotOptimize(r.du(0).data());
  }
  const int nw = kNu - kNe;
  setFlops(state, kN * (projectionFlops(kNx, kNu, kNe) + backwardFlops(kNx, nw) +
                        forwardFlops(kNx, nw) + recoverFlops(kNx, kNu, kNe)));
}
BENCHMARK(BM_SearchDirectionN100)->Unit(benchmark::kMillisecond);

void BM_RiccatiUnconstrainedN100(benchmark::State& state) {
  const Data d = makeData();
  solver::RiccatiSolver r(kN, kNx, kNu, 0);
  fillStages(r, d, 0);
  for (int k = 0; k < kN; ++k) r.projectStage(k, 1e-9);
  const VectorXd dx0 = d.x0;
  for (auto _ : state) {
    r.backward();
    r.forward(dx0);
    benchmark::DoNotOptimize(r.dx(kN).data());
  }
  setFlops(state, kN * (backwardFlops(kNx, kNu) + forwardFlops(kNx, kNu)));
}
BENCHMARK(BM_RiccatiUnconstrainedN100)->Unit(benchmark::kMillisecond);

// One real-time iteration of the solver (Solver::update) at a representative interior
// point. `newton_only`: the benchmark time is the solver's own timers for barrier
// condensing + projection + Riccati + slack/dual step + fraction to boundary + update
// (the Newton step), without the linearisation of the nodes (the problem's evaluation).
void realTimeIteration(benchmark::State& state, int threads, bool newton_only) {
  const Data d = makeData();
  solver::SolverSettings set;
  set.mode = solver::SolverMode::RealTime;
  set.num_threads = threads;
  solver::Solver s(makeProblem(d), set);
  // Warm up into a representative interior point.
  for (int i = 0; i < 20; ++i) s.update(0.0, d.x0);
  double lin = 0.0, ric = 0.0, upd = 0.0, newton_min = 1e9;
  for (auto _ : state) {
    s.update(0.0, d.x0);
    const auto& st = s.stats()[0];
    lin += st.time_linearize_ms;
    ric += st.time_riccati_ms;
    upd += st.time_update_ms;
    newton_min = std::min(newton_min, st.time_riccati_ms + st.time_update_ms);
    if (newton_only) state.SetIterationTime(1e-3 * (st.time_riccati_ms + st.time_update_ms));
  }
  const double n = static_cast<double>(state.iterations());
  // The fastest Newton step seen: robust to preemption on a busy machine.
  state.counters["newton_min_ms"] = newton_min;
  state.counters["lin_ms"] = lin / n;
  state.counters["riccati_ms"] = ric / n;
  state.counters["update_ms"] = upd / n;
  state.counters["primal_res"] = s.stats()[0].primal_residual;
  state.counters["inertia_shift"] = s.stats()[0].inertia_shift;
}
void BM_NewtonStepN100(benchmark::State& state) { realTimeIteration(state, 1, true); }
BENCHMARK(BM_NewtonStepN100)->Unit(benchmark::kMillisecond)->UseManualTime();
void BM_RealTimeIterationN100(benchmark::State& state) { realTimeIteration(state, 1, false); }
BENCHMARK(BM_RealTimeIterationN100)->Unit(benchmark::kMillisecond);
void BM_RealTimeIterationN100_2Threads(benchmark::State& state) {
  realTimeIteration(state, 2, false);
}
BENCHMARK(BM_RealTimeIterationN100_2Threads)->Unit(benchmark::kMillisecond)->UseRealTime();

// A converging solve of the robot-size LQ problem from a cold start: the defaults
// (Mehrotra's predictor-corrector: the problem has no curvature), exact_hessian = false
// (the same path: nothing to differentiate), and the monotone barrier with the filter line
// search (predictor_corrector = false): iterations and time per iteration.
void convergingSolve(benchmark::State& state, bool exact_hessian, bool predictor_corrector,
                     bool many_active = false) {
  const Data d = many_active ? makeActiveData() : makeData();
  solver::SolverSettings set;
  set.exact_hessian = exact_hessian;
  set.predictor_corrector = predictor_corrector;
  auto problem = makeProblem(d);
  solver::Solver s(problem, set);
  const std::vector<VectorXd> xs(kN + 1, VectorXd::Zero(kNx));
  const std::vector<VectorXd> us(kN, VectorXd::Zero(kNu));
  int iterations = 0;
  bool converged = true;
  double ms = 0.0;
  for (auto _ : state) {
    s.setInitialGuess(xs, us);
    const auto t = std::chrono::steady_clock::now();
    converged = converged && s.solve(d.x0) == solver::SolverStatus::Converged;
    ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
    iterations = s.iterations();
  }
  state.counters["iterations"] = iterations;
  state.counters["ms_per_iteration"] =
      ms / static_cast<double>(state.iterations()) / std::max(iterations, 1);
  state.counters["converged"] = converged ? 1 : 0;
}
void BM_ConvergingSolveLqN100(benchmark::State& state) { convergingSolve(state, true, true); }
BENCHMARK(BM_ConvergingSolveLqN100)->Unit(benchmark::kMillisecond);
void BM_ConvergingSolveLqN100_GaussNewton(benchmark::State& state) {
  convergingSolve(state, false, true);
}
BENCHMARK(BM_ConvergingSolveLqN100_GaussNewton)->Unit(benchmark::kMillisecond);
void BM_ConvergingSolveLqN100_MonotoneBarrier(benchmark::State& state) {
  convergingSolve(state, true, false);
}
BENCHMARK(BM_ConvergingSolveLqN100_MonotoneBarrier)->Unit(benchmark::kMillisecond);
// makeActiveData: targets beyond the bounds, about 720 active rows at the optimum.
void BM_ConvergingSolveLqActiveN100(benchmark::State& state) {
  convergingSolve(state, true, true, true);
}
BENCHMARK(BM_ConvergingSolveLqActiveN100)->Unit(benchmark::kMillisecond);
void BM_ConvergingSolveLqActiveN100_MonotoneBarrier(benchmark::State& state) {
  convergingSolve(state, true, false, true);
}
BENCHMARK(BM_ConvergingSolveLqActiveN100_MonotoneBarrier)->Unit(benchmark::kMillisecond);

}  // namespace

// main: bench/common/bench_main.cpp
