#include "rollstep/planning/speed_adaptation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "check.hpp"

namespace rollstep::planning {

namespace {

void checkLimits(const SpeedAdaptationLimits& l) {
  const char* where = "adaptTrotToSpeed";
  detail::checkPositive(where, "knee_speed", l.knee_speed);
  detail::checkPositive(where, "rise", l.rise);
  if (!(l.apex_margin > 0.0 && l.apex_margin <= 0.5)) {
    detail::fail(where, "apex_margin", l.apex_margin, "must be in (0, 0.5]");
  }
  detail::checkPositive(where, "stance_stroke", l.stance_stroke);
  detail::checkOpenUnit(where, "min_duty", l.min_duty);
  if (!(l.max_duty >= l.min_duty && l.max_duty < 1.0)) {
    detail::fail(where, "max_duty", l.max_duty, "must be in [min_duty, 1)");
  }
}

lie::Vector6d twistOf(const BaseVelocityCommand& c) {
  lie::Vector6d v;
  v << c.v_x, c.v_y, 0.0, 0.0, 0.0, c.yaw_rate;
  return v;
}

bool sameCommand(const BaseVelocityCommand& a, const BaseVelocityCommand& b) {
  return a.v_x == b.v_x && a.v_y == b.v_y && a.yaw_rate == b.yaw_rate;
}

BaseVelocityCommand scaled(const BaseVelocityCommand& c, double s) {
  return {c.v_x * s, c.v_y * s, c.yaw_rate * s};
}

double yawOf(const Eigen::Quaterniond& q) {
  const Eigen::Matrix3d r = q.toRotationMatrix();
  return std::atan2(r(1, 0), r(0, 0));
}

/// True when a sample point, moved along the unit travel direction e from `behind` back to
/// `ahead` forward, crosses surfaces whose heights differ by more than min_step.
bool nearStep(const TerrainModel& terrain, const lie::SE3& pose,
              const std::vector<Eigen::Vector2d>& samples, const Eigen::Vector2d& e, double behind,
              double ahead, double min_step) {
  constexpr double kSpacing = 0.02;  // [m] finer than any foothold region a wheel stands on
  for (const Eigen::Vector2d& s : samples) {
    const Eigen::Vector2d w = pose.act(Eigen::Vector3d(s.x(), s.y(), 0.0)).head<2>();
    double lo = std::numeric_limits<double>::infinity();
    double hi = -lo;
    for (double d = -behind; d <= ahead + 1e-9; d += kSpacing) {
      const double h = terrain.heightAt(w + d * e);
      lo = std::min(lo, h);
      hi = std::max(hi, h);
    }
    if (hi - lo > min_step) return true;
  }
  return false;
}

}  // namespace

TrotTiming adaptTrotToSpeed(double speed, const SpeedAdaptationLimits& limits) {
  checkLimits(limits);
  detail::checkFinite("adaptTrotToSpeed", "speed", speed);
  const double v = std::abs(speed);
  TrotTiming t;
  // The rise takes (1 - apex_margin) of the swing on a cubic 1.5 times as steep as its mean.
  t.swing = 1.5 * limits.rise / ((1.0 - limits.apex_margin) * limits.knee_speed);
  const double longest_stance = t.swing * limits.max_duty / (1.0 - limits.max_duty);
  const double shortest_stance = t.swing * limits.min_duty / (1.0 - limits.min_duty);
  t.step_speed_limit = limits.stance_stroke / shortest_stance;
  const double stroke_stance = v > 0.0 ? limits.stance_stroke / v : longest_stance;
  t.stance = std::clamp(stroke_stance, shortest_stance, longest_stance);
  t.period = t.swing + t.stance;
  t.duty = t.stance / t.period;
  t.speed_limited = v > t.step_speed_limit;
  const double v_gait = std::min(v, t.step_speed_limit);
  t.max_edge_hold =
      v_gait > 0.0 ? limits.stance_stroke / v_gait : std::numeric_limits<double>::infinity();
  return t;
}

double commandSpeed(const BaseVelocityCommand& command, double turn_radius) {
  return std::hypot(command.v_x, command.v_y) + std::abs(command.yaw_rate) * turn_radius;
}

double maxCommandSpeed(const std::vector<TimedBaseCommand>& schedule, double turn_radius) {
  double v = 0.0;
  for (const TimedBaseCommand& c : schedule) v = std::max(v, commandSpeed(c.command, turn_radius));
  return v;
}

std::vector<TimedBaseCommand> adaptScheduleToTerrain(const std::vector<TimedBaseCommand>& schedule,
                                                     const lie::SE3& start,
                                                     const TerrainModel& terrain,
                                                     const std::vector<Eigen::Vector2d>& samples,
                                                     const SpeedScheduleConfig& config,
                                                     std::vector<StepSlowdown>* slowdowns) {
  const char* where = "adaptScheduleToTerrain";
  if (schedule.empty()) detail::fail(where, "schedule.size()", 0, "need at least one command");
  for (std::size_t k = 0; k < schedule.size(); ++k) {
    const std::string name = "schedule[" + std::to_string(k) + "].time";
    detail::checkFinite(where, name.c_str(), schedule[k].time);
    if (k == 0 && schedule[k].time != 0.0) detail::fail(where, name.c_str(), 0, "must be 0");
    if (k > 0 && !(schedule[k].time > schedule[k - 1].time)) {
      detail::fail(where, name.c_str(), schedule[k].time, "times must increase");
    }
  }
  detail::checkFinite(where, "step_speed_limit", config.step_speed_limit);
  detail::checkNonNegative(where, "step_reach", config.step_reach);
  detail::checkNonNegative(where, "min_step", config.min_step);
  detail::checkFinite(where, "max_acceleration", config.max_acceleration);
  detail::checkPositive(where, "resolution", config.resolution);
  detail::checkNonNegative(where, "scan_time", config.scan_time);
  detail::checkNonNegative(where, "turn_radius", config.turn_radius);
  const bool limit_steps = config.step_speed_limit > 0.0 && terrain.size() > 0;
  const bool limit_acceleration = config.max_acceleration > 0.0;
  if (!limit_steps && !limit_acceleration) return schedule;

  std::vector<TimedBaseCommand> out;
  const Eigen::Quaterniond yaw0(
      Eigen::AngleAxisd(yawOf(start.rotation.normalized()), Eigen::Vector3d::UnitZ()));
  lie::SE3 pose(Eigen::Vector3d(start.translation.x(), start.translation.y(), 0.0), yaw0);
  BaseVelocityCommand current{};  // the reference starts from rest
  if (!limit_acceleration) current = schedule.front().command;
  const double end = schedule.back().time + config.scan_time;
  std::size_t k = 0;
  double t = 0.0;
  bool slowed = false;
  while (true) {
    while (k + 1 < schedule.size() && t >= schedule[k + 1].time) ++k;
    const BaseVelocityCommand& asked = schedule[k].command;
    const double asked_speed = commandSpeed(asked, config.turn_radius);
    // The target: the command, scaled down to the limit near a step (looking ahead by the
    // distance it takes to brake to it).
    BaseVelocityCommand target = asked;
    bool limited = false;
    if (limit_steps && asked_speed > config.step_speed_limit) {
      Eigen::Vector2d e = (pose.rotation * Eigen::Vector3d(asked.v_x, asked.v_y, 0.0)).head<2>();
      if (e.norm() > 1e-9) {
        e.normalize();
        const double braking =
            limit_acceleration
                ? (asked_speed * asked_speed - config.step_speed_limit * config.step_speed_limit) /
                      (2.0 * config.max_acceleration)
                : 0.0;
        if (nearStep(terrain, pose, samples, e, config.step_reach, config.step_reach + braking,
                     config.min_step)) {
          target = scaled(asked, config.step_speed_limit / asked_speed);
          limited = true;
        }
      }
    }
    if (slowdowns != nullptr) {
      if (limited && !slowed) {
        slowdowns->push_back({t, t, asked_speed, config.step_speed_limit});
      }
      if (slowed) slowdowns->back().end = t;
    }
    slowed = limited;
    // The speed moves towards the target at most max_acceleration.
    BaseVelocityCommand next = target;
    if (limit_acceleration) {
      const double dv = std::hypot(target.v_x - current.v_x, target.v_y - current.v_y);
      const double step = config.max_acceleration * config.resolution;
      if (dv > step) {
        const double f = step / dv;
        next = {current.v_x + f * (target.v_x - current.v_x),
                current.v_y + f * (target.v_y - current.v_y),
                current.yaw_rate + f * (target.yaw_rate - current.yaw_rate)};
      }
    }
    if (out.empty() || !sameCommand(out.back().command, next)) out.push_back({t, next});
    current = next;
    if (t >= end) break;
    // The next time: a resolution step, or the next segment's start if that comes first.
    double t_next = t + config.resolution;
    if (k + 1 < schedule.size()) t_next = std::min(t_next, schedule[k + 1].time);
    pose = pose * lie::expSE3((t_next - t) * twistOf(current));
    t = t_next;
    // Past the last segment, steady and with no step in reach: nothing changes any more on a
    // straight path (a turning one is scanned to the end).
    if (k + 1 == schedule.size() && sameCommand(current, target) && !limited &&
        asked.yaw_rate == 0.0 && t > schedule.back().time + 1.0) {
      const Eigen::Vector2d e =
          (pose.rotation * Eigen::Vector3d(asked.v_x, asked.v_y, 0.0)).head<2>();
      if (e.norm() < 1e-9 || !limit_steps) break;
      bool ahead = false;
      // Any region still ahead along the path within the scan?
      const Eigen::Vector2d u = e.normalized();
      for (const ConvexRegion& r : terrain.regions()) {
        for (const Eigen::Vector2d& vertex : r.vertices) {
          ahead = ahead || (vertex - pose.translation.head<2>()).dot(u) > -1.0;
        }
        if (ahead) break;
      }
      if (!ahead) break;
    }
  }
  return out;
}

}  // namespace rollstep::planning
