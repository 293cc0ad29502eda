// What is the algorithm? The public API of Solver and its main loop (Impl::run), which
// reads as the interior-point iteration: linearise, test for convergence, update the
// barrier, find the direction, choose the step length, update the duals. The phases live
// in their own files (solver_impl.hpp lists them).
#include "rollstep/solver/solver.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "solver_impl.hpp"

namespace rollstep::solver {

using detail::msSince;

const char* toString(SolverStatus s) { return enumName(s, "Unknown"); }

/// Starts a run: clears the outputs of the last one, sets x0, the barrier and (converging
/// mode) fresh slacks, duals and filter. Returns false on an invalid x_init (status set).
bool Solver::Impl::begin(ConstVecRef x_init, bool realtime) {
  stats.clear();
  iterations = 0;
  failed_node = -1;
  message[0] = '\0';
  gains_valid.assign(gains_valid.size(), false);
  if (x_init.size() != nx || !x_init.allFinite()) {
    ROLLSTEP_MSG("initial state has the wrong size or non-finite entries");
    status = SolverStatus::InvalidInput;
    return false;
  }
  x0 = x_init;
  if (!has_guess) {
    for (auto& x : xs) x = x0;
    has_guess = true;
  }
  if (realtime) {
    mu = set.barrier_realtime;
  } else {
    mu = set.barrier_initial;
    for (auto& n : nodes) {
      n.fresh = true;
      n.lam.setZero();
    }
    pushIntoBounds();
    filter.clear();
    filter_mu = -1.0;
    filter_rejections_in_a_row = 0;
    filter_resets = 0;
    last_delta = 0.0;
  }
  // Mehrotra's predictor-corrector on convex QPs (no curvature; soft rows are checked at
  // the first linearisation).
  pc_active = !realtime && set.predictor_corrector && !has_curvature;
  tiny_step = false;
  nonfinite_trials = 0;
  acceptable_count = 0;
  prox = 0.0;
  return true;
}

/// Converging mode: moves the guess's hard-bounded inputs (every node) and states (from
/// node 1; x_0 is data) inside their bounds by bound_push, as Ipopt moves its starting
/// point off its variable bounds (bound_push, bound_frac). A bound row is linear, so the
/// first full Newton step would satisfy it; but a guess outside a bound starts that row's
/// slack above its value, the fraction to the boundary then cuts every step that moves
/// towards the violated side, and from a noisy start the slacks were driven to 1e-4 while
/// the rows stayed violated by 1 (two random starts of the bicycle ended Infeasible).
void Solver::Impl::pushIntoBounds() {
  pushInputsIntoBounds(us);
  const ocp::BoundSet& xb = prob->stateBounds();
  for (int k = 1; k <= N && !xb.options.soft; ++k) {
    VectorXd& x = xs[static_cast<std::size_t>(k)];
    for (int j = 0; j < nbx; ++j) {
      moveInsideBound(x(xb.index[static_cast<std::size_t>(j)] + rep_off), xb, j);
    }
  }
}

/// The hard-bounded inputs of every node of `inputs` moved inside their bounds (bound_push).
void Solver::Impl::pushInputsIntoBounds(std::vector<VectorXd>& inputs) const {
  const ocp::BoundSet& ub = prob->inputBounds();
  for (int k = 0; k < N && !ub.options.soft; ++k) {
    VectorXd& u = inputs[static_cast<std::size_t>(k)];
    for (int j = 0; j < nbu; ++j) moveInsideBound(u(ub.index[static_cast<std::size_t>(j)]), ub, j);
  }
}

/// v moved at least bound_push max(1, |bound|), at most bound_push of the range, inside bound
/// j of b (where it has that bound).
void Solver::Impl::moveInsideBound(double& v, const ocp::BoundSet& b, int j) const {
  const double push = set.bound_push;
  const auto jj = static_cast<std::size_t>(j);
  const double lo = b.lower(j), hi = b.upper(j);
  const double width = b.has_lower[jj] && b.has_upper[jj] ? hi - lo : detail::kInf;
  if (b.has_upper[jj]) v = std::min(v, hi - push * std::min(std::max(1.0, std::abs(hi)), width));
  if (b.has_lower[jj]) v = std::max(v, lo + push * std::min(std::max(1.0, std::abs(lo)), width));
}

/// One real-time iteration (realtime) or a converging solve.
SolverStatus Solver::Impl::run(ConstVecRef x_init, bool realtime) {
  if (!begin(x_init, realtime)) return status;
  const int max_it = realtime ? set.realtime_iterations : std::max(set.max_iterations, 0);
  for (;;) {
    IterationStats it;
    it.iteration = iterations;
    // Linearise every node; stop if the iterate diverged.
    const Kkt kkt = linearize(realtime, it);
    if (diverged(kkt)) return status;
    cost = kkt.cost;
    recordResiduals(kkt, it);
    if (pc_active && kkt.soft_rows) pc_active = false;  // not a QP: monotone barrier
    // Converging mode: stop when converged or out of iterations, else update the barrier
    // (the predictor-corrector chooses it with the direction).
    if (!realtime) {
      if (terminated(kkt, max_it, it)) return status;
      if (!pc_active) updateBarrier(kkt);
    }
    it.barrier = mu;
    // Newton direction (condensing, Riccati with inertia correction, step recovery).
    Direction dir;
    if (!searchDirection(realtime, kkt.primal, it, dir)) return status;
    // Step length: filter line search (converging mode) or the fraction-to-boundary step;
    // a rejected step ends in a restoration step or a failure.
    const auto t_upd = Clock::now();
    backup();
    backup_valid = true;
    double alpha = dir.alpha_p, alpha_d = dir.alpha_d;
    if (pc_active) {
      // Convex QP: one step length for primal and dual variables, no line search.
      alpha = alpha_d = std::min(dir.alpha_p, dir.alpha_d);
      takeFullStep(alpha);
    } else if (!realtime && set.line_search && !dir.tiny) {
      double theta0 = 0.0, f0 = 0.0;
      filter_was_reset = false;
      const bool accepted =
          filterLineSearch(dir.dphi, alpha, alpha_d, theta0, f0, it.second_order_corrections);
      it.filter_reset = filter_was_reset;
      if (!accepted) {
        if (stepRejected(kkt, theta0, f0, dir.dphi, t_upd, it)) continue;
        return status;
      }
      adaptProximalShift(alpha);
    } else {
      // Real-time mode, no line search, or a step too small for the line search to tell
      // apart from rounding (taken whole; the barrier decreases next).
      tiny_step = dir.tiny && !realtime;
      takeFullStep(alpha);
    }
    updateDuals(alpha, alpha_d);
    it.primal_step = alpha;
    it.dual_step = alpha_d;
    it.time_update_ms = msSince(t_upd);
    stats.push_back(it);
    ++iterations;
    has_solution = true;
    if (realtime && iterations >= max_it) return endRealTimeIteration();
  }
}

// ------------------------------------------------------------------------------------------
void checkSettings(const SolverSettings& s) {
  const auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("SolverSettings: ") + what);
  };
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  const auto requireIn = [](int v, IntSettingRange r, const char* name) {
    if (v < r.min || v > r.max) {
      throw std::invalid_argument(std::string("SolverSettings: ") + name + " must be in [" +
                                  std::to_string(r.min) + ", " + std::to_string(r.max) + "]");
    }
  };
  requireIn(s.max_iterations, kIterationCountRange, "max_iterations");
  require(positive(s.kkt_tolerance), "kkt_tolerance must be finite and > 0");
  require(positive(s.barrier_initial), "barrier_initial must be finite and > 0");
  require(positive(s.barrier_min), "barrier_min must be finite and > 0");
  require(s.barrier_min <= s.barrier_initial, "barrier_min must be <= barrier_initial");
  require(s.barrier_decrease > 0.0 && s.barrier_decrease < 1.0,
          "barrier_decrease must be in (0, 1)");
  require(positive(s.barrier_realtime), "barrier_realtime must be finite and > 0");
  requireIn(s.realtime_iterations, kRealtimeIterationRange, "realtime_iterations");
  require(s.fraction_to_boundary > 0.0 && s.fraction_to_boundary < 1.0,
          "fraction_to_boundary must be in (0, 1)");
  require(s.bound_push >= 0.0 && s.bound_push < 0.5, "bound_push must be in [0, 0.5)");
  requireIn(s.max_line_search_steps, kLineSearchStepsRange, "max_line_search_steps");
  require(s.rank_tolerance >= 0.0 && s.rank_tolerance < 1.0, "rank_tolerance must be in [0, 1)");
  requireIn(s.num_threads, kThreadCountRange, "num_threads");
  requireIn(s.thread_spin_us, kThreadSpinRange, "thread_spin_us");
  require(s.divergence_threshold > 0.0, "divergence_threshold must be > 0 (inf: never)");
  require(s.infeasibility_tolerance >= 0.0, "infeasibility_tolerance must be >= 0 (inf: never)");
  requireIn(s.filter_reset_trigger, kFilterResetRange, "filter_reset_trigger");
  requireIn(s.max_filter_resets, kFilterResetRange, "max_filter_resets");
  requireIn(s.max_second_order_corrections, kSecondOrderCorrectionRange,
            "max_second_order_corrections");
  require(positive(s.acceptable_tolerance), "acceptable_tolerance must be finite and > 0");
  requireIn(s.acceptable_iterations, kIterationCountRange, "acceptable_iterations");
}

Solver::Solver(std::shared_ptr<ocp::OptimalControlProblem> problem, SolverSettings settings) {
  if (!problem) throw std::invalid_argument("Solver: null problem");
  checkSettings(settings);
  impl_ = std::make_unique<Impl>(std::move(problem), settings);
}

Solver::~Solver() = default;

void Solver::setInitialGuess(const std::vector<VectorXd>& xs, const std::vector<VectorXd>& us) {
  Impl& m = *impl_;
  if (xs.size() != static_cast<std::size_t>(m.N) + 1 ||
      us.size() != static_cast<std::size_t>(m.N)) {
    throw std::invalid_argument("Solver::setInitialGuess: need N+1 states and N inputs");
  }
  for (const auto& x : xs) {
    if (x.size() != m.nx || !x.allFinite()) {
      throw std::invalid_argument(
          "Solver::setInitialGuess: a state has the wrong size or is not finite");
    }
  }
  for (const auto& u : us) {
    if (u.size() != m.nu || !u.allFinite()) {
      throw std::invalid_argument(
          "Solver::setInitialGuess: an input has the wrong size or is not finite");
    }
  }
  for (std::size_t k = 0; k < xs.size(); ++k) m.xs[k] = xs[k];
  m.backup_valid = false;
  for (std::size_t k = 0; k < us.size(); ++k) m.us[k] = us[k];
  for (auto& n : m.nodes) {
    n.fresh = true;
    n.lam.setZero();
  }
  m.has_guess = true;
}

SolverStatus Solver::solve(ConstVecRef x0) {
  Impl& m = *impl_;
  m.solution_t0 = m.prob->initialTime();
  m.last_shift = 0;
  return m.run(x0, m.set.mode == SolverMode::RealTime);
}

SolverStatus Solver::update(double t0, ConstVecRef x0) {
  Impl& m = *impl_;
  if (!std::isfinite(t0)) {
    m.stats.clear();
    std::snprintf(m.message, sizeof(m.message), "non-finite time");
    return m.status = SolverStatus::InvalidInput;
  }
  m.shiftToTime(t0);
  return m.run(x0, true);
}

const std::vector<VectorXd>& Solver::states() const { return impl_->xs; }
const std::vector<VectorXd>& Solver::inputs() const { return impl_->us; }
const VectorXd& Solver::equalityMultipliers(int k) const {
  return impl_->nodes.at(static_cast<std::size_t>(k)).mult;
}
const VectorXd& Solver::inequalityDuals(int k) const {
  return impl_->nodes.at(static_cast<std::size_t>(k)).z;
}
const VectorXd& Solver::slacks(int k) const {
  return impl_->nodes.at(static_cast<std::size_t>(k)).s;
}
const MatrixXd& Solver::feedbackGain(int k) const {
  Impl& m = *impl_;
  const auto kk = static_cast<std::size_t>(k);
  if (k < 0 || k >= m.N) throw std::out_of_range("Solver::feedbackGain: node out of range");
  if (!m.gains_valid[kk]) {
    if (m.direction_ready) {
      m.lq.feedbackGain(k, m.gains[kk]);
    } else {
      m.gains[kk].setZero();  // no factorisation yet
    }
    m.gains_valid[kk] = true;
  }
  return m.gains[kk];
}
const ocp::NodeData& Solver::nodeData(int k) const {
  return *impl_->nodes.at(static_cast<std::size_t>(k)).d;
}
const std::vector<IterationStats>& Solver::stats() const { return impl_->stats; }
int Solver::iterations() const { return impl_->iterations; }
int Solver::lastShift() const { return impl_->last_shift; }
SolverStatus Solver::status() const { return impl_->status; }
double Solver::cost() const { return impl_->cost; }
double Solver::barrier() const { return impl_->mu; }
int Solver::failedNode() const { return impl_->failed_node; }
const char* Solver::message() const { return impl_->message; }
const SolverSettings& Solver::settings() const { return impl_->set; }
void Solver::setSettings(const SolverSettings& s) {
  checkSettings(s);
  if (s.num_threads != impl_->set.num_threads || s.thread_spin_us != impl_->set.thread_spin_us) {
    throw std::invalid_argument(
        "Solver::setSettings: num_threads and thread_spin_us cannot change after construction");
  }
  impl_->set = s;
  if (impl_->needsCurvature(s)) impl_->reserveCurvature();
  impl_->stats.reserve(static_cast<std::size_t>(std::max(s.max_iterations, 1)) + 2);
  impl_->filter.reserve(static_cast<std::size_t>(std::max(s.max_iterations, 1)) + 2);
}
ocp::OptimalControlProblem& Solver::problem() { return *impl_->prob; }
const RiccatiSolver& Solver::riccati() const { return impl_->lq; }

}  // namespace rollstep::solver
