#pragma once
// The CBF-QP baseline (control/baseline_pipeline.hpp: the paper's previous controller, no
// MPC) as a controller of the MuJoCo plant, on the ground-truth state (StateSource). Joints
// and drive wheels are matched as NmpcController does (plantJointMap, plantWheelMap).
#include <memory>
#include <string_view>
#include <vector>

#include "rollstep/control/baseline_pipeline.hpp"
#include "rollstep/sim/nmpc_controller.hpp"
#include "rollstep/sim/scenario.hpp"

namespace rollstep::sim {

class CbfQpController final : public Controller {
 public:
  /// Builds the baseline pipeline and initialises it at the plant's ground-truth state.
  /// `terrain`: foothold regions (shrunk); `collision_terrain`: the terrain's solids
  /// (unshrunk). Throws std::invalid_argument naming what is wrong.
  /// `region_edge_capacity`, `collision_prism_capacity`: BaselinePipeline's (for terrains
  /// given later by setPerception; 0: the initial terrains').
  CbfQpController(const Plant& plant, const centroidal::RobotOcpDescription& robot,
                  const control::ControlSettings& settings, const planning::TerrainModel& terrain,
                  const planning::TerrainModel& collision_terrain, planning::GaitKind gait,
                  const planning::BaseVelocityCommand& command, int region_edge_capacity = 0,
                  int collision_prism_capacity = 0);
  ~CbfQpController() override;

  void compute(double t, const SensorReadings& sensors, PlantCommand& command) override;
  std::string_view name() const override { return "cbfqp"; }
  /// mode[-], support[-] (support feet mask), qp_status, qp_iterations[-], qp_active[-],
  /// qp_correction[m/s^2], ref_base_z[m] (planned height), int_base_z[m], terrain_high[m],
  /// terrain_version[-] (BaselinePipeline's, 0: the initial), then barrierLogColumns()
  /// (the wheel centre heights are the scenario log's foot_z_<leg>[m]).
  std::string logColumns() const override;
  void logValues(std::string& out) const override;

  control::BaselinePipeline& pipeline() { return *pipeline_; }
  const control::BaselinePipeline& pipeline() const { return *pipeline_; }
  /// Plant joint index of each model joint, in the model's order.
  const std::vector<int>& jointMap() const { return joint_map_; }

  /// Perception in closed loop (online_perception.hpp; started already): every scan that is
  /// due is taken at the state's base pose before the tick (deterministic perception: fused
  /// there; asynchronous: posted to the perception thread), and each new terrain goes to
  /// the pipeline (BaselinePipeline::setTerrain, on the thread that built it): unshrunk as
  /// the collision solids, shrunk by the baseline's foothold_margin as the foothold regions.
  void setPerception(std::unique_ptr<OnlinePerception> perception);
  const OnlinePerception* perception() const { return perception_.get(); }
  OnlinePerception* perception() { return perception_.get(); }
  /// New terrains the pipeline refused (setTerrain returned 0: too many solids...;
  /// asynchronous perception: complete after perception()->stop()).
  std::uint64_t terrainsRefused() const {
    return perception_ ? perception_->counters().refused : 0;
  }
  /// The reactive plan's foot ground points (stance: the foothold; swing: where the swing
  /// is planned to be now), 3 x nc, world.
  Eigen::Matrix3Xd plannedFootholds() const;
  /// terrains.csv (TerrainLog): the foothold terrain in use now and every one perception
  /// hands over from now on; the log's terrain_version[-] says which one each row used.
  void enableTerrainLog() { terrain_log_.enable(pipeline_->terrain()); }
  /// "" if not enabled; with asynchronous perception complete after perception()->stop().
  std::string terrainsCsv() const { return terrain_log_.csv(); }

 private:
  std::unique_ptr<control::BaselinePipeline> pipeline_;
  TerrainLog terrain_log_;
  std::unique_ptr<StateSource> source_;
  std::vector<int> joint_map_;
  std::vector<int> wheel_map_;
  control::RobotState state_;
  control::JointCommand command_;
  const Plant* plant_ = nullptr;
  std::unique_ptr<OnlinePerception> perception_;
};

}  // namespace rollstep::sim
