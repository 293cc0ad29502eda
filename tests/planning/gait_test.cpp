// Gaits and contact schedules: trot, standing, rolling, static walk and custom tables;
// wrap-around at period boundaries; ModeSchedules filled for a horizon at any t0 and the
// per-foot swing timing read back from them, without allocation.
#include "rollstep/planning/gait.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/alloc_counter.hpp"
#include "rollstep/planning/contact_schedule.hpp"

namespace {

using namespace rollstep;
using planning::Gait;
using planning::inContact;

// The robot's contact order is an argument of the library; the test plays the robot.
const std::vector<std::string> kFeet{"LF", "MF", "RF", "LR", "MR", "RR"};
constexpr int kLF = 0, kMF = 1, kRF = 2, kLR = 3, kMR = 4, kRR = 5;

Gait paperTrot(double period, double duty) {
  return Gait::trot(6, period, duty, planning::contactMask(kFeet, {"LF", "RF", "MR"}),
                    planning::contactMask(kFeet, {"MF", "LR", "RR"}));
}

template <class F>
void expectThrowsNaming(F&& f, const std::string& what) {
  try {
    f();
    ADD_FAILURE() << "no exception, expected one naming " << what;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
  }
}

TEST(Gait, ContactMaskFromNames) {
  EXPECT_EQ(planning::contactMask(kFeet, {"LF", "RF", "MR"}), (1 << kLF) | (1 << kRF) | (1 << kMR));
  EXPECT_EQ(planning::allFeetMask(6), 63);
  EXPECT_EQ(planning::contactCount(0b101101), 4);
  EXPECT_THROW(planning::contactMask(kFeet, {"XX"}), std::invalid_argument);
  EXPECT_THROW(planning::contactMask(kFeet, {"LF", "LF"}), std::invalid_argument);
}

TEST(Gait, TrotAlternatesThePapersGroups) {
  const double T = 0.8, duty = 0.5;
  const Gait g = paperTrot(T, duty);
  EXPECT_EQ(g.kind(), planning::GaitKind::Trot);
  EXPECT_DOUBLE_EQ(g.period(), T);
  EXPECT_EQ(g.switchesPerPeriod(), 2);
  const int a = planning::contactMask(kFeet, {"LF", "RF", "MR"});
  const int b = planning::contactMask(kFeet, {"MF", "LR", "RR"});
  EXPECT_EQ(g.modeAt(0.1), a);
  EXPECT_EQ(g.modeAt(0.5), b);
  for (int f = 0; f < 6; ++f) EXPECT_NEAR(g.dutyOf(f), duty, 1e-12);
  // Exactly one group in stance at every time, the other swinging.
  for (double t = 0.0; t < 3 * T; t += 0.013) {
    const int m = g.modeAt(t);
    EXPECT_TRUE(m == a || m == b) << t;
    EXPECT_EQ(inContact(m, kLF), inContact(m, kMR));
    EXPECT_NE(inContact(m, kLF), inContact(m, kMF));
  }
}

TEST(Gait, TrotDutyAboveHalfAddsAllStanceOverlaps) {
  const double T = 1.0, duty = 0.6;
  const Gait g = paperTrot(T, duty);
  EXPECT_EQ(g.switchesPerPeriod(), 4);
  for (int f = 0; f < 6; ++f) EXPECT_NEAR(g.dutyOf(f), duty, 1e-12);
  // Group A stance on [0, 0.6), group B on [0.5, 1.1): both on [0.5, 0.6) and [0, 0.1).
  EXPECT_EQ(g.modeAt(0.55), 63);
  EXPECT_EQ(g.modeAt(0.05), 63);
  EXPECT_EQ(g.modeAt(0.3), planning::contactMask(kFeet, {"LF", "RF", "MR"}));
  EXPECT_EQ(g.modeAt(0.8), planning::contactMask(kFeet, {"MF", "LR", "RR"}));
  // Duty below a half: flight phases with no contact.
  const Gait h = paperTrot(T, 0.4);
  EXPECT_EQ(h.modeAt(0.45), 0);
  EXPECT_EQ(h.modeAt(0.95), 0);
}

TEST(Gait, WrapsAroundPeriodBoundaries) {
  const double T = 0.7;
  const Gait g = paperTrot(T, 0.6);
  for (double t = -2.0; t < 2.0; t += 0.0371) {
    for (int k = -3; k <= 3; ++k) EXPECT_EQ(g.modeAt(t + k * T), g.modeAt(t)) << t << " " << k;
  }
  // Just before and after a period boundary.
  EXPECT_EQ(g.modeAt(5 * T - 1e-9), g.modeAt(T - 1e-9));
  EXPECT_EQ(g.modeAt(5 * T + 1e-9), g.modeAt(1e-9));
  EXPECT_EQ(g.modeAt(-1e-9), g.modeAt(T - 1e-9));
}

TEST(Gait, NegativeTimesNearPeriodMultiplesGiveAPhaseOfTheGait) {
  // t - period * floor(t / period) can round to a hair below 0 just below a negative
  // multiple of the period (the foot planner searches back before t = 0): the mode must
  // still be one of the gait's phases, never a read before the phase table (UBSan found one).
  const Gait g = paperTrot(0.8, 0.5);
  std::vector<int> modes;
  for (double t = 0.0; t < 0.8; t += 1e-4) modes.push_back(g.modeAt(t));
  const auto isAMode = [&](int m) {
    return std::find(modes.begin(), modes.end(), m) != modes.end();
  };
  for (int m = 1; m <= 200; ++m) {
    const double multiple = -0.8 * m;  // e.g. just below -7.2, t / 0.8 rounds to -9 exactly
    for (const double t :
         {std::nextafter(multiple, -1e9), multiple, std::nextafter(multiple, 0.0)}) {
      EXPECT_TRUE(isAMode(g.modeAt(t))) << t;
    }
  }
}

TEST(Gait, StandingAndRollingKeepEveryFootDown) {
  for (const Gait& g : {Gait::standing(6), Gait::rolling(6)}) {
    EXPECT_EQ(g.switchesPerPeriod(), 0);
    for (double t = -1.0; t < 3.0; t += 0.1) EXPECT_EQ(g.modeAt(t), 63);
  }
  EXPECT_EQ(Gait::standing(6).kind(), planning::GaitKind::Standing);
  EXPECT_EQ(Gait::rolling(6).kind(), planning::GaitKind::Rolling);
}

TEST(Gait, StaticWalkLiftsOneFootAtATime) {
  const std::vector<int> order{kLF, kRR, kMF, kMR, kRF, kLR};
  const double T = 3.0, duty = 0.85;
  const Gait g = Gait::staticWalk(6, T, duty, order);
  for (int f = 0; f < 6; ++f) EXPECT_NEAR(g.dutyOf(f), duty, 1e-12);
  for (double t = 0.0; t < 2 * T; t += 0.01) {
    EXPECT_GE(planning::contactCount(g.modeAt(t)), 5) << t;
  }
  // Foot order[k] swings right after k T / 6.
  for (std::size_t k = 0; k < order.size(); ++k) {
    const double t = static_cast<double>(k) * T / 6.0 + 0.01;
    EXPECT_EQ(g.modeAt(t), 63 & ~(1 << order[k])) << k;
  }
  expectThrowsNaming([&] { Gait::staticWalk(6, T, 0.7, order); }, "duty = 0.7");
}

TEST(Gait, CustomTable) {
  // A wave gait: front row, middle pair... any table of contact phases.
  const int front = planning::contactMask(kFeet, {"LF", "MF", "RF"});
  const int rear = planning::contactMask(kFeet, {"LR", "MR", "RR"});
  const Gait g = Gait::fromTable(6, {{0.2, 63}, {0.3, rear}, {0.2, 63}, {0.3, front}});
  EXPECT_EQ(g.kind(), planning::GaitKind::Custom);
  EXPECT_DOUBLE_EQ(g.period(), 1.0);
  EXPECT_EQ(g.modeAt(0.1), 63);
  EXPECT_EQ(g.modeAt(0.3), rear);
  EXPECT_EQ(g.modeAt(0.6), 63);
  EXPECT_EQ(g.modeAt(0.9), front);
  EXPECT_NEAR(g.dutyOf(kLF), 0.7, 1e-12);
  EXPECT_NEAR(g.dutyOf(kRR), 0.7, 1e-12);
  // Equal neighbours merge; the wrap from the last to the first phase is not a switch.
  const Gait h = Gait::fromTable(6, {{0.2, 63}, {0.2, 63}, {0.3, rear}, {0.3, 63}});
  EXPECT_EQ(h.phaseModes().size(), 3u);
  EXPECT_EQ(h.switchesPerPeriod(), 2);
}

TEST(Gait, BadInputThrowsNamingTheParameter) {
  const int a = 0b010101, b = 0b101010;
  expectThrowsNaming([&] { Gait::trot(6, 0.0, 0.5, a, b); }, "period = 0");
  expectThrowsNaming([&] { Gait::trot(6, -1.0, 0.5, a, b); }, "period = -1");
  expectThrowsNaming([&] { Gait::trot(6, 0.8, 1.0, a, b); }, "duty = 1");
  expectThrowsNaming([&] { Gait::trot(6, 0.8, 0.0, a, b); }, "duty = 0");
  expectThrowsNaming([&] { Gait::trot(6, 0.8, std::nan(""), a, b); }, "duty = nan");
  expectThrowsNaming([&] { Gait::trot(6, std::nan(""), 0.5, a, b); }, "period = nan");
  expectThrowsNaming([&] { Gait::trot(6, 0.8, 0.5, a, a); }, "group_a");
  expectThrowsNaming([&] { Gait::trot(6, 0.8, 0.5, a, 1 << 7); }, "group_b");
  expectThrowsNaming([&] { Gait::standing(0); }, "num_feet = 0");
  expectThrowsNaming(
      [&] {
        Gait::fromTable(6, {{0.5, 63}, {-0.1, 0}});
      },
      "phases[1].duration = -0.1");
  expectThrowsNaming([&] { Gait::fromTable(6, {{0.5, 63}, {0.5, 64}}); }, "phases[1].mode = 64");
  // A foot that never touches down.
  expectThrowsNaming([&] { Gait::fromTable(6, {{0.5, 62}}); }, "foot 0");
}

// ---- ModeSchedule from a gait -------------------------------------------------------------

/// True if t is within `tol` of a switching time of the gait (mode ambiguous by rounding).
bool nearSwitch(const Gait& g, double t, double tol = 1e-9) {
  const double tau = t - g.period() * std::floor(t / g.period());
  for (double s : g.phaseStarts()) {
    if (std::abs(tau - s) < tol || std::abs(tau - s - g.period()) < tol) return true;
  }
  return false;
}

TEST(GaitScheduler, FillsModeScheduleAtArbitraryT0) {
  const Gait g = paperTrot(0.8, 0.6);
  const double horizon = 1.5, dt = 0.015;
  planning::GaitScheduler s(g, horizon);
  ocp::ModeSchedule ms(s.requiredCapacity());
  for (double t0 : {0.0, 0.123, 0.8, 1.6 - 1e-12, 7.777, -3.21, 1234.5678}) {
    s.fill(t0, horizon, ms);
    EXPECT_LE(ms.switches(), s.requiredCapacity());
    for (int k = 0; k <= 100; ++k) {
      const double t = t0 + k * dt;
      if (nearSwitch(g, t)) continue;
      EXPECT_EQ(ms.modeAt(t), g.modeAt(t)) << "t0 " << t0 << " node " << k;
    }
    // The window covers a period on each side.
    EXPECT_LE(ms.switchingTimes().front(), t0);
    EXPECT_GE(ms.switchingTimes().back(), t0 + horizon);
  }
}

TEST(GaitScheduler, SwingTimingFromTheSchedule) {
  const double T = 0.8, duty = 0.6;
  const Gait g = paperTrot(T, duty);
  planning::GaitScheduler s(g, 1.5);
  ocp::ModeSchedule ms(s.requiredCapacity());
  const double t0 = 2.05;
  s.fill(t0, 1.5, ms);
  // Group A (LF) in stance on [kT, kT + 0.48), swinging on [kT + 0.48, (k+1)T).
  // Group B (MF) in stance on [kT + 0.4, kT + 0.88), swinging on [kT + 0.08, kT + 0.4).
  for (int k = 0; k <= 150; ++k) {
    const double t = t0 + 0.01 * k;
    if (nearSwitch(g, t)) continue;
    const double tau = t - T * std::floor(t / T), base = t - tau;
    const planning::FootPhase lf = planning::footPhase(ms, kLF, t);
    EXPECT_EQ(lf.stance, g.inStance(kLF, t));
    if (!lf.stance) {
      ASSERT_TRUE(lf.bounded()) << t;
      EXPECT_NEAR(lf.liftoff, base + duty * T, 1e-9);
      EXPECT_NEAR(lf.touchdown, base + T, 1e-9);
      EXPECT_NEAR(lf.phase, (tau - duty * T) / ((1 - duty) * T), 1e-9);
    }
    const planning::FootPhase mf = planning::footPhase(ms, kMF, t);
    EXPECT_EQ(mf.stance, g.inStance(kMF, t));
    if (!mf.stance) {
      ASSERT_TRUE(mf.bounded()) << t;
      // Swing on [0.08 s, 0.4 s) of the period (stance [0.4 s, 0.88 s) wraps to 0.08 s).
      EXPECT_NEAR(mf.liftoff, base + 0.08, 1e-9);
      EXPECT_NEAR(mf.touchdown, base + 0.5 * T, 1e-9);
      EXPECT_GE(mf.phase, 0.0);
      EXPECT_LE(mf.phase, 1.0);
    }
  }
}

TEST(GaitScheduler, UnknownEndsOfASwingAreInfinite) {
  ocp::ModeSchedule ms(4);
  // Foot 0 swings before t = 1 (lift-off unknown) and after t = 3 (touch-down unknown).
  ms.set({1.0, 3.0}, {0b10, 0b11, 0b10});
  const planning::FootPhase before = planning::footPhase(ms, 0, 0.5);
  EXPECT_FALSE(before.stance);
  EXPECT_FALSE(before.bounded());
  EXPECT_EQ(before.touchdown, 1.0);
  EXPECT_TRUE(std::isnan(before.phase));
  const planning::FootPhase after = planning::footPhase(ms, 0, 4.0);
  EXPECT_EQ(after.liftoff, 3.0);
  EXPECT_TRUE(std::isinf(after.touchdown));
  EXPECT_TRUE(planning::footPhase(ms, 0, 2.0).stance);
  EXPECT_TRUE(planning::footPhase(ms, 1, 0.5).stance);
}

TEST(GaitScheduler, ConstantGaitAndStaticWalkSchedules) {
  planning::GaitScheduler stand(Gait::standing(6), 1.5);
  ocp::ModeSchedule ms(stand.requiredCapacity() + 1);
  stand.fill(3.3, 1.5, ms);
  EXPECT_EQ(ms.switches(), 0);
  EXPECT_EQ(ms.modeAt(4.0), 63);

  const Gait walk = Gait::staticWalk(6, 3.0, 5.0 / 6.0, {0, 1, 2, 3, 4, 5});
  planning::GaitScheduler s(walk, 1.5);
  ocp::ModeSchedule mw(s.requiredCapacity());
  s.fill(0.7, 1.5, mw);
  for (double t = 0.7; t <= 2.2; t += 0.015) {
    if (nearSwitch(walk, t)) continue;
    EXPECT_EQ(mw.modeAt(t), walk.modeAt(t));
    int swinging = 0;
    for (int f = 0; f < 6; ++f) {
      const planning::FootPhase fp = planning::footPhase(mw, f, t);
      if (fp.stance) continue;
      ++swinging;
      EXPECT_NEAR(fp.touchdown - fp.liftoff, 0.5, 1e-9);
    }
    EXPECT_EQ(swinging, 1) << t;  // duty 5/6 with six feet: always exactly one swing
  }
}

TEST(GaitScheduler, FillAndQueriesDoNotAllocate) {
  planning::GaitScheduler s(paperTrot(0.8, 0.6), 1.5);
  ocp::ModeSchedule ms(s.requiredCapacity());
  s.fill(0.0, 1.5, ms);
  double sum = 0.0;
  test::AllocationGuard guard;
  for (double t0 = 0.0; t0 < 5.0; t0 += 0.0371) {
    s.fill(t0, 1.5, ms);
    for (int k = 0; k <= 100; ++k) {
      for (int f = 0; f < 6; ++f) {
        const planning::FootPhase fp = planning::footPhase(ms, f, t0 + 0.015 * k);
        sum += fp.stance ? 0.0 : fp.phase;
      }
    }
  }
  EXPECT_EQ(guard.count(), 0u);
  EXPECT_GT(sum, 0.0);
}

TEST(GaitScheduler, BadArguments) {
  planning::GaitScheduler s(paperTrot(0.8, 0.6), 1.5);
  ocp::ModeSchedule ms(s.requiredCapacity());
  expectThrowsNaming([&] { s.fill(0.0, 2.0, ms); }, "horizon = 2");
  expectThrowsNaming([&] { s.fill(std::nan(""), 1.0, ms); }, "t0 = nan");
  ocp::ModeSchedule small(2);
  EXPECT_THROW(s.fill(0.0, 1.5, small), std::invalid_argument);
  expectThrowsNaming([&] { planning::GaitScheduler(Gait::standing(6), -1.0); }, "max_horizon = -1");
}

}  // namespace
