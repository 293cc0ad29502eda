// The CBF-QP baseline pipeline (baseline_pipeline.hpp).
#include "rollstep/control/baseline_pipeline.hpp"

#include <stdexcept>

#include "rollstep/control/wheel_speed.hpp"
#include "rollstep/model/gravity.hpp"
#include "rollstep/model/kinematics.hpp"

namespace rollstep::control {

namespace {

/// The OCP settings of the contact planner: the baseline's gait and swing height; one node
/// (no MPC is solved).
centroidal::OcpSettings plannerOcpSettings(const ControlSettings& s) {
  centroidal::OcpSettings ocp = s.ocp;
  ocp.horizon = 1;
  ocp.gait_period = s.baseline.gait_period;
  ocp.trot_duty = s.baseline.trot_duty;
  ocp.swing_clearance = s.baseline.swing_clearance;
  return ocp;
}

}  // namespace

BaselinePipeline::BaselinePipeline(const centroidal::RobotOcpDescription& robot,
                                   const ControlSettings& settings,
                                   const planning::TerrainModel& terrain,
                                   const planning::TerrainModel& collision_terrain,
                                   planning::GaitKind gait, int region_edge_capacity,
                                   int collision_prism_capacity)
    : settings_(settings) {
  checkSettings(settings_);
  robot_ = centroidal::loadRobot(robot);
  contacts_ = centroidal::makeContactPlanner(robot_, plannerOcpSettings(settings_), terrain, gait,
                                             region_edge_capacity);
  collision_terrain_ = std::make_unique<planning::TerrainModel>(collision_terrain);
  planner_ = std::make_unique<ReactivePlanner>(robot_, *contacts_, *collision_terrain_,
                                               settings_.baseline);
  tracking_ = std::make_unique<TrackingStage>(robot_.robot, contacts_->terrain(), settings_, 0.0,
                                              collision_terrain_.get(), collision_prism_capacity);
  const centroidal::CentroidalRobot& r = *robot_.robot;
  data_ = std::make_unique<model::Data>(r.model());
  for (int i = 0; i < r.nc(); ++i) {
    if (r.contact(i).drive_wheel) drive_wheels_.push_back(i);
  }
  plan_ = planner_->makePlan();
  q_meas_ = Eigen::VectorXd::Zero(r.nq());
  v_meas_ = Eigen::VectorXd::Zero(r.nv());
  stance_forces_ = Eigen::VectorXd::Zero(3 * r.nc());
  if (settings_.integrator.deflection_compensation > 0.0 &&
      robot_.description.servo_stiffness.size() != r.nj()) {
    throw std::invalid_argument(
        "BaselinePipeline: integrator.deflection_compensation needs the robot description's "
        "servo_stiffness (one per joint)");
  }
}

BaselinePipeline::~BaselinePipeline() = default;

JointCommand BaselinePipeline::makeCommand() const {
  JointCommand c;
  c.joint_position = robot_.description.nominal_joint_positions;
  c.joint_velocity = Eigen::VectorXd::Zero(robot().nj());
  c.wheel_velocity = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(drive_wheels_.size()));
  return c;
}

std::uint64_t BaselinePipeline::setTerrain(const planning::TerrainModel& terrain,
                                           const planning::TerrainModel& collision_terrain) {
  if (terrain.size() == 0 || !contacts_->acceptsTerrain(terrain) ||
      terrain.maxEdges() > filter().maxRegionEdges() ||
      collision_terrain.size() > filter().maxCollisionPrisms()) {
    return 0;
  }
  return terrain_in_.publish(TerrainPair{terrain, collision_terrain});
}

void BaselinePipeline::initialize(const RobotState& state,
                                  const planning::BaseVelocityCommand& command) {
  if (!state.valid(robot().nj())) {
    throw std::invalid_argument(
        "BaselinePipeline::initialize: the state is not valid (non-finite values, a quaternion "
        "that is not unit, or joint vectors of the wrong size)");
  }
  toModelState(state, q_meas_, v_meas_);
  tracking_->reset(q_meas_, v_meas_);
  planner_->reset(state.time, q_meas_, command);
  counters_ = PipelineCounters{};
  initialized_ = true;
}

void BaselinePipeline::computeTargets() noexcept {
  const centroidal::CentroidalRobot& r = robot();
  const FeedbackSettings& fb = settings_.feedback;
  const Eigen::VectorXd& v = tracking_->v();
  const int nj = r.nj();
  // Configuration error plan (-) internal, in the internal state's tangent (LOCAL).
  const Eigen::VectorXd& dq = tracking_->configurationError(plan_.q);
  AccelerationTargets& targets = tracking_->targets();
  targets.base = fb.base_kp.cwiseProduct(dq.head<6>()) +
                 fb.base_kd.cwiseProduct(plan_.v.head<6>() - v.head<6>());
  targets.joints = fb.joint_kp * dq.tail(nj) - fb.joint_kd * v.tail(nj);
  const double stance = settings_.baseline.stance_foot_gain;
  const Eigen::Matrix3Xd& foot_p = tracking_->footPositions();
  const Eigen::Matrix3Xd& foot_v = tracking_->footVelocities();
  for (int i = 0; i < r.nc(); ++i) {
    const double scale = centroidal::CentroidalRobot::inStance(plan_.mode, i) ? stance : 1.0;
    targets.feet.col(i) = scale * (fb.foot_kp * (plan_.foot_position.col(i) - foot_p.col(i)) +
                                   fb.foot_kd * (plan_.foot_velocity.col(i) - foot_v.col(i)));
  }
}

void BaselinePipeline::tick(const RobotState& state, JointCommand& command) noexcept {
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
  toModelState(state, q_meas_, v_meas_);

  // A new terrain (setTerrain): swapped in, the planner's indices moved onto it.
  std::uint64_t version = 0;
  if (terrain_in_.take(incoming_, version) && contacts_->swapTerrain(incoming_.footholds)) {
    collision_terrain_->swap(incoming_.solids);
    planner_->remapRegions(incoming_.footholds);
    terrain_version_ = version;
    ++counters_.terrain_updates;
  }
  record_.terrain_version = terrain_version_;

  // Feet at the internal state; plan, targets, safety filter, integrator.
  tracking_->updateFeet();
  planner_->plan(t, q_meas_, tracking_->q(), tracking_->footPositions(), plan_);
  record_.mode = plan_.mode;
  computeTargets();
  tracking_->safetyFilter().setSupportFeet(plan_.support_mask);
  if (tracking_->filter(plan_.mode, plan_.regions.data(), record_, counters_)) {
    // The filter's fallback keeps the base velocity; here the commanded base brakes as well:
    // the drive wheels follow the commanded base, and rolling on unfiltered carries a
    // stance wheel over an edge.
    tracking_->acceleration().head<6>() =
        -tracking_->v().head<6>() / settings_.cbf_qp.fallback_brake_time;
  }
  tracking_->step(q_meas_, v_meas_, command);

  // Commands.
  computeDriveWheelSpeeds(r, *data_, tracking_->q(), tracking_->v(), drive_wheels_, 0.0,
                          Eigen::Vector2d::Zero(), command.wheel_velocity);
  const double compensation = settings_.integrator.deflection_compensation;
  if (compensation > 0.0) {
    // As the NMPC pipeline's, with no planned forces: the weight spread evenly over the
    // stance feet. Each servo sits tau / K short of its command under the static torque tau:
    // command that much further (compliant servos otherwise sag, and the blend of the
    // measured state into the internal one carries the sag into the next command).
    int stance = 0;
    for (int i = 0; i < r.nc(); ++i) {
      if (centroidal::CentroidalRobot::inStance(plan_.mode, i)) ++stance;
    }
    stance_forces_.setZero();
    for (int i = 0; i < r.nc() && stance > 0; ++i) {
      if (centroidal::CentroidalRobot::inStance(plan_.mode, i)) {
        stance_forces_[3 * i + 2] = -r.mass() * r.model().gravity.z() / stance;
      }
    }
    const Eigen::VectorXd& tau =
        model::computeStaticTorque(r.model(), *data_, tracking_->q(), r.frameIds(), stance_forces_);
    command.joint_position.array() +=
        compensation * tau.tail(r.nj()).array() / robot_.description.servo_stiffness.array();
  }
}

}  // namespace rollstep::control
