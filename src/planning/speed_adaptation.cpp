#include "rollstep/planning/speed_adaptation.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
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

BaseVelocityCommand scaled(const BaseVelocityCommand& c, double s) {
  return {c.v_x * s, c.v_y * s, c.yaw_rate * s};
}

/// True when a sample point, moved along the unit travel direction e from `behind` back to
/// `ahead` forward, crosses surfaces whose heights differ by more than min_step.
bool nearStep(const TerrainModel& terrain, const lie::SE3& pose,
              const std::vector<Eigen::Vector2d>& samples, const Eigen::Vector2d& e, double behind,
              double ahead, double min_step) {
  for (const Eigen::Vector2d& s : samples) {
    const detail::HeightRange r =
        detail::heightRangeAlong(terrain, detail::worldPoint(pose, s), e, -behind, ahead);
    if (r.hi - r.lo > min_step) return true;
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

namespace {

/// The planar start pose of the schedules: the start's x, y and yaw.
lie::SE3 planarStart(const lie::SE3& start) {
  const Eigen::Quaterniond yaw0(
      Eigen::AngleAxisd(yawOf(start.rotation.normalized()), Eigen::Vector3d::UnitZ()));
  return lie::SE3(Eigen::Vector3d(start.translation.x(), start.translation.y(), 0.0), yaw0);
}

/// The speed rule's schedule (slowed near steps, ramped), validated inputs.
std::vector<TimedBaseCommand> limitSpeeds(const std::vector<TimedBaseCommand>& schedule,
                                          const lie::SE3& start, const TerrainModel& terrain,
                                          const std::vector<Eigen::Vector2d>& samples,
                                          const SpeedScheduleConfig& config,
                                          std::vector<StepSlowdown>* slowdowns) {
  const bool limit_steps = config.step_speed_limit > 0.0 && terrain.size() > 0;
  const bool limit_acceleration = config.max_acceleration > 0.0;
  if (!limit_steps && !limit_acceleration) return schedule;

  std::vector<TimedBaseCommand> out;
  lie::SE3 pose = planarStart(start);
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

/// A schedule's planar path: the pose at each segment's start.
class PlanarPath {
 public:
  PlanarPath(const std::vector<TimedBaseCommand>& schedule, const lie::SE3& start)
      : schedule_(schedule) {
    poses_.push_back(start);
    for (std::size_t k = 1; k < schedule_.size(); ++k) {
      poses_.push_back(poses_.back() * lie::expSE3((schedule_[k].time - schedule_[k - 1].time) *
                                                   twistOf(schedule_[k - 1].command)));
    }
  }
  std::size_t segmentAt(double t) const {
    const auto it =
        std::upper_bound(schedule_.begin(), schedule_.end(), t,
                         [](double v, const TimedBaseCommand& c) { return v < c.time; });
    return it == schedule_.begin() ? 0 : static_cast<std::size_t>(it - schedule_.begin()) - 1;
  }
  lie::SE3 poseAt(double t) const {
    const std::size_t k = segmentAt(t);
    return poses_[k] * lie::expSE3((std::max(t, schedule_[k].time) - schedule_[k].time) *
                                   twistOf(schedule_[k].command));
  }
  const BaseVelocityCommand& commandAt(double t) const { return schedule_[segmentAt(t)].command; }

 private:
  const std::vector<TimedBaseCommand>& schedule_;
  std::vector<lie::SE3> poses_;
};

/// The first touch-down onto another level (a step up or down) of any foot, with the path
/// `delay` seconds late (the touch-down at schedule time t lands where the path is at t -
/// delay): its time, how far past the riser it lands (along its foot's travel) and where it
/// should (speed x period / 4).
struct StepTouchdown {
  bool found = false;
  double time = 0.0;
  double past = 0.0;
  double target = 0.0;
};

StepTouchdown firstStepTouchdown(const PlanarPath& path, double path_end,
                                 const TerrainModel& terrain,
                                 const std::vector<Eigen::Vector2d>& samples,
                                 const SpeedScheduleConfig& config, double delay) {
  const double period = config.gait_period;
  const auto foothold = [&](std::size_t f, double t) {
    const Eigen::Vector2d& s = samples[f];
    return path.poseAt(std::max(t - delay, 0.0))
        .act(Eigen::Vector3d(s.x(), s.y(), 0.0))
        .head<2>()
        .eval();
  };
  std::vector<Eigen::Vector2d> last(samples.size());
  for (std::size_t f = 0; f < samples.size(); ++f) last[f] = foothold(f, 0.0);
  std::vector<std::pair<double, std::size_t>> touchdowns;
  StepTouchdown best;
  for (double base = 0.0; base - delay <= path_end; base += period) {
    touchdowns.clear();
    for (std::size_t f = 0; f < samples.size(); ++f) {
      for (const double phase : config.touchdowns[f]) {
        const double t = base + (phase - config.gait_time_at_start) -
                         period * std::floor((phase - config.gait_time_at_start) / period);
        touchdowns.push_back({t, f});
      }
    }
    std::sort(touchdowns.begin(), touchdowns.end());
    for (const auto& [t, f] : touchdowns) {
      const Eigen::Vector2d p = foothold(f, t);
      const Eigen::Vector2d from = last[f];
      last[f] = p;
      const double h0 = terrain.heightAt(from);
      if (!(std::abs(terrain.heightAt(p) - h0) > config.min_step)) continue;
      // The riser: where the height first changes along the foot's travel (in a gap between
      // regions heightAt gives the nearest region's: the change comes at the gap's middle).
      const double length = (p - from).norm();
      const Eigen::Vector2d u = (p - from) / length;
      constexpr double kScan = 0.005;  // [m]
      double riser = length;
      for (double d = 0.0; d <= length; d += kScan) {
        if (std::abs(terrain.heightAt(from + d * u) - h0) > config.min_step) {
          riser = d;
          break;
        }
      }
      const BaseVelocityCommand& c = path.commandAt(std::max(t - delay, 0.0));
      best.found = true;
      best.time = t;
      best.past = length - riser;
      best.target = 0.25 * period * commandSpeed(c, 0.0);
      return best;
    }
  }
  return best;
}

/// `schedule` with its speed scaled by 1 - depth (reached and left over `ramp`) over
/// [dip_start, dip_start + length]: the same path, later by the time the dip lost (`shift`).
std::vector<TimedBaseCommand> dipSchedule(const std::vector<TimedBaseCommand>& schedule,
                                          double dip_start, double length, double depth,
                                          double ramp, double resolution, double* shift) {
  const auto old = [&schedule](double t) -> const BaseVelocityCommand& {
    const auto it =
        std::upper_bound(schedule.begin(), schedule.end(), t,
                         [](double v, const TimedBaseCommand& c) { return v < c.time; });
    return it == schedule.begin() ? it->command : std::prev(it)->command;
  };
  std::vector<TimedBaseCommand> out;
  const auto push = [&out](double t, const BaseVelocityCommand& c) {
    if (out.empty() || !sameCommand(out.back().command, c)) out.push_back({t, c});
  };
  for (const TimedBaseCommand& c : schedule) {
    if (c.time < dip_start) push(c.time, c.command);
  }
  const auto sigma = [&](double u) {
    const double r = ramp > 0.0 ? std::min({1.0, u / ramp, (length - u) / ramp}) : 1.0;
    return 1.0 - depth * std::max(r, 0.0);
  };
  // Even steps of at most `resolution` (a short last one would change the speed as much in
  // less time).
  const int steps = std::max(1, static_cast<int>(std::ceil(length / resolution - 1e-9)));
  const double dt = length / steps;
  double t = dip_start, tau = dip_start;
  for (int i = 0; i < steps; ++i) {
    const double s = sigma((i + 0.5) * dt);
    push(t, scaled(old(tau + 0.5 * s * dt), s));
    t = dip_start + (i + 1) * dt;
    tau += s * dt;
  }
  *shift = t - tau;
  push(t, old(tau));
  for (const TimedBaseCommand& c : schedule) {
    if (c.time > tau) push(c.time + *shift, c.command);
  }
  return out;
}

}  // namespace

std::vector<TimedBaseCommand> adaptScheduleToTerrain(const std::vector<TimedBaseCommand>& schedule,
                                                     const lie::SE3& start,
                                                     const TerrainModel& terrain,
                                                     const std::vector<Eigen::Vector2d>& samples,
                                                     const SpeedScheduleConfig& config,
                                                     std::vector<StepSlowdown>* slowdowns,
                                                     ApproachTiming* approach) {
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
  const bool timed = config.gait_period > 0.0 && !config.touchdowns.empty();
  if (timed) {
    detail::checkFinite(where, "gait_period", config.gait_period);
    detail::checkFinite(where, "gait_time_at_start", config.gait_time_at_start);
    if (config.touchdowns.size() != samples.size()) {
      detail::fail(where, "touchdowns.size()", static_cast<double>(config.touchdowns.size()),
                   "must be one list per sample point");
    }
    for (const std::vector<double>& phases : config.touchdowns) {
      for (const double phase : phases) {
        if (!(phase >= 0.0 && phase < config.gait_period)) {
          detail::fail(where, "touchdowns", phase, "must be in [0, gait_period)");
        }
      }
    }
    if (!(config.approach_dip >= 0.0 && config.approach_dip < 1.0)) {
      detail::fail(where, "approach_dip", config.approach_dip, "must be in [0, 1)");
    }
  }
  std::vector<TimedBaseCommand> out =
      limitSpeeds(schedule, start, terrain, samples, config, slowdowns);
  if (approach != nullptr) *approach = ApproachTiming{};
  if (!timed || terrain.size() == 0) return out;

  // The approach timing: the least delay (under half a period) that lands the first
  // touch-down onto a step at its target past the riser.
  const lie::SE3 pose0 = planarStart(start);
  const double path_end = out.back().time + config.scan_time;
  const PlanarPath path(out, pose0);
  const StepTouchdown first = firstStepTouchdown(path, path_end, terrain, samples, config, 0.0);
  if (!first.found || !(first.target > 0.0)) return out;
  // Near enough: at most a twentieth past the target (nearer the riser the wheel behind it
  // is held for less; the footholds move with the tracking error). The least delay that
  // lands there, else the one that lands nearest the target.
  const double half = 0.5 * config.gait_period;
  const auto nearEnough = [](const StepTouchdown& td) {
    return td.found && td.past <= 1.05 * td.target;
  };
  constexpr double kDelayStep = 0.005;  // [s]
  double delay = 0.0;
  StepTouchdown chosen = first;
  for (double d = kDelayStep; d < half && !nearEnough(chosen); d += kDelayStep) {
    const StepTouchdown td = firstStepTouchdown(path, path_end, terrain, samples, config, d);
    if (nearEnough(td) ||
        (td.found && std::abs(td.past - td.target) < std::abs(chosen.past - chosen.target))) {
      delay = d;
      chosen = td;
    }
  }
  if (approach != nullptr) {
    approach->timed = true;
    approach->touchdown = chosen.time;
    approach->target = chosen.target;
    approach->before = first.past;
    approach->after = chosen.past;
  }
  if (delay <= 0.0) return out;
  // The dip: depth 1 - approach_dip, its ramps within max_acceleration at the schedule's top
  // speed (shallower for a short delay), ending a gait period before the touch-down.
  const double top = maxCommandSpeed(out, 0.0);
  if (!(top > 1e-9)) return out;
  const double a = config.max_acceleration;
  double depth = 1.0 - config.approach_dip;
  double ramp = a > 0.0 ? depth * top / a : 0.0;
  double length = 0.0;
  if (delay >= depth * ramp) {
    length = delay / depth + ramp;
  } else {
    depth = std::sqrt(delay * a / top);
    ramp = depth * top / a;
    length = 2.0 * ramp;
  }
  const double dip_start = std::max(0.0, chosen.time - config.gait_period - length);
  double shift = 0.0;
  out = dipSchedule(out, dip_start, length, depth, ramp, config.resolution, &shift);
  if (slowdowns != nullptr) {
    for (StepSlowdown& d : *slowdowns) {
      if (d.start >= dip_start) d.start += shift;
      if (d.end >= dip_start) d.end += shift;
    }
  }
  if (approach != nullptr) {
    approach->delay = shift;
    approach->dip_start = dip_start;
    approach->dip_end = dip_start + length;
    const PlanarPath timed_path(out, pose0);
    const StepTouchdown after = firstStepTouchdown(timed_path, out.back().time + config.scan_time,
                                                   terrain, samples, config, 0.0);
    approach->after = after.found ? after.past : 0.0;
    approach->touchdown = after.time;
  }
  return out;
}

}  // namespace rollstep::planning
