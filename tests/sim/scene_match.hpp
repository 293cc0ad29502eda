#pragma once
// Regions built from the simulated LiDAR against the scene's ground truth (issue 15's proof
// in MuJoCo): per ground-truth surface, the area IoU of its region over the cells the map
// observed densely, the region boundary's distance from the rising step edges it borders,
// and the height error. Shared by the LiDAR tests and the closed-loop perception tests.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <utility>
#include <vector>

#include "rollstep/perception/polygon.hpp"
#include "rollstep/perception/terrain_perception.hpp"
#include "rollstep/sim/scene.hpp"
#include "rollstep/sim/scene_terrain.hpp"

namespace rollstep::sim::test {

/// Per ground-truth surface (0 floor, b + 1 block b's top): area IoU over the densely
/// observed cells, largest distance of its region's boundary from the rising step edges
/// it borders (its near edge, the next block's near edge), largest height error.
struct Surface {
  double iou = 0, edge = 1e9, height = 1e9;
  int edge_samples = 0;
};
using Approach = std::vector<Surface>;

/// Checks every ground-truth surface the map observed densely (the sensor at x =
/// sensor_x) against its region; prints the figures.
inline Approach evaluate(const SceneConfig& config, const perception::TerrainPerception& perception,
                         double sensor_x, const char* name) {
  const perception::Segmentation& seg = perception.segmentation();
  const perception::ElevationMap& map = perception.map();
  std::printf("%s: %zu regions\n", name, seg.regions.size());

  if (const char* dump = std::getenv("LIDAR_DUMP")) {
    FILE* f = std::fopen(dump, "w");
    for (int r = 0; r < seg.size; ++r) {
      for (int c = 0; c < seg.size; ++c)
        std::fprintf(f, "%d %g\n", seg.label(r, c), static_cast<double>(map.height(r, c)));
    }
    std::fclose(f);
  }
  // The terrain model the planner gets (convex pieces): the surface height along the path,
  // 1 m behind to 1.2 m ahead of the sensor, 5 cm clear of the step edges.
  {
    const double sx = sensor_x;
    double worst = 0;
    for (double x = sx - 1.0; x <= sx + 1.2; x += 0.05) {
      for (double y = -0.6; y <= 0.6; y += 0.3) {
        if (std::abs(terrainHeight(config, x - 0.05, y) - terrainHeight(config, x + 0.05, y)) >
            1e-9)
          continue;
        const double e =
            std::abs(perception.terrain().heightAt({x, y}, -1.0) - terrainHeight(config, x, y));
        if (e > 0.01 && std::getenv("LIDAR_DEBUG"))
          std::printf("    height error %.3f at (%.2f, %.2f)\n", e, x, y);
        worst = std::max(worst, e);
      }
    }
    std::printf("  terrain model: %d convex pieces, height error on the path %.4f m\n",
                perception.terrain().size(), worst);
    EXPECT_LE(worst, 0.01);
  }
  // Ground truth per cell: the surface (0 floor, b + 1 block b's top) and its height.
  const std::vector<SceneSolid> boxes = resolveScene(config).solids;
  const int n = seg.size;
  auto surfaceAt = [&](const Eigen::Vector2d& p) {
    int s = 0;
    double top = 0;
    for (std::size_t b = 0; b < boxes.size(); ++b) {
      const double h = boxes[b].topHeightAt(p.x(), p.y());
      if (boxes[b].coversTop(p.x(), p.y()) && h > top) {
        top = h;
        s = static_cast<int>(b) + 1;
      }
    }
    return std::make_pair(s, top);
  };
  // A cell is densely observed when its plane-fit window holds enough measured cells
  // (the segmentation's own min_window_fill): only there can any segmentation judge it.
  // Beyond, a 32-beam sensor's rings are tens of centimetres apart.
  const int hw = perception.settings().segmentation.window_half;
  const double fill = perception.settings().segmentation.min_window_fill;
  auto dense = [&](int r, int c) {
    int count = 0;
    for (int i = std::max(0, r - hw); i <= std::min(n - 1, r + hw); ++i) {
      for (int j = std::max(0, c - hw); j <= std::min(n - 1, c + hw); ++j)
        count += !std::isnan(map.height(i, j));
    }
    return count >= fill * (2 * hw + 1) * (2 * hw + 1);
  };
  Approach out(boxes.size() + 1);
  for (int s = 0; s <= static_cast<int>(boxes.size()); ++s) {
    // Cells of surface s that the map observed densely, one cell clear of its edges (a
    // cell straddling an edge belongs to neither side).
    std::vector<int> votes(seg.regions.size(), 0);
    int truth_cells = 0;
    std::vector<unsigned char> in_truth(static_cast<std::size_t>(n * n), 0);
    for (int r = 1; r < n - 1; ++r) {
      for (int c = 1; c < n - 1; ++c) {
        const Eigen::Vector2d p = seg.cellCenter(r, c);
        if (surfaceAt(p).first != s) continue;
        if (!dense(r, c)) continue;
        const double h = 0.5 * seg.resolution;
        if (surfaceAt(p + Eigen::Vector2d(h, 0)).first != s ||
            surfaceAt(p - Eigen::Vector2d(h, 0)).first != s)
          continue;
        in_truth[static_cast<std::size_t>(r * n + c)] = 1;
        ++truth_cells;
        if (seg.label(r, c) >= 0) ++votes[static_cast<std::size_t>(seg.label(r, c))];
      }
    }
    if (truth_cells * seg.resolution * seg.resolution < 0.1) continue;  // hardly seen
    const int k = static_cast<int>(std::max_element(votes.begin(), votes.end()) - votes.begin());
    const perception::PlanarRegion& reg = seg.regions[static_cast<std::size_t>(k)];
    int inter = 0, uni = 0;
    double height = 0;
    for (int r = 1; r < n - 1; ++r) {
      for (int c = 1; c < n - 1; ++c) {
        if (!dense(r, c)) continue;
        const bool t = in_truth[static_cast<std::size_t>(r * n + c)] != 0, e = seg.label(r, c) == k;
        inter += t && e;
        uni += t || e;
        if (t)
          height = std::max(height, std::abs(reg.heightAt(seg.cellCenter(r, c)) -
                                             surfaceAt(seg.cellCenter(r, c)).second));
      }
    }
    // Rising edges: the near side of each block, 10 cm clear of its ends and the map's.
    double edge = 0;
    int edge_samples = 0;
    for (std::size_t b = 0; b < boxes.size(); ++b) {
      if (static_cast<int>(b) + 1 != s && static_cast<int>(b) != s) continue;
      const double x = boxes[b].center.x() - boxes[b].half_size.x();
      const double y0 = boxes[b].center.y() - boxes[b].half_size.y() + 0.1;
      const double y1 = boxes[b].center.y() + boxes[b].half_size.y() - 0.1;
      for (double y = y0; y <= y1; y += 0.02) {
        int r0 = 0, c0 = 0, r1 = 0, c1 = 0;
        // Both sides of the edge densely observed.
        if (!map.cellOf({x - 0.05, y}, r0, c0) || !map.cellOf({x + 0.05, y}, r1, c1) ||
            !dense(r0, c0) || !dense(r1, c1))
          continue;
        edge = std::max(edge, perception::boundaryDistance(reg.polygons, {x, y}));
        ++edge_samples;
      }
    }
    const double overlap = static_cast<double>(inter) / uni;
    std::printf(
        "  surface %d (region %d): IoU %.4f over %d seen cells, rising edge error %.4f m (%d "
        "samples), height error %.4f m\n",
        s, k, overlap, truth_cells, edge, edge_samples, height);
    out[static_cast<std::size_t>(s)] = {overlap, edge, height, edge_samples};
  }
  return out;
}

inline constexpr double kRounding =
    1e-6;  // region edges lie on cell edges, at most one 2 cm cell from
           // the truth: 2 cm up to the polygon offset's rounding

inline void expectMatch(const Surface& s, const char* what, bool check_edges = true) {
  EXPECT_GE(s.iou, 0.9) << what;
  EXPECT_LE(s.height, 0.01) << what;
  if (check_edges) {
    EXPECT_GT(s.edge_samples, 50) << what;
    EXPECT_LE(s.edge, 0.02 + kRounding) << what;
  }
}

}  // namespace rollstep::sim::test
