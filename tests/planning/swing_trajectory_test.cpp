// Swing height splines: end values, apex = max(lift-off, touch-down) + clearance,
// monotone up then down on a dense grid (ascending, descending, level), derivative
// against finite differences, C1 continuity, the region rule, bad input.
#include "rollstep/planning/swing_trajectory.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "common/alloc_counter.hpp"

namespace {

using rollstep::planning::SwingDirection;
using rollstep::planning::SwingHeightSpline;

struct Case {
  const char* name;
  double z_lo, z_td, clearance;
  SwingDirection dir;
};
const Case kCases[] = {{"ascending", 0.0, 0.20, 0.08, SwingDirection::Ascending},
                       {"descending", 0.365, 0.20, 0.08, SwingDirection::Descending},
                       {"level", 0.10, 0.10, 0.06, SwingDirection::Level},
                       {"level, no clearance", 0.0, 0.0, 0.0, SwingDirection::Level}};

TEST(SwingHeightSpline, EndValuesAndApex) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(c.name);
    const SwingHeightSpline s(1.3, 1.7, c.z_lo, c.z_td, c.clearance);
    EXPECT_DOUBLE_EQ(s.position(1.3), c.z_lo);
    EXPECT_DOUBLE_EQ(s.position(1.7), c.z_td);
    EXPECT_DOUBLE_EQ(s.velocity(1.3), 0.0);
    EXPECT_DOUBLE_EQ(s.velocity(1.7), 0.0);
    EXPECT_NEAR(s.apexHeight(), std::max(c.z_lo, c.z_td) + c.clearance, 1e-15);
    EXPECT_NEAR(s.position(s.apexTime()), s.apexHeight(), 1e-12);
    EXPECT_DOUBLE_EQ(s.apexTime(), 1.5);
    EXPECT_EQ(s.direction(), c.dir);
    // Outside the swing: held at the end heights.
    EXPECT_DOUBLE_EQ(s.position(0.0), c.z_lo);
    EXPECT_DOUBLE_EQ(s.position(9.0), c.z_td);
    EXPECT_DOUBLE_EQ(s.velocity(9.0), 0.0);
  }
}

TEST(SwingHeightSpline, MonotoneUpThenDownOnADenseGrid) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(c.name);
    const SwingHeightSpline s(0.0, 0.45, c.z_lo, c.z_td, c.clearance);
    const int n = 10000;
    double prev = s.position(0.0), max_z = prev;
    for (int k = 1; k <= n; ++k) {
      const double t = 0.45 * k / n;
      const double z = s.position(t);
      if (t <= s.apexTime()) {
        EXPECT_GE(z, prev - 1e-15) << t;
        EXPECT_GE(s.velocity(t), -1e-15) << t;
      } else {
        EXPECT_LE(z, prev + 1e-15) << t;
        EXPECT_LE(s.velocity(t), 1e-15) << t;
      }
      EXPECT_LE(z, s.apexHeight() + 1e-15);
      EXPECT_GE(z, std::min(c.z_lo, c.z_td) - 1e-15);
      max_z = std::max(max_z, z);
      prev = z;
    }
    EXPECT_NEAR(max_z, s.apexHeight(), 1e-9);
  }
}

TEST(SwingHeightSpline, DerivativeMatchesFiniteDifferencesAndIsContinuous) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(c.name);
    const SwingHeightSpline s(2.0, 2.4, c.z_lo, c.z_td, c.clearance);
    const double h = 1e-6;
    for (double t = 2.0 + 1e-3; t < 2.4 - 1e-3; t += 0.0037) {
      const double fd = (s.position(t + h) - s.position(t - h)) / (2 * h);
      EXPECT_NEAR(s.velocity(t), fd, 1e-6) << t;
    }
    // C1: position and velocity continuous at lift-off, apex and touch-down.
    for (double tk : {2.0, s.apexTime(), 2.4}) {
      const double e = 1e-9;
      EXPECT_NEAR(s.position(tk - e), s.position(tk + e), 1e-7) << tk;
      EXPECT_NEAR(s.velocity(tk - e), s.velocity(tk + e), 1e-6) << tk;
    }
  }
  // The first half really moves (not a degenerate zero curve).
  const SwingHeightSpline s(0.0, 0.4, 0.0, 0.2, 0.05);
  EXPECT_GT(s.velocity(0.1), 1.0);
  EXPECT_LT(s.velocity(0.3), -0.3);
}

TEST(SwingHeightSpline, RegionRuleFollowsTheDirection) {
  using rollstep::planning::classifySwing;
  using rollstep::planning::swingRegionActive;
  EXPECT_EQ(classifySwing(0.0, 0.2), SwingDirection::Ascending);
  EXPECT_EQ(classifySwing(0.2, 0.0), SwingDirection::Descending);
  EXPECT_EQ(classifySwing(0.2, 0.2005), SwingDirection::Level);
  EXPECT_TRUE(swingRegionActive(SwingDirection::Ascending, 0.2));
  EXPECT_FALSE(swingRegionActive(SwingDirection::Ascending, 0.7));
  EXPECT_FALSE(swingRegionActive(SwingDirection::Descending, 0.2));
  EXPECT_TRUE(swingRegionActive(SwingDirection::Descending, 0.7));
  EXPECT_FALSE(swingRegionActive(SwingDirection::Level, 0.2));
  EXPECT_FALSE(swingRegionActive(SwingDirection::Level, 0.7));
}

TEST(SwingHeightSpline, DoesNotAllocate) {
  rollstep::test::AllocationGuard guard;
  double sum = 0.0;
  for (int k = 0; k < 100; ++k) {
    const SwingHeightSpline s(0.0, 0.4, 0.0, 0.01 * k, 0.05);
    double z, zd;
    s.evaluate(0.004 * k, z, zd);
    sum += z + zd;
  }
  EXPECT_EQ(guard.count(), 0u);
  EXPECT_GT(sum, 0.0);
}

TEST(SwingHeightSpline, BadInputThrowsNamingTheParameter) {
  auto expectNaming = [](auto f, const std::string& what) {
    try {
      f();
      ADD_FAILURE() << "no exception, expected " << what;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  expectNaming([] { SwingHeightSpline(1.0, 1.0, 0, 0, 0.1); }, "t_touchdown = 1");
  expectNaming([] { SwingHeightSpline(1.0, 0.5, 0, 0, 0.1); }, "t_touchdown = 0.5");
  expectNaming([] { SwingHeightSpline(std::nan(""), 1.0, 0, 0, 0.1); }, "t_liftoff = nan");
  expectNaming([] { SwingHeightSpline(0.0, 1.0, std::nan(""), 0, 0.1); }, "z_liftoff = nan");
  expectNaming([] { SwingHeightSpline(0.0, 1.0, 0, std::numeric_limits<double>::infinity(), 0.1); },
               "z_touchdown = inf");
  expectNaming([] { SwingHeightSpline(0.0, 1.0, 0, 0, -0.1); }, "clearance = -0.1");
  expectNaming([] { SwingHeightSpline(0.0, 1.0, 0, 0, 0.1, 0.0); }, "apex_margin = 0");
  expectNaming([] { SwingHeightSpline(0.0, 1.0, 0, 0, 0.1, 0.6); }, "apex_margin = 0.6");
}

// An apex margin below 1/2 moves the apex of a swing up a step later (of one down
// earlier), to rise / (rise + fall) of the swing within [margin, 1 - margin]: the peak
// speeds of the two pieces (1.5 x height / duration) are then equal, or as close as the
// margin allows. The spline stays monotone up to the apex and down after it, and the
// region rule follows the apex.
TEST(SwingHeightSpline, ApexMarginBalancesThePeakSpeeds) {
  using rollstep::planning::swingRegionActive;
  const double T = 0.56;
  const auto peak = [&](const SwingHeightSpline& s, double t0, double t1) {
    double v = 0.0;
    for (int i = 0; i <= 2000; ++i)
      v = std::max(v, std::abs(s.velocity(t0 + (t1 - t0) * i / 2000.0)));
    return v;
  };
  // 0.2 m up, 0.02 m clearance: rise 0.22, fall 0.02 -> phase 0.917, clamped to 0.8.
  const SwingHeightSpline mid(0.0, T, 0.0, 0.2, 0.02), late(0.0, T, 0.0, 0.2, 0.02, 0.2);
  EXPECT_DOUBLE_EQ(mid.apexPhase(), 0.5);
  EXPECT_NEAR(late.apexPhase(), 0.8, 1e-12);
  EXPECT_NEAR(peak(mid, 0.0, T), 1.5 * 0.22 / (0.5 * T), 1e-3);
  EXPECT_NEAR(peak(late, 0.0, late.apexTime()), 1.5 * 0.22 / (0.8 * T), 1e-3);
  EXPECT_NEAR(peak(late, late.apexTime(), T), 1.5 * 0.02 / (0.2 * T), 1e-3);
  EXPECT_NEAR(late.position(late.apexTime()), 0.22, 1e-12);
  // Unclamped: 0.1 up with 0.1 clearance (rise 0.2, fall 0.1) puts the apex at 2/3 and
  // equalises the two peaks; a swing down mirrors it.
  const SwingHeightSpline up(0.0, T, 0.0, 0.1, 0.1, 0.1), down(0.0, T, 0.1, 0.0, 0.1, 0.1);
  EXPECT_NEAR(up.apexPhase(), 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(down.apexPhase(), 1.0 / 3.0, 1e-12);
  EXPECT_NEAR(peak(up, 0.0, up.apexTime()), peak(up, up.apexTime(), T), 1e-3);
  // Monotone on each side of the apex.
  double prev = late.position(0.0);
  for (int i = 1; i <= 1000; ++i) {
    const double t = T * i / 1000.0, z = late.position(t);
    if (t <= late.apexTime())
      EXPECT_GE(z, prev - 1e-15) << t;
    else
      EXPECT_LE(z, prev + 1e-15) << t;
    prev = z;
  }
  // The region window ends at the apex, not at mid-swing.
  EXPECT_TRUE(swingRegionActive(SwingDirection::Ascending, 0.7, late.apexPhase()));
  EXPECT_FALSE(swingRegionActive(SwingDirection::Ascending, 0.85, late.apexPhase()));
  EXPECT_TRUE(swingRegionActive(SwingDirection::Descending, 0.4, down.apexPhase()));
  EXPECT_FALSE(swingRegionActive(SwingDirection::Descending, 0.3, down.apexPhase()));
}

}  // namespace
