#include "ipopt_reference.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <stdexcept>
#include <utility>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wold-style-cast"
#pragma GCC diagnostic ignored "-Wnon-virtual-dtor"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Woverloaded-virtual"
#pragma GCC diagnostic ignored "-Wpedantic"
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <coin/IpIpoptApplication.hpp>
#include <coin/IpSolveStatistics.hpp>
#include <coin/IpTNLP.hpp>
#pragma GCC diagnostic pop

#include "nonlinear_problems.hpp"

namespace rollstep::nltest {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using Ipopt::Index;
using Ipopt::Number;

namespace {

constexpr double kIpoptInf = 1e20;

/// Everything evaluated on one node's window of variables.
struct NodeWork {
  std::unique_ptr<ocp::NodeData> d;
  VectorXd xk, xk1, defect;
  MatrixXd Tk, Tk1, Jtmp, J0, J1;
  MatrixXd Jdef;  ///< ndx x window
  MatrixXd Jeq;   ///< ne x window
  MatrixXd Jin;   ///< ni x window
  VectorXd grad;  ///< cost gradient on the window
};

class OcpTnlp final : public Ipopt::TNLP {
 public:
  OcpTnlp(const ocp::OptimalControlProblem& pb, const VectorXd& x_init,
          const std::vector<VectorXd>& xbar, const std::vector<VectorXd>& us_guess,
          const IpoptOptions& opt)
      : pb_(pb),
        space_(pb.stateSpace()),
        N_(pb.horizon()),
        ndx_(pb.ndx()),
        nu_(pb.nu()),
        nx_(pb.nx()),
        x_init_(x_init),
        xbar_(xbar),
        us_guess_(us_guess),
        opt_(opt) {
    xbar_[0] = x_init_;
    // Active rows per node (fixed for the solve: they depend on the node context only).
    auto d = pb_.createNodeData();
    const VectorXd u0 = VectorXd::Zero(nu_);
    ne_.resize(static_cast<size_t>(N_ + 1));
    ni_.resize(static_cast<size_t>(N_ + 1));
    for (int k = 0; k <= N_; ++k) {
      const auto kk = static_cast<size_t>(k);
      pb_.evaluate(k, xbar_[kk], k < N_ ? us_guess_[kk] : u0, *d);
      ne_[kk] = k < N_ ? d->ne : 0;
      ni_[kk] = d->ni;
      for (int i = 0; i < d->ni; ++i)
        if (d->soft[i] && !opt_.soft_as_hard)
          throw std::invalid_argument(
              "solveWithIpopt: soft inequalities are not reproduced (set soft_as_hard)");
    }
    if (pb_.stateBounds().size() > 0 && pb_.stateBounds().options.soft && !opt_.soft_as_hard)
      throw std::invalid_argument("solveWithIpopt: soft state bounds are not reproduced");
    // Offsets.
    int row = 0;
    for (int k = 0; k <= N_; ++k) {
      const auto kk = static_cast<size_t>(k);
      cdef_.push_back(row);
      if (k < N_) row += ndx_;
      ceq_.push_back(row);
      row += ne_[kk];
      cin_.push_back(row);
      row += ni_[kk];
    }
    m_ = row;
    n_ = (N_ + 1) * ndx_ + N_ * nu_;
    for (int k = 0; k <= N_; ++k) work_.push_back(makeWork(k));
    scratch_ = makeWork(0);
    buildHessianStructure();
  }

  // ---- result
  std::vector<double> x_sol, lambda_sol;
  double obj_sol = 0.0;
  Ipopt::SolverReturn solver_status = Ipopt::INTERNAL_ERROR;

  std::vector<VectorXd> states(const double* z) const {
    std::vector<VectorXd> xs(static_cast<size_t>(N_ + 1), VectorXd(nx_));
    for (int k = 0; k <= N_; ++k) {
      const auto kk = static_cast<size_t>(k);
      space_.integrate(xbar_[kk], Eigen::Map<const VectorXd>(z + vx(k), ndx_), xs[kk]);
    }
    return xs;
  }
  std::vector<VectorXd> inputs(const double* z) const {
    std::vector<VectorXd> us;
    for (int k = 0; k < N_; ++k) us.emplace_back(Eigen::Map<const VectorXd>(z + vx(k) + ndx_, nu_));
    return us;
  }
  int cdef(int k) const { return cdef_[static_cast<size_t>(k)]; }
  int ceq(int k) const { return ceq_[static_cast<size_t>(k)]; }
  int cin(int k) const { return cin_[static_cast<size_t>(k)]; }
  int ne(int k) const { return ne_[static_cast<size_t>(k)]; }
  int ni(int k) const { return ni_[static_cast<size_t>(k)]; }

  // ---- TNLP
  bool get_nlp_info(Index& n, Index& m, Index& nnz_jac_g, Index& nnz_h_lag,
                    IndexStyleEnum& index_style) override {
    n = n_;
    m = m_;
    int nnz = 0;
    for (int k = 0; k <= N_; ++k) {
      if (k < N_) nnz += ndx_ * (2 * ndx_ + nu_);
      nnz += (ne(k) + ni(k)) * (k < N_ ? ndx_ + nu_ : ndx_);
    }
    nnz_jac_g = nnz;
    nnz_h_lag = static_cast<Index>(hess_rows_.size());
    index_style = C_STYLE;
    return true;
  }

  bool get_bounds_info(Index, Number* x_l, Number* x_u, Index, Number* g_l, Number* g_u) override {
    for (int i = 0; i < n_; ++i) {
      x_l[i] = -kIpoptInf;
      x_u[i] = kIpoptInf;
    }
    for (int i = 0; i < ndx_; ++i) x_l[i] = x_u[i] = 0.0;  // x_0 = x_init
    const ocp::BoundSet& ub = pb_.inputBounds();
    const ocp::BoundSet& xb = pb_.stateBounds();
    const int off = nx_ - ndx_;
    for (int k = 0; k <= N_; ++k) {
      const auto kk = static_cast<size_t>(k);
      if (k >= 1) {
        for (int j = 0; j < xb.size(); ++j) {
          const auto jj = static_cast<size_t>(j);
          const int idx = xb.index[jj];
          const double ref = xbar_[kk][idx + off];
          if (xb.has_lower[jj]) x_l[vx(k) + idx] = xb.lower[j] - ref;
          if (xb.has_upper[jj]) x_u[vx(k) + idx] = xb.upper[j] - ref;
        }
      }
      if (k < N_) {
        for (int j = 0; j < ub.size(); ++j) {
          const auto jj = static_cast<size_t>(j);
          const int idx = ub.index[jj];
          if (ub.has_lower[jj]) x_l[vx(k) + ndx_ + idx] = ub.lower[j];
          if (ub.has_upper[jj]) x_u[vx(k) + ndx_ + idx] = ub.upper[j];
        }
      }
    }
    for (int k = 0; k <= N_; ++k) {
      for (int i = 0; i < (k < N_ ? ndx_ : 0) + ne(k); ++i)
        g_l[cdef(k) + i] = g_u[cdef(k) + i] = 0.0;
      for (int i = 0; i < ni(k); ++i) {
        g_l[cin(k) + i] = 0.0;
        g_u[cin(k) + i] = kIpoptInf;
      }
    }
    return true;
  }

  bool get_starting_point(Index, bool init_x, Number* x, bool init_z, Number*, Number*, Index,
                          bool init_lambda, Number*) override {
    if (init_z || init_lambda) return false;
    if (init_x) {
      std::fill(x, x + n_, 0.0);
      for (int k = 0; k < N_; ++k)
        for (int i = 0; i < nu_; ++i) x[vx(k) + ndx_ + i] = us_guess_[static_cast<size_t>(k)][i];
    }
    return true;
  }

  bool eval_f(Index, const Number* x, bool, Number& obj_value) override {
    if (!update(x)) return false;
    double c = 0.0;
    for (const auto& w : work_) c += w.d->cost;
    obj_value = c;
    return std::isfinite(c);
  }

  bool eval_grad_f(Index, const Number* x, bool, Number* grad_f) override {
    if (!update(x)) return false;
    std::fill(grad_f, grad_f + n_, 0.0);
    for (int k = 0; k <= N_; ++k) {
      const auto& w = work_[static_cast<size_t>(k)];
      for (int i = 0; i < w.grad.size(); ++i) grad_f[vx(k) + i] += w.grad[i];
    }
    return true;
  }

  bool eval_g(Index, const Number* x, bool, Index, Number* g) override {
    if (!update(x)) return false;
    for (int k = 0; k <= N_; ++k) {
      const auto& w = work_[static_cast<size_t>(k)];
      if (k < N_)
        for (int i = 0; i < ndx_; ++i) g[cdef(k) + i] = w.defect[i];
      for (int i = 0; i < ne(k); ++i) g[ceq(k) + i] = w.d->e[i];
      for (int i = 0; i < ni(k); ++i) g[cin(k) + i] = w.d->g[i];
    }
    return true;
  }

  bool eval_jac_g(Index, const Number* x, bool, Index, Index, Index* iRow, Index* jCol,
                  Number* values) override {
    if (values == nullptr) {
      int p = 0;
      for (int k = 0; k <= N_; ++k) {
        const int wd = k < N_ ? 2 * ndx_ + nu_ : ndx_;
        const int ws = k < N_ ? ndx_ + nu_ : ndx_;
        if (k < N_)
          for (int i = 0; i < ndx_; ++i)
            for (int j = 0; j < wd; ++j, ++p) {
              iRow[p] = cdef(k) + i;
              jCol[p] = vx(k) + j;
            }
        for (int i = 0; i < ne(k); ++i)
          for (int j = 0; j < ws; ++j, ++p) {
            iRow[p] = ceq(k) + i;
            jCol[p] = vx(k) + j;
          }
        for (int i = 0; i < ni(k); ++i)
          for (int j = 0; j < ws; ++j, ++p) {
            iRow[p] = cin(k) + i;
            jCol[p] = vx(k) + j;
          }
      }
      return true;
    }
    if (!update(x)) return false;
    int p = 0;
    for (int k = 0; k <= N_; ++k) {
      const auto& w = work_[static_cast<size_t>(k)];
      const int wd = k < N_ ? 2 * ndx_ + nu_ : ndx_;
      const int ws = k < N_ ? ndx_ + nu_ : ndx_;
      if (k < N_)
        for (int i = 0; i < ndx_; ++i)
          for (int j = 0; j < wd; ++j) values[p++] = w.Jdef(i, j);
      for (int i = 0; i < ne(k); ++i)
        for (int j = 0; j < ws; ++j) values[p++] = w.Jeq(i, j);
      for (int i = 0; i < ni(k); ++i)
        for (int j = 0; j < ws; ++j) values[p++] = w.Jin(i, j);
    }
    return true;
  }

  bool eval_h(Index, const Number* x, bool, Number obj_factor, Index, const Number* lambda, bool,
              Index, Index* iRow, Index* jCol, Number* values) override {
    if (values == nullptr) {
      for (size_t p = 0; p < hess_rows_.size(); ++p) {
        iRow[p] = hess_rows_[p];
        jCol[p] = hess_cols_[p];
      }
      return true;
    }
    try {
      std::fill(values, values + hess_rows_.size(), 0.0);
      const double h = opt_.hessian_fd_step;
      for (int k = 0; k <= N_; ++k) {
        const int wd = windowSize(k);
        const VectorXd w0 = Eigen::Map<const VectorXd>(x + vx(k), wd);
        MatrixXd H(wd, wd);
        VectorXd wp = w0, gp(wd), gm(wd);
        for (int j = 0; j < wd; ++j) {
          wp = w0;
          wp[j] += h;
          evalNode(k, wp, scratch_, true);
          lagrangianGradient(k, scratch_, obj_factor, lambda, gp);
          wp[j] = w0[j] - h;
          evalNode(k, wp, scratch_, true);
          lagrangianGradient(k, scratch_, obj_factor, lambda, gm);
          H.col(j) = (gp - gm) / (2.0 * h);
        }
        const auto& pos = hess_pos_[static_cast<size_t>(k)];
        int q = 0;
        for (int i = 0; i < wd; ++i)
          for (int j = 0; j <= i; ++j)
            values[pos[static_cast<size_t>(q++)]] += 0.5 * (H(i, j) + H(j, i));
      }
      return true;
    } catch (...) {
      return false;
    }
  }

  void finalize_solution(Ipopt::SolverReturn status, Index n, const Number* x, const Number*,
                         const Number*, Index m, const Number*, const Number* lambda,
                         Number obj_value, const Ipopt::IpoptData*,
                         Ipopt::IpoptCalculatedQuantities*) override {
    solver_status = status;
    x_sol.assign(x, x + n);
    lambda_sol.assign(lambda, lambda + m);
    obj_sol = obj_value;
  }

 private:
  int vx(int k) const { return k * (ndx_ + nu_); }
  int windowSize(int k) const { return k < N_ ? 2 * ndx_ + nu_ : ndx_; }

  NodeWork makeWork(int k) const {
    NodeWork w;
    w.d = pb_.createNodeData();
    const int wd = windowSize(k);
    w.xk = VectorXd::Zero(nx_);
    w.xk1 = VectorXd::Zero(nx_);
    w.defect = VectorXd::Zero(ndx_);
    w.Tk = MatrixXd::Zero(ndx_, ndx_);
    w.Tk1 = MatrixXd::Zero(ndx_, ndx_);
    w.Jtmp = MatrixXd::Zero(ndx_, ndx_);
    w.J0 = MatrixXd::Zero(ndx_, ndx_);
    w.J1 = MatrixXd::Zero(ndx_, ndx_);
    // Sized for the largest window so the scratch works for any node.
    const int wmax = std::max(wd, 2 * ndx_ + nu_);
    w.Jdef = MatrixXd::Zero(ndx_, wmax);
    w.Jeq = MatrixXd::Zero(std::max(1, pb_.maxEqualities()), wmax);
    w.Jin = MatrixXd::Zero(std::max(1, pb_.maxInequalities()), wmax);
    w.grad = VectorXd::Zero(wd);
    return w;
  }

  /// Evaluates node k at the window w = [delta_k, u_k, delta_{k+1}] (terminal: [delta_N]).
  void evalNode(int k, const VectorXd& w, NodeWork& nw, bool deriv) const {
    const auto kk = static_cast<size_t>(k);
    const bool term = k == N_;
    const auto dk = w.head(ndx_);
    space_.integrate(xbar_[kk], dk, nw.xk);
    const VectorXd u = term ? VectorXd::Zero(nu_) : VectorXd(w.segment(ndx_, nu_));
    if (deriv)
      pb_.linearize(k, nw.xk, u, *nw.d);
    else
      pb_.evaluate(k, nw.xk, u, *nw.d);
    const auto& d = *nw.d;
    if (!term) {
      space_.integrate(xbar_[kk + 1], w.tail(ndx_), nw.xk1);
      space_.difference(d.xnext, nw.xk1, nw.defect);
    }
    if (!deriv) return;
    const int wd = windowSize(k);
    space_.integrateJacobians(xbar_[kk], dk, nw.Jtmp, nw.Tk);
    nw.grad.resize(wd);
    nw.grad.setZero();
    nw.grad.head(ndx_) = nw.Tk.transpose() * d.lx;
    if (!term) {
      nw.grad.segment(ndx_, nu_) = d.lu;
      space_.integrateJacobians(xbar_[kk + 1], w.tail(ndx_), nw.Jtmp, nw.Tk1);
      space_.differenceJacobians(d.xnext, nw.xk1, nw.J0, nw.J1);
      nw.Jdef.leftCols(ndx_) = nw.J0 * d.Fx * nw.Tk;
      nw.Jdef.middleCols(ndx_, nu_) = nw.J0 * d.Fu;
      nw.Jdef.middleCols(ndx_ + nu_, ndx_) = nw.J1 * nw.Tk1;
      if (d.ne > 0) {
        nw.Jeq.topLeftCorner(d.ne, ndx_) = d.Ex.topRows(d.ne) * nw.Tk;
        nw.Jeq.block(0, ndx_, d.ne, nu_) = d.Eu.topRows(d.ne);
      }
    }
    if (d.ni > 0) {
      nw.Jin.topLeftCorner(d.ni, ndx_) = d.Gx.topRows(d.ni) * nw.Tk;
      if (!term) nw.Jin.block(0, ndx_, d.ni, nu_) = d.Gu.topRows(d.ni);
    }
  }

  void lagrangianGradient(int k, const NodeWork& nw, double sigma, const double* lambda,
                          VectorXd& out) const {
    const int wd = windowSize(k);
    const int ws = k < N_ ? ndx_ + nu_ : ndx_;
    out = sigma * nw.grad;
    if (k < N_)
      out += nw.Jdef.leftCols(wd).transpose() * Eigen::Map<const VectorXd>(lambda + cdef(k), ndx_);
    if (ne(k) > 0)
      out.head(ws) += nw.Jeq.topLeftCorner(ne(k), ws).transpose() *
                      Eigen::Map<const VectorXd>(lambda + ceq(k), ne(k));
    if (ni(k) > 0)
      out.head(ws) += nw.Jin.topLeftCorner(ni(k), ws).transpose() *
                      Eigen::Map<const VectorXd>(lambda + cin(k), ni(k));
  }

  bool update(const double* x) {
    if (!last_x_.empty() && std::memcmp(last_x_.data(), x, sizeof(double) * last_x_.size()) == 0)
      return last_ok_;
    last_x_.assign(x, x + n_);
    last_ok_ = true;
    try {
      for (int k = 0; k <= N_; ++k) {
        auto& w = work_[static_cast<size_t>(k)];
        evalNode(k, Eigen::Map<const VectorXd>(x + vx(k), windowSize(k)), w, true);
        if (!std::isfinite(w.d->cost) || !w.defect.allFinite()) last_ok_ = false;
        if (ne(k) != (k < N_ ? w.d->ne : 0) || ni(k) != w.d->ni)
          throw std::runtime_error("solveWithIpopt: active rows changed during the solve");
      }
    } catch (...) {
      last_ok_ = false;
    }
    return last_ok_;
  }

  void buildHessianStructure() {
    std::map<std::pair<int, int>, int> index;
    for (int k = 0; k <= N_; ++k) {
      const int wd = windowSize(k);
      std::vector<int> pos;
      for (int i = 0; i < wd; ++i)
        for (int j = 0; j <= i; ++j) {
          const std::pair<int, int> key(vx(k) + i, vx(k) + j);
          auto it = index.find(key);
          if (it == index.end()) {
            const int p = static_cast<int>(hess_rows_.size());
            index.emplace(key, p);
            hess_rows_.push_back(key.first);
            hess_cols_.push_back(key.second);
            pos.push_back(p);
          } else {
            pos.push_back(it->second);
          }
        }
      hess_pos_.push_back(std::move(pos));
    }
  }

  const ocp::OptimalControlProblem& pb_;
  const ocp::StateSpace& space_;
  int N_, ndx_, nu_, nx_;
  VectorXd x_init_;
  std::vector<VectorXd> xbar_, us_guess_;
  IpoptOptions opt_;
  std::vector<int> ne_, ni_, cdef_, ceq_, cin_;
  int n_ = 0, m_ = 0;
  std::vector<NodeWork> work_;
  NodeWork scratch_;
  std::vector<double> last_x_;
  bool last_ok_ = false;
  std::vector<int> hess_rows_, hess_cols_;
  std::vector<std::vector<int>> hess_pos_;
};

const char* statusName(Ipopt::ApplicationReturnStatus s) {
  switch (s) {
    case Ipopt::Solve_Succeeded:
      return "Solve_Succeeded";
    case Ipopt::Solved_To_Acceptable_Level:
      return "Solved_To_Acceptable_Level";
    case Ipopt::Infeasible_Problem_Detected:
      return "Infeasible_Problem_Detected";
    case Ipopt::Search_Direction_Becomes_Too_Small:
      return "Search_Direction_Becomes_Too_Small";
    case Ipopt::Diverging_Iterates:
      return "Diverging_Iterates";
    case Ipopt::User_Requested_Stop:
      return "User_Requested_Stop";
    case Ipopt::Feasible_Point_Found:
      return "Feasible_Point_Found";
    case Ipopt::Maximum_Iterations_Exceeded:
      return "Maximum_Iterations_Exceeded";
    case Ipopt::Restoration_Failed:
      return "Restoration_Failed";
    case Ipopt::Error_In_Step_Computation:
      return "Error_In_Step_Computation";
    case Ipopt::Maximum_CpuTime_Exceeded:
      return "Maximum_CpuTime_Exceeded";
    case Ipopt::Not_Enough_Degrees_Of_Freedom:
      return "Not_Enough_Degrees_Of_Freedom";
    case Ipopt::Invalid_Problem_Definition:
      return "Invalid_Problem_Definition";
    case Ipopt::Invalid_Option:
      return "Invalid_Option";
    case Ipopt::Invalid_Number_Detected:
      return "Invalid_Number_Detected";
    default:
      return "Ipopt_Error";
  }
}

}  // namespace

IpoptResult solveWithIpopt(const ocp::OptimalControlProblem& problem, const VectorXd& x_init,
                           const std::vector<VectorXd>& xs_guess,
                           const std::vector<VectorXd>& us_guess, const IpoptOptions& options) {
  const int N = problem.horizon();
  if (static_cast<int>(xs_guess.size()) != N + 1 || static_cast<int>(us_guess.size()) != N)
    throw std::invalid_argument("solveWithIpopt: initial guess sizes");
  IpoptResult res;
  std::vector<VectorXd> xbar = xs_guess, ubar = us_guess;
  const int passes =
      problem.stateSpace().isEuclidean() ? 1 : 1 + std::max(0, options.recentre_passes);
  for (int pass = 0; pass < passes; ++pass) {
    Ipopt::SmartPtr<OcpTnlp> nlp = new OcpTnlp(problem, x_init, xbar, ubar, options);
    Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
    auto& o = *app->Options();
    o.SetNumericValue("tol", options.tol);
    o.SetNumericValue("acceptable_tol", options.acceptable_tol);
    o.SetNumericValue("constr_viol_tol", options.tol);
    o.SetNumericValue("compl_inf_tol", options.tol);
    o.SetNumericValue("dual_inf_tol", 1e-8);
    o.SetNumericValue("bound_relax_factor", 0.0);
    o.SetIntegerValue("max_iter", options.max_iter);
    o.SetIntegerValue("print_level", options.print_level);
    o.SetStringValue("sb", "yes");
    o.SetStringValue("nlp_scaling_method", "none");
    o.SetStringValue("hessian_approximation", options.exact_hessian ? "exact" : "limited-memory");
    if (pass > 0) {
      // Already at the solution: do not push the point away from active bounds much.
      o.SetNumericValue("bound_push", 1e-10);
      o.SetNumericValue("bound_frac", 1e-10);
      o.SetNumericValue("mu_init", 1e-9);
    }
    if (app->Initialize() != Ipopt::Solve_Succeeded) {
      res.status_string = "Initialize failed";
      return res;
    }
    const Ipopt::ApplicationReturnStatus st = app->OptimizeTNLP(Ipopt::SmartPtr<Ipopt::TNLP>(nlp));
    res.status = static_cast<int>(st);
    res.status_string = statusName(st);
    res.success = st == Ipopt::Solve_Succeeded || st == Ipopt::Solved_To_Acceptable_Level;
    res.iterations += Ipopt::IsValid(app->Statistics()) ? app->Statistics()->IterationCount() : 0;
    if (nlp->x_sol.empty()) return res;
    res.xs = nlp->states(nlp->x_sol.data());
    res.us = nlp->inputs(nlp->x_sol.data());
    res.cost = nlp->obj_sol;
    res.defect_multipliers.clear();
    res.equality_multipliers.clear();
    res.inequality_multipliers.clear();
    for (int k = 0; k <= N; ++k) {
      const double* l = nlp->lambda_sol.data();
      if (k < N)
        res.defect_multipliers.emplace_back(
            Eigen::Map<const VectorXd>(l + nlp->cdef(k), problem.ndx()));
      if (k < N)
        res.equality_multipliers.emplace_back(
            Eigen::Map<const VectorXd>(l + nlp->ceq(k), nlp->ne(k)));
      res.inequality_multipliers.emplace_back(
          Eigen::Map<const VectorXd>(l + nlp->cin(k), nlp->ni(k)));
    }
    if (!res.success) break;
    xbar = res.xs;
    ubar = res.us;
  }
  if (!res.xs.empty()) {
    res.cost = totalCost(problem, res.xs, res.us);
    res.max_violation = maxViolation(problem, x_init, res.xs, res.us);
  }
  return res;
}

}  // namespace rollstep::nltest
