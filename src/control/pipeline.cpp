#include "rollstep/control/pipeline.hpp"

#include <Eigen/Geometry>
#include <algorithm>
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

ControlPipeline::ControlPipeline(const centroidal::RobotOcpDescription& robot,
                                 const ControlSettings& settings,
                                 const planning::TerrainModel& terrain, planning::GaitKind gait,
                                 int region_edge_capacity)
    : settings_(settings) {
  checkSettings(settings_);
  runner_ = std::make_unique<MpcRunner>(robot, settings_, terrain, gait, region_edge_capacity);
  robot_ = centroidal::loadRobot(robot);
  planner_ =
      centroidal::makeContactPlanner(robot_, settings_.ocp, terrain, gait, region_edge_capacity);
  const centroidal::CentroidalRobot& r = *robot_.robot;
  schedule_horizon_ = settings_.ocp.dt;
  schedule_ = ocp::ModeSchedule(planner_->scheduleCapacity());
  reference_ = std::make_unique<ReferenceTrajectory>(
      std::make_shared<const centroidal::CentroidalPrecomputation>(robot_.robot),
      settings_.refinement, settings_.ocp.horizon);
  tracking_ = std::make_unique<TrackingStage>(robot_.robot, planner_->terrain(), settings_,
                                              settings_.ocp.lateral_slip_weight);
  if (settings_.integrator.deflection_compensation > 0.0 &&
      robot_.description.servo_stiffness.size() != r.nj()) {
    throw std::invalid_argument(
        "ControlPipeline: integrator.deflection_compensation needs the robot description's "
        "servo_stiffness (one per joint)");
  }
  data_ = std::make_unique<model::Data>(r.model());
  measured_data_ = std::make_unique<model::Data>(r.model());
  for (int i = 0; i < r.nc(); ++i) {
    if (r.contact(i).drive_wheel) drive_wheels_.push_back(i);
  }
  regions_.assign(static_cast<size_t>(r.nc()), FootRegionPlan{});
  solution_ = runner_->makeSolution();
  sample_ = reference_->makeSample();
  q_meas_ = Eigen::VectorXd::Zero(r.nq());
  v_meas_ = Eigen::VectorXd::Zero(r.nv());
  x_meas_ = Eigen::VectorXd::Zero(r.nx());
  measured_feet_ = Eigen::Matrix3Xd::Zero(3, r.nc());
}

ControlPipeline::~ControlPipeline() { stop(); }

void ControlPipeline::stop() {
  if (runner_) runner_->stop();
}

std::uint64_t ControlPipeline::setTerrain(const planning::TerrainModel& terrain) {
  if (!planner_->acceptsTerrain(terrain) || terrain.maxEdges() > filter().maxRegionEdges()) {
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
  c.joint_position = robot_.description.nominal_joint_positions;
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
  adaptSchedule(state.time, start, schedule);
  // The clock the MPC's first plan has (its edge holds), until a solution brings its own.
  planner_->resetSchedule(state.time, start, reference_schedule_);
  planner_->planSchedule(state.time, schedule_);
  const solver::SolverStatus status =
      runner_->initializeSchedule(state.time, start, reference_schedule_, x_meas_);
  tracking_->reset(q_meas_, v_meas_);
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

void ControlPipeline::adaptSchedule(double t0, const lie::SE3& start,
                                    const std::vector<planning::TimedBaseCommand>& schedule) {
  step_slowdowns_.clear();
  approach_timing_ = planning::ApproachTiming{};
  sideways_holds_.clear();
  step_speed_limit_ = 0.0;
  const centroidal::OcpSettings& ocp = settings_.ocp;
  if (!ocp.speed_adaptation) {
    reference_schedule_ = schedule;
    return;
  }
  const centroidal::CentroidalRobot& r = robot();
  // The contacts are the description's frames, in its order (centroidal::loadRobot).
  const std::vector<std::string>& frames = robot_.description.contact_frames;
  planning::SpeedScheduleConfig config;
  config.turn_radius = turnRadius(r.model(), frames, robot_.description.nominal_joint_positions);
  if (planner_->gait().kind() == planning::GaitKind::Trot) {
    const planning::SpeedAdaptationLimits limits =
        speedRuleLimits(r.model(), frames, robot_.description.nominal_joint_positions, ocp);
    step_speed_limit_ = planning::adaptTrotToSpeed(0.0, limits).step_speed_limit;
    config.step_speed_limit = step_speed_limit_;
  }
  config.step_reach = ocp.step_speed_reach;
  config.max_acceleration = ocp.command_acceleration;
  // The approach is timed to the gait where the gait cannot wait at an edge itself (no phase
  // with every foot in stance for the edge holds; the gait clock starts at t0).
  const planning::Gait& gait = planner_->gait();
  const std::vector<int>& modes = gait.phaseModes();
  const std::vector<double>& starts = gait.phaseStarts();
  const int all = planning::allFeetMask(gait.numFeet());
  if (ocp.approach_timing && gait.switchesPerPeriod() > 0 &&
      std::find(modes.begin(), modes.end(), all) == modes.end()) {
    config.gait_period = gait.period();
    config.gait_time_at_start = t0;
    config.time_every_edge = ocp.approach_timing_every_edge;
    config.touchdowns.assign(static_cast<std::size_t>(gait.numFeet()), {});
    const std::size_t n = modes.size();
    for (std::size_t j = 0; j < n; ++j) {
      const int landing = modes[j] & ~modes[(j + n - 1) % n];
      for (int f = 0; f < gait.numFeet(); ++f) {
        if (planning::inContact(landing, f)) {
          config.touchdowns[static_cast<std::size_t>(f)].push_back(starts[j]);
        }
      }
    }
  }
  reference_schedule_ = planning::adaptScheduleToTerrain(schedule, start, planner_->terrain(),
                                                         planner_->stance().feet, config,
                                                         &step_slowdowns_, &approach_timing_);
  // The legs cannot reach sideways: no sideways motion while a foot crosses a step.
  planning::SidewaysHoldConfig sideways;
  sideways.reach = ocp.step_speed_reach;
  sideways.max_acceleration = ocp.command_acceleration;
  reference_schedule_ =
      planning::holdSidewaysAtSteps(reference_schedule_, start, planner_->terrain(),
                                    planner_->stance().feet, sideways, &sideways_holds_);
}

void ControlPipeline::measure(const RobotState& state) noexcept {
  const centroidal::CentroidalRobot& r = robot();
  toModelState(state, q_meas_, v_meas_);
  x_meas_.head(r.nq()) = q_meas_;
  x_meas_.tail<6>() = model::computeCentroidalMomentum(r.model(), *data_, q_meas_, v_meas_);
}

void ControlPipeline::computeTargets() noexcept {
  const int nj = robot().nj();
  const FeedbackSettings& fb = settings_.feedback;
  const Eigen::VectorXd& v = tracking_->v();
  // Configuration error reference (-) internal, in the internal state's tangent (LOCAL).
  const Eigen::VectorXd& dq = tracking_->configurationError(sample_.q);
  AccelerationTargets& targets = tracking_->targets();
  targets.base = sample_.a.head<6>() + fb.base_kp.cwiseProduct(dq.head<6>()) +
                 fb.base_kd.cwiseProduct(sample_.v.head<6>() - v.head<6>());
  targets.joints = sample_.a.tail(nj) + fb.joint_kp * dq.tail(nj) +
                   fb.joint_kd * (sample_.v.tail(nj) - v.tail(nj));
  tracking_->updateFeet();
  targets.feet = sample_.foot_acceleration +
                 fb.foot_kp * (sample_.foot_position - tracking_->footPositions()) +
                 fb.foot_kd * (sample_.foot_velocity - tracking_->footVelocities());
}

void ControlPipeline::computeWheelCommands(double t, JointCommand& command) noexcept {
  const Eigen::VectorXd& q = tracking_->q();
  const Eigen::VectorXd& v = tracking_->v();
  // Skid steering (pipeline.hpp): the extra yaw rate the wheels' speed difference is
  // commanded for, (factor - 1) w_cmd + gain (w_cmd - w_measured), world z.
  double extra_yaw_rate = 0.0;
  Eigen::Vector2d extra_velocity = Eigen::Vector2d::Zero();
  if (settings_.ocp.lateral_slip_weight > 0.0) {
    const WheelSettings& ws = settings_.wheels;
    const double w_cmd = worldYawRate(q, v);
    const double w_meas = worldYawRate(q_meas_, v_meas_);
    extra_yaw_rate =
        (ws.skid_track_factor - 1.0) * w_cmd + ws.skid_yaw_rate_gain * (w_cmd - w_meas);
    if (!std::isfinite(extra_yaw_rate)) extra_yaw_rate = 0.0;
    if (ws.skid_velocity_gain > 0.0 || ws.skid_position_gain > 0.0) {
      // The base reference's planar pose and velocity (the command's, not the plan's: the plan
      // starts from the measured state and so follows a drift) minus the measured ones.
      const planning::BaseReference& reference = planner_->baseReference();
      const lie::Vector6d twist = reference.twistAt(t);
      const lie::SE3 pose = reference.planarPoseAt(t);
      const Eigen::Vector3d v_ref = pose.rotation * Eigen::Vector3d(twist[0], twist[1], 0.0);
      const Eigen::Quaterniond orientation(q_meas_[6], q_meas_[3], q_meas_[4], q_meas_[5]);
      const Eigen::Vector3d v_world = orientation.normalized() * Eigen::Vector3d(v_meas_.head<3>());
      extra_velocity = ws.skid_velocity_gain * (v_ref - v_world).head<2>() +
                       ws.skid_position_gain * (pose.translation - q_meas_.head<3>()).head<2>();
      if (!extra_velocity.allFinite()) extra_velocity.setZero();
    }
  }
  computeDriveWheelSpeeds(robot(), *data_, q, v, drive_wheels_, extra_yaw_rate, extra_velocity,
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
          terrain_in_.take(rt_incoming_, version) && planner_->swapTerrain(rt_incoming_)) {
        rt_terrain_version_ = version;
        ++counters_.terrain_updates;
      }
      // The foothold regions follow the reference the solution was solved on.
      planner_->setReferenceCorrection(solution_.reference_correction);
      planner_->setGaitClock(solution_.gait_clock);
      adopted_t0_ = solution_.t0;
      holding_ = false;
      // Naive state feedback: the commands restart from the measurement with each plan.
      if (settings_.integrator.mode == IntegratorMode::Naive) tracking_->reset(q_meas_, v_meas_);
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
  planner_->fillSchedule(t_plan, schedule_horizon_, schedule_);
  if (planner_->usesMeasuredFeet()) {
    centroidal::contactPositionsOfState(r, *measured_data_, x_meas_, measured_feet_);
  }
  planner_->anchorStanceFeet(schedule_, t_plan, measured_feet_);
  // Late touch-downs: out of the mode (no contact consistency holding them in the air)
  // until they land; the MPC's side delays the same stances in its plan.
  record_.late_feet = holding_ ? 0 : planner_->landLateFeet(schedule_, t_plan, measured_feet_);
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
    const planning::FootReference ref = planner_->footPlanner().query(schedule_, i, t_plan);
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
  tracking_->filter(record_.mode, regions_.data(), record_, counters_);
  tracking_->step(q_meas_, v_meas_, command);

  // Commands.
  computeWheelCommands(t_plan, command);
  const double compensation = settings_.integrator.deflection_compensation;
  if (compensation > 0.0) {
    // Each servo carries the static torque of the planned contact forces and sits tau / K
    // short of its command: command that much further.
    const Eigen::VectorXd& tau =
        model::computeStaticTorque(r.model(), *data_, tracking_->q(), r.frameIds(), sample_.forces);
    command.joint_position.array() +=
        compensation * tau.tail(r.nj()).array() / robot_.description.servo_stiffness.array();
  }
}

}  // namespace rollstep::control
