#pragma once
// The CBF-QP baseline (the paper's previous controller, Takasugi et al. 2023; DESIGN.md
// section 6): the NMPC pipeline's CBF-QP safety filter at 1 kHz driven by the myopic
// reactive planner (reactive_planner.hpp), without any MPC. Every tick:
//
//   state (RobotState) -> reactive planner (gait, swings, footholds, body height, support
//   feet) -> acceleration commands: kp, kd feedback (ControlSettings::feedback) of the
//   planner's references against the INTERNAL integrator state (stance feet: gains scaled
//   by baseline.stance_foot_gain) -> CBF-QP (contact consistency, joint position and
//   velocity limits, foothold regions, COM inside the support polygon with a margin,
//   leg/terrain collision with smoothed distances; config/baseline.yaml turns the last two
//   on) -> internal state integrator -> joint position commands and drive-wheel speeds
//   (wheel_speed.hpp, the NMPC pipeline's rule).
//
// Settings: ControlSettings' control_period, feedback, cbf_qp, integrator and baseline
// sections (mpc, refinement and wheels are not used; the ocp section gives only the
// contact planner whose gait, nominal stance and terrain the reactive planner reads).
//
// Fallbacks (each counted): an invalid state keeps the previous command; a failed QP gives
// the filter's fallback acceleration (joints brake to rest) with the base braking to rest
// too (the drive wheels follow the commanded base: rolling on unfiltered would carry a
// stance wheel over an edge).
//
// Terrain updates (perception; setTerrain from one producer thread, not real-time): the
// next tick swaps the new foothold and collision terrains in (no allocation) and moves the
// planner's region indices onto them (ReactivePlanner::remapRegions).
//
// Real-time contract: tick() never allocates, locks or throws (tests count allocations).
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <vector>

#include "rollstep/centroidal/loaded_robot.hpp"
#include "rollstep/common/latest_value_mailbox.hpp"
#include "rollstep/control/cbf_qp.hpp"
#include "rollstep/control/control_settings.hpp"
#include "rollstep/control/pipeline.hpp"
#include "rollstep/control/reactive_planner.hpp"
#include "rollstep/control/robot_state.hpp"
#include "rollstep/control/state_integrator.hpp"
#include "rollstep/control/tracking_stage.hpp"

namespace rollstep::control {

class BaselinePipeline {
 public:
  /// `terrain`: the foothold regions (shrunk); `collision_terrain`: the solids of the
  /// collision barrier (unshrunk). Both are copied. Throws std::invalid_argument for bad
  /// settings or robot description.
  /// `region_edge_capacity`, `collision_prism_capacity`: the most edges of a foothold region
  /// and the most collision prisms of any terrain given later (setTerrain); 0: the initial
  /// terrains'.
  BaselinePipeline(const centroidal::RobotOcpDescription& robot, const ControlSettings& settings,
                   const planning::TerrainModel& terrain,
                   const planning::TerrainModel& collision_terrain, planning::GaitKind gait,
                   int region_edge_capacity = 0, int collision_prism_capacity = 0);
  ~BaselinePipeline();
  BaselinePipeline(const BaselinePipeline&) = delete;
  BaselinePipeline& operator=(const BaselinePipeline&) = delete;

  /// Not real-time: starts the planner and the integrator at the state. Throws
  /// std::invalid_argument for an invalid state.
  void initialize(const RobotState& state, const planning::BaseVelocityCommand& command);
  /// One real-time tick at state.time. Never allocates, locks or throws.
  void tick(const RobotState& state, JointCommand& command) noexcept;

  /// Producer of terrains (one thread, not real-time: copies them): the foothold regions
  /// and the collision solids the next tick changes to. Returns the version (1, 2, ...), or
  /// 0 if refused (an empty foothold terrain, a region with more edges or more solids than
  /// the capacities): the terrains in use stay.
  std::uint64_t setTerrain(const planning::TerrainModel& terrain,
                           const planning::TerrainModel& collision_terrain);
  /// Version of the terrains in use (0: the constructor's).
  std::uint64_t terrainVersion() const { return terrain_version_; }
  const planning::TerrainModel& terrain() const { return contacts_->terrain(); }
  const planning::TerrainModel& collisionTerrain() const { return *collision_terrain_; }

  /// A new base velocity command from the next tick on. Never allocates.
  void setCommand(const planning::BaseVelocityCommand& command) { planner_->setCommand(command); }

  JointCommand makeCommand() const;
  RobotState makeState() const { return RobotState::zero(robot().nj()); }
  /// solution_sequence and the MPC fields stay 0.
  const TickRecord& lastTick() const { return record_; }
  const PipelineCounters& counters() const { return counters_; }
  const ReactivePlan& plan() const { return plan_; }
  const StateIntegrator& integrator() const { return tracking_->integrator(); }
  const CbfQpFilter& filter() const { return tracking_->safetyFilter(); }
  const ReactivePlanner& planner() const { return *planner_; }
  const centroidal::CentroidalRobot& robot() const { return *robot_.robot; }
  const ControlSettings& settings() const { return settings_; }
  /// Contact index of each drive wheel, in the order of JointCommand::wheel_velocity.
  const std::vector<int>& driveWheelContacts() const { return drive_wheels_; }

 private:
  void computeTargets() noexcept;

  ControlSettings settings_;
  centroidal::LoadedRobot robot_;
  std::unique_ptr<planning::ContactPlanner> contacts_;
  std::unique_ptr<planning::TerrainModel> collision_terrain_;
  std::unique_ptr<ReactivePlanner> planner_;
  std::unique_ptr<TrackingStage> tracking_;
  std::unique_ptr<model::Data> data_;
  std::vector<int> drive_wheels_;
  ReactivePlan plan_;
  TickRecord record_;
  PipelineCounters counters_;
  Eigen::VectorXd q_meas_, v_meas_;
  Eigen::VectorXd stance_forces_;  ///< 3 nc: the weight spread over the stance feet (world)
  bool initialized_ = false;

  /// Foothold and collision terrains handed over together.
  struct TerrainPair {
    planning::TerrainModel footholds, solids;
    void swap(TerrainPair& other) noexcept {
      footholds.swap(other.footholds);
      solids.swap(other.solids);
    }
  };
  LatestValueMailbox<TerrainPair> terrain_in_;
  TerrainPair incoming_;
  std::uint64_t terrain_version_ = 0;
};

}  // namespace rollstep::control
