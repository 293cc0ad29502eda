// The stages of the plane segmentation one at a time, on exact synthetic elevation maps
// (no noise: every figure is known) or on labels set by hand: step edges and local fits
// at a step, region growing at a crease, grow-back to the step, joining a strip to its
// floor, hole filling, and the workspace pattern (the per-cell stages allocate nothing once
// sized).
#include "segmentation_stages.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "common/alloc_counter.hpp"
#include "perception/synthetic_terrain.hpp"
#include "rollstep/perception/polygon.hpp"

namespace rollstep::perception {
namespace {

using namespace segmentation;

constexpr double kPi = 3.14159265358979323846;

/// Every cell of `map` (default: 200 x 200 cells of 2 cm) set to height(r, c).
template <class Height>
void setHeights(ElevationMap& map, Height height) {
  for (int r = 0; r < map.size(); ++r) {
    for (int c = 0; c < map.size(); ++c) map.setCell(r, c, static_cast<float>(height(r, c)), 1e-4f);
  }
}

/// Stage 1 on `map`: reference height, summed-area tables, step edges, local fits.
void localFits(const ElevationMap& map, const SegmentationSettings& s, Workspace& w,
               Segmentation& out) {
  beginSegmentation(map, w, out);
  referenceHeight(map, w);
  sumMeasuredCells(map, w);
  markStepEdges(map, s, w);
  fitLocalPlanes(map, s, w);
}

double tiltDeg(const Eigen::Vector3d& normal) { return std::acos(normal.z()) * 180.0 / kPi; }

// A 10 cm step at column 100 (x = 0): the cells on both sides of it are step edges and no
// other; the window fit (5 x 5) accepts the cells whose window lies on one side, with that
// side's height and a zero gradient, and rejects the four columns whose window spans the step.
TEST(SegmentationStages, AStepIsMarkedOnBothSidesAndTheLocalFitsStopAWindowShortOfIt) {
  ElevationMap map;
  const int n = map.size(), edge = n / 2;
  ASSERT_EQ(n, 200);
  setHeights(map, [&](int, int c) { return c < edge ? 0.0 : 0.1; });
  const SegmentationSettings s;
  const int hw = s.window_half;
  Workspace w;
  Segmentation out;
  localFits(map, s, w, out);
  int steps = 0, planar = 0;
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) {
      EXPECT_EQ(w.stepEdge(r, c), c == edge - 1 || c == edge) << r << ", " << c;
      steps += w.stepEdge(r, c) ? 1 : 0;
      // Away from the map's border, where every window is whole.
      if (r < hw || c < hw || r >= n - hw || c >= n - hw) continue;
      const auto i = static_cast<std::size_t>(r * n + c);
      const bool one_side = c + hw < edge || c - hw >= edge;
      ASSERT_EQ(w.planar[i] != 0, one_side) << r << ", " << c;
      if (!one_side) continue;
      ++planar;
      EXPECT_NEAR(w.fitted[i], c < edge ? 0.0 : 0.1, 1e-6);
      EXPECT_NEAR(w.gx[i], 0.0, 1e-5);
      EXPECT_NEAR(w.gy[i], 0.0, 1e-5);
    }
  }
  EXPECT_EQ(steps, 2 * n);
  EXPECT_EQ(planar, (n - 2 * hw) * (n - 2 * hw - 4));
}

// A floor (z = 0) and a 10 degree ramp rising from it at x = 0 with no step between them:
// only the normals separate them, and region growing gives two regions whose planes are the
// floor's and the ramp's.
TEST(SegmentationStages, AFloorAndARampFromItGrowIntoTwoRegionsWithTheirPlanes) {
  ElevationMap map;
  const int n = map.size(), edge = n / 2;
  const double res = map.resolution(), slope = std::tan(10.0 * kPi / 180.0);
  // Height of the ramp at the cell centre: 0 at x = 0 (the edge between columns 99, 100).
  setHeights(map, [&](int, int c) { return c < edge ? 0.0 : slope * (c + 0.5 - edge) * res; });
  const SegmentationSettings s;
  Workspace w;
  Segmentation out;
  localFits(map, s, w, out);
  growRegions(map, s, w, out);
  ASSERT_EQ(out.regions.size(), 2u);
  fitRegionPlanes(map, w, out);
  const int floor = out.label(n / 2, 20), ramp = out.label(n / 2, n - 20);
  ASSERT_GE(floor, 0);
  ASSERT_GE(ramp, 0);
  ASSERT_NE(floor, ramp);
  const PlanarRegion& f = out.regions[static_cast<std::size_t>(floor)];
  const PlanarRegion& g = out.regions[static_cast<std::size_t>(ramp)];
  EXPECT_NEAR(tiltDeg(f.normal), 0.0, 0.1);
  EXPECT_NEAR(tiltDeg(g.normal), 10.0, 0.1);
  EXPECT_LT(g.normal.x(), 0.0);  // rising in +x
  EXPECT_NEAR(std::abs(g.normal.y()), 0.0, 1e-6);
  EXPECT_NEAR(f.heightAt({-1.0, 0.3}), 0.0, 0.002);
  EXPECT_NEAR(g.heightAt({1.0, -0.3}), slope * 1.0, 0.002);
  // Every cell of a region lies on its side of the crease but for the window's width.
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) {
      const int l = out.label(r, c);
      if (l == floor) {
        EXPECT_LT(c, edge + s.window_half) << r << ", " << c;
      } else if (l == ramp) {
        EXPECT_GE(c, edge - s.window_half) << r << ", " << c;
      }
    }
  }
}

// At a 10 cm step the regions first stop where the window fit stops (a window's half-width
// short of it); grown back, each reaches the step and no further (the other side is off its
// plane), so the floor's polygon ends on
// x = 0, the top's begins there and the step edge's obstacle covers the cell on each side.
TEST(SegmentationStages, GrowBackMovesEachRegionsBoundaryOntoTheStep) {
  ElevationMap map;
  const int n = map.size(), edge = n / 2;
  const double res = map.resolution();
  setHeights(map, [&](int, int c) { return c < edge ? 0.0 : 0.1; });
  const SegmentationSettings s;
  const int hw = s.window_half;
  Workspace w;
  Segmentation out;
  localFits(map, s, w, out);
  growRegions(map, s, w, out);
  ASSERT_EQ(out.regions.size(), 2u);
  const int low = out.label(n / 2, 0), high = out.label(n / 2, n - 1);
  ASSERT_NE(low, high);
  EXPECT_EQ(out.label(n / 2, edge - hw - 1), low);
  EXPECT_EQ(out.label(n / 2, edge - hw), -1);
  EXPECT_EQ(out.label(n / 2, edge + hw - 1), -1);
  EXPECT_EQ(out.label(n / 2, edge + hw), high);
  fitRegionPlanes(map, w, out);
  growBack(map, s, w, out);
  // Every cell of the map now belongs to its side's region.
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) ASSERT_EQ(out.label(r, c), c < edge ? low : high) << r << ", " << c;
  }
  joinRegionsOnPlanes(map, s, w, out);
  ASSERT_EQ(out.regions.size(), 2u);  // 10 cm apart: not joined
  regionBoundingBoxes(w, out);
  EXPECT_FALSE(fillHoles(map, s, w, out));
  traceRegionPolygons(w, out);
  traceStepEdges(w, out);
  const double x0 = map.origin().x(), y0 = map.origin().y(), side = n * res;
  const std::vector<PolygonWithHoles> low_truth{rectangle(x0, 0.0, y0, y0 + side)};
  const std::vector<PolygonWithHoles> high_truth{rectangle(0.0, x0 + side, y0, y0 + side)};
  EXPECT_NEAR(iou(out.regions[static_cast<std::size_t>(low)].polygons, low_truth), 1.0, 1e-9);
  EXPECT_NEAR(iou(out.regions[static_cast<std::size_t>(high)].polygons, high_truth), 1.0, 1e-9);
  EXPECT_EQ(out.regions[static_cast<std::size_t>(low)].cells, n * edge);
  EXPECT_NEAR(out.regions[static_cast<std::size_t>(high)].area, n * (n - edge) * res * res, 1e-12);
  const std::vector<PolygonWithHoles> step_truth{rectangle(-res, res, y0, y0 + side)};
  EXPECT_NEAR(iou(out.step_edges, step_truth), 1.0, 1e-9);
}

// Grow-back reaches window_half + 1 cells past a region's border, no further, and only over
// cells within grow_tolerance of its plane: labels by hand, a region over columns 0-49 on a
// floor (z = 0) that ends at column 52 (3 cm higher beyond) and one over 150-199.
TEST(SegmentationStages, GrowBackReachesAWindowsHalfWidthPlusOneCellOnItsPlane) {
  ElevationMap map;
  const int n = map.size();
  setHeights(map, [&](int, int c) { return c < 52 ? 0.0 : 0.03; });
  SegmentationSettings s;
  s.window_half = 3;
  Workspace w;
  Segmentation out;
  localFits(map, s, w, out);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c)
      out.labels[static_cast<std::size_t>(r * n + c)] = c < 50 ? 0 : c >= 150 ? 1 : -1;
  }
  out.regions.resize(2);
  fitRegionPlanes(map, w, out);
  growBack(map, s, w, out);
  const int reach = s.window_half + 1;
  ASSERT_GT(50 + reach, 52);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) {
      const int expected = c < 52 ? 0 : c >= 150 - reach ? 1 : -1;
      ASSERT_EQ(out.label(r, c), expected) << r << ", " << c;
    }
  }
}

// Labels by hand on a floor (z = 0) with a tread 10 cm up at column 150: a strip of the floor
// (columns 0-19, region 0) beside the rest of it (region 1) lies near the floor's plane and
// joins it, keeping the lower index; the merged plane is fitted to both parts' cells (its
// anchor at their common centroid); the tread (region 2) stays apart.
TEST(SegmentationStages, AStripOnTheFloorsPlaneJoinsTheFloorButATreadDoesNot) {
  ElevationMap map;
  const int n = map.size();
  const double res = map.resolution();
  // The strip's cells scatter by 1 cm (a checkerboard): near the floor's plane, not on it.
  setHeights(map, [&](int r, int c) {
    return c < 20 ? 0.01 * ((r + c) % 2) : c < 150 ? 0.0 : 0.1;
  });
  const SegmentationSettings s;
  Workspace w;
  Segmentation out;
  localFits(map, s, w, out);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c)
      out.labels[static_cast<std::size_t>(r * n + c)] = c < 20 ? 0 : c < 150 ? 1 : 2;
  }
  out.regions.resize(3);
  fitRegionPlanes(map, w, out);
  EXPECT_NEAR(out.regions[0].anchor.x(), map.origin().x() + 10 * res, 1e-9);
  joinRegionsOnPlanes(map, s, w, out);
  ASSERT_EQ(out.regions.size(), 2u);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) ASSERT_EQ(out.label(r, c), c < 150 ? 0 : 1) << r << ", " << c;
  }
  EXPECT_NEAR(out.regions[0].anchor.x(), map.origin().x() + 75 * res, 1e-9);
  // The strip's 20 of 150 columns average 5 mm.
  EXPECT_NEAR(out.regions[0].height, 0.005 * 20 / 150, 1e-6);
  EXPECT_NEAR(out.regions[1].height, 0.1, 1e-6);
  EXPECT_NEAR(out.regions[1].anchor.x(), map.origin().x() + 175 * res, 1e-9);
}

// One region (0) with five holes in a floor (z = 0), labels by hand: a 3 x 3 bump 10 cm high
// (small: filled whatever it holds), a 15 x 15 patch 1 cm high with a smaller region (1) in
// it (level: filled, region 1 joins and is dropped), a 15 x 15 pit 10 cm deep (step edges,
// off the plane: stays), a 15 x 15 unseen patch (stays) and a 15 x 15 patch of which one
// cell is 5 cm high (off the plane: stays).
TEST(SegmentationStages, SmallAndLevelHolesAreFilledButPitsUnseenAndRaisedPatchesStay) {
  ElevationMap map;
  const int n = map.size();
  const double res = map.resolution();
  auto in = [](int r, int c, int r0, int c0, int side) {
    return r >= r0 && r < r0 + side && c >= c0 && c < c0 + side;
  };
  setHeights(map, [&](int r, int c) {
    if (in(r, c, 120, 60, 3)) return 0.1;
    if (in(r, c, 40, 140, 15)) return 0.01;
    if (in(r, c, 40, 40, 15)) return -0.1;
    if (r == 157 && c == 107) return 0.05;
    return 0.0;
  });
  for (int r = 40; r < 55; ++r) {
    for (int c = 100; c < 115; ++c) map.setCell(r, c, std::nanf(""), std::nanf(""));
  }
  const SegmentationSettings s;
  Workspace w;
  Segmentation out;
  localFits(map, s, w, out);
  auto hole = [&](int r, int c) {
    return in(r, c, 120, 60, 3) || in(r, c, 40, 140, 15) || in(r, c, 40, 40, 15) ||
           in(r, c, 40, 100, 15) || in(r, c, 150, 100, 15);
  };
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) {
      out.labels[static_cast<std::size_t>(r * n + c)] = in(r, c, 44, 144, 7) ? 1
                                                        : hole(r, c)         ? -1
                                                                             : 0;
    }
  }
  out.regions.resize(2);  // both planes z = 0
  regionBoundingBoxes(w, out);
  EXPECT_TRUE(fillHoles(map, s, w, out));  // region 1 was taken
  dropEmptyRegions(w, out);
  ASSERT_EQ(out.regions.size(), 1u);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) {
      const bool stays = in(r, c, 40, 40, 15) || in(r, c, 40, 100, 15) || in(r, c, 150, 100, 15);
      ASSERT_EQ(out.label(r, c), stays ? -1 : 0) << r << ", " << c;
    }
  }
  traceRegionPolygons(w, out);
  EXPECT_EQ(out.regions[0].cells, n * n - 3 * 15 * 15);
  int holes = 0;
  for (const PolygonWithHoles& p : out.regions[0].polygons)
    holes += static_cast<int>(p.holes.size());
  EXPECT_EQ(holes, 3);
  EXPECT_NEAR(out.regions[0].area, (n * n - 3 * 15 * 15) * res * res, 1e-12);
}

// The workspace pattern: once sized (a first segmentation of the same map), the stages up to
// the regions' boxes allocate nothing (OpenCV's morphology, contours and the polygons do).
TEST(SegmentationStages, PerCellStagesAllocateNothingOnceTheWorkspaceIsSized) {
  ElevationMapSettings ms;
  ms.visibility_cleanup = false;
  ElevationMap map(ms);
  map.moveTo(Eigen::Vector2d::Zero());
  const Eigen::Vector3d sensor(0.0, 0.0, 3.0);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = sensor;
  map.update(test::stairsTerrain().cloud(0.01, 0.005, 0.1, sensor, 1), pose);
  const SegmentationSettings s;
  Workspace w;
  Segmentation out;
  for (int pass = 0; pass < 2; ++pass) {
    std::size_t allocations = 0;
    beginSegmentation(map, w, out);
    referenceHeight(map, w);
    {
      rollstep::test::AllocationGuard guard;
      sumMeasuredCells(map, w);
      allocations += guard.count();
    }
    markStepEdges(map, s, w);
    {
      rollstep::test::AllocationGuard guard;
      fitLocalPlanes(map, s, w);
      growRegions(map, s, w, out);
      fitRegionPlanes(map, w, out);
      growBack(map, s, w, out);
      joinRegionsOnPlanes(map, s, w, out);
      regionBoundingBoxes(w, out);
      allocations += guard.count();
    }
    EXPECT_GE(out.regions.size(), 4u);
    if (fillHoles(map, s, w, out)) dropEmptyRegions(w, out);
    traceRegionPolygons(w, out);
    traceStepEdges(w, out);
    if (pass == 1) {
      EXPECT_EQ(allocations, 0u);
    }
  }
}

}  // namespace
}  // namespace rollstep::perception
