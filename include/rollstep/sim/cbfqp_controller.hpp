#pragma once
// The CBF-QP baseline (control/baseline_pipeline.hpp: the paper's previous controller, no
// MPC) as a controller of the MuJoCo plant, on the ground-truth state (StateSource). Joints
// and drive wheels are matched as NmpcController does (plantJointMap, plantWheelMap).
#include <memory>
#include <string_view>
#include <vector>

#include "rollstep/control/baseline_pipeline.hpp"
#include "rollstep/sim/nmpc_controller.hpp"

namespace rollstep::sim {

class CbfQpController final : public Controller {
 public:
  /// Builds the baseline pipeline and initialises it at the plant's ground-truth state.
  /// `terrain`: foothold regions (shrunk); `collision_terrain`: the terrain's solids
  /// (unshrunk). Throws std::invalid_argument naming what is wrong.
  CbfQpController(const Plant& plant, const centroidal::RobotOcpDescription& robot,
                  const control::ControlSettings& settings, const planning::TerrainModel& terrain,
                  const planning::TerrainModel& collision_terrain, planning::GaitKind gait,
                  const planning::BaseVelocityCommand& command);

  void compute(double t, const SensorReadings& sensors, PlantCommand& command) override;
  std::string_view name() const override { return "cbfqp"; }
  /// mode[-], support[-] (support feet mask), qp_status, qp_iterations[-], qp_active[-],
  /// qp_correction[m/s^2], ref_base_z[m] (planned height), int_base_z[m], terrain_high[m]
  /// (the wheel centre heights are the scenario log's foot_z_<leg>[m]).
  std::string logColumns() const override;
  void logValues(std::string& out) const override;

  control::BaselinePipeline& pipeline() { return *pipeline_; }
  const control::BaselinePipeline& pipeline() const { return *pipeline_; }
  /// Plant joint index of each model joint, in the model's order.
  const std::vector<int>& jointMap() const { return joint_map_; }

 private:
  std::unique_ptr<control::BaselinePipeline> pipeline_;
  std::unique_ptr<StateSource> source_;
  std::vector<int> joint_map_;
  std::vector<int> wheel_map_;
  control::RobotState state_;
  control::JointCommand command_;
};

}  // namespace rollstep::sim
