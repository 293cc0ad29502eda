#pragma once
// Riccati recursion for an equality-constrained linear-quadratic problem (the search
// direction of the interior-point solver, usable on its own):
//
//   min  sum_{k<N} 0.5 [dx;du]^T [Q S^T; S R] [dx;du] + q^T dx + r^T du
//        + 0.5 dx_N^T Q_N dx_N + q_N^T dx_N
//   s.t. dx_0 = dx_init,  dx_{k+1} = A_k dx_k + B_k du_k + b_k,
//        Ex_k dx_k + Eu_k du_k + e_k = 0      (ne_k rows, full row rank in du)
//
// Equalities are eliminated by projection (variable reduction): an LU factorisation with
// partial pivoting of Eu^T, P Eu^T = [L1; L2] U, picks ne dependent input entries
// (the pivot rows) du_D = T [w; dx; 1], T = -L1^-T [L2^T | U^-T [Ex e]], and leaves the
// nu - ne independent entries w = du_I, on which the Riccati recursion runs. The
// null-space basis is Z = P^T [-L1^-T L2^T; I]: cheaper than an orthonormal basis (no
// dense nu x nu products), and well conditioned because the pivoting keeps every entry
// of L bounded by 1. A pivot below rank_tolerance times the largest |Eu| entry means the
// rows are rank deficient (after the elimination of the earlier rows, the row has
// nothing left in u).
// Rows that fix one input (Ex row zero, one non-zero entry in the Eu row: du_c = -e / Eu_c,
// such as a swing foot's zero force) are eliminated first by substitution: their inputs
// take no part in the LU, T, or the reduced Hessian, whose vectors r, q, b, e absorb the
// fixed values. A second row fixing the same input stays in the LU, which reports the rank
// deficiency.
// Multipliers: costates lambda_k (lambda_k = P_k dx_k + p_k, the multiplier of the
// dynamics constraint that defines dx_k) and nu_k of the equalities, with the
// Lagrangian sum cost + lambda_{k+1}^T (A dx + B du + b - dx_{k+1}) + nu^T (e + Ex dx + Eu du).
//
// Memory: everything is sized by the constructor; projectStage, backward, forward and
// recoverStage never allocate. projectStage(k) and recoverStage(k) touch stage k only,
// so callers may run them for different k on different threads.
#include <Eigen/Core>
#include <vector>

namespace rollstep::solver {

/// Data of one stage (sized at the maximum dimensions; rows [0, ne) of the equality
/// block are used). Only the LOWER triangles of Q and R are read (the upper ones may hold
/// anything). The terminal stage (k = N) uses Q and q only.
struct LqStage {
  int ne = 0;
  Eigen::MatrixXd Q, S, R;  ///< nx x nx, nu x nx, nu x nu
  Eigen::VectorXd q, r;     ///< nx, nu
  Eigen::MatrixXd A, B;     ///< nx x nx, nx x nu
  Eigen::VectorXd b;        ///< nx
  Eigen::MatrixXd Ex, Eu;   ///< ne_max x nx, ne_max x nu
  Eigen::VectorXd e;        ///< ne_max
};

class RiccatiSolver {
 public:
  RiccatiSolver(int horizon, int nx, int nu, int ne_max);

  int horizon() const { return N_; }
  int nx() const { return nx_; }
  int nu() const { return nu_; }
  int maxEqualities() const { return ne_max_; }

  LqStage& stage(int k) { return stages_[static_cast<std::size_t>(k)]; }
  const LqStage& stage(int k) const { return stages_[static_cast<std::size_t>(k)]; }

  /// Projects the equalities of running stage k (k < N) and builds its reduced stage.
  /// Returns false when Eu_k is rank deficient: a pivot of the QR below
  /// rank_tolerance * (largest pivot), or ne > nu. `pivot_ratio` (optional) receives the
  /// smallest relative pivot.
  bool projectStage(int k, double rank_tolerance, double* pivot_ratio = nullptr);
  /// Backward Riccati sweep over the projected stages (call projectStage for every
  /// k < N first). Returns false when a reduced Hessian of the input is not positive
  /// definite even after regularisation (failedStage() says where).
  bool backward();
  /// Forward sweep: dx, w, the costates lambda. Call after backward().
  void forward(const Eigen::Ref<const Eigen::VectorXd>& dx0);
  /// The sweeps one stage at a time, for callers that interleave their own per-node work
  /// (data still in cache): backward() is beginBackward() then backwardStage(k) for
  /// k = N-1 .. 0 (false: failedStage() == k); forward(dx0) is beginForward(dx0) then
  /// forwardStage(k) for k = 0 .. N-1. backwardStage(k) needs projectStage(k) and
  /// backwardStage(k + 1); forwardStage(k) gives w_k, dx_{k+1} and lambda_{k+1}, so
  /// recoverStage(k) may follow it at once.
  void beginBackward();
  bool backwardStage(int k);
  void beginForward(const Eigen::Ref<const Eigen::VectorXd>& dx0);
  void forwardStage(int k);
  /// du_k and the equality multipliers nu_k (needs forward()).
  void recoverStage(int k);
  /// On: every stage's reduced Hessian goes to one buffer, for a caller that runs
  /// backwardStage(k) right after projectStage(k) for k = N-1 .. 0 (as the Solver does
  /// with one thread): it stays in cache, where one per stage ((nu + nx + 1)^2, 24 kB for
  /// the Tachyon 3 OCP) is written and read cold. Then backward() and solve(), which
  /// project every stage first, throw std::logic_error, and the stages' own buffers are
  /// released (allocated again by turning it off). Off by default.
  void shareReducedHessian(bool on);
  /// The Hessian blocks of a stage, as the caller writes them: the stage's own Q, R, S,
  /// or with shareStageHessians one set for every stage.
  struct StageHessian {
    Eigen::MatrixXd& Q;
    Eigen::MatrixXd& R;
    Eigen::MatrixXd& S;
  };
  StageHessian hessian(int k);
  /// On: every stage's Q, R, S are one set (hessian(k); the stages' own are not read), for
  /// a caller that writes stage k's right before projectStage(k) (k = N: before
  /// beginBackward) and runs backwardStage(k) right after, as the Solver does with one
  /// thread: 17.6 kB per stage of the Tachyon 3 OCP that an iteration wrote and read cold.
  /// projectStage keeps what the later passes need (R's columns and S's rows of the fixed
  /// inputs). Then backward() and solve() throw std::logic_error, and the stages' own
  /// Q, R, S are released (empty; allocated again, zero, by turning it off). Off by
  /// default.
  void shareStageHessians(bool on);
  /// Convenience: projectStage for every k, backward, forward, recoverStage for every k.
  bool solve(const Eigen::Ref<const Eigen::VectorXd>& dx0, double rank_tolerance = 1e-9);
  /// Re-solves with the same matrices (Q, S, R, A, B, Ex, Eu, ne unchanged since the last
  /// projectStage/backward) and new vectors q, r, b, e of every stage: reuses the
  /// projection and the factorisation, costs O(N (nu + nx)^2) (vector passes only).
  /// For second-order corrections and iterative refinement. Then forward and recover
  /// every stage, as solve() does. Needs a successful backward().
  void resolveVectors(const Eigen::Ref<const Eigen::VectorXd>& dx0);

  // --- results ------------------------------------------------------------------------
  const Eigen::VectorXd& dx(int k) const { return work_[idx(k)].dx; }
  const Eigen::VectorXd& du(int k) const { return work_[idx(k)].du; }
  const Eigen::VectorXd& costate(int k) const { return work_[idx(k)].lam; }
  /// Equality multipliers of stage k (first stage(k).ne entries; the rest are zero).
  const Eigen::VectorXd& equalityMultipliers(int k) const { return work_[idx(k)].mult; }
  /// Full-input feedback du_k = K_k dx_k + kff_k (computes K into `K`, nu x nx).
  void feedbackGain(int k, Eigen::MatrixXd& K) const;
  int failedStage() const { return failed_stage_; }
  /// Largest diagonal regularisation added in the last backward() (0 when none).
  double regularization() const { return regularization_; }

 private:
  struct Work {
    int nw = 0;          // reduced input size nu - ne
    int nf = 0;          // rows that fix one input each (substituted, not in the LU)
    Eigen::VectorXd lu;  // nv x ng (nv = nu - nf), packed: [L1\U; L2] of P Eu^T (unit L1 below U)
    // nu: input permutation [dependent (ne - nf); independent (nw); fixed (nf)]
    Eigen::VectorXi perm;
    Eigen::VectorXi rows;  // ne_max: equality rows [in the LU (ne - nf); fixing (nf)]
    Eigen::VectorXi mark;  // nu: scratch, 1 on fixed inputs
    Eigen::VectorXi col;   // ne_max: scratch, the input a row fixes (-1: none)
    Eigen::VectorXd tf;    // ne_max: the values of the fixed inputs
    // The vectors with the fixed inputs substituted: r + R_F tf (nu), q + S_F^T tf,
    // b + B_F tf (nx), e + Eu_F tf (ne_max, rows in the LU).
    Eigen::VectorXd reff, qeff, beff, eeff;
    // Column f: R's column (nu), S's row (nx), B's column (nx) and Eu's column (ne_max,
    // rows 0 .. ne) of the input the f-th fixing row fixes, kept by projectStage for
    // substituteFixedInputs and recoverStage (after projectStage(k), the stage's Q, R, S,
    // A, B, Ex and Eu are not read again).
    Eigen::MatrixXd RF, SF, BF, EF;
    // V, W and HDD are stored packed (packed()), each column as long as the stage uses:
    // with the stride of the largest sizes a stage wrote parts of twice as many cache
    // lines, cold, and the buffers were 2.5 times as large (Tachyon 3 OCP).
    Eigen::VectorXd V;    // (nz + 1) x ng: T^T, du_D = T [w; dx; 1]
    Eigen::VectorXd W;    // (nz + 1) x ng: (H_Dv + 0.5 H_DD T)^T
    Eigen::VectorXd HDD;  // ng x ng
    Eigen::MatrixXd BD;   // nx x ne_max: dependent columns of B
    Eigen::MatrixXd Hr;   // (nu + nx + 1)^2: reduced augmented Hessian [w; dx; 1] (lower)
    Eigen::VectorXd gr;   // nu + nx: reduced gradient
    Eigen::MatrixXd BA;   // nx x (nu + nx + 1): reduced [B A | b]
    // (nu + nx) x nu: the first nw columns of M = [L 0; Lxw P] after backward (lower):
    // [L; Lxw], all that the forward sweep, resolveVectors and feedbackGain read.
    Eigen::MatrixXd L;
    Eigen::VectorXd hm;  // nu + nx; its head(nw) becomes v = L^-1 h_w
    Eigen::VectorXd pb;  // nx
    Eigen::MatrixXd P;   // nx x nx (both triangles)
    Eigen::VectorXd p;   // nx
    Eigen::VectorXd dx, w, du, lam, mult, t, t1;
    mutable Eigen::MatrixXd Kw, KD;  // feedbackGain scratch
  };
  std::size_t idx(int k) const { return static_cast<std::size_t>(k); }
  using PackedMatrix = Eigen::Map<Eigen::MatrixXd>;
  using ConstPackedMatrix = Eigen::Map<const Eigen::MatrixXd>;
  /// A stage's V or W ((nz + 1) x ng, nz = nw + nx) or HDD (ng x ng): column-major without
  /// gaps.
  static PackedMatrix packed(Eigen::VectorXd& buf, int rows, int cols) {
    return PackedMatrix(buf.data(), rows, cols);
  }
  static ConstPackedMatrix packed(const Eigen::VectorXd& buf, int rows, int cols) {
    return ConstPackedMatrix(buf.data(), rows, cols);
  }
  /// [L1\U] of the LU (ng x ng, the top of the packed nv x ng factor).
  static Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>> luFactor(const Work& w, int nu,
                                                                             int ng) {
    return {w.lu.data(), ng, ng, Eigen::OuterStride<>(nu - w.nf)};
  }
  Eigen::MatrixXd& reducedHessian(Work& w) { return share_hr_ ? Hr_shared_ : w.Hr; }
  /// Finds the rows of stage k that fix one input each (w.nf, w.rows, w.perm: free
  /// inputs in order, then the fixed ones). False when a fixing entry is below
  /// rank_tolerance * scale (then *ratio is its ratio).
  bool findFixedInputs(const LqStage& s, Work& w, double rank_tolerance, double scale,
                       double* ratio) const;
  /// The fixed values w.tf and the substituted vectors w.reff, qeff, beff, eeff from the
  /// stage's current vectors (no-op without fixed inputs).
  void substituteFixedInputs(const LqStage& s, Work& w) const;
  /// w.RF, w.SF, w.BF and w.EF from the stage's Hessian blocks R and S, its B and Eu.
  void keepFixedColumns(const Eigen::MatrixXd& R, const Eigen::MatrixXd& S, const LqStage& s,
                        Work& w) const;

  int N_, nx_, nu_, ne_max_;
  std::vector<LqStage> stages_;
  std::vector<Work> work_;
  // Backward scratch (sequential): [B A b]^T and [B A b]^T P, (nu + nx + 1) x nx.
  Eigen::MatrixXd BAt_, PBAt_;
  // Backward scratch: M of the stage being factorised, (nu + nx)^2 (its Schur block gives
  // P; its first nw columns are kept in Work::L). One, where one per stage (23 kB for the
  // Tachyon 3 OCP) was written cold and mostly never read again.
  Eigen::MatrixXd M_;
  Eigen::MatrixXd Hr_shared_;  // every stage's Hr when share_hr_
  bool share_hr_ = false;
  Eigen::MatrixXd Q_shared_, R_shared_, S_shared_;  // every stage's Q, R, S when share_h_
  bool share_h_ = false;
  int failed_stage_ = -1;
  double regularization_ = 0.0;
};

}  // namespace rollstep::solver
