// A user's linear-quadratic problem from numpy arrays, solved by rollstep's solver:
//   min sum_k 0.5 x'Q_k x + 0.5 u'R_k u + u'S_k x + q_k'x + r_k'u + 0.5 x_N'Q_N x_N + q_N'x_N
//   s.t. x_{k+1} = A_k x_k + B_k u_k + c_k,  x_0 given,
//        u_lo_k <= u_k <= u_hi_k, x_lo_k <= x_k <= x_hi_k (k >= 1),
//        lg_k <= C_k x_k + D_k u_k <= ug_k (k < N),  lg_N <= C_N x_N <= ug_N,
//        E_k x_k + F_k u_k = e_k (k < N; F_k of full row rank).
// Bounds shared by every node go to the solver's bound rows; bounds that differ between
// nodes become identity rows of the general rows of their node.
// Every term is exact (linear dynamics and rows, exact Hessians): the solver's converging
// mode is an interior point method on the QP.
#include <Eigen/LU>
#include <chrono>
#include <cmath>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "rollstep/ocp/cost.hpp"
#include "rollstep/ocp/dynamics.hpp"
#include "rollstep/ocp/problem.hpp"
#include "rollstep/ocp/residual.hpp"
#include "rollstep/ocp/state_space.hpp"
#include "rollstep/solver/solver.hpp"

namespace rollstep::python {

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using ocp::ConstVecRef;
using ocp::NodeContext;

std::string shapeText(const MatrixXd& m) {
  return "(" + std::to_string(m.rows()) + ", " + std::to_string(m.cols()) + ")";
}

void checkShape(const MatrixXd& m, Eigen::Index rows, Eigen::Index cols, const std::string& what) {
  if (m.rows() != rows || m.cols() != cols) {
    throw std::invalid_argument(what + " has shape " + shapeText(m) + "; expected (" +
                                std::to_string(rows) + ", " + std::to_string(cols) + ")");
  }
  if (!m.allFinite()) throw std::invalid_argument(what + " is not finite");
}

void checkVector(const VectorXd& v, Eigen::Index n, const std::string& what) {
  checkSize(v.size(), n, what.c_str());
  if (!v.allFinite()) throw std::invalid_argument(what + " is not finite");
}

std::string at(const char* name, std::size_t k) {
  return std::string(name) + "[" + std::to_string(k) + "]";
}

class LinearDynamics final : public ocp::Dynamics {
 public:
  LinearDynamics(int nx, int nu, std::vector<MatrixXd> A, std::vector<MatrixXd> B,
                 std::vector<VectorXd> c)
      : Dynamics(std::make_shared<ocp::EuclideanSpace>(nx), nu),
        A_(std::move(A)),
        B_(std::move(B)),
        c_(std::move(c)) {}
  bool isLinear() const override { return true; }
  std::unique_ptr<ocp::DynamicsData> createData() const override {
    return std::make_unique<ocp::DynamicsData>();
  }
  void calc(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, ocp::DynamicsData&,
            ocp::VecRef xnext) const override {
    const auto k = static_cast<std::size_t>(ctx.node);
    xnext.noalias() = A_[k] * x;
    xnext.noalias() += B_[k] * u;
    xnext += c_[k];
  }
  void calcDiff(const NodeContext& ctx, ConstVecRef, ConstVecRef, ocp::DynamicsData&,
                ocp::MatRef Fx, ocp::MatRef Fu) const override {
    const auto k = static_cast<std::size_t>(ctx.node);
    Fx = A_[k];
    Fu = B_[k];
  }

 private:
  std::vector<MatrixXd> A_, B_;
  std::vector<VectorXd> c_;
};

/// Node k's quadratic cost (the terminal one at node N, state only).
class QuadraticCost final : public ocp::CostTerm {
 public:
  QuadraticCost(int nx, int nu, std::vector<MatrixXd> Q, std::vector<MatrixXd> R,
                std::vector<MatrixXd> S, std::vector<VectorXd> q, std::vector<VectorXd> r,
                bool terminal)
      : CostTerm(nx, nu),
        Q_(std::move(Q)),
        R_(std::move(R)),
        S_(std::move(S)),
        q_(std::move(q)),
        r_(std::move(r)),
        terminal_(terminal) {}
  bool dependsOnInput() const override { return !terminal_; }
  bool hessianIsExact() const override { return true; }
  std::unique_ptr<ocp::CostData> createData() const override {
    return std::make_unique<ocp::CostData>();
  }
  double calc(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, ocp::CostData&) const override {
    const std::size_t k = index(ctx);
    double l = 0.5 * x.dot(Q_[k] * x) + q_[k].dot(x);
    if (!terminal_) l += 0.5 * u.dot(R_[k] * u) + u.dot(S_[k] * x) + r_[k].dot(u);
    return l;
  }
  void calcDiff(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, ocp::CostData&, double scale,
                ocp::VecRef lx, ocp::VecRef lu, ocp::MatRef Lxx, ocp::MatRef Luu,
                ocp::MatRef Lux) const override {
    const std::size_t k = index(ctx);
    lx += scale * (Q_[k] * x + q_[k]);
    Lxx += scale * Q_[k];
    if (terminal_) return;
    lx += scale * (S_[k].transpose() * u);
    lu += scale * (R_[k] * u + S_[k] * x + r_[k]);
    Luu += scale * R_[k];
    Lux += scale * S_[k];
  }

 private:
  std::size_t index(const NodeContext& ctx) const {
    return terminal_ ? 0 : static_cast<std::size_t>(ctx.node);
  }
  std::vector<MatrixXd> Q_, R_, S_;
  std::vector<VectorXd> q_, r_;
  bool terminal_;
};

/// g = G_x x + G_u u + g0 >= 0 per node: each finite side of lg <= C x + D u <= ug is a row.
class LinearRows final : public ocp::Residual {
 public:
  struct Node {
    MatrixXd Gx, Gu;
    VectorXd g0;
  };
  LinearRows(int nx, int nu, int max_rows, std::vector<Node> nodes, bool terminal)
      : Residual(nx, nu, max_rows), nodes_(std::move(nodes)), terminal_(terminal) {}
  int rows(const NodeContext& ctx) const override {
    return static_cast<int>(nodes_[index(ctx)].g0.size());
  }
  bool dependsOnInput() const override { return !terminal_; }
  bool isLinear() const override { return true; }
  void calc(const NodeContext& ctx, ConstVecRef x, ConstVecRef u,
            ocp::ResidualData& d) const override {
    const Node& n = nodes_[index(ctx)];
    const Eigen::Index m = n.g0.size();
    d.r.head(m).noalias() = n.Gx * x;
    d.r.head(m).noalias() += n.Gu * u;
    d.r.head(m) += n.g0;
  }
  void calcDiff(const NodeContext& ctx, ConstVecRef, ConstVecRef,
                ocp::ResidualData& d) const override {
    const Node& n = nodes_[index(ctx)];
    d.Rx.topRows(n.g0.size()) = n.Gx;
    d.Ru.topRows(n.g0.size()) = n.Gu;
  }

 private:
  std::size_t index(const NodeContext& ctx) const {
    return terminal_ ? 0 : static_cast<std::size_t>(ctx.node);
  }
  std::vector<Node> nodes_;
  bool terminal_;
};

/// r = E x + F u - e = 0 per node (eliminated by the solver through the input, so F must
/// have full row rank).
class LinearEqualities final : public ocp::Residual {
 public:
  struct Node {
    MatrixXd E, F;
    VectorXd e;
  };
  LinearEqualities(int nx, int nu, int max_rows, std::vector<Node> nodes)
      : Residual(nx, nu, max_rows), nodes_(std::move(nodes)) {}
  int rows(const NodeContext& ctx) const override {
    return static_cast<int>(nodes_[static_cast<std::size_t>(ctx.node)].e.size());
  }
  bool isLinear() const override { return true; }
  void calc(const NodeContext& ctx, ConstVecRef x, ConstVecRef u,
            ocp::ResidualData& d) const override {
    const Node& n = nodes_[static_cast<std::size_t>(ctx.node)];
    const Eigen::Index m = n.e.size();
    d.r.head(m).noalias() = n.E * x;
    d.r.head(m).noalias() += n.F * u;
    d.r.head(m) -= n.e;
  }
  void calcDiff(const NodeContext& ctx, ConstVecRef, ConstVecRef,
                ocp::ResidualData& d) const override {
    const Node& n = nodes_[static_cast<std::size_t>(ctx.node)];
    d.Rx.topRows(n.e.size()) = n.E;
    d.Ru.topRows(n.e.size()) = n.F;
  }

 private:
  std::vector<Node> nodes_;
};

LinearRows::Node rowsOf(const MatrixXd& C, const MatrixXd& D, const VectorXd& lo,
                        const VectorXd& hi) {
  int m = 0;
  for (Eigen::Index j = 0; j < lo.size(); ++j)
    m += (std::isfinite(lo[j]) ? 1 : 0) + (std::isfinite(hi[j]) ? 1 : 0);
  LinearRows::Node n{MatrixXd(m, C.cols()), MatrixXd(m, D.cols()), VectorXd(m)};
  int row = 0;
  for (Eigen::Index j = 0; j < lo.size(); ++j) {
    if (std::isfinite(lo[j])) {
      n.Gx.row(row) = C.row(j);
      n.Gu.row(row) = D.row(j);
      n.g0[row++] = -lo[j];
    }
    if (std::isfinite(hi[j])) {
      n.Gx.row(row) = -C.row(j);
      n.Gu.row(row) = -D.row(j);
      n.g0[row++] = hi[j];
    }
  }
  return n;
}

/// `extra` appended below `n`'s rows.
void appendRows(LinearRows::Node& n, const LinearRows::Node& extra) {
  const Eigen::Index m = n.g0.size(), k = extra.g0.size();
  if (k == 0) return;
  MatrixXd Gx(m + k, n.Gx.cols()), Gu(m + k, n.Gu.cols());
  VectorXd g0(m + k);
  Gx << n.Gx, extra.Gx;
  Gu << n.Gu, extra.Gu;
  g0 << n.g0, extra.g0;
  n = {std::move(Gx), std::move(Gu), std::move(g0)};
}

/// Whether every row of a per-node bound matrix equals the first.
bool sameOnEveryNode(const MatrixXd& lo, const MatrixXd& hi) {
  for (Eigen::Index k = 1; k < lo.rows(); ++k) {
    if (lo.row(k) != lo.row(0) || hi.row(k) != hi.row(0)) return false;
  }
  return true;
}

void checkBounds(const VectorXd& lo, const VectorXd& hi, Eigen::Index n, const std::string& what) {
  checkSize(lo.size(), n, (what + " lower").c_str());
  checkSize(hi.size(), n, (what + " upper").c_str());
  for (Eigen::Index j = 0; j < n; ++j) {
    if (std::isnan(lo[j]) || std::isnan(hi[j]) || lo[j] > hi[j]) {
      throw std::invalid_argument(what + " " + std::to_string(j) + ": lower " +
                                  std::to_string(lo[j]) + " above upper " + std::to_string(hi[j]) +
                                  " (or NaN)");
    }
  }
}

/// The problem and its solver (see the file comment for the notation).
struct LqProblem {
  int nx = 0, nu = 0, N = 0;
  std::shared_ptr<ocp::OptimalControlProblem> problem;
  std::unique_ptr<solver::Solver> solver;
  double solve_time = 0.0;
  mutable std::mutex mutex;
};

std::unique_ptr<LqProblem> makeLq(const std::vector<MatrixXd>& A, const std::vector<MatrixXd>& B,
                                  const std::vector<VectorXd>& c, const std::vector<MatrixXd>& Q,
                                  const std::vector<MatrixXd>& R, const std::vector<MatrixXd>& S,
                                  const std::vector<VectorXd>& q, const std::vector<VectorXd>& r,
                                  const MatrixXd& QN, const VectorXd& qN, const MatrixXd& u_lo,
                                  const MatrixXd& u_hi, const MatrixXd& x_lo, const MatrixXd& x_hi,
                                  const std::vector<MatrixXd>& C, const std::vector<MatrixXd>& D,
                                  const std::vector<VectorXd>& lg, const std::vector<VectorXd>& ug,
                                  const MatrixXd& CN, const VectorXd& lgN, const VectorXd& ugN,
                                  const std::vector<MatrixXd>& E, const std::vector<MatrixXd>& F,
                                  const std::vector<VectorXd>& e,
                                  const solver::SolverSettings& settings) {
  if (A.empty()) throw std::invalid_argument("A: at least one node (horizon N >= 1)");
  auto lq = std::make_unique<LqProblem>();
  const std::size_t N = A.size();
  lq->N = static_cast<int>(N);
  lq->nx = static_cast<int>(A[0].rows());
  lq->nu = static_cast<int>(B.empty() ? 0 : B[0].cols());
  const int nx = lq->nx, nu = lq->nu;
  if (nx < 1 || nu < 1) throw std::invalid_argument("nx and nu must be at least 1");
  const auto count = [N](std::size_t n, const char* what) {
    if (n != N) {
      throw std::invalid_argument(std::string(what) + " has " + std::to_string(n) +
                                  " nodes; expected N = " + std::to_string(N));
    }
  };
  count(B.size(), "B");
  count(c.size(), "c");
  count(Q.size(), "Q");
  count(R.size(), "R");
  count(S.size(), "S");
  count(q.size(), "q");
  count(r.size(), "r");
  count(C.size(), "C");
  count(D.size(), "D");
  count(lg.size(), "lg");
  count(ug.size(), "ug");
  count(E.size(), "E");
  count(F.size(), "F");
  count(e.size(), "e");
  // Bounds: one row shared by every node, or one row per node (x: nodes 1..N).
  const auto boundRows = [N](const MatrixXd& lo, const MatrixXd& hi, Eigen::Index n,
                             const char* what) {
    for (const MatrixXd* b : {&lo, &hi}) {
      if ((b->rows() != 1 && b->rows() != static_cast<Eigen::Index>(N)) || b->cols() != n) {
        throw std::invalid_argument(std::string(what) + " have shape " + shapeText(*b) +
                                    "; expected (" + std::to_string(n) + ",) for every node or (" +
                                    std::to_string(N) + ", " + std::to_string(n) + ") per node");
      }
    }
    if (lo.rows() != hi.rows()) {
      throw std::invalid_argument(std::string(what) + ": lower and upper have different shapes");
    }
    for (Eigen::Index k = 0; k < lo.rows(); ++k) {
      checkBounds(lo.row(k).transpose(), hi.row(k).transpose(), n,
                  lo.rows() == 1 ? std::string(what) : at(what, static_cast<std::size_t>(k)));
    }
  };
  boundRows(u_lo, u_hi, nu, "input bounds");
  boundRows(x_lo, x_hi, nx, "state bounds");
  const bool shared_u = sameOnEveryNode(u_lo, u_hi), shared_x = sameOnEveryNode(x_lo, x_hi);
  int max_equalities = 0;
  std::vector<LinearEqualities::Node> equalities;
  int max_rows = 0;
  std::vector<LinearRows::Node> rows;
  for (std::size_t k = 0; k < N; ++k) {
    checkShape(A[k], nx, nx, at("A", k));
    checkShape(B[k], nx, nu, at("B", k));
    checkVector(c[k], nx, at("c", k));
    checkShape(Q[k], nx, nx, at("Q", k));
    checkShape(R[k], nu, nu, at("R", k));
    checkShape(S[k], nu, nx, at("S", k));
    checkVector(q[k], nx, at("q", k));
    checkVector(r[k], nu, at("r", k));
    const Eigen::Index m = C[k].rows();
    checkShape(C[k], m, nx, at("C", k));
    checkShape(D[k], m, nu, at("D", k));
    checkBounds(lg[k], ug[k], m, at("general rows", k));
    rows.push_back(rowsOf(C[k], D[k], lg[k], ug[k]));
    if (!shared_u) {
      appendRows(rows.back(), rowsOf(MatrixXd::Zero(nu, nx), MatrixXd::Identity(nu, nu),
                                     u_lo.row(static_cast<Eigen::Index>(k)).transpose(),
                                     u_hi.row(static_cast<Eigen::Index>(k)).transpose()));
    }
    if (!shared_x && k >= 1) {
      appendRows(rows.back(), rowsOf(MatrixXd::Identity(nx, nx), MatrixXd::Zero(nx, nu),
                                     x_lo.row(static_cast<Eigen::Index>(k) - 1).transpose(),
                                     x_hi.row(static_cast<Eigen::Index>(k) - 1).transpose()));
    }
    max_rows = std::max(max_rows, static_cast<int>(rows.back().g0.size()));
    const Eigen::Index me = E[k].rows();
    checkShape(E[k], me, nx, at("E", k));
    checkShape(F[k], me, nu, at("F", k));
    checkVector(e[k], me, at("e", k));
    if (me > 0 && Eigen::FullPivLU<MatrixXd>(F[k]).rank() < me) {
      throw std::invalid_argument(at("F", k) + " has rank " +
                                  std::to_string(Eigen::FullPivLU<MatrixXd>(F[k]).rank()) +
                                  " below its " + std::to_string(me) +
                                  " rows: the solver eliminates equalities through the input, "
                                  "so F_k must have full row rank");
    }
    equalities.push_back({E[k], F[k], e[k]});
    max_equalities = std::max(max_equalities, static_cast<int>(me));
  }
  checkShape(QN, nx, nx, "QN");
  checkVector(qN, nx, "qN");
  checkShape(CN, CN.rows(), nx, "CN");
  checkBounds(lgN, ugN, CN.rows(), "terminal rows");

  auto dynamics = std::make_shared<LinearDynamics>(nx, nu, A, B, c);
  // dt = 1: the running costs are summed as given.
  lq->problem = std::make_shared<ocp::OptimalControlProblem>(dynamics, lq->N, 1.0);
  lq->problem->addCost("running", std::make_shared<QuadraticCost>(nx, nu, Q, R, S, q, r, false),
                       ocp::Stage::Running);
  lq->problem->addCost(
      "terminal",
      std::make_shared<QuadraticCost>(nx, nu, std::vector<MatrixXd>{QN}, std::vector<MatrixXd>{},
                                      std::vector<MatrixXd>{}, std::vector<VectorXd>{qN},
                                      std::vector<VectorXd>{}, true),
      ocp::Stage::Terminal);
  if (max_rows > 0) {
    lq->problem->addInequality(
        "rows", std::make_shared<LinearRows>(nx, nu, max_rows, std::move(rows), false),
        ocp::Stage::Running);
  }
  if (max_equalities > 0) {
    lq->problem->addEquality("equalities", std::make_shared<LinearEqualities>(
                                               nx, nu, max_equalities, std::move(equalities)));
  }
  LinearRows::Node terminal = rowsOf(CN, MatrixXd::Zero(CN.rows(), nu), lgN, ugN);
  if (!shared_x) {
    appendRows(terminal, rowsOf(MatrixXd::Identity(nx, nx), MatrixXd::Zero(nx, nu),
                                x_lo.bottomRows(1).transpose(), x_hi.bottomRows(1).transpose()));
  }
  if (terminal.g0.size() > 0) {
    const int m = static_cast<int>(terminal.g0.size());
    lq->problem->addInequality(
        "terminal_rows",
        std::make_shared<LinearRows>(nx, nu, m, std::vector<LinearRows::Node>{terminal}, true),
        ocp::Stage::Terminal);
  }
  if (shared_u && (!(u_lo.array() == -INFINITY).all() || !(u_hi.array() == INFINITY).all())) {
    lq->problem->setInputBounds(u_lo.row(0).transpose(), u_hi.row(0).transpose());
  }
  if (shared_x && (!(x_lo.array() == -INFINITY).all() || !(x_hi.array() == INFINITY).all())) {
    lq->problem->setStateBounds(x_lo.row(0).transpose(), x_hi.row(0).transpose());
  }
  lq->solver = std::make_unique<solver::Solver>(lq->problem, settings);
  return lq;
}

MatrixXd stackRows(const std::vector<VectorXd>& v) {
  MatrixXd out(static_cast<Eigen::Index>(v.size()), v.empty() ? 0 : v.front().size());
  for (std::size_t k = 0; k < v.size(); ++k) out.row(static_cast<Eigen::Index>(k)) = v[k];
  return out;
}

}  // namespace

void bindLqProblem(py::module_& m) {
  py::class_<LqProblem>(m, "_LqProblem", "C++ side of rollstep.LqProblem.")
      .def(py::init(&makeLq), py::call_guard<py::gil_scoped_release>())
      .def_property_readonly("nx", [](const LqProblem& p) { return p.nx; })
      .def_property_readonly("nu", [](const LqProblem& p) { return p.nu; })
      .def_property_readonly("horizon", [](const LqProblem& p) { return p.N; })
      .def("set_initial_guess",
           [](LqProblem& p, const MatrixXd& xs, const MatrixXd& us) {
             checkShape(xs, p.N + 1, p.nx, "xs");
             checkShape(us, p.N, p.nu, "us");
             std::vector<VectorXd> x, u;
             for (int k = 0; k <= p.N; ++k) x.emplace_back(xs.row(k).transpose());
             for (int k = 0; k < p.N; ++k) u.emplace_back(us.row(k).transpose());
             const std::lock_guard<std::mutex> lock(p.mutex);
             p.solver->setInitialGuess(x, u);
           })
      .def("solve",
           [](LqProblem& p, const VectorXd& x0) {
             checkVector(x0, p.nx, "x0");
             solver::SolverStatus status{};
             {
               py::gil_scoped_release release;
               const std::lock_guard<std::mutex> lock(p.mutex);
               const auto t0 = std::chrono::steady_clock::now();
               status = p.solver->solve(x0);
               p.solve_time =
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
             }
             return std::string(solver::toString(status));
           })
      .def_property_readonly("states",
                             [](const LqProblem& p) {
                               const std::lock_guard<std::mutex> lock(p.mutex);
                               return stackRows(p.solver->states());
                             })
      .def_property_readonly("inputs",
                             [](const LqProblem& p) {
                               const std::lock_guard<std::mutex> lock(p.mutex);
                               return stackRows(p.solver->inputs());
                             })
      .def_property_readonly(
          "status",
          [](const LqProblem& p) { return std::string(solver::toString(p.solver->status())); })
      .def_property_readonly("message",
                             [](const LqProblem& p) { return std::string(p.solver->message()); })
      .def_property_readonly("iterations",
                             [](const LqProblem& p) { return p.solver->iterations(); })
      .def_property_readonly("cost", [](const LqProblem& p) { return p.solver->cost(); })
      .def_property_readonly("solve_time", [](const LqProblem& p) { return p.solve_time; })
      .def("feedback_gain",
           [](const LqProblem& p, int k) {
             if (k < 0 || k >= p.N) {
               throw std::out_of_range("node " + std::to_string(k) + " out of range [0, " +
                                       std::to_string(p.N) + ")");
             }
             const std::lock_guard<std::mutex> lock(p.mutex);
             return MatrixXd(p.solver->feedbackGain(k));
           })
      .def_property_readonly("kkt_error", [](const LqProblem& p) {
        return p.solver->stats().empty() ? 0.0 : p.solver->stats().back().kkt_error;
      });
}

}  // namespace rollstep::python
