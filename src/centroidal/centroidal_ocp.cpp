#include "rollstep/centroidal/centroidal_ocp.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "rollstep/centroidal/costs.hpp"
#include "rollstep/centroidal/dynamics.hpp"
#include "rollstep/centroidal/equalities.hpp"
#include "rollstep/centroidal/inequalities.hpp"
#include "rollstep/model/kinematics.hpp"
#include "rollstep/ocp/cost.hpp"
#include "rollstep/ocp/dynamics.hpp"

namespace rollstep::centroidal {

planning::GaitKind gaitKindFromString(const std::string& name) {
  if (name == "standing") return planning::GaitKind::Standing;
  if (name == "rolling") return planning::GaitKind::Rolling;
  if (name == "trot") return planning::GaitKind::Trot;
  if (name == "static_walk") return planning::GaitKind::StaticWalk;
  throw std::invalid_argument("unknown gait '" + name +
                              "' (expected standing, rolling, trot or static_walk)");
}

const char* toString(planning::GaitKind kind) {
  switch (kind) {
    case planning::GaitKind::Standing:
      return "standing";
    case planning::GaitKind::Rolling:
      return "rolling";
    case planning::GaitKind::Trot:
      return "trot";
    case planning::GaitKind::StaticWalk:
      return "static_walk";
    case planning::GaitKind::Custom:
      return "custom";
  }
  return "?";
}

namespace {

int indexOf(const std::vector<std::string>& names, const std::string& name) {
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name) return static_cast<int>(i);
  }
  throw std::invalid_argument("'" + name + "' is not a contact frame");
}

planning::Gait makeGait(planning::GaitKind kind, const RobotOcpDescription& d,
                        const OcpSettings& s) {
  const int nc = static_cast<int>(d.contact_frames.size());
  switch (kind) {
    case planning::GaitKind::Standing:
      return planning::Gait::standing(nc, s.gait_period);
    case planning::GaitKind::Rolling:
      return planning::Gait::rolling(nc, s.gait_period);
    case planning::GaitKind::Trot:
      if (d.trot_group_a.empty() || d.trot_group_b.empty()) {
        throw std::invalid_argument("the robot description gives no trot_groups: cannot trot");
      }
      return planning::Gait::trot(nc, s.gait_period, s.trot_duty,
                                  planning::contactMask(d.contact_frames, d.trot_group_a),
                                  planning::contactMask(d.contact_frames, d.trot_group_b));
    case planning::GaitKind::StaticWalk: {
      if (d.walk_order.empty()) {
        throw std::invalid_argument("the robot description gives no walk_order: cannot walk");
      }
      std::vector<int> order;
      for (const std::string& name : d.walk_order) order.push_back(indexOf(d.contact_frames, name));
      return planning::Gait::staticWalk(nc, s.walk_period, s.walk_duty, order);
    }
    case planning::GaitKind::Custom:
      break;
  }
  throw std::invalid_argument("CentroidalOcp: a custom gait needs its table (not supported here)");
}

Eigen::VectorXd repeat(double value, int n) { return Eigen::VectorXd::Constant(n, value); }

}  // namespace

CentroidalOcp::CentroidalOcp(const RobotOcpDescription& description, const OcpSettings& settings,
                             planning::TerrainModel terrain, planning::GaitKind gait,
                             int region_edge_capacity)
    : settings_(settings), contact_names_(description.contact_frames) {
  if (region_edge_capacity < 0) {
    throw std::invalid_argument("CentroidalOcp: region_edge_capacity = " +
                                std::to_string(region_edge_capacity) + " must be >= 0");
  }
  // --- the robot --------------------------------------------------------------------------
  auto model =
      std::make_shared<const model::Model>(model::buildModelFromUrdfFile(description.urdf));
  std::vector<ContactDescription> contacts;
  for (const std::string& frame : description.contact_frames) {
    bool drive = false;
    for (const std::string& w : description.drive_wheels) drive = drive || w == frame;
    contacts.push_back({frame, drive});
  }
  std::vector<std::array<int, 2>> pairs;
  for (const auto& p : description.side_pairs) {
    pairs.push_back(
        {indexOf(description.contact_frames, p[0]), indexOf(description.contact_frames, p[1])});
  }
  robot_ =
      std::make_shared<const CentroidalRobot>(model, contacts, pairs, description.contact_offset);
  const int nj = robot_->nj(), nc = robot_->nc(), ndx = robot_->ndx(), nu = robot_->nu();
  const std::string description_name = description.source.empty()
                                           ? std::string("robot description: ")
                                           : "robot description " + description.source + ": ";
  const auto requireOnePerJoint = [&](const char* key, const Eigen::VectorXd& values) {
    if (values.size() != nj) {
      throw std::invalid_argument(description_name + std::string(key) + " has " +
                                  std::to_string(values.size()) + " entries, the URDF " +
                                  description.urdf + " has " + std::to_string(nj) + " joints");
    }
  };
  requireOnePerJoint("nominal_joint_positions", description.nominal_joint_positions);
  for (int j = 0; j < nj; ++j) {  // the posture every term pulls towards must be reachable
    const double q = description.nominal_joint_positions[j];
    const double lo = model->lowerPositionLimit[j], hi = model->upperPositionLimit[j];
    if (q < lo || q > hi) {
      std::ostringstream os;
      os << description_name << "nominal_joint_positions[" << j << "] = " << q << " for joint '"
         << model->jointNames[static_cast<std::size_t>(j)] << "' is outside its limits [" << lo
         << ", " << hi << "] in the URDF " << description.urdf;
      throw std::invalid_argument(os.str());
    }
  }
  q_joint_ref_ = description.nominal_joint_positions;
  if (description.servo_stiffness.size() != 0) {
    requireOnePerJoint("servo_stiffness", description.servo_stiffness);
  }
  servo_stiffness_ = description.servo_stiffness;
  // The nodes' precomputation; it also caches every foot's planner reference once the
  // planner exists (below): the terrain and swing terms read them instead of querying the
  // planner once per term and call.
  auto pre = std::make_shared<CentroidalPrecomputation>(robot_);
  pre_ = pre;
  scratch_ = std::make_unique<CentroidalCache>(*robot_);
  anchor_data_ = std::make_unique<model::Data>(robot_->model());
  settled_stance_.assign(static_cast<std::size_t>(robot_->nc()),
                         std::numeric_limits<double>::quiet_NaN());
  landings_.assign(static_cast<std::size_t>(robot_->nc()), LandingPlan{});

  // --- nominal footholds and height, from the URDF at the nominal posture -------------------
  {
    Eigen::VectorXd x = Eigen::VectorXd::Zero(robot_->nx());
    x[6] = 1.0;  // identity quaternion (x, y, z, w)
    x.segment(robot_->stateJointIndex(), nj) = q_joint_ref_;
    pre_->compute(x, Eigen::VectorXd::Zero(nu), false, *scratch_);
    double height = 0.0;
    for (int i = 0; i < nc; ++i) {
      const Eigen::Vector3d p = scratch_->footPosition(i);
      nominal_feet_.emplace_back(p.x(), p.y());
      height += -p.z() + robot_->contactOffset();
    }
    nominal_height_ = height / nc;
  }

  // --- planning inputs ------------------------------------------------------------------------
  terrain_ = std::make_unique<planning::TerrainModel>(std::move(terrain));
  region_edge_capacity_ = std::max(region_edge_capacity, terrain_->maxEdges());
  has_regions_ = terrain_->size() > 0;
  planning::BaseReferenceConfig base_config;
  base_config.nominal_height = nominal_height_;
  base_config.height_samples = nominal_feet_;  // the body rises as the feet climb
  base_config.height_reach = settings.base_height_reach;
  base_config.height_slope = settings.base_height_slope;
  base_config.height_rate = settings.base_height_rate;
  base_ = std::make_shared<planning::BaseReference>(*terrain_, base_config);
  planning::FootReferenceConfig foot_config;
  foot_config.nominal_feet = nominal_feet_;
  foot_config.swing_clearance = settings.swing_clearance;
  foot_config.swing_apex_margin = settings.swing_apex_margin;
  foot_config.gap_reach = settings.foothold_gap_reach;
  foot_config.foot_height_offset = robot_->contactOffset();
  feet_ = std::make_shared<planning::FootReferencePlanner>(*terrain_, *base_, foot_config);
  pre->setFootPlanner(feet_);
  const double horizon_time = settings.horizon * settings.dt;
  scheduler_ = std::make_unique<planning::GaitScheduler>(makeGait(gait, description, settings),
                                                         horizon_time);
  hold_config_.max_down_hold = settings.step_down_max_hold;
  hold_config_.lead = settings.edge_hold_lead;
  hold_config_.reach = settings.step_down_reach;
  hold_config_.max_up_hold = settings.step_up_max_hold;
  hold_config_.setback = settings.step_up_setback;
  hold_config_.up_reach = settings.step_up_reach;

  // --- the problem -----------------------------------------------------------------------------
  auto dynamics = std::make_shared<ocp::ExplicitEuler>(std::make_shared<CentroidalDynamics>(pre_));
  // The schedule's capacity: the gait's switches and one landing per foot (landLateFeet).
  problem_ = std::make_shared<ocp::OptimalControlProblem>(
      dynamics, settings.horizon, settings.dt, scheduler_->requiredCapacity() + robot_->nc());
  problem_->setPrecomputation(pre_);
  problem_->setCoordinateNames(robot_->tangentNames(), robot_->inputNames());

  // Costs.
  problem_->addCost("base_velocity", std::make_shared<ocp::LeastSquaresCost>(
                                         std::make_shared<BaseVelocityResidual>(pre_, base_),
                                         Eigen::VectorXd(settings.base_velocity_weight)));
  Eigen::VectorXd w_state(ndx);
  w_state << settings.base_position_weight, settings.base_orientation_weight,
      repeat(settings.joint_position_weight, nj), settings.momentum_weight;
  auto state_residual = std::make_shared<StateTrackingResidual>(robot_, q_joint_ref_, base_);
  problem_->addCost("state", std::make_shared<ocp::LeastSquaresCost>(state_residual, w_state));
  problem_->addCost("terminal_state",
                    std::make_shared<ocp::LeastSquaresCost>(
                        state_residual, settings.terminal_weight_scale * w_state),
                    ocp::Stage::Terminal);
  Eigen::VectorXd w_input(nu);
  w_input << repeat(settings.joint_velocity_weight, nj), repeat(settings.force_weight, 3 * nc);
  problem_->addCost("input", std::make_shared<ocp::LeastSquaresCost>(
                                 std::make_shared<InputTrackingResidual>(robot_), w_input));

  // Skid steering: the drive wheels' lateral rows leave the equalities (and the freed-row
  // cost) for a cost of their own on every stance drive wheel.
  const bool skid = settings.lateral_slip_weight > 0.0;
  auto freed = std::make_shared<StanceVelocityResidual>(
      pre_, StanceRows::Freed, skid ? StanceComponents::VerticalOnly : StanceComponents::All);
  problem_->addCost("freed_stance_velocity",
                    std::make_shared<ocp::LeastSquaresCost>(
                        freed, repeat(settings.freed_stance_velocity_weight, freed->maxRows())));

  if (skid) {
    auto slip = std::make_shared<StanceVelocityResidual>(pre_, StanceRows::All,
                                                         StanceComponents::LateralOnly);
    problem_->addCost("lateral_slip",
                      std::make_shared<ocp::LeastSquaresCost>(
                          slip, repeat(settings.lateral_slip_weight, slip->maxRows())));
  }

  // Equalities.
  problem_->addEquality("swing_force", std::make_shared<SwingForceResidual>(robot_));
  problem_->addEquality(
      "stance_velocity",
      std::make_shared<StanceVelocityResidual>(
          pre_, StanceRows::Kept, skid ? StanceComponents::VerticalOnly : StanceComponents::All));
  problem_->addEquality(
      "swing_height", std::make_shared<SwingHeightResidual>(pre_, feet_, settings.swing_height_gain,
                                                            settings.swing_height_max_correction));

  // Real-time warm start: a node appended by the shift, or whose mode changed since the
  // last solve, gets its mode's reference contact forces (otherwise a foot that begins a
  // swing there keeps its stance force against f = 0, and a step cut by the fraction to the
  // boundary leaves most of that violation in place, update after update).
  problem_->setInputGuess(
      [robot = robot_](const ocp::NodeContext& ctx, ocp::ConstVecRef, ocp::VecRef u) {
        setStanceForceReference(*robot, ctx.mode, u);
      });

  // Inequalities.
  ocp::InequalityOptions state_only;
  state_only.soft = settings.soft_state_constraints;
  state_only.relaxation = settings.soft_relaxation;
  state_only.weight = settings.soft_weight;
  TorqueLimitOptions torque;
  torque.scale = settings.torque_limit_scale;
  problem_->addInequality("torque", std::make_shared<StaticTorqueLimitResidual>(robot_, torque));
  const TerrainReferences refs{terrain_.get(), feet_.get()};
  FrictionPyramidOptions friction;
  friction.mu = settings.friction_coefficient;
  friction.min_normal_force = settings.min_normal_force;
  problem_->addInequality("friction",
                          std::make_shared<FrictionPyramidResidual>(robot_, refs, friction));
  ocp::InequalityOptions regions = state_only;
  regions.soft = settings.soft_state_constraints || settings.soft_region_constraints;
  if (terrain_->size() > 0) {
    problem_->addInequality("stance_region",
                            std::make_shared<FootRegionResidual>(robot_, refs, RegionUse::Stance,
                                                                 region_edge_capacity_),
                            ocp::Stage::Running, regions);
    problem_->addInequality(
        "swing_region",
        std::make_shared<FootRegionResidual>(robot_, refs, RegionUse::Swing, region_edge_capacity_),
        ocp::Stage::Running, regions);
  }
  JointLimitBoundOptions limits;
  limits.position_margin = settings.joint_limit_margin;
  limits.velocity_scale = settings.velocity_limit_scale;
  const JointLimitBounds bounds = jointLimitBounds(*robot_, limits);
  problem_->setStateBounds(bounds.state_lower, bounds.state_upper, state_only);
  ocp::InequalityOptions velocity = state_only;
  velocity.soft = settings.soft_velocity_limits;
  problem_->setInputBounds(bounds.input_lower, bounds.input_upper, velocity);

  reset(0.0, lie::SE3::Identity(), planning::BaseVelocityCommand{});
}

void CentroidalOcp::reset(double t0, const lie::SE3& start,
                          const planning::BaseVelocityCommand& command) {
  base_->reset(t0, start, command);
  feet_->clearAnchors();
  clock_.clear();
  advance(t0);
}

void CentroidalOcp::resetSchedule(double t0, const lie::SE3& start,
                                  const std::vector<planning::TimedBaseCommand>& schedule) {
  base_->resetSchedule(t0, start, schedule);
  feet_->clearAnchors();
  std::fill(settled_stance_.begin(), settled_stance_.end(),
            std::numeric_limits<double>::quiet_NaN());
  for (LandingPlan& plan : landings_) plan.valid = false;
  clock_.clear();
  advance(t0);
}

void CentroidalOcp::advance(double t0) {
  problem_->setInitialTime(t0);
  const double horizon = settings_.horizon * settings_.dt;
  planning::planEdgeHolds(scheduler_->gait(), *feet_, hold_config_, t0, horizon, clock_);
  scheduler_->fill(t0, horizon, problem_->modeSchedule(), clock_);
}

bool CentroidalOcp::followRobot(double t, const lie::SE3& base_pose, double max_distance,
                                double max_yaw) {
  return base_->follow(t, base_pose, max_distance, max_yaw);
}

bool CentroidalOcp::setReferenceCorrection(const lie::SE3& correction) noexcept {
  return base_->setCorrection(correction);
}

bool CentroidalOcp::acceptsTerrain(const planning::TerrainModel& terrain) const noexcept {
  return (terrain.size() > 0) == has_regions_ && terrain.maxEdges() <= region_edge_capacity_;
}

bool CentroidalOcp::swapTerrain(planning::TerrainModel& terrain) noexcept {
  if (!acceptsTerrain(terrain)) return false;
  terrain_->swap(terrain);
  return true;
}

void CentroidalOcp::anchorStanceFeet(const ocp::ModeSchedule& schedule, double t,
                                     const Eigen::VectorXd& x) noexcept {
  if (!settings_.anchor_stance_feet && !settings_.latch_touchdowns) return;
  if (x.size() != robot_->nx() || !x.allFinite() || !std::isfinite(t)) return;
  if (schedule.modes().empty()) return;
  if (settings_.latch_touchdowns) {
    for (int i = 0; i < robot_->nc(); ++i) {
      const planning::FootPhase phase = planning::footPhase(schedule, i, t);
      if (!phase.stance && phase.bounded()) feet_->latchTouchdown(i, phase.touchdown);
    }
  }
  if (!settings_.anchor_stance_feet) return;
  const model::Model& model = robot_->model();
  model::forwardKinematics(model, *anchor_data_, x.head(robot_->nq()));
  for (int i = 0; i < robot_->nc(); ++i) {
    const double start = planning::FootReferencePlanner::stanceStartAt(schedule, i, t);
    if (std::isnan(start)) continue;  // in swing: its lift-off anchor stays
    const model::FrameIndex f = robot_->frameIds()[static_cast<std::size_t>(i)];
    model::updateFramePlacement(model, *anchor_data_, f);
    feet_->anchorStance(i, start, anchor_data_->opf[static_cast<std::size_t>(f)].head<2>());
  }
}

int CentroidalOcp::landLateFeet(ocp::ModeSchedule& schedule, double t,
                                const Eigen::VectorXd& x) noexcept {
  const double tolerance = settings_.late_touchdown_tolerance;
  if (tolerance <= 0.0) return 0;
  const int nc = robot_->nc();
  if (x.size() != robot_->nx() || !x.allFinite() || !std::isfinite(t) || schedule.modes().empty()) {
    for (int i = 0; i < nc; ++i) feet_->clearLanding(i);
    return 0;
  }
  const model::Model& model = robot_->model();
  model::forwardKinematics(model, *anchor_data_, x.head(robot_->nq()));
  int late = 0;
  for (int i = 0; i < nc; ++i) {
    const std::size_t fi = static_cast<std::size_t>(i);
    const double start = planning::FootReferencePlanner::stanceStartAt(schedule, i, t);
    // In swing, or a stance that began before the schedule (nothing to delay).
    if (!std::isfinite(start)) {
      feet_->clearLanding(i);
      continue;
    }
    if (std::abs(settled_stance_[fi] - start) <= 1e-6) {
      feet_->clearLanding(i);
      continue;
    }
    const planning::FootPhase swing = planning::footPhase(
        schedule, i, std::nextafter(start, -std::numeric_limits<double>::infinity()));
    const double duration = swing.bounded() ? start - swing.liftoff : 0.0;
    const double surface = feet_->query(schedule, i, t).z_ref;  // the stance's, + offset
    const model::FrameIndex f = robot_->frameIds()[fi];
    model::updateFramePlacement(model, *anchor_data_, f);
    const double z = anchor_data_->opf[static_cast<std::size_t>(f)].z();
    if (z <= surface + tolerance || t >= start + settings_.late_touchdown_max_delay * duration) {
      settled_stance_[fi] = start;  // landed, or too late: the stance goes on as scheduled
      feet_->clearLanding(i);
      continue;
    }
    // The descent planned at the first call that found this stance late stays (a reference
    // re-planned from the measured height at every call would always start at rest); only
    // a foot still up at its landing time gets a new one, from where it is.
    LandingPlan& plan = landings_[fi];
    if (!plan.valid || std::abs(plan.stance - start) > 1e-6 || t >= plan.landing) {
      plan.valid = true;
      plan.stance = start;
      plan.from = t;
      plan.z_from = z;
      plan.landing =
          t + std::max(2.0 * settings_.dt, (z - surface) / settings_.late_touchdown_speed);
    }
    if (!planning::delayTouchdown(schedule, i, start, plan.landing)) {
      settled_stance_[fi] = start;  // no room in the stance: as scheduled
      feet_->clearLanding(i);
      continue;
    }
    feet_->setLanding(i, start, plan.from, plan.z_from, plan.landing, surface);
    late |= 1 << i;
  }
  return late;
}

Eigen::VectorXd CentroidalOcp::standingState(double x, double y, double yaw) const {
  Eigen::VectorXd state = Eigen::VectorXd::Zero(robot_->nx());
  const Eigen::Quaterniond q(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  // Terrain height under the nominal feet at this pose, like the base reference.
  const Eigen::Rotation2Dd R(yaw);
  double ground = 0.0;
  for (const Eigen::Vector2d& foot : nominal_feet_) {
    ground += terrain_->heightAt(Eigen::Vector2d(x, y) + R * foot, 0.0);
  }
  ground /= static_cast<double>(nominal_feet_.size());
  state.head<3>() = Eigen::Vector3d(x, y, ground + nominal_height_);
  state.segment<4>(3) = q.coeffs();
  state.segment(robot_->stateJointIndex(), robot_->nj()) = q_joint_ref_;
  return state;
}

void CentroidalOcp::initialGuess(std::vector<Eigen::VectorXd>& xs,
                                 std::vector<Eigen::VectorXd>& us) const {
  const int N = problem_->horizon();
  xs.assign(static_cast<std::size_t>(N + 1), Eigen::VectorXd());
  us.assign(static_cast<std::size_t>(N), Eigen::VectorXd());
  InputTrackingResidual input(robot_);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(robot_->nx());
  x.segment(robot_->stateJointIndex(), robot_->nj()) = q_joint_ref_;
  for (int k = 0; k <= N; ++k) {
    const ocp::NodeContext ctx = problem_->context(k);
    const lie::Vector7d pose = base_->poseAt(ctx.time).coeffs();
    for (int i = 0; i < 7; ++i) x[i] = pose[i];
    xs[static_cast<std::size_t>(k)] = x;
    if (k < N) {
      Eigen::VectorXd u(robot_->nu());
      input.reference(ctx, u);
      us[static_cast<std::size_t>(k)] = u;
    }
  }
}

Eigen::Matrix3Xd CentroidalOcp::footPositions(const Eigen::VectorXd& x) const {
  pre_->compute(x, Eigen::VectorXd::Zero(robot_->nu()), false, *scratch_);
  return scratch_->nq.contactPositions;
}

Eigen::Matrix3Xd CentroidalOcp::footVelocities(const Eigen::VectorXd& x,
                                               const Eigen::VectorXd& u) const {
  pre_->compute(x, u, false, *scratch_);
  return scratch_->nq.contactVelocities;
}

lie::Vector6d CentroidalOcp::baseTwist(const Eigen::VectorXd& x, const Eigen::VectorXd& u) const {
  pre_->compute(x, u, false, *scratch_);
  return scratch_->vb;
}

Eigen::VectorXd CentroidalOcp::jointTorques(const Eigen::VectorXd& x,
                                            const Eigen::VectorXd& u) const {
  StaticTorqueLimitResidual torque(robot_);
  auto data = torque.createData();
  ocp::NodeContext ctx;  // no cache: the term computes its own
  return torque.torques(ctx, x, u, *data);
}

std::vector<ConstraintViolation> constraintViolations(const ocp::OptimalControlProblem& problem,
                                                      const std::vector<Eigen::VectorXd>& xs,
                                                      const std::vector<Eigen::VectorXd>& us) {
  const int N = problem.horizon();
  if (static_cast<int>(xs.size()) != N + 1 || static_cast<int>(us.size()) != N) {
    throw std::invalid_argument("constraintViolations: expected N+1 states and N inputs");
  }
  std::vector<ConstraintViolation> out;
  const auto slot = [&](const std::string& group) -> ConstraintViolation& {
    for (ConstraintViolation& v : out) {
      if (v.group == group) return v;
    }
    out.push_back({group, 0.0, -1, {}});
    return out.back();
  };
  slot("dynamics");
  for (const std::string& name : problem.equalityNames()) slot(name);
  for (const std::string& name : problem.inequalityNames()) slot(name);
  slot("state_bounds");
  slot("input_bounds");
  // Returns the group's entry when value is its new worst (the caller names the row).
  const auto note = [&](const std::string& group, double value, int k) -> ConstraintViolation* {
    ConstraintViolation& v = slot(group);
    // NaN counts as the worst: it replaces any value and nothing replaces it.
    if (std::isnan(v.value) || value <= v.value) return nullptr;
    v.value = value;
    v.node = k;
    return &v;
  };
  // The entry of v with the largest |value| (largest) or the most negative value; a NaN
  // entry first of all.
  const auto worstEntry = [](const Eigen::Ref<const Eigen::VectorXd>& v, bool largest) {
    for (Eigen::Index j = 0; j < v.size(); ++j) {
      if (std::isnan(v[j])) return static_cast<int>(j);
    }
    Eigen::Index i = 0;
    if (largest) {
      v.cwiseAbs().maxCoeff(&i);
    } else {
      v.minCoeff(&i);
    }
    return static_cast<int>(i);
  };
  auto running = problem.createNodeData();
  auto terminal = problem.createNodeData();  // fresh: running terms keep rows = 0 there
  const ocp::StateSpace& space = problem.stateSpace();
  Eigen::VectorXd defect(problem.ndx());
  const Eigen::VectorXd zero_u = Eigen::VectorXd::Zero(problem.nu());
  for (int k = 0; k <= N; ++k) {
    const Eigen::VectorXd& x = xs[static_cast<std::size_t>(k)];
    const Eigen::VectorXd& u = k < N ? us[static_cast<std::size_t>(k)] : zero_u;
    ocp::NodeData* data = k < N ? running.get() : terminal.get();
    problem.evaluate(k, x, u, *data);
    if (k < N) {
      space.difference(data->xnext, xs[static_cast<std::size_t>(k + 1)], defect);
      const int worst = worstEntry(defect, true);
      if (ConstraintViolation* v = note("dynamics", std::abs(defect[worst]), k)) {
        v->row = problem.tangentName(worst);
      }
      for (std::size_t j = 0; j < data->equality_data.size(); ++j) {
        const ocp::ResidualData& r = *data->equality_data[j];
        if (r.rows <= 0) continue;
        const int row = worstEntry(r.r.head(r.rows), true);
        if (ConstraintViolation* v = note(problem.equalityNames()[j], std::abs(r.r[row]), k)) {
          v->row = problem.equality(j).rowName(problem.context(k), row);
        }
      }
      const ocp::BoundSet& ub = problem.inputBounds();
      for (int b = 0; b < ub.size(); ++b) {
        const double v = u[ub.index[static_cast<std::size_t>(b)]];
        double excess = 0.0;
        if (ub.has_lower[static_cast<std::size_t>(b)]) excess = std::max(excess, ub.lower[b] - v);
        if (ub.has_upper[static_cast<std::size_t>(b)]) excess = std::max(excess, v - ub.upper[b]);
        if (ConstraintViolation* w = note("input_bounds", excess, k)) {
          w->row = problem.inputName(ub.index[static_cast<std::size_t>(b)]);
        }
      }
    }
    int offset = 0;  // of the term's rows in the stacked inequality block
    for (std::size_t j = 0; j < data->inequality_data.size(); ++j) {
      const ocp::ResidualData& r = *data->inequality_data[j];
      if (r.rows <= 0) continue;
      // x_0 is data: the solver does not impose state-only rows there.
      const bool skip = k == 0 && data->state_only[offset];
      offset += r.rows;
      if (!skip) {
        const int row = worstEntry(r.r.head(r.rows), false);
        const double value = std::isnan(r.r[row]) ? r.r[row] : std::max(0.0, -r.r[row]);
        if (ConstraintViolation* v = note(problem.inequalityNames()[j], value, k)) {
          v->row = problem.inequality(j).rowName(problem.context(k), row);
        }
      }
    }
    if (k > 0) {  // x_0 is data: its bounds are not imposed
      const ocp::BoundSet& sb = problem.stateBounds();
      const int rep = problem.nx() - problem.ndx();  // representation index offset
      for (int b = 0; b < sb.size(); ++b) {
        const double v = x[sb.index[static_cast<std::size_t>(b)] + rep];
        double excess = 0.0;
        if (sb.has_lower[static_cast<std::size_t>(b)]) excess = std::max(excess, sb.lower[b] - v);
        if (sb.has_upper[static_cast<std::size_t>(b)]) excess = std::max(excess, v - sb.upper[b]);
        if (ConstraintViolation* w = note("state_bounds", excess, k)) {
          w->row = problem.tangentName(sb.index[static_cast<std::size_t>(b)]);
        }
      }
    }
  }
  return out;
}

}  // namespace rollstep::centroidal
