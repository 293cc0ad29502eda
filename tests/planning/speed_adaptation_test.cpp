// The speed rule: the trot's timing against the knee's speed and the hips' stroke at every
// speed, and the command schedule slowed at steps (step20's block) and ramped from rest.
#include "rollstep/planning/speed_adaptation.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace {

using Eigen::Vector2d;
using namespace rollstep;

const std::vector<Vector2d> kNominal{{0.33, 0.22},  {0.33, 0.0},  {0.33, -0.22},
                                     {-0.33, 0.22}, {-0.33, 0.0}, {-0.33, -0.22}};
constexpr double kEdgeUp = 1.0, kEdgeDown = 2.2;  // the block's edges [m]

planning::TerrainModel blockTerrain() {
  return planning::terrainFromBoxes({-5.0, 10.0, -1.5, 1.5, 0.0}, 0.0,
                                    {{kEdgeUp, kEdgeDown, -1.5, 1.5, 0.20}}, 0.085);
}

planning::SpeedAdaptationLimits limits() {
  planning::SpeedAdaptationLimits l;
  l.knee_speed = 0.6;
  l.rise = 0.23;
  l.apex_margin = 0.2;
  l.stance_stroke = 0.25;
  l.max_duty = 0.6;
  l.min_duty = 0.5;
  return l;
}

TEST(TrotTiming, TheSwingRisesWithinTheKneeSpeedAndTheStanceWithinTheStroke) {
  const planning::SpeedAdaptationLimits l = limits();
  for (double v = 0.0; v <= 1.0; v += 0.01) {
    const planning::TrotTiming t = planning::adaptTrotToSpeed(v, l);
    // The steepest vertical speed of the swing's cubic: 1.5 x rise over the rising part.
    EXPECT_LE(1.5 * l.rise / ((1.0 - l.apex_margin) * t.swing), l.knee_speed * (1 + 1e-12)) << v;
    EXPECT_NEAR(t.period, t.swing + t.stance, 1e-12);
    EXPECT_NEAR(t.duty, t.stance / t.period, 1e-12);
    EXPECT_GE(t.duty, l.min_duty - 1e-12) << v;
    EXPECT_LE(t.duty, l.max_duty + 1e-12) << v;
    if (v <= t.step_speed_limit) {
      EXPECT_LE(v * t.stance, l.stance_stroke * (1 + 1e-12)) << v;
      EXPECT_FALSE(t.speed_limited) << v;
    } else {
      EXPECT_TRUE(t.speed_limited) << v;
      // At the limit's timing the stroke is used up exactly.
      EXPECT_NEAR(t.step_speed_limit * t.stance, l.stance_stroke, 1e-12);
    }
  }
  // Slow: the long, overlapped trot; the direction does not matter.
  const planning::TrotTiming slow = planning::adaptTrotToSpeed(0.05, l);
  EXPECT_NEAR(slow.duty, l.max_duty, 1e-12);
  const planning::TrotTiming back = planning::adaptTrotToSpeed(-0.3, l);
  EXPECT_EQ(back.period, planning::adaptTrotToSpeed(0.3, l).period);
}

TEST(TrotTiming, IsContinuousAndShortensWithSpeed) {
  const planning::SpeedAdaptationLimits l = limits();
  planning::TrotTiming previous = planning::adaptTrotToSpeed(0.0, l);
  for (double v = 0.001; v <= 1.0; v += 0.001) {
    const planning::TrotTiming t = planning::adaptTrotToSpeed(v, l);
    EXPECT_LE(t.period, previous.period + 1e-12) << v;
    EXPECT_LT(std::abs(t.period - previous.period), 0.01) << "a jump at " << v;
    previous = t;
  }
}

TEST(TrotTiming, RefusesBadLimits) {
  planning::SpeedAdaptationLimits l = limits();
  l.knee_speed = 0.0;
  EXPECT_THROW(planning::adaptTrotToSpeed(0.2, l), std::invalid_argument);
  l = limits();
  l.max_duty = 0.4;  // below min_duty
  EXPECT_THROW(planning::adaptTrotToSpeed(0.2, l), std::invalid_argument);
  EXPECT_THROW(planning::adaptTrotToSpeed(std::nan(""), limits()), std::invalid_argument);
}

/// The base's planar path under a schedule, sampled every dt: (t, x, y, planar speed).
struct PathSample {
  double t, x, y, speed;
};
std::vector<PathSample> integrate(const std::vector<planning::TimedBaseCommand>& schedule,
                                  double x0, double duration, double dt = 0.005) {
  std::vector<PathSample> out;
  double x = x0, y = 0.0, yaw = 0.0;
  std::size_t k = 0;
  for (double t = 0.0; t <= duration; t += dt) {
    while (k + 1 < schedule.size() && t >= schedule[k + 1].time - 1e-12) ++k;
    const planning::BaseVelocityCommand& c = schedule[k].command;
    out.push_back({t, x, y, std::hypot(c.v_x, c.v_y)});
    x += dt * (std::cos(yaw) * c.v_x - std::sin(yaw) * c.v_y);
    y += dt * (std::sin(yaw) * c.v_x + std::cos(yaw) * c.v_y);
    yaw += dt * c.yaw_rate;
  }
  return out;
}

TEST(StepSpeed, SlowsDownOnlyNearTheStepAndSaysWhere) {
  const planning::TerrainModel terrain = blockTerrain();
  planning::SpeedScheduleConfig config;
  config.step_speed_limit = 0.3;
  config.step_reach = 0.3;
  config.max_acceleration = 0.5;
  for (const double v : {0.5, -0.45}) {
    // Backwards the robot starts beyond the block and comes back over it.
    const double x0 = v > 0 ? 0.0 : 3.4;
    std::vector<planning::StepSlowdown> slowdowns;
    const auto schedule = planning::adaptScheduleToTerrain(
        {{0.0, {v, 0.0, 0.0}}},
        lie::SE3(Eigen::Vector3d(x0, 0.0, 0.0), Eigen::Quaterniond::Identity()), terrain, kNominal,
        config, &slowdowns);
    ASSERT_FALSE(slowdowns.empty()) << v;
    bool full_speed = false;
    for (const PathSample& s : integrate(schedule, x0, 20.0)) {
      // A foot within the reach of an edge: at most the limit.
      bool near_edge = false;
      for (const Vector2d& f : kNominal) {
        for (const double edge : {kEdgeUp, kEdgeDown}) {
          near_edge = near_edge || std::abs(s.x + f.x() - edge) < config.step_reach - 0.1;
        }
      }
      if (near_edge) {
        EXPECT_LE(s.speed, config.step_speed_limit + 1e-9) << "v " << v << " at x " << s.x;
      }
      full_speed = full_speed || std::abs(s.speed - std::abs(v)) < 1e-9;
    }
    EXPECT_TRUE(full_speed) << "never at the command's speed, v " << v;
    for (const planning::StepSlowdown& d : slowdowns) {
      EXPECT_LT(d.start, d.end);
      EXPECT_NEAR(d.commanded_speed, std::abs(v), 1e-12);
      EXPECT_NEAR(d.limited_speed, config.step_speed_limit, 1e-12);
    }
    // The speed never changes faster than the acceleration limit.
    for (std::size_t k = 1; k < schedule.size(); ++k) {
      const auto& a = schedule[k - 1];
      const auto& b = schedule[k];
      const double dv = std::hypot(b.command.v_x - a.command.v_x, b.command.v_y - a.command.v_y);
      EXPECT_LE(dv, config.max_acceleration * (b.time - a.time) + 1e-9) << k;
    }
  }
}

TEST(StepSpeed, LeavesASlowCommandAndLevelGroundAlone) {
  planning::SpeedScheduleConfig config;
  config.step_speed_limit = 0.3;
  const lie::SE3 start = lie::SE3::Identity();
  // No acceleration limit and slower than the step limit: the schedule as given.
  const std::vector<planning::TimedBaseCommand> slow{{0.0, {0.2, 0.05, 0.0}}, {5.0, {-0.1, 0, 0}}};
  const auto same =
      planning::adaptScheduleToTerrain(slow, start, blockTerrain(), kNominal, config, nullptr);
  ASSERT_EQ(same.size(), slow.size());
  for (std::size_t k = 0; k < slow.size(); ++k) {
    EXPECT_EQ(same[k].time, slow[k].time);
    EXPECT_EQ(same[k].command.v_x, slow[k].command.v_x);
  }
  // Level ground, fast, with the acceleration limit: a ramp from rest, then the command.
  config.max_acceleration = 0.5;
  const planning::TerrainModel flat =
      planning::terrainFromBoxes({-5.0, 50.0, -1.5, 1.5, 0.0}, 0.0, {}, 0.085);
  std::vector<planning::StepSlowdown> slowdowns;
  const auto ramp = planning::adaptScheduleToTerrain({{0.0, {0.5, 0.0, 0.0}}}, start, flat,
                                                     kNominal, config, &slowdowns);
  EXPECT_TRUE(slowdowns.empty());
  EXPECT_EQ(ramp.front().time, 0.0);
  EXPECT_NEAR(ramp.back().command.v_x, 0.5, 1e-12);
  EXPECT_NEAR(ramp.back().time, 0.5 / 0.5 - config.resolution, 1e-9);
}

TEST(StepSpeed, ASlopeIsNoStep) {
  // A long 8 deg plane: along it the terrain under a foot rises 0.14 m per metre (past
  // min_step within the reach), but a wheel rolls along it: no slowdown (the rule measured
  // heights against the level before and slowed the whole way).
  planning::SpeedScheduleConfig config;
  config.step_speed_limit = 0.3;
  config.step_reach = 0.3;
  config.max_acceleration = 0.5;
  const double grade = std::tan(8.0 * M_PI / 180.0);
  const planning::TerrainModel slope(
      {planning::ConvexRegion::fromPolygon({{-5.0, -2.0}, {20.0, -2.0}, {20.0, 2.0}, {-5.0, 2.0}},
                                           0.0, Eigen::Vector3d(-grade, 0.0, 1.0).normalized())});
  std::vector<planning::StepSlowdown> slowdowns;
  planning::adaptScheduleToTerrain({{0.0, {0.5, 0.0, 0.0}}}, lie::SE3::Identity(), slope, kNominal,
                                   config, &slowdowns);
  EXPECT_TRUE(slowdowns.empty());
  // A riser from the slope up onto a level block still counts.
  const planning::TerrainModel with_block(
      {planning::ConvexRegion::fromPolygon({{-5.0, -2.0}, {3.0, -2.0}, {3.0, 2.0}, {-5.0, 2.0}},
                                           0.0, Eigen::Vector3d(-grade, 0.0, 1.0).normalized()),
       planning::ConvexRegion::fromPolygon({{3.0, -2.0}, {20.0, -2.0}, {20.0, 2.0}, {3.0, 2.0}},
                                           0.0 + 7.0 * grade + 0.1)});
  planning::adaptScheduleToTerrain({{0.0, {0.5, 0.0, 0.0}}}, lie::SE3::Identity(), with_block,
                                   kNominal, config, &slowdowns);
  EXPECT_FALSE(slowdowns.empty());
}

TEST(StepSpeed, RefusesABadSchedule) {
  planning::SpeedScheduleConfig config;
  config.max_acceleration = 0.5;
  EXPECT_THROW(planning::adaptScheduleToTerrain({}, lie::SE3::Identity(), blockTerrain(), kNominal,
                                                config, nullptr),
               std::invalid_argument);
  EXPECT_THROW(planning::adaptScheduleToTerrain({{1.0, {0.1, 0, 0}}}, lie::SE3::Identity(),
                                                blockTerrain(), kNominal, config, nullptr),
               std::invalid_argument);
}

/// The approach timing, checked on the schedule it gives: Tachyon 3's feet in its trot groups
/// (LF, RF, MR at the period's start, MF, LR, RR half a period later), the gait clock from
/// the schedule's start.
planning::SpeedScheduleConfig timedConfig() {
  planning::SpeedScheduleConfig config;
  config.step_speed_limit = 0.29;
  config.max_acceleration = 0.5;
  config.gait_period = 1.44;
  config.touchdowns = {{0.0}, {0.72}, {0.0}, {0.72}, {0.0}, {0.72}};
  return config;
}

/// The first touch-down of any foot onto another level of `terrain`, on the integrated path:
/// how far past the riser at x = kEdgeUp it lands and the speed there.
struct Landing {
  bool found = false;
  double time = 0.0, past = 0.0, speed = 0.0;
};
/// Every foot's touch-down along the integrated path (the trot's two offsets each period),
/// in time order: visit(time, x, sample, foot, height, previous height) returns false to stop.
template <class Visit>
void forEachTouchdown(const std::vector<PathSample>& path, const planning::TerrainModel& terrain,
                      const planning::SpeedScheduleConfig& config, Visit&& visit) {
  const double dt = path[1].t - path[0].t;
  const auto at = [&](double t) {
    return path[std::min(static_cast<std::size_t>(std::lround(t / dt)), path.size() - 1)];
  };
  std::vector<double> last_height(kNominal.size(), 0.0);
  for (double base = 0.0; base < path.back().t - config.gait_period; base += config.gait_period) {
    for (const double offset : {0.0, 0.72}) {
      const double t = base + offset;
      for (std::size_t f = 0; f < kNominal.size(); ++f) {
        if (config.touchdowns[f].front() != offset) continue;
        const PathSample s = at(t);
        const double x = s.x + kNominal[f].x();
        const double h = terrain.heightAt(Vector2d(x, s.y + kNominal[f].y()));
        const double previous = last_height[f];
        last_height[f] = h;
        if (!visit(t, x, s, f, h, previous)) return;
      }
    }
  }
}

Landing firstLanding(const std::vector<PathSample>& path, const planning::TerrainModel& terrain,
                     const planning::SpeedScheduleConfig& config) {
  Landing out;
  forEachTouchdown(
      path, terrain, config,
      [&](double t, double x, const PathSample& s, std::size_t, double h, double previous) {
        if (std::abs(h - previous) <= config.min_step) return true;
        out = {true, t, x - kEdgeUp, s.speed};
        return false;
      });
  return out;
}

/// The delay of every edge the timing delayed.
double totalDelay(const planning::ApproachTiming& approach) {
  double d = 0.0;
  for (const planning::EdgeTiming& e : approach.edges) d += e.delay;
  return d;
}

/// Each row of feet (front: body x > 0, hind) meeting each of the block's edges, on the
/// integrated path: its first touch-down past the edge, how far past and the speed there.
struct RowLanding {
  bool front = false, up = false;
  double time = 0.0, past = 0.0, speed = 0.0;
};
std::vector<RowLanding> rowLandings(const std::vector<PathSample>& path,
                                    const planning::TerrainModel& terrain,
                                    const planning::SpeedScheduleConfig& config, double edge_down) {
  std::vector<RowLanding> out;
  forEachTouchdown(
      path, terrain, config,
      [&](double t, double x, const PathSample& s, std::size_t f, double h, double previous) {
        if (std::abs(h - previous) <= config.min_step) return true;
        const bool up = h > previous;
        const bool front = kNominal[f].x() > 0.0;
        const bool seen = std::any_of(out.begin(), out.end(), [&](const RowLanding& l) {
          return l.front == front && l.up == up;
        });
        if (!seen) out.push_back({front, up, t, x - (up ? kEdgeUp : edge_down), s.speed});
        return true;
      });
  return out;
}

TEST(ApproachTiming, LandsEveryRowOnEveryEdgeClearOfTheRiserAndAtMostAQuarterPeriodPastIt) {
  // Block lengths that bring the later edges anywhere in the gait's cycle.
  const planning::SpeedScheduleConfig timed = timedConfig();
  planning::SpeedScheduleConfig untimed = timed;
  untimed.gait_period = 0.0;
  const double target = 0.25 * timed.gait_period * timed.step_speed_limit;
  int later = 0, later_off_untimed = 0, later_off_timed = 0;
  int edges = 0, near_untimed = 0, near_timed = 0;  // nearer the riser than half the target
  for (const double length : {1.0, 1.1, 1.2, 1.3, 1.45}) {
    const planning::TerrainModel terrain = planning::terrainFromBoxes(
        {-5.0, 10.0, -1.5, 1.5, 0.0}, 0.0, {{kEdgeUp, kEdgeUp + length, -1.5, 1.5, 0.20}}, 0.085);
    for (const double v : {0.3, 0.45}) {
      for (double x0 = -0.5; x0 <= 0.3 + 1e-9; x0 += 0.16) {
        const lie::SE3 start(Eigen::Vector3d(x0, 0.0, 0.0), Eigen::Quaterniond::Identity());
        planning::ApproachTiming approach;
        const auto schedule = planning::adaptScheduleToTerrain(
            {{0.0, {v, 0.0, 0.0}}}, start, terrain, kNominal, timed, nullptr, &approach);
        const auto plain = planning::adaptScheduleToTerrain({{0.0, {v, 0.0, 0.0}}}, start, terrain,
                                                            kNominal, untimed, nullptr, nullptr);
        // Four edges: each row up, each row down, in the order met.
        ASSERT_EQ(approach.edges.size(), 4u) << length << " " << v << " " << x0;
        const std::vector<RowLanding> landings =
            rowLandings(integrate(schedule, x0, 16.0), terrain, timed, kEdgeUp + length);
        const std::vector<RowLanding> plain_landings =
            rowLandings(integrate(plain, x0, 16.0), terrain, timed, kEdgeUp + length);
        ASSERT_EQ(landings.size(), 4u);
        ASSERT_EQ(plain_landings.size(), 4u);
        for (std::size_t k = 0; k < 4; ++k) {
          const RowLanding& l = landings[k];
          const planning::EdgeTiming& e = approach.edges[k];
          EXPECT_EQ(e.up, l.up) << k;
          EXPECT_GE(e.delay, 0.0);
          EXPECT_LT(e.delay, 0.5 * timed.gait_period);
          // What the timing says is what the path does.
          EXPECT_NEAR(l.past, e.after, 0.006) << length << " " << v << " " << x0 << " " << k;
          EXPECT_GE(l.past, -1e-9) << k;
          if (k == 0 || e.fits) {
            EXPECT_LE(l.past, 1.05 * target + 0.006)
                << "length " << length << " v " << v << " x0 " << x0 << " edge " << k;
            // Clear of the band beside the riser where no foothold lies.
            EXPECT_GE(l.past, 0.5 * target - 0.006)
                << "length " << length << " v " << v << " x0 " << x0 << " edge " << k;
          }
          ++edges;
          near_untimed += plain_landings[k].past < 0.5 * target - 0.006 ? 1 : 0;
          near_timed += l.past < 0.5 * target - 0.006 ? 1 : 0;
          if (k > 0) {
            ++later;
            later_off_untimed += plain_landings[k].past > 1.05 * target + 0.006 ? 1 : 0;
            later_off_timed += l.past > 1.05 * target + 0.006 ? 1 : 0;
          }
        }
      }
    }
  }
  // Without the timing many later edges land further; with it the dip fits nearly always.
  EXPECT_GT(later_off_untimed, later / 4);
  EXPECT_LE(later_off_timed, later / 10);
  // Untimed, some edges land in the band beside the riser; timed, only where no dip fits.
  EXPECT_GT(near_untimed, edges / 10);
  EXPECT_LE(near_timed, edges / 20);
  // The first edge only: one edge reported, and no dip after its touch-down.
  planning::SpeedScheduleConfig first_only = timed;
  first_only.time_every_edge = false;
  planning::ApproachTiming approach;
  const auto schedule =
      planning::adaptScheduleToTerrain({{0.0, {0.3, 0.0, 0.0}}}, lie::SE3::Identity(),
                                       blockTerrain(), kNominal, first_only, nullptr, &approach);
  ASSERT_EQ(approach.edges.size(), 1u);
  for (const planning::TimedBaseCommand& c : schedule) {
    // Over the block (4 s at the limit): the limit's speed, never a dip below it.
    if (c.time > approach.touchdown && c.time < approach.touchdown + 4.0) {
      EXPECT_GE(c.command.v_x, first_only.step_speed_limit - 1e-9) << c.time;
    }
  }
}

TEST(ApproachTiming, LandsTheFirstTouchdownOnTheStepAtMostAQuarterPeriodPastTheRiser) {
  const planning::TerrainModel terrain = blockTerrain();
  planning::SpeedScheduleConfig timed = timedConfig();
  timed.time_every_edge = false;  // the first edge only (no lower bound on the landing)
  planning::SpeedScheduleConfig untimed = timed;
  untimed.gait_period = 0.0;
  int off_target_untimed = 0, cases = 0;
  for (const double v : {0.3, 0.5}) {
    for (double x0 = -0.5; x0 <= 0.3 + 1e-9; x0 += 0.08) {
      const lie::SE3 start(Eigen::Vector3d(x0, 0.0, 0.0), Eigen::Quaterniond::Identity());
      planning::ApproachTiming approach;
      const auto schedule = planning::adaptScheduleToTerrain({{0.0, {v, 0.0, 0.0}}}, start, terrain,
                                                             kNominal, timed, nullptr, &approach);
      const auto plain = planning::adaptScheduleToTerrain({{0.0, {v, 0.0, 0.0}}}, start, terrain,
                                                          kNominal, untimed, nullptr, nullptr);
      ++cases;
      ASSERT_TRUE(approach.timed) << v << " " << x0;
      // At the step the speed is the limit's: the target is its quarter period's travel.
      const double target = 0.25 * timed.gait_period * timed.step_speed_limit;
      EXPECT_NEAR(approach.target, target, 1e-9);
      const Landing landing = firstLanding(integrate(schedule, x0, 12.0), terrain, timed);
      ASSERT_TRUE(landing.found) << v << " " << x0;
      EXPECT_GE(landing.past, 0.0) << "v " << v << " x0 " << x0;
      EXPECT_LE(landing.past, 1.05 * target + 0.005) << "v " << v << " x0 " << x0;
      EXPECT_NEAR(landing.past, approach.after, 0.005) << "v " << v << " x0 " << x0;
      // The least delay: under half a period, none when the plain schedule lands near enough.
      EXPECT_GE(approach.delay, 0.0);
      EXPECT_LT(approach.delay, 0.5 * timed.gait_period);
      const Landing before = firstLanding(integrate(plain, x0, 12.0), terrain, timed);
      ASSERT_TRUE(before.found);
      EXPECT_NEAR(before.past, approach.before, 0.005) << "v " << v << " x0 " << x0;
      const bool near_enough = before.past <= 1.05 * target;
      if (near_enough) {
        EXPECT_EQ(approach.delay, 0.0) << "v " << v << " x0 " << x0;
      }
      off_target_untimed += near_enough ? 0 : 1;
      // The same path, later: the timed schedule reaches each point of the plain one no
      // sooner, and by at most the delay.
      const auto a = integrate(plain, x0, 12.0), b = integrate(schedule, x0, 12.0);
      for (std::size_t i = 0, j = 0; i < a.size(); i += 20) {
        while (j < b.size() && b[j].x < a[i].x - 1e-9) ++j;
        if (j == b.size()) break;
        EXPECT_GE(b[j].t, a[i].t - 0.01) << i;
        EXPECT_LE(b[j].t, a[i].t + totalDelay(approach) + 0.01) << i;
      }
      // The dip never asks for a reverse, nor for much more than twice the acceleration limit:
      // its ramps keep to the limit, on top of the ramp from rest, resampled on the dip's
      // steps (an old 0.02 s step can fall into a shorter new one).
      for (std::size_t k = 1; k < schedule.size(); ++k) {
        const double dv = std::abs(schedule[k].command.v_x - schedule[k - 1].command.v_x);
        EXPECT_LE(dv,
                  2.5 * timed.max_acceleration * (schedule[k].time - schedule[k - 1].time) + 1e-9)
            << k;
        EXPECT_GE(schedule[k].command.v_x, 0.0);
      }
    }
  }
  // Without the timing many start positions land further: the test means something.
  EXPECT_GT(off_target_untimed, cases / 4);
}

TEST(ApproachTiming, LeavesLevelGroundAloneAndRefusesBadTouchdowns) {
  const planning::TerrainModel flat =
      planning::terrainFromBoxes({-5.0, 50.0, -1.5, 1.5, 0.0}, 0.0, {}, 0.085);
  planning::SpeedScheduleConfig config = timedConfig();
  planning::ApproachTiming approach;
  const auto timed = planning::adaptScheduleToTerrain(
      {{0.0, {0.45, 0.0, 0.0}}}, lie::SE3::Identity(), flat, kNominal, config, nullptr, &approach);
  EXPECT_FALSE(approach.timed);
  config.gait_period = 0.0;
  const auto plain = planning::adaptScheduleToTerrain(
      {{0.0, {0.45, 0.0, 0.0}}}, lie::SE3::Identity(), flat, kNominal, config, nullptr);
  ASSERT_EQ(timed.size(), plain.size());
  for (std::size_t k = 0; k < plain.size(); ++k) {
    EXPECT_EQ(timed[k].time, plain[k].time);
    EXPECT_EQ(timed[k].command.v_x, plain[k].command.v_x);
  }
  config = timedConfig();
  config.touchdowns[2] = {1.5};  // beyond the period
  EXPECT_THROW(planning::adaptScheduleToTerrain({{0.0, {0.45, 0, 0}}}, lie::SE3::Identity(),
                                                blockTerrain(), kNominal, config, nullptr),
               std::invalid_argument);
  config = timedConfig();
  config.touchdowns.pop_back();  // one list short
  EXPECT_THROW(planning::adaptScheduleToTerrain({{0.0, {0.45, 0, 0}}}, lie::SE3::Identity(),
                                                blockTerrain(), kNominal, config, nullptr),
               std::invalid_argument);
}

}  // namespace
