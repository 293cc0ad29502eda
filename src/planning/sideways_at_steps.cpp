#include "rollstep/planning/sideways_at_steps.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "check.hpp"
#include "command_math.hpp"
#include "terrain_scan.hpp"

namespace rollstep::planning {

namespace {

using detail::sameCommand;
using detail::twistOf;
using detail::yawOf;

/// True when a sample point moved from where it is up to `reach` along the unit world
/// direction e meets a height more than min_step above or below the one under it.
bool crossesStep(const TerrainModel& terrain, const lie::SE3& pose,
                 const std::vector<Eigen::Vector2d>& samples, const Eigen::Vector2d& e,
                 double reach, double min_step) {
  for (const Eigen::Vector2d& s : samples) {
    const Eigen::Vector2d w = detail::worldPoint(pose, s);
    const detail::SurfacePlane plane(terrain, w);  // a slope is no step
    const double h0 = plane.height();
    const detail::HeightRange r =
        detail::heightRangeAlong(terrain, w, e, detail::kScanSpacing, reach, plane);
    if (r.hi - h0 > min_step || h0 - r.lo > min_step) return true;
  }
  return false;
}

/// Whether the sideways part of `asked` must be held at `pose`: a step within reach ahead
/// along the travel, along the body's x axis (v_x's way) or sideways (v_y's way).
bool mustHold(const TerrainModel& terrain, const lie::SE3& pose,
              const std::vector<Eigen::Vector2d>& samples, const BaseVelocityCommand& asked,
              const SidewaysHoldConfig& config) {
  const Eigen::Matrix3d r = pose.rotation.toRotationMatrix();
  const Eigen::Vector2d forward = r.col(0).head<2>().normalized();
  const Eigen::Vector2d left = r.col(1).head<2>().normalized();
  const Eigen::Vector2d travel = asked.v_x * forward + asked.v_y * left;
  const auto crosses = [&](const Eigen::Vector2d& e) {
    return crossesStep(terrain, pose, samples, e, config.reach, config.min_step);
  };
  if (crosses(std::copysign(1.0, asked.v_y) * left)) return true;
  if (asked.v_x != 0.0 && crosses(std::copysign(1.0, asked.v_x) * forward)) return true;
  return travel.norm() > 1e-12 && crosses(travel.normalized());
}

}  // namespace

std::vector<TimedBaseCommand> holdSidewaysAtSteps(const std::vector<TimedBaseCommand>& schedule,
                                                  const lie::SE3& start,
                                                  const TerrainModel& terrain,
                                                  const std::vector<Eigen::Vector2d>& samples,
                                                  const SidewaysHoldConfig& config,
                                                  std::vector<SidewaysHold>* holds) {
  const char* where = "holdSidewaysAtSteps";
  if (schedule.empty()) detail::fail(where, "schedule.size()", 0, "need at least one command");
  for (std::size_t k = 0; k < schedule.size(); ++k) {
    const std::string name = "schedule[" + std::to_string(k) + "].time";
    detail::checkFinite(where, name.c_str(), schedule[k].time);
    if (k == 0 && schedule[k].time != 0.0) detail::fail(where, name.c_str(), 0, "must be 0");
    if (k > 0 && !(schedule[k].time > schedule[k - 1].time)) {
      detail::fail(where, name.c_str(), schedule[k].time, "times must increase");
    }
    const std::string v = "schedule[" + std::to_string(k) + "].command";
    detail::checkFinite(where, (v + ".v_x").c_str(), schedule[k].command.v_x);
    detail::checkFinite(where, (v + ".v_y").c_str(), schedule[k].command.v_y);
    detail::checkFinite(where, (v + ".yaw_rate").c_str(), schedule[k].command.yaw_rate);
  }
  detail::checkNonNegative(where, "reach", config.reach);
  detail::checkNonNegative(where, "min_step", config.min_step);
  detail::checkFinite(where, "max_acceleration", config.max_acceleration);
  detail::checkPositive(where, "resolution", config.resolution);
  detail::checkNonNegative(where, "scan_time", config.scan_time);
  const bool sideways = std::any_of(schedule.begin(), schedule.end(),
                                    [](const TimedBaseCommand& c) { return c.command.v_y != 0.0; });
  if (terrain.size() == 0 || !sideways || !(config.reach > 0.0)) return schedule;

  std::vector<TimedBaseCommand> out;
  const Eigen::Quaterniond yaw0(
      Eigen::AngleAxisd(yawOf(start.rotation.normalized()), Eigen::Vector3d::UnitZ()));
  lie::SE3 pose(Eigen::Vector3d(start.translation.x(), start.translation.y(), 0.0), yaw0);
  const double end = schedule.back().time + config.scan_time;
  const double dv_max = config.max_acceleration > 0.0 ? config.max_acceleration * config.resolution
                                                      : std::numeric_limits<double>::infinity();
  double v_y = schedule.front().command.v_y;  // the sideways speed given
  double previous_asked = v_y;
  std::size_t k = 0;
  double t = 0.0;
  bool held = false;
  while (true) {
    while (k + 1 < schedule.size() && t >= schedule[k + 1].time) ++k;
    const BaseVelocityCommand& asked = schedule[k].command;
    const bool hold = asked.v_y != 0.0 && mustHold(terrain, pose, samples, asked, config);
    // Into and out of a hold at max_acceleration; the command's own changes as asked.
    const bool following = v_y == previous_asked;
    previous_asked = asked.v_y;
    if (!hold && following) {
      v_y = asked.v_y;
    } else {
      v_y += std::clamp((hold ? 0.0 : asked.v_y) - v_y, -dv_max, dv_max);
    }
    const BaseVelocityCommand next{asked.v_x, v_y, asked.yaw_rate};
    if (out.empty() || !sameCommand(out.back().command, next)) out.push_back({t, next});
    if (holds != nullptr) {
      if (hold && !held) holds->push_back({t, t});
      if (held) holds->back().end = t;
    }
    held = hold;
    if (t >= end) break;
    // The last segment, with no sideways part asked and none left: nothing changes any more.
    if (k + 1 == schedule.size() && asked.v_y == 0.0 && v_y == 0.0) break;
    double t_next = t + config.resolution;
    if (k + 1 < schedule.size()) t_next = std::min(t_next, schedule[k + 1].time);
    pose = pose * lie::expSE3((t_next - t) * twistOf(next));
    t = t_next;
  }
  return out;
}

}  // namespace rollstep::planning
