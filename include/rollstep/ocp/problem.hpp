#pragma once
// The switched-system optimal control problem of the paper (Sec. 2.1), transcribed by
// direct multiple shooting on a uniform grid of N steps of length dt:
//
//   min  sum_{k<N} dt * l_k(x_k, u_k) + V(x_N)
//   s.t. x_0 = x_init,   x_{k+1} = F(x_k, u_k)                (defects on the manifold)
//        e_k(x_k, u_k) = 0                 k < N              (state-input, projected)
//        g_k(x_k, u_k) >= 0                k < N (and k = N for state-only terms)
//        u_lo <= u_k <= u_hi,  x_lo <= x_k <= x_hi            (simple bounds)
//
// The mode of node k is the mode schedule's mode at t_k = t0 + k dt; every term sees it
// in its NodeContext and decides its own rows (0 = inactive). The problem is composed
// once (not real-time); evaluation afterwards never allocates. The solver evaluates
// different nodes concurrently (SolverSettings::num_threads > 1), each into its own
// NodeData: terms and precomputations must not modify shared state in calc/calcDiff.
// Hard state bounds are not imposed at node 0 by the solver (x_0 is fixed by x_init).
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "rollstep/ocp/cost.hpp"
#include "rollstep/ocp/dynamics.hpp"
#include "rollstep/ocp/mode_schedule.hpp"
#include "rollstep/ocp/residual.hpp"

namespace rollstep::ocp {

/// Creates and fills the per-node cache (NodeContext::cache) before the dynamics and
/// the terms of a node run, so that shared work (kinematics, Jacobians) is done once.
class NodePrecomputation {
 public:
  virtual ~NodePrecomputation() = default;
  virtual std::unique_ptr<NodeCache> createCache() const = 0;
  virtual void compute(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, bool derivatives,
                       NodeCache& cache) const = 0;
};

/// How an inequality is enforced.
struct InequalityOptions {
  /// false: hard (primal-dual interior point, slack > 0 always).
  /// true: soft, relaxed log barrier (Feller and Jones 2016) with the given relaxation
  /// delta; only for state-only residuals. Allowed to be violated, penalised
  /// quadratically beyond delta.
  bool soft = false;
  double relaxation = 1e-2;
  /// Soft rows: fixed weight w of the relaxed barrier, the cost gets w * beta_delta(g)
  /// in every solver mode (independent of the solver's barrier parameter, so it does not
  /// fade in Converging mode). The default equals SolverSettings::barrier_realtime.
  double weight = 1e-3;
};

/// Everything evaluated at one node, sized once for the problem's capacity.
/// Rows [0, ne) of the equality block and [0, ni) of the inequality block are in use.
struct NodeData {
  NodeContext context;
  double cost = 0.0;       ///< dt * l (running) or V (terminal)
  VectorXd lx, lu;         ///< cost gradient (tangent of x, u)
  MatrixXd Lxx, Luu, Lux;  ///< Gauss-Newton cost Hessian (Lux is nu x ndx)
  VectorXd xnext;          ///< F(x, u) (running nodes)
  MatrixXd Fx, Fu;         ///< dynamics Jacobians (tangent)
  int ne = 0;              ///< equality rows in use
  VectorXd e;              ///< e(x, u)
  MatrixXd Ex, Eu;
  int ni = 0;  ///< general inequality rows in use (bounds are separate)
  VectorXd g;  ///< g(x, u) >= 0
  MatrixXd Gx, Gu;
  Eigen::Matrix<bool, Eigen::Dynamic, 1> soft;        ///< per inequality row
  Eigen::Matrix<bool, Eigen::Dynamic, 1> state_only;  ///< per inequality row: Gu == 0
  VectorXd relaxation;                                ///< per inequality row (soft rows)
  VectorXd soft_weight;                               ///< per inequality row (soft rows)
  /// Per inequality row: the row whose Jacobians are its exact negatives (the other side
  /// of a two-sided limit, Residual::mirroredRows), -1 for none.
  Eigen::VectorXi mirror;
  VectorXd zero_input;  ///< the u passed to terms at the terminal node

  // Workspaces of the terms (opaque to the solver), possibly shared with other nodes'
  // data (OptimalControlProblem::createNodeDataSharingWorkspaces).
  std::shared_ptr<NodeCache> cache;
  std::shared_ptr<DynamicsData> dynamics_data;
  std::vector<std::shared_ptr<CostData>> cost_data;
  std::vector<std::shared_ptr<ResidualData>> equality_data;
  std::vector<std::shared_ptr<ResidualData>> inequality_data;
};

/// Simple bounds on a set of coordinates: lower <= v[index[j]] <= upper (j-th bound).
/// For the state, indices are tangent indices of the Euclidean part (the representation
/// coordinate is index + nx - ndx). Infinite sides are dropped when the bound set is built.
struct BoundSet {
  std::vector<int> index;
  VectorXd lower, upper;
  std::vector<bool> has_lower, has_upper;
  InequalityOptions options;
  int size() const { return static_cast<int>(index.size()); }
};

class OptimalControlProblem {
 public:
  static constexpr double kInfinity = std::numeric_limits<double>::infinity();

  /// @param dynamics discrete dynamics (gives the state space and nu)
  /// @param horizon  number of steps N (nodes 0..N, N+1 states, N inputs)
  /// @param dt       step length [s]
  OptimalControlProblem(std::shared_ptr<const Dynamics> dynamics, int horizon, double dt,
                        int schedule_capacity = 64);

  // --- composition (before a solver is built) ---------------------------------------
  void setPrecomputation(std::shared_ptr<const NodePrecomputation> pre);
  void addCost(std::string name, std::shared_ptr<const CostTerm> cost,
               Stage stage = Stage::Running);
  /// State-input equality e(x, u) = 0 on running nodes; its active rows must have full
  /// row rank in u (they are eliminated by projection).
  void addEquality(std::string name, std::shared_ptr<const Residual> residual);
  /// g(x, u) >= 0. Terminal or soft inequalities must be state-only.
  void addInequality(std::string name, std::shared_ptr<const Residual> residual,
                     Stage stage = Stage::Running, InequalityOptions options = {});
  /// lower <= u <= upper on running nodes (size nu; +-kInfinity for none); soft: relaxed
  /// log barrier rows, which never cut a step (a real-time iteration whose linearisation
  /// asks for more than a bound allows then takes its whole step).
  void setInputBounds(const VectorXd& lower, const VectorXd& upper, InequalityOptions options = {});
  /// lower <= x <= upper on the Euclidean tangent coordinates (size ndx; entries of the
  /// non-Euclidean part must be infinite), on every node 0..N.
  void setStateBounds(const VectorXd& lower, const VectorXd& upper, InequalityOptions options = {});

  /// Warm start of a real-time update (Solver::update) where the previous solution does
  /// not fit: the inputs a shift appends (they repeat the old last one) and those of nodes
  /// whose contact mode changed since they were last solved (the node grid moves by
  /// fractions of dt, so a node near a switch changes mode). The solver calls this for
  /// them with the node's context and state, for example to set the contact forces of the
  /// new mode (a foot whose swing begins there would otherwise keep its stance force
  /// against the swing's f = 0). Must not allocate. None by default.
  using InputGuess = std::function<void(const NodeContext& ctx, ConstVecRef x, VecRef u)>;
  void setInputGuess(InputGuess guess) { input_guess_ = std::move(guess); }
  const InputGuess& inputGuess() const { return input_guess_; }

  // --- per-solve inputs (real-time safe) ------------------------------------------------
  void setInitialTime(double t0) { t0_ = t0; }
  double initialTime() const { return t0_; }
  ModeSchedule& modeSchedule() { return schedule_; }
  const ModeSchedule& modeSchedule() const { return schedule_; }

  // --- dimensions -------------------------------------------------------------------------
  const StateSpace& stateSpace() const { return dynamics_->space(); }
  const Dynamics& dynamics() const { return *dynamics_; }
  int nx() const { return stateSpace().nx(); }
  int ndx() const { return stateSpace().ndx(); }
  int nu() const { return dynamics_->nu(); }
  int horizon() const { return horizon_; }
  double dt() const { return dt_; }
  /// Upper bounds on the rows any node can have (sum of the terms' maxRows).
  int maxEqualities() const { return max_eq_; }
  int maxInequalities() const { return max_ineq_; }
  const BoundSet& inputBounds() const { return input_bounds_; }
  const BoundSet& stateBounds() const { return state_bounds_; }

  // --- evaluation (never allocates) ------------------------------------------------------
  NodeContext context(int k) const;
  std::unique_ptr<NodeData> createNodeData() const;
  /// A node's data whose terms' workspaces and precomputation cache are those of `other`
  /// (from this problem's createNodeData). An evaluation fills them at its start and reads
  /// them only within it (a node's results are its own blocks: derivatives, values), so
  /// the data of nodes that are never evaluated at the same time (the nodes one thread
  /// runs through in turn) may share them: one set that stays in cache from node to node
  /// instead of a cold one per node (the cache alone: 55 kB for the Tachyon 3 OCP). The shared
  /// workspaces hold what the last of those evaluations left there.
  std::unique_ptr<NodeData> createNodeDataSharingWorkspaces(const NodeData& other) const;
  /// Values only: cost, xnext (running), e, g. At k == horizon() u is ignored.
  void evaluate(int k, ConstVecRef x, ConstVecRef u, NodeData& d) const;
  /// Values and first derivatives (Gauss-Newton Hessian of the cost).
  void linearize(int k, ConstVecRef x, ConstVecRef u, NodeData& d) const;
  /// Like linearize, but only for the terms whose second derivatives the solver must
  /// find by differences of first derivatives: costs whose Hessian is not exact
  /// (CostTerm::hessianIsExact), nonlinear dynamics, nonlinear equality and inequality
  /// residuals (Residual::isLinear). The other terms contribute zero: no cost, zero
  /// gradient, zero Jacobian rows (row counts and values of the constraints are still
  /// those of linearize). Differences of two such evaluations give the curvature that
  /// linearize's Hessian misses, at a fraction of the cost when most terms are linear.
  void linearizeCurvatureTerms(int k, ConstVecRef x, ConstVecRef u, NodeData& d) const;
  /// False when every term is exactly described by linearize (a linear-quadratic
  /// problem on a Euclidean space): the Lagrangian's Hessian is then the Gauss-Newton one.
  bool hasCurvature() const;

  /// Term names, in the order their rows are stacked (for reports and errors).
  const std::vector<std::string>& costNames() const { return cost_names_; }
  const std::vector<std::string>& equalityNames() const { return eq_names_; }
  const std::vector<std::string>& inequalityNames() const { return ineq_names_; }
  /// The j-th equality / inequality term, in the order of the names above.
  const Residual& equality(std::size_t j) const { return *equalities_.at(j); }
  const Residual& inequality(std::size_t j) const { return *inequalities_.at(j).residual; }
  /// Names of the tangent coordinates (ndx) and of the inputs (nu), for diagnostics (a
  /// violated state bound or dynamics row, a violated input bound). Either list may be
  /// empty (then "tangent i" / "input i"); otherwise its size must match (else
  /// std::invalid_argument).
  void setCoordinateNames(std::vector<std::string> tangent, std::vector<std::string> inputs);
  /// Coordinate i's name (diagnostics only, allocates); "tangent i" / "input i" without one.
  std::string tangentName(int i) const;
  std::string inputName(int i) const;

 private:
  enum class Pass { Values, Derivatives, Curvature };
  void run(int k, ConstVecRef x, ConstVecRef u, NodeData& d, Pass pass) const;
  /// A node's data without the terms' workspaces (the blocks the solver reads).
  std::unique_ptr<NodeData> createNodeBlocks() const;

  std::shared_ptr<const Dynamics> dynamics_;
  int horizon_;
  double dt_;
  double t0_ = 0.0;
  ModeSchedule schedule_;
  std::shared_ptr<const NodePrecomputation> pre_;

  struct CostEntry {
    std::shared_ptr<const CostTerm> term;
    Stage stage;
  };
  struct IneqEntry {
    std::shared_ptr<const Residual> residual;
    Stage stage;
    InequalityOptions options;
  };
  std::vector<CostEntry> costs_;
  std::vector<std::shared_ptr<const Residual>> equalities_;
  std::vector<IneqEntry> inequalities_;
  std::vector<std::string> cost_names_, eq_names_, ineq_names_;
  std::vector<std::string> tangent_names_, input_names_;  // empty: generated
  int max_eq_ = 0, max_ineq_ = 0;
  BoundSet input_bounds_, state_bounds_;
  InputGuess input_guess_;
};

}  // namespace rollstep::ocp
