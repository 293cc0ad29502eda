#include "rollstep/control/wheel_speed.hpp"

#include <cmath>

#include "rollstep/model/kinematics.hpp"

namespace rollstep::control {

void computeDriveWheelSpeeds(const centroidal::CentroidalRobot& robot, model::Data& data,
                             const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                             const std::vector<int>& drive_wheels, double extra_yaw_rate,
                             const Eigen::Vector2d& extra_velocity,
                             Eigen::Ref<Eigen::VectorXd> out) noexcept {
  const model::Model& m = robot.model();
  model::forwardKinematics(m, data, q, v);
  const double radius = robot.contactOffset();
  for (size_t w = 0; w < drive_wheels.size(); ++w) {
    const int i = drive_wheels[w];
    const model::FrameIndex f = robot.frameIds()[static_cast<size_t>(i)];
    model::updateFramePlacement(m, data, f);
    const Eigen::Matrix3d& R = data.oRf[static_cast<size_t>(f)];
    Eigen::Vector3d heading(R(0, 0), R(1, 0), 0.0);
    const double norm = heading.norm();
    double speed = 0.0;
    if (norm > 1e-6 && radius > 0.0) {
      heading /= norm;
      const lie::Vector6d local = model::getFrameVelocity(m, data, f, model::ReferenceFrame::LOCAL);
      const Eigen::Vector3d v_world = R * local.head<3>();
      speed = heading.dot(v_world) / radius - local[4];
      // The wheel centre's ground speed a yaw rate w about the base gives: w (e_z x d) . h.
      const Eigen::Vector3d d = data.opf[static_cast<size_t>(f)] - q.head<3>();
      speed += extra_yaw_rate * (heading.y() * d.x() - heading.x() * d.y()) / radius;
      speed += heading.head<2>().dot(extra_velocity) / radius;
    }
    out[static_cast<Eigen::Index>(w)] = std::isfinite(speed) ? speed : 0.0;
  }
}

}  // namespace rollstep::control
