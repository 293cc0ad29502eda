#include "rollstep/centroidal/centroidal_ocp.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "rollstep/centroidal/contact_equalities.hpp"
#include "rollstep/centroidal/costs.hpp"
#include "rollstep/centroidal/dynamics.hpp"
#include "rollstep/centroidal/inequalities.hpp"
#include "rollstep/centroidal/swing_height.hpp"
#include "rollstep/ocp/cost.hpp"
#include "rollstep/ocp/dynamics.hpp"

namespace rollstep::centroidal {

planning::GaitKind gaitKindFromString(const std::string& name) {
  // Every named gait but Custom (a table, not a name).
  const std::optional<planning::GaitKind> kind = enumFromName<planning::GaitKind>(name);
  if (!kind || *kind == planning::GaitKind::Custom) {
    throw std::invalid_argument("unknown gait '" + name +
                                "' (expected standing, rolling, trot or static_walk)");
  }
  return *kind;
}

const char* toString(planning::GaitKind kind) { return enumName(kind, "?"); }

namespace {

Eigen::VectorXd repeat(double value, int n) { return Eigen::VectorXd::Constant(n, value); }

}  // namespace

CentroidalOcp::CentroidalOcp(const RobotOcpDescription& description, const OcpSettings& settings,
                             planning::TerrainModel terrain, planning::GaitKind gait,
                             int region_edge_capacity)
    : settings_(settings) {
  if (region_edge_capacity < 0) {
    throw std::invalid_argument("CentroidalOcp: region_edge_capacity = " +
                                std::to_string(region_edge_capacity) + " must be >= 0");
  }
  loaded_ = loadRobot(description);
  const std::shared_ptr<const CentroidalRobot>& robot_ptr = loaded_.robot;
  const Eigen::VectorXd& q_joint_ref = loaded_.description.nominal_joint_positions;
  const int nj = robot_ptr->nj(), nc = robot_ptr->nc(), ndx = robot_ptr->ndx(),
            nu = robot_ptr->nu();
  // The nodes' precomputation; it also caches every foot's planner reference (below): the
  // terrain and swing terms read them instead of querying the planner once per term and call.
  auto pre = std::make_shared<CentroidalPrecomputation>(robot_ptr);
  pre_ = pre;
  scratch_ = std::make_unique<CentroidalCache>(*robot_ptr);
  feet_data_ = std::make_unique<model::Data>(robot_ptr->model());
  feet_ = Eigen::Matrix3Xd::Zero(3, nc);

  // --- planning inputs ------------------------------------------------------------------------
  planner_ = makeContactPlanner(loaded_, settings, std::move(terrain), gait, region_edge_capacity);
  // The terms hold the planner's references through pointers that keep the planner alive.
  const std::shared_ptr<const planning::BaseReference> base_ref(planner_,
                                                                &planner_->baseReference());
  const std::shared_ptr<const planning::FootReferencePlanner> foot_refs(planner_,
                                                                        &planner_->footPlanner());
  const planning::TerrainModel* terrain_model = &planner_->terrain();
  pre->setFootPlanner(foot_refs);

  // --- the problem -----------------------------------------------------------------------------
  auto dynamics = std::make_shared<ocp::ExplicitEuler>(std::make_shared<CentroidalDynamics>(pre_));
  problem_ = std::make_shared<ocp::OptimalControlProblem>(dynamics, settings.horizon, settings.dt,
                                                          planner_->scheduleCapacity());
  problem_->setPrecomputation(pre_);
  problem_->setCoordinateNames(robot_ptr->tangentNames(), robot_ptr->inputNames());

  // Costs.
  problem_->addCost("base_velocity", std::make_shared<ocp::LeastSquaresCost>(
                                         std::make_shared<BaseVelocityResidual>(pre_, base_ref),
                                         Eigen::VectorXd(settings.base_velocity_weight)));
  Eigen::VectorXd w_state(ndx);
  w_state << settings.base_position_weight, settings.base_orientation_weight,
      repeat(settings.joint_position_weight, nj), settings.momentum_weight;
  auto state_residual = std::make_shared<StateTrackingResidual>(robot_ptr, q_joint_ref, base_ref);
  problem_->addCost("state", std::make_shared<ocp::LeastSquaresCost>(state_residual, w_state));
  problem_->addCost("terminal_state",
                    std::make_shared<ocp::LeastSquaresCost>(
                        state_residual, settings.terminal_weight_scale * w_state),
                    ocp::Stage::Terminal);
  Eigen::VectorXd w_input(nu);
  w_input << repeat(settings.joint_velocity_weight, nj), repeat(settings.force_weight, 3 * nc);
  problem_->addCost("input", std::make_shared<ocp::LeastSquaresCost>(
                                 std::make_shared<InputTrackingResidual>(robot_ptr), w_input));

  // Skid steering: the drive wheels' lateral rows leave the equalities (and the freed-row
  // cost) for a cost of their own on every stance drive wheel.
  const bool skid = settings.lateral_slip_weight > 0.0;
  // Terrain normals of the stance velocity rows, the friction cones and the regions.
  const TerrainReferences refs{terrain_model, foot_refs.get()};
  auto freed = std::make_shared<StanceVelocityResidual>(
      pre_, StanceRows::Freed, skid ? StanceComponents::VerticalOnly : StanceComponents::All, refs);
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
  problem_->addEquality("swing_force", std::make_shared<SwingForceResidual>(robot_ptr));
  problem_->addEquality("stance_velocity",
                        std::make_shared<StanceVelocityResidual>(
                            pre_, StanceRows::Kept,
                            skid ? StanceComponents::VerticalOnly : StanceComponents::All, refs));
  problem_->addEquality("swing_height", std::make_shared<SwingHeightResidual>(
                                            pre_, foot_refs, settings.swing_height_gain,
                                            settings.swing_height_max_correction));

  // Real-time warm start: a node appended by the shift, or whose mode changed since the
  // last solve, gets its mode's reference contact forces (otherwise a foot that begins a
  // swing there keeps its stance force against f = 0, and a step cut by the fraction to the
  // boundary leaves most of that violation in place, update after update).
  problem_->setInputGuess(
      [robot = robot_ptr](const ocp::NodeContext& ctx, ocp::ConstVecRef, ocp::VecRef u) {
        setStanceForceReference(*robot, ctx.mode, u);
      });

  // Inequalities.
  ocp::InequalityOptions state_only;
  state_only.soft = settings.soft_state_constraints;
  state_only.relaxation = settings.soft_relaxation;
  state_only.weight = settings.soft_weight;
  TorqueLimitOptions torque;
  torque.scale = settings.torque_limit_scale;
  problem_->addInequality("torque", std::make_shared<StaticTorqueLimitResidual>(robot_ptr, torque));
  FrictionPyramidOptions friction;
  friction.mu = settings.friction_coefficient;
  friction.min_normal_force = settings.min_normal_force;
  problem_->addInequality("friction",
                          std::make_shared<FrictionPyramidResidual>(robot_ptr, refs, friction));
  ocp::InequalityOptions regions = state_only;
  regions.soft = settings.soft_state_constraints || settings.soft_region_constraints;
  if (terrain_model->size() > 0) {
    problem_->addInequality("stance_region",
                            std::make_shared<FootRegionResidual>(robot_ptr, refs, RegionUse::Stance,
                                                                 regionEdgeCapacity()),
                            ocp::Stage::Running, regions);
    problem_->addInequality("swing_region",
                            std::make_shared<FootRegionResidual>(robot_ptr, refs, RegionUse::Swing,
                                                                 regionEdgeCapacity()),
                            ocp::Stage::Running, regions);
  }
  JointLimitBoundOptions limits;
  limits.position_margin = settings.joint_limit_margin;
  limits.velocity_scale = settings.velocity_limit_scale;
  const JointLimitBounds bounds = jointLimitBounds(*robot_ptr, limits);
  problem_->setStateBounds(bounds.state_lower, bounds.state_upper, state_only);
  ocp::InequalityOptions velocity = state_only;
  velocity.soft = settings.soft_velocity_limits;
  problem_->setInputBounds(bounds.input_lower, bounds.input_upper, velocity);

  reset(0.0, lie::SE3::Identity(), planning::BaseVelocityCommand{});
}

void CentroidalOcp::reset(double t0, const lie::SE3& start,
                          const planning::BaseVelocityCommand& command) {
  planner_->reset(t0, start, command);
  advance(t0);
}

void CentroidalOcp::resetSchedule(double t0, const lie::SE3& start,
                                  const std::vector<planning::TimedBaseCommand>& schedule) {
  planner_->resetSchedule(t0, start, schedule);
  advance(t0);
}

void CentroidalOcp::advance(double t0) {
  problem_->setInitialTime(t0);
  planner_->planSchedule(t0, problem_->modeSchedule());
}

void CentroidalOcp::anchorStanceFeet(const ocp::ModeSchedule& schedule, double t,
                                     const Eigen::VectorXd& x) noexcept {
  if (!planner_->usesMeasuredFeet()) return;
  contactPositionsOfState(*loaded_.robot, *feet_data_, x, feet_);
  planner_->anchorStanceFeet(schedule, t, feet_);
}

int CentroidalOcp::landLateFeet(ocp::ModeSchedule& schedule, double t,
                                const Eigen::VectorXd& x) noexcept {
  if (!planner_->usesMeasuredFeet()) return 0;
  contactPositionsOfState(*loaded_.robot, *feet_data_, x, feet_);
  return planner_->landLateFeet(schedule, t, feet_);
}

Eigen::VectorXd CentroidalOcp::standingState(double x, double y, double yaw) const {
  Eigen::VectorXd state = Eigen::VectorXd::Zero(loaded_.robot->nx());
  const Eigen::Quaterniond q(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  // Terrain height under the nominal feet at this pose, like the base reference.
  const Eigen::Rotation2Dd R(yaw);
  double ground = 0.0;
  for (const Eigen::Vector2d& foot : loaded_.stance.feet) {
    ground += planner_->terrain().heightAt(Eigen::Vector2d(x, y) + R * foot, 0.0);
  }
  ground /= static_cast<double>(loaded_.stance.feet.size());
  state.head<3>() = Eigen::Vector3d(x, y, ground + loaded_.stance.height);
  state.segment<4>(3) = q.coeffs();
  state.segment(loaded_.robot->stateJointIndex(), loaded_.robot->nj()) = nominalJointPositions();
  return state;
}

void CentroidalOcp::initialGuess(std::vector<Eigen::VectorXd>& xs,
                                 std::vector<Eigen::VectorXd>& us) const {
  const int N = problem_->horizon();
  xs.assign(static_cast<std::size_t>(N + 1), Eigen::VectorXd());
  us.assign(static_cast<std::size_t>(N), Eigen::VectorXd());
  InputTrackingResidual input(loaded_.robot);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(loaded_.robot->nx());
  x.segment(loaded_.robot->stateJointIndex(), loaded_.robot->nj()) = nominalJointPositions();
  for (int k = 0; k <= N; ++k) {
    const ocp::NodeContext ctx = problem_->context(k);
    const lie::Vector7d pose = planner_->baseReference().poseAt(ctx.time).coeffs();
    for (int i = 0; i < 7; ++i) x[i] = pose[i];
    xs[static_cast<std::size_t>(k)] = x;
    if (k < N) {
      Eigen::VectorXd u(loaded_.robot->nu());
      input.reference(ctx, u);
      us[static_cast<std::size_t>(k)] = u;
    }
  }
}

Eigen::Matrix3Xd CentroidalOcp::footPositions(const Eigen::VectorXd& x) const {
  pre_->compute(x, Eigen::VectorXd::Zero(loaded_.robot->nu()), false, *scratch_);
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
  StaticTorqueLimitResidual torque(loaded_.robot);
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
