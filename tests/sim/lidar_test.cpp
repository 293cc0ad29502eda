// Issue 15 proof in MuJoCo: the simulated LiDAR on the robot approaching step20 and
// stairs2 (driving with the simple drive controller, a scan every 100 ms), fused into the
// elevation map and segmented, gives regions that match the scene's ground truth where
// the sensor saw it: area IoU >= 0.9, the rising step edges within 2 cm (both sides),
// heights within 1 cm.
#include "rollstep/sim/lidar.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "rollstep/perception/polygon.hpp"
#include "rollstep/perception/terrain_perception.hpp"
#include "rollstep/sim/simple_controllers.hpp"

namespace rollstep::sim {
namespace {

using perception::PolygonWithHoles;

TEST(Lidar, ScansTheFloorAtItsHeightWithNoiseAndDropouts) {
  SceneConfig c;
  c.kind = SceneKind::kFlat;
  Plant plant(c);
  Lidar lidar(loadLidarSettings(ROLLSTEP_CONFIG_DIR "/lidar.yaml"));
  const std::vector<Eigen::Vector3d>& pts = lidar.scan(plant);
  ASSERT_EQ(pts.size(), static_cast<std::size_t>(32 * 450));
  int hits = 0, misses = 0;
  double worst = 0;
  for (const Eigen::Vector3d& p : pts) {
    if (!p.allFinite()) {
      ++misses;
      continue;
    }
    ++hits;
    worst = std::max(worst, std::abs((lidar.lastPose() * p).z()));
  }
  EXPECT_EQ(hits, lidar.lastHits());
  EXPECT_GT(misses, 0);    // upward beams and dropouts
  EXPECT_LT(worst, 0.06);  // 1 cm range noise, 5 sigma at grazing rays
  // Same seed, same scan.
  Lidar again(loadLidarSettings(ROLLSTEP_CONFIG_DIR "/lidar.yaml"));
  const std::vector<Eigen::Vector3d>& pts2 = again.scan(plant);
  for (std::size_t i = 0; i < pts.size(); i += 97) {
    EXPECT_TRUE((pts[i].array() == pts2[i].array()).all() ||
                (!pts[i].allFinite() && !pts2[i].allFinite()));
  }
  EXPECT_THROW(parseLidarSettings("beams: 0\n", "x.yaml"), std::runtime_error);
  EXPECT_THROW(parseLidarSettings("beam: 3\n", "x.yaml"), std::runtime_error);
}

// Range errors name the file, line and key, and the value as given (shortest round-trip
// text): -1e-9 must not read as -0.000000, nor 0.0499999 as 0.050000.
TEST(LidarSettings, RangeErrorsShowTheValueGiven) {
  const auto error = [](const char* text) {
    try {
      parseLidarSettings(text, "x.yaml");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error("seed: 1\ndropout: -1e-9\n"),
            "lidar settings 'x.yaml': line 2: dropout = -1e-09: must be in [0, 1]");
  EXPECT_EQ(error("horizontal_resolution_deg: 0.0499999\n"),
            "lidar settings 'x.yaml': line 1: horizontal_resolution_deg = 0.0499999: must be in "
            "[0.05, horizontal_fov_deg]");
  EXPECT_EQ(error("beams: 0\n"), "lidar settings 'x.yaml': line 1: beams = 0: must be 1 to 256");
  EXPECT_EQ(error("mount_position: [0, 0, 10.5]\n"),
            "lidar settings 'x.yaml': line 1: mount_position = 10.5: must be finite, within 10 m "
            "of the base");
}

/// Per ground-truth surface (0 floor, b + 1 block b's top): area IoU over the densely
/// observed cells, largest distance of its region's boundary from the rising step edges
/// it borders (its near edge, the next block's near edge), largest height error.
struct Surface {
  double iou = 0, edge = 1e9, height = 1e9;
  int edge_samples = 0;
};
using Approach = std::vector<Surface>;

/// Drives at 0.3 m/s towards the blocks for `duration`, a scan every 100 ms, then checks
/// every ground-truth surface the map observed on the path ahead against its region.
Approach evaluate(const SceneConfig& config, const perception::TerrainPerception& perception,
                  double sensor_x, const char* name);

Approach approach(SceneKind kind, double start_x, double duration) {
  SceneConfig config;
  config.kind = kind;
  config.start_x = start_x;
  Plant plant(config);
  Lidar lidar(loadLidarSettings(ROLLSTEP_CONFIG_DIR "/lidar.yaml"));
  perception::TerrainPerception perception(
      perception::loadPerceptionSettings(ROLLSTEP_CONFIG_DIR "/perception.yaml"));
  DriveController drive(plant.nominalCommand(), plant.wheelRadius(0), {0.3, 0.0, 1.0, 0.3});
  PlantCommand command = plant.nominalCommand();
  const int per_scan = static_cast<int>(std::lround(0.1 / plant.controlPeriod()));
  const int steps = static_cast<int>(std::lround(duration / plant.controlPeriod()));
  perception::PerceptionStatus status = perception::PerceptionStatus::NoPoints;
  for (int k = 0; k <= steps; ++k) {
    if (k % per_scan == 0)
      status = perception.update(lidar.scan(plant), lidar.lastPose(), plant.time());
    drive.compute(plant.time(), plant.sensors(), command);
    plant.setCommand(command);
    plant.step();
  }
  EXPECT_EQ(status, perception::PerceptionStatus::Ok);
  std::printf("%s: base at x = %.3f\n", kind == SceneKind::kStep20 ? "step20" : "stairs2",
              plant.groundTruth().base_position.x());
  return evaluate(config, perception, lidar.lastPose().translation().x(),
                  kind == SceneKind::kStep20 ? "step20" : "stairs2");
}

Approach evaluate(const SceneConfig& config, const perception::TerrainPerception& perception,
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
  const std::vector<TerrainBox> boxes = terrainBoxes(config);
  const int n = seg.size;
  auto surfaceAt = [&](const Eigen::Vector2d& p) {
    int s = 0;
    double top = 0;
    for (std::size_t b = 0; b < boxes.size(); ++b) {
      const Eigen::Vector3d lo = boxes[b].center - boxes[b].half_size,
                            hi = boxes[b].center + boxes[b].half_size;
      if (p.x() >= lo.x() && p.x() <= hi.x() && p.y() >= lo.y() && p.y() <= hi.y() &&
          hi.z() > top) {
        top = hi.z();
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

constexpr double kRounding = 1e-6;  // region edges lie on cell edges, at most one 2 cm cell from
                                    // the truth: 2 cm up to the polygon offset's rounding

void expectMatch(const Surface& s, const char* what, bool check_edges = true) {
  EXPECT_GE(s.iou, 0.9) << what;
  EXPECT_LE(s.height, 0.01) << what;
  if (check_edges) {
    EXPECT_GT(s.edge_samples, 50) << what;
    EXPECT_LE(s.edge, 0.02 + kRounding) << what;
  }
}

// Start 1.8 m before the block, drive 1.2 m towards it in 4.5 s.
// The sensor carried up the stairs: scans every 3 cm from x = 0 on the floor, up the
// first landing and to the second rise (the base 0.375 m above the surface under it),
// as if the robot climbed; here the top landing is seen from close by.
TEST(LidarPerception, Stairs2PlacedAlongTheClimbMatchesEverySurface) {
  SceneConfig config;
  config.kind = SceneKind::kStairs2;
  Plant plant(config);
  Lidar lidar(loadLidarSettings(ROLLSTEP_CONFIG_DIR "/lidar.yaml"));
  perception::TerrainPerception perception(
      perception::loadPerceptionSettings(ROLLSTEP_CONFIG_DIR "/perception.yaml"));
  const double x_end = config.start_x + config.step1_length - 0.5;
  double t = 0;
  for (double x = 0; x <= x_end; x += 0.03, t += 0.1) {
    const Eigen::Vector3d base(x, 0.0, 0.375 + terrainHeight(config, x, 0.0));
    EXPECT_NE(perception.update(lidar.scanFrom(plant, base, Eigen::Quaterniond::Identity()),
                                lidar.lastPose(), t),
              perception::PerceptionStatus::InvalidPose);
  }
  EXPECT_EQ(perception.lastStatus(), perception::PerceptionStatus::Ok);
  const Approach a =
      evaluate(config, perception, lidar.lastPose().translation().x(), "stairs2 climb");
  expectMatch(a[0], "floor");
  expectMatch(a[1], "first landing");  // both rises: its near edge and the second's foot
  expectMatch(a[2], "top landing");
}

TEST(LidarPerception, Step20RegionsMatchTheScene) {
  const Approach a = approach(SceneKind::kStep20, 1.8, 4.5);
  expectMatch(a[0], "floor");
  expectMatch(a[1], "block top");
}

// Approaching on the floor: the floor, the first rise and the first landing match. The
// top landing, 1.5 m to 3 m ahead and 0.26 m below the sensor, is crossed by two or three
// beam rings only from there: its figures are printed, not asserted (the climb test above
// sees it from the first landing).
TEST(LidarPerception, Stairs2FloorFirstRiseAndLandingMatchTheScene) {
  const Approach a = approach(SceneKind::kStairs2, 1.8, 4.5);
  expectMatch(a[0], "floor");
  // The landing's edges include the second rise's foot, where the riser's points smear;
  // its IoU and height are asserted, its first rise is checked through the floor's.
  expectMatch(a[1], "first landing", false);
}

}  // namespace
}  // namespace rollstep::sim
