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
    const Eigen::Vector2d w = detail::worldPoint(pose, s);
    const detail::SurfacePlane plane(terrain, w);  // a slope is no step
    const detail::HeightRange r = detail::heightRangeAlong(terrain, w, e, -behind, ahead, plane);
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

/// A touch-down onto another level (a step up or down): its time, its foot's row (body x of
/// its sample point), where along the travel its riser lies, how far past the riser it lands
/// (along its foot's travel) and where it should (speed x period / 4).
struct StepTouchdown {
  bool found = false;
  double time = 0.0;
  double row = 0.0;    // [m] body x of the foot's sample point
  double riser = 0.0;  // [m] the riser's position along the travel direction at the touch-down
  double past = 0.0;
  double target = 0.0;
  bool up = false;
};

/// Rows of feet closer than this along the body x are one row; risers closer than this along
/// the travel are one riser [m].
constexpr double kSameEdge = 0.05;

/// An edge already timed: a row of feet (body x) meeting a riser (position along the travel).
struct TimedEdge {
  double row = 0.0;
  double riser = 0.0;
};

/// The first touch-down onto another level of any foot whose row has not met that riser yet
/// (not in `timed`), with the path `delay` seconds late from `from_time` on (a touch-down at
/// schedule time t > from_time lands where the path is at max(t - delay, from_time); the
/// gait clock runs on).
StepTouchdown nextStepTouchdown(const PlanarPath& path, double path_end,
                                const TerrainModel& terrain,
                                const std::vector<Eigen::Vector2d>& samples,
                                const SpeedScheduleConfig& config, double delay, double from_time,
                                const std::vector<TimedEdge>& timed) {
  const double period = config.gait_period;
  const auto pathTime = [&](double t) {
    return t <= from_time ? std::max(t, 0.0) : std::max(t - delay, from_time);
  };
  const auto foothold = [&](std::size_t f, double t) {
    const Eigen::Vector2d& s = samples[f];
    return path.poseAt(pathTime(t)).act(Eigen::Vector3d(s.x(), s.y(), 0.0)).head<2>().eval();
  };
  std::vector<Eigen::Vector2d> last(samples.size());
  for (std::size_t f = 0; f < samples.size(); ++f) last[f] = foothold(f, 0.0);
  std::vector<std::pair<double, std::size_t>> touchdowns;
  StepTouchdown best;
  for (double base = 0.0; pathTime(base) <= path_end; base += period) {
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
      const detail::SurfacePlane plane(terrain, from);  // a slope is no step
      if (!(std::abs(terrain.heightAt(p) - plane.at(p)) > config.min_step)) continue;
      // The riser: where the height first changes along the foot's travel (in a gap between
      // regions heightAt gives the nearest region's: the change comes at the gap's middle).
      const double length = (p - from).norm();
      const Eigen::Vector2d u = (p - from) / length;
      constexpr double kScan = 0.005;  // [m]
      double riser = length;
      for (double d = 0.0; d <= length; d += kScan) {
        if (std::abs(terrain.heightAt(from + d * u) - plane.at(from + d * u)) > config.min_step) {
          riser = d;
          break;
        }
      }
      // Where the riser lies along the body's travel (the heading at the touch-down).
      const lie::SE3 pose = path.poseAt(pathTime(t));
      const Eigen::Vector2d heading = (pose.rotation * Eigen::Vector3d::UnitX()).head<2>();
      const double along = (from + riser * u).dot(heading);
      const double row = samples[f].x();
      const bool seen = std::any_of(timed.begin(), timed.end(), [&](const TimedEdge& e) {
        return std::abs(e.row - row) < kSameEdge && std::abs(e.riser - along) < kSameEdge;
      });
      if (seen) continue;
      const BaseVelocityCommand& c = path.commandAt(pathTime(t));
      best.found = true;
      best.time = t;
      best.row = row;
      best.riser = along;
      best.past = length - riser;
      best.up = terrain.heightAt(p) > plane.at(p);
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

  // The approach timing, edge by edge: for the first touch-down onto a step, then for each
  // next row of feet meeting a riser, the least delay (under half a period) that lands it at
  // its target past the riser, by a dip that leaves the touch-downs timed before it alone.
  const lie::SE3 pose0 = planarStart(start);
  // Near enough: at most a twentieth past the target (nearer the riser the wheel behind it
  // is held for less; the footholds move with the tracking error). The least delay that
  // lands there, else the one that lands nearest the target.
  const double half = 0.5 * config.gait_period;
  // With every edge timed, also no nearer than half the target: nearer, the nominal foothold
  // falls in the band beside the riser where the foothold regions leave no room, and the
  // wheel stalls there as one that lands too far does.
  const auto nearEnough = [&config](const StepTouchdown& td) {
    return td.found && td.past <= 1.05 * td.target &&
           (!config.time_every_edge || td.past >= 0.5 * td.target);
  };
  const auto sameEdge = [](const StepTouchdown& a, const StepTouchdown& b) {
    return a.found && b.found && std::abs(a.row - b.row) < kSameEdge &&
           std::abs(a.riser - b.riser) < kSameEdge;
  };
  constexpr double kDelayStep = 0.005;  // [s]
  constexpr int kMaxEdges = 64;         // bounds the work on long terrains
  std::vector<TimedEdge> timed_edges;
  double from_time = 0.0;  // [s] a dip begins no sooner (the touch-downs before it stay)
  const double top = maxCommandSpeed(out, 0.0);
  for (int edge = 0; edge < kMaxEdges && top > 1e-9; ++edge) {
    const double path_end = out.back().time + config.scan_time;
    const PlanarPath path(out, pose0);
    const StepTouchdown first =
        nextStepTouchdown(path, path_end, terrain, samples, config, 0.0, from_time, timed_edges);
    if (!first.found || !(first.target > 0.0)) break;
    double delay = 0.0;
    StepTouchdown chosen = first;
    for (double d = kDelayStep; d < half && !nearEnough(chosen); d += kDelayStep) {
      const StepTouchdown td =
          nextStepTouchdown(path, path_end, terrain, samples, config, d, from_time, timed_edges);
      if (!sameEdge(td, first)) continue;
      if (nearEnough(td) || std::abs(td.past - td.target) < std::abs(chosen.past - chosen.target)) {
        delay = d;
        chosen = td;
      }
    }
    timed_edges.push_back({first.row, first.riser});
    // The dip: depth 1 - approach_dip, its ramps within max_acceleration (shallower for a
    // short delay), ending a gait period before the touch-down. The first edge's ramps are
    // timed for the schedule's top speed (the approach may still be at it); a later edge's
    // for the speed at its touch-down, and its dip must begin after the touch-downs timed
    // before and end before its own.
    const double a = config.max_acceleration;
    const double speed = edge == 0 ? top : commandSpeed(path.commandAt(first.time), 0.0);
    double depth = 1.0 - config.approach_dip;
    double ramp = a > 0.0 ? depth * speed / a : 0.0;
    double length = 0.0;
    if (delay >= depth * ramp) {
      length = delay / depth + ramp;
    } else {
      depth = std::sqrt(delay * a / speed);
      ramp = depth * speed / a;
      length = 2.0 * ramp;
    }
    const double dip_start = std::max(from_time, chosen.time - config.gait_period - length);
    const bool fits = edge == 0 || (speed > 1e-9 && dip_start + length <= chosen.time + 1e-9);
    EdgeTiming timing;
    timing.delay = 0.0;
    timing.touchdown = first.time;
    timing.target = first.target;
    timing.before = first.past;
    timing.after = first.past;
    timing.up = first.up;
    timing.fits = fits;
    if (delay > 0.0 && fits) {
      double shift = 0.0;
      out = dipSchedule(out, dip_start, length, depth, ramp, config.resolution, &shift);
      if (slowdowns != nullptr) {
        for (StepSlowdown& d : *slowdowns) {
          if (d.start >= dip_start) d.start += shift;
          if (d.end >= dip_start) d.end += shift;
        }
      }
      timing.delay = shift;
      timing.dip_start = dip_start;
      timing.dip_end = dip_start + length;
      const PlanarPath timed_path(out, pose0);
      std::vector<TimedEdge> before(timed_edges.begin(), timed_edges.end() - 1);
      const StepTouchdown after =
          nextStepTouchdown(timed_path, out.back().time + config.scan_time, terrain, samples,
                            config, 0.0, from_time, before);
      timing.after = sameEdge(after, first) ? after.past : chosen.past;
      timing.touchdown = sameEdge(after, first) ? after.time : chosen.time;
    }
    if (approach != nullptr) {
      if (edge == 0) {
        approach->timed = true;
        approach->delay = timing.delay;
        approach->dip_start = timing.dip_start;
        approach->dip_end = timing.dip_end;
        approach->touchdown = timing.touchdown;
        approach->target = timing.target;
        approach->before = timing.before;
        approach->after = timing.after;
      }
      approach->edges.push_back(timing);
    }
    // The other group of this row meets the riser half a period later: later dips begin
    // after it.
    from_time = std::max(from_time, timing.touchdown + half);
    if (!config.time_every_edge) break;
  }
  return out;
}

}  // namespace rollstep::planning
