// The gait's clock and its step-down holds: a 1.8 s trot at 0.15 m/s over step20's block
// (regions shrunk by 0.085 m, the gap rule across the gap), from many start positions.
#include "rollstep/planning/edge_holds.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "common/alloc_counter.hpp"
#include "rollstep/planning/contact_schedule.hpp"
#include "rollstep/planning/gait.hpp"

namespace {

using Eigen::Vector2d;
using namespace rollstep;

const std::vector<std::string> kFeet{"LF", "MF", "RF", "LR", "MR", "RR"};
const std::vector<Vector2d> kNominal{{0.33, 0.22},  {0.33, 0.0},  {0.33, -0.22},
                                     {-0.33, 0.22}, {-0.33, 0.0}, {-0.33, -0.22}};
constexpr double kPeriod = 1.8, kSpeed = 0.15, kHorizon = 1.5, kMargin = 0.085;
constexpr double kEdgeUp = 1.0, kEdgeDown = 2.2;  // the block's edges [m]

planning::Gait paperTrot() {
  return planning::Gait::trot(6, kPeriod, 0.6, planning::contactMask(kFeet, {"LF", "RF", "MR"}),
                              planning::contactMask(kFeet, {"MF", "LR", "RR"}));
}

planning::TerrainModel blockTerrain() {
  return planning::terrainFromBoxes({-5.0, 10.0, -1.5, 1.5, 0.0}, 0.0,
                                    {{kEdgeUp, kEdgeDown, -1.5, 1.5, 0.20}}, kMargin);
}

struct BlockScene {
  planning::TerrainModel terrain;
  planning::BaseReference base{terrain, {0.375, kNominal}};
  planning::FootReferencePlanner feet;
  planning::GaitScheduler scheduler;
  ocp::ModeSchedule schedule{scheduler.requiredCapacity()};
  planning::GaitClock clock;
  planning::EdgeHoldConfig config;

  /// The base starts at x0 with `speed` (negative: backwards); gap rule across the gap.
  explicit BlockScene(double x0, double speed = kSpeed, double max_hold = 0.9)
      : BlockScene(blockTerrain(), x0, speed, max_hold) {}
  /// The same on another terrain (and with another gait).
  BlockScene(planning::TerrainModel other, double x0, double speed, double max_hold,
             const planning::Gait& gait = paperTrot())
      : terrain(std::move(other)), feet(terrain, base, footConfig()), scheduler(gait, kHorizon) {
    base.reset(0.0, lie::SE3(Eigen::Vector3d(x0, 0.0, 0.0), Eigen::Quaterniond::Identity()),
               planning::BaseVelocityCommand{speed, 0.0, 0.0});
    config.max_down_hold = max_hold;
  }
  static planning::FootReferenceConfig footConfig() {
    planning::FootReferenceConfig c{kNominal, 0.08, 0.075};
    c.gap_reach = 0.2;
    return c;
  }
  /// Plays the MPC: plans at every 20 ms update up to t_end, and keeps every hold once it
  /// can no longer change (begun before t0 + lead), which the clock forgets a while later.
  void run(double t_end) {
    for (; t <= t_end + 1e-9; t += 0.02) {
      planning::planEdgeHolds(scheduler.gait(), feet, config, t, kHorizon, clock);
      last = t;
      for (int i = 0; i < clock.size(); ++i) {
        const planning::GaitClock::Hold& h = clock.hold(i);
        if (h.start > t + config.lead) break;
        if (!held.empty() && held.back().start == h.start) {
          held.back() = h;  // extended
        } else if (held.empty() || h.start > held.back().start) {
          held.push_back(h);
        }
      }
    }
  }
  /// The clock of the whole run so far (every hold begun).
  planning::GaitClock history() const {
    planning::GaitClock c;
    for (const planning::GaitClock::Hold& h : held) EXPECT_TRUE(c.addHold(h.start, h.duration));
    return c;
  }
  double t = 0.0, last = 0.0;  // the next and the last planning time
  std::vector<planning::GaitClock::Hold> held;
};

struct Swing {
  int foot;
  double liftoff, touchdown;
};

/// Every swing of the gait read through `clock` that lifts off in [t_begin, t_end].
std::vector<Swing> swings(const planning::Gait& gait, const planning::GaitClock& clock,
                          double t_begin, double t_end) {
  std::vector<Swing> out;
  const double dt = 1e-3;
  for (int foot = 0; foot < 6; ++foot) {
    double liftoff = std::numeric_limits<double>::quiet_NaN();
    bool was = gait.inStance(foot, clock.gaitTime(t_begin));
    for (double t = t_begin + dt; t <= t_end + kPeriod; t += dt) {
      const bool now = gait.inStance(foot, clock.gaitTime(t));
      if (was && !now) liftoff = t;
      if (!was && now && std::isfinite(liftoff) && liftoff <= t_end) {
        out.push_back({foot, liftoff, t});
      }
      was = now;
    }
  }
  return out;
}

/// Every hold of `clock` at most `max_hold` long and inside an all-stance phase.
void expectHoldsInAllStance(const planning::Gait& gait, const planning::GaitClock& clock,
                            double max_hold) {
  for (int i = 0; i < clock.size(); ++i) {
    const planning::GaitClock::Hold& h = clock.hold(i);
    EXPECT_LE(h.duration, max_hold + 1e-12);
    for (double t = h.start; t <= h.end(); t += 0.01) {
      EXPECT_EQ(gait.modeAt(clock.gaitTime(t)), planning::allFeetMask(6));
    }
  }
}

/// One scene played with its holds off or on: how many touch-downs landed where the holds
/// are there to prevent, and how many holds it had.
struct HoldRun {
  int bad = 0, holds = 0;
};

/// Over start positions that put the gait at every phase of the block's edges (x0 in
/// [-0.3, 0) m): `play(x0, on)` runs a scene with its holds off or on. With them on no
/// touch-down lands where they are there to prevent and some runs hold; without, some land
/// there (the test can fail).
template <class Play>
void expectHoldsPrevent(Play play) {
  int bad_without = 0, held_runs = 0;
  for (double x0 = -0.3; x0 < 0.0; x0 += 0.02) {
    bad_without += play(x0, false).bad;
    const HoldRun on = play(x0, true);
    EXPECT_EQ(on.bad, 0) << "x0 " << x0;
    if (on.holds > 0) ++held_runs;
  }
  EXPECT_GT(bad_without, 0);
  EXPECT_GT(held_runs, 0);
}

TEST(GaitClock, HoldsStopTheGaitTime) {
  planning::GaitClock c;
  EXPECT_DOUBLE_EQ(c.gaitTime(3.7), 3.7);
  EXPECT_DOUBLE_EQ(c.loopTime(3.7), 3.7);
  ASSERT_TRUE(c.addHold(1.0, 0.5));
  ASSERT_TRUE(c.addHold(2.0, 0.25));
  EXPECT_DOUBLE_EQ(c.gaitTime(0.9), 0.9);
  EXPECT_DOUBLE_EQ(c.gaitTime(1.2), 1.0);  // held
  EXPECT_DOUBLE_EQ(c.gaitTime(1.5), 1.0);  // the hold's end
  EXPECT_DOUBLE_EQ(c.gaitTime(1.75), 1.25);
  EXPECT_DOUBLE_EQ(c.gaitTime(2.1), 1.5);  // in the second hold
  EXPECT_DOUBLE_EQ(c.gaitTime(3.0), 2.25);
  EXPECT_DOUBLE_EQ(c.totalHeld(), 0.75);
  // loopTime: the earliest loop time of a gait time; inverse of gaitTime outside holds.
  EXPECT_DOUBLE_EQ(c.loopTime(1.0), 1.0);
  EXPECT_DOUBLE_EQ(c.loopTime(1.25), 1.75);
  EXPECT_DOUBLE_EQ(c.loopTime(1.5), 2.0);
  for (double t = 0.0; t < 4.0; t += 0.01) {
    const bool held = (t > 1.0 && t < 1.5) || (t > 2.0 && t < 2.25);
    if (!held) {
      EXPECT_NEAR(c.loopTime(c.gaitTime(t)), t, 1e-12) << t;
    }
  }
}

TEST(GaitClock, AddDropAndForget) {
  planning::GaitClock c;
  ASSERT_TRUE(c.addHold(1.0, 0.5));
  EXPECT_FALSE(c.addHold(1.2, 0.1));  // inside the last hold
  EXPECT_FALSE(c.addHold(2.0, -0.1));
  EXPECT_FALSE(c.addHold(std::numeric_limits<double>::quiet_NaN(), 0.1));
  ASSERT_TRUE(c.addHold(1.5, 0.25));  // at its end: extends it
  EXPECT_EQ(c.size(), 1);
  EXPECT_DOUBLE_EQ(c.hold(0).duration, 0.75);
  ASSERT_TRUE(c.addHold(3.0, 0.5));
  ASSERT_TRUE(c.addHold(5.0, 0.5));
  c.dropHoldsAfter(3.0);  // a hold beginning at 3.0 stays
  EXPECT_EQ(c.size(), 2);
  const double tau_late = c.gaitTime(4.2), t_back = c.loopTime(3.2);
  c.forgetBefore(3.6);  // the first ends at 1.75, the second at 3.5
  EXPECT_EQ(c.size(), 0);
  EXPECT_DOUBLE_EQ(c.gaitTime(4.2), tau_late);
  EXPECT_DOUBLE_EQ(c.loopTime(3.2), t_back);
  EXPECT_DOUBLE_EQ(c.totalHeld(), 1.25);
  for (int i = 0; i < planning::GaitClock::kMaxHolds; ++i) {
    ASSERT_TRUE(c.addHold(10.0 + i, 0.1));
  }
  EXPECT_FALSE(c.addHold(100.0, 0.1));  // full
  c.clear();
  EXPECT_DOUBLE_EQ(c.gaitTime(4.2), 4.2);
}

TEST(GaitScheduler, FillsThroughAClock) {
  const planning::Gait gait = paperTrot();
  planning::GaitScheduler scheduler(gait, kHorizon);
  ocp::ModeSchedule plain(scheduler.requiredCapacity()), held(scheduler.requiredCapacity());
  planning::GaitClock none;
  scheduler.fill(3.3, kHorizon, plain);
  scheduler.fill(3.3, kHorizon, held, none);
  EXPECT_EQ(plain.switchingTimes(), held.switchingTimes());
  EXPECT_EQ(plain.modes(), held.modes());
  // A 0.4 s hold inside the all-stance phase after the switch at 3.6 (= 2 x 1.8 + 0):
  // switches before it stay, later ones move by 0.4; modes unchanged.
  planning::GaitClock clock;
  ASSERT_TRUE(clock.addHold(3.65, 0.4));
  scheduler.fill(3.3, kHorizon, held, clock);
  // The window is a span of gait time: the held one ends earlier in the gait.
  ASSERT_LE(held.modes().size(), plain.modes().size());
  ASSERT_GT(held.switchingTimes().back(), 3.3 + kHorizon + 0.4 * kPeriod);
  for (std::size_t i = 0; i < held.switchingTimes().size(); ++i) {
    const double t = plain.switchingTimes()[i];
    EXPECT_NEAR(held.switchingTimes()[i], t <= 3.65 ? t : t + 0.4, 1e-12) << i;
    EXPECT_EQ(held.modes()[i], plain.modes()[i]);
  }
  EXPECT_EQ(held.modeAt(3.8), planning::allFeetMask(6));  // in the hold: all in stance
}

/// The property the holds are for: no swing touches down on the block within what a hold
/// can wait for (speed x max_hold) before its far edge, and every hold lies in an
/// all-stance phase at most max_hold long, beyond the climb. Swings keep their length.
TEST(StepDownHolds, NoTouchDownOnTheBrinkOfTheDrop) {
  const double brink_begin = kEdgeDown - kMargin;  // the top region's far edge
  expectHoldsPrevent([&](double x0, bool on) {
    const double max_hold = on ? 0.9 : 0.0;
    BlockScene s(x0, kSpeed, max_hold);
    s.run(20.0);
    const planning::GaitClock clock = s.history();
    // Within what a 0.9 s hold could wait for, short of the edge (a held foothold goes
    // past it by the gap less the reach).
    const double zone = 0.9 * kSpeed - (2.0 * kMargin - s.config.reach);
    HoldRun r{0, clock.size()};
    for (const Swing& w : swings(s.scheduler.gait(), clock, 1.0, 18.0)) {
      const double to_edge = brink_begin - s.feet.nominalFoothold(w.foot, w.touchdown).x();
      if (to_edge >= 0.0 && to_edge < zone) ++r.bad;
      EXPECT_NEAR(w.touchdown - w.liftoff, 0.4 * kPeriod, 2e-3);
    }
    expectHoldsInAllStance(s.scheduler.gait(), clock, max_hold);
    for (int i = 0; i < clock.size(); ++i) {
      EXPECT_GT(s.base.worldPoint({-0.33, 0.0}, clock.hold(i).start).x(), kEdgeUp);
    }
    if (!on) {
      EXPECT_EQ(clock.size(), 0);
    }
    return r;
  });
}

/// A floor beyond the drop that perception has not seen up to the edge yet (hidden behind
/// it): its foothold region begins kHidden past the edge instead of kMargin, and a nominal
/// touch-down in the wide gap goes back onto the block (out of foothold_gap_reach). The
/// holds then wait until the foothold is within `reach` of the floor region (the foot steps
/// down there, not onto the brink or far ahead of its hip): no touch-down lands where a
/// hold could have fixed that.
TEST(StepDownHolds, FloorHiddenBeyondTheDrop) {
  constexpr double kHidden = 0.25, kW = 1.5 - kMargin;
  const auto rect = [&](double x0, double x1, double z) {
    return planning::ConvexRegion::fromPolygon({{x0, -kW}, {x1, -kW}, {x1, kW}, {x0, kW}}, z);
  };
  const double lower_start = kEdgeDown + kHidden;
  const planning::TerrainModel hidden(std::vector<planning::ConvexRegion>{
      rect(-5.0 + kMargin, kEdgeUp - kMargin, 0.0),
      rect(kEdgeUp + kMargin, kEdgeDown - kMargin, 0.2), rect(lower_start, 10.0 - kMargin, 0.0)});
  expectHoldsPrevent([&](double x0, bool on) {
    BlockScene s(hidden, x0, kSpeed, on ? 0.9 : 0.0);
    s.run(20.0);
    const planning::GaitClock clock = s.history();
    expectHoldsInAllStance(s.scheduler.gait(), clock, 0.9);
    const double target = lower_start - s.config.reach;  // a held foothold reaches this
    HoldRun r{0, clock.size()};
    for (const Swing& w : swings(s.scheduler.gait(), clock, 1.0, 18.0)) {
      const double x = s.feet.nominalFoothold(w.foot, w.touchdown).x();
      if (x > target - 0.9 * kSpeed + 1e-3 && x < target - 1e-3) ++r.bad;
    }
    return r;
  });
}

/// Before a step up (max_up_hold): no swing touches down on the floor short of the riser
/// by more than the setback and less than what a hold can wait for; it lands setback short
/// of the floor region's end instead (the next swing climbs).
/// A trot at the speed rule's timing for 0.267 m/s (stance = stroke / speed) over the
/// 1.2 m block, step-down and step-up holds as long as the rule allows: a hold before the
/// front feet's step down at the far end can come while the rear feet wait at the riser of
/// the step up, and it lengthens their stance. With the stroke check no stance foot stopped
/// at a riser is passed by the body further than the stroke (from the end of its region to
/// its lift-off); without it, some are (the test can fail), and holds are still made.
TEST(EdgeHolds, NoHoldPassesTheBodyFurtherThanTheStrokeOverAFootAtARiser) {
  constexpr double kStroke = 0.21, kFast = 0.267, kSwing = 0.72;
  const double stance = kStroke / kFast;
  const planning::Gait gait =
      planning::Gait::trot(6, kSwing + stance, stance / (kSwing + stance),
                           planning::contactMask(kFeet, {"LF", "RF", "MR"}),
                           planning::contactMask(kFeet, {"MF", "LR", "RR"}));
  const double floor_end = kEdgeUp - kMargin;
  // The most body travel past a riser stop over any stance of a run, and how many holds.
  const auto play = [&](double x0, bool checked) {
    BlockScene s(blockTerrain(), x0, kFast, stance, gait);
    s.config.max_up_hold = stance;
    s.config.stance_stroke = checked ? kStroke : 0.0;
    s.run(10.0);
    const planning::GaitClock clock = s.history();
    expectHoldsInAllStance(gait, clock, stance);
    double worst = 0.0;
    for (int foot = 0; foot < 6; ++foot) {
      double touchdown = std::numeric_limits<double>::quiet_NaN();
      bool was = gait.inStance(foot, clock.gaitTime(0.5));
      for (double t = 0.5; t <= 9.0; t += 1e-3) {
        const bool now = gait.inStance(foot, clock.gaitTime(t));
        if (!was && now) touchdown = t;
        if (was && !now && std::isfinite(touchdown)) {
          const double foothold = s.feet.nominalFoothold(foot, touchdown).x();
          if (foothold < floor_end) {
            const double past = kFast * (t - touchdown) - (floor_end - foothold);
            worst = std::max(worst, past);
          }
        }
        was = now;
      }
    }
    return std::make_pair(worst, clock.size());
  };
  double worst_unchecked = 0.0;
  int held_runs = 0;
  for (double x0 = -0.3; x0 < 0.0; x0 += 0.02) {
    worst_unchecked = std::max(worst_unchecked, play(x0, false).first);
    const auto [worst, holds] = play(x0, true);
    EXPECT_LE(worst, kStroke + 1e-3) << "x0 " << x0;
    if (holds > 0) ++held_runs;
  }
  EXPECT_GT(worst_unchecked, kStroke + 0.03);
  EXPECT_GT(held_runs, 0);
}

TEST(StepUpHolds, TouchDownsCloseUpToTheRiser) {
  const double floor_end = kEdgeUp - kMargin;
  expectHoldsPrevent([&](double x0, bool on) {
    BlockScene s(x0, kSpeed, 0.0);
    s.config.max_up_hold = on ? 1.5 : 0.0;
    s.run(12.0);
    const planning::GaitClock clock = s.history();
    expectHoldsInAllStance(s.scheduler.gait(), clock, 1.5);
    HoldRun r{0, clock.size()};
    for (const Swing& w : swings(s.scheduler.gait(), clock, 1.0, 10.0)) {
      const double to_end = floor_end - s.feet.nominalFoothold(w.foot, w.touchdown).x();
      if (to_end > s.config.setback + 1e-3 && to_end < 1.5 * kSpeed) ++r.bad;
    }
    if (!on) {
      EXPECT_EQ(clock.size(), 0);
    }
    return r;
  });
}

/// A trot whose stride is short against the longest hold (0.99 s at 0.3 m/s: 0.30 m, holds
/// up to 1.5 s, 0.45 m; a longer-legged robot's): a touch-down whose next one (a period
/// later) still lands short of the floor's end is not held, since that next swing climbs
/// from nearer the riser. Without the rule the hold before such a touch-down carries the body
/// up to 0.45 m with every foot standing (heavyquad tipped over at the restart).
TEST(StepUpHolds, NoHoldWhereTheNextTouchDownStillLandsShortOfTheRiser) {
  const double period = 0.99, speed = 0.3, stride = period * speed;
  const planning::Gait gait =
      planning::Gait::trot(6, period, 0.6, planning::contactMask(kFeet, {"LF", "RF", "MR"}),
                           planning::contactMask(kFeet, {"MF", "LR", "RR"}));
  int runs_held = 0;
  for (double x0 = -0.3; x0 < 0.0; x0 += 0.02) {
    BlockScene s(blockTerrain(), x0, speed, 0.0, gait);
    s.config.max_up_hold = 1.5;
    s.run(7.0);
    const planning::GaitClock clock = s.history();
    expectHoldsInAllStance(gait, clock, 1.5);
    if (clock.size() > 0) ++runs_held;
    for (int i = 0; i < clock.size(); ++i) {
      EXPECT_LE(clock.hold(i).duration * speed, stride) << "x0 " << x0 << " hold " << i;
    }
  }
  EXPECT_GT(runs_held, 0);  // the rule does not remove every step-up hold
}

/// A swing whose nominal touch-down lies in the gap before the riser (the foothold rule
/// sends it up onto the block, out of a leg's reach once it has cleared the riser) waits
/// until it is at most up_reach short of the block's region (up_reach 0: off); a setback
/// too far back for the swing after it to land on the block makes such swings.
TEST(StepUpHolds, NoClimbFromFarInTheGap) {
  const double block_start = kEdgeUp + kMargin, floor_end = kEdgeUp - kMargin;
  expectHoldsPrevent([&](double x0, bool on) {
    BlockScene s(x0, kSpeed, 0.0);
    s.config.max_up_hold = 1.5;
    s.config.setback = 0.2;
    s.config.up_reach = on ? 0.05 : 0.0;
    s.run(12.0);
    const planning::GaitClock clock = s.history();
    expectHoldsInAllStance(s.scheduler.gait(), clock, 1.5);
    HoldRun r{0, clock.size()};
    for (const Swing& w : swings(s.scheduler.gait(), clock, 1.0, 10.0)) {
      const double x = s.feet.nominalFoothold(w.foot, w.touchdown).x();
      if (x > floor_end + 1e-3 && x < block_start - 0.05 - 1e-3) ++r.bad;
    }
    return r;
  });
}

TEST(EdgeHolds, NoHoldAtALowStep) {
  // A 2 cm "step" (two perceived surfaces of one floor): no hold either way.
  planning::TerrainModel terrain = planning::terrainFromBoxes(
      {-5.0, 10.0, -1.5, 1.5, 0.0}, 0.0, {{1.0, 2.2, -1.5, 1.5, 0.02}}, kMargin);
  planning::BaseReference base{terrain, {0.375, kNominal}};
  planning::FootReferencePlanner feet(terrain, base, BlockScene::footConfig());
  planning::GaitScheduler scheduler{paperTrot(), kHorizon};
  planning::EdgeHoldConfig config;
  config.max_down_hold = 0.9;
  config.max_up_hold = 1.5;
  for (double x0 = -0.3; x0 < 0.0; x0 += 0.05) {
    base.reset(0.0, lie::SE3(Eigen::Vector3d(x0, 0.0, 0.0), Eigen::Quaterniond::Identity()),
               planning::BaseVelocityCommand{kSpeed, 0.0, 0.0});
    planning::GaitClock clock;
    for (double t = 0.0; t < 20.0; t += 0.02) {
      planning::planEdgeHolds(scheduler.gait(), feet, config, t, kHorizon, clock);
      ASSERT_EQ(clock.size(), 0) << x0 << " " << t;
    }
  }
}

TEST(StepDownHolds, BackwardsOffTheBlock) {
  // Reversing off the block's front edge (stairs2's way down): the drop is behind.
  for (double x0 = 1.9; x0 < 2.2; x0 += 0.03) {
    BlockScene s(x0, -kSpeed);
    s.run(20.0);
    const planning::GaitClock clock = s.history();
    for (const Swing& w : swings(s.scheduler.gait(), clock, 1.0, 18.0)) {
      const double to_edge = s.feet.nominalFoothold(w.foot, w.touchdown).x() - (kEdgeUp + kMargin);
      EXPECT_FALSE(to_edge >= 0.0 && to_edge < 0.9 * kSpeed - (2.0 * kMargin - s.config.reach))
          << x0 << " foot " << w.foot;
    }
  }
}

TEST(StepDownHolds, StartedHoldsStayAndReplanningRepeats) {
  BlockScene s(-0.2);
  s.run(8.0);
  planning::GaitClock before = s.clock;
  // The same inputs again: the same holds.
  planning::planEdgeHolds(s.scheduler.gait(), s.feet, s.config, s.last, kHorizon, s.clock);
  ASSERT_EQ(s.clock.size(), before.size());
  for (int i = 0; i < s.clock.size(); ++i) {
    EXPECT_EQ(s.clock.hold(i).start, before.hold(i).start);
    EXPECT_EQ(s.clock.hold(i).duration, before.hold(i).duration);
  }
  // Holds already under way (begun before t0 + lead) are kept whatever comes next: with
  // holding switched off they stay, the later ones go.
  // On until a hold has begun.
  const auto begun = [&] {
    return s.clock.size() > 0 && s.clock.hold(0).start <= s.last + s.config.lead;
  };
  while (s.t < 20.0 && !begun()) s.run(s.t);
  ASSERT_TRUE(begun());
  before = s.clock;
  s.config.max_down_hold = 0.0;
  const double t0 = s.t;
  planning::planEdgeHolds(s.scheduler.gait(), s.feet, s.config, t0, kHorizon, s.clock);
  const auto kept = [&](const planning::GaitClock::Hold& h) {
    for (int i = 0; i < s.clock.size(); ++i) {
      if (s.clock.hold(i).start == h.start && s.clock.hold(i).duration == h.duration) return true;
    }
    return false;
  };
  int under_way = 0;
  for (int i = 0; i < before.size(); ++i) {
    const planning::GaitClock::Hold& h = before.hold(i);
    if (h.start > t0 + s.config.lead) {
      EXPECT_FALSE(kept(h)) << h.start;
    } else if (h.end() > t0 - 2.0 * kPeriod) {
      EXPECT_TRUE(kept(h)) << h.start;
      ++under_way;
    }
  }
  EXPECT_GT(under_way, 0);
}

TEST(StepDownHolds, NoAllocation) {
  BlockScene s(-0.2);
  s.run(10.0);
  test::AllocationGuard guard;  // the clock is full-size already: a run reuses it
  for (double t0 = 10.0; t0 < 16.0; t0 += 0.02) {
    planning::planEdgeHolds(s.scheduler.gait(), s.feet, s.config, t0, kHorizon, s.clock);
    s.scheduler.fill(t0, kHorizon, s.schedule, s.clock);
  }
  EXPECT_EQ(guard.count(), 0u);
}

}  // namespace
