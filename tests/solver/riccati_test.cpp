// The Riccati recursion with equality projection against one dense KKT solve of the same
// equality-constrained LQ.
#include "rollstep/solver/riccati.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

#include "lq_problems.hpp"

namespace {

using namespace rollstep;
using lqtest::randn;
using ocp::MatrixXd;
using ocp::VectorXd;

/// Random time-varying stages (positive definite Hessians, stable-ish dynamics, a
/// well-conditioned Eu = [I 0] + noise) with ne_of(k) equality rows at node k. The upper
/// triangles of Q and R are poisoned: only the lower ones are part of the contract.
/// The first `nfix` rows of a stage (when it has more) fix one input each (Ex row zero, one
/// non-zero in Eu, as a swing foot's zero force): inputs nu - 1, nu - 3, ..., scaled by
/// 0.5 + row; the other rows keep their entries on those inputs.
template <class NeOf>
void fillRandomStages(solver::RiccatiSolver& ric, NeOf ne_of, std::mt19937& rng, int nfix = 0) {
  const int nx = ric.nx(), nu = ric.nu(), N = ric.horizon();
  for (int k = 0; k <= N; ++k) {
    auto& s = ric.stage(k);
    const MatrixXd Lh = randn(nx + nu, nx + nu, rng, 1.0 / std::sqrt(nx + nu));
    const MatrixXd H = Lh * Lh.transpose() + 0.1 * MatrixXd::Identity(nx + nu, nx + nu);
    s.Q = H.bottomRightCorner(nx, nx);
    s.R = H.topLeftCorner(nu, nu);
    s.S = H.topRightCorner(nu, nx);
    s.Q.triangularView<Eigen::StrictlyUpper>().setConstant(std::nan(""));
    s.R.triangularView<Eigen::StrictlyUpper>().setConstant(std::nan(""));
    s.A = MatrixXd::Identity(nx, nx) + randn(nx, nx, rng, 0.2 / std::sqrt(nx));
    s.B = randn(nx, nu, rng, 0.5 / std::sqrt(nu));
    s.ne = (k < N) ? ne_of(k) : 0;
    s.Ex.setZero();
    s.Eu.setZero();
    if (s.ne > 0) {
      s.Ex.topRows(s.ne) = randn(s.ne, nx, rng, 0.3);
      s.Eu.topRows(s.ne) = randn(s.ne, nu, rng, 0.3);
      s.Eu.topLeftCorner(s.ne, s.ne) += MatrixXd::Identity(s.ne, s.ne);
      for (int i = 0; i < std::min(nfix, s.ne); ++i) {
        s.Ex.row(i).setZero();
        s.Eu.row(i).setZero();
        s.Eu(i, nu - 1 - 2 * i) = 0.5 + i;
      }
    }
  }
}

/// Random vectors q, r, b, e of every stage.
void randomVectors(solver::RiccatiSolver& ric, std::mt19937& rng) {
  for (int k = 0; k <= ric.horizon(); ++k) {
    auto& s = ric.stage(k);
    s.q = randn(ric.nx(), 1, rng, 0.5);
    s.r = randn(ric.nu(), 1, rng, 0.5);
    s.b = randn(ric.nx(), 1, rng, 0.3);
    s.e = randn(ric.maxEqualities(), 1, rng, 0.3);
  }
}

struct Case {
  int nx, nu, N, ne, nfix = 0;  // nfix: rows that fix one input each
  // The solver's row capacity above ne (as the Tachyon 3 OCP's, above nu), and stages with
  // every count of rows 0 .. ne in turn (else ne and ne - 1): the projection's blocks are
  // stored packed to each stage's sizes.
  int ne_spare = 0;
  bool every_count = false;
};

class RiccatiDense : public ::testing::TestWithParam<Case> {};

TEST_P(RiccatiDense, MatchesDenseKkt) {
  const Case c = GetParam();
  const int nx = c.nx, nu = c.nu, N = c.N;
  std::mt19937 rng(42u + static_cast<unsigned>(c.ne));
  solver::RiccatiSolver ric(N, nx, nu, c.ne + c.ne_spare);
  // Random time-varying stages; the number of equality rows varies with k.
  fillRandomStages(
      ric,
      [&](int k) {
        if (c.every_count) return k % (c.ne + 1);
        return c.ne == 0 ? 0 : (k % 3 == 1 ? c.ne - 1 : c.ne);
      },
      rng, c.nfix);
  randomVectors(ric, rng);
  std::vector<int> nes(static_cast<std::size_t>(N));
  for (int k = 0; k < N; ++k) nes[static_cast<std::size_t>(k)] = ric.stage(k).ne;
  const VectorXd dx0 = randn(nx, 1, rng);
  ASSERT_TRUE(ric.solve(dx0, 1e-12));

  // Dense: z = [x_0 u_0 ... x_N]; equalities: -x_0 = -dx0, A x + B u - x+ = -b, Ex x + Eu u = -e.
  const int nz = N * (nx + nu) + nx;
  int neq = nx;
  for (int k = 0; k < N; ++k) neq += nx + nes[static_cast<std::size_t>(k)];
  MatrixXd K = MatrixXd::Zero(nz + neq, nz + neq);
  VectorXd rhs = VectorXd::Zero(nz + neq);
  int r = nz;
  K.block(r, 0, nx, nx) = -MatrixXd::Identity(nx, nx);
  rhs.segment(r, nx) = -dx0;
  r += nx;
  for (int k = 0; k <= N; ++k) {
    const auto& s = ric.stage(k);
    const int o = k * (nx + nu);
    K.block(o, o, nx, nx) = s.Q.selfadjointView<Eigen::Lower>();
    rhs.segment(o, nx) = -s.q;
    if (k == N) break;
    K.block(o + nx, o + nx, nu, nu) = s.R.selfadjointView<Eigen::Lower>();
    K.block(o + nx, o, nu, nx) = s.S;
    K.block(o, o + nx, nx, nu) = s.S.transpose();
    rhs.segment(o + nx, nu) = -s.r;
    K.block(r, o, nx, nx) = s.A;
    K.block(r, o + nx, nx, nu) = s.B;
    K.block(r, o + nx + nu, nx, nx) = -MatrixXd::Identity(nx, nx);
    rhs.segment(r, nx) = -s.b;
    r += nx;
    if (s.ne > 0) {
      K.block(r, o, s.ne, nx) = s.Ex.topRows(s.ne);
      K.block(r, o + nx, s.ne, nu) = s.Eu.topRows(s.ne);
      rhs.segment(r, s.ne) = -s.e.head(s.ne);
      r += s.ne;
    }
  }
  K.topRightCorner(nz, neq) = K.bottomLeftCorner(neq, nz).transpose();
  const VectorXd sol = K.fullPivLu().solve(rhs);
  ASSERT_LT((K * sol - rhs).norm(), 1e-9);

  // Our solution in the same stacking: its KKT residual must be as small as the dense one.
  VectorXd ours(nz + neq);
  r = nz;
  ours.segment(r, nx) = ric.costate(0);
  r += nx;
  for (int k = 0; k <= N; ++k) {
    const int o = k * (nx + nu);
    ours.segment(o, nx) = ric.dx(k);
    if (k == N) break;
    ours.segment(o + nx, nu) = ric.du(k);
    ours.segment(r, nx) = ric.costate(k + 1);
    r += nx;
    const int ne = ric.stage(k).ne;
    ours.segment(r, ne) = ric.equalityMultipliers(k).head(ne);
    r += ne;
  }
  const double scale = std::max(1.0, sol.lpNorm<Eigen::Infinity>());
  RecordProperty("solution_scale", std::to_string(scale));
  EXPECT_LT((K * ours - rhs).lpNorm<Eigen::Infinity>(), 1e-11 * scale);
  const double tol = 1e-9;  // absolute; the solutions are O(1..100) (solution_scale)
  r = nz;
  EXPECT_LT((ric.costate(0) - sol.segment(r, nx)).lpNorm<Eigen::Infinity>(), tol);
  r += nx;
  for (int k = 0; k <= N; ++k) {
    const int o = k * (nx + nu);
    EXPECT_LT((ric.dx(k) - sol.segment(o, nx)).lpNorm<Eigen::Infinity>(), tol) << "node " << k;
    if (k == N) break;
    EXPECT_LT((ric.du(k) - sol.segment(o + nx, nu)).lpNorm<Eigen::Infinity>(), tol) << "node " << k;
    EXPECT_LT((ric.costate(k + 1) - sol.segment(r, nx)).lpNorm<Eigen::Infinity>(), tol)
        << "node " << k;
    r += nx;
    const int ne = ric.stage(k).ne;
    if (ne > 0) {
      EXPECT_LT(
          (ric.equalityMultipliers(k).head(ne) - sol.segment(r, ne)).lpNorm<Eigen::Infinity>(), tol)
          << "node " << k;
      r += ne;
    }
  }
  // Feedback gain: du = K dx + k. Check with a perturbed initial state (linearity).
  MatrixXd K0(nu, nx);
  ric.feedbackGain(0, K0);
  const VectorXd du0 = ric.du(0);
  const VectorXd delta = randn(nx, 1, rng, 1e-2);
  ric.forward(dx0 + delta);
  ric.recoverStage(0);
  EXPECT_LT((ric.du(0) - du0 - K0 * delta).lpNorm<Eigen::Infinity>(), 1e-10);
}

INSTANTIATE_TEST_SUITE_P(Sizes, RiccatiDense,
                         ::testing::Values(Case{4, 2, 10, 0}, Case{4, 3, 12, 2}, Case{6, 5, 8, 5},
                                           Case{24, 30, 6, 15}, Case{6, 7, 8, 4, 2},
                                           Case{5, 6, 6, 3, 3}, Case{24, 30, 6, 15, 9},
                                           Case{5, 6, 14, 6, 2, 3, true},
                                           Case{8, 10, 22, 10, 3, 4, true}));

TEST(RiccatiProjection, RankDeficientEqualitiesAreDetected) {
  const int nx = 3, nu = 4;
  solver::RiccatiSolver ric(2, nx, nu, 3);
  auto& s = ric.stage(0);
  s.ne = 3;
  s.Eu.setZero();
  s.Eu.row(0) << 1, 2, 0, 0;
  s.Eu.row(1) << 0, 1, 1, 0;
  s.Eu.row(2) = 2.0 * s.Eu.row(0) - s.Eu.row(1);  // dependent
  double ratio = 1.0;
  EXPECT_FALSE(ric.projectStage(0, 1e-9, &ratio));
  EXPECT_LT(ratio, 1e-9);
  s.Eu.row(2) << 0, 0, 0, 1;
  EXPECT_TRUE(ric.projectStage(0, 1e-9, &ratio));
  EXPECT_GT(ratio, 1e-3);
  // Two rows fixing the same input, and a fixing entry below the tolerance.
  s.Ex.setZero();
  s.Eu.setZero();
  s.Eu(0, 2) = 1.0;
  s.Eu.row(1) << 1, 0, 0, 1;
  s.Eu(2, 2) = -3.0;
  EXPECT_FALSE(ric.projectStage(0, 1e-9, &ratio));
  EXPECT_LT(ratio, 1e-9);
  s.Eu(2, 2) = 0.0;
  s.Eu(2, 1) = 1e-12;
  s.Eu(1, 0) = 1e3;
  EXPECT_FALSE(ric.projectStage(0, 1e-9, &ratio));
  EXPECT_NEAR(ratio, 1e-15, 1e-20);
  s.Eu(2, 1) = 1.0;
  EXPECT_TRUE(ric.projectStage(0, 1e-9, &ratio));
  s.ne = 0;
  EXPECT_TRUE(ric.projectStage(0, 1e-9));
}

}  // namespace

// A second right-hand side through the stored projection and factorisation gives what a
// full solve from scratch gives.
TEST(RiccatiProjection, ResolveVectorsMatchesAFreshSolve) {
  for (const int ne : {0, 3, 7, -5}) {  // -5: 5 rows, 2 of which fix an input
    const int nfix = ne < 0 ? 2 : 0, ner = std::abs(ne);
    std::mt19937 rng(5u + static_cast<unsigned>(ner));
    const int nx = 6, nu = 8, N = 9;
    solver::RiccatiSolver ric(N, nx, nu, 7), ref(N, nx, nu, 7);
    fillRandomStages(
        ric, [ner](int k) { return k % 4 == 2 ? 0 : ner; }, rng, nfix);
    randomVectors(ric, rng);
    ASSERT_TRUE(ric.solve(randn(nx, 1, rng), 1e-12));
    randomVectors(ric, rng);
    const VectorXd dx0 = randn(nx, 1, rng);
    ric.resolveVectors(dx0);
    for (int k = 0; k <= N; ++k) ref.stage(k) = ric.stage(k);
    ASSERT_TRUE(ref.solve(dx0, 1e-12));
    for (int k = 0; k <= N; ++k) {
      EXPECT_LT((ric.dx(k) - ref.dx(k)).norm(), 1e-10) << "ne " << ne << " k " << k;
      EXPECT_LT((ric.costate(k) - ref.costate(k)).norm(), 1e-10) << "ne " << ne << " k " << k;
      if (k < N) {
        EXPECT_LT((ric.du(k) - ref.du(k)).norm(), 1e-10) << "ne " << ne << " k " << k;
        EXPECT_LT((ric.equalityMultipliers(k) - ref.equalityMultipliers(k)).norm(), 1e-10);
      }
    }
  }
}

namespace {

// The shared-sweep tests' problem: random stages with `ne` rows at most stages (ne < 0: -ne
// rows, 2 of which fix an input) and random vectors in `ref`, copied to `ric`.
void fillSharedSweepCase(int ne, std::mt19937& rng, solver::RiccatiSolver& ref,
                         solver::RiccatiSolver& ric, int N) {
  const int nfix = ne < 0 ? 2 : 0, ner = std::abs(ne);
  fillRandomStages(
      ref, [ner](int k) { return k % 4 == 2 ? 0 : ner; }, rng, nfix);
  randomVectors(ref, rng);
  for (int k = 0; k <= N; ++k) ric.stage(k) = ref.stage(k);
}

// Bit for bit the same step, costates and equality multipliers.
void expectSameSolution(const solver::RiccatiSolver& ric, const solver::RiccatiSolver& ref, int N,
                        const std::string& what) {
  for (int k = 0; k <= N; ++k) {
    EXPECT_EQ(ric.dx(k), ref.dx(k)) << what << " k " << k;
    EXPECT_EQ(ric.costate(k), ref.costate(k)) << what << " k " << k;
    if (k < N) {
      EXPECT_EQ(ric.du(k), ref.du(k)) << what << " k " << k;
      EXPECT_EQ(ric.equalityMultipliers(k), ref.equalityMultipliers(k)) << what << " k " << k;
    }
  }
}

}  // namespace

// With one shared reduced Hessian (the Solver's single-thread sweep), projecting and
// factorising each stage in turn gives bit for bit the solution of solve(); backward()
// and solve(), which project every stage first, refuse to run.
TEST(RiccatiProjection, SharedReducedHessianGivesTheSameSolution) {
  for (const int ne : {0, 3, -5}) {  // -5: 5 rows, 2 of which fix an input
    std::mt19937 rng(11u + static_cast<unsigned>(std::abs(ne)));
    const int nx = 6, nu = 8, N = 9;
    solver::RiccatiSolver ric(N, nx, nu, 7), ref(N, nx, nu, 7);
    fillSharedSweepCase(ne, rng, ref, ric, N);
    const VectorXd dx0 = randn(nx, 1, rng);
    ASSERT_TRUE(ref.solve(dx0, 1e-12));
    ric.shareReducedHessian(true);
    EXPECT_THROW(ric.solve(dx0, 1e-12), std::logic_error);
    EXPECT_THROW(ric.backward(), std::logic_error);
    ric.beginBackward();
    for (int k = N - 1; k >= 0; --k) {
      ASSERT_TRUE(ric.projectStage(k, 1e-12));
      ASSERT_TRUE(ric.backwardStage(k));
    }
    ric.forward(dx0);
    for (int k = 0; k < N; ++k) ric.recoverStage(k);
    expectSameSolution(ric, ref, N, "ne " + std::to_string(ne));
  }
}

// With one shared set of Hessian blocks Q, R, S (the Solver's single-thread sweep), each
// stage's written into it right before its projection, and the shared reduced Hessian:
// bit for bit the solution of solve(), also the multipliers of the rows that fix an input
// (which need R's column and S's row of that input after the set was overwritten), and
// after resolveVectors with new vectors. The blocks left in the stages are poisoned: they
// must not be read. backward() and solve() refuse to run.
TEST(RiccatiProjection, SharedStageHessiansGiveTheSameSolution) {
  for (const int ne : {0, 3, -5}) {  // -5: 5 rows, 2 of which fix an input
    std::mt19937 rng(23u + static_cast<unsigned>(std::abs(ne)));
    const int nx = 6, nu = 8, N = 9;
    solver::RiccatiSolver ric(N, nx, nu, 7), ref(N, nx, nu, 7);
    fillSharedSweepCase(ne, rng, ref, ric, N);
    for (int k = 0; k <= N; ++k) {
      ric.stage(k).Q.setConstant(std::nan(""));
      ric.stage(k).R.setConstant(std::nan(""));
      ric.stage(k).S.setConstant(std::nan(""));
    }
    const VectorXd dx0 = randn(nx, 1, rng);
    ASSERT_TRUE(ref.solve(dx0, 1e-12));
    ric.shareStageHessians(true);
    ric.shareReducedHessian(true);
    EXPECT_THROW(ric.solve(dx0, 1e-12), std::logic_error);
    EXPECT_THROW(ric.backward(), std::logic_error);
    const auto write = [&](int k) {
      const solver::RiccatiSolver::StageHessian h = ric.hessian(k);
      h.Q = ref.stage(k).Q;
      h.R = ref.stage(k).R;
      h.S = ref.stage(k).S;
    };
    write(N);
    ric.beginBackward();
    for (int k = N - 1; k >= 0; --k) {
      write(k);
      ASSERT_TRUE(ric.projectStage(k, 1e-12));
      ASSERT_TRUE(ric.backwardStage(k));
      // Nothing after the projection reads the stage's A, B, Ex and Eu either (the Solver
      // shares them with one thread): the fixed-input columns of B and Eu are kept.
      ric.stage(k).A.setConstant(std::nan(""));
      ric.stage(k).B.setConstant(std::nan(""));
      ric.stage(k).Ex.setConstant(std::nan(""));
      ric.stage(k).Eu.setConstant(std::nan(""));
    }
    ric.hessian(0).R.setConstant(std::nan(""));  // nothing after the sweep reads it
    ric.hessian(0).S.setConstant(std::nan(""));
    ric.forward(dx0);
    for (int k = 0; k < N; ++k) ric.recoverStage(k);
    expectSameSolution(ric, ref, N, "solve, ne " + std::to_string(ne));
    randomVectors(ref, rng);
    for (int k = 0; k <= N; ++k) {
      ric.stage(k).q = ref.stage(k).q;
      ric.stage(k).r = ref.stage(k).r;
      ric.stage(k).b = ref.stage(k).b;
      ric.stage(k).e = ref.stage(k).e;
    }
    ref.resolveVectors(dx0);
    ric.resolveVectors(dx0);
    expectSameSolution(ric, ref, N, "resolveVectors, ne " + std::to_string(ne));
  }
}

// A reduced Hessian that is only semidefinite (an input that neither costs nor moves the
// state) fails the first factorisation; the stage is rebuilt with a small diagonal shift,
// which must give exactly the solution of the problem with that shift added to R. An
// indefinite one is reported at its stage.
TEST(RiccatiProjection, SemidefiniteStageIsShiftedAndIndefiniteIsReported) {
  std::mt19937 rng(17u);
  const int nx = 5, nu = 4, N = 6, ks = 3;
  solver::RiccatiSolver ric(N, nx, nu, 1), ref(N, nx, nu, 1);
  fillRandomStages(
      ric, [](int) { return 0; }, rng);
  randomVectors(ric, rng);
  auto& s = ric.stage(ks);
  s.R.row(0).setZero();
  s.R.col(0).setZero();
  s.S.row(0).setZero();
  s.B.col(0).setZero();
  s.r(0) = 0.0;
  const VectorXd dx0 = randn(nx, 1, rng);
  ASSERT_TRUE(ric.solve(dx0));
  const double reg = ric.regularization();
  EXPECT_GT(reg, 0.0);
  EXPECT_LT(reg, 1e-10);
  for (int k = 0; k <= N; ++k) ref.stage(k) = ric.stage(k);
  ref.stage(ks).R.diagonal().array() += reg;
  ASSERT_TRUE(ref.solve(dx0));
  EXPECT_EQ(ref.regularization(), 0.0);
  for (int k = 0; k <= N; ++k) {
    EXPECT_LT((ric.dx(k) - ref.dx(k)).norm(), 1e-12 * (1.0 + ref.dx(k).norm())) << "k " << k;
    EXPECT_LT((ric.costate(k) - ref.costate(k)).norm(), 1e-12 * (1.0 + ref.costate(k).norm()));
    if (k < N) {
      EXPECT_LT((ric.du(k) - ref.du(k)).norm(), 1e-12 * (1.0 + ref.du(k).norm()));
    }
  }
  s.R.diagonal().array() -= 10.0;
  EXPECT_FALSE(ric.solve(dx0));
  EXPECT_EQ(ric.failedStage(), ks);
}
