#include "rollstep/planning/base_reference.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "check.hpp"
#include "command_math.hpp"

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
  detail::checkNonNegative(where, "height_reach", config_.height_reach);
  detail::checkNonNegative(where, "height_slope", config_.height_slope);
  segments_.reserve(4);
  segments_.push_back({0.0, BaseVelocityCommand{}, lie::SE3::Identity()});
}

namespace {

using detail::twistOf;
using detail::yawOf;

bool finitePose(const lie::SE3& x) {
  return x.translation.allFinite() && x.rotation.coeffs().allFinite() && x.rotation.norm() >= 1e-9;
}

/// The planar pose (x, y, yaw), z = 0.
lie::SE3 planarPose(const Eigen::Vector2d& xy, double yaw) {
  return lie::SE3(Eigen::Vector3d(xy.x(), xy.y(), 0.0),
                  Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())));
}

}  // namespace

void BaseReference::reset(double t0, const lie::SE3& start, const BaseVelocityCommand& command) {
  const char* where = "BaseReference::reset";
  detail::checkFinite(where, "command.v_x", command.v_x);
  detail::checkFinite(where, "command.v_y", command.v_y);
  detail::checkFinite(where, "command.yaw_rate", command.yaw_rate);
  const TimedBaseCommand one{0.0, command};
  resetSegments(t0, start, &one, 1);
}

void BaseReference::resetSchedule(double t0, const lie::SE3& start,
                                  const std::vector<TimedBaseCommand>& schedule) {
  const char* where = "BaseReference::reset";
  if (schedule.empty()) detail::fail(where, "schedule.size()", 0, "need at least one command");
  for (std::size_t k = 0; k < schedule.size(); ++k) {
    const std::string name = "schedule[" + std::to_string(k) + "]";
    detail::checkFinite(where, (name + ".time").c_str(), schedule[k].time);
    detail::checkFinite(where, (name + ".v_x").c_str(), schedule[k].command.v_x);
    detail::checkFinite(where, (name + ".v_y").c_str(), schedule[k].command.v_y);
    detail::checkFinite(where, (name + ".yaw_rate").c_str(), schedule[k].command.yaw_rate);
    if (k == 0 && schedule[k].time != 0.0) {
      detail::fail(where, (name + ".time").c_str(), schedule[k].time, "the first must be 0");
    }
    if (k > 0 && !(schedule[k].time > schedule[k - 1].time)) {
      detail::fail(where, (name + ".time").c_str(), schedule[k].time, "times must increase");
    }
  }
  resetSegments(t0, start, schedule.data(), schedule.size());
}

void BaseReference::resetSegments(double t0, const lie::SE3& start,
                                  const TimedBaseCommand* schedule, std::size_t n) {
  const char* where = "BaseReference::reset";
  detail::checkFinite(where, "t0", t0);
  if (!finitePose(start)) {
    detail::fail(where, "start", "(non-finite or zero quaternion)", "must be a finite pose");
  }
  t0_ = t0;
  correction_ = lie::SE3::Identity();
  segments_.clear();
  lie::SE3 pose = planarPose(start.translation.head<2>(), yawOf(start.rotation.normalized()));
  for (std::size_t k = 0; k < n; ++k) {
    if (k > 0) {
      const Segment& prev = segments_.back();
      pose = prev.start *
             lie::expSE3((t0 + schedule[k].time - prev.start_time) * twistOf(prev.command));
    }
    segments_.push_back({t0 + schedule[k].time, schedule[k].command, pose});
  }
}

const BaseReference::Segment& BaseReference::segmentAt(double t) const {
  std::size_t k = 0;
  while (k + 1 < segments_.size() && t >= segments_[k + 1].start_time) ++k;
  return segments_[k];
}

lie::Vector6d BaseReference::twistAt(double t) const { return twistOf(segmentAt(t).command); }

lie::Vector6d BaseReference::twist() const { return twistOf(segments_.front().command); }

lie::Vector6d BaseReference::velocityAt(double t) const {
  lie::Vector6d v = twistAt(t);
  if (config_.height_rate && config_.height_reach > 0.0) {
    v[2] = (terrainHeightAt(t + kRateStep) - terrainHeightAt(t - kRateStep)) / (2.0 * kRateStep);
  }
  return v;
}

lie::SE3 BaseReference::planarPoseAt(double t) const {
  const Segment& s = segmentAt(t);
  return correction_ * (s.start * lie::expSE3((t - s.start_time) * twistOf(s.command)));
}

bool BaseReference::follow(double t, const lie::SE3& measured, double max_distance, double max_yaw,
                           double max_lateral) {
  const char* where = "BaseReference::follow";
  detail::checkFinite(where, "t", t);
  detail::checkFinite(where, "max_distance", max_distance);
  detail::checkFinite(where, "max_yaw", max_yaw);
  detail::checkFinite(where, "max_lateral", max_lateral);
  if (!finitePose(measured)) {
    detail::fail(where, "measured", "(non-finite or zero quaternion)", "must be a finite pose");
  }
  const lie::SE3 ref = planarPoseAt(t);
  const Eigen::Vector2d robot_xy = measured.translation.head<2>();
  const double robot_yaw = yawOf(measured.rotation.normalized());
  const double ref_yaw = yawOf(ref.rotation);
  Eigen::Vector2d target_xy = ref.translation.head<2>();
  double target_yaw = ref_yaw;
  bool moved = false;
  if (max_lateral > 0.0) {
    const Eigen::Vector2d across(-std::sin(ref_yaw), std::cos(ref_yaw));
    const double aside = across.dot(target_xy - robot_xy);
    if (std::abs(aside) > max_lateral) {
      target_xy -= (aside - std::copysign(max_lateral, aside)) * across;
      moved = true;
    }
  }
  const Eigen::Vector2d lead = target_xy - robot_xy;
  const double distance = lead.norm();
  if (max_distance > 0.0 && distance > max_distance) {
    target_xy = robot_xy + lead * (max_distance / distance);
    moved = true;
  }
  const double yaw_lead = std::remainder(ref_yaw - robot_yaw, 2.0 * M_PI);
  if (max_yaw > 0.0 && std::abs(yaw_lead) > max_yaw) {
    target_yaw = robot_yaw + std::copysign(max_yaw, yaw_lead);
    moved = true;
  }
  if (!moved) return false;
  // target = C' * schedule(t) and ref = C * schedule(t): C' = target * ref^-1 * C.
  correction_ = planarPose(target_xy, target_yaw) * ref.inverse() * correction_;
  correction_.rotation.normalize();
  return true;
}

bool BaseReference::setCorrection(const lie::SE3& correction) noexcept {
  if (!finitePose(correction)) return false;
  correction_ = correction;
  correction_.rotation.normalize();
  return true;
}

Eigen::Vector2d BaseReference::worldPoint(const Eigen::Vector2d& body_xy, double t) const {
  return planarPoseAt(t).act(Eigen::Vector3d(body_xy.x(), body_xy.y(), 0.0)).head<2>();
}

double BaseReference::terrainHeightAt(double t) const {
  const lie::SE3 p = planarPoseAt(t);
  if (config_.height_reach > 0.0) {
    // Direction of travel in the world plane (none when standing or turning on the spot:
    // the envelope then reduces to the heights under the samples).
    const BaseVelocityCommand& c = segmentAt(t).command;
    Eigen::Vector2d e = (p.rotation * Eigen::Vector3d(c.v_x, c.v_y, 0.0)).head<2>();
    const double speed = e.norm();
    const double reach = speed > 1e-9 ? config_.height_reach : 0.0;
    if (speed > 1e-9) e /= speed;
    double best = -std::numeric_limits<double>::infinity();
    const Eigen::Vector2d centre = p.translation.head<2>();
    for (const Eigen::Vector2d& s : config_.height_samples) {
      const Eigen::Vector2d w = p.act(Eigen::Vector3d(s.x(), s.y(), 0.0)).head<2>();
      double h = terrain_->envelopeHeight(w, e, reach, config_.height_slope);
      // On a sloped surface the wheels follow the plane: only terrain above that plane's
      // continuation within reach raises the body, and the sample's height is carried to
      // the body's centre along the plane (otherwise the front feet on an up-slope set the
      // height and the rear legs overextend). Level surfaces keep the plain envelope.
      const int under = terrain_->regionAt(w);
      if (under >= 0) {
        const Eigen::Vector3d& n = terrain_->region(under).normal;
        if (n.x() != 0.0 || n.y() != 0.0) {
          const Eigen::Vector2d grade = -n.head<2>() / n.z();
          // The envelope looks reach ahead and behind: the plane rises on one side.
          const double own_rise = reach * std::abs(grade.dot(e));
          h = std::max(terrain_->heightAt(w), h - own_rise) - grade.dot(w - centre);
        }
      }
      best = std::max(best, h);
    }
    return best;
  }
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
