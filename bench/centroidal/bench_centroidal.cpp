// Centroidal layer benchmarks on Tachyon 3: the node precomputation, the dynamics (explicit
// Euler), the equalities and costs of one node, a whole node linearisation, and one
// real-time iteration of the problem (no inequalities) at N = 100 during a trot, and the
// horizon's advance with and without edge holds.
//   build-*/bench/centroidal/bench_centroidal
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "centroidal/assembly.hpp"
#include "rollstep/centroidal/centroidal_ocp.hpp"
#include "rollstep/solver/solver.hpp"

namespace {

using namespace rollstep;
using namespace rollstep::centroidal;
using namespace rollstep::centroidal::test;

struct NodeFixture {
  std::shared_ptr<const CentroidalRobot> robot = tachyon3Robot();
  std::shared_ptr<const CentroidalPrecomputation> pre =
      std::make_shared<const CentroidalPrecomputation>(robot);
  std::unique_ptr<ocp::NodeCache> cache = pre->createCache();
  Tachyon3Scene scene = makeTachyon3Scene("trot");
  Eigen::VectorXd x, u;
  int mode = maskOf({LF, RF, MR});
  ocp::NodeContext ctx;
  NodeFixture() {
    std::mt19937 rng(1);
    x = randomState(*robot, rng);
    u = randomInput(*robot, rng);
    ctx = makeContext(mode, scene.timeInMode(mode), scene.schedule.get(), cache.get());
  }
};

/// Bytes in use on the heap (glibc's count of allocated chunks; 0 elsewhere): the difference
/// around a constructor is the memory it holds.
double heapBytesInUse() {
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 33))
  return static_cast<double>(mallinfo2().uordblks);
#else
  return 0.0;
#endif
}

NodeFixture& node() {
  static NodeFixture f;
  return f;
}

void BM_Precompute(benchmark::State& state) {
  NodeFixture& f = node();
  const bool derivatives = state.range(0) != 0;
  for (auto _ : state) {
    f.pre->compute(f.ctx, f.x, f.u, derivatives, *f.cache);
    benchmark::DoNotOptimize(f.cache.get());
  }
}
BENCHMARK(BM_Precompute)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

void BM_ContinuousDynamics(benchmark::State& state) {
  NodeFixture& f = node();
  const CentroidalDynamics dyn(f.pre);
  auto d = dyn.createData();
  Eigen::VectorXd xdot(f.robot->ndx());
  Eigen::MatrixXd fx(f.robot->ndx(), f.robot->ndx()), fu(f.robot->ndx(), f.robot->nu());
  f.pre->compute(f.ctx, f.x, f.u, true, *f.cache);
  for (auto _ : state) {
    dyn.calc(f.ctx, f.x, f.u, *d, xdot);
    dyn.calcDiff(f.ctx, f.x, f.u, *d, fx, fu);
    benchmark::DoNotOptimize(fx.data());
  }
}
BENCHMARK(BM_ContinuousDynamics)->Unit(benchmark::kMicrosecond);

void BM_DynamicsEuler(benchmark::State& state) {
  NodeFixture& f = node();
  const ocp::ExplicitEuler F(std::make_shared<const CentroidalDynamics>(f.pre));
  auto d = F.createData();
  Eigen::VectorXd xn(f.robot->nx());
  Eigen::MatrixXd Fx(f.robot->ndx(), f.robot->ndx()), Fu(f.robot->ndx(), f.robot->nu());
  f.pre->compute(f.ctx, f.x, f.u, true, *f.cache);
  for (auto _ : state) {
    F.calc(f.ctx, f.x, f.u, *d, xn);
    F.calcDiff(f.ctx, f.x, f.u, *d, Fx, Fu);
    benchmark::DoNotOptimize(Fx.data());
  }
}
BENCHMARK(BM_DynamicsEuler)->Unit(benchmark::kMicrosecond);

void BM_Equalities(benchmark::State& state) {
  NodeFixture& f = node();
  const SwingForceResidual force(f.robot);
  const StanceVelocityResidual velocity(f.pre);
  const SwingHeightResidual height(f.pre, f.scene.feet, 10.0);
  const std::vector<const ocp::Residual*> terms{&force, &velocity, &height};
  std::vector<std::unique_ptr<ocp::ResidualData>> data;
  for (const auto* t : terms) data.push_back(t->createData());
  f.pre->compute(f.ctx, f.x, f.u, true, *f.cache);
  for (auto _ : state) {
    for (std::size_t k = 0; k < terms.size(); ++k) {
      data[k]->rows = terms[k]->rows(f.ctx);
      terms[k]->calc(f.ctx, f.x, f.u, *data[k]);
      terms[k]->calcDiff(f.ctx, f.x, f.u, *data[k]);
    }
    benchmark::DoNotOptimize(data[1]->Rx.data());
  }
}
BENCHMARK(BM_Equalities)->Unit(benchmark::kMicrosecond);

void BM_Costs(benchmark::State& state) {
  NodeFixture& f = node();
  const Eigen::VectorXd q_j_ref = nominalState(*f.robot).segment(7, f.robot->nj());
  const ocp::LeastSquaresCost velocity(
      std::make_shared<const BaseVelocityResidual>(f.pre, f.scene.base), Eigen::VectorXd::Ones(6));
  const ocp::LeastSquaresCost tracking(
      std::make_shared<const StateTrackingResidual>(f.robot, q_j_ref, f.scene.base),
      Eigen::VectorXd::Ones(f.robot->ndx()));
  const ocp::LeastSquaresCost input(std::make_shared<const InputTrackingResidual>(f.robot),
                                    Eigen::VectorXd::Ones(f.robot->nu()));
  const std::vector<const ocp::CostTerm*> costs{&velocity, &tracking, &input};
  std::vector<std::unique_ptr<ocp::CostData>> data;
  for (const auto* c : costs) data.push_back(c->createData());
  const int ndx = f.robot->ndx(), nu = f.robot->nu();
  Eigen::VectorXd lx = Eigen::VectorXd::Zero(ndx), lu = Eigen::VectorXd::Zero(nu);
  Eigen::MatrixXd Lxx = Eigen::MatrixXd::Zero(ndx, ndx), Luu = Eigen::MatrixXd::Zero(nu, nu),
                  Lux = Eigen::MatrixXd::Zero(nu, ndx);
  f.pre->compute(f.ctx, f.x, f.u, true, *f.cache);
  for (auto _ : state) {
    for (std::size_t k = 0; k < costs.size(); ++k) {
      costs[k]->calc(f.ctx, f.x, f.u, *data[k]);
      costs[k]->calcDiff(f.ctx, f.x, f.u, *data[k], 0.015, lx, lu, Lxx, Luu, Lux);
    }
    benchmark::DoNotOptimize(Lxx.data());
  }
}
BENCHMARK(BM_Costs)->Unit(benchmark::kMicrosecond);

struct ProblemFixture {
  Assembly a{"trot", 0.3, 100};
  solver::Solver solver;
  std::vector<Eigen::VectorXd> xs, us;
  ProblemFixture() : solver(a.problem, realTime()) {
    nominalGuess(*a.robot, 100, xs, us);
    solver.setInitialGuess(xs, us);
  }
  static solver::SolverSettings realTime() {
    solver::SolverSettings s;
    s.mode = solver::SolverMode::RealTime;
    return s;
  }
};

void BM_NodeLinearize(benchmark::State& state) {
  static ProblemFixture p;
  auto d = p.a.problem->createNodeData();
  for (auto _ : state) {
    p.a.problem->linearize(10, p.xs[10], p.us[10], *d);
    benchmark::DoNotOptimize(d->Fx.data());
  }
}
BENCHMARK(BM_NodeLinearize)->Unit(benchmark::kMicrosecond);

void BM_RealTimeIterationN100(benchmark::State& state) {
  static ProblemFixture p;
  const Eigen::VectorXd x0 = p.xs[0];
  double lin = 0.0, ric = 0.0, upd = 0.0, shift = 0.0;
  for (auto _ : state) {
    const auto status = p.solver.update(0.0, x0);
    benchmark::DoNotOptimize(status);
    const solver::IterationStats& it = p.solver.stats().back();
    lin += it.time_linearize_ms;
    ric += it.time_riccati_ms;
    upd += it.time_update_ms;
    shift = std::max(shift, it.inertia_shift);
  }
  const auto n = static_cast<double>(state.iterations());
  state.counters["linearize_ms"] = lin / n;
  state.counters["riccati_ms"] = ric / n;
  state.counters["update_ms"] = upd / n;
  state.counters["max_inertia_shift"] = shift;
}
BENCHMARK(BM_RealTimeIterationN100)->Unit(benchmark::kMillisecond);

/// The Tachyon 3 OCP as `rollstep plan` builds it on flat ground, trotting at 0.15 m/s.
std::unique_ptr<CentroidalOcp> tachyon3FlatTrotOcp(const OcpSettings& settings) {
  const RobotOcpDescription robot =
      loadRobotOcpDescription(std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/centroidal.yaml");
  auto ocp = std::make_unique<CentroidalOcp>(
      robot, settings, planning::terrainFromBoxes({-20, 20, -5, 5, 0}, 0.0, {}),
      planning::GaitKind::Trot);
  ocp->reset(0.0, lie::SE3::Identity(), planning::BaseVelocityCommand{0.15, 0.0, 0.0});
  return ocp;
}

/// The whole OCP as `rollstep plan` builds it (every cost, equality and
/// inequality, joint bounds; config defaults) on flat ground, trotting at 0.15 m/s, solved
/// to convergence once; then one real-time iteration per benchmark iteration (linearise
/// every node and term, condense, project, Riccati, update), from the same x0 and time so
/// that every iteration does the same work. Arg: solver threads. The environment variable
/// ROLLSTEP_BENCH_HUGE_PAGES=0 turns SolverSettings::huge_pages off (on by default), to
/// measure what the advice gains. Counter solver_bytes: the heap the solver holds (its
/// workspace, the nodes' data and the Riccati stages), measured around its constructor.
void BM_Tachyon3RtiUpdateN100(benchmark::State& state) {
  OcpSettings settings;
  settings.solver.realtime_iterations = 1;  // one iteration per update (the NMPC's runs two)
  settings.solver.num_threads = static_cast<int>(state.range(0));
  const char* huge = std::getenv("ROLLSTEP_BENCH_HUGE_PAGES");
  if (huge != nullptr && std::string(huge) == "0") settings.solver.huge_pages = false;
  const std::unique_ptr<CentroidalOcp> ocp_ptr = tachyon3FlatTrotOcp(settings);
  CentroidalOcp& ocp = *ocp_ptr;
  const double heap_before = heapBytesInUse();
  solver::Solver solver(ocp.problem(), settings.solver);
  const double solver_bytes = heapBytesInUse() - heap_before;
  const Eigen::VectorXd x0 = ocp.standingState(0.0, 0.0, 0.0);
  std::vector<Eigen::VectorXd> xs, us;
  ocp.initialGuess(xs, us);
  solver.setInitialGuess(xs, us);
  solver.solve(x0);
  double lin = 0.0, ric = 0.0, upd = 0.0;
  for (auto _ : state) {
    const auto status = solver.update(0.0, x0);
    benchmark::DoNotOptimize(status);
    const solver::IterationStats& it = solver.stats().back();
    lin += it.time_linearize_ms;
    ric += it.time_riccati_ms;
    upd += it.time_update_ms;
  }
  const auto n = static_cast<double>(state.iterations());
  state.counters["linearize_ms"] = lin / n;
  state.counters["riccati_ms"] = ric / n;
  state.counters["update_ms"] = upd / n;
  state.counters["solver_bytes"] = solver_bytes;
}
BENCHMARK(BM_Tachyon3RtiUpdateN100)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

/// The term evaluation alone of BM_Tachyon3RtiUpdateN100's linearisation: every node of
/// the same OCP (every cost, equality and inequality, the terrain and foot planner) linearised
/// in turn at the converged solution (no condensing, projection or Riccati step). Arg 0:
/// through one node data that stays in cache; Arg 1: through a node data of its own per node
/// (every node's workspaces, cache and results apart: what the memory costs the term
/// evaluation); Arg 2: a node data per node sharing the first one's workspaces and cache, as
/// the solver's nodes on one thread do (the nodes' own results apart). Counters: s_per_node,
/// the time of one node; data_bytes, the heap the node data hold. BM_NodeLinearize times a
/// smaller problem (no inequalities, no terrain).
void BM_Tachyon3LinearizeAllNodes(benchmark::State& state) {
  OcpSettings settings;
  settings.solver.realtime_iterations = 1;
  const std::unique_ptr<CentroidalOcp> ocp = tachyon3FlatTrotOcp(settings);
  solver::Solver solver(ocp->problem(), settings.solver);
  const Eigen::VectorXd x0 = ocp->standingState(0.0, 0.0, 0.0);
  std::vector<Eigen::VectorXd> xs, us;
  ocp->initialGuess(xs, us);
  solver.setInitialGuess(xs, us);
  solver.solve(x0);
  const ocp::OptimalControlProblem& problem = *ocp->problem();
  const int n = problem.horizon();
  const bool per_node = state.range(0) != 0;
  std::vector<std::unique_ptr<ocp::NodeData>> data;
  const double heap_before = heapBytesInUse();
  data.push_back(problem.createNodeData());
  for (int k = 1; per_node && k <= n; ++k) {
    data.push_back(state.range(0) == 1 ? problem.createNodeData()
                                       : problem.createNodeDataSharingWorkspaces(*data[0]));
  }
  for (auto _ : state) {
    for (int k = 0; k <= n; ++k) {
      ocp::NodeData& d = *data[per_node ? static_cast<std::size_t>(k) : 0];
      problem.linearize(k, solver.states()[static_cast<std::size_t>(k)],
                        solver.inputs()[static_cast<std::size_t>(std::min(k, n - 1))], d);
      benchmark::DoNotOptimize(d.Fx.data());
    }
  }
  state.counters["data_bytes"] = heapBytesInUse() - heap_before;
  state.counters["s_per_node"] = benchmark::Counter(
      n + 1, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_Tachyon3LinearizeAllNodes)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

/// CentroidalOcp::advance over step20 (regions shrunk by 0.085 m, climb.yaml's gait and
/// foothold rule) at t0 sweeping 1-17 s, over both of the block's edges: the horizon's mode
/// schedule, with (Arg 1: climb.yaml's edge holds, ocp.step_down_max_hold 0.9 s and
/// step_up_max_hold 1.5 s, planned over the horizon first) or without (Arg 0) them.
void BM_AdvanceWithEdgeHolds(benchmark::State& state) {
  OcpSettings settings;
  settings.gait_period = 1.8;
  settings.foothold_gap_reach = 0.2;
  settings.step_down_max_hold = state.range(0) != 0 ? 0.9 : 0.0;
  settings.step_up_max_hold = state.range(0) != 0 ? 1.5 : 0.0;
  const RobotOcpDescription robot =
      loadRobotOcpDescription(std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/centroidal.yaml");
  CentroidalOcp ocp(
      robot, settings,
      planning::terrainFromBoxes({-5, 10, -1.5, 1.5, 0}, 0.0, {{1.0, 2.2, -1.5, 1.5, 0.2}}, 0.085),
      planning::GaitKind::Trot);
  ocp.reset(0.0, lie::SE3::Identity(), planning::BaseVelocityCommand{0.15, 0.0, 0.0});
  double t0 = 1.0;
  for (auto _ : state) {
    ocp.advance(t0);
    benchmark::DoNotOptimize(ocp.gaitClock().totalHeld());
    t0 += 0.02;
    if (t0 > 17.0) {  // back to the start with a fresh clock
      state.PauseTiming();
      ocp.reset(0.0, lie::SE3::Identity(), planning::BaseVelocityCommand{0.15, 0.0, 0.0});
      t0 = 1.0;
      state.ResumeTiming();
    }
  }
}
BENCHMARK(BM_AdvanceWithEdgeHolds)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

}  // namespace
