#include "rollstep/sim/estimator_source.hpp"

#include <stdexcept>
#include <string>

namespace rollstep::sim {

std::vector<estimation::ContactSpec> estimatorContacts(const centroidal::CentroidalRobot& robot) {
  std::vector<estimation::ContactSpec> out;
  for (int i = 0; i < robot.nc(); ++i) {
    estimation::ContactSpec c;
    c.frame = robot.contact(i).frame;
    c.kind = robot.contact(i).drive_wheel ? estimation::ContactKind::DriveWheel
                                          : estimation::ContactKind::OmniWheel;
    c.radius = robot.contactOffset();
    out.push_back(c);
  }
  return out;
}

EstimatorSource::EstimatorSource(const Plant& plant, const centroidal::CentroidalRobot& robot,
                                 std::vector<int> joint_map,
                                 const estimation::InekfSettings& settings, bool ground_heights)
    : joint_map_(std::move(joint_map)),
      scene_(resolveScene(plant.scene())),
      ground_heights_(ground_heights) {
  filter_ =
      std::make_unique<estimation::InvariantEkf>(robot.model(), estimatorContacts(robot), settings);
  for (int i = 0; i < robot.nc(); ++i) {
    const std::string& frame = robot.contact(i).frame;
    const int leg = plant.layout().legOfContactFrame(frame);
    if (leg < 0) {
      throw std::invalid_argument("estimator: contact frame '" + frame +
                                  "' is not a wheel of the plant");
    }
    const int wheel = plant.layout().legs[static_cast<size_t>(leg)].drive_wheel;
    if (robot.contact(i).drive_wheel && wheel < 0) {
      throw std::invalid_argument("estimator: drive-wheel contact '" + frame +
                                  "' has no wheel encoder in the plant");
    }
    contact_leg_.push_back(leg);
    contact_wheel_.push_back(wheel);
  }
  input_ = filter_->makeInput();
  const GroundTruth& g = plant.groundTruth();
  filter_->reset(plant.time(), g.base_orientation, g.base_position, g.base_linear_velocity);
}

bool EstimatorSource::read(double t, const SensorReadings& sensors, control::RobotState& state) {
  input_.time = t;
  input_.gyro = sensors.imu_angular_velocity;
  input_.accel = sensors.imu_acceleration;
  for (size_t j = 0; j < joint_map_.size(); ++j) {
    input_.joint_position[static_cast<Eigen::Index>(j)] = sensors.joint_position[joint_map_[j]];
    input_.joint_velocity[static_cast<Eigen::Index>(j)] = sensors.joint_velocity[joint_map_[j]];
  }
  for (size_t i = 0; i < contact_leg_.size(); ++i) {
    input_.contact[i] = sensors.foot_contact[static_cast<size_t>(contact_leg_[i])];
    if (ground_heights_) {
      const Eigen::Vector3d& c = filter_->contactPoint(static_cast<int>(i));
      input_.ground_height[i] = terrainHeight(scene_, c.x(), c.y());
    }
    input_.wheel_velocity[i] =
        contact_wheel_[i] >= 0 ? sensors.wheel_velocity[contact_wheel_[i]] : 0.0;
  }
  filter_->tick(input_);
  const estimation::InvariantEkf& f = *filter_;
  state.time = t;
  state.base_position = f.position();
  state.base_orientation = f.orientation();
  state.base_linear_velocity = f.velocity();
  state.base_angular_velocity = f.angularVelocity();
  state.joint_position = f.jointPosition();
  state.joint_velocity = f.jointVelocity();
  return f.finite();
}

}  // namespace rollstep::sim
