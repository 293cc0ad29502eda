#include "rollstep/sim/cbfqp_controller.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

namespace rollstep::sim {

CbfQpController::CbfQpController(const Plant& plant, const centroidal::RobotOcpDescription& robot,
                                 const control::ControlSettings& settings,
                                 const planning::TerrainModel& terrain,
                                 const planning::TerrainModel& collision_terrain,
                                 planning::GaitKind gait,
                                 const planning::BaseVelocityCommand& command,
                                 int region_edge_capacity, int collision_prism_capacity)
    : plant_(&plant) {
  if (std::abs(settings.control_period - plant.controlPeriod()) > 1e-12) {
    throw std::invalid_argument("cbfqp: control_period " + std::to_string(settings.control_period) +
                                " s differs from the plant's control period " +
                                std::to_string(plant.controlPeriod()) + " s");
  }
  pipeline_ =
      std::make_unique<control::BaselinePipeline>(robot, settings, terrain, collision_terrain, gait,
                                                  region_edge_capacity, collision_prism_capacity);
  const centroidal::CentroidalRobot& r = pipeline_->robot();
  joint_map_ = plantJointMap(r, plant.layout(), "cbfqp");
  wheel_map_ = plantWheelMap(r, pipeline_->driveWheelContacts(), plant.layout(), "cbfqp");
  source_ = std::make_unique<GroundTruthSource>(plant, joint_map_);
  state_ = pipeline_->makeState();
  command_ = pipeline_->makeCommand();
  if (!source_->read(plant.time(), plant.sensors(), state_)) {
    throw std::runtime_error("cbfqp: no initial state");
  }
  pipeline_->initialize(state_, command);
}

std::string CbfQpController::logColumns() const {
  return ",mode[-],support[-],qp_status,qp_iterations[-],qp_active[-],qp_correction[m/s^2],"
         "ref_base_z[m],int_base_z[m],terrain_high[m],terrain_version[-]" +
         barrierLogColumns(pipeline_->robot(), plant_->layout());
}

void CbfQpController::logValues(std::string& out) const {
  const control::TickRecord& r = pipeline_->lastTick();
  const control::ReactivePlan& p = pipeline_->plan();
  char text[300];
  std::snprintf(text, sizeof text, ",%d,%d,%s,%d,%d,%.6g,%.6f,%.6f,%.4f,%llu", r.mode,
                p.support_mask, r.state_valid ? control::toString(r.cbf_status) : "invalid_state",
                r.qp_iterations, r.active_barriers, r.correction, p.q[2],
                pipeline_->integrator().q()[2], p.terrain_high,
                static_cast<unsigned long long>(r.terrain_version));
  out.assign(text);
  writeBarrierLogValues(r, pipeline_->robot().nc(), text, sizeof text);
  out.append(text);
}

CbfQpController::~CbfQpController() {
  // The perception thread hands terrains to the pipeline: it stops first.
  perception_.reset();
}

void CbfQpController::setPerception(std::unique_ptr<OnlinePerception> perception) {
  perception_ = std::move(perception);
  perception_->connect([this](const OnlinePerception& p) {
    const planning::TerrainModel regions =
        p.footholdTerrain(pipeline_->settings().baseline.foothold_margin);
    const std::uint64_t version = pipeline_->setTerrain(regions, p.terrain());
    terrain_log_.add(version, regions);
    return version != 0;
  });
}

Eigen::Matrix3Xd CbfQpController::plannedFootholds() const {
  Eigen::Matrix3Xd out = pipeline_->plan().foot_position;
  out.row(2).array() -= pipeline_->robot().contactOffset();
  return out;
}

void CbfQpController::compute(double t, const SensorReadings& sensors, PlantCommand& command) {
  const bool valid = source_->read(t, sensors, state_);
  // Perception (not real-time: the pipeline's tick below is) at the LiDAR's rate.
  if (valid && perception_ != nullptr && perception_->due(t)) {
    perception_->step(t, *plant_, state_.base_position, state_.base_orientation);
    if (perception_->logDue(t)) {
      perception_->writeSnapshot(t, pipeline_->terrain(), plannedFootholds(), state_.base_position,
                                 yawOf(state_.base_orientation));
    }
  }
  if (valid) pipeline_->tick(state_, command_);
  for (size_t j = 0; j < joint_map_.size(); ++j) {
    command.joint_position[joint_map_[j]] = command_.joint_position[static_cast<Eigen::Index>(j)];
  }
  for (size_t w = 0; w < wheel_map_.size(); ++w) {
    command.wheel_velocity[static_cast<Eigen::Index>(w)] = command_.wheel_velocity[wheel_map_[w]];
  }
}

}  // namespace rollstep::sim
