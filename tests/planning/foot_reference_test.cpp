// The per-node foot query: a paper trot at 0.5 m/s over the step20 block. Stance feet
// get the region under the nominal foothold of their touch-down; swings crossing the front edge
// ascend (constrained by the floor region on their first half), swings crossing the back edge
// descend (floor region on their second half); z_ref / z_dot_ref follow the spline.
#include "rollstep/planning/foot_reference.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/alloc_counter.hpp"
#include "rollstep/planning/gait.hpp"

namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;
using namespace rollstep;
using planning::SwingDirection;

// The test plays the robot: contact order, nominal feet, heights (robot/tachyon3.md).
const std::vector<std::string> kFeet{"LF", "MF", "RF", "LR", "MR", "RR"};
const std::vector<Vector2d> kNominal{{0.33, 0.22},  {0.33, 0.0},  {0.33, -0.22},
                                     {-0.33, 0.22}, {-0.33, 0.0}, {-0.33, -0.22}};
constexpr double kWheelRadius = 0.075, kClearance = 0.08;

struct Scene {
  planning::TerrainModel terrain =
      planning::terrainFromBoxes({-5.0, 10.0, -1.5, 1.5, 0.0}, 0.0, {{1.0, 2.2, -1.5, 1.5, 0.20}});
  planning::BaseReference base{terrain, {0.375, kNominal}};
  planning::FootReferencePlanner feet{terrain, base, {kNominal, kClearance, kWheelRadius}};
  planning::GaitScheduler scheduler{
      planning::Gait::trot(6, 0.8, 0.6, planning::contactMask(kFeet, {"LF", "RF", "MR"}),
                           planning::contactMask(kFeet, {"MF", "LR", "RR"})),
      1.5};
  ocp::ModeSchedule schedule{scheduler.requiredCapacity()};
  Scene() { base.reset(0.0, lie::SE3(), {0.5, 0.0, 0.0}); }
};

/// Start of the stance of `foot` containing (or, for a swing, ending just before) t, from
/// the gait itself: searched back, then bisected.
double stanceStart(const Scene& s, int foot, double t) {
  const planning::Gait& g = s.scheduler.gait();
  double hi = t;
  while (!g.inStance(foot, hi)) hi -= 1e-3;  // a swing: back into the stance before it
  double lo = hi;
  while (g.inStance(foot, lo)) lo -= 1e-3;
  for (int k = 0; k < 60; ++k) {
    const double mid = 0.5 * (lo + hi);
    (g.inStance(foot, mid) ? hi : lo) = mid;
  }
  return hi;
}

/// step20's block with regions shrunk by 0.085 m (a gap [0.915, 1.085] before the block),
/// a base reference at 0.5 m/s and a 0.8 s trot over 3 s.
struct ShrunkStepScene {
  planning::TerrainModel terrain = planning::terrainFromBoxes({-5.0, 10.0, -1.5, 1.5, 0.0}, 0.0,
                                                              {{1.0, 2.2, -1.5, 1.5, 0.20}}, 0.085);
  planning::BaseReference base{terrain, {0.375, kNominal}};
  planning::GaitScheduler scheduler{
      planning::Gait::trot(6, 0.8, 0.6, planning::contactMask(kFeet, {"LF", "RF", "MR"}),
                           planning::contactMask(kFeet, {"MF", "LR", "RR"})),
      3.0};
  ocp::ModeSchedule schedule{scheduler.requiredCapacity()};
  int floor = -1, block = -1;
  ShrunkStepScene() {
    base.reset(0.0, lie::SE3(), planning::BaseVelocityCommand{0.5, 0.0, 0.0});
    scheduler.fill(0.0, 3.0, schedule);
    floor = terrain.regionAt({0.5, 0.0});
    block = terrain.regionAt({1.5, 0.0});
  }
};

TEST(FootReference, GapReachSendsAFootholdInAGapOntoTheRegionAhead) {
  // Regions shrunk by 0.085 m: a gap [0.915, 1.085] before the block. A touch-down whose
  // nominal foothold falls 1 cm into the gap goes onto the block (ascending, its spline ends
  // on the top) with gap_reach 0.2, onto the floor (level) with the nearest rule.
  const ShrunkStepScene sc;
  const ocp::ModeSchedule& schedule = sc.schedule;
  const int floor = sc.floor, block = sc.block;
  planning::FootReferenceConfig near{kNominal, kClearance, kWheelRadius};
  planning::FootReferenceConfig ahead = near;
  ahead.gap_reach = 0.2;
  const planning::FootReferencePlanner nearest(sc.terrain, sc.base, near),
      forward(sc.terrain, sc.base, ahead);
  int crossings = 0;
  for (double t = 0.0; t < 2.5; t += 0.005) {
    for (int f : {0, 1, 2}) {  // front feet
      const planning::FootReference a = nearest.query(schedule, f, t);
      const planning::FootReference b = forward.query(schedule, f, t);
      if (a.timing.stance || !a.timing.bounded()) continue;
      const double x_td = nearest.nominalFoothold(f, a.timing.touchdown).x();
      if (x_td > 0.915 && x_td < 1.0) {  // nearest: the floor; ahead: the block
        ++crossings;
        EXPECT_EQ(a.region, floor);
        EXPECT_EQ(a.direction, SwingDirection::Level);
        EXPECT_EQ(b.region, block);
        EXPECT_EQ(b.direction, SwingDirection::Ascending);
        EXPECT_EQ(b.swing_region, floor);  // the first half stays over the floor
      } else {
        EXPECT_EQ(a.region, b.region) << "t " << t << " foot " << f;
      }
    }
  }
  EXPECT_GT(crossings, 0) << "no touch-down fell into the gap";
}

// A robot lagging its base reference lands short of the nominal foothold. A stance whose
// nominal foothold lies in the gap before the block belongs to the block (gap_reach), so the
// swing after it would be planned level at the block's height; anchored where the foot
// actually stands (on the floor, 3.5 cm short of the gap), the stance is on the floor and
// the swing after it climbs onto the block from the floor.
TEST(FootReference, AnchoredStanceUsesTheSurfaceTheFootStandsOn) {
  const ShrunkStepScene sc;
  const ocp::ModeSchedule& schedule = sc.schedule;
  const int floor = sc.floor, block = sc.block;
  planning::FootReferenceConfig config{kNominal, kClearance, kWheelRadius};
  config.gap_reach = 0.2;
  planning::FootReferencePlanner planner(sc.terrain, sc.base, config);
  int checked = 0;
  for (int f : {0, 1, 2}) {  // front feet: find a stance whose nominal foothold is in the gap
    for (double t = 0.0; t < 2.0; t += 0.005) {
      const planning::FootReference nominal = planner.query(schedule, f, t);
      if (!nominal.timing.stance) continue;
      const double start = planning::FootReferencePlanner::stanceStartAt(schedule, f, t);
      ASSERT_FALSE(std::isnan(start));
      EXPECT_NEAR(start, stanceStart(Scene{}, f, t), 1e-6);
      const Vector2d p_nominal = planner.stanceFoothold(schedule, f, t);
      if (!(p_nominal.x() > 0.915 && p_nominal.x() < 1.0)) continue;
      ASSERT_EQ(nominal.region, block);
      // The swing after this stance, nominally level on the block.
      double t_swing = t;
      while (planner.query(schedule, f, t_swing).timing.stance) t_swing += 0.005;
      t_swing += 0.01;
      const planning::FootReference swing_nominal = planner.query(schedule, f, t_swing);
      ASSERT_FALSE(swing_nominal.timing.stance);
      EXPECT_EQ(swing_nominal.direction, SwingDirection::Level);

      const Vector2d stands(0.88, p_nominal.y());
      planner.anchorStance(f, start, stands);
      const planning::FootReference anchored = planner.query(schedule, f, t);
      EXPECT_EQ(anchored.region, floor);
      EXPECT_NEAR(anchored.z_ref, kWheelRadius, 1e-12);
      EXPECT_EQ(planner.stanceFoothold(schedule, f, t), stands);
      const planning::FootReference swing = planner.query(schedule, f, t_swing);
      EXPECT_EQ(swing.direction, SwingDirection::Ascending);
      EXPECT_EQ(swing.swing_region, floor);
      EXPECT_EQ(swing.region, block);
      // An anchor of another stance, or none, leaves the footholds nominal.
      planner.anchorStance(f, start - 0.8, stands);
      EXPECT_EQ(planner.query(schedule, f, t).region, block);
      planner.anchorStance(f, start, stands);
      planner.clearAnchors();
      EXPECT_EQ(planner.query(schedule, f, t_swing).direction, SwingDirection::Level);
      planner.anchorStance(f, start, Vector2d(std::nan(""), 0.0));  // refused: nominal
      EXPECT_EQ(planner.query(schedule, f, t).region, block);
      ++checked;
      break;
    }
  }
  EXPECT_GT(checked, 0) << "no stance's nominal foothold fell into the gap";
  // A foot in swing has no stance start.
  for (double t = 0.0; t < 1.0; t += 0.01) {
    if (!planner.query(schedule, 0, t).timing.stance) {
      EXPECT_TRUE(std::isnan(planning::FootReferencePlanner::stanceStartAt(schedule, 0, t)));
    }
  }
}

TEST(FootReference, ALatchedTouchDownKeepsItsRegionWhenTheTerrainMoves) {
  // A front swing whose nominal touch-down falls into the gap before the block goes up onto
  // it (gap_reach 0.2). Then the perceived block "moves" 0.2 m away: the nominal choice
  // becomes level onto the floor, mid-swing; latched, the swing still goes up onto the
  // block, and the stance it begins stands there.
  ShrunkStepScene sc;
  const ocp::ModeSchedule& schedule = sc.schedule;
  planning::FootReferenceConfig config{kNominal, kClearance, kWheelRadius};
  config.gap_reach = 0.2;
  planning::FootReferencePlanner planner(sc.terrain, sc.base, config);
  planning::TerrainModel moved = planning::terrainFromBoxes({-5.0, 10.0, -1.5, 1.5, 0.0}, 0.0,
                                                            {{1.2, 2.4, -1.5, 1.5, 0.20}}, 0.085);
  int checked = 0;
  for (int f : {0, 1, 2}) {
    for (double t = 0.0; t < 2.5 && checked <= f; t += 0.005) {
      const planning::FootReference r = planner.query(schedule, f, t);
      if (r.timing.stance || !r.timing.bounded() || r.timing.phase > 0.3) continue;
      const double x_td = planner.nominalFoothold(f, r.timing.touchdown).x();
      if (!(x_td > 0.915 && x_td < 1.0)) continue;
      ASSERT_EQ(r.direction, SwingDirection::Ascending);
      const double t_stance = r.timing.touchdown + 0.05;  // in the stance it begins
      planner.latchTouchdown(f, r.timing.touchdown);
      sc.terrain.swap(moved);  // the block now begins at 1.285 (shrunk): out of reach
      const int floor = sc.terrain.regionAt({0.5, 0.0}), block = sc.terrain.regionAt({1.5, 0.0});
      const planning::FootReference latched = planner.query(schedule, f, t);
      EXPECT_EQ(latched.direction, SwingDirection::Ascending);
      EXPECT_EQ(latched.region, block);
      const planning::FootReference stance = planner.query(schedule, f, t_stance);
      ASSERT_TRUE(stance.timing.stance);
      EXPECT_EQ(stance.region, block);
      EXPECT_NEAR(stance.z_ref, 0.20 + kWheelRadius, 1e-9);
      // The latch point lies in the region chosen (the nominal foothold moved into it), which
      // now begins 0.2 m further on (to rounding).
      EXPECT_TRUE(sc.terrain.region(block).contains(planner.stanceFoothold(schedule, f, t_stance),
                                                    0.2 + 1e-9));
      // Latching the same touch-down again keeps the first choice.
      planner.latchTouchdown(f, r.timing.touchdown);
      EXPECT_EQ(planner.query(schedule, f, t).region, block);
      // Without the latch the same query is level onto the floor.
      planner.clearAnchors();
      const planning::FootReference nominal = planner.query(schedule, f, t);
      EXPECT_EQ(nominal.direction, SwingDirection::Level);
      EXPECT_EQ(nominal.region, floor);
      // Latched now, on this terrain: the floor; a NaN time clears it.
      planner.latchTouchdown(f, r.timing.touchdown);
      EXPECT_EQ(planner.query(schedule, f, t).region, floor);
      planner.latchTouchdown(f, std::nan(""));
      sc.terrain.swap(moved);  // back to the scene's terrain
      EXPECT_EQ(planner.query(schedule, f, t).direction, SwingDirection::Ascending);
      ++checked;
    }
  }
  EXPECT_GT(checked, 0) << "no front swing's touch-down fell into the gap";
}

TEST(FootReference, TrotOverTheStep) {
  Scene s;
  const int floor_before = s.terrain.regionAt({0.0, 0.0});
  const int floor_after = s.terrain.regionAt({3.0, 0.0});
  std::vector<int> ascending(6, 0), descending(6, 0);
  const double dt = 0.005;
  for (double t0 = 0.0; t0 < 7.0; t0 += 1.5) {
    s.scheduler.fill(t0, 1.5, s.schedule);
    for (double t = t0; t < t0 + 1.5; t += dt) {
      for (int f = 0; f < 6; ++f) {
        const planning::FootReference r = s.feet.query(s.schedule, f, t);
        EXPECT_EQ(r.timing.stance, s.scheduler.gait().inStance(f, t));
        // A stance keeps the foothold of its touch-down (the wheel cannot roll up a step).
        const Vector2d p = s.feet.nominalFoothold(f, stanceStart(s, f, t));
        if (r.timing.stance) {
          EXPECT_EQ(r.region, s.terrain.regionAt(p));
          EXPECT_DOUBLE_EQ(r.z_ref, s.terrain.heightAt(p) + kWheelRadius);
          EXPECT_EQ(r.z_dot_ref, 0.0);
          continue;
        }
        ASSERT_TRUE(r.timing.bounded());
        EXPECT_NEAR(r.timing.touchdown - r.timing.liftoff, 0.32, 1e-9);
        const Vector2d p_lo = s.feet.nominalFoothold(f, stanceStart(s, f, r.timing.liftoff - 1e-9));
        const Vector2d p_td = s.feet.nominalFoothold(f, r.timing.touchdown);
        const double z_lo = s.terrain.heightAt(p_lo), z_td = s.terrain.heightAt(p_td);
        EXPECT_LE(r.z_ref, std::max(z_lo, z_td) + kWheelRadius + kClearance + 1e-12);
        EXPECT_GE(r.z_ref, std::min(z_lo, z_td) + kWheelRadius - 1e-12);
        // z_dot_ref is the rate of z_ref (same swing, away from its ends).
        if (r.timing.phase > 0.05 && r.timing.phase < 0.95) {
          const double e = 1e-7;  // small: z'' jumps at the apex
          const double zp = s.feet.query(s.schedule, f, t + e).z_ref;
          const double zm = s.feet.query(s.schedule, f, t - e).z_ref;
          EXPECT_NEAR(r.z_dot_ref, (zp - zm) / (2 * e), 1e-5);
        }
        if (p_lo.x() < 1.0 && p_td.x() > 1.0) {
          ++ascending[static_cast<std::size_t>(f)];
          EXPECT_EQ(r.direction, SwingDirection::Ascending);
          EXPECT_EQ(r.swing_region, floor_before);
          EXPECT_EQ(r.swing_region_active, r.timing.phase <= 0.5);
          EXPECT_EQ(r.region, s.terrain.regionAt({1.6, 0.0}));  // lands on the block
        } else if (p_lo.x() < 2.2 && p_td.x() > 2.2) {
          ++descending[static_cast<std::size_t>(f)];
          EXPECT_EQ(r.direction, SwingDirection::Descending);
          EXPECT_EQ(r.swing_region, floor_after);
          EXPECT_EQ(r.swing_region_active, r.timing.phase >= 0.5);
          EXPECT_EQ(r.region, floor_after);
        } else {
          EXPECT_EQ(r.direction, SwingDirection::Level);
          EXPECT_EQ(r.swing_region, -1);
          EXPECT_FALSE(r.swing_region_active);
        }
      }
    }
  }
  // Some swings crossed each edge.
  int up = 0, down = 0;
  for (int f = 0; f < 6; ++f) {
    up += ascending[static_cast<std::size_t>(f)];
    down += descending[static_cast<std::size_t>(f)];
  }
  EXPECT_GT(up, 20);
  EXPECT_GT(down, 20);
}

TEST(FootReference, SwingEndsAndApex) {
  Scene s;
  s.scheduler.fill(0.0, 1.5, s.schedule);
  // LF swings on [0.48, 0.8) over flat floor: ends at ground + wheel radius, apex above.
  const planning::FootReference lo = s.feet.query(s.schedule, 0, 0.48 + 1e-9);
  const planning::FootReference mid = s.feet.query(s.schedule, 0, 0.64);
  EXPECT_NEAR(lo.z_ref, kWheelRadius, 1e-6);
  EXPECT_NEAR(mid.z_ref, kWheelRadius + kClearance, 1e-12);
  EXPECT_NEAR(mid.timing.phase, 0.5, 1e-12);
  const planning::SwingHeightSpline sp = s.feet.swingSpline(0, 0.48, 0.8);
  EXPECT_NEAR(sp.position(0.7), s.feet.query(s.schedule, 0, 0.7).z_ref, 1e-12);
}

// Late touch-down: LF's stance due at 0.8 s begins at 0.9 s instead (delayTouchdown), the
// swing descending from where the foot is (0.08 m up at 0.82 s) to the surface; the stance
// that begins at the landing keeps the foothold of the one it replaces, and so does the
// lift-off end of the swing after it. Nothing else in the schedule moves.
TEST(FootReference, ALateTouchDownDescendsAndKeepsTheStanceFoothold) {
  Scene s;
  ocp::ModeSchedule due(s.scheduler.requiredCapacity() + 6);
  s.scheduler.fill(0.0, 1.5, due);
  ocp::ModeSchedule late = due;
  const double T = 0.8, from = 0.82, landing = 0.9;
  {
    test::AllocationGuard guard;
    ASSERT_TRUE(planning::delayTouchdown(late, 0, T, landing));
    EXPECT_EQ(guard.count(), 0u);
  }
  EXPECT_EQ(late.switches(), due.switches() + 1);
  // LF is in swing until the landing, the other feet as before.
  const planning::FootPhase phase = planning::footPhase(late, 0, 0.85);
  EXPECT_FALSE(phase.stance);
  EXPECT_DOUBLE_EQ(phase.liftoff, 0.48);
  EXPECT_DOUBLE_EQ(phase.touchdown, landing);
  EXPECT_TRUE(planning::footPhase(late, 0, landing).stance);
  for (double t = 0.0; t < 2.5; t += 0.01) {
    for (int f = 1; f < 6; ++f) {
      EXPECT_EQ(planning::footPhase(late, f, t).stance, planning::footPhase(due, f, t).stance);
    }
    if (t < T - 1e-9 || t >= landing) {
      EXPECT_EQ(late.modeAt(t), due.modeAt(t)) << t;
    }
  }
  // Refused, changing nothing: a landing past the stance's end (the next lift-off at 1.28),
  // a time that does not begin a stance of this foot, a landing before the touch-down.
  ocp::ModeSchedule copy = due;
  EXPECT_FALSE(planning::delayTouchdown(copy, 0, T, 1.3));
  EXPECT_FALSE(planning::delayTouchdown(copy, 0, 0.75, 0.85));
  EXPECT_FALSE(planning::delayTouchdown(copy, 1, T, 0.85));  // MF already stands before 0.8
  EXPECT_FALSE(planning::delayTouchdown(copy, 0, T, T));
  EXPECT_EQ(copy.modes(), due.modes());
  EXPECT_EQ(copy.switchingTimes(), due.switchingTimes());

  const planning::FootReference stance_due = s.feet.query(due, 0, 0.95);
  const Vector2d foothold_due = s.feet.stanceFoothold(due, 0, 0.95);
  const double z_from = stance_due.z_ref + 0.08;
  s.feet.setLanding(0, T, from, z_from, landing, stance_due.z_ref);
  // The descent: from z_from at rest to the surface at rest, smooth in between.
  const planning::FootReference start = s.feet.query(late, 0, from);
  EXPECT_FALSE(start.timing.stance);
  EXPECT_DOUBLE_EQ(start.z_ref, z_from);
  EXPECT_DOUBLE_EQ(start.z_dot_ref, 0.0);
  EXPECT_EQ(start.region, stance_due.region);
  EXPECT_NEAR(s.feet.query(late, 0, landing - 1e-9).z_ref, stance_due.z_ref, 1e-9);
  for (double t = from + 0.005; t < landing - 0.005; t += 0.01) {
    const planning::FootReference r = s.feet.query(late, 0, t);
    const double h = 1e-6;
    const double fd =
        (s.feet.query(late, 0, t + h).z_ref - s.feet.query(late, 0, t - h).z_ref) / (2.0 * h);
    EXPECT_NEAR(r.z_dot_ref, fd, 1e-6);
    EXPECT_LT(r.z_dot_ref, 0.0);
    EXPECT_LT(r.z_ref, z_from);
    EXPECT_GT(r.z_ref, stance_due.z_ref);
  }
  // The stance after the landing: the same foothold, region and height as the one due.
  const planning::FootReference stance_late = s.feet.query(late, 0, 0.95);
  EXPECT_TRUE(stance_late.timing.stance);
  EXPECT_EQ(stance_late.region, stance_due.region);
  EXPECT_DOUBLE_EQ(stance_late.z_ref, stance_due.z_ref);
  EXPECT_EQ(s.feet.stanceFoothold(late, 0, 0.95), foothold_due);
  // ... and the swing after it (lift-off 1.28) starts from there.
  EXPECT_DOUBLE_EQ(s.feet.query(late, 0, 1.35).z_ref, s.feet.query(due, 0, 1.35).z_ref);
  // Cleared: the swing to 0.9 is an ordinary (stretched) spline again.
  s.feet.clearLanding(0);
  EXPECT_GT(std::abs(s.feet.query(late, 0, from).z_ref - z_from), 1e-3);
}

TEST(FootReference, UnknownSwingEndsHoldTheApex) {
  Scene s;
  ocp::ModeSchedule ms(4);
  ms.set({1.0}, {62, 63});  // LF swinging before t = 1 with no known lift-off
  const planning::FootReference r = s.feet.query(ms, 0, 0.5);
  EXPECT_FALSE(r.timing.stance);
  EXPECT_FALSE(r.timing.bounded());
  EXPECT_DOUBLE_EQ(r.z_ref, kWheelRadius + kClearance);
  EXPECT_EQ(r.swing_region, -1);
}

TEST(FootReference, QueriesDoNotAllocate) {
  Scene s;
  s.scheduler.fill(1.2, 1.5, s.schedule);
  test::AllocationGuard guard;
  double sum = 0.0;
  for (int k = 0; k <= 100; ++k) {
    for (int f = 0; f < 6; ++f) sum += s.feet.query(s.schedule, f, 1.2 + 0.015 * k).z_ref;
  }
  // Anchors and touch-down latches, as the 1 kHz tick sets them.
  for (int f = 0; f < 6; ++f) {
    const planning::FootPhase phase = planning::footPhase(s.schedule, f, 1.5);
    if (phase.stance) {
      s.feet.anchorStance(f, planning::FootReferencePlanner::stanceStartAt(s.schedule, f, 1.5),
                          s.feet.nominalFoothold(f, 1.5));
    } else if (phase.bounded()) {
      s.feet.latchTouchdown(f, phase.touchdown);
    }
    sum += s.feet.query(s.schedule, f, 1.5).z_ref;
  }
  EXPECT_EQ(guard.count(), 0u);
  EXPECT_GT(sum, 0.0);
}

TEST(FootReference, BadConfigThrows) {
  Scene s;
  auto expectNaming = [](auto f, const std::string& what) {
    try {
      f();
      ADD_FAILURE() << "no exception, expected " << what;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  expectNaming(
      [&] {
        planning::FootReferencePlanner(s.terrain, s.base, {{}, 0.1, 0.0});
      },
      "nominal_feet.size() = 0");
  expectNaming(
      [&] {
        planning::FootReferencePlanner(
            s.terrain, s.base, {{Vector2d(std::numeric_limits<double>::quiet_NaN(), 0)}, 0.1, 0.0});
      },
      "nominal_feet[0].x = nan");
  expectNaming(
      [&] {
        planning::FootReferencePlanner(s.terrain, s.base, {kNominal, -0.1, 0.0});
      },
      "swing_clearance = -0.1");
}

}  // namespace
