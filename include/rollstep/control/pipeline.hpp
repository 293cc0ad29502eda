#pragma once
// The 1 kHz control pipeline (paper Sec. 3.3, Fig. 5; DESIGN.md section 5). Every tick:
//
//   state (estimator or ground truth, RobotState)
//   -> MPC runner: post the state; take a newer solution if one is ready
//   -> time-lag refinement of a new solution from the latest state (ReferenceTrajectory)
//   -> contact planner: the gait's mode and each foot's regions at t (a foot still in the
//      air when its stance was due stays in swing and is brought down first: late
//      touch-downs, OcpSettings::late_touchdown_tolerance, on both the MPC's and this side)
//   -> reference at t: base pose/twist/acceleration, feet position/velocity/acceleration,
//      joints; acceleration commands = feedforward + Kp, Kd feedback against the INTERNAL
//      integrator state
//   -> CBF-QP safety filter (contact consistency, joint limits, foothold regions,
//      leg/terrain clearance)
//   -> internal state integrator (measured state blended in)
//   -> joint position commands (hips, knees) and drive-wheel velocity commands.
// (Feedback, filter, integrator and joint commands: TrackingStage, shared with the
// baseline pipeline.)
//
// Drive-wheel speed (relative to its shank): the wheel centre's velocity along the wheel's
// heading (the contact frame's x axis projected on the ground) over the wheel radius (the
// robot's contact offset), minus the shank's own rotation rate about the axle (the contact
// frame's y axis), both at the internal state. Swing wheels get the same rule, so that
// they touch down at ground speed.
//
// Skid steering (only with OcpSettings::lateral_slip_weight > 0, the drive wheels allowed to
// slide sideways; WheelSettings, config/control.yaml `wheels:`). Wheels with fixed headings
// turn the body only by sliding, and sliding wheels realize only part of the yaw rate their
// speed difference gives without slip: the instantaneous centres of rotation of the wheel
// tracks lie outside the wheels, so the effective track width is larger than the geometric
// one (Mandow et al. 2007; on friction it depends, not on the robot alone). The rule above
// assumes rolling without slip, so the body turned at a fraction of the commanded yaw rate
// while the internal state turned at the full rate. Two terms correct it; each drive wheel
// gets the ground speed a yaw rate w_x about the base origin gives it,
//   w_x (e_z x d) . h / r,   d = wheel centre - base origin, h its heading, r its radius,
//   w_x = (skid_track_factor - 1) w_c + skid_yaw_rate_gain (w_c - w_m),
// with w_c the internal state's (commanded) and w_m the measured base yaw rate (world z):
// - the track factor (effective / geometric track width) is the feedforward: the speed
//   difference of a turn is scaled so that the sliding wheels realize w_c (with a factor
//   that matches the ground, w_m = w_c and the feedback term is 0);
// - the yaw-rate feedback takes up what the factor misses (a factor that does not match
//   the ground, load or speed changes): a proportional correction is enough because the MPC
//   closes the yaw angle loop above it.
// Why it matters beyond the yaw rate: the OCP's base reference runs from the start pose at
// the commanded yaw rate, so an unrealized turn makes the yaw error grow without bound; the
// MPC keeps planning the largest turn, whose slip cost (lateral speed = yaw rate times the
// wheel's distance along the heading) pulls the front and rear drive wheels towards the
// yaw axis. Replanned every period from the measured state, that posture change ratchets:
// the hips pitch (front and rear opposite), the wheels roll towards each other and the
// prismatic knees extend until the body stands far above its nominal height. With the
// turn realized the yaw error stays bounded and so does the posture. The defaults (factor
// 1, gain 0) change nothing; with lateral_slip_weight == 0 the terms are not used at all.
//
// Fallbacks (documented rules, each counted in TickRecord):
// - an invalid state (non-finite, wrong size): the previous command is kept, nothing is
//   updated;
// - an unusable MPC solution (failed solve): the previous reference is kept (it holds its
//   last state at rest once it runs past the end of its horizon);
// - a failed CBF-QP: the filter's fallback acceleration (joints brake to rest);
// - a stale solution (older than mpc.max_solution_age: the MPC stalled or keeps failing):
//   the safe posture, i.e. the reference and the contact plan frozen at the moment the
//   watchdog tripped, at rest (zero velocity and acceleration), until a new solution is
//   adopted (a solution already older than the limit when it arrives is not adopted). Until
//   the limit the last solution, refined, is used as usual.
//
// Terrain updates (perception, at its own rate; setTerrain from one producer thread, not
// real-time): the MPC solves on a new terrain from the start of its next solve; the
// real-time side (contact planner, CBF-QP) changes to it when it adopts the first solution
// solved on it, so that the plan and the safety filter see the same regions. Both swap the
// terrain in (no allocation). A terrain the problem cannot take (empty, or regions with
// more edges than the capacity) is refused by setTerrain: the last one stays.
//
// Real-time contract: tick() never allocates, locks or throws (tests count allocations).
// Construction and initialize() allocate and may throw.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <vector>

#include "rollstep/centroidal/loaded_robot.hpp"
#include "rollstep/common/latest_value_mailbox.hpp"
#include "rollstep/control/cbf_qp.hpp"
#include "rollstep/control/control_settings.hpp"
#include "rollstep/control/mpc_runner.hpp"
#include "rollstep/control/reference_trajectory.hpp"
#include "rollstep/control/robot_state.hpp"
#include "rollstep/control/state_integrator.hpp"
#include "rollstep/control/tracking_stage.hpp"
#include "rollstep/planning/sideways_at_steps.hpp"
#include "rollstep/planning/speed_adaptation.hpp"

namespace rollstep::control {

class ControlPipeline {
 public:
  /// Builds the MPC runner (its own OCP) and the real-time side (its own robot model,
  /// contact planner and terrain, no OCP: nothing is shared between the threads).
  /// `region_edge_capacity`: the most edges of a region of any terrain given later
  /// (setTerrain); 0: the initial terrain's (the CBF-QP takes at least 8 in any case).
  ControlPipeline(const centroidal::RobotOcpDescription& robot, const ControlSettings& settings,
                  const planning::TerrainModel& terrain, planning::GaitKind gait,
                  int region_edge_capacity = 0);
  ~ControlPipeline();
  ControlPipeline(const ControlPipeline&) = delete;
  ControlPipeline& operator=(const ControlPipeline&) = delete;

  /// Not real-time: starts the references at the state's planar pose with `command`, solves
  /// the first MPC problem from the state (cold, converging) and starts the runner. The
  /// internal integrator starts at the state. Throws std::invalid_argument for an invalid
  /// state.
  solver::SolverStatus initialize(const RobotState& state,
                                  const planning::BaseVelocityCommand& command);
  /// Same with a command schedule (planning::BaseReference::reset; its times count from
  /// state.time). With ocp.speed_adaptation the references follow the schedule adapted to
  /// the terrain known now (planning::adaptScheduleToTerrain: ramped at
  /// ocp.command_acceleration and, for a trot, slowed down near steps to the speed rule's
  /// step speed limit; referenceSchedule(), stepSlowdowns()), with its sideways part held
  /// back while a foot crosses a step (planning::holdSidewaysAtSteps; sidewaysHolds()).
  solver::SolverStatus initializeSchedule(const RobotState& state,
                                          const std::vector<planning::TimedBaseCommand>& schedule);
  /// The schedule the references follow (the one given, or its adaptation).
  const std::vector<planning::TimedBaseCommand>& referenceSchedule() const {
    return reference_schedule_;
  }
  /// Where initializeSchedule slowed the command down at a step (times from state.time).
  const std::vector<planning::StepSlowdown>& stepSlowdowns() const { return step_slowdowns_; }
  /// How initializeSchedule timed the approach to the first step (ocp.approach_timing).
  const planning::ApproachTiming& approachTiming() const { return approach_timing_; }
  /// Where the sideways part of the command is held back over a step (speed rule on;
  /// planning::holdSidewaysAtSteps), in seconds from the schedule's start.
  const std::vector<planning::SidewaysHold>& sidewaysHolds() const { return sideways_holds_; }
  /// [m/s] The speed rule's step speed limit (0: no trot, or no speed adaptation).
  double stepSpeedLimit() const { return step_speed_limit_; }
  /// One real-time tick at state.time. Never allocates, locks or throws.
  void tick(const RobotState& state, JointCommand& command) noexcept;
  /// Stops the MPC thread (asynchronous mode); idempotent.
  void stop();
  /// Producer of terrains (one thread, not real-time: copies it twice): hands a new terrain
  /// to the MPC (next solve) and to the real-time side (with the first solution solved on
  /// it). Returns its version (1, 2, ...), or 0 if refused (empty, or a region with more
  /// edges than the capacity): the terrain in use stays.
  std::uint64_t setTerrain(const planning::TerrainModel& terrain);
  /// Version of the real-time side's terrain (0: the constructor's).
  std::uint64_t terrainVersion() const { return rt_terrain_version_; }

  JointCommand makeCommand() const;
  RobotState makeState() const { return RobotState::zero(robot().nj()); }
  const TickRecord& lastTick() const { return record_; }
  const PipelineCounters& counters() const { return counters_; }
  /// The newest solution received (its statistics: iterations, KKT error, solve time).
  const MpcSolution& lastSolution() const { return solution_; }
  const ReferenceSample& reference() const { return sample_; }
  const StateIntegrator& integrator() const { return tracking_->integrator(); }
  const CbfQpFilter& filter() const { return tracking_->safetyFilter(); }
  const MpcRunner& runner() const { return *runner_; }
  /// The real-time side's contact planner (its terrain, references, gait clock).
  const planning::ContactPlanner& contactPlanner() const { return *planner_; }
  const centroidal::LoadedRobot& loadedRobot() const { return robot_; }
  const centroidal::CentroidalRobot& robot() const { return *robot_.robot; }
  const ControlSettings& settings() const { return settings_; }
  /// Fault drills and tests: faults of the deterministic MPC (MpcRunner::injectFaults).
  void injectMpcFaults(const MpcFaultInjection& faults) { runner_->injectFaults(faults); }
  /// Diagnostics of every MPC solve (MpcRunner::setSolveObserver; not real-time).
  void setMpcSolveObserver(MpcRunner::SolveObserver observer) {
    runner_->setSolveObserver(std::move(observer));
  }
  /// Contact index of each drive wheel, in the order of JointCommand::wheel_velocity.
  const std::vector<int>& driveWheelContacts() const { return drive_wheels_; }

 private:
  /// reference_schedule_, step_slowdowns_, approach_timing_, sideways_holds_ and
  /// step_speed_limit_ for a schedule from `start` at time t0 (the gait clock's time then).
  void adaptSchedule(double t0, const lie::SE3& start,
                     const std::vector<planning::TimedBaseCommand>& schedule);
  /// q_meas_, v_meas_ and the centroidal state x_meas_ (h = A(q) v) of a valid state.
  void measure(const RobotState& state) noexcept;
  void computeTargets() noexcept;
  void computeWheelCommands(double t, JointCommand& command) noexcept;

  ControlSettings settings_;
  std::unique_ptr<MpcRunner> runner_;
  centroidal::LoadedRobot robot_;
  std::unique_ptr<planning::ContactPlanner> planner_;
  ocp::ModeSchedule schedule_;
  std::unique_ptr<ReferenceTrajectory> reference_;
  std::unique_ptr<TrackingStage> tracking_;
  std::unique_ptr<model::Data> data_;
  std::vector<int> drive_wheels_;
  std::vector<FootRegionPlan> regions_;
  LatestValueMailbox<planning::TerrainModel> terrain_in_;  // setTerrain -> tick
  planning::TerrainModel rt_incoming_;
  std::uint64_t rt_terrain_version_ = 0;

  MpcSolution solution_;
  ReferenceSample sample_;
  TickRecord record_;
  PipelineCounters counters_;
  Eigen::VectorXd q_meas_, v_meas_, x_meas_;
  std::unique_ptr<model::Data> measured_data_;  // the measured feet of the contact planner
  Eigen::Matrix3Xd measured_feet_;
  double schedule_horizon_ = 0.0;
  std::uint64_t adopted_sequence_ = 0;
  double adopted_t0_ = 0.0;  // state time of the solution in use
  bool holding_ = false;     // watchdog: safe posture held since hold_time_
  double hold_time_ = 0.0;
  bool initialized_ = false;
  std::vector<planning::TimedBaseCommand> reference_schedule_;
  std::vector<planning::StepSlowdown> step_slowdowns_;
  planning::ApproachTiming approach_timing_;
  std::vector<planning::SidewaysHold> sideways_holds_;
  double step_speed_limit_ = 0.0;
};

}  // namespace rollstep::control
