#pragma once
// Register-blocked products for the Riccati recursion's 15..55-wide blocks (internal to
// the solver layer). Eigen's general product packs both operands into panels on every
// call, which at these sizes costs as much as the arithmetic; these kernels read the
// operands in place instead, in tiles of up to 3 packets of rows by 4 columns whose
// accumulators stay in registers for the whole depth (Eigen's packet types: AVX-512, AVX2
// with FMA, SSE2, or scalars, whatever the target has), and store each tile once.
//
// Every product is written C = A B with A column-major (read down its columns, one packet
// of rows at a time) and B read entry by entry (broadcast) at any strides: B(k, c) =
// B[k bk + c bj], so bk = 1, bj = ldb is B column-major and bk = ldb, bj = 1 is B stored
// transposed. A remainder of rows shorter than a packet is done by one packet that ends
// at the last row and overlaps rows already done with the same values (so no scalar
// remainder loop runs); C must therefore not alias any operand.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <type_traits>

namespace rollstep::solver::kernels {

using Index = Eigen::Index;

/// One product term A B (A: rows x K column-major; B(k, c) = B[k bk + c bj]).
struct Term {
  int K = 0;
  const double* A = nullptr;
  Index lda = 0;
  const double* B = nullptr;
  Index bk = 0, bj = 0;
};

/// How a tile's sum s of the terms reaches C: C = s, C = -s, C = Cin + s, C = Cin - s,
/// or C += s in place (Accumulate: an overlapping tile leaves the rows it overlaps as
/// they are, by zeroing those lanes of s).
enum class Store { Set, Negate, Add, Subtract, Accumulate };

namespace detail {

namespace ei = Eigen::internal;
// The target's widest packets: on an AVX-512 Xeon (2026-12-07) the 8-wide tiles were no
// slower than the 4-wide AVX ones and up to 10 % faster in the Riccati and projection
// benchmarks (bench_solver, a loaded machine), with the same results.
using Packet = ei::packet_traits<double>::type;
constexpr int kP = ei::packet_traits<double>::size;
// Tiles of up to 3 packets of rows by 4 columns: 12 accumulators, 3 loaded packets and a
// broadcast fill the 16 vector registers of AVX2. Without fused multiply-add each update
// needs a temporary register, so tiles stop at 2 packets.
#ifdef EIGEN_VECTORIZE_FMA
constexpr int kMaxMP = 3;
#else
constexpr int kMaxMP = 2;
#endif

/// Keeps a loaded packet in a register: without this, GCC folds the loads of A into the
/// multiply-adds (one load per use instead of one per packet), and the tile becomes bound
/// by loads instead of arithmetic (about 1.8 times slower on AVX2). An empty asm
/// statement that claims to modify the register; a no-op elsewhere.
EIGEN_ALWAYS_INLINE void inRegister(Packet& p) {
#if defined(EIGEN_VECTORIZE) && (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
#ifdef __AVX512F__
  __asm__("" : "+v"(p));
#else
  __asm__("" : "+x"(p));
#endif
#else
  (void)p;
#endif
}

template <int MP, int NR>
EIGEN_ALWAYS_INLINE void accumulate(Packet (&acc)[MP][NR], const Term& t, Index r, Index c0) {
  const double* A = t.A + r;
  const double* B = t.B + c0 * t.bj;
  for (int k = 0; k < t.K; ++k) {
    const double* a = A + k * t.lda;
    const double* b = B + k * t.bk;
    Packet av[MP];
    for (int m = 0; m < MP; ++m) {
      av[m] = ei::ploadu<Packet>(a + m * kP);
      inRegister(av[m]);
    }
    for (int c = 0; c < NR; ++c) {
      const Packet bv = ei::pset1<Packet>(b[c * t.bj]);
      for (int m = 0; m < MP; ++m) acc[m][c] = ei::pmadd(av[m], bv, acc[m][c]);
    }
  }
}

// Lanes [0, 8) zero, [8, 16) one: ploadu(kMask + 8 - skip) zeroes the first `skip` lanes.
alignas(64) constexpr double kMask[16] = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1};
static_assert(kP <= 8, "kMask covers packets of up to 8 doubles");

/// Rows [r, r + MP kP) x columns [c0, c0 + NR) of C from the terms t1 (and t2); with
/// Accumulate, the first `skip` rows are left as they are.
template <int MP, int NR, Store S>
EIGEN_ALWAYS_INLINE void tile(const Term& t1, const Term& t2, Index r, Index c0, const double* Cin,
                              Index ldi, double* C, Index ldc, int skip = 0) {
  Packet acc[MP][NR];
  for (int m = 0; m < MP; ++m) {
    for (int c = 0; c < NR; ++c) acc[m][c] = ei::pset1<Packet>(0.0);
  }
  accumulate<MP, NR>(acc, t1, r, c0);
  if (t2.K > 0) accumulate<MP, NR>(acc, t2, r, c0);
  if (S == Store::Accumulate && skip > 0) {
    const Packet mask = ei::ploadu<Packet>(kMask + 8 - skip);
    for (int c = 0; c < NR; ++c) acc[0][c] = ei::pmul(acc[0][c], mask);
  }
  for (int c = 0; c < NR; ++c) {
    double* out = C + r + (c0 + c) * ldc;
    for (int m = 0; m < MP; ++m) {
      Packet v = acc[m][c];
      if constexpr (S == Store::Negate) v = ei::pnegate(v);
      if constexpr (S == Store::Accumulate) v = ei::padd(ei::ploadu<Packet>(out + m * kP), v);
      if constexpr (S == Store::Add || S == Store::Subtract) {
        const Packet in = ei::ploadu<Packet>(Cin + r + (c0 + c) * ldi + m * kP);
        v = S == Store::Add ? ei::padd(in, v) : ei::psub(in, v);
      }
      ei::pstoreu(out + m * kP, v);
    }
  }
}

/// Rows [i0, m) of columns [c0, c0 + NR): tiles of kMaxMP packets, then the rest by one
/// tile of as many packets as it needs, ending at row m (it overlaps rows already done, or
/// rows above i0, with the same values). A short tile at the end would be bound by the
/// latency of its few accumulators. Needs m >= kP.
template <int NR, Store S>
void columnTile(int i0, int m, Index c0, const Term& t1, const Term& t2, const double* Cin,
                Index ldi, double* C, Index ldc) {
  int i = i0;
  for (; i + kMaxMP * kP <= m; i += kMaxMP * kP) {
    tile<kMaxMP, NR, S>(t1, t2, i, c0, Cin, ldi, C, ldc);
  }
  if (i == m) return;
  const int mp = (m - i + kP - 1) / kP;
  const int start = m - mp * kP;
  if (mp == 1) {
    tile<1, NR, S>(t1, t2, start, c0, Cin, ldi, C, ldc, i - start);
  } else if (start < 0) {  // a column shorter than mp packets: single packets
    for (; i + kP <= m; i += kP) tile<1, NR, S>(t1, t2, i, c0, Cin, ldi, C, ldc);
    if (i < m) tile<1, NR, S>(t1, t2, m - kP, c0, Cin, ldi, C, ldc, i - (m - kP));
  } else if (mp == 2) {
    tile<2, NR, S>(t1, t2, start, c0, Cin, ldi, C, ldc, i - start);
  } else if constexpr (kMaxMP == 3) {
    tile<3, NR, S>(t1, t2, start, c0, Cin, ldi, C, ldc, i - start);
  }
}

/// Columns [c0, c1) of C (rows [0, m), or [column, m) with `lower`), at most 4 at a time.
template <Store S>
void columns(int m, int c0, int c1, bool lower, const Term& t1, const Term& t2, const double* Cin,
             Index ldi, double* C, Index ldc) {
  if (m < kP) {  // too short for one packet: plain loops
    for (int j = c0; j < c1; ++j) {
      for (int i = lower ? j : 0; i < m; ++i) {
        double s = 0.0;
        for (const Term* t : {&t1, &t2}) {
          for (int k = 0; k < t->K; ++k) s += t->A[i + k * t->lda] * t->B[k * t->bk + j * t->bj];
        }
        double& out = C[i + j * ldc];
        if constexpr (S == Store::Set) out = s;
        if constexpr (S == Store::Negate) out = -s;
        if constexpr (S == Store::Add) out = Cin[i + j * ldi] + s;
        if constexpr (S == Store::Subtract) out = Cin[i + j * ldi] - s;
        if constexpr (S == Store::Accumulate) out += s;
      }
    }
    return;
  }
  for (int j = c0; j < c1; j += 4) {
    const int i0 = lower ? j : 0;
    switch (c1 - j) {
      case 1:
        columnTile<1, S>(i0, m, j, t1, t2, Cin, ldi, C, ldc);
        break;
      case 2:
        columnTile<2, S>(i0, m, j, t1, t2, Cin, ldi, C, ldc);
        break;
      case 3:
        columnTile<3, S>(i0, m, j, t1, t2, Cin, ldi, C, ldc);
        break;
      default:
        columnTile<4, S>(i0, m, j, t1, t2, Cin, ldi, C, ldc);
        break;
    }
  }
}

}  // namespace detail

/// C = A B (m x n; A m x K as in Term), or C = -A B with `negate`.
inline void gemm(int m, int n, int K, const double* A, Index lda, const double* B, Index bk,
                 Index bj, double* C, Index ldc, bool negate = false) {
  if (m <= 0 || n <= 0) return;
  const Term t{K, A, lda, B, bk, bj};
  if (negate) {
    detail::columns<Store::Negate>(m, 0, n, false, t, Term{}, nullptr, 0, C, ldc);
  } else {
    detail::columns<Store::Set>(m, 0, n, false, t, Term{}, nullptr, 0, C, ldc);
  }
}

/// lower(C) = lower(Cin + A B) for n x n C and Cin (A n x K). Entries of C above the
/// diagonal within the diagonal tiles (and up to a packet above them) are overwritten with
/// unspecified values.
inline void gemmtLower(int n, int K, const double* A, Index lda, const double* B, Index bk,
                       Index bj, const double* Cin, Index ldi, double* C, Index ldc) {
  if (n <= 0) return;
  const Term t{K, A, lda, B, bk, bj};
  detail::columns<Store::Add>(n, 0, n, true, t, Term{}, Cin, ldi, C, ldc);
}

/// C += A B in place (m x n; A m x K as in Term).
inline void gemmAccumulate(int m, int n, int K, const double* A, Index lda, const double* B,
                           Index bk, Index bj, double* C, Index ldc) {
  if (m <= 0 || n <= 0 || K <= 0) return;
  const Term t{K, A, lda, B, bk, bj};
  detail::columns<Store::Accumulate>(m, 0, n, false, t, Term{}, nullptr, 0, C, ldc);
}

/// lower(C) += lower(A B) in place for n x n C (A n x K). Entries above the diagonal
/// within C's diagonal 4 x 4 blocks receive their part of A B too; none further above.
inline void gemmtLowerAccumulate(int n, int K, const double* A, Index lda, const double* B,
                                 Index bk, Index bj, double* C, Index ldc) {
  if (n <= 0 || K <= 0) return;
  const Term t{K, A, lda, B, bk, bj};
  detail::columns<Store::Accumulate>(n, 0, n, true, t, Term{}, nullptr, 0, C, ldc);
}

/// lower(H) += lower(V W^T + W V^T) in place for n x n H (V, W: n x K column-major), as
/// gemmtLowerAccumulate (the two products in the same accumulators).
inline void syr2kLowerAccumulate(int n, int K, const double* V, Index ldv, const double* W,
                                 Index ldw, double* H, Index ldh) {
  if (n <= 0 || K <= 0) return;
  const Term t1{K, V, ldv, W, ldw, 1}, t2{K, W, ldw, V, ldv, 1};
  detail::columns<Store::Accumulate>(n, 0, n, true, t1, t2, nullptr, 0, H, ldh);
}

/// The backward Riccati step's factorisation, fused with the product that forms its
/// matrix. With G = A Y^T (A: n x K, Y: n x K, both column-major; the caller passes
/// Yneg = -Y), the lower triangle of the n x n matrix
///   M = H + G + shift [I_nw 0; 0 0] = [Mww .; Mxw Mxx]
/// becomes [L .; Lxw P] with L L^T = Mww, Lxw = Mxw L^-T and P = Mxx - Lxw Lxw^T (the
/// Schur complement: the next cost-to-go Hessian). Left-looking in panels of 4 columns:
/// each panel takes H - (A Yneg^T + L L^T) of its columns in one register-blocked pass
/// (the product and the update by the columns of L before it, in the same accumulators),
/// then factorises its own columns. Only the lower triangle of H is read where it matters
/// (the strict upper triangle of H is read into junk entries of M above its diagonal,
/// which are overwritten with unspecified values). M must not alias H, A or Yneg. False
/// when a pivot is not positive and finite (M is then partly overwritten).
inline bool factorSchur(int n, int nw, int K, const double* A, Index lda, const double* Yneg,
                        Index ldy, const double* H, Index ldh, double* M, Index ldm,
                        double shift = 0.0) {
  for (int j = 0; j < n; j += 4) {
    const int j1 = std::min(j + 4, n);
    const Term t1{K, A, lda, Yneg, ldy, 1};
    const Term t2{std::min(j, nw), M, ldm, M, ldm, 1};
    detail::columns<Store::Subtract>(n, j, j1, true, t1, t2, H, ldh, M, ldm);
    // The panel's own columns: factorise those of the input block, and update the later
    // columns of the panel by them.
    for (int c = j; c < std::min(j1, nw); ++c) {
      double* mc = M + c * ldm;
      const double d = mc[c] + shift;
      if (!(d > 0.0) || !std::isfinite(d)) return false;
      const double l = std::sqrt(d);
      mc[c] = l;
      const double inv = 1.0 / l;
      for (int r = c + 1; r < n; ++r) mc[r] *= inv;
      for (int c2 = c + 1; c2 < j1; ++c2) {
        double* m2 = M + c2 * ldm;
        const double f = mc[c2];
        for (int r = c2; r < n; ++r) m2[r] -= f * mc[r];
      }
    }
  }
  return true;
}

}  // namespace rollstep::solver::kernels
