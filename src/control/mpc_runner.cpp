#include "rollstep/control/mpc_runner.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "rollstep/common/latest_value_mailbox.hpp"

namespace rollstep::control {
namespace {

/// Loop times closer than this count as equal (t = k * 0.001 against a grid of periods).
constexpr double kTimeTolerance = 1e-9;
/// [periods] Tolerance of the deterministic solve grid's period count: a simulation clock
/// that accumulates its step (MuJoCo's time) drifts by about 1e-10 s over a minute, which
/// is more than kTimeTolerance in periods; counted one short, the next solve came one tick
/// later, superseded the pending solution before its release, and with a latency of one
/// period no solution was ever released again (the watchdog held the robot still).
constexpr double kGridTolerance = 1e-6;
/// How long the asynchronous thread sleeps when it has nothing to do.
constexpr std::chrono::microseconds kIdleSleep{200};

double millisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

/// What one MPC solve does, whoever calls it and when: takes a newly published terrain,
/// follows the robot with the reference (leash), advances the contact plan, solves one
/// real-time iteration and copies the result into an MpcSolution. An exception from the
/// solve becomes a Diverged solution and is counted. Everything here runs on the solving
/// side (the caller in deterministic timing, the thread in asynchronous timing), except
/// publishTerrain (the terrain producer) and the counters' readers.
class MpcSolveStep {
 public:
  MpcSolveStep(const ControlSettings& settings, centroidal::CentroidalOcp& ocp)
      : settings_(settings), ocp_(ocp) {
    realtime_settings_ = settings_.ocp.solver;
    realtime_settings_.mode = solver::SolverMode::RealTime;
    solver_ = std::make_unique<solver::Solver>(ocp_.problem(), realtime_settings_);
  }

  int nx() const { return ocp_.problem()->nx(); }

  MpcSolution makeSolution() const {
    const ocp::OptimalControlProblem& problem = *ocp_.problem();
    const int n = problem.horizon();
    MpcSolution s;
    s.dt = problem.dt();
    s.xs.assign(static_cast<std::size_t>(n + 1), Eigen::VectorXd::Zero(problem.nx()));
    s.us.assign(static_cast<std::size_t>(n), Eigen::VectorXd::Zero(problem.nu()));
    s.modes.assign(static_cast<std::size_t>(n + 1), 0);
    return s;
  }

  /// Not real-time: the converging solve from a cold start (as `rollstep plan` does) after
  /// resetting the references at t0; restarts the counters and the solutions' sequence.
  /// `solve_ms`: its wall time.
  solver::SolverStatus initialSolve(double t0, const lie::SE3& start,
                                    const std::vector<planning::TimedBaseCommand>& schedule,
                                    const Eigen::VectorXd& x0, double& solve_ms) {
    ocp_.resetSchedule(t0, start, schedule);
    ocp_.anchorStanceFeet(ocp_.problem()->modeSchedule(), t0, x0);
    solver::SolverSettings converging = realtime_settings_;
    converging.mode = solver::SolverMode::Converging;
    converging.max_iterations = settings_.mpc.initial_iterations;
    solver_->setSettings(converging);
    ocp_.initialGuess(guess_xs_, guess_us_);
    guess_xs_[0] = x0;
    solver_->setInitialGuess(guess_xs_, guess_us_);
    const auto start_time = std::chrono::steady_clock::now();
    const solver::SolverStatus status = solver_->solve(x0);
    solve_ms = millisecondsSince(start_time);
    initial_iterations_ = solver_->iterations();
    initial_message_ = solver_->message();
    solver_->setSettings(realtime_settings_);

    sequence_ = 0;
    solves_started_.store(0, std::memory_order_relaxed);
    solve_exceptions_.store(0, std::memory_order_relaxed);
    first_exception_taken_.store(false, std::memory_order_relaxed);
    return status;
  }

  /// One real-time iteration from x at t (never allocates). An exception from the solve
  /// (a problem term, the observer) would end the process in the thread or through the
  /// noexcept post(): it becomes a Diverged solution, which the pipeline does not adopt,
  /// and is counted (solveExceptions(); the first one's message kept).
  solver::SolverStatus solve(double t, const Eigen::VectorXd& x) noexcept {
    solves_started_.fetch_add(1, std::memory_order_relaxed);
    try {
      return solveOrThrow(t, x);
    } catch (const std::exception& e) {
      noteException(e.what());
    } catch (...) {
      noteException("an exception not derived from std::exception");
    }
    return solver::SolverStatus::Diverged;
  }

  /// Copies the solver's result of a solve from the state at t into `out` (no allocation:
  /// same sizes), with the next sequence number.
  void fill(MpcSolution& out, double t, double release_time, solver::SolverStatus status,
            double solve_time_ms) {
    const ocp::OptimalControlProblem& problem = *ocp_.problem();
    out.sequence = ++sequence_;
    out.t0 = t;
    out.dt = problem.dt();
    const std::vector<Eigen::VectorXd>& xs = solver_->states();
    const std::vector<Eigen::VectorXd>& us = solver_->inputs();
    for (std::size_t k = 0; k < out.xs.size(); ++k) out.xs[k] = xs[k];
    for (std::size_t k = 0; k < out.us.size(); ++k) out.us[k] = us[k];
    for (std::size_t k = 0; k < out.modes.size(); ++k) {
      out.modes[k] = problem.context(static_cast<int>(k)).mode;
    }
    out.status = status;
    out.iterations = solver_->iterations();
    const std::vector<solver::IterationStats>& stats = solver_->stats();
    out.kkt_error = stats.empty() ? 0.0 : stats.back().kkt_error;
    out.primal_residual = stats.empty() ? 0.0 : stats.back().primal_residual;
    out.primal_step = stats.empty() ? 0.0 : stats.back().primal_step;
    out.solve_time_ms = solve_time_ms;
    out.release_time = release_time;
    out.terrain_version = terrain_version_.load(std::memory_order_relaxed);
    out.reference_correction = ocp_.baseReference().correction();
    out.gait_clock = ocp_.gaitClock();
  }

  /// Terrain producer: see MpcRunner::publishTerrain.
  std::uint64_t publishTerrain(const planning::TerrainModel& terrain) {
    // acceptsTerrain reads only the OCP's constant capacity and whether its terrain is empty
    // (which no accepted terrain changes): safe beside a solve in the thread.
    if (!ocp_.acceptsTerrain(terrain)) return 0;
    return terrain_in_.publish(terrain);
  }

  void setObserver(MpcRunner::SolveObserver observer) { observer_ = std::move(observer); }

  std::uint64_t terrainVersion() const { return terrain_version_.load(std::memory_order_relaxed); }
  std::uint64_t solvesStarted() const { return solves_started_.load(std::memory_order_relaxed); }
  std::uint64_t solveExceptions() const {
    return solve_exceptions_.load(std::memory_order_acquire);
  }
  const char* firstException() const { return first_exception_.data(); }
  int initialIterations() const { return initial_iterations_; }
  const std::string& initialMessage() const { return initial_message_; }

 private:
  solver::SolverStatus solveOrThrow(double t, const Eigen::VectorXd& x) {
    // A new terrain takes effect at the start of a solve (swapped in: no allocation).
    std::uint64_t version = 0;
    if (terrain_in_.take(incoming_terrain_, version) && ocp_.swapTerrain(incoming_terrain_)) {
      terrain_version_.store(version, std::memory_order_relaxed);
    }
    if (settings_.mpc.reference_leash > 0.0 || settings_.mpc.reference_leash_yaw > 0.0 ||
        settings_.mpc.reference_leash_lateral > 0.0) {
      // x = (base position, base quaternion x y z w, ...): the measured base pose.
      const lie::SE3 base(x.head<3>(), Eigen::Quaterniond(x[6], x[3], x[4], x[5]));
      ocp_.followRobot(t, base, settings_.mpc.reference_leash, settings_.mpc.reference_leash_yaw,
                       settings_.mpc.reference_leash_lateral);
    }
    ocp_.advance(t);
    ocp_.anchorStanceFeet(ocp_.problem()->modeSchedule(), t, x);
    ocp_.landLateFeet(ocp_.problem()->modeSchedule(), t, x);
    const solver::SolverStatus status = solver_->update(t, x);
    if (observer_) observer_(t, *ocp_.problem(), solver_->states(), solver_->inputs());
    return status;
  }

  void noteException(const char* what) noexcept {
    if (!first_exception_taken_.exchange(true, std::memory_order_relaxed)) {
      std::snprintf(first_exception_.data(), first_exception_.size(), "%s", what);
    }
    // Release: the message is written before a reader that sees the count reads it.
    solve_exceptions_.fetch_add(1, std::memory_order_release);
  }

  const ControlSettings& settings_;
  centroidal::CentroidalOcp& ocp_;
  solver::SolverSettings realtime_settings_;
  std::unique_ptr<solver::Solver> solver_;
  std::vector<Eigen::VectorXd> guess_xs_, guess_us_;
  std::uint64_t sequence_ = 0;         ///< of the last solution filled
  MpcRunner::SolveObserver observer_;  ///< diagnostics (setSolveObserver), empty by default

  // Terrains from the producer (publishTerrain) to the solving side.
  LatestValueMailbox<planning::TerrainModel> terrain_in_;
  planning::TerrainModel incoming_terrain_;
  std::atomic<std::uint64_t> terrain_version_{0};

  std::atomic<std::uint64_t> solves_started_{0};
  std::atomic<std::uint64_t> solve_exceptions_{0};
  std::atomic<bool> first_exception_taken_{false};
  std::array<char, 256> first_exception_{};  // written once, by the first exception
  int initial_iterations_ = 0;               ///< of the converging first solve
  std::string initial_message_;              ///< its Solver::message()
};

/// When the solves run: a driver owns the solutions between the solving side and poll().
/// post() and poll() run on the real-time thread and never allocate, lock or throw.
class MpcDriver {
 public:
  virtual ~MpcDriver() = default;
  /// Not real-time, no solve running: publishes the converging first solve (released at
  /// once, sequence 1) from t0 and starts solving.
  virtual void start(double t0, solver::SolverStatus status, double solve_ms) = 0;
  virtual void post(double t, const Eigen::VectorXd& x) noexcept = 0;
  virtual bool poll(double t, MpcSolution& out) noexcept = 0;
  /// Stops solving (joins a thread); idempotent.
  virtual void stop() = 0;
  /// Deterministic timing only (MpcRunner::injectFaults).
  virtual void injectFaults(const MpcFaultInjection& /*faults*/) {}
};

/// Deterministic timing: post() solves in the caller's thread on the grid t0 + k period,
/// and poll() releases each solution from its release time (t + latency), with the faults
/// injected: reproducible bit for bit.
class DeterministicDriver final : public MpcDriver {
 public:
  DeterministicDriver(const MpcSettings& settings, MpcSolveStep& step)
      : settings_(settings), step_(step) {
    for (MpcSolution& slot : solutions_) slot = step_.makeSolution();
  }

  void start(double t0, solver::SolverStatus status, double solve_ms) override {
    released_ = -1;
    pending_ = -1;
    for (MpcSolution& slot : solutions_) slot.sequence = 0;
    publish(t0, t0, status, solve_ms);
    grid_start_ = t0;
    next_index_ = 1;
  }

  void post(double t, const Eigen::VectorXd& x) noexcept override {
    const double period = settings_.period;
    if (t < grid_start_ + static_cast<double>(next_index_) * period - kGridTolerance * period) {
      return;
    }
    const auto start = std::chrono::steady_clock::now();
    const solver::SolverStatus status = step_.solve(t, x);
    double release = t + settings_.latency;
    const bool stall = t >= faults_.stall_at - kTimeTolerance && !stalled_;
    if (stall) {
      stalled_ = true;
      release += faults_.stall_duration;
    }
    publish(t, release, status, millisecondsSince(start));
    if (t >= faults_.fail_at - kTimeTolerance && failures_ < faults_.fail_count) {
      MpcSolution& s = solutions_[static_cast<std::size_t>(pending_)];
      if (failures_ % 2 == 0 && !s.xs.empty()) {
        s.xs.back()[0] = std::numeric_limits<double>::quiet_NaN();
      } else {
        s.status = solver::SolverStatus::Diverged;
      }
      ++failures_;
    }
    if (stall) {
      // The thread is busy until the release: the next solve starts after it.
      const double periods = std::floor((release - grid_start_) / period + kGridTolerance);
      next_index_ = static_cast<std::int64_t>(periods) + 1;
      return;
    }
    // The next solve time: the first point of the grid t_init + k period after t (one
    // period on when on time, further when more than a period behind).
    const double periods = std::floor((t - grid_start_) / period + kGridTolerance);
    next_index_ = static_cast<std::int64_t>(periods) + 1;
  }

  bool poll(double t, MpcSolution& out) noexcept override {
    if (pending_ >= 0 &&
        t >= solutions_[static_cast<std::size_t>(pending_)].release_time - kTimeTolerance) {
      released_ = pending_;
      pending_ = -1;
    }
    if (released_ < 0) return false;
    const MpcSolution& s = solutions_[static_cast<std::size_t>(released_)];
    if (s.sequence <= out.sequence) return false;
    out = s;  // same sizes: element-wise copies, no allocation
    return true;
  }

  void stop() override {}

  void injectFaults(const MpcFaultInjection& faults) override {
    faults_ = faults;
    stalled_ = false;
    failures_ = 0;
  }

 private:
  /// Publishes the solver's result of a solve at t: the pending one, released at
  /// release_time; a pending solution already released becomes the released one first.
  void publish(double t, double release_time, solver::SolverStatus status, double solve_ms) {
    if (pending_ >= 0) {
      // Released by now: kept for poll(); otherwise superseded (latency above the period,
      // which checkSettings refuses).
      if (t >= solutions_[static_cast<std::size_t>(pending_)].release_time - kTimeTolerance) {
        released_ = pending_;
      }
      pending_ = -1;
    }
    const int slot = released_ == 0 ? 1 : 0;
    step_.fill(solutions_[static_cast<std::size_t>(slot)], t, release_time, status, solve_ms);
    pending_ = slot;
  }

  const MpcSettings& settings_;
  MpcSolveStep& step_;
  /// The released and the pending solution (-1: none).
  std::array<MpcSolution, 2> solutions_;
  int released_ = -1, pending_ = -1;
  // Solves on the grid grid_start + k period, the next one at k = next_index.
  double grid_start_ = 0.0;
  std::int64_t next_index_ = 1;
  MpcFaultInjection faults_;
  bool stalled_ = false;
  int failures_ = 0;
};

/// Asynchronous timing: a thread of its own solves back to back (at most once per period
/// of wall time) on the newest posted state; poll() hands out the newest finished solution.
/// Both hand-overs are latest-value mailboxes.
class ThreadDriver final : public MpcDriver {
 public:
  ThreadDriver(const MpcSettings& settings, MpcSolveStep& step)
      : settings_(settings),
        step_(step),
        states_(PostedState{0.0, Eigen::VectorXd::Zero(step.nx())}),
        solutions_(step.makeSolution()) {}
  ~ThreadDriver() override { stop(); }

  void start(double t0, solver::SolverStatus status, double solve_ms) override {
    states_.reset();
    solutions_.reset();
    solutions_.forEachSlot([](MpcSolution& s) { s.sequence = 0; });
    step_.fill(solutions_.writable(), t0, t0, status, solve_ms);
    solutions_.publish();
    stop_requested_.store(false, std::memory_order_relaxed);
    thread_ = std::thread([this] { run(); });
  }

  void post(double t, const Eigen::VectorXd& x) noexcept override {
    PostedState& slot = states_.writable();
    slot.t = t;
    slot.x = x;  // same size: no allocation
    states_.publish();
  }

  bool poll(double /*t*/, MpcSolution& out) noexcept override {
    solutions_.take();
    const MpcSolution& s = solutions_.current();
    if (s.sequence <= out.sequence) return false;
    out = s;
    return true;
  }

  void stop() override {
    stop_requested_.store(true, std::memory_order_release);
    if (thread_.joinable()) thread_.join();
  }

 private:
  /// A state handed from post() to the thread.
  struct PostedState {
    double t = 0.0;
    Eigen::VectorXd x;
  };

  void run() {
    using Clock = std::chrono::steady_clock;
    Clock::time_point last_start = Clock::now();
    bool first = true;
    const auto min_gap = std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(settings_.period));
    while (!stop_requested_.load(std::memory_order_acquire)) {
      if (!first && Clock::now() < last_start + min_gap) {
        std::this_thread::sleep_for(
            std::min<Clock::duration>(kIdleSleep, last_start + min_gap - Clock::now()));
        continue;
      }
      // The newest posted state, if there is one the thread has not solved from yet.
      if (!states_.take()) {
        std::this_thread::sleep_for(kIdleSleep);
        continue;
      }
      const PostedState& state = states_.current();
      first = false;
      last_start = Clock::now();
      const solver::SolverStatus status = step_.solve(state.t, state.x);
      step_.fill(solutions_.writable(), state.t, state.t, status, millisecondsSince(last_start));
      solutions_.publish();
    }
  }

  const MpcSettings& settings_;
  MpcSolveStep& step_;
  LatestValueMailbox<PostedState> states_;     // post() -> thread
  LatestValueMailbox<MpcSolution> solutions_;  // thread -> poll()
  std::thread thread_;
  std::atomic<bool> stop_requested_{false};
};

}  // namespace

bool MpcSolution::usable() const {
  switch (status) {
    case solver::SolverStatus::IterationDone:
    case solver::SolverStatus::Converged:
    case solver::SolverStatus::Acceptable:
    case solver::SolverStatus::MaxIterations:
      break;
    default:
      return false;
  }
  if (xs.empty() || xs.size() != us.size() + 1) return false;
  for (const Eigen::VectorXd& x : xs) {
    if (!x.allFinite()) return false;
  }
  for (const Eigen::VectorXd& u : us) {
    if (!u.allFinite()) return false;
  }
  return true;
}

/// The solve step and the driver of the configured timing; what the runner itself checks.
struct MpcRunner::Impl {
  Impl(const ControlSettings& settings, centroidal::CentroidalOcp& ocp) : step(settings, ocp) {
    if (settings.mpc.timing == MpcTiming::Deterministic) {
      driver = std::make_unique<DeterministicDriver>(settings.mpc, step);
    } else {
      driver = std::make_unique<ThreadDriver>(settings.mpc, step);
    }
  }

  MpcSolveStep step;
  std::unique_ptr<MpcDriver> driver;
  bool initialized = false;
  std::atomic<bool> stopped{false};
  std::atomic<std::uint64_t> rejected{0};
};

MpcRunner::MpcRunner(const centroidal::RobotOcpDescription& robot, const ControlSettings& settings,
                     planning::TerrainModel terrain, planning::GaitKind gait,
                     int region_edge_capacity)
    : settings_(settings) {
  checkSettings(settings_);
  ocp_ = std::make_unique<centroidal::CentroidalOcp>(robot, settings_.ocp, std::move(terrain), gait,
                                                     region_edge_capacity);
  impl_ = std::make_unique<Impl>(settings_, *ocp_);
}

MpcRunner::~MpcRunner() { stop(); }

solver::SolverStatus MpcRunner::initialize(double t0, const lie::SE3& start,
                                           const planning::BaseVelocityCommand& command,
                                           const Eigen::VectorXd& x0) {
  return initializeSchedule(t0, start, std::vector<planning::TimedBaseCommand>{{0.0, command}}, x0);
}

solver::SolverStatus MpcRunner::initializeSchedule(
    double t0, const lie::SE3& start, const std::vector<planning::TimedBaseCommand>& schedule,
    const Eigen::VectorXd& x0) {
  Impl& m = *impl_;
  const int nx = m.step.nx();
  if (x0.size() != nx) {
    throw std::invalid_argument("MpcRunner::initialize: x0 has size " + std::to_string(x0.size()) +
                                ", expected " + std::to_string(nx) + " (the centroidal state)");
  }
  if (!x0.allFinite()) throw std::invalid_argument("MpcRunner::initialize: x0 is not finite");
  if (!std::isfinite(t0)) throw std::invalid_argument("MpcRunner::initialize: t0 is not finite");
  m.driver->stop();  // a second initialize() restarts from scratch
  m.stopped.store(false, std::memory_order_relaxed);
  m.initialized = false;

  double solve_ms = 0.0;
  const solver::SolverStatus status = m.step.initialSolve(t0, start, schedule, x0, solve_ms);
  m.rejected.store(0, std::memory_order_relaxed);
  m.driver->start(t0, status, solve_ms);
  m.initialized = true;
  return status;
}

void MpcRunner::setSolveObserver(SolveObserver observer) {
  impl_->step.setObserver(std::move(observer));
}

void MpcRunner::injectFaults(const MpcFaultInjection& faults) {
  impl_->driver->injectFaults(faults);
}

void MpcRunner::post(double t, const Eigen::VectorXd& x) noexcept {
  Impl& m = *impl_;
  if (!m.initialized || m.stopped.load(std::memory_order_relaxed)) return;
  if (x.size() != m.step.nx() || !x.allFinite() || !std::isfinite(t)) {
    m.rejected.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  m.driver->post(t, x);
}

bool MpcRunner::poll(double t, MpcSolution& out) noexcept {
  Impl& m = *impl_;
  if (!m.initialized) return false;
  return m.driver->poll(t, out);
}

MpcSolution MpcRunner::makeSolution() const { return impl_->step.makeSolution(); }

std::uint64_t MpcRunner::publishTerrain(const planning::TerrainModel& terrain) {
  return impl_->step.publishTerrain(terrain);
}

std::uint64_t MpcRunner::terrainVersion() const { return impl_->step.terrainVersion(); }

void MpcRunner::stop() {
  if (!impl_) return;
  impl_->stopped.store(true, std::memory_order_relaxed);
  impl_->driver->stop();
}

std::uint64_t MpcRunner::solvesStarted() const { return impl_->step.solvesStarted(); }

std::uint64_t MpcRunner::rejectedStates() const {
  return impl_->rejected.load(std::memory_order_relaxed);
}

std::uint64_t MpcRunner::solveExceptions() const { return impl_->step.solveExceptions(); }

const char* MpcRunner::firstSolveException() const {
  return solveExceptions() > 0 ? impl_->step.firstException() : "";
}

int MpcRunner::initialIterations() const { return impl_->step.initialIterations(); }

const std::string& MpcRunner::initialMessage() const { return impl_->step.initialMessage(); }

}  // namespace rollstep::control
