// The contact planner: its schedule follows the gait settings (period, duty, groups, the
// clock's holds), anchoring keeps a stance foot where it stands while the base moves on, late
// feet are brought down and then settled, terrains are swapped within the capacity, and the
// measured calls allocate nothing.
#include "rollstep/planning/contact_planner.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "common/alloc_counter.hpp"

namespace {

using Eigen::Vector2d;
using namespace rollstep;

const std::vector<std::string> kFeet{"LF", "MF", "RF", "LR", "MR", "RR"};
const std::vector<Vector2d> kNominal{{0.33, 0.22},  {0.33, 0.0},  {0.33, -0.22},
                                     {-0.33, 0.22}, {-0.33, 0.0}, {-0.33, -0.22}};
constexpr double kHeight = 0.375, kOffset = 0.075, kHorizon = 1.5;

planning::GaitGroups paperGroups() {
  planning::GaitGroups g;
  g.trot_a = planning::contactMask(kFeet, {"LF", "RF", "MR"});
  g.trot_b = planning::contactMask(kFeet, {"MF", "LR", "RR"});
  g.walk_order = {0, 4, 2, 3, 1, 5};
  return g;
}

planning::ContactPlannerSettings settings() {
  planning::ContactPlannerSettings s;
  s.horizon = kHorizon;
  s.gait.period = 0.8;
  s.gait.trot_duty = 0.6;
  s.swing_clearance = 0.08;
  return s;
}

planning::NominalStance stance() { return {kNominal, kHeight, kOffset}; }

planning::TerrainModel flat() {
  return planning::terrainFromBoxes({-5.0, 10.0, -1.5, 1.5, 0.0}, 0.0, {}, 0.0);
}

std::unique_ptr<planning::ContactPlanner> trotPlanner(
    const planning::ContactPlannerSettings& s = settings(),
    planning::TerrainModel terrain = flat()) {
  return std::make_unique<planning::ContactPlanner>(
      s, stance(), planning::makeGait(planning::GaitKind::Trot, 6, s.gait, paperGroups()),
      std::move(terrain));
}

/// The feet of the nominal stance at the planner's base reference at t (world, contact
/// frames at the offset above flat ground).
Eigen::Matrix3Xd nominalFeet(const planning::ContactPlanner& p, double t) {
  Eigen::Matrix3Xd feet(3, p.numFeet());
  for (int i = 0; i < p.numFeet(); ++i) {
    feet.col(i) << p.footPlanner().nominalFoothold(i, t), kOffset;
  }
  return feet;
}

TEST(ContactPlanner, TheScheduleIsTheGaitOfTheSettings) {
  for (const double period : {0.6, 0.8, 1.2}) {
    for (const double duty : {0.55, 0.6, 0.75}) {
      planning::ContactPlannerSettings s = settings();
      s.gait.period = period;
      s.gait.trot_duty = duty;
      auto planner = trotPlanner(s);
      planner->reset(0.3, lie::SE3::Identity(), planning::BaseVelocityCommand{0.2, 0.0, 0.0});
      ocp::ModeSchedule schedule(planner->scheduleCapacity());
      planner->planSchedule(0.3, schedule);
      EXPECT_EQ(planner->gaitClock().size(), 0);  // no holds configured
      const planning::GaitGroups g = paperGroups();
      for (int i = 0; i < 6; ++i) {
        const bool in_a = (g.trot_a >> i & 1) != 0;
        // Group a is in stance on [0, duty T) mod T, group b half a period later.
        const double offset = in_a ? 0.0 : 0.5 * period;
        for (double t = 0.3; t < 0.3 + kHorizon; t += 0.0137) {
          double phase = std::fmod(t - offset, period) / period;
          if (phase < 0.0) phase += 1.0;
          if (std::abs(phase - duty) < 1e-6 || phase < 1e-6 || phase > 1.0 - 1e-6) continue;
          const planning::FootPhase f = planning::footPhase(schedule, i, t);
          EXPECT_EQ(f.stance, phase < duty) << "foot " << i << " t " << t;
          if (!f.stance) {
            EXPECT_NEAR(f.touchdown - f.liftoff, (1.0 - duty) * period, 1e-9);
          }
        }
      }
    }
  }
}

TEST(ContactPlanner, AHeldClockShiftsEveryLaterSwitchByTheHold) {
  auto planner = trotPlanner();
  ocp::ModeSchedule plain(planner->scheduleCapacity()), held(planner->scheduleCapacity());
  planner->fillSchedule(0.0, kHorizon, plain);
  planning::GaitClock clock;
  // In the all-stance phase of [0.48, 0.8) (duty 0.6 of 0.8: group a lifts off at 0.48,
  // group b lands at 0.08 + ... ), a hold of 0.25 s at 0.7.
  ASSERT_TRUE(clock.addHold(0.7, 0.25));
  planner->setGaitClock(clock);
  planner->fillSchedule(0.0, kHorizon, held);
  for (double t = 0.0; t < kHorizon; t += 0.01) {
    const double tau = t < 0.7 ? t : (t < 0.95 ? 0.7 : t - 0.25);
    EXPECT_EQ(held.modeAt(t), plain.modeAt(tau)) << "t " << t;
  }
}

TEST(ContactPlanner, AnchoringKeepsAStanceFootWhereItStands) {
  auto planner = trotPlanner();
  planning::ContactPlannerSettings s = settings();
  s.anchor_stance_feet = true;
  auto anchored = trotPlanner(s);
  EXPECT_FALSE(planner->usesMeasuredFeet());
  EXPECT_TRUE(anchored->usesMeasuredFeet());
  const planning::BaseVelocityCommand command{0.3, 0.0, 0.0};
  planner->reset(0.0, lie::SE3::Identity(), command);
  anchored->reset(0.0, lie::SE3::Identity(), command);
  ocp::ModeSchedule schedule(anchored->scheduleCapacity());
  anchored->planSchedule(0.0, schedule);
  // LF (group a) is in stance on [0, 0.48): measured at t = 0.1 4 cm behind its nominal
  // foothold (the one at its touch-down at 0: a robot lagging its reference).
  constexpr int kFoot = 0;
  Eigen::Matrix3Xd feet = nominalFeet(*anchored, 0.0);
  feet(0, kFoot) -= 0.04;
  const Vector2d stood = feet.col(kFoot).head<2>();
  anchored->anchorStanceFeet(schedule, 0.1, feet);
  for (const double t : {0.1, 0.2, 0.3, 0.45}) {
    // Anchored: where it stood, for the whole stance.
    EXPECT_NEAR((anchored->footPlanner().stanceFoothold(schedule, kFoot, t) - stood).norm(), 0.0,
                1e-12)
        << "t " << t;
    // Not anchored: the nominal foothold.
    EXPECT_GT((planner->footPlanner().stanceFoothold(schedule, kFoot, t) - stood).norm(), 0.03);
  }
  // The next stance (after the swing from 0.48 to 0.8) is nominal again.
  const Vector2d next = anchored->footPlanner().stanceFoothold(schedule, kFoot, 0.9);
  EXPECT_NEAR((next - planner->footPlanner().stanceFoothold(schedule, kFoot, 0.9)).norm(), 0.0,
              1e-12);
  // Feet that are not measured (NaN) or of the wrong count change nothing.
  Eigen::Matrix<double, 3, 6> bad = feet;
  bad(2, 3) = std::numeric_limits<double>::quiet_NaN();
  bad(0, kFoot) += 0.1;
  anchored->anchorStanceFeet(schedule, 0.2, Eigen::Matrix3Xd(bad));
  anchored->anchorStanceFeet(schedule, 0.2, Eigen::Matrix3Xd::Zero(3, 2));
  EXPECT_NEAR((anchored->footPlanner().stanceFoothold(schedule, kFoot, 0.3) - stood).norm(), 0.0,
              1e-12);
}

TEST(ContactPlanner, ALateFootStaysInSwingUntilItLandsThenTheStanceIsSettled) {
  planning::ContactPlannerSettings s = settings();
  s.late_touchdown_tolerance = 0.01;
  s.late_touchdown_max_delay = 0.5;
  s.late_touchdown_speed = 0.5;
  s.late_touchdown_min_time = 0.03;
  auto planner = trotPlanner(s);
  planner->reset(0.0, lie::SE3::Identity(), planning::BaseVelocityCommand{0.2, 0.0, 0.0});
  // MF (group b) swings on [0.08, 0.4) and is due on the ground at 0.4 (swing 0.32 s).
  constexpr int kFoot = 1;
  constexpr double kDue = 0.4;
  const auto fresh = [&](double t) {
    ocp::ModeSchedule schedule(planner->scheduleCapacity());
    planner->fillSchedule(t, kHorizon, schedule);
    return schedule;
  };
  ocp::ModeSchedule schedule = fresh(kDue + 0.02);
  ASSERT_TRUE(planning::footPhase(schedule, kFoot, kDue + 0.02).stance);
  Eigen::Matrix3Xd feet = nominalFeet(*planner, kDue + 0.02);
  feet(2, kFoot) += 0.05;  // 5 cm above its surface
  EXPECT_EQ(planner->landLateFeet(schedule, kDue + 0.02, feet), 1 << kFoot);
  // Its stance now begins at the landing: 0.1 s for 5 cm at 0.5 m/s.
  const planning::FootPhase late = planning::footPhase(schedule, kFoot, kDue + 0.02);
  EXPECT_FALSE(late.stance);
  EXPECT_NEAR(late.touchdown, kDue + 0.02 + 0.1, 1e-9);
  // The other feet keep their schedule.
  const ocp::ModeSchedule untouched = fresh(kDue + 0.02);
  for (int i = 0; i < 6; ++i) {
    if (i == kFoot) continue;
    for (double t = kDue; t < kDue + 0.5; t += 0.01) {
      EXPECT_EQ(planning::footPhase(schedule, i, t).stance,
                planning::footPhase(untouched, i, t).stance);
    }
  }
  // Its height reference descends from where it was towards the surface.
  const double z_mid = planner->footPlanner().query(schedule, kFoot, kDue + 0.07).z_ref;
  EXPECT_LT(z_mid, kOffset + 0.05);
  EXPECT_GT(z_mid, kOffset);
  // Landed: settled, and never delayed again in that stance even if measured up.
  ocp::ModeSchedule again = fresh(kDue + 0.05);
  feet(2, kFoot) = kOffset;
  EXPECT_EQ(planner->landLateFeet(again, kDue + 0.05, feet), 0);
  again = fresh(kDue + 0.06);
  feet(2, kFoot) = kOffset + 0.05;
  EXPECT_EQ(planner->landLateFeet(again, kDue + 0.06, feet), 0);
  EXPECT_TRUE(planning::footPhase(again, kFoot, kDue + 0.06).stance);
  // Off (tolerance 0): nothing is ever late.
  auto off = trotPlanner();
  ocp::ModeSchedule s_off(off->scheduleCapacity());
  off->fillSchedule(kDue + 0.02, kHorizon, s_off);
  EXPECT_EQ(off->landLateFeet(s_off, kDue + 0.02, feet), 0);
}

TEST(ContactPlanner, TerrainsAreSwappedWithinTheCapacity) {
  auto planner = trotPlanner(settings(), flat());
  EXPECT_EQ(planner->regionEdgeCapacity(), 4);
  planning::TerrainModel empty;
  EXPECT_FALSE(planner->acceptsTerrain(empty));
  planning::TerrainModel step = planning::terrainFromBoxes({-5.0, 10.0, -1.5, 1.5, 0.0}, 0.0,
                                                           {{1.0, 2.2, -1.5, 1.5, 0.2}}, 0.05);
  ASSERT_TRUE(planner->acceptsTerrain(step));
  const int regions = step.size();
  EXPECT_TRUE(planner->swapTerrain(step));
  EXPECT_EQ(planner->terrain().size(), regions);
  EXPECT_EQ(step.size(), 1);  // the old one, handed back
  EXPECT_NEAR(planner->terrain().heightAt({1.5, 0.0}, 0.0), 0.2, 1e-12);
}

TEST(ContactPlanner, MakeGaitRefusesAGaitWithoutItsGroups) {
  const planning::GaitTiming timing;
  EXPECT_THROW(planning::makeGait(planning::GaitKind::Trot, 6, timing, {}), std::invalid_argument);
  EXPECT_THROW(planning::makeGait(planning::GaitKind::StaticWalk, 6, timing, {}),
               std::invalid_argument);
  EXPECT_THROW(planning::makeGait(planning::GaitKind::Custom, 6, timing, paperGroups()),
               std::invalid_argument);
  EXPECT_EQ(planning::makeGait(planning::GaitKind::StaticWalk, 6, timing, paperGroups()).kind(),
            planning::GaitKind::StaticWalk);
  // A gait for another number of feet than the stance has.
  EXPECT_THROW(planning::ContactPlanner(
                   settings(), stance(),
                   planning::makeGait(planning::GaitKind::Standing, 4, timing, {}), flat()),
               std::invalid_argument);
}

TEST(ContactPlanner, TheRealTimeCallsDoNotAllocate) {
  planning::ContactPlannerSettings s = settings();
  s.anchor_stance_feet = true;
  s.latch_touchdowns = true;
  s.late_touchdown_tolerance = 0.01;
  s.late_touchdown_min_time = 0.03;
  auto planner = trotPlanner(s);
  planner->reset(0.0, lie::SE3::Identity(), planning::BaseVelocityCommand{0.2, 0.0, 0.0});
  ocp::ModeSchedule schedule(planner->scheduleCapacity());
  Eigen::Matrix3Xd feet = nominalFeet(*planner, 0.0);
  planning::TerrainModel other = flat();
  test::AllocationGuard guard;
  for (double t = 0.0; t < 2.0; t += 0.001) {
    planner->fillSchedule(t, 0.015, schedule);
    feet.row(2).setConstant(kOffset + 0.03);  // every foot up: late ones on every touch-down
    planner->anchorStanceFeet(schedule, t, feet);
    planner->landLateFeet(schedule, t, feet);
  }
  planner->swapTerrain(other);
  EXPECT_EQ(guard.count(), 0u);
}

}  // namespace
