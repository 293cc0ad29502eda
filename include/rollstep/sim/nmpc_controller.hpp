#pragma once
// The NMPC control pipeline (control/pipeline.hpp) as a controller of the MuJoCo plant.
// The state comes from a StateSource: the simulator's ground truth for now; the state
// estimator plugs in through the same interface. Joints are matched between the
// plant (its leg order) and the model (the URDF's order) by name, drive wheels by their
// contact frame.
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "rollstep/common/enum_names.hpp"
#include "rollstep/control/pipeline.hpp"
#include "rollstep/estimation/invariant_ekf.hpp"
#include "rollstep/planning/speed_adaptation.hpp"
#include "rollstep/sim/online_perception.hpp"
#include "rollstep/sim/plant.hpp"
#include "rollstep/sim/simple_controllers.hpp"

namespace rollstep::sim {

/// Where the pipeline's state comes from.
class StateSource {
 public:
  virtual ~StateSource() = default;
  /// Fills `state` (sized, model joint order) for time t from the sensors; false if no
  /// state is available (the pipeline then keeps its previous command).
  virtual bool read(double t, const SensorReadings& sensors, control::RobotState& state) = 0;
};

/// The plant's exact state (no estimator).
class GroundTruthSource final : public StateSource {
 public:
  /// `joint_map[j]`: the plant joint index of model joint j.
  GroundTruthSource(const Plant& plant, std::vector<int> joint_map)
      : plant_(&plant), joint_map_(std::move(joint_map)) {}
  bool read(double t, const SensorReadings& sensors, control::RobotState& state) override;

 private:
  const Plant* plant_;
  std::vector<int> joint_map_;
};

/// The plant joint index of each model joint, matched by name; throws std::invalid_argument
/// naming a model joint the plant lacks, `who` ("nmpc") first.
std::vector<int> plantJointMap(const centroidal::CentroidalRobot& robot, const PlantLayout& layout,
                               const char* who);
/// For each plant drive wheel (PlantLayout::drive_wheel_legs order), the index into
/// `drive_wheels` (contact indices) of the contact with the wheel's contact frame; throws
/// std::invalid_argument when a plant wheel has none.
std::vector<int> plantWheelMap(const centroidal::CentroidalRobot& robot,
                               const std::vector<int>& drive_wheels, const PlantLayout& layout,
                               const char* who);

/// terrains.csv (docs/REPLAY.md) of a perception run: the foothold terrain in use at the
/// start (version 0) and each one handed to a pipeline since, with its version; every vertex
/// of every region, z on the region's plane. Written by the terrains' producer thread, read
/// after it stopped.
class TerrainLog {
 public:
  /// Starts the log with `initial` as version 0.
  void enable(const planning::TerrainModel& initial);
  /// Appends `terrain` as `version` if enabled and the version is not 0 (refused).
  void add(std::uint64_t version, const planning::TerrainModel& terrain);
  /// The CSV with its header; "" if not enabled.
  const std::string& csv() const { return csv_; }

 private:
  void append(std::uint64_t version, const planning::TerrainModel& terrain);
  bool enabled_ = false;
  std::string csv_;
};

/// The log columns of the CBF-QP's active barriers (docs/REPLAY.md), after qp_active[-]:
/// qp_active_<leg>[-] per contact of `robot` (its leg's name in `layout`, else the contact
/// frame): the BarrierKind bits active of that foot (1 foothold region, 2 clearance, 4
/// collision); qp_active_joints[-], qp_active_support[-]: active joint bounds and support
/// polygon edges. Starts with a comma.
std::string barrierLogColumns(const centroidal::CentroidalRobot& robot, const PlantLayout& layout);
/// Their values for `record` (nc feet) appended at `out` (at most `size` bytes with the
/// terminating zero); returns the characters written. Never allocates.
int writeBarrierLogValues(const control::TickRecord& record, int nc, char* out, std::size_t size);

/// Which state the pipeline runs on: the simulator's ground truth, or the state estimator
/// (estimator_source.hpp) on the plant's sensors (give the plant a sensor noise model,
/// PlantOptions::sensor_noise, for realistic readings).
enum class StateSourceKind { GroundTruth, Inekf };
constexpr std::array<EnumName<StateSourceKind>, 2> enumNames(StateSourceKind) {
  return {{{StateSourceKind::GroundTruth, "ground_truth"}, {StateSourceKind::Inekf, "inekf"}}};
}
/// "ground_truth" or "inekf".
const char* toString(StateSourceKind kind);
/// Inverse of toString; throws std::invalid_argument naming the accepted values.
StateSourceKind stateSourceFromString(const std::string& name);

struct StateSourceOptions {
  StateSourceKind kind = StateSourceKind::GroundTruth;
  estimation::InekfSettings estimator;
  /// The estimator gets the scene's terrain height under each stance contact (the map).
  bool ground_heights = true;  ///< tuning of the estimator (a robot's estimation.yaml,
                               ///< e.g. robots/tachyon3/estimation.yaml)
};

class EstimatorSource;

/// One MPC solution as the real-time loop received it (the log's mpc.csv rows).
struct MpcUpdateRecord {
  double time = 0.0;        ///< [s] loop time it arrived
  double state_time = 0.0;  ///< [s] time of the state it was solved from (its t0)
  std::uint64_t sequence = 0;
  solver::SolverStatus status = solver::SolverStatus::InvalidInput;
  int iterations = 0;
  double kkt_error = 0.0;
  double primal_residual = 0.0;
  double primal_step = 0.0;    ///< of the last iteration (1: full Newton step)
  double solve_time_ms = 0.0;  ///< wall time (not reproducible)
  bool adopted = false;        ///< refined into the reference (false: unusable, rejected)
  /// [s] time its gait clock has stood still in all (edge holds begun or planned)
  double gait_held = 0.0;
};

class NmpcController final : public Controller {
 public:
  /// Builds the pipeline and initialises it at the plant's current ground-truth state
  /// (a cold converging solve). Throws std::invalid_argument / std::runtime_error naming
  /// what is wrong (a joint or wheel of the plant the model lacks, bad settings).
  NmpcController(const Plant& plant, const centroidal::RobotOcpDescription& robot,
                 const control::ControlSettings& settings, const planning::TerrainModel& terrain,
                 planning::GaitKind gait, const planning::BaseVelocityCommand& command,
                 const StateSourceOptions& source = {}, int region_edge_capacity = 0);
  /// Same with a base velocity command schedule (times from the plant's current time).
  /// `region_edge_capacity`: the most edges of a foothold region of a terrain given later
  /// (setPerception: the perception's regions.directions); 0: the initial terrain's.
  NmpcController(const Plant& plant, const centroidal::RobotOcpDescription& robot,
                 const control::ControlSettings& settings, const planning::TerrainModel& terrain,
                 planning::GaitKind gait, const std::vector<planning::TimedBaseCommand>& schedule,
                 const StateSourceOptions& source = {}, int region_edge_capacity = 0);
  ~NmpcController() override;

  void compute(double t, const SensorReadings& sensors, PlantCommand& command) override;
  std::string_view name() const override { return "nmpc"; }
  /// True in asynchronous MPC mode: the MPC thread solves on the wall clock.
  bool paceToWallClock() const override {
    return pipeline_->settings().mpc.timing == control::MpcTiming::Asynchronous;
  }
  /// mode[-] (contact mask), mpc_sequence[-] (solution in use), qp_status (optimal,
  /// fallback, invalid_input), qp_iterations[-], qp_active[-] (active barrier sides),
  /// qp_correction[m/s^2] (CbfQpFilter::correction); with the estimator also est_base_*
  /// (its position, yaw, world velocity), est_gyro_bias_* and est_contacts_rejected.
  std::string logColumns() const override;
  void logValues(std::string& out) const override;
  /// Every solution received so far, in order (the first one is the initial solve's), up to
  /// the reserve of reserveUpdateLog.
  const std::vector<MpcUpdateRecord>& mpcUpdates() const { return updates_; }
  /// Reserves mpcUpdates() for a run of `duration` [s], so that recording never allocates in
  /// the loop: one record per MPC period with the deterministic timing, one per control
  /// period with the asynchronous one (its thread can hand a solution to every tick when
  /// the simulation runs slower than real time), 80 B each. The constructor reserves
  /// for kDefaultUpdateLogDuration. Past the reserve (a caller running longer) records are
  /// counted (mpcUpdatesDropped), not kept. Throws std::invalid_argument for a negative or
  /// non-finite duration or a reserve above 8 GiB.
  void reserveUpdateLog(double duration);
  static constexpr double kDefaultUpdateLogDuration = 60.0;  ///< [s]
  /// Records mpcUpdates() has room for (reserveUpdateLog).
  std::size_t updateLogCapacity() const { return update_capacity_; }
  /// Solutions received but not recorded because the reserve was full.
  std::size_t mpcUpdatesDropped() const { return updates_dropped_; }
  /// The mpc.csv text of mpcUpdates() (header with units, one row per update).
  std::string mpcUpdatesCsv() const;
  /// Diagnostics (deterministic MPC timing only; throws std::logic_error otherwise): from
  /// now on every MPC solve's trajectory is checked against the problem it solved
  /// (centroidal::constraintViolations: the largest violation of each constraint group
  /// and its node). Slows the run down; the real-time loop itself is unaffected.
  void enableViolationLog();
  /// mpc_violations.csv: time[s], then per group <group>[-] and <group>_node[-]; empty
  /// when the log is off.
  const std::string& violationsCsv() const { return violations_csv_; }

  control::ControlPipeline& pipeline() { return *pipeline_; }
  const control::ControlPipeline& pipeline() const { return *pipeline_; }
  /// Plant joint index of each model joint, in the model's order.
  const std::vector<int>& jointMap() const { return joint_map_; }
  /// The state estimator when the state source is Inekf, else null.
  const EstimatorSource* estimator() const { return estimator_; }
  /// Status of the first (converging) solve.
  solver::SolverStatus initialStatus() const { return initial_status_; }
  /// The trot timed by the speed rule (ocp.speed_adaptation with a trot; else period 0).
  const planning::TrotTiming& trotTiming() const { return trot_timing_; }

  /// Perception in closed loop (online_perception.hpp; started already): every scan that is
  /// due is taken at the state source's base pose before the tick (deterministic perception:
  /// fused there; asynchronous: posted to the perception thread), and each new terrain,
  /// shrunk by `margin` [m] (planning::shrinkTerrain), goes to the pipeline
  /// (ControlPipeline::setTerrain, outside its real-time tick, on the thread that built it).
  void setPerception(std::unique_ptr<OnlinePerception> perception, double margin);
  const OnlinePerception* perception() const { return perception_.get(); }
  OnlinePerception* perception() { return perception_.get(); }
  /// New terrains the pipeline refused (ControlPipeline::setTerrain returned 0;
  /// asynchronous perception: complete after perception()->stop()).
  std::uint64_t terrainsRefused() const {
    return perception_ ? perception_->counters().refused : 0;
  }
  /// The planned footholds of the newest MPC solution: each foot's ground point where the
  /// plan touches it down in the horizon, or at node 0 for a stance foot (3 x n, world).
  Eigen::Matrix3Xd plannedFootholds() const;

  /// Records, from now on, every adopted MPC solution's plan for the replay page: every
  /// `node_stride`-th node (and the last) with its contact mask, base position and contact
  /// positions to the millimetre (planCsv). Storage for a run of `duration` [s] whatever its
  /// length is reserved here (one solution per MPC period: about 2 kB each for Tachyon 3), so
  /// that recording never allocates. Asynchronous MPC timing can adopt solutions faster
  /// than the period (back-to-back solves in a simulation slower than real time): there a
  /// solution is kept only if its state is at least half a period newer than the last kept
  /// one (twice the storage). Past the reserve (a caller running longer than `duration`)
  /// solutions are counted (planLogDropped), not recorded. Throws std::invalid_argument for
  /// node_stride < 1, a negative or non-finite duration, or a reserve above 8 GiB.
  void enablePlanLog(int node_stride, double duration);
  /// The recorded plans as CSV (docs/REPLAY.md: plan.csv.gz), header included, handed to
  /// `sink` in pieces of at most about 64 kB (the text of a long run is never whole in
  /// memory); nothing if not enabled.
  void writePlanCsv(const std::function<void(std::string_view)>& sink) const;
  /// Same as one string (tests, short runs); "" if not enabled.
  std::string planCsv() const;
  /// Solutions the plan log has room for (enablePlanLog).
  std::size_t planLogCapacity() const { return plan_solution_capacity_; }
  /// Adopted solutions not recorded because the reserve of enablePlanLog was full.
  std::size_t planLogDropped() const { return plan_dropped_; }
  /// Records the foothold terrain in use now (version 0) and, from now on, every terrain
  /// perception hands to the pipeline (setPerception) with the version setTerrain gave it:
  /// the log's terrain_version[-] says which one the real-time side used at each row.
  void enableTerrainLog();
  /// The recorded terrains as CSV (docs/REPLAY.md: terrains.csv), header included; "" if not
  /// enabled. With asynchronous perception, complete after perception()->stop().
  std::string terrainsCsv() const;

 private:
  void recordPlan();
  void record(double t, bool adopted);
  void updatePerception(double t);

  std::unique_ptr<control::ControlPipeline> pipeline_;
  std::unique_ptr<StateSource> source_;
  const EstimatorSource* estimator_ = nullptr;  // source_ when it is the estimator
  std::vector<int> joint_map_;                  // model joint -> plant joint
  std::vector<int> wheel_map_;                  // plant drive wheel -> pipeline wheel command index
  control::RobotState state_;
  control::JointCommand command_;
  solver::SolverStatus initial_status_ = solver::SolverStatus::InvalidInput;
  planning::TrotTiming trot_timing_;
  std::string violations_csv_;
  std::vector<MpcUpdateRecord> updates_;
  std::size_t update_capacity_ = 0;
  std::size_t updates_dropped_ = 0;
  const Plant* plant_ = nullptr;
  std::unique_ptr<OnlinePerception> perception_;
  double perception_margin_ = 0.0;
  // Plan log (enablePlanLog): the kept solutions, and per kept node plan_columns_ integers
  // (node index, contact mask, base and contact positions in mm), all reserved up front.
  struct PlanSolution {
    double t0 = 0.0;  // [s] the state's time
    double dt = 0.0;  // [s] node spacing
    std::uint64_t sequence = 0;
    std::uint32_t nodes = 0;  // kept nodes (rows)
  };
  int plan_stride_ = 0;
  int plan_columns_ = 0;
  double plan_min_gap_ = 0.0;  // [s] between the states of two kept solutions
  std::size_t plan_solution_capacity_ = 0;
  std::size_t plan_dropped_ = 0;
  std::vector<PlanSolution> plan_solutions_;
  std::vector<std::int32_t> plan_nodes_;
  std::unique_ptr<model::Data> plan_data_;
  Eigen::Matrix3Xd plan_feet_;
  TerrainLog terrain_log_;  // enableTerrainLog
};

}  // namespace rollstep::sim
