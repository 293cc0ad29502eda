// The CBF-QP's dense QP solver against Ipopt (tests only) on random QPs of the filter's
// sizes: same minimiser, objective and multipliers; and both agree that a problem with
// contradicting rows is infeasible. Ipopt solves the QP as an NLP: variables x with bounds
// lb <= x <= ub, constraints g(x) = [A_eq x; C x] in [b_eq, b_eq] x [l, u], exact Hessian.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <vector>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wold-style-cast"
#pragma GCC diagnostic ignored "-Wnon-virtual-dtor"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Woverloaded-virtual"
#pragma GCC diagnostic ignored "-Wpedantic"
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <coin/IpIpoptApplication.hpp>
#include <coin/IpTNLP.hpp>
#pragma GCC diagnostic pop

#include "qp_test_problems.hpp"
#include "rollstep/control/dense_qp.hpp"

namespace {

using namespace rollstep;
using control::DenseQpProblem;
using control::DenseQpSolver;
using control::DenseQpStatus;
using Eigen::VectorXd;
using Ipopt::Index;
using Ipopt::Number;

constexpr double kIpoptInf = 2e19;  // beyond Ipopt's nlp_*_bound_inf (1e19): no bound

struct IpoptQpResult {
  Ipopt::ApplicationReturnStatus status = Ipopt::Internal_Error;
  VectorXd x, lambda, z_lower, z_upper;  ///< Ipopt's convention: grad f + J^T lambda - zL + zU = 0
  double objective = 0.0;
};

class QpTnlp final : public Ipopt::TNLP {
 public:
  QpTnlp(const DenseQpProblem& qp, IpoptQpResult& out)
      : qp_(qp), out_(out), n_(qp.n()), m_(qp.nEq() + qp.nIneq()) {}

  bool get_nlp_info(Index& n, Index& m, Index& nnz_jac_g, Index& nnz_h_lag,
                    IndexStyleEnum& index_style) override {
    n = n_;
    m = m_;
    nnz_jac_g = n_ * m_;
    nnz_h_lag = n_ * (n_ + 1) / 2;
    index_style = C_STYLE;
    return true;
  }
  bool get_bounds_info(Index, Number* x_l, Number* x_u, Index, Number* g_l, Number* g_u) override {
    auto clip = [](double v) { return std::isinf(v) ? (v > 0 ? kIpoptInf : -kIpoptInf) : v; };
    for (int j = 0; j < n_; ++j) {
      x_l[j] = clip(qp_.lb()(j));
      x_u[j] = clip(qp_.ub()(j));
    }
    for (int i = 0; i < qp_.nEq(); ++i) g_l[i] = g_u[i] = qp_.beq()(i);
    for (int i = 0; i < qp_.nIneq(); ++i) {
      g_l[qp_.nEq() + i] = clip(qp_.l()(i));
      g_u[qp_.nEq() + i] = clip(qp_.u()(i));
    }
    return true;
  }
  bool get_starting_point(Index, bool, Number* x, bool, Number*, Number*, Index, bool,
                          Number*) override {
    for (int j = 0; j < n_; ++j) x[j] = 0.0;
    return true;
  }
  bool eval_f(Index, const Number* x, bool, Number& f) override {
    const Eigen::Map<const VectorXd> xv(x, n_);
    f = 0.5 * xv.dot(qp_.H() * xv) + qp_.g().dot(xv);
    return true;
  }
  bool eval_grad_f(Index, const Number* x, bool, Number* grad) override {
    const Eigen::Map<const VectorXd> xv(x, n_);
    Eigen::Map<VectorXd>(grad, n_) = qp_.H() * xv + qp_.g();
    return true;
  }
  bool eval_g(Index, const Number* x, bool, Index, Number* g) override {
    const Eigen::Map<const VectorXd> xv(x, n_);
    Eigen::Map<VectorXd> gv(g, m_);
    gv.head(qp_.nEq()) = qp_.Aeq() * xv;
    gv.tail(qp_.nIneq()) = qp_.C() * xv;
    return true;
  }
  bool eval_jac_g(Index, const Number*, bool, Index, Index, Index* rows, Index* cols,
                  Number* values) override {
    int k = 0;
    for (int i = 0; i < m_; ++i) {
      for (int j = 0; j < n_; ++j, ++k) {
        if (values == nullptr) {
          rows[k] = i;
          cols[k] = j;
        } else {
          values[k] = i < qp_.nEq() ? qp_.Aeq()(i, j) : qp_.C()(i - qp_.nEq(), j);
        }
      }
    }
    return true;
  }
  bool eval_h(Index, const Number*, bool, Number obj_factor, Index, const Number*, bool, Index,
              Index* rows, Index* cols, Number* values) override {
    int k = 0;
    for (int i = 0; i < n_; ++i) {
      for (int j = 0; j <= i; ++j, ++k) {
        if (values == nullptr) {
          rows[k] = i;
          cols[k] = j;
        } else {
          values[k] = obj_factor * qp_.H()(i, j);
        }
      }
    }
    return true;
  }
  void finalize_solution(Ipopt::SolverReturn, Index, const Number* x, const Number* z_l,
                         const Number* z_u, Index, const Number*, const Number* lambda,
                         Number obj_value, const Ipopt::IpoptData*,
                         Ipopt::IpoptCalculatedQuantities*) override {
    out_.x = Eigen::Map<const VectorXd>(x, n_);
    out_.z_lower = Eigen::Map<const VectorXd>(z_l, n_);
    out_.z_upper = Eigen::Map<const VectorXd>(z_u, n_);
    out_.lambda = Eigen::Map<const VectorXd>(lambda, m_);
    out_.objective = obj_value;
  }

 private:
  const DenseQpProblem& qp_;
  IpoptQpResult& out_;
  int n_, m_;
};

IpoptQpResult solveWithIpopt(const DenseQpProblem& qp, int max_iter = 500) {
  IpoptQpResult res;
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
  auto& o = *app->Options();
  o.SetNumericValue("tol", 1e-12);
  o.SetNumericValue("constr_viol_tol", 1e-12);
  o.SetNumericValue("compl_inf_tol", 1e-12);
  o.SetNumericValue("bound_relax_factor", 0.0);
  o.SetIntegerValue("max_iter", max_iter);
  o.SetIntegerValue("print_level", 0);
  o.SetStringValue("sb", "yes");
  o.SetStringValue("mehrotra_algorithm", "yes");  // Ipopt's recommendation for convex QPs
  o.SetStringValue("jac_c_constant", "yes");
  o.SetStringValue("jac_d_constant", "yes");
  o.SetStringValue("hessian_constant", "yes");
  if (app->Initialize() != Ipopt::Solve_Succeeded) return res;
  res.status = app->OptimizeTNLP(Ipopt::SmartPtr<Ipopt::TNLP>(new QpTnlp(qp, res)));
  return res;
}

TEST(DenseQpVsIpopt, RandomProblemsOfTheFiltersSizes) {
  const std::vector<qptest::RandomQpSpec> specs = {{10, 3, 20}, {30, 12, 60}, {40, 20, 100}};
  int compared = 0, active = 0;
  for (const auto& spec : specs) {
    DenseQpProblem qp({spec.n, spec.n_eq, spec.n_ineq});
    DenseQpSolver solver({spec.n, spec.n_eq, spec.n_ineq});
    for (unsigned seed = 1; seed <= 4; ++seed) {
      qptest::makeRandomQp(spec, 1000 + seed, qp);
      ASSERT_EQ(solver.solve(qp), DenseQpStatus::Optimal) << spec.n << " " << seed;
      const IpoptQpResult ip = solveWithIpopt(qp);
      ASSERT_EQ(ip.status, Ipopt::Solve_Succeeded) << spec.n << " " << seed;
      const double scale = 1.0 + ip.x.lpNorm<Eigen::Infinity>();
      EXPECT_LE((solver.x() - ip.x).lpNorm<Eigen::Infinity>(), 1e-7 * scale)
          << spec.n << " seed " << seed;
      EXPECT_NEAR(solver.objective(), ip.objective, 1e-9 * (1.0 + std::abs(ip.objective)));
      // Multipliers (unique: random data, strictly complementary with probability 1).
      // Ours: grad f = A^T y + C^T (zl - zu) + (wl - wu); Ipopt's: grad f = -J^T lambda +
      // zL - zU.
      const double mscale = 1.0 + ip.lambda.lpNorm<Eigen::Infinity>();
      const int me = spec.n_eq;
      EXPECT_LE((solver.yEq() + ip.lambda.head(me)).lpNorm<Eigen::Infinity>(), 1e-6 * mscale);
      EXPECT_LE((solver.zLower() - solver.zUpper() + ip.lambda.tail(spec.n_ineq))
                    .lpNorm<Eigen::Infinity>(),
                1e-6 * mscale);
      EXPECT_LE((solver.wLower() - ip.z_lower).lpNorm<Eigen::Infinity>(), 1e-6 * mscale);
      EXPECT_LE((solver.wUpper() - ip.z_upper).lpNorm<Eigen::Infinity>(), 1e-6 * mscale);
      active += solver.numActiveInequalities();
      ++compared;
    }
  }
  EXPECT_EQ(compared, 12);
  EXPECT_GT(active, 60);
}

TEST(DenseQpVsIpopt, BothFindContradictingRowsInfeasible) {
  qptest::RandomQpSpec spec{30, 12, 60};
  DenseQpProblem qp({30, 12, 62});
  DenseQpSolver solver({30, 12, 62});
  qptest::makeRandomQp(spec, 77, qp);
  qp.setDimensions(30, 12, 62);
  qp.C().row(60).setOnes();
  qp.l()(60) = 1.0;
  qp.C().row(61).setConstant(-1.0);
  qp.l()(61) = 1.0;
  EXPECT_EQ(solver.solve(qp), DenseQpStatus::Infeasible);
  EXPECT_LT(solver.iterations(), 60);
  // Ipopt does not succeed either; it usually runs into its iteration limit (or its
  // restoration phase) rather than proving infeasibility, so only "no solution" is asked.
  const IpoptQpResult ip = solveWithIpopt(qp, 100);
  EXPECT_NE(ip.status, Ipopt::Solve_Succeeded);
  EXPECT_NE(ip.status, Ipopt::Solved_To_Acceptable_Level);
}

}  // namespace
