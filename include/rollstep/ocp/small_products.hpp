#pragma once
// Dense products of small depth for a node's linearisation: C = alpha A B (+ C) with A
// n x k and k small (the 6 rows of a residual or of the SE(3) pose block, the 6 x 6
// Jacobians of integrate and difference). Eigen's general product packs both operands and
// zeroes the destination on every call: at these sizes that set-up costs more than the
// arithmetic (docs/history/PERFORMANCE_HISTORY.md, "third pass: linearisation"). Here each column
// of C is accumulated in registers (Eigen's packets: FMA with AVX2) over chunks of 8 depth entries
// and stored once per chunk; a column whose length is not a multiple of the packet ends with an
// overlapping packet computed first and stored last (no scalar remainder loop when n >= packet
// size). Allocation-free; results equal Eigen's up to rounding.
#include <Eigen/Core>
#include <algorithm>

namespace rollstep::ocp {

namespace small_products_detail {
namespace ei = Eigen::internal;
using Packet = ei::packet_traits<double>::type;
constexpr int kPacket = ei::packet_traits<double>::size;
constexpr int kDepthChunk = 8;

/// C[:, j] = (accumulate ? C[:, j] : 0) + alpha * sum_{l < KC} A[:, l] B(l, j) for every
/// column j < p, with n >= kPacket rows; KC is a compile-time depth so that the
/// broadcasts of B's column stay in registers.
template <int KC>
inline void chunk(double* C, Eigen::Index ldc, int n, int p, const double* A, Eigen::Index lda,
                  const double* B, Eigen::Index ldb, double alpha, bool accumulate) {
  const int full = n - n % kPacket;  // rows [0, full) in whole packets
  const bool tail = full != n;
  for (int j = 0; j < p; ++j) {
    double* c = C + j * ldc;
    const double* b = B + j * ldb;
    Packet bl[KC];
    for (int l = 0; l < KC; ++l) bl[l] = ei::pset1<Packet>(alpha * b[l]);
    const auto sum = [&](int i) {
      Packet s = accumulate ? ei::ploadu<Packet>(c + i) : ei::pset1<Packet>(0.0);
      for (int l = 0; l < KC; ++l) s = ei::pmadd(ei::ploadu<Packet>(A + l * lda + i), bl[l], s);
      return s;
    };
    // The overlapping last packet reads rows the main loop writes: computed first.
    const Packet t = tail ? sum(n - kPacket) : ei::pset1<Packet>(0.0);
    for (int i = 0; i < full; i += kPacket) ei::pstoreu(c + i, sum(i));
    if (tail) ei::pstoreu(c + n - kPacket, t);
  }
}
}  // namespace small_products_detail

/// C = alpha * A * B (accumulate = false) or C += alpha * A * B (accumulate = true), A of
/// size n x k, B k x p, C n x p (column-major, inner stride 1). C must not alias A or B.
/// Meant for small k (each chunk of 8 depth entries loads and stores C once); any n, p.
inline void smallDepthProduct(Eigen::Ref<Eigen::MatrixXd> C,
                              const Eigen::Ref<const Eigen::MatrixXd>& A,
                              const Eigen::Ref<const Eigen::MatrixXd>& B, double alpha,
                              bool accumulate) {
  namespace sp = small_products_detail;
  eigen_assert(A.rows() == C.rows() && A.cols() == B.rows() && B.cols() == C.cols());
  const int n = static_cast<int>(C.rows()), k = static_cast<int>(A.cols());
  if (k == 0) {
    if (!accumulate) C.setZero();
    return;
  }
  const int p = static_cast<int>(C.cols());
  if (n < sp::kPacket) {
    for (int j = 0; j < p; ++j) {
      for (int i = 0; i < n; ++i) {
        double s = 0.0;
        for (int l = 0; l < k; ++l) s += A(i, l) * B(l, j);
        C(i, j) = (accumulate ? C(i, j) : 0.0) + alpha * s;
      }
    }
    return;
  }
  for (int l0 = 0; l0 < k; l0 += sp::kDepthChunk) {
    const bool acc = accumulate || l0 > 0;
    const double* a = A.data() + l0 * A.outerStride();
    const double* b = B.data() + l0;
    const auto lda = A.outerStride(), ldb = B.outerStride(), ldc = C.outerStride();
    switch (std::min(sp::kDepthChunk, k - l0)) {
      case 1:
        sp::chunk<1>(C.data(), ldc, n, p, a, lda, b, ldb, alpha, acc);
        break;
      case 2:
        sp::chunk<2>(C.data(), ldc, n, p, a, lda, b, ldb, alpha, acc);
        break;
      case 3:
        sp::chunk<3>(C.data(), ldc, n, p, a, lda, b, ldb, alpha, acc);
        break;
      case 4:
        sp::chunk<4>(C.data(), ldc, n, p, a, lda, b, ldb, alpha, acc);
        break;
      case 5:
        sp::chunk<5>(C.data(), ldc, n, p, a, lda, b, ldb, alpha, acc);
        break;
      case 6:
        sp::chunk<6>(C.data(), ldc, n, p, a, lda, b, ldb, alpha, acc);
        break;
      case 7:
        sp::chunk<7>(C.data(), ldc, n, p, a, lda, b, ldb, alpha, acc);
        break;
      default:
        sp::chunk<8>(C.data(), ldc, n, p, a, lda, b, ldb, alpha, acc);
        break;
    }
  }
}

}  // namespace rollstep::ocp
