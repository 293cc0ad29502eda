#include "rollstep/control/robot_state.hpp"

#include <cmath>

namespace rollstep::control {

bool RobotState::valid(int nj) const {
  if (joint_position.size() != nj || joint_velocity.size() != nj) return false;
  if (!std::isfinite(time) || !base_position.allFinite() || !base_linear_velocity.allFinite() ||
      !base_angular_velocity.allFinite() || !base_orientation.coeffs().allFinite() ||
      !joint_position.allFinite() || !joint_velocity.allFinite()) {
    return false;
  }
  return std::abs(base_orientation.norm() - 1.0) <= 1e-6;
}

void toModelState(const RobotState& state, Eigen::Ref<Eigen::VectorXd> q,
                  Eigen::Ref<Eigen::VectorXd> v) {
  const Eigen::Index nj = state.joint_position.size();
  q.head<3>() = state.base_position;
  q.segment<4>(3) = state.base_orientation.coeffs();  // x y z w
  q.tail(nj) = state.joint_position;
  v.head<3>() = state.base_orientation.conjugate() * state.base_linear_velocity;
  v.segment<3>(3) = state.base_angular_velocity;
  v.tail(nj) = state.joint_velocity;
}

void fromModelState(double time, const Eigen::Ref<const Eigen::VectorXd>& q,
                    const Eigen::Ref<const Eigen::VectorXd>& v, RobotState& state) {
  const Eigen::Index nj = state.joint_position.size();
  state.time = time;
  state.base_position = q.head<3>();
  state.base_orientation.coeffs() = q.segment<4>(3);
  state.base_orientation.normalize();
  state.base_linear_velocity = state.base_orientation * v.head<3>();
  state.base_angular_velocity = v.segment<3>(3);
  state.joint_position = q.tail(nj);
  state.joint_velocity = v.tail(nj);
}

}  // namespace rollstep::control
