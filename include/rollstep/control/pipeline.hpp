#pragma once
// The 1 kHz control pipeline (paper Sec. 3.3, Fig. 5; DESIGN.md section 5). Every tick:
//
//   state (estimator or ground truth, RobotState)
//   -> MPC runner: post the state; take a newer solution if one is ready
//   -> time-lag refinement of a new solution from the latest state (ReferenceTrajectory)
//   -> contact planner: the gait's mode and each foot's regions at t
//   -> reference at t: base pose/twist/acceleration, feet position/velocity/acceleration,
//      joints; acceleration commands = feedforward + Kp, Kd feedback against the INTERNAL
//      integrator state
//   -> CBF-QP safety filter (contact consistency, joint limits, foothold regions,
//      leg/terrain clearance)
//   -> internal state integrator (measured state blended in)
//   -> joint position commands (hips, knees) and drive-wheel velocity commands.
//
// Drive-wheel speed (relative to its shank): the wheel centre's velocity along the wheel's
// heading (the contact frame's x axis projected on the ground) over the wheel radius (the
// robot's contact offset), minus the shank's own rotation rate about the axle (the contact
// frame's y axis), both at the internal state. Swing wheels get the same rule, so that
// they touch down at ground speed.
//
// Fallbacks (documented rules, each counted in TickRecord):
// - an invalid state (non-finite, wrong size): the previous command is kept, nothing is
//   updated;
// - an unusable MPC solution (failed solve): the previous reference is kept (it holds its
//   last state at rest once it runs past the end of its horizon);
// - a failed CBF-QP: the filter's fallback acceleration (joints brake to rest).
//
// Real-time contract: tick() never allocates, locks or throws (tests count allocations).
// Construction and initialize() allocate and may throw.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <vector>

#include "rollstep/centroidal/centroidal_ocp.hpp"
#include "rollstep/control/cbf_qp.hpp"
#include "rollstep/control/control_settings.hpp"
#include "rollstep/control/mpc_runner.hpp"
#include "rollstep/control/reference_trajectory.hpp"
#include "rollstep/control/robot_state.hpp"
#include "rollstep/control/state_integrator.hpp"

namespace rollstep::control {

/// What the pipeline sends to the actuators.
struct JointCommand {
  Eigen::VectorXd joint_position;  ///< nj, model joint order [rad or m]
  Eigen::VectorXd joint_velocity;  ///< nj, the internal state's joint velocities
  Eigen::VectorXd wheel_velocity;  ///< one per drive wheel, in contact order [rad/s]
};

/// What happened in one tick (for logs and tests).
struct TickRecord {
  double time = 0.0;
  int mode = 0;                         ///< contact mask of the contact planner at t
  bool state_valid = true;              ///< false: the state was rejected, the command kept
  bool new_solution = false;            ///< a solution arrived this tick
  bool solution_adopted = false;        ///< ... and was refined into the reference
  std::uint64_t solution_sequence = 0;  ///< of the reference in use
  CbfQpStatus cbf_status = CbfQpStatus::Optimal;
  DenseQpStatus qp_status = DenseQpStatus::Optimal;
  int qp_iterations = 0;
  int active_barriers = 0;
  double correction = 0.0;  ///< CbfQpFilter::correction()
};

/// Counters over the run.
struct PipelineCounters {
  std::uint64_t ticks = 0;
  std::uint64_t invalid_states = 0;
  std::uint64_t solutions_received = 0;
  std::uint64_t solutions_rejected = 0;  ///< unusable, reference kept
  std::uint64_t qp_fallbacks = 0;
};

class ControlPipeline {
 public:
  /// Builds the MPC runner (its own OCP) and the real-time side (a second instance of the
  /// OCP's model, planners and terrain: nothing is shared between the threads).
  ControlPipeline(const centroidal::RobotOcpDescription& robot, const ControlSettings& settings,
                  const planning::TerrainModel& terrain, planning::GaitKind gait);
  ~ControlPipeline();
  ControlPipeline(const ControlPipeline&) = delete;
  ControlPipeline& operator=(const ControlPipeline&) = delete;

  /// Not real-time: starts the references at the state's planar pose with `command`, solves
  /// the first MPC problem from the state (cold, converging) and starts the runner. The
  /// internal integrator starts at the state. Throws std::invalid_argument for an invalid
  /// state.
  solver::SolverStatus initialize(const RobotState& state,
                                  const planning::BaseVelocityCommand& command);
  /// One real-time tick at state.time. Never allocates, locks or throws.
  void tick(const RobotState& state, JointCommand& command) noexcept;
  /// Stops the MPC thread (asynchronous mode); idempotent.
  void stop();

  JointCommand makeCommand() const;
  RobotState makeState() const { return RobotState::zero(robot().nj()); }
  const TickRecord& lastTick() const { return record_; }
  const PipelineCounters& counters() const { return counters_; }
  /// The newest solution received (its statistics: iterations, KKT error, solve time).
  const MpcSolution& lastSolution() const { return solution_; }
  const ReferenceSample& reference() const { return sample_; }
  const StateIntegrator& integrator() const { return *integrator_; }
  const CbfQpFilter& filter() const { return *filter_; }
  const MpcRunner& runner() const { return *runner_; }
  const centroidal::CentroidalOcp& ocp() const { return *rt_ocp_; }
  const centroidal::CentroidalRobot& robot() const { return rt_ocp_->robot(); }
  const ControlSettings& settings() const { return settings_; }
  /// Contact index of each drive wheel, in the order of JointCommand::wheel_velocity.
  const std::vector<int>& driveWheelContacts() const { return drive_wheels_; }

 private:
  void computeTargets() noexcept;
  void computeWheelCommands(JointCommand& command) noexcept;

  ControlSettings settings_;
  std::unique_ptr<MpcRunner> runner_;
  std::unique_ptr<centroidal::CentroidalOcp> rt_ocp_;
  std::unique_ptr<planning::GaitScheduler> scheduler_;
  ocp::ModeSchedule schedule_;
  std::unique_ptr<ReferenceTrajectory> reference_;
  std::unique_ptr<CbfQpFilter> filter_;
  std::unique_ptr<StateIntegrator> integrator_;
  std::unique_ptr<model::Data> data_;
  std::vector<int> drive_wheels_;
  std::vector<FootRegionPlan> regions_;

  MpcSolution solution_;
  ReferenceSample sample_;
  AccelerationTargets targets_;
  TickRecord record_;
  PipelineCounters counters_;
  Eigen::VectorXd q_meas_, v_meas_, x_meas_, a_, dq_;
  Eigen::Matrix3Xd foot_p_, foot_v_;
  double schedule_horizon_ = 0.0;
  std::uint64_t adopted_sequence_ = 0;
  bool initialized_ = false;
};

}  // namespace rollstep::control
