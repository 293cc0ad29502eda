// Terrain model: convex regions (half-planes, containment, heights on tilted planes),
// a flat floor and the step20 / stairs2 geometry built from boxes (region lookup on the
// floor, on the block, near the edges; ascending / descending swings; normals), the margin
// as a band around steps only (no gap between pieces of one floor, creases kept), bad
// input, allocation-free queries.
#include "rollstep/planning/terrain.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "common/alloc_counter.hpp"

namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;
using rollstep::planning::ConvexRegion;
using rollstep::planning::SwingDirection;
using rollstep::planning::TerrainBox;
using rollstep::planning::terrainFromBoxes;
using rollstep::planning::TerrainModel;

template <class F>
void expectThrowsNaming(F&& f, const std::string& what) {
  try {
    f();
    ADD_FAILURE() << "no exception, expected one naming " << what;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
  }
}

// Scene numbers of the reference scenes (robot/tachyon3.md), given as plain geometry.
const TerrainBox kFloor{-5.0, 10.0, -1.5, 1.5, 0.0};
const TerrainBox kStep20{1.0, 2.2, -1.5, 1.5, 0.20};

TEST(ConvexRegion, HalfPlanesOfASquareEitherOrientation) {
  const std::vector<Vector2d> ccw{{0, 0}, {2, 0}, {2, 1}, {0, 1}};
  const std::vector<Vector2d> cw(ccw.rbegin(), ccw.rend());
  EXPECT_EQ(rollstep::planning::signedPolygonArea(ccw), 2.0);
  EXPECT_EQ(rollstep::planning::signedPolygonArea(cw), -2.0);
  for (const auto& v : {ccw, cw}) {
    const ConvexRegion r = ConvexRegion::fromPolygon(v, 0.3);
    ASSERT_EQ(r.A.rows(), 4);
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(r.A.row(k).norm(), 1.0, 1e-15);
    EXPECT_NEAR(r.margin({1.0, 0.5}), 0.5, 1e-12);
    EXPECT_NEAR(r.margin({1.9, 0.5}), 0.1, 1e-12);
    EXPECT_NEAR(r.margin({2.5, 0.5}), -0.5, 1e-12);
    EXPECT_TRUE(r.contains({0.0, 0.0}));
    EXPECT_FALSE(r.contains({-0.01, 0.5}));
    EXPECT_NEAR(r.distance({3.0, 2.0}), std::sqrt(2.0), 1e-12);
    EXPECT_EQ(r.distance({1.0, 0.5}), 0.0);
    EXPECT_TRUE(r.centroid.isApprox(Vector2d(1.0, 0.5)));
    EXPECT_EQ(r.area(), 2.0);  // stored counter-clockwise
    // A p + b >= 0 row by row.
    const Eigen::VectorXd in = r.A * Vector2d(1.0, 0.5) + r.b;
    EXPECT_GT(in.minCoeff(), 0.0);
  }
}

TEST(ConvexRegion, TiltedPlaneHeight) {
  // A 10 degree ramp rising along +x.
  const double a = 10.0 * M_PI / 180.0;
  const Vector3d n(-std::sin(a), 0.0, std::cos(a));
  const ConvexRegion r =
      ConvexRegion::fromPolygon({{0, -1}, {2, -1}, {2, 1}, {0, 1}}, 0.5, 2.0 * n);
  EXPECT_NEAR(r.normal.norm(), 1.0, 1e-15);
  EXPECT_NEAR(r.heightAt({1.0, 0.3}), 0.5, 1e-12);
  EXPECT_NEAR(r.heightAt({2.0, 0.0}), 0.5 + std::tan(a), 1e-12);
  EXPECT_NEAR(r.heightAt({0.0, 0.0}), 0.5 - std::tan(a), 1e-12);
}

TEST(ConvexRegion, BadPolygonsThrow) {
  expectThrowsNaming([] { ConvexRegion::fromPolygon({}, 0.0); }, "vertices.size() = 0");
  expectThrowsNaming(
      [] {
        ConvexRegion::fromPolygon({{0, 0}, {1, 0}}, 0.0);
      },
      "vertices.size() = 2");
  // An L shape: non-convex at the reflex corner (1, 1).
  expectThrowsNaming(
      [] {
        ConvexRegion::fromPolygon({{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}}, 0.0);
      },
      "not convex");
  // A pentagram winds twice.
  std::vector<Vector2d> star;
  for (int k = 0; k < 5; ++k) {
    const double t = 2.0 * M_PI * (2 * k) / 5.0;
    star.emplace_back(std::cos(t), std::sin(t));
  }
  expectThrowsNaming([&] { ConvexRegion::fromPolygon(star, 0.0); }, "not convex");
  const std::vector<Vector2d> sq{{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  expectThrowsNaming([&] { ConvexRegion::fromPolygon(sq, 0.0, Vector3d::Zero()); },
                     "normal = (0, 0, 0)");
  expectThrowsNaming([&] { ConvexRegion::fromPolygon(sq, 0.0, Vector3d(1, 0, 0)); }, "normal");
  expectThrowsNaming([&] { ConvexRegion::fromPolygon(sq, std::nan("")); }, "height = nan");
  expectThrowsNaming(
      [] {
        ConvexRegion::fromPolygon({{0, 0}, {1, 0}, {std::numeric_limits<double>::quiet_NaN(), 1}},
                                  0.0);
      },
      "vertices[2]");
  expectThrowsNaming(
      [] {
        ConvexRegion::fromPolygon({{0, 0}, {1, 0}, {1, 0}, {0, 1}}, 0.0);
      },
      "vertices[2]");
  expectThrowsNaming([] { ConvexRegion::fromPolygon({{0, 0}, {1, 0}, {2, 0}}, 0.0); }, "zero area");
}

TEST(TerrainModel, FlatFloorIsOneRegion) {
  const TerrainModel t = terrainFromBoxes(kFloor, 0.0, {});
  ASSERT_EQ(t.size(), 1);
  EXPECT_EQ(t.regionAt({0.0, 0.0}), 0);
  EXPECT_EQ(t.heightAt({3.0, -1.0}), 0.0);
  EXPECT_TRUE(t.region(0).normal.isApprox(Vector3d::UnitZ()));
  EXPECT_EQ(t.classifySwing({0, 0}, {0.3, 0}), SwingDirection::Level);
  EXPECT_EQ(t.swingRegion({0, 0}, {0.3, 0}), -1);
  // Outside the floor: the nearest region.
  EXPECT_EQ(t.regionAt({20.0, 0.0}), 0);
  EXPECT_EQ(TerrainModel().regionAt({0, 0}), -1);
  EXPECT_EQ(TerrainModel().heightAt({0, 0}, -7.0), -7.0);
}

TEST(TerrainModel, Step20Block) {
  const TerrainModel t = terrainFromBoxes(kFloor, 0.0, {kStep20});
  ASSERT_EQ(t.size(), 3);  // floor before, block top, floor after
  const int before = t.regionAt({0.0, 0.0});
  const int block = t.regionAt({1.6, 0.5});
  const int after = t.regionAt({3.0, -0.5});
  EXPECT_NE(before, block);
  EXPECT_NE(after, block);
  EXPECT_NE(before, after);
  EXPECT_DOUBLE_EQ(t.region(block).height, 0.20);
  EXPECT_DOUBLE_EQ(t.heightAt({1.6, 0.5}), 0.20);
  EXPECT_DOUBLE_EQ(t.heightAt({0.5, 0.5}), 0.0);
  // Near the edge at x = 1.0: each side gets its own region.
  EXPECT_EQ(t.regionAt({0.99, 0.0}), before);
  EXPECT_EQ(t.regionAt({1.01, 0.0}), block);
  EXPECT_EQ(t.regionAt({2.19, 0.0}), block);
  EXPECT_EQ(t.regionAt({2.21, 0.0}), after);
  // On the edge itself both contain the point: the higher surface wins.
  EXPECT_EQ(t.regionAt({1.0, 0.0}), block);
  // The block region's half-planes: its front edge row is x >= 1.0.
  EXPECT_NEAR(t.region(block).margin({1.05, 0.0}), 0.05, 1e-12);
  for (const auto& r : t.regions()) EXPECT_TRUE(r.normal.isApprox(Vector3d::UnitZ()));
  // Up the front edge, down the back edge, level on top.
  EXPECT_EQ(t.classifySwing({0.85, 0.2}, {1.15, 0.2}), SwingDirection::Ascending);
  EXPECT_EQ(t.swingRegion({0.85, 0.2}, {1.15, 0.2}), before);
  EXPECT_EQ(t.classifySwing({2.05, 0.2}, {2.35, 0.2}), SwingDirection::Descending);
  EXPECT_EQ(t.swingRegion({2.05, 0.2}, {2.35, 0.2}), after);
  EXPECT_EQ(t.classifySwing({1.2, 0.2}, {1.5, 0.2}), SwingDirection::Level);
}

TEST(TerrainModel, MarginKeepsFeetOffTheEdgeAndGapsGoToTheNearest) {
  const TerrainModel t = terrainFromBoxes(kFloor, 0.0, {kStep20}, 0.05);
  const int block = t.regionAt({1.6, 0.0});
  EXPECT_NEAR(t.region(block).margin({1.05, 0.0}), 0.0, 1e-12);
  // 2 cm before the edge: in the gap of the floor's shrunk region (3 cm away) and the
  // block's (7 cm): the floor.
  const int near = t.regionAt({0.98, 0.0});
  EXPECT_DOUBLE_EQ(t.region(near).height, 0.0);
  EXPECT_FALSE(t.region(near).contains({0.98, 0.0}));
  EXPECT_EQ(t.regionAt({1.04, 0.0}), block);
  expectThrowsNaming([] { terrainFromBoxes(kFloor, 0.0, {kStep20}, 0.7); }, "margin = 0.7");
  // The error names the surface too narrow for the margin (the 1.2 m block top).
  expectThrowsNaming([] { terrainFromBoxes(kFloor, 0.0, {kStep20}, 0.7); },
                     "the surface at height 0.2 m over x [1, 2.2], y [-1.5, 1.5] m");
}

TEST(TerrainModel, Stairs2AndPartialWidthBoxes) {
  // stairs2: 0.20 m rise at x = 1, 1.2 m landing, 0.165 m rise onto a 1.5 m top.
  const TerrainModel t =
      terrainFromBoxes(kFloor, 0.0, {{1.0, 4.7, -1.5, 1.5, 0.20}, {2.2, 3.7, -1.5, 1.5, 0.365}});
  EXPECT_EQ(t.size(), 5);  // floor, 0.20, 0.365, 0.20, floor
  EXPECT_DOUBLE_EQ(t.heightAt({0.5, 0}), 0.0);
  EXPECT_DOUBLE_EQ(t.heightAt({1.5, 0}), 0.20);
  EXPECT_DOUBLE_EQ(t.heightAt({3.0, 0}), 0.365);
  EXPECT_DOUBLE_EQ(t.heightAt({4.0, 0}), 0.20);
  EXPECT_EQ(t.classifySwing({2.1, 0}, {2.3, 0}), SwingDirection::Ascending);
  EXPECT_EQ(t.classifySwing({3.6, 0}, {3.8, 0}), SwingDirection::Descending);
  // A box narrower than the floor: the floor around it is cut into convex pieces that
  // cover every floor point exactly once.
  const TerrainModel u = terrainFromBoxes(kFloor, 0.0, {{1.0, 2.0, -0.5, 0.5, 0.1}});
  EXPECT_EQ(u.size(), 5);
  // A grid that avoids the cut lines (points on them belong to both sides).
  for (int i = 0; i < 150; ++i) {
    for (int j = 0; j < 30; ++j) {
      const double x = -4.95 + 0.1 * i, y = -1.45 + 0.1 * j;
      int containing = 0;
      for (const auto& r : u.regions()) containing += r.margin({x, y}) > 1e-9 ? 1 : 0;
      const bool on_box = x > 1.0 && x < 2.0 && y > -0.5 && y < 0.5;
      EXPECT_LE(containing, 1);
      EXPECT_DOUBLE_EQ(u.heightAt({x, y}), on_box ? 0.1 : 0.0) << x << " " << y;
    }
  }
}

TEST(TerrainModel, EdgesThatDifferByRoundingAreOneEdge) {
  // stairs2 built as the scene builds it: the lower block's end a + (l1 + l2), the top's
  // (a + l1) + l2, which differ in the last bit for about half of all a. Between them was a
  // region of zero width, which a margin then emptied (an error: half of the randomized
  // stairs2 trials failed before they started).
  const double a = 1.0452, l1 = 1.2, l2 = 1.5;
  ASSERT_NE(a + (l1 + l2), (a + l1) + l2);
  const std::vector<TerrainBox> boxes{{a, a + (l1 + l2), -1.5, 1.5, 0.2},
                                      {a + l1, (a + l1) + l2, -1.5, 1.5, 0.365}};
  for (const double margin : {0.0, 0.085}) {
    const TerrainModel t = terrainFromBoxes(kFloor, 0.0, boxes, margin);
    EXPECT_EQ(t.size(), 4) << margin;  // floor, 0.20, 0.365, floor (no landing behind the top)
    EXPECT_DOUBLE_EQ(t.heightAt({a + l1 + l2 - 0.3, 0.0}), 0.365);
    EXPECT_DOUBLE_EQ(t.heightAt({a + l1 + l2 + 0.3, 0.0}), 0.0);
  }
  // Edges 1 mm apart stay two edges: a real 1 mm strip of floor between two blocks, which
  // any margin above 0.5 mm takes away (no foot fits there) while the floor stays.
  const std::vector<TerrainBox> slot{{1.0, 2.0, -1.5, 1.5, 0.2}, {2.001, 3.0, -1.5, 1.5, 0.2}};
  const TerrainModel strip = terrainFromBoxes(kFloor, 0.0, slot);
  EXPECT_EQ(strip.size(), 5);  // floor, block, the 1 mm floor strip, block, floor
  EXPECT_DOUBLE_EQ(strip.heightAt({2.0005, 0.0}), 0.0);
  const TerrainModel closed = terrainFromBoxes(kFloor, 0.0, slot, 0.001);
  EXPECT_EQ(closed.size(), 4);
  for (const auto& r : closed.regions()) EXPECT_FALSE(r.contains({2.0005, 0.0}));
}

/// Largest distance along x or y from p to the rectangle of b (0 inside).
double boxDistance(const TerrainBox& b, const Vector2d& p) {
  const double dx = std::max({b.x_min - p.x(), 0.0, p.x() - b.x_max});
  const double dy = std::max({b.y_min - p.y(), 0.0, p.y() - b.y_max});
  return std::max(dx, dy);
}

// A block narrower than the floor: the floor around it is cut into convex pieces, and the
// margin keeps feet off the block's edges only. Pieces of the floor beside the block meet
// with no gap (once each piece was shrunk along the block's side lines, leaving a strip of
// level floor 2 margins wide with no foothold, where a robot walking sideways fell), and
// the step edges are still a margin away on both sides.
TEST(TerrainModel, FloorBesideABlockHasNoGapAndStepsKeepTheirMargin) {
  const TerrainBox floor{-5.0, 10.0, -5.0, 5.0, 0.0};
  const double m = 0.095;  // Tachyon 3's wheel radius + 1 cm
  for (const std::vector<TerrainBox>& boxes :
       {std::vector<TerrainBox>{kStep20},
        // stairs2, and a second block standing off to the side of the first
        std::vector<TerrainBox>{{1.0, 4.7, -1.5, 1.5, 0.20}, {2.2, 3.7, -1.5, 1.5, 0.365}},
        std::vector<TerrainBox>{kStep20, {3.0, 4.0, 0.5, 2.5, 0.1}}}) {
    SCOPED_TRACE(boxes.size() == 1 ? "step20" : boxes[1].top > 0.2 ? "stairs2" : "two blocks");
    const TerrainModel t = terrainFromBoxes(floor, 0.0, boxes, m);
    const auto seen = [&](const Vector2d& p) {
      double h = 0.0;
      for (const TerrainBox& c : boxes) {
        if (boxDistance(c, p) == 0.0) h = std::max(h, c.top);
      }
      return h;
    };
    // Whether the seen height changes within `r` of p along x, y or a diagonal.
    const auto stepWithin = [&](const Vector2d& p, double r) {
      for (const double dx : {-r, 0.0, r}) {
        for (const double dy : {-r, 0.0, r}) {
          if (std::abs(seen(p + Vector2d(dx, dy)) - seen(p)) > 1e-3) return true;
        }
      }
      return false;
    };
    int floor_points = 0, edge_points = 0;
    for (double x = -4.9; x < 9.9; x += 0.0237) {
      for (double y = -4.9; y < 4.9; y += 0.0191) {
        const Vector2d p(x, y);
        int containing = 0;
        for (const auto& r : t.regions()) containing += r.margin(p) > 1e-9 ? 1 : 0;
        if (!stepWithin(p, m)) {
          // Every point a margin clear of the steps is in one region, at its own height.
          ASSERT_EQ(containing, 1) << x << " " << y;
          EXPECT_DOUBLE_EQ(t.heightAt(p), seen(p)) << x << " " << y;
          floor_points += seen(p) == 0.0 ? 1 : 0;
        }
        if (stepWithin(p, 0.9 * m)) {
          EXPECT_EQ(containing, 0) << x << " " << y;  // nearer a step than the margin
          ++edge_points;
        }
      }
    }
    EXPECT_GT(floor_points, 200000);
    EXPECT_GT(edge_points, 2000);
  }
  // The points where the robot fell: the floor beside step20's block and after it, by the
  // line of its sides, 2 cm either side of it.
  const TerrainModel t = terrainFromBoxes(floor, 0.0, {kStep20}, m);
  for (const Vector2d& p : {Vector2d(1.6, 1.5 + m + 0.02), Vector2d(3.0, 1.48), Vector2d(3.0, 1.52),
                            Vector2d(0.5, 1.48), Vector2d(0.5, 1.52), Vector2d(3.0, -1.5)}) {
    const int r = t.regionAt(p);
    ASSERT_GE(r, 0);
    EXPECT_TRUE(t.region(r).contains(p)) << p.transpose();
    EXPECT_EQ(t.region(r).height, 0.0) << p.transpose();
  }
  // The step edges: the block top and the floor before it each end a margin away.
  const ConvexRegion& top = t.region(t.regionAt({1.6, 0.0}));
  EXPECT_EQ(top.height, 0.2);
  EXPECT_NEAR(top.margin({1.0 + m, 0.0}), 0.0, 1e-12);
  EXPECT_NEAR(top.margin({1.6, 1.5 - m}), 0.0, 1e-12);
  EXPECT_NEAR(t.region(t.regionAt({0.5, 0.0})).margin({1.0 - m, 0.0}), 0.0, 1e-12);
  EXPECT_FALSE(t.region(t.regionAt({0.95, 0.0})).contains({0.95, 0.0}));
  EXPECT_FALSE(t.region(t.regionAt({1.6, 1.55})).contains({1.6, 1.55}));
}

// A ramp rising from the floor (slope 0.1 along +x from x = 1): where it meets the floor the
// height is continuous, a crease and no step, so no band there; its sides and high end are
// steps. A bad surface is refused naming it.
TEST(TerrainModel, SurfacesKeepTheirStepsOffButNotTheirCreases) {
  using rollstep::planning::terrainFromSurfaces;
  using rollstep::planning::TerrainSurface;
  const TerrainBox floor{-5.0, 10.0, -5.0, 5.0, 0.0};
  const TerrainSurface ramp{{{1.0, -1.0}, {3.0, -1.0}, {3.0, 1.0}, {1.0, 1.0}},
                            Vector3d(1.0, 0.0, 0.0),
                            Vector3d(-0.1, 0.0, 1.0).normalized()};
  const double m = 0.05;
  const TerrainModel t = terrainFromSurfaces(floor, 0.0, {ramp}, m);
  const auto inside = [&](const Vector2d& p) {
    const int r = t.regionAt(p);
    return r >= 0 && t.region(r).contains(p);
  };
  for (const Vector2d& p : {Vector2d(0.98, 0.0), Vector2d(1.02, 0.0), Vector2d(1.0 + 1e-3, 0.5)}) {
    EXPECT_TRUE(inside(p)) << p.transpose();  // either side of the crease
  }
  EXPECT_NEAR(t.heightAt({1.02, 0.0}), 0.002, 1e-12);
  EXPECT_NEAR(t.heightAt({2.5, 0.3}), 0.15, 1e-12);
  EXPECT_DOUBLE_EQ(t.heightAt({0.98, 0.0}), 0.0);
  for (const Vector2d& p :
       {Vector2d(2.0, 0.97), Vector2d(2.0, 1.03), Vector2d(2.97, 0.0), Vector2d(3.03, 0.0)}) {
    EXPECT_FALSE(inside(p)) << p.transpose();  // a side or the high end: a step
  }
  EXPECT_TRUE(inside({2.0, 1.0 + m + 1e-3}));  // the floor beside it
  EXPECT_TRUE(inside({3.0 + m + 1e-3, 0.0}));  // and after it
  expectThrowsNaming(
      [&] {
        TerrainSurface bent = ramp;
        std::swap(bent.footprint[1], bent.footprint[2]);  // self-intersecting
        terrainFromSurfaces(floor, 0.0, {ramp, bent});
      },
      "surfaces[1].footprint");
  expectThrowsNaming(
      [&] {
        TerrainSurface down = ramp;
        down.normal = Vector3d(0.0, 0.0, -1.0);
        terrainFromSurfaces(floor, 0.0, {down});
      },
      "surfaces[0].normal");
  expectThrowsNaming(
      [&] {
        TerrainSurface far = ramp;
        far.point.x() = std::numeric_limits<double>::infinity();
        terrainFromSurfaces(floor, 0.0, {far});
      },
      "surfaces[0].point");
  expectThrowsNaming([&] { terrainFromSurfaces(floor, 0.0, {ramp}, -1.0); }, "margin = -1");
}

// A ramp (slope 0.1 from x = 1) meant to end on the edge of a 0.2 m block at x = 3, written
// with a few digits: it ends 3 um short of the block or 3 um under it. Either way the wheel
// rolls from one onto the other: no step band at the seam (the ramp's region reaches the
// block's, within the hairline), no floor region in the gap; the block's far end and the
// ramp's sides stay steps.
TEST(TerrainModel, AHairlineGapBetweenSurfacesThatMeetIsNoStep) {
  using rollstep::planning::terrainFromSurfaces;
  using rollstep::planning::TerrainSurface;
  const TerrainBox floor{-5.0, 10.0, -5.0, 5.0, 0.0};
  const double m = 0.05;
  for (const double ramp_end : {3.0 - 3e-6, 3.0 + 3e-6}) {
    const TerrainSurface ramp{{{1.0, -1.0}, {ramp_end, -1.0}, {ramp_end, 1.0}, {1.0, 1.0}},
                              Vector3d(1.0, 0.0, 0.0),
                              Vector3d(-0.1, 0.0, 1.0).normalized()};
    const TerrainSurface block{{{3.0, -1.0}, {4.0, -1.0}, {4.0, 1.0}, {3.0, 1.0}},
                               Vector3d(3.5, 0.0, 0.2),
                               Vector3d::UnitZ()};
    const TerrainModel t = terrainFromSurfaces(floor, 0.0, {ramp, block}, m);
    const auto inside = [&](const Vector2d& p) {
      const int r = t.regionAt(p);
      return r >= 0 && t.region(r).contains(p);
    };
    for (const Vector2d& p : {Vector2d(2.97, 0.0), Vector2d(3.0 - 1e-5, 0.5), Vector2d(3.03, 0.0),
                              Vector2d(3.0 + 1e-5, -0.5)}) {
      EXPECT_TRUE(inside(p)) << "ramp end " << ramp_end << ": " << p.transpose();
    }
    EXPECT_NEAR(t.heightAt({2.97, 0.0}), 0.197, 1e-9);
    EXPECT_NEAR(t.heightAt({3.03, 0.0}), 0.2, 1e-12);
    EXPECT_NEAR(t.heightAt({3.0, 0.3}), 0.2, 1e-5);  // never the floor in the gap
    for (const Vector2d& p : {Vector2d(3.97, 0.0), Vector2d(2.0, 0.97), Vector2d(3.5, 0.97)}) {
      EXPECT_FALSE(inside(p)) << "ramp end " << ramp_end << ": " << p.transpose();
    }
  }
}

TEST(TerrainModel, BadBoxesThrow) {
  expectThrowsNaming([] { terrainFromBoxes({0, 0, -1, 1, 0}, 0.0, {}); }, "floor.x_max = 0");
  expectThrowsNaming([] { terrainFromBoxes(kFloor, std::numeric_limits<double>::quiet_NaN(), {}); },
                     "floor.top = nan");
  expectThrowsNaming(
      [] {
        terrainFromBoxes(kFloor, 0.0, {kStep20, {1, 2, 1, -1, 0.1}});
      },
      "boxes[1].y_max = -1");
  expectThrowsNaming(
      [] {
        terrainFromBoxes(kFloor, 0.0, {{1, 2, -1, 1, std::numeric_limits<double>::infinity()}});
      },
      "boxes[0].top = inf");
  expectThrowsNaming([] { terrainFromBoxes(kFloor, 0.0, {}, -0.1); }, "margin = -0.1");
}

TEST(TerrainModel, EnvelopeHeightEqualsADenseSearch) {
  // Stairs of shrunk regions and a sloped region: the exact envelope against a search over
  // 1 mm steps of the same definition, along several directions.
  std::vector<ConvexRegion> regions =
      terrainFromBoxes(kFloor, 0.0, {kStep20, {1.6, 2.2, -1.5, 1.5, 0.365}}, 0.085).regions();
  regions.push_back(ConvexRegion::fromPolygon({{3.0, -1.0}, {4.0, -1.0}, {4.0, 1.0}, {3.0, 1.0}},
                                              0.1, Vector3d(-0.2, 0.1, 1.0)));
  const TerrainModel t(regions);
  const auto dense = [&](const Vector2d& p, const Vector2d& e, double reach, double slope) {
    double best = t.heightAt(p);
    for (double d = -4.0; d <= 4.0; d += 1e-3) {
      const Vector2d q = p + d * e;
      double h = -1e9;
      for (const ConvexRegion& r : t.regions()) {
        if (r.contains(q)) h = std::max(h, r.heightAt(q));
      }
      best = std::max(best, h - slope * std::max(std::abs(d) - reach, 0.0));
    }
    return best;
  };
  for (const Vector2d& p : {Vector2d(0.5, 0.0), Vector2d(0.95, 0.3), Vector2d(1.9, -0.2),
                            Vector2d(2.6, 0.1), Vector2d(3.5, 0.0)}) {
    for (const double angle : {0.0, 0.4, M_PI, -2.0}) {
      const Vector2d e(std::cos(angle), std::sin(angle));
      for (const double reach : {0.0, 0.25}) {
        const double slope = 0.5;
        EXPECT_NEAR(t.envelopeHeight(p, e, reach, slope), dense(p, e, reach, slope), 1e-3)
            << "p (" << p.transpose() << ") angle " << angle << " reach " << reach;
      }
    }
  }
  // Without distance the heights under p only; a step 0.3 m ahead with reach 0.25 and grade
  // 0.5: 0.2 - 0.5 * 0.05.
  EXPECT_NEAR(t.envelopeHeight({0.5, 0.0}, {1.0, 0.0}, 0.0, 0.0), 0.0, 1e-12);
  EXPECT_NEAR(t.envelopeHeight({1.085 - 0.3, 0.0}, {1.0, 0.0}, 0.25, 0.5), 0.175, 1e-12);
}

TEST(TerrainModel, RegionAheadCrossesAGapAlongTheTravel) {
  const TerrainModel t = terrainFromBoxes(kFloor, 0.0, {kStep20}, 0.085);
  const int floor = t.regionAt({0.5, 0.0}), block = t.regionAt({1.5, 0.0});
  const int beyond = t.regionAt({2.5, 0.0});
  ASSERT_NE(floor, block);
  // In the gap [0.915, 1.085], 1 cm past the floor region: nearest is the floor; ahead
  // (forward, reach 0.2) the block; backwards the floor; too short a reach: the nearest.
  EXPECT_EQ(t.regionAt({0.925, 0.0}), floor);
  EXPECT_EQ(t.regionAhead({0.925, 0.0}, {1.0, 0.0}, 0.2), block);
  EXPECT_EQ(t.regionAhead({0.925, 0.0}, {-1.0, 0.0}, 0.2), floor);
  EXPECT_EQ(t.regionAhead({0.925, 0.0}, {1.0, 0.0}, 0.1), floor);
  // Inside a region: that region, whatever the direction.
  EXPECT_EQ(t.regionAhead({0.9, 0.0}, {1.0, 0.0}, 0.2), floor);
  // Stepping down: the floor beyond the block.
  EXPECT_EQ(t.regionAhead({2.13, 0.0}, {1.0, 0.0}, 0.2), beyond);
  EXPECT_EQ(t.regionAhead({2.13, 0.0}, {-1.0, 0.0}, 0.2), block);
}

TEST(TerrainModel, QueriesDoNotAllocate) {
  const TerrainModel t = terrainFromBoxes(kFloor, 0.0, {kStep20}, 0.02);
  rollstep::test::AllocationGuard guard;
  double sum = 0.0;
  for (double x = -1.0; x < 4.0; x += 0.01) {
    sum += t.heightAt({x, 0.1});
    sum += t.swingRegion({x, 0.0}, {x + 0.3, 0.0});
    sum += static_cast<int>(t.classifySwing({x, 0.0}, {x + 0.3, 0.0}));
    sum += t.envelopeHeight({x, 0.0}, {1.0, 0.0}, 0.25, 0.5);
    sum += t.regionAhead({x, 0.0}, {1.0, 0.0}, 0.2);
  }
  EXPECT_EQ(guard.count(), 0u);
  EXPECT_NE(sum, 0.0);  // the queries ran
}

// Shrinking (the foothold regions of a perceived terrain): every edge moves inwards by the
// margin, heights follow a tilted plane, an edge shorter than the shrink vanishes, a region
// the margin empties is dropped; swap exchanges without allocating.
TEST(TerrainModel, ShrinkMovesEveryEdgeInwardsAndDropsVanishedRegions) {
  const Vector3d tilt = Vector3d(0.0, -std::sin(0.1), std::cos(0.1));  // rises along +y
  const ConvexRegion square =
      ConvexRegion::fromPolygon({{0, 0}, {1, 0}, {1, 1}, {0, 1}}, 0.3, tilt);
  // A pentagon whose short top-right edge (length 0.02 * sqrt 2) vanishes under 0.1.
  const ConvexRegion cut =
      ConvexRegion::fromPolygon({{2, 0}, {3, 0}, {3, 0.98}, {2.98, 1}, {2, 1}}, 0.0);
  const ConvexRegion thin = ConvexRegion::fromPolygon({{5, 0}, {5.15, 0}, {5.15, 1}, {5, 1}}, 0.0);
  const TerrainModel terrain({square, cut, thin});
  const TerrainModel shrunk = rollstep::planning::shrinkTerrain(terrain, 0.1);
  ASSERT_EQ(shrunk.size(), 2);  // the 0.15 m wide strip is gone
  const ConvexRegion& s = shrunk.region(0);
  ASSERT_EQ(s.vertices.size(), 4u);
  for (const Vector2d& v : s.vertices) {
    EXPECT_NEAR(std::min(v.x(), 1.0 - v.x()), 0.1, 1e-12);
    EXPECT_NEAR(std::min(v.y(), 1.0 - v.y()), 0.1, 1e-12);
  }
  // Same plane: heights agree wherever both are defined.
  for (const Vector2d& p : {Vector2d(0.5, 0.5), Vector2d(0.2, 0.8), Vector2d(0.9, 0.1)}) {
    EXPECT_NEAR(s.heightAt(p), square.heightAt(p), 1e-12);
  }
  EXPECT_NEAR(s.normal.dot(tilt), 1.0, 1e-12);
  // The pentagon: its far edges at 0.1 from the old ones, the corner cut gone.
  const ConvexRegion& c = shrunk.region(1);
  EXPECT_TRUE(c.contains({2.1 + 1e-9, 0.1 + 1e-9}));
  EXPECT_TRUE(c.contains({2.9 - 1e-6, 0.9 - 1e-6}) || c.vertices.size() == 5u);
  for (const Vector2d& v : c.vertices) {
    EXPECT_GE(cut.margin(v), 0.1 - 1e-9) << v.transpose();
  }
  EXPECT_LE(c.vertices.size(), 5u);
  // A vertex on a straight edge does not survive the shrink (no more edges than needed).
  const ConvexRegion five =
      ConvexRegion::fromPolygon({{0, 0}, {0.5, 0}, {1, 0}, {1, 1}, {0, 1}}, 0.0);
  ASSERT_EQ(five.A.rows(), 5);
  const TerrainModel s5 = rollstep::planning::shrinkTerrain(TerrainModel({five}), 0.1);
  ASSERT_EQ(s5.size(), 1);
  EXPECT_EQ(s5.region(0).vertices.size(), 4u);
  EXPECT_EQ(s5.maxEdges(), 4);
  // Margin 0 changes nothing; a bad margin throws.
  const TerrainModel same = rollstep::planning::shrinkTerrain(terrain, 0.0);
  ASSERT_EQ(same.size(), 3);
  EXPECT_NEAR(same.region(0).margin({0.5, 0.5}), 0.5, 1e-12);
  expectThrowsNaming([&] { rollstep::planning::shrinkTerrain(terrain, -0.1); }, "margin");
  expectThrowsNaming(
      [&] { rollstep::planning::shrinkTerrain(terrain, std::numeric_limits<double>::quiet_NaN()); },
      "margin");

  TerrainModel a = terrain, b = shrunk;
  EXPECT_EQ(a.maxEdges(), 5);
  rollstep::test::AllocationGuard guard;
  a.swap(b);
  EXPECT_EQ(guard.count(), 0u);
  EXPECT_EQ(a.size(), 2);
  EXPECT_EQ(b.size(), 3);
}

// Seams: two pieces of one floor keep the edges they share (no gap opens in the middle of
// the floor); the same pieces at different heights (a step) shrink on both sides.
TEST(TerrainModel, ShrinkKeepsSeamsBetweenPiecesOfOneSurface) {
  for (const double rise : {0.0, 0.1}) {
    const ConvexRegion left = ConvexRegion::fromPolygon({{0, 0}, {1, 0}, {1, 1}, {0, 1}}, 0.0);
    const ConvexRegion right =
        ConvexRegion::fromPolygon({{1.02, -0.2}, {2, -0.2}, {2, 1.2}, {1.02, 1.2}}, rise);
    const TerrainModel shrunk =
        rollstep::planning::shrinkTerrain(TerrainModel({left, right}), 0.1, 0.04, 0.02);
    ASSERT_EQ(shrunk.size(), 2);
    const ConvexRegion& l = shrunk.region(0);
    const ConvexRegion& r = shrunk.region(1);
    double l_max_x = -1, r_min_x = 10;
    for (const Vector2d& v : l.vertices) l_max_x = std::max(l_max_x, v.x());
    for (const Vector2d& v : r.vertices) r_min_x = std::min(r_min_x, v.x());
    if (rise == 0.0) {
      EXPECT_NEAR(l_max_x, 1.0, 1e-12) << "the seam of the left piece moved";
      // The right piece is longer than the left: its left edge is not covered all along.
      EXPECT_NEAR(r_min_x, 1.12, 1e-12);
      // A foot anywhere on the floor between the pieces is inside one of them.
      EXPECT_TRUE(l.contains({0.99, 0.5}));
      EXPECT_TRUE(r.contains({1.13, 0.5}));
    } else {
      EXPECT_NEAR(l_max_x, 0.9, 1e-12);
      EXPECT_NEAR(r_min_x, 1.12, 1e-12);
    }
    // The other edges moved in.
    for (const Vector2d& v : l.vertices) {
      EXPECT_NEAR(std::min(v.y(), 1.0 - v.y()), 0.1, 1e-12);
    }
  }
  expectThrowsNaming([] { rollstep::planning::shrinkTerrain(TerrainModel(), 0.1, -1.0); },
                     "seam_probe");
}

// Levelling (measured terrains): floor pieces a few millimetres apart and slightly tilted
// become one level height (area-weighted), so swings between them are level; a step stays a
// step and a real slope stays a slope.
TEST(TerrainModel, LevelTerrainMergesNoisyFloorPiecesButKeepsStepsAndSlopes) {
  const Vector3d tiny_tilt = Vector3d(0.01, 0.0, 1.0).normalized();       // 0.57 deg
  const Vector3d slope = Vector3d(-std::sin(0.17), 0.0, std::cos(0.17));  // 10 deg
  const TerrainModel terrain({
      ConvexRegion::fromPolygon({{0, 0}, {1, 0}, {1, 1}, {0, 1}}, 0.002, tiny_tilt),  // 1 m^2
      ConvexRegion::fromPolygon({{1, 0}, {2, 0}, {2, 3}, {1, 3}}, -0.002),            // 3 m^2
      ConvexRegion::fromPolygon({{2, 0}, {3, 0}, {3, 1}, {2, 1}}, 0.2),               // a step
      ConvexRegion::fromPolygon({{3, 0}, {4, 0}, {4, 1}, {3, 1}}, 0.3, slope),
  });
  EXPECT_EQ(terrain.classifySwing({0.5, 0.5}, {1.5, 0.5}), SwingDirection::Descending);
  const TerrainModel level = rollstep::planning::levelTerrain(terrain, 2.0 * M_PI / 180.0, 0.01);
  ASSERT_EQ(level.size(), 4);
  const double merged = (1.0 * 0.002 + 3.0 * -0.002) / 4.0;
  EXPECT_NEAR(level.region(0).height, merged, 1e-12);
  EXPECT_NEAR(level.region(1).height, merged, 1e-12);
  EXPECT_EQ(level.region(0).normal, Vector3d::UnitZ());
  EXPECT_EQ(level.classifySwing({0.5, 0.5}, {1.5, 0.5}), SwingDirection::Level);
  EXPECT_DOUBLE_EQ(level.region(2).height, 0.2);
  EXPECT_EQ(level.classifySwing({1.5, 0.5}, {2.5, 0.5}), SwingDirection::Ascending);
  EXPECT_EQ(level.region(3).normal, terrain.region(3).normal);  // 10 deg: kept
  EXPECT_EQ(level.region(0).vertices, terrain.region(0).vertices);
  expectThrowsNaming([&] { rollstep::planning::levelTerrain(terrain, -1.0, 0.01); }, "max_tilt");
  expectThrowsNaming([&] { rollstep::planning::levelTerrain(terrain, 0.1, -0.01); },
                     "height_tolerance");
}

}  // namespace
