// The Riccati recursion's register-blocked kernels (src/solver/riccati_kernels.hpp)
// against the plain Eigen expressions, on random sizes 1..60 (most of them not multiples
// of the packet width), with padded leading dimensions and operands that start off a
// packet boundary.
#include "riccati_kernels.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace {

using Eigen::MatrixXd;
using rollstep::solver::kernels::factorSchur;
using rollstep::solver::kernels::gemm;
using rollstep::solver::kernels::gemmAccumulate;
using rollstep::solver::kernels::gemmtLower;
using rollstep::solver::kernels::gemmtLowerAccumulate;
using rollstep::solver::kernels::syr2kLowerAccumulate;
using Strided = Eigen::Map<MatrixXd, Eigen::Unaligned, Eigen::OuterStride<>>;

constexpr double kSentinel = 12345.678;

/// A rows x cols matrix inside a buffer with leading dimension rows + pad, starting
/// `offset` doubles into it (so packets of it may straddle alignment boundaries); the rest
/// of the buffer holds a sentinel, so that writes outside the matrix are caught.
struct Buffer {
  std::vector<double> data;
  int rows, cols, ld, offset;
  Buffer(int r, int c, int pad, int off)
      : data(static_cast<std::size_t>(off + (r + pad) * c), kSentinel),
        rows(r),
        cols(c),
        ld(r + pad),
        offset(off) {}
  double* ptr() { return data.data() + offset; }
  Strided map() { return Strided(ptr(), rows, cols, Eigen::OuterStride<>(ld)); }
  /// True when every entry outside the matrix still holds the sentinel.
  bool untouchedOutside() const {
    for (int i = 0; i < static_cast<int>(data.size()); ++i) {
      const int j = i - offset;
      const bool inside = j >= 0 && j < ld * cols && j % ld < rows;
      if (!inside && data[static_cast<std::size_t>(i)] != kSentinel) return false;
    }
    return true;
  }
};

MatrixXd random(int r, int c, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  MatrixXd m(r, c);
  for (int j = 0; j < c; ++j) {
    for (int i = 0; i < r; ++i) m(i, j) = n(rng);
  }
  return m;
}

double relativeError(const MatrixXd& got, const MatrixXd& want) {
  return (got - want).norm() / std::max(1.0, want.norm());
}

int uniform(std::mt19937& rng, int lo, int hi) {
  return std::uniform_int_distribution<int>(lo, hi)(rng);
}

TEST(RiccatiKernels, GemmEqualsEigenProduct) {
  std::mt19937 rng(7u);
  for (int trial = 0; trial < 300; ++trial) {
    const int m = uniform(rng, 1, 60), n = uniform(rng, 1, 60), K = uniform(rng, 1, 60);
    const bool transposed_b = trial % 2 == 1, negate = trial % 3 == 0;
    Buffer a(m, K, uniform(rng, 0, 3), uniform(rng, 0, 3));
    Buffer b(transposed_b ? n : K, transposed_b ? K : n, uniform(rng, 0, 3), uniform(rng, 0, 3));
    Buffer c(m, n, uniform(rng, 0, 3), uniform(rng, 0, 3));
    a.map() = random(m, K, rng);
    b.map() = random(b.rows, b.cols, rng);
    const MatrixXd B = transposed_b ? MatrixXd(b.map().transpose()) : MatrixXd(b.map());
    gemm(m, n, K, a.ptr(), a.ld, b.ptr(), transposed_b ? b.ld : 1, transposed_b ? 1 : b.ld, c.ptr(),
         c.ld, negate);
    const MatrixXd want = (negate ? -1.0 : 1.0) * (MatrixXd(a.map()) * B);
    EXPECT_LT(relativeError(c.map(), want), 1e-12) << m << " x " << n << " x " << K;
    EXPECT_TRUE(c.untouchedOutside()) << m << " x " << n << " x " << K;
  }
}

TEST(RiccatiKernels, GemmtLowerEqualsEigenProductOnTheLowerTriangle) {
  std::mt19937 rng(11u);
  for (int trial = 0; trial < 300; ++trial) {
    const int n = uniform(rng, 1, 60), K = uniform(rng, 1, 60);
    Buffer a(n, K, uniform(rng, 0, 3), uniform(rng, 0, 3));
    Buffer bt(n, K, uniform(rng, 0, 3), uniform(rng, 0, 3));  // B stored transposed
    Buffer h(n, n, uniform(rng, 0, 3), uniform(rng, 0, 3));
    Buffer c(n, n, uniform(rng, 0, 3), uniform(rng, 0, 3));
    a.map() = random(n, K, rng);
    bt.map() = random(n, K, rng);
    h.map() = random(n, n, rng);
    gemmtLower(n, K, a.ptr(), a.ld, bt.ptr(), bt.ld, 1, h.ptr(), h.ld, c.ptr(), c.ld);
    const MatrixXd want = MatrixXd(h.map()) + MatrixXd(a.map()) * MatrixXd(bt.map()).transpose();
    MatrixXd got = c.map();
    got.triangularView<Eigen::StrictlyUpper>() = want.triangularView<Eigen::StrictlyUpper>();
    EXPECT_LT(relativeError(got, want), 1e-12) << n << " x " << K;
    EXPECT_TRUE(c.untouchedOutside()) << n << " x " << K;
  }
}

/// The in-place forms (the condensing's weighted products): C += A B, with B's rows read
/// in place (bk = 1) as the condensing does; lower(C) += lower(A B), and nothing above
/// C's diagonal 4 x 4 blocks changes.
TEST(RiccatiKernels, AccumulatingProductsEqualEigen) {
  std::mt19937 rng(19u);
  for (int trial = 0; trial < 300; ++trial) {
    const int m = uniform(rng, 1, 60), n = uniform(rng, 1, 60), K = uniform(rng, 1, 60);
    Buffer a(m, K, uniform(rng, 0, 3), uniform(rng, 0, 3));
    Buffer b(K, n, uniform(rng, 0, 3), uniform(rng, 0, 3));
    Buffer c(m, n, uniform(rng, 0, 3), uniform(rng, 0, 3));
    a.map() = random(m, K, rng);
    b.map() = random(K, n, rng);
    const MatrixXd C0 = random(m, n, rng);
    c.map() = C0;
    gemmAccumulate(m, n, K, a.ptr(), a.ld, b.ptr(), 1, b.ld, c.ptr(), c.ld);
    const MatrixXd want = C0 + MatrixXd(a.map()) * MatrixXd(b.map());
    EXPECT_LT(relativeError(c.map(), want), 1e-12) << m << " x " << n << " x " << K;
    EXPECT_TRUE(c.untouchedOutside());

    Buffer at(n, K, uniform(rng, 0, 3), uniform(rng, 0, 3));
    Buffer bt(K, n, uniform(rng, 0, 3), uniform(rng, 0, 3));
    Buffer s(n, n, uniform(rng, 0, 3), uniform(rng, 0, 3));
    at.map() = random(n, K, rng);
    bt.map() = random(K, n, rng);
    const MatrixXd S0 = random(n, n, rng);
    s.map() = S0;
    gemmtLowerAccumulate(n, K, at.ptr(), at.ld, bt.ptr(), 1, bt.ld, s.ptr(), s.ld);
    const MatrixXd full = S0 + MatrixXd(at.map()) * MatrixXd(bt.map());
    MatrixXd got = s.map();
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < j; ++i) {
        if (i < j / 4 * 4) {
          EXPECT_EQ(got(i, j), S0(i, j)) << "above the diagonal block: " << i << ", " << j;
        }
        got(i, j) = full(i, j);
      }
    }
    EXPECT_LT(relativeError(got, full), 1e-12) << n << " x " << K;
    EXPECT_TRUE(s.untouchedOutside());
  }
}

/// The projection's lower(H) += V W^T + W V^T.
TEST(RiccatiKernels, SymmetricRank2kEqualsEigenOnTheLowerTriangle) {
  std::mt19937 rng(23u);
  for (int trial = 0; trial < 300; ++trial) {
    const int n = uniform(rng, 1, 60), K = uniform(rng, 1, 20);
    Buffer v(n, K, uniform(rng, 0, 3), uniform(rng, 0, 3));
    Buffer w(n, K, uniform(rng, 0, 3), uniform(rng, 0, 3));
    Buffer h(n, n, uniform(rng, 0, 3), uniform(rng, 0, 3));
    v.map() = random(n, K, rng);
    w.map() = random(n, K, rng);
    const MatrixXd H0 = random(n, n, rng);
    h.map() = H0;
    syr2kLowerAccumulate(n, K, v.ptr(), v.ld, w.ptr(), w.ld, h.ptr(), h.ld);
    const MatrixXd V = v.map(), W = w.map();
    const MatrixXd want = H0 + V * W.transpose() + W * V.transpose();
    MatrixXd got = h.map();
    got.triangularView<Eigen::StrictlyUpper>() = want.triangularView<Eigen::StrictlyUpper>();
    EXPECT_LT(relativeError(got, want), 1e-12) << n << " x " << K;
    EXPECT_TRUE(h.untouchedOutside());
  }
}

/// factorSchur against LLT of the input block, a triangular solve and the Schur
/// complement, with H's strict upper triangle poisoned (only its lower one may matter).
TEST(RiccatiKernels, FactorSchurEqualsCholeskyAndSchurComplement) {
  std::mt19937 rng(13u);
  for (int trial = 0; trial < 300; ++trial) {
    const int n = uniform(rng, 1, 60), nw = uniform(rng, 0, n), K = uniform(rng, 1, 40);
    const double shift = trial % 4 == 0 ? 0.5 : 0.0;
    Buffer a(n, K, uniform(rng, 0, 3), uniform(rng, 0, 3));
    Buffer yneg(n, K, uniform(rng, 0, 3), uniform(rng, 0, 3));
    Buffer h(n, n, uniform(rng, 0, 3), uniform(rng, 0, 3));
    Buffer m(n, n, uniform(rng, 0, 3), uniform(rng, 0, 3));
    const MatrixXd L = random(K, K, rng);
    const MatrixXd P = L * L.transpose() / K;  // the next stage's cost-to-go Hessian
    const MatrixXd Hl = random(n, n, rng);
    const MatrixXd H = Hl * Hl.transpose() / n + MatrixXd::Identity(n, n);
    a.map() = random(n, K, rng);
    yneg.map() = -MatrixXd(a.map()) * P;
    h.map() = H;
    h.map().triangularView<Eigen::StrictlyUpper>().setConstant(
        std::numeric_limits<double>::quiet_NaN());
    ASSERT_TRUE(factorSchur(n, nw, K, a.ptr(), a.ld, yneg.ptr(), yneg.ld, h.ptr(), h.ld, m.ptr(),
                            m.ld, shift));
    MatrixXd Mf = H + MatrixXd(a.map()) * P * MatrixXd(a.map()).transpose();
    Mf.diagonal().head(nw).array() += shift;
    const int nx = n - nw;
    const Eigen::LLT<MatrixXd> llt(Mf.topLeftCorner(nw, nw));
    const MatrixXd Lw = llt.matrixL();
    // (Eigen's triangular solve binds a reference to the data of an empty right-hand side:
    // undefined behaviour for UBSan, so the empty cases are written out.)
    const MatrixXd Lxw = nw > 0 && nx > 0
                             ? MatrixXd(Lw.triangularView<Eigen::Lower>()
                                            .solve(Mf.bottomLeftCorner(nx, nw).transpose())
                                            .transpose())
                             : MatrixXd::Zero(nx, nw);
    const MatrixXd Pn = Mf.bottomRightCorner(nx, nx) - Lxw * Lxw.transpose();
    const MatrixXd got = m.map();
    const MatrixXd gotL = got.topLeftCorner(nw, nw).triangularView<Eigen::Lower>();
    const MatrixXd gotP = got.bottomRightCorner(nx, nx).triangularView<Eigen::Lower>();
    const MatrixXd wantP = Pn.triangularView<Eigen::Lower>();
    EXPECT_LT(relativeError(gotL, Lw), 1e-12) << n << ", " << nw << ", " << K;
    EXPECT_LT(relativeError(got.bottomLeftCorner(nx, nw), Lxw), 1e-12) << n << ", " << nw;
    EXPECT_LT(relativeError(gotP, wantP), 1e-12) << n << ", " << nw << ", " << K;
    EXPECT_TRUE(got.triangularView<Eigen::Lower>().toDenseMatrix().allFinite());
    EXPECT_TRUE(m.untouchedOutside()) << n << ", " << nw << ", " << K;
  }
}

TEST(RiccatiKernels, FactorSchurReportsANonPositivePivot) {
  std::mt19937 rng(17u);
  for (const int n : {1, 3, 9, 30}) {
    const int nw = n, K = 5;
    Buffer a(n, K, 1, 1), yneg(n, K, 0, 0), h(n, n, 2, 3), m(n, n, 1, 0);
    a.map() = random(n, K, rng);
    yneg.map().setZero();  // P = 0
    // H = I except one negative diagonal entry in the middle: that pivot fails.
    h.map().setIdentity();
    h.map()(n / 2, n / 2) = -1.0;
    EXPECT_FALSE(
        factorSchur(n, nw, K, a.ptr(), a.ld, yneg.ptr(), yneg.ld, h.ptr(), h.ld, m.ptr(), m.ld));
    // The shift makes it positive again.
    EXPECT_TRUE(factorSchur(n, nw, K, a.ptr(), a.ld, yneg.ptr(), yneg.ld, h.ptr(), h.ld, m.ptr(),
                            m.ld, 2.0));
    EXPECT_NEAR(m.map()(n / 2, n / 2), 1.0, 1e-15);
  }
}

}  // namespace
