#pragma once
// The MPC runner: solves the full-centroidal OCP on the latest state and contact plan and
// publishes its solutions to the real-time loop without blocking it (paper Sec. 3.3).
//
//   Deterministic  post() solves in the caller's thread when a period of loop time has
//                  passed since the last solve, and the result is released by poll() from
//                  latency later: reproducible bit for bit (same inputs, same outputs).
//   Asynchronous   a thread of its own solves back to back (or every period of wall time)
//                  on the newest posted state; poll() returns the newest finished solution.
//
// What a solve does (terrain hand-over, reference leash, contact plan, one real-time
// iteration, an exception turned into a failed solution) is one solve step; the two
// timings are two drivers of it (the deterministic one also injects faults).
// The contact plan is the OCP's gait advanced to the solve's start time (the gait cycle
// starts at t = 0), the same schedule the real-time loop's contact planner computes.
//
// Real-time contract: post() and poll() never allocate, lock or throw (latest-value
// mailboxes between the threads, common/latest_value_mailbox.hpp; in deterministic mode
// post() runs the allocation-free solver update). Construction and initialize() allocate
// and may throw.
#include <Eigen/Core>
#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "rollstep/centroidal/centroidal_ocp.hpp"
#include "rollstep/control/control_settings.hpp"
#include "rollstep/solver/solver.hpp"

namespace rollstep::control {

/// One published MPC solution, sized once (N + 1 states, N inputs, N + 1 modes).
struct MpcSolution {
  std::uint64_t sequence = 0;  ///< 1, 2, ... in publication order; 0: empty
  double t0 = 0.0;             ///< [s] time of node 0 (= the time of the state it started from)
  double dt = 0.0;             ///< [s] node step
  std::vector<Eigen::VectorXd> xs;  ///< x_0..x_N (centroidal state, robot.hpp layout)
  std::vector<Eigen::VectorXd> us;  ///< u_0..u_{N-1}
  std::vector<int> modes;           ///< contact mask of each node 0..N
  solver::SolverStatus status = solver::SolverStatus::InvalidInput;
  int iterations = 0;
  double kkt_error = 0.0;        ///< scaled KKT error of the last iteration (stats())
  double primal_residual = 0.0;  ///< of the last iteration (before its step)
  /// Primal step length of the last iteration (IterationStats::primal_step). The initial
  /// state is a constraint of the iteration like the defects: x_0 equals the state the
  /// solve started from when this is 1; a step cut by the fraction to the boundary (< 1)
  /// moves x_0 only that share of the way there (the next solves close the rest). 0 for a
  /// converging solve (its last entry holds the final residuals, no step).
  double primal_step = 0.0;
  double solve_time_ms = 0.0;  ///< wall time of the solve (not reproducible)
  /// Version of the terrain it was solved on (MpcRunner::publishTerrain; 0: the initial).
  std::uint64_t terrain_version = 0;
  /// The planar correction of the base reference it was solved on (MpcSettings::
  /// reference_leash; identity with the leash off): the real-time side plans on the same.
  lie::SE3 reference_correction;
  /// The gait's clock it was solved on (its edge holds, CentroidalOcp::gaitClock):
  /// the real-time side fills its contact schedule through the same.
  planning::GaitClock gait_clock;
  /// Deterministic mode: loop time from which poll() hands it out (t0 + latency).
  /// Asynchronous mode and the first solution: t0 (handed out as soon as it is finished).
  double release_time = 0.0;

  int horizon() const { return static_cast<int>(us.size()); }
  /// True if the solve ended with a usable iterate: IterationDone, Converged, Acceptable or
  /// MaxIterations with every state and input finite.
  bool usable() const;
};

/// Faults injected into the deterministic MPC (fault drills and tests; nothing by default):
/// the first solve at or after stall_at [s] delivers its solution stall_duration [s] late and
/// no solve starts meanwhile (a stalled MPC thread); the first fail_count solutions at or
/// after fail_at [s] are published broken, alternately with a non-finite state (status
/// fine) and with a failure status (SolverStatus::Diverged). The solver itself is untouched.
struct MpcFaultInjection {
  double stall_at = std::numeric_limits<double>::infinity();
  double stall_duration = 0.0;
  double fail_at = std::numeric_limits<double>::infinity();
  int fail_count = 0;
};

class MpcRunner {
 public:
  /// Builds the OCP (its own CentroidalOcp) and the solver in real-time mode from
  /// settings.ocp; settings.mpc gives the timing. Throws std::invalid_argument /
  /// std::runtime_error naming what is wrong.
  /// `region_edge_capacity`: CentroidalOcp's (the most edges of a region of any terrain
  /// published later; 0: the initial terrain's).
  MpcRunner(const centroidal::RobotOcpDescription& robot, const ControlSettings& settings,
            planning::TerrainModel terrain, planning::GaitKind gait, int region_edge_capacity = 0);
  ~MpcRunner();  ///< stops the thread (asynchronous mode)
  MpcRunner(const MpcRunner&) = delete;
  MpcRunner& operator=(const MpcRunner&) = delete;

  /// Not real-time. Resets the references at t0 (start pose and command as
  /// CentroidalOcp::reset), solves from x0 in converging mode from a cold start (the OCP's
  /// initial guess with x_0 = x0, at most mpc.initial_iterations iterations), publishes that
  /// solution (released at once, sequence 1) and, in asynchronous mode, starts the thread.
  /// Returns the converging solve's status; throws std::invalid_argument for a non-finite
  /// or wrongly sized x0.
  solver::SolverStatus initialize(double t0, const lie::SE3& start,
                                  const planning::BaseVelocityCommand& command,
                                  const Eigen::VectorXd& x0);
  /// Same with a command schedule (planning::BaseReference::reset).
  solver::SolverStatus initializeSchedule(double t0, const lie::SE3& start,
                                          const std::vector<planning::TimedBaseCommand>& schedule,
                                          const Eigen::VectorXd& x0);

  /// Real-time thread: the latest state x (centroidal layout) at loop time t.
  /// Deterministic: solves now if t has reached the next solve time (then the next one is a
  /// period later). Asynchronous: hands x to the thread. Non-finite x is ignored (counted in
  /// rejectedStates()).
  void post(double t, const Eigen::VectorXd& x) noexcept;
  /// Real-time thread: if a solution newer than out.sequence is available at loop time t,
  /// copies it into `out` (sized by makeSolution()) and returns true.
  bool poll(double t, MpcSolution& out) noexcept;

  /// Producer of terrains (one thread, not real-time: copies `terrain`): the next solve
  /// that starts after this call solves on it (in the solving thread, at the start of the
  /// solve, without allocating). Returns its version (1, 2, ...; the solutions carry it),
  /// or 0 when the OCP refuses it (CentroidalOcp::acceptsTerrain: empty, or regions with
  /// more edges than the OCP's capacity; the terrain in use stays).
  std::uint64_t publishTerrain(const planning::TerrainModel& terrain);
  /// Version of the terrain the last solve started on (the solving side's; 0: initial).
  std::uint64_t terrainVersion() const;

  /// An MpcSolution sized for this problem (allocates; for the caller's buffers).
  MpcSolution makeSolution() const;
  /// Stops the thread (asynchronous mode); idempotent. post() is ignored afterwards.
  void stop();

  /// Deterministic timing only (asynchronous: ignored). Not real-time.
  void injectFaults(const MpcFaultInjection& faults);

  /// Diagnostics: called after every real-time solve, in the solving thread, with the time
  /// solved from, the problem as solved and the solver's trajectory. It may allocate and
  /// takes the solve's time, so it is for analysis runs, not for the real-time loop. Set
  /// it before the first post() (not synchronised with a running thread). If it throws,
  /// the solve counts as failed (solveExceptions()).
  using SolveObserver = std::function<void(double t, const ocp::OptimalControlProblem& problem,
                                           const std::vector<Eigen::VectorXd>& xs,
                                           const std::vector<Eigen::VectorXd>& us)>;
  void setSolveObserver(SolveObserver observer);

  const centroidal::CentroidalOcp& ocp() const { return *ocp_; }
  const ControlSettings& settings() const { return settings_; }
  /// Real-time solves started since initialize() (the converging first one not counted).
  std::uint64_t solvesStarted() const;
  /// States post() ignored since initialize(): non-finite or of the wrong size.
  std::uint64_t rejectedStates() const;
  /// Real-time solves since initialize() that threw (a problem term, the solve observer):
  /// each published as a Diverged solution instead of ending the process; and the first
  /// one's message ("" when none).
  std::uint64_t solveExceptions() const;
  const char* firstSolveException() const;
  /// What the converging first solve of the last initialize() ended with: its iteration
  /// count and the solver's message (Solver::message(); empty after a clean convergence),
  /// kept from the later real-time solves that overwrite the solver's own.
  int initialIterations() const;
  const std::string& initialMessage() const;

 private:
  struct Impl;
  ControlSettings settings_;
  std::unique_ptr<centroidal::CentroidalOcp> ocp_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rollstep::control
