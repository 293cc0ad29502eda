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

/// Lock-free triple buffer indices: the producer owns one slot, the consumer one, and the
/// third ("middle") is exchanged through an atomic, kDirty marking it as newer than what
/// the consumer holds. Neither side ever waits for the other.
constexpr int kIndexMask = 3;
constexpr int kDirty = 4;

class TripleBufferIndices {
 public:
  /// Producer: the slot it may write.
  int writeSlot() const { return write_; }
  /// Producer: publishes the slot just written, takes another one to write next.
  void publish() {
    write_ = middle_.exchange(write_ | kDirty, std::memory_order_acq_rel) & kIndexMask;
  }
  /// Consumer: takes the newest published slot if one was published since the last take
  /// (then true); readSlot() is the slot it holds.
  bool take() {
    if ((middle_.load(std::memory_order_acquire) & kDirty) == 0) return false;
    read_ = middle_.exchange(read_, std::memory_order_acq_rel) & kIndexMask;
    return true;
  }
  int readSlot() const { return read_; }
  /// Not concurrent with the others: back to the start.
  void reset() {
    write_ = 0;
    middle_.store(1, std::memory_order_relaxed);
    read_ = 2;
  }

 private:
  int write_ = 0;               // producer's
  std::atomic<int> middle_{1};  // shared
  int read_ = 2;                // consumer's
};

double millisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

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

struct MpcRunner::Impl {
  /// A state handed from post() to the asynchronous thread.
  struct PostedState {
    double t = 0.0;
    Eigen::VectorXd x;
  };

  Impl(const ControlSettings& s, centroidal::CentroidalOcp& o) : settings(s), ocp(o) {
    solver::SolverSettings realtime = settings.ocp.solver;
    realtime.mode = solver::SolverMode::RealTime;
    realtime_settings = realtime;
    solver = std::make_unique<solver::Solver>(ocp.problem(), realtime);
    const ocp::OptimalControlProblem& problem = *ocp.problem();
    nx = problem.nx();
    for (MpcSolution& slot : solutions) slot = makeSolution();
    for (PostedState& slot : states) slot.x = Eigen::VectorXd::Zero(nx);
  }

  MpcSolution makeSolution() const {
    const ocp::OptimalControlProblem& problem = *ocp.problem();
    const int n = problem.horizon();
    MpcSolution s;
    s.dt = problem.dt();
    s.xs.assign(static_cast<std::size_t>(n + 1), Eigen::VectorXd::Zero(problem.nx()));
    s.us.assign(static_cast<std::size_t>(n), Eigen::VectorXd::Zero(problem.nu()));
    s.modes.assign(static_cast<std::size_t>(n + 1), 0);
    return s;
  }

  /// Copies the solver's result of a solve from the state at t into `out` (no allocation:
  /// same sizes).
  void fill(MpcSolution& out, double t, double release_time, solver::SolverStatus status,
            double solve_time_ms) {
    const ocp::OptimalControlProblem& problem = *ocp.problem();
    out.sequence = ++sequence;
    out.t0 = t;
    out.dt = problem.dt();
    const std::vector<Eigen::VectorXd>& xs = solver->states();
    const std::vector<Eigen::VectorXd>& us = solver->inputs();
    for (std::size_t k = 0; k < out.xs.size(); ++k) out.xs[k] = xs[k];
    for (std::size_t k = 0; k < out.us.size(); ++k) out.us[k] = us[k];
    for (std::size_t k = 0; k < out.modes.size(); ++k) {
      out.modes[k] = problem.context(static_cast<int>(k)).mode;
    }
    out.status = status;
    out.iterations = solver->iterations();
    const std::vector<solver::IterationStats>& stats = solver->stats();
    out.kkt_error = stats.empty() ? 0.0 : stats.back().kkt_error;
    out.primal_residual = stats.empty() ? 0.0 : stats.back().primal_residual;
    out.primal_step = stats.empty() ? 0.0 : stats.back().primal_step;
    out.solve_time_ms = solve_time_ms;
    out.release_time = release_time;
    out.terrain_version = terrain_version.load(std::memory_order_relaxed);
    out.reference_correction = ocp.baseReference().correction();
    out.gait_clock = ocp.gaitClock();
  }

  /// One real-time iteration from x at t (never allocates). An exception from the solve
  /// (a problem term, the observer) would end the process in the thread or through the
  /// noexcept post(): it becomes a Diverged solution, which the pipeline does not adopt,
  /// and is counted (solveExceptions(); the first one's message kept).
  solver::SolverStatus solveRealTime(double t, const Eigen::VectorXd& x) noexcept {
    solves_started.fetch_add(1, std::memory_order_relaxed);
    try {
      return solveRealTimeOrThrow(t, x);
    } catch (const std::exception& e) {
      noteSolveException(e.what());
    } catch (...) {
      noteSolveException("an exception not derived from std::exception");
    }
    return solver::SolverStatus::Diverged;
  }

  void noteSolveException(const char* what) noexcept {
    if (!first_exception_taken.exchange(true, std::memory_order_relaxed)) {
      std::snprintf(first_exception.data(), first_exception.size(), "%s", what);
    }
    // Release: the message is written before a reader that sees the count reads it.
    solve_exceptions.fetch_add(1, std::memory_order_release);
  }

  solver::SolverStatus solveRealTimeOrThrow(double t, const Eigen::VectorXd& x) {
    // A new terrain takes effect at the start of a solve (swapped in: no allocation).
    std::uint64_t version = 0;
    if (terrain_in.take(incoming_terrain, version) && ocp.swapTerrain(incoming_terrain)) {
      terrain_version.store(version, std::memory_order_relaxed);
    }
    if (settings.mpc.reference_leash > 0.0 || settings.mpc.reference_leash_yaw > 0.0) {
      // x = (base position, base quaternion x y z w, ...): the measured base pose.
      const lie::SE3 base(x.head<3>(), Eigen::Quaterniond(x[6], x[3], x[4], x[5]));
      ocp.followRobot(t, base, settings.mpc.reference_leash, settings.mpc.reference_leash_yaw);
    }
    ocp.advance(t);
    ocp.anchorStanceFeet(ocp.problem()->modeSchedule(), t, x);
    ocp.landLateFeet(ocp.problem()->modeSchedule(), t, x);
    const solver::SolverStatus status = solver->update(t, x);
    if (observer) observer(t, *ocp.problem(), solver->states(), solver->inputs());
    return status;
  }

  // --- deterministic timing (the caller's thread only) -----------------------------------
  /// Publishes the solver's result of a solve at t: the pending one, released at
  /// release_time; a pending solution already released becomes the released one first.
  void publishDeterministic(double t, double release_time, solver::SolverStatus status,
                            double solve_time_ms) {
    if (pending >= 0) {
      // Released by now: kept for poll(); otherwise superseded (latency above the period,
      // which checkSettings refuses).
      if (t >= solutions[static_cast<std::size_t>(pending)].release_time - kTimeTolerance) {
        released = pending;
      }
      pending = -1;
    }
    int slot = 0;
    while (slot == released) ++slot;
    fill(solutions[static_cast<std::size_t>(slot)], t, release_time, status, solve_time_ms);
    pending = slot;
  }

  void postDeterministic(double t, const Eigen::VectorXd& x) {
    const double period = settings.mpc.period;
    if (t < grid_start + static_cast<double>(next_index) * period - kGridTolerance * period) {
      return;
    }
    const auto start = std::chrono::steady_clock::now();
    const solver::SolverStatus status = solveRealTime(t, x);
    double release = t + settings.mpc.latency;
    const bool stall = t >= faults.stall_at - kTimeTolerance && !stalled;
    if (stall) {
      stalled = true;
      release += faults.stall_duration;
    }
    publishDeterministic(t, release, status, millisecondsSince(start));
    if (t >= faults.fail_at - kTimeTolerance && failures < faults.fail_count) {
      MpcSolution& s = solutions[static_cast<std::size_t>(pending)];
      if (failures % 2 == 0 && !s.xs.empty()) {
        s.xs.back()[0] = std::numeric_limits<double>::quiet_NaN();
      } else {
        s.status = solver::SolverStatus::Diverged;
      }
      ++failures;
    }
    if (stall) {
      // The thread is busy until the release: the next solve starts after it.
      const double periods = std::floor((release - grid_start) / period + kGridTolerance);
      next_index = static_cast<std::int64_t>(periods) + 1;
      return;
    }
    // The next solve time: the first point of the grid t_init + k period after t (one
    // period on when on time, further when more than a period behind).
    const double periods = std::floor((t - grid_start) / period + kGridTolerance);
    next_index = static_cast<std::int64_t>(periods) + 1;
  }

  bool pollDeterministic(double t, MpcSolution& out) {
    if (pending >= 0 &&
        t >= solutions[static_cast<std::size_t>(pending)].release_time - kTimeTolerance) {
      released = pending;
      pending = -1;
    }
    if (released < 0) return false;
    const MpcSolution& s = solutions[static_cast<std::size_t>(released)];
    if (s.sequence <= out.sequence) return false;
    out = s;  // same sizes: element-wise copies, no allocation
    return true;
  }

  // --- asynchronous timing --------------------------------------------------------------
  void run() {
    using Clock = std::chrono::steady_clock;
    Clock::time_point last_start = Clock::now();
    bool first = true;
    const auto min_gap = std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(settings.mpc.period));
    while (!stop_requested.load(std::memory_order_acquire)) {
      if (!first && Clock::now() < last_start + min_gap) {
        std::this_thread::sleep_for(
            std::min<Clock::duration>(kIdleSleep, last_start + min_gap - Clock::now()));
        continue;
      }
      // The newest posted state, if there is one the thread has not solved from yet.
      if (!state_buffer.take()) {
        std::this_thread::sleep_for(kIdleSleep);
        continue;
      }
      const PostedState& state = states[static_cast<std::size_t>(state_buffer.readSlot())];
      first = false;
      last_start = Clock::now();
      const solver::SolverStatus status = solveRealTime(state.t, state.x);
      MpcSolution& slot = solutions[static_cast<std::size_t>(solution_buffer.writeSlot())];
      fill(slot, state.t, state.t, status, millisecondsSince(last_start));
      solution_buffer.publish();
    }
  }

  void postAsynchronous(double t, const Eigen::VectorXd& x) {
    PostedState& slot = states[static_cast<std::size_t>(state_buffer.writeSlot())];
    slot.t = t;
    slot.x = x;  // same size: no allocation
    state_buffer.publish();
  }

  bool pollAsynchronous(MpcSolution& out) {
    solution_buffer.take();
    const MpcSolution& s = solutions[static_cast<std::size_t>(solution_buffer.readSlot())];
    if (s.sequence <= out.sequence) return false;
    out = s;
    return true;
  }

  void stopThread() {
    stop_requested.store(true, std::memory_order_release);
    if (thread.joinable()) thread.join();
  }

  const ControlSettings& settings;
  centroidal::CentroidalOcp& ocp;
  solver::SolverSettings realtime_settings;
  std::unique_ptr<solver::Solver> solver;
  int nx = 0;
  std::vector<Eigen::VectorXd> guess_xs, guess_us;

  /// Written by the solving side only (the caller in deterministic mode, the thread in
  /// asynchronous mode, initialize() before the thread starts).
  std::uint64_t sequence = 0;
  std::array<MpcSolution, 3> solutions;
  // Deterministic: the released and pending slots (-1: none); solves on the grid
  // grid_start + k period, the next one at k = next_index.
  int released = -1, pending = -1;
  MpcFaultInjection faults;
  MpcRunner::SolveObserver observer;  ///< diagnostics (setSolveObserver), empty by default
  bool stalled = false;
  int failures = 0;
  double grid_start = 0.0;
  std::int64_t next_index = 1;
  // Asynchronous: triple buffers of posted states (post() -> thread) and of solutions
  // (thread -> poll()).
  std::array<PostedState, 3> states;
  TripleBufferIndices state_buffer, solution_buffer;
  std::thread thread;
  std::atomic<bool> stop_requested{false};

  // Terrains from the producer (publishTerrain) to the solving side.
  LatestValueExchange<planning::TerrainModel> terrain_in;
  planning::TerrainModel incoming_terrain;
  std::atomic<std::uint64_t> terrain_version{0};

  bool initialized = false;
  std::atomic<bool> stopped{false};
  std::atomic<std::uint64_t> solves_started{0};
  std::atomic<std::uint64_t> rejected{0};
  std::atomic<std::uint64_t> solve_exceptions{0};
  std::atomic<bool> first_exception_taken{false};
  std::array<char, 256> first_exception{};  // written once, by the first exception
  int initial_iterations = 0;               ///< of the converging first solve (initialize())
  std::string initial_message;              ///< its Solver::message()
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
  if (x0.size() != m.nx) {
    throw std::invalid_argument("MpcRunner::initialize: x0 has size " + std::to_string(x0.size()) +
                                ", expected " + std::to_string(m.nx) + " (the centroidal state)");
  }
  if (!x0.allFinite()) throw std::invalid_argument("MpcRunner::initialize: x0 is not finite");
  if (!std::isfinite(t0)) throw std::invalid_argument("MpcRunner::initialize: t0 is not finite");
  m.stopThread();  // a second initialize() restarts from scratch
  m.stop_requested.store(false, std::memory_order_relaxed);
  m.stopped.store(false, std::memory_order_relaxed);
  m.initialized = false;

  // The converging solve from a cold start (as `rollstep plan` does).
  ocp_->resetSchedule(t0, start, schedule);
  ocp_->anchorStanceFeet(ocp_->problem()->modeSchedule(), t0, x0);
  solver::SolverSettings converging = m.realtime_settings;
  converging.mode = solver::SolverMode::Converging;
  converging.max_iterations = settings_.mpc.initial_iterations;
  m.solver->setSettings(converging);
  ocp_->initialGuess(m.guess_xs, m.guess_us);
  m.guess_xs[0] = x0;
  m.solver->setInitialGuess(m.guess_xs, m.guess_us);
  const auto start_time = std::chrono::steady_clock::now();
  const solver::SolverStatus status = m.solver->solve(x0);
  const double solve_ms = millisecondsSince(start_time);
  m.initial_iterations = m.solver->iterations();
  m.initial_message = m.solver->message();
  m.solver->setSettings(m.realtime_settings);

  // Publish it, released at once, as sequence 1.
  m.sequence = 0;
  m.solves_started.store(0, std::memory_order_relaxed);
  m.rejected.store(0, std::memory_order_relaxed);
  m.solve_exceptions.store(0, std::memory_order_relaxed);
  m.first_exception_taken.store(false, std::memory_order_relaxed);
  m.released = -1;
  m.pending = -1;
  for (MpcSolution& slot : m.solutions) slot.sequence = 0;
  if (settings_.mpc.timing == MpcTiming::Deterministic) {
    m.publishDeterministic(t0, t0, status, solve_ms);
    m.grid_start = t0;
    m.next_index = 1;
  } else {
    m.state_buffer.reset();
    m.solution_buffer.reset();
    m.fill(m.solutions[static_cast<std::size_t>(m.solution_buffer.writeSlot())], t0, t0, status,
           solve_ms);
    m.solution_buffer.publish();
    m.thread = std::thread([&m] { m.run(); });
  }
  m.initialized = true;
  return status;
}

void MpcRunner::setSolveObserver(SolveObserver observer) { impl_->observer = std::move(observer); }

void MpcRunner::injectFaults(const MpcFaultInjection& faults) {
  impl_->faults = faults;
  impl_->stalled = false;
  impl_->failures = 0;
}

void MpcRunner::post(double t, const Eigen::VectorXd& x) noexcept {
  Impl& m = *impl_;
  if (!m.initialized || m.stopped.load(std::memory_order_relaxed)) return;
  if (x.size() != m.nx || !x.allFinite() || !std::isfinite(t)) {
    m.rejected.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  if (settings_.mpc.timing == MpcTiming::Deterministic) {
    m.postDeterministic(t, x);
  } else {
    m.postAsynchronous(t, x);
  }
}

bool MpcRunner::poll(double t, MpcSolution& out) noexcept {
  Impl& m = *impl_;
  if (!m.initialized) return false;
  return settings_.mpc.timing == MpcTiming::Deterministic ? m.pollDeterministic(t, out)
                                                          : m.pollAsynchronous(out);
}

MpcSolution MpcRunner::makeSolution() const { return impl_->makeSolution(); }

std::uint64_t MpcRunner::publishTerrain(const planning::TerrainModel& terrain) {
  // acceptsTerrain reads only the OCP's constant capacity and whether its terrain is empty
  // (which no accepted terrain changes): safe beside a solve in the thread.
  if (!ocp_->acceptsTerrain(terrain)) return 0;
  return impl_->terrain_in.publish(terrain);
}

std::uint64_t MpcRunner::terrainVersion() const {
  return impl_->terrain_version.load(std::memory_order_relaxed);
}

void MpcRunner::stop() {
  if (!impl_) return;
  impl_->stopped.store(true, std::memory_order_relaxed);
  impl_->stopThread();
}

std::uint64_t MpcRunner::solvesStarted() const {
  return impl_->solves_started.load(std::memory_order_relaxed);
}

std::uint64_t MpcRunner::rejectedStates() const {
  return impl_->rejected.load(std::memory_order_relaxed);
}

std::uint64_t MpcRunner::solveExceptions() const {
  return impl_->solve_exceptions.load(std::memory_order_acquire);
}

const char* MpcRunner::firstSolveException() const {
  return solveExceptions() > 0 ? impl_->first_exception.data() : "";
}

int MpcRunner::initialIterations() const { return impl_->initial_iterations; }

const std::string& MpcRunner::initialMessage() const { return impl_->initial_message; }

}  // namespace rollstep::control
