#include "rollstep/planning/base_reference.hpp"

#include <cmath>
#include <string>
#include <utility>

#include "check.hpp"

namespace rollstep::planning {

BaseReference::BaseReference(const TerrainModel& terrain, BaseReferenceConfig config)
    : terrain_(&terrain), config_(std::move(config)) {
  const char* where = "BaseReference";
  detail::checkFinite(where, "nominal_height", config_.nominal_height);
  if (config_.height_samples.empty()) {
    detail::fail(where, "height_samples.size()", 0, "need at least one sample point");
  }
  for (std::size_t k = 0; k < config_.height_samples.size(); ++k) {
    const Eigen::Vector2d& s = config_.height_samples[k];
    detail::checkFinite(where, ("height_samples[" + std::to_string(k) + "].x").c_str(), s.x());
    detail::checkFinite(where, ("height_samples[" + std::to_string(k) + "].y").c_str(), s.y());
  }
}

void BaseReference::reset(double t0, const lie::SE3& start, const BaseVelocityCommand& command) {
  const char* where = "BaseReference::reset";
  detail::checkFinite(where, "t0", t0);
  detail::checkFinite(where, "command.v_x", command.v_x);
  detail::checkFinite(where, "command.v_y", command.v_y);
  detail::checkFinite(where, "command.yaw_rate", command.yaw_rate);
  if (!start.translation.allFinite() || !start.rotation.coeffs().allFinite() ||
      start.rotation.norm() < 1e-9) {
    detail::fail(where, "start", "(non-finite or zero quaternion)", "must be a finite pose");
  }
  const Eigen::Matrix3d r = start.rotation.normalized().toRotationMatrix();
  const double yaw = std::atan2(r(1, 0), r(0, 0));
  t0_ = t0;
  command_ = command;
  start_ = lie::SE3(Eigen::Vector3d(start.translation.x(), start.translation.y(), 0.0),
                    Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())));
}

lie::Vector6d BaseReference::twist() const {
  lie::Vector6d v;
  v << command_.v_x, command_.v_y, 0.0, 0.0, 0.0, command_.yaw_rate;
  return v;
}

lie::SE3 BaseReference::planarPoseAt(double t) const {
  const lie::Vector6d d = (t - t0_) * twist();
  return start_ * lie::expSE3(d);
}

Eigen::Vector2d BaseReference::worldPoint(const Eigen::Vector2d& body_xy, double t) const {
  return planarPoseAt(t).act(Eigen::Vector3d(body_xy.x(), body_xy.y(), 0.0)).head<2>();
}

double BaseReference::terrainHeightAt(double t) const {
  const lie::SE3 p = planarPoseAt(t);
  double sum = 0.0;
  for (const Eigen::Vector2d& s : config_.height_samples) {
    sum += terrain_->heightAt(p.act(Eigen::Vector3d(s.x(), s.y(), 0.0)).head<2>());
  }
  return sum / static_cast<double>(config_.height_samples.size());
}

lie::SE3 BaseReference::poseAt(double t) const {
  lie::SE3 p = planarPoseAt(t);
  p.translation.z() = terrainHeightAt(t) + config_.nominal_height;
  return p;
}

}  // namespace rollstep::planning
