// The CBF-QP's dense QP solver at the safety filter's size: n = 30 variables, 12
// equalities, 60 two-sided general rows, about half the variables bounded (the random
// problems of tests/control/qp_test_problems.hpp, feasible by construction).
//
// Each benchmark walks a sequence of slowly drifting problems, as the filter sees them from
// one 1 kHz tick to the next (g, the row sides and the rows themselves drift by a few
// percent per 100 ticks), and times every solve on its own (manual time), so that the
// counters give the distribution, not just the mean:
//   median_us, p99_us, max_us   wall time per solve (steady_clock)
//   cpu_median_us, cpu_p99_us   thread CPU time per solve (CLOCK_THREAD_CPUTIME_ID): on a
//                               shared machine the wall-time tail is other processes
//   iterations                  mean active-set changes per solve
//   active                      mean inequality sides active at the optimum
//   BM_QpCold   every solve from the unconstrained minimum (warm_start = false)
//   BM_QpWarm   every solve from the previous tick's active set (the filter's mode)
//   BM_QpColdNewH, BM_QpWarmNewH   the same with H changing every tick too (the solver
//               then refactorises H; with a constant H it reuses the factors)
#include <benchmark/benchmark.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "qp_test_problems.hpp"
#include "rollstep/control/dense_qp.hpp"

namespace {

using namespace rollstep;

constexpr int kN = 30, kNeq = 12, kNineq = 60;

double threadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

class DriftingQp {
 public:
  DriftingQp(unsigned seed, bool drift_h) : qp_({kN, kNeq, kNineq}), drift_h_(drift_h) {
    qptest::RandomQpSpec spec{kN, kNeq, kNineq};
    qptest::makeRandomQp(spec, seed, qp_);
    H0_ = qp_.H();
    g0_ = qp_.g();
    C0_ = qp_.C();
    l0_ = qp_.l();
    u0_ = qp_.u();
  }
  /// The problem of tick k.
  const control::DenseQpProblem& at(long k) {
    const double t = 0.01 * static_cast<double>(k);
    if (drift_h_) qp_.H() = H0_ * (1.0 + 0.05 * std::sin(0.9 * t));
    for (int j = 0; j < kN; ++j) qp_.g()(j) = g0_(j) + 2.0 * std::sin(t + j);
    // Rows tilt and sides move together, so the drift keeps the problem feasible at
    // nearly the same point: 2 % of a row per unit of t.
    const double s = 0.02 * std::sin(0.7 * t);
    for (int i = 0; i < kNineq; ++i) {
      const double shift = 0.05 * std::sin(1.3 * t + i);
      qp_.C().row(i) = C0_.row(i) * (1.0 + s * std::cos(i));
      qp_.l()(i) = l0_(i) * (1.0 + s * std::cos(i)) - std::abs(shift);
      qp_.u()(i) = u0_(i) * (1.0 + s * std::cos(i)) + std::abs(shift);
    }
    return qp_;
  }

 private:
  control::DenseQpProblem qp_;
  bool drift_h_;
  Eigen::VectorXd g0_, l0_, u0_;
  Eigen::MatrixXd H0_, C0_;
};

void runSequence(benchmark::State& state, bool warm, bool drift_h) {
  DriftingQp problems(1, drift_h);
  control::DenseQpSolver solver({kN, kNeq, kNineq});
  solver.settings().warm_start = warm;
  std::vector<double> us, cpu_us;
  us.reserve(1 << 20);
  cpu_us.reserve(1 << 20);
  long tick = 0, iterations = 0, active = 0, failures = 0;
  solver.solve(problems.at(tick++));  // the previous tick, for the first warm start
  for (auto _ : state) {
    const control::DenseQpProblem& qp = problems.at(tick++);
    const double c0 = threadCpuSeconds();
    const auto t0 = std::chrono::steady_clock::now();
    const control::DenseQpStatus st = solver.solve(qp);
    const auto t1 = std::chrono::steady_clock::now();
    const double c1 = threadCpuSeconds();
    const double seconds = std::chrono::duration<double>(t1 - t0).count();
    state.SetIterationTime(seconds);
    if (us.size() < us.capacity()) {
      us.push_back(1e6 * seconds);
      cpu_us.push_back(1e6 * (c1 - c0));
    }
    iterations += solver.iterations();
    active += solver.numActiveInequalities();
    failures += st != control::DenseQpStatus::Optimal;
    benchmark::DoNotOptimize(solver.x().data());
  }
  if (us.empty()) return;
  auto quantile = [](std::vector<double>& v, double q) {
    const auto k = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1));
    std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
    return v[k];
  };
  const double n = static_cast<double>(us.size());
  state.counters["median_us"] = quantile(us, 0.5);
  state.counters["p99_us"] = quantile(us, 0.99);
  state.counters["cpu_median_us"] = quantile(cpu_us, 0.5);
  state.counters["cpu_p99_us"] = quantile(cpu_us, 0.99);
  state.counters["max_us"] = *std::max_element(us.begin(), us.end());
  state.counters["iterations"] = static_cast<double>(iterations) / n;
  state.counters["active"] = static_cast<double>(active) / n;
  state.counters["failures"] = static_cast<double>(failures);
}

void BM_QpCold(benchmark::State& state) { runSequence(state, false, false); }
void BM_QpWarm(benchmark::State& state) { runSequence(state, true, false); }
void BM_QpColdNewH(benchmark::State& state) { runSequence(state, false, true); }
void BM_QpWarmNewH(benchmark::State& state) { runSequence(state, true, true); }

BENCHMARK(BM_QpCold)->UseManualTime()->Iterations(20000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_QpWarm)->UseManualTime()->Iterations(20000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_QpColdNewH)->UseManualTime()->Iterations(20000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_QpWarmNewH)->UseManualTime()->Iterations(20000)->Unit(benchmark::kMicrosecond);

}  // namespace
