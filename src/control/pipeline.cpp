#include "rollstep/control/pipeline.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <stdexcept>

#include "rollstep/control/speed_rule.hpp"
#include "rollstep/control/wheel_speed.hpp"
#include "rollstep/model/centroidal.hpp"
#include "rollstep/model/gravity.hpp"
#include "rollstep/model/kinematics.hpp"

namespace rollstep::control {

namespace {

/// World z component of the base angular velocity of the model state (q, v): v's angular
/// part is LOCAL, q's quaternion is x y z w.
double worldYawRate(const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  const Eigen::Quaterniond orientation(q[6], q[3], q[4], q[5]);
  return (orientation.normalized() * Eigen::Vector3d(v.segment<3>(3))).z();
}

}  // namespace

bool recordFilterOutcome(const CbfQpFilter& filter, CbfQpStatus status, TickRecord& record,
                         PipelineCounters& counters) {
  record.cbf_status = status;
  record.qp_status = filter.qpStatus();
  record.qp_iterations = filter.qpIterations();
  record.active_barriers = filter.activeBarriers();
  record.correction = filter.correction();
  if (status == CbfQpStatus::Relaxed) ++counters.qp_relaxations;
  const bool fallback = status != CbfQpStatus::Optimal && status != CbfQpStatus::Relaxed;
  if (fallback) ++counters.qp_fallbacks;
  return fallback;
}

ControlPipeline::ControlPipeline(const centroidal::RobotOcpDescription& robot,
                                 const ControlSettings& settings,
                                 const planning::TerrainModel& terrain, planning::GaitKind gait,
                                 int region_edge_capacity)
    : settings_(settings) {
  checkSettings(settings_);
  runner_ = std::make_unique<MpcRunner>(robot, settings_, terrain, gait, region_edge_capacity);
  rt_ocp_ = std::make_unique<centroidal::CentroidalOcp>(robot, settings_.ocp, terrain, gait,
                                                        region_edge_capacity);
  const centroidal::CentroidalRobot& r = rt_ocp_->robot();
  schedule_horizon_ = settings_.ocp.dt;
  scheduler_ = std::make_unique<planning::GaitScheduler>(rt_ocp_->gait(), schedule_horizon_);
  // The gait's switches and one landing per foot (CentroidalOcp::landLateFeet).
  schedule_ = ocp::ModeSchedule(scheduler_->requiredCapacity() + r.nc());
  reference_ = std::make_unique<ReferenceTrajectory>(
      std::make_shared<const centroidal::CentroidalPrecomputation>(rt_ocp_->robotPtr()),
      settings_.refinement, settings_.ocp.horizon);
  filter_ = std::make_unique<CbfQpFilter>(rt_ocp_->robotPtr(), rt_ocp_->terrain(), settings_.cbf_qp,
                                          settings_.ocp.lateral_slip_weight);
  integrator_ = std::make_unique<StateIntegrator>(r.modelPtr(), settings_.integrator,
                                                  settings_.control_period);
  if (settings_.integrator.deflection_compensation > 0.0 &&
      rt_ocp_->servoStiffness().size() != r.nj()) {
    throw std::invalid_argument(
        "ControlPipeline: integrator.deflection_compensation needs the robot description's "
        "servo_stiffness (one per joint)");
  }
  data_ = std::make_unique<model::Data>(r.model());
  for (int i = 0; i < r.nc(); ++i) {
    if (r.contact(i).drive_wheel) drive_wheels_.push_back(i);
  }
  regions_.assign(static_cast<size_t>(r.nc()), FootRegionPlan{});
  solution_ = runner_->makeSolution();
  sample_ = reference_->makeSample();
  targets_ = filter_->makeTargets();
  q_meas_ = Eigen::VectorXd::Zero(r.nq());
  v_meas_ = Eigen::VectorXd::Zero(r.nv());
  x_meas_ = Eigen::VectorXd::Zero(r.nx());
  a_ = Eigen::VectorXd::Zero(r.nv());
  dq_ = Eigen::VectorXd::Zero(r.nv());
  foot_p_ = Eigen::Matrix3Xd::Zero(3, r.nc());
  foot_v_ = Eigen::Matrix3Xd::Zero(3, r.nc());
}

ControlPipeline::~ControlPipeline() { stop(); }

void ControlPipeline::stop() {
  if (runner_) runner_->stop();
}

std::uint64_t ControlPipeline::setTerrain(const planning::TerrainModel& terrain) {
  if (!rt_ocp_->acceptsTerrain(terrain) || terrain.maxEdges() > filter_->maxRegionEdges()) {
    return 0;
  }
  // The real-time side's copy first: it is there when a solution solved on it arrives. The
  // runner applies the same checks (same capacity): both count the same versions.
  const std::uint64_t version = terrain_in_.publish(terrain);
  return runner_->publishTerrain(terrain) == version ? version : 0;
}

JointCommand ControlPipeline::makeCommand() const {
  const centroidal::CentroidalRobot& r = robot();
  JointCommand c;
  c.joint_position = rt_ocp_->nominalJointPositions();
  c.joint_velocity = Eigen::VectorXd::Zero(r.nj());
  c.wheel_velocity = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(drive_wheels_.size()));
  return c;
}

solver::SolverStatus ControlPipeline::initialize(const RobotState& state,
                                                 const planning::BaseVelocityCommand& command) {
  return initializeSchedule(state, std::vector<planning::TimedBaseCommand>{{0.0, command}});
}

solver::SolverStatus ControlPipeline::initializeSchedule(
    const RobotState& state, const std::vector<planning::TimedBaseCommand>& schedule) {
  const centroidal::CentroidalRobot& r = robot();
  if (!state.valid(r.nj())) {
    throw std::invalid_argument(
        "ControlPipeline::initialize: the state is not valid (non-finite values, a quaternion "
        "that is not unit, or joint vectors of the wrong size)");
  }
  measure(state);
  // The references start at the state's pose (they keep its x, y and yaw).
  const lie::SE3 start(state.base_position, state.base_orientation);
  adaptSchedule(start, schedule);
  rt_ocp_->resetSchedule(state.time, start, reference_schedule_);
  const solver::SolverStatus status =
      runner_->initializeSchedule(state.time, start, reference_schedule_, x_meas_);
  integrator_->reset(q_meas_, v_meas_);
  solution_.sequence = 0;
  if (runner_->poll(state.time, solution_)) {
    reference_->refine(solution_, state.time, x_meas_);
  }
  adopted_t0_ = state.time;
  holding_ = false;
  counters_ = PipelineCounters{};
  initialized_ = true;
  return status;
}

void ControlPipeline::adaptSchedule(const lie::SE3& start,
                                    const std::vector<planning::TimedBaseCommand>& schedule) {
  step_slowdowns_.clear();
  step_speed_limit_ = 0.0;
  const centroidal::OcpSettings& ocp = settings_.ocp;
  if (!ocp.speed_adaptation) {
    reference_schedule_ = schedule;
    return;
  }
  const centroidal::CentroidalRobot& r = robot();
  std::vector<std::string> frames;
  for (int i = 0; i < r.nc(); ++i) frames.push_back(r.contact(i).frame);
  planning::SpeedScheduleConfig config;
  config.turn_radius = turnRadius(r.model(), frames, rt_ocp_->nominalJointPositions());
  if (rt_ocp_->gait().kind() == planning::GaitKind::Trot) {
    const planning::SpeedAdaptationLimits limits =
        speedRuleLimits(r.model(), frames, rt_ocp_->nominalJointPositions(), ocp);
    step_speed_limit_ = planning::adaptTrotToSpeed(0.0, limits).step_speed_limit;
    config.step_speed_limit = step_speed_limit_;
  }
  config.step_reach = ocp.step_speed_reach;
  config.max_acceleration = ocp.command_acceleration;
  reference_schedule_ = planning::adaptScheduleToTerrain(
      schedule, start, rt_ocp_->terrain(), rt_ocp_->nominalFeet(), config, &step_slowdowns_);
}

void ControlPipeline::measure(const RobotState& state) noexcept {
  const centroidal::CentroidalRobot& r = robot();
  toModelState(state, q_meas_, v_meas_);
  x_meas_.head(r.nq()) = q_meas_;
  x_meas_.tail<6>() = model::computeCentroidalMomentum(r.model(), *data_, q_meas_, v_meas_);
}

void ControlPipeline::computeTargets() noexcept {
  const centroidal::CentroidalRobot& r = robot();
  const model::Model& m = r.model();
  const FeedbackSettings& fb = settings_.feedback;
  const Eigen::VectorXd& q = integrator_->q();
  const Eigen::VectorXd& v = integrator_->v();
  const int nj = r.nj();
  // Configuration error reference (-) internal, in the internal state's tangent (LOCAL).
  model::difference(m, q, sample_.q, dq_);
  targets_.base = sample_.a.head<6>() + fb.base_kp.cwiseProduct(dq_.head<6>()) +
                  fb.base_kd.cwiseProduct(sample_.v.head<6>() - v.head<6>());
  targets_.joints = sample_.a.tail(nj) + fb.joint_kp * dq_.tail(nj) +
                    fb.joint_kd * (sample_.v.tail(nj) - v.tail(nj));
  // Feet at the internal state.
  model::forwardKinematics(m, *data_, q, v);
  for (int i = 0; i < r.nc(); ++i) {
    const model::FrameIndex f = r.frameIds()[static_cast<size_t>(i)];
    model::updateFramePlacement(m, *data_, f);
    foot_p_.col(i) = data_->opf[static_cast<size_t>(f)];
    foot_v_.col(i) =
        model::getFrameVelocity(m, *data_, f, model::ReferenceFrame::LOCAL_WORLD_ALIGNED).head<3>();
  }
  targets_.feet = sample_.foot_acceleration + fb.foot_kp * (sample_.foot_position - foot_p_) +
                  fb.foot_kd * (sample_.foot_velocity - foot_v_);
}

void ControlPipeline::computeWheelCommands(JointCommand& command) noexcept {
  const Eigen::VectorXd& q = integrator_->q();
  const Eigen::VectorXd& v = integrator_->v();
  // Skid steering (pipeline.hpp): the extra yaw rate the wheels' speed difference is
  // commanded for, (factor - 1) w_cmd + gain (w_cmd - w_measured), world z.
  double extra_yaw_rate = 0.0;
  if (settings_.ocp.lateral_slip_weight > 0.0) {
    const WheelSettings& ws = settings_.wheels;
    const double w_cmd = worldYawRate(q, v);
    const double w_meas = worldYawRate(q_meas_, v_meas_);
    extra_yaw_rate =
        (ws.skid_track_factor - 1.0) * w_cmd + ws.skid_yaw_rate_gain * (w_cmd - w_meas);
    if (!std::isfinite(extra_yaw_rate)) extra_yaw_rate = 0.0;
  }
  computeDriveWheelSpeeds(robot(), *data_, q, v, drive_wheels_, extra_yaw_rate,
                          command.wheel_velocity);
}

void ControlPipeline::tick(const RobotState& state, JointCommand& command) noexcept {
  const centroidal::CentroidalRobot& r = robot();
  const double t = state.time;
  record_ = TickRecord{};
  record_.time = t;
  ++counters_.ticks;
  if (!initialized_ || !state.valid(r.nj())) {
    record_.state_valid = false;
    ++counters_.invalid_states;
    return;
  }
  measure(state);

  // MPC: post the state, take a newer solution, refine it from this state.
  runner_->post(t, x_meas_);
  if (runner_->poll(t, solution_)) {
    record_.new_solution = true;
    ++counters_.solutions_received;
    if (t - solution_.t0 > settings_.mpc.max_solution_age) {
      // Too old on arrival (a stalled solve): the watchdog's business, not adopted.
      ++counters_.stale_solutions;
    } else if (reference_->refine(solution_, t, x_meas_)) {
      record_.solution_adopted = true;
      adopted_sequence_ = solution_.sequence;
      // The first solution solved on a newer terrain: the contact planner and the filter
      // change to it too (the newest published, swapped in).
      std::uint64_t version = 0;
      if (solution_.terrain_version > rt_terrain_version_ &&
          terrain_in_.take(rt_incoming_, version) && rt_ocp_->swapTerrain(rt_incoming_)) {
        rt_terrain_version_ = version;
        ++counters_.terrain_updates;
      }
      // The foothold regions follow the reference the solution was solved on.
      rt_ocp_->setReferenceCorrection(solution_.reference_correction);
      rt_ocp_->setGaitClock(solution_.gait_clock);
      adopted_t0_ = solution_.t0;
      holding_ = false;
      // Naive state feedback: the commands restart from the measurement with each plan.
      if (settings_.integrator.mode == IntegratorMode::Naive) integrator_->reset(q_meas_, v_meas_);
    } else {
      ++counters_.solutions_rejected;
    }
  }
  record_.solution_sequence = adopted_sequence_;
  record_.terrain_version = rt_terrain_version_;
  // Stale-solution watchdog: past the age limit, freeze the plan where it is, at rest.
  if (!holding_ && t - adopted_t0_ > settings_.mpc.max_solution_age) {
    holding_ = true;
    hold_time_ = t;
    ++counters_.watchdog_trips;
  }
  record_.holding = holding_;
  if (holding_) ++counters_.holding_ticks;
  const double t_plan = holding_ ? hold_time_ : t;

  // Contact planner: the gait at t and each foot's regions.
  scheduler_->fill(t_plan, schedule_horizon_, schedule_, rt_ocp_->gaitClock());
  rt_ocp_->anchorStanceFeet(schedule_, t_plan, x_meas_);
  // Late touch-downs: out of the mode (no contact consistency holding them in the air)
  // until they land; the MPC's side delays the same stances in its plan.
  record_.late_feet = holding_ ? 0 : rt_ocp_->landLateFeet(schedule_, t_plan, x_meas_);
  if (record_.late_feet != 0) ++counters_.late_touchdown_ticks;
  record_.mode = schedule_.modeAt(t_plan);

  // Reference at t (the adopted solution's; the foot queries below do not change it).
  reference_->sample(t_plan, sample_);
  if (holding_) {
    sample_.v.setZero();
    sample_.a.setZero();
    sample_.foot_velocity.setZero();
    sample_.foot_acceleration.setZero();
  }
  for (int i = 0; i < r.nc(); ++i) {
    const planning::FootReference ref = rt_ocp_->footPlanner().query(schedule_, i, t_plan);
    FootRegionPlan& plan = regions_[static_cast<size_t>(i)];
    plan.region = ref.region;
    plan.swing_region = ref.swing_region;
    plan.swing_region_active = ref.swing_region_active;
    if ((record_.late_feet >> i & 1) != 0) {
      // A late foot descends on its landing (the adopted plan may still hold it up, until
      // the MPC's next solution).
      sample_.foot_position(2, i) = ref.z_ref;
      sample_.foot_velocity(2, i) = ref.z_dot_ref;
      sample_.foot_acceleration(2, i) = 0.0;
    }
  }

  // Acceleration commands, safety filter, integrator.
  computeTargets();
  recordFilterOutcome(*filter_,
                      filter_->filter(integrator_->q(), integrator_->v(), record_.mode,
                                      regions_.data(), targets_, a_),
                      record_, counters_);
  integrator_->step(a_, q_meas_, v_meas_);

  // Commands.
  command.joint_position = integrator_->q().tail(r.nj());
  command.joint_velocity = integrator_->v().tail(r.nj());
  computeWheelCommands(command);
  const double compensation = settings_.integrator.deflection_compensation;
  if (compensation > 0.0) {
    // Each servo carries the static torque of the planned contact forces and sits tau / K
    // short of its command: command that much further.
    const Eigen::VectorXd& tau = model::computeStaticTorque(r.model(), *data_, integrator_->q(),
                                                            r.frameIds(), sample_.forces);
    command.joint_position.array() +=
        compensation * tau.tail(r.nj()).array() / rt_ocp_->servoStiffness().array();
  }
}

}  // namespace rollstep::control
