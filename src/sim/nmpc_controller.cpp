#include "rollstep/sim/nmpc_controller.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>

#include "rollstep/common/number_text.hpp"
#include "rollstep/control/speed_rule.hpp"
#include "rollstep/model/model.hpp"
#include "rollstep/sim/estimator_source.hpp"
#include "rollstep/sim/scenario.hpp"

namespace rollstep::sim {

bool GroundTruthSource::read(double t, const SensorReadings&, control::RobotState& state) {
  const GroundTruth& g = plant_->groundTruth();
  state.time = t;
  state.base_position = g.base_position;
  state.base_orientation = g.base_orientation;
  state.base_linear_velocity = g.base_linear_velocity;
  state.base_angular_velocity = g.base_angular_velocity;
  for (size_t j = 0; j < joint_map_.size(); ++j) {
    const int p = joint_map_[j];
    state.joint_position[static_cast<Eigen::Index>(j)] = g.joint_position[p];
    state.joint_velocity[static_cast<Eigen::Index>(j)] = g.joint_velocity[p];
  }
  return true;
}

std::vector<int> plantJointMap(const centroidal::CentroidalRobot& r, const PlantLayout& layout,
                               const char* who) {
  const model::Model& m = r.model();
  if (r.nj() != layout.numJoints()) {
    throw std::invalid_argument(std::string(who) + ": the model has " + std::to_string(r.nj()) +
                                " joints, the plant " + std::to_string(layout.numJoints()));
  }
  std::vector<int> map(static_cast<size_t>(r.nj()), -1);
  for (int j = 0; j < r.nj(); ++j) {
    const std::string& name = m.jointNames[static_cast<size_t>(j)];
    map[static_cast<size_t>(j)] = layout.jointIndex(name);
    if (map[static_cast<size_t>(j)] < 0) {
      throw std::invalid_argument(std::string(who) + ": model joint '" + name +
                                  "' is not a joint of the plant");
    }
  }
  return map;
}

std::vector<int> plantWheelMap(const centroidal::CentroidalRobot& r, const std::vector<int>& wheels,
                               const PlantLayout& layout, const char* who) {
  std::vector<int> map(static_cast<size_t>(layout.numDriveWheels()), -1);
  for (int w = 0; w < layout.numDriveWheels(); ++w) {
    const std::string& frame =
        layout.legs[static_cast<size_t>(layout.drive_wheel_legs[static_cast<size_t>(w)])]
            .contact_frame;
    for (size_t k = 0; k < wheels.size(); ++k) {
      if (r.contact(wheels[k]).frame == frame) map[static_cast<size_t>(w)] = static_cast<int>(k);
    }
    if (map[static_cast<size_t>(w)] < 0) {
      throw std::invalid_argument(std::string(who) +
                                  ": no drive-wheel contact of the robot description for the "
                                  "plant's drive wheel '" +
                                  frame + "'");
    }
  }
  return map;
}

void TerrainLog::enable(const planning::TerrainModel& initial) {
  enabled_ = true;
  csv_ = "version[-],region[-],vertex[-],x[m],y[m],z[m]\n";
  append(0, initial);
}

void TerrainLog::add(std::uint64_t version, const planning::TerrainModel& terrain) {
  if (enabled_ && version != 0) append(version, terrain);
}

void TerrainLog::append(std::uint64_t version, const planning::TerrainModel& terrain) {
  char row[160];
  for (int r = 0; r < terrain.size(); ++r) {
    const planning::ConvexRegion& region = terrain.region(r);
    for (std::size_t v = 0; v < region.vertices.size(); ++v) {
      const Eigen::Vector2d& p = region.vertices[v];
      std::snprintf(row, sizeof row, "%llu,%d,%zu,%.4f,%.4f,%.4f\n",
                    static_cast<unsigned long long>(version), r, v, p.x(), p.y(),
                    region.heightAt(p));
      csv_ += row;
    }
  }
}

std::string barrierLogColumns(const centroidal::CentroidalRobot& robot, const PlantLayout& layout) {
  std::string out;
  for (int c = 0; c < robot.nc(); ++c) {
    std::string name = robot.contact(c).frame;
    for (const PlantLayout::Leg& leg : layout.legs) {
      if (leg.contact_frame == name) name = leg.name;
    }
    out += ",qp_active_" + name + "[-]";
  }
  return out + ",qp_active_joints[-],qp_active_support[-]";
}

int writeBarrierLogValues(const control::TickRecord& record, int nc, char* out, std::size_t size) {
  std::size_t n = 0;
  const auto put = [&](int value) {
    if (n >= size) return;
    const int w = std::snprintf(out + n, size - n, ",%d", value);
    if (w > 0) n = std::min(size - 1, n + static_cast<std::size_t>(w));
  };
  for (int c = 0; c < nc; ++c) {
    put(control::CbfQpFilter::footBarriers(record.active_foot_barriers, c));
  }
  put(record.active_joint_limits);
  put(record.active_support_edges);
  return static_cast<int>(n);
}

const char* toString(StateSourceKind kind) { return enumName(kind); }

StateSourceKind stateSourceFromString(const std::string& name) {
  if (const std::optional<StateSourceKind> kind = enumFromName<StateSourceKind>(name)) return *kind;
  throw std::invalid_argument("state source '" + name + "': expected " +
                              enumChoices<StateSourceKind>());
}

NmpcController::NmpcController(const Plant& plant, const centroidal::RobotOcpDescription& robot,
                               const control::ControlSettings& settings,
                               const planning::TerrainModel& terrain, planning::GaitKind gait,
                               const planning::BaseVelocityCommand& command,
                               const StateSourceOptions& source, int region_edge_capacity)
    : NmpcController(plant, robot, settings, terrain, gait,
                     std::vector<planning::TimedBaseCommand>{{0.0, command}}, source,
                     region_edge_capacity) {}

NmpcController::NmpcController(const Plant& plant, const centroidal::RobotOcpDescription& robot,
                               const control::ControlSettings& settings,
                               const planning::TerrainModel& terrain, planning::GaitKind gait,
                               const std::vector<planning::TimedBaseCommand>& schedule,
                               const StateSourceOptions& source, int region_edge_capacity) {
  if (std::abs(settings.control_period - plant.controlPeriod()) > 1e-12) {
    throw std::invalid_argument("nmpc: control_period " + std::to_string(settings.control_period) +
                                " s differs from the plant's control period " +
                                std::to_string(plant.controlPeriod()) + " s");
  }
  // The speed rule times the trot for the schedule's fastest command (the schedule itself is
  // adapted by the pipeline).
  control::ControlSettings adapted = settings;
  if (const auto timing = control::timeTrotForSchedule(adapted.ocp, robot, gait, schedule)) {
    trot_timing_ = *timing;
  }
  pipeline_ = std::make_unique<control::ControlPipeline>(robot, adapted, terrain, gait,
                                                         region_edge_capacity);
  plant_ = &plant;
  const centroidal::CentroidalRobot& r = pipeline_->robot();
  joint_map_ = plantJointMap(r, plant.layout(), "nmpc");
  wheel_map_ = plantWheelMap(r, pipeline_->driveWheelContacts(), plant.layout(), "nmpc");
  if (source.kind == StateSourceKind::Inekf) {
    auto estimator = std::make_unique<EstimatorSource>(plant, r, joint_map_, source.estimator,
                                                       source.ground_heights);
    estimator_ = estimator.get();
    source_ = std::move(estimator);
  } else {
    source_ = std::make_unique<GroundTruthSource>(plant, joint_map_);
  }
  state_ = pipeline_->makeState();
  command_ = pipeline_->makeCommand();
  if (!source_->read(plant.time(), plant.sensors(), state_)) {
    throw std::runtime_error("nmpc: no initial state");
  }
  initial_status_ = pipeline_->initializeSchedule(state_, schedule);
  reserveUpdateLog(kDefaultUpdateLogDuration);
  record(plant.time(), true);
}

void NmpcController::reserveUpdateLog(double duration) {
  if (!std::isfinite(duration) || duration < 0.0) {
    throw std::invalid_argument("nmpc: MPC update log duration must be finite and >= 0 s");
  }
  // Deterministic timing solves once per period of loop time; the asynchronous thread's
  // solutions are taken once per tick at most (poll), whatever its period.
  const control::ControlSettings& settings = pipeline_->settings();
  const bool asynchronous = settings.mpc.timing == control::MpcTiming::Asynchronous;
  const double interval =
      asynchronous || !(settings.mpc.period > 0.0) ? settings.control_period : settings.mpc.period;
  const double records = std::floor(duration / interval) + 3.0;  // + the initial solve's
  const double bytes = records * static_cast<double>(sizeof(MpcUpdateRecord));
  if (bytes > 8.0 * (1 << 30)) {
    throw std::invalid_argument(
        formatText("nmpc: the MPC update log of a %.0f s run needs %.1f GiB (more than 8 GiB): run "
                   "shorter runs",
                   duration, bytes / (1 << 30)));
  }
  update_capacity_ = static_cast<std::size_t>(records);
  std::vector<MpcUpdateRecord> kept;  // exactly the run's size, the records so far in it
  kept.reserve(update_capacity_);
  kept.assign(updates_.begin(), updates_.begin() + static_cast<std::ptrdiff_t>(std::min(
                                                       updates_.size(), update_capacity_)));
  updates_.swap(kept);
  updates_dropped_ = 0;
}

void NmpcController::record(double t, bool adopted) {
  const control::MpcSolution& s = pipeline_->lastSolution();
  MpcUpdateRecord r;
  r.time = t;
  r.state_time = s.t0;
  r.sequence = s.sequence;
  r.status = s.status;
  r.iterations = s.iterations;
  r.kkt_error = s.kkt_error;
  r.primal_residual = s.primal_residual;
  r.primal_step = s.primal_step;
  r.solve_time_ms = s.solve_time_ms;
  r.adopted = adopted;
  r.gait_held = s.gait_clock.totalHeld();
  if (updates_.size() == update_capacity_) {
    ++updates_dropped_;  // past the run's reserve: never grow in the loop
    return;
  }
  updates_.push_back(r);
}

std::string NmpcController::logColumns() const {
  return ",mode[-],mpc_sequence[-],qp_status,qp_iterations[-],qp_active[-],qp_correction[m/s^2],"
         "ref_base_x[m],ref_base_y[m],ref_base_z[m],ref_base_yaw[rad],ref_base_vx[m/s],"
         "ref_base_wz[rad/s],int_base_z[m],int_base_wz[rad/s],terrain_version[-]" +
         barrierLogColumns(pipeline_->robot(), plant_->layout()) +
         std::string(estimator_ != nullptr
                         ? ",est_base_x[m],est_base_y[m],est_base_z[m],est_base_yaw[rad],"
                           "est_base_vx[m/s],est_base_vy[m/s],est_base_vz[m/s],"
                           "est_gyro_bias_x[rad/s],est_gyro_bias_y[rad/s],est_gyro_bias_z[rad/s],"
                           "est_contacts_rejected[-]"
                         : "");
}

void NmpcController::logValues(std::string& out) const {
  const control::TickRecord& r = pipeline_->lastTick();
  const control::ReferenceSample& ref = pipeline_->reference();
  const Eigen::Quaterniond q_ref(ref.q[6], ref.q[3], ref.q[4], ref.q[5]);
  const Eigen::VectorXd& q_int = pipeline_->integrator().q();
  const Eigen::VectorXd& v_int = pipeline_->integrator().v();
  char text[400];
  std::snprintf(text, sizeof text, ",%d,%llu,%s,%d,%d,%.6g,%.6f,%.6f,%.6f,%.6f,%.5f,%.5f,%.6f,%.5f",
                r.mode, static_cast<unsigned long long>(r.solution_sequence),
                r.state_valid ? control::toString(r.cbf_status) : "invalid_state", r.qp_iterations,
                r.active_barriers, r.correction, ref.q[0], ref.q[1], ref.q[2], yawOf(q_ref),
                ref.v[0], ref.v[5], q_int[2], v_int[5]);
  out.assign(text);
  std::snprintf(text, sizeof text, ",%llu", static_cast<unsigned long long>(r.terrain_version));
  out.append(text);
  writeBarrierLogValues(r, pipeline_->robot().nc(), text, sizeof text);
  out.append(text);
  if (estimator_ != nullptr) {
    // The estimate beside the ground truth of the log's base columns.
    const estimation::InvariantEkf& f = estimator_->filter();
    std::snprintf(text, sizeof text, ",%.6f,%.6f,%.6f,%.6f,%.5f,%.5f,%.5f,%.4e,%.4e,%.4e,%llu",
                  f.position().x(), f.position().y(), f.position().z(), yawOf(f.orientation()),
                  f.velocity().x(), f.velocity().y(), f.velocity().z(), f.gyroBias().x(),
                  f.gyroBias().y(), f.gyroBias().z(),
                  static_cast<unsigned long long>(f.counters().contacts_rejected));
    out.append(text);
  }
}

std::string NmpcController::mpcUpdatesCsv() const {
  std::string out =
      "time[s],state_time[s],sequence[-],status,iterations[-],kkt_error[-],primal_residual[-],"
      "solve_time[ms],adopted[0/1],primal_step[-],gait_held[s]\n";
  char row[300];
  for (const MpcUpdateRecord& r : updates_) {
    std::snprintf(row, sizeof row, "%.4f,%.4f,%llu,%s,%d,%.6g,%.6g,%.3f,%d,%.4g,%.4f\n", r.time,
                  r.state_time, static_cast<unsigned long long>(r.sequence),
                  solver::toString(r.status), r.iterations, r.kkt_error, r.primal_residual,
                  r.solve_time_ms, r.adopted ? 1 : 0, r.primal_step, r.gait_held);
    out += row;
  }
  return out;
}

void NmpcController::enableViolationLog() {
  if (pipeline_->settings().mpc.timing != control::MpcTiming::Deterministic) {
    throw std::logic_error("nmpc: the constraint violation log needs deterministic MPC timing");
  }
  pipeline_->setMpcSolveObserver([this](double t, const ocp::OptimalControlProblem& problem,
                                        const std::vector<Eigen::VectorXd>& xs,
                                        const std::vector<Eigen::VectorXd>& us) {
    const std::vector<centroidal::ConstraintViolation> v =
        centroidal::constraintViolations(problem, xs, us);
    if (violations_csv_.empty()) {
      violations_csv_ = "time[s]";
      for (const centroidal::ConstraintViolation& g : v) {
        violations_csv_ += "," + g.group + "[-]," + g.group + "_node[-]," + g.group + "_row";
      }
      violations_csv_ += "\n";
    }
    char cell[64];
    std::snprintf(cell, sizeof cell, "%.4f", t);
    violations_csv_ += cell;
    for (const centroidal::ConstraintViolation& g : v) {
      std::snprintf(cell, sizeof cell, ",%.4g,%d,", g.value, g.node);
      violations_csv_ += cell;
      // Row names are frame and joint names and words: no commas, but a robot's could.
      for (const char c : g.row) violations_csv_ += c == ',' ? ';' : c;
    }
    violations_csv_ += "\n";
  });
}

NmpcController::~NmpcController() {
  // The perception thread hands terrains to the pipeline: it stops first.
  perception_.reset();
  if (pipeline_) pipeline_->stop();
}

void NmpcController::setPerception(std::unique_ptr<OnlinePerception> perception, double margin) {
  perception_ = std::move(perception);
  perception_margin_ = margin;
  perception_->connect([this](const OnlinePerception& p) {
    const planning::TerrainModel terrain = p.footholdTerrain(perception_margin_);
    const std::uint64_t version = pipeline_->setTerrain(terrain);
    terrain_log_.add(version, terrain);
    return version != 0;
  });
}

void NmpcController::enableTerrainLog() {
  terrain_log_.enable(pipeline_->contactPlanner().terrain());
}

std::string NmpcController::terrainsCsv() const { return terrain_log_.csv(); }

void NmpcController::updatePerception(double t) {
  perception_->step(t, *plant_, state_.base_position, state_.base_orientation);
  if (perception_->logDue(t)) {
    perception_->writeSnapshot(t, pipeline_->contactPlanner().terrain(), plannedFootholds(),
                               state_.base_position, yawOf(state_.base_orientation));
  }
}

Eigen::Matrix3Xd NmpcController::plannedFootholds() const {
  const control::MpcSolution& s = pipeline_->lastSolution();
  const centroidal::CentroidalRobot& robot = pipeline_->robot();
  const int nc = robot.nc();
  const double offset = robot.contactOffset();
  model::Data data(robot.model());
  Eigen::Matrix3Xd feet(3, nc);
  std::vector<Eigen::Vector3d> points;
  for (std::size_t k = 0; k < s.xs.size() && k < s.modes.size(); ++k) {
    int landing = 0;
    for (int i = 0; i < nc; ++i) {
      const bool stance = (s.modes[k] >> i) & 1;
      const bool before = k > 0 && ((s.modes[k - 1] >> i) & 1);
      if (stance && (k == 0 || !before)) landing |= 1 << i;
    }
    if (landing == 0) continue;
    centroidal::contactPositionsOfState(robot, data, s.xs[k], feet);
    for (int i = 0; i < nc; ++i) {
      if ((landing >> i) & 1) points.push_back(feet.col(i) - offset * Eigen::Vector3d::UnitZ());
    }
  }
  Eigen::Matrix3Xd out(3, static_cast<Eigen::Index>(points.size()));
  for (std::size_t k = 0; k < points.size(); ++k) {
    out.col(static_cast<Eigen::Index>(k)) = points[k];
  }
  return out;
}

void NmpcController::enablePlanLog(int node_stride, double duration) {
  if (node_stride < 1) throw std::invalid_argument("nmpc: plan log node stride must be >= 1");
  if (!std::isfinite(duration) || duration < 0.0) {
    throw std::invalid_argument("nmpc: plan log duration must be finite and >= 0 s");
  }
  const centroidal::CentroidalRobot& robot = pipeline_->robot();
  const control::MpcSolution& s = pipeline_->lastSolution();
  const double period = pipeline_->settings().mpc.period;
  const bool asynchronous = pipeline_->settings().mpc.timing == control::MpcTiming::Asynchronous;
  // Deterministic timing solves once per period of loop time; asynchronous solutions are
  // thinned to one per half period (enablePlanLog's contract).
  plan_min_gap_ = asynchronous ? 0.5 * period : 0.0;
  const double per_second = period > 0.0 ? (asynchronous ? 2.0 : 1.0) / period : 1000.0;
  const double solutions = std::floor(duration * per_second) + 3.0;  // + the one in use now
  const std::size_t n = std::min(s.xs.size(), s.modes.size());
  const std::size_t nodes = n == 0 ? 0 : (n - 1) / static_cast<std::size_t>(node_stride) + 2;
  const int columns = 2 + 3 * (1 + robot.nc());  // node, mode, base, contacts
  const double bytes = solutions * (sizeof(PlanSolution) +
                                    static_cast<double>(nodes * columns) * sizeof(std::int32_t));
  if (bytes > 8.0 * (1 << 30)) {
    throw std::invalid_argument(formatText(
        "nmpc: the plan log of a %.0f s run needs %.1f GiB (more than 8 GiB): run shorter runs",
        duration, bytes / (1 << 30)));
  }
  plan_stride_ = node_stride;
  plan_columns_ = columns;
  plan_solution_capacity_ = static_cast<std::size_t>(solutions);
  plan_dropped_ = 0;
  plan_solutions_.clear();
  plan_nodes_.clear();
  plan_solutions_.reserve(plan_solution_capacity_);
  plan_nodes_.reserve(plan_solution_capacity_ * nodes * static_cast<std::size_t>(columns));
  plan_data_ = std::make_unique<model::Data>(robot.model());
  plan_feet_.resize(3, robot.nc());
  recordPlan();  // the solution in use now
}

void NmpcController::recordPlan() {
  const control::MpcSolution& s = pipeline_->lastSolution();
  if (!plan_solutions_.empty() && s.t0 < plan_solutions_.back().t0 + plan_min_gap_) return;
  const centroidal::CentroidalRobot& robot = pipeline_->robot();
  const std::size_t n = std::min(s.xs.size(), s.modes.size());
  const std::size_t stride = static_cast<std::size_t>(plan_stride_);
  const std::size_t nodes = n == 0 ? 0 : (n - 1) / stride + ((n - 1) % stride != 0 ? 2 : 1);
  if (plan_solutions_.size() == plan_solution_capacity_ ||
      plan_nodes_.size() + nodes * static_cast<std::size_t>(plan_columns_) >
          plan_nodes_.capacity()) {
    ++plan_dropped_;  // past the run's reserve: never grow in the loop
    return;
  }
  const auto mm = [](double v) {
    return static_cast<std::int32_t>(std::lround(std::clamp(v, -2.0e6, 2.0e6) * 1000.0));
  };
  for (std::size_t k = 0; k < n; ++k) {
    if (k % stride != 0 && k + 1 != n) continue;
    centroidal::contactPositionsOfState(robot, *plan_data_, s.xs[k], plan_feet_);
    plan_nodes_.push_back(static_cast<std::int32_t>(k));
    plan_nodes_.push_back(static_cast<std::int32_t>(s.modes[k]));
    for (int i = 0; i < 3; ++i) plan_nodes_.push_back(mm(s.xs[k][i]));
    for (int c = 0; c < robot.nc(); ++c) {
      for (int i = 0; i < 3; ++i) plan_nodes_.push_back(mm(plan_feet_(i, c)));
    }
  }
  plan_solutions_.push_back({s.t0, s.dt, s.sequence, static_cast<std::uint32_t>(nodes)});
}

void NmpcController::writePlanCsv(const std::function<void(std::string_view)>& sink) const {
  if (plan_stride_ == 0) return;
  const centroidal::CentroidalRobot& robot = pipeline_->robot();
  std::string out = "solution_time[s],time[s],sequence[-],mode[-],base_x[m],base_y[m],base_z[m]";
  for (int c = 0; c < robot.nc(); ++c) {
    const std::string& name = robot.contact(c).frame;
    for (const char* axis : {"x", "y", "z"}) out += ",foot_" + name + "_" + axis + "[m]";
  }
  out += "\n";
  constexpr std::size_t kPiece = 1 << 16;
  out.reserve(kPiece + 1024);
  char cell[64];
  const std::size_t columns = static_cast<std::size_t>(plan_columns_);
  std::size_t r = 0;
  for (const PlanSolution& s : plan_solutions_) {
    for (std::uint32_t k = 0; k < s.nodes; ++k, r += columns) {
      const std::int32_t* node = plan_nodes_.data() + r;
      std::snprintf(cell, sizeof cell, "%.4f,%.4f,%llu,%ld", s.t0,
                    s.t0 + s.dt * static_cast<double>(node[0]),
                    static_cast<unsigned long long>(s.sequence), static_cast<long>(node[1]));
      out += cell;
      for (std::size_t i = 2; i < columns; ++i) {  // millimetres as metres, exactly
        const std::int32_t v = node[i];
        const unsigned long a = static_cast<unsigned long>(v < 0 ? -static_cast<long>(v) : v);
        std::snprintf(cell, sizeof cell, ",%s%lu.%03lu", v < 0 ? "-" : "", a / 1000, a % 1000);
        out += cell;
      }
      out += '\n';
      if (out.size() >= kPiece) {
        sink(out);
        out.clear();
      }
    }
  }
  if (!out.empty()) sink(out);
}

std::string NmpcController::planCsv() const {
  std::string out;
  writePlanCsv([&out](std::string_view piece) { out += piece; });
  return out;
}

void NmpcController::compute(double t, const SensorReadings& sensors, PlantCommand& command) {
  if (source_->read(t, sensors, state_)) {
    // Perception (not real-time: the pipeline's tick below is) at the LiDAR's rate, at the
    // base pose the pipeline runs on.
    if (perception_ != nullptr && perception_->due(t)) updatePerception(t);
    pipeline_->tick(state_, command_);
    const control::TickRecord& r = pipeline_->lastTick();
    if (r.new_solution) record(t, r.solution_adopted);
    if (r.solution_adopted && plan_stride_ > 0) recordPlan();
  }
  for (size_t j = 0; j < joint_map_.size(); ++j) {
    command.joint_position[joint_map_[j]] = command_.joint_position[static_cast<Eigen::Index>(j)];
  }
  for (size_t w = 0; w < wheel_map_.size(); ++w) {
    command.wheel_velocity[static_cast<Eigen::Index>(w)] = command_.wheel_velocity[wheel_map_[w]];
  }
}

}  // namespace rollstep::sim
