// The planning terrain built from a scene agrees with the scene: with its own ground-truth
// height, with what MuJoCo's raycast sees in the world built from the same file (yawed
// boxes, ramps, overlapping boxes; with a margin, every point clear of the edges still in a
// region), and for the reference scenes with the regions of their boxes.
#include "rollstep/sim/scene_terrain.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>

#include "rollstep/sim/plant.hpp"

namespace {

using namespace rollstep;

TEST(SceneTerrain, HeightsMatchTheSceneGroundTruth) {
  for (const char* name : {"flat", "step20", "stairs2"}) {
    const sim::SceneConfig c = sim::loadScene(name);
    const planning::TerrainModel t = sim::terrainFromScene(c);
    SCOPED_TRACE(name);
    EXPECT_EQ(t.size(), name == std::string("flat")     ? 1
                        : name == std::string("step20") ? 5    // 3 along x, 2 beside
                                                        : 6);  // 4 along x, 2 beside
    for (int i = 0; i < 120; ++i) {
      for (int j = 0; j < 9; ++j) {
        const double x = -1.0 + 0.05 * i + 0.0123, y = -2.0 + 0.5 * j + 0.0123;
        EXPECT_DOUBLE_EQ(t.heightAt({x, y}), sim::terrainHeight(c, x, y)) << x << " " << y;
      }
    }
  }
}

// The reference scenes' regions are those of planning::terrainFromBoxes from the boxes as
// the code computed them: one rule for scenes and boxes, bit for bit.
TEST(SceneTerrain, ReferenceScenesGiveTheRegionsOfTheirBoxes) {
  const double start_x = 1.0, w = 3.0, h1 = 0.20, l1 = 1.20, h2 = 0.165, l2 = 1.50;
  const auto box = [&](double x0, double length, double height) {
    const double cx = x0 + 0.5 * length, hx = 0.5 * length, hy = 0.5 * w;
    return planning::TerrainBox{cx - hx, cx + hx, -hy, hy, 0.5 * height + 0.5 * height};
  };
  const double e = sim::kSceneFloorHalfExtent;
  for (double margin : {0.0, 0.085}) {
    const planning::TerrainModel step = sim::terrainFromScene(sim::loadScene("step20"), margin);
    const planning::TerrainModel stairs = sim::terrainFromScene(sim::loadScene("stairs2"), margin);
    const planning::TerrainModel old_step =
        planning::terrainFromBoxes({-e, e, -e, e, 0.0}, 0.0, {box(start_x, l1, h1)}, margin);
    const planning::TerrainModel old_stairs = planning::terrainFromBoxes(
        {-e, e, -e, e, 0.0}, 0.0, {box(start_x, l1 + l2, h1), box(start_x + l1, l2, h1 + h2)},
        margin);
    for (const auto& [now, before] :
         {std::pair{&step, &old_step}, std::pair{&stairs, &old_stairs}}) {
      ASSERT_EQ(now->size(), before->size());
      // The same polygons at the same heights, in any order (the scene's corners come out
      // of a rotation by zero yaw, equal within rounding).
      for (const planning::ConvexRegion& r : now->regions()) {
        int same = 0;
        for (const planning::ConvexRegion& q : before->regions()) {
          if (q.vertices.size() != r.vertices.size() || std::abs(q.height - r.height) > 1e-12)
            continue;
          bool all = true;
          for (const Eigen::Vector2d& v : r.vertices) {
            all =
                all && std::any_of(q.vertices.begin(), q.vertices.end(),
                                   [&](const Eigen::Vector2d& u) { return (u - v).norm() < 1e-9; });
          }
          same += all ? 1 : 0;
        }
        EXPECT_EQ(same, 1) << r.centroid.transpose();
      }
    }
  }
}

TEST(SceneTerrain, EveryStartPositionGivesTheSameRegions) {
  // The trials move start_x at random; the boxes' shared edges then differ by rounding for
  // about half of the values (stairs2's top landing ends at start_x + (l1 + l2) and
  // (start_x + l1) + l2), which once gave a region of zero width and an error.
  for (const char* name : {"step20", "stairs2"}) {
    for (int k = 0; k <= 40; ++k) {
      sim::SceneConfig c = sim::loadScene(name);
      const double start_x = 0.8 + 0.0113 * k;
      sim::setSceneNumber(c, "start_x", start_x);
      SCOPED_TRACE(std::string(name) + " start_x " + std::to_string(start_x));
      const planning::TerrainModel t = sim::terrainFromScene(c, 0.085);
      EXPECT_EQ(t.size(), sim::terrainFromScene(sim::loadScene(name), 0.085).size());
      EXPECT_NEAR(t.heightAt({start_x + 0.1, 0.0}), sim::sceneNumber(c, "step1_height"), 1e-12);
    }
  }
}

TEST(SceneTerrain, Stairs2EdgesAndBadConfig) {
  sim::SceneConfig c = sim::loadScene("stairs2");
  const planning::TerrainModel t = sim::terrainFromScene(c, 0.03);
  const double x1 = sim::sceneNumber(c, "start_x");
  const double x2 = x1 + sim::sceneNumber(c, "step1_length");
  EXPECT_EQ(t.classifySwing({x1 - 0.1, 0}, {x1 + 0.1, 0}), planning::SwingDirection::Ascending);
  EXPECT_EQ(t.classifySwing({x2 - 0.1, 0}, {x2 + 0.1, 0}), planning::SwingDirection::Ascending);
  EXPECT_EQ(t.classifySwing({x2 + 0.1, 0}, {x2 - 0.1, 0}), planning::SwingDirection::Descending);
  EXPECT_NEAR(t.heightAt({x2 + 0.5, 0}), 0.365, 1e-12);
  sim::setSceneNumber(c, "step1_height", -0.1);
  EXPECT_THROW(sim::terrainFromScene(c), std::invalid_argument);
}

/// Distance [m] from p to the nearest edge of any solid's top face seen from above.
double distanceToAnEdge(const sim::SceneGeometry& g, const Eigen::Vector2d& p) {
  double d = 1e9;
  for (const sim::SceneSolid& s : g.solids) {
    const std::array<Eigen::Vector2d, 4> f = s.topFootprint();
    for (std::size_t k = 0; k < 4; ++k) {
      const Eigen::Vector2d a = f[k], b = f[(k + 1) % 4];
      const double u = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
      d = std::min(d, (p - (a + u * (b - a))).norm());
    }
  }
  return d;
}

/// The terrain of `yaml` against MuJoCo's raycast of the same scene at sampled points
/// clear of edges (2 cm, more than a ramp's high end face is wide seen from above): the
/// region height under every point is the height the ray meets.
void expectRegionsMatchRaycast(const std::string& yaml, int expected_regions_at_least) {
  SCOPED_TRACE(yaml);
  const sim::SceneConfig config = sim::parseSceneConfig(yaml, "test.yaml");
  const sim::SceneGeometry g = sim::resolveScene(config);
  const planning::TerrainModel terrain = sim::terrainFromScene(config);
  EXPECT_GE(terrain.size(), expected_regions_at_least);
  const sim::Plant plant(config);
  int checked = 0;
  for (double x = -4.0; x <= 6.0; x += 0.0371) {
    for (double y = -3.0; y <= 3.0; y += 0.0413) {
      const Eigen::Vector2d p(x, y);
      if (std::hypot(x, y) < 1.2) continue;  // the robot stands there
      if (distanceToAnEdge(g, p) < 0.03) continue;
      const double distance =
          plant.raycast(Eigen::Vector3d(x, y, 3.0), -Eigen::Vector3d::UnitZ(), 10.0);
      ASSERT_GT(distance, 0.0) << x << " " << y;
      const double seen = 3.0 - distance;
      const int r = terrain.regionAt(p);
      ASSERT_GE(r, 0);
      EXPECT_TRUE(terrain.region(r).contains(p, 1e-9)) << x << " " << y;
      EXPECT_NEAR(terrain.heightAt(p), seen, 1e-9) << x << " " << y;
      EXPECT_NEAR(sim::terrainHeight(g, x, y), seen, 1e-9) << x << " " << y;
      ++checked;
    }
  }
  EXPECT_GT(checked, 10000);
  // With a margin the regions keep off the edges and stay regions (no error, none empty);
  // every point clear of the edges by more than the margin's band (square at its ends) is
  // still in a region, at the height the ray meets: pieces of one surface meet with no gap.
  const double margin = 0.05;
  const planning::TerrainModel shrunk = sim::terrainFromScene(config, margin);
  EXPECT_GE(shrunk.size(), 1);
  for (const planning::ConvexRegion& region : shrunk.regions()) EXPECT_GT(region.area(), 0.0);
  int clear = 0;
  for (double x = -4.0; x <= 6.0; x += 0.0371) {
    for (double y = -3.0; y <= 3.0; y += 0.0413) {
      const Eigen::Vector2d p(x, y);
      if (std::hypot(x, y) < 1.2 || distanceToAnEdge(g, p) < std::sqrt(2.0) * margin + 1e-3)
        continue;
      const int r = shrunk.regionAt(p);
      ASSERT_GE(r, 0);
      EXPECT_TRUE(shrunk.region(r).contains(p, 1e-9)) << x << " " << y;
      EXPECT_NEAR(shrunk.heightAt(p), sim::terrainHeight(g, x, y), 1e-9) << x << " " << y;
      ++clear;
    }
  }
  EXPECT_GT(clear, 10000);
}

TEST(SceneTerrain, YawedBoxMatchesTheRaycast) {
  expectRegionsMatchRaycast(
      "boxes:\n  - {position: [3, 0.5, 0.1], size: [1.5, 1, 0.2], yaw_deg: 30}\n", 2);
}

TEST(SceneTerrain, RampMatchesTheRaycast) {
  // 15 deg up towards +x, its low end under the floor, its high end 0.5 m up.
  expectRegionsMatchRaycast(
      "ramps:\n  - {position: [3, 0, 0.2], size: [2, 1.2, 0.1], yaw_deg: 0, slope_deg: 15}\n", 2);
  // Turned, and descending along its own x.
  expectRegionsMatchRaycast(
      "ramps:\n  - {position: [-2.5, 1, 0.1], size: [2, 1, 0.1], yaw_deg: 60, slope_deg: -12}\n",
      2);
}

TEST(SceneTerrain, OverlappingBoxesMatchTheRaycast) {
  // Axis-aligned (the rectangles' path) and one of them yawed (the general path).
  expectRegionsMatchRaycast(
      "boxes:\n  - {position: [3, 0, 0.1], size: [2, 2, 0.2]}\n"
      "  - {position: [3.5, 0.5, 0.15], size: [1, 1.5, 0.3]}\n",
      3);
  expectRegionsMatchRaycast(
      "boxes:\n  - {position: [3, 0, 0.1], size: [2, 2, 0.2]}\n"
      "  - {position: [3.5, 0.5, 0.15], size: [1, 1.5, 0.3], yaw_deg: 25}\n",
      3);
  // A ramp onto a box, crossing into it.
  expectRegionsMatchRaycast(
      "boxes:\n  - {position: [4, 0, 0.15], size: [1.5, 2, 0.3]}\n"
      "ramps:\n  - {position: [2.6, 0, 0.12], size: [2, 1, 0.1], slope_deg: 12}\n",
      3);
}

}  // namespace

namespace {

// Many overlapping solids, yawed and sloped: the regions give the scene's own height
// everywhere away from the edges (heights where surfaces cross included).
TEST(SceneTerrain, ManyOverlappingSolidsGiveTheScenesHeights) {
  std::string yaml = "boxes:\n";
  for (int k = 0; k < 8; ++k) {
    yaml += "  - {position: [" + std::to_string(2.0 + 0.45 * k) + ", " +
            std::to_string(0.3 * ((k % 3) - 1)) + ", " + std::to_string(0.05 + 0.02 * k) +
            "], size: [0.9, 1.1, " + std::to_string(0.1 + 0.04 * k) +
            "], yaw_deg: " + std::to_string(17 * k) + "}\n";
  }
  yaml += "ramps:\n";
  for (int k = 0; k < 4; ++k) {
    yaml += "  - {position: [" + std::to_string(2.5 + 0.8 * k) + ", " +
            std::to_string(0.6 - 0.4 * k) +
            ", 0.15], size: [1.6, 0.8, 0.1], yaw_deg: " + std::to_string(-40 + 25 * k) +
            ", slope_deg: " + std::to_string(18 - 9 * k) + "}\n";
  }
  const sim::SceneGeometry g = sim::resolveScene(sim::parseSceneConfig(yaml, "many.yaml"));
  const planning::TerrainModel t = sim::terrainFromScene(g);
  std::printf("12 solids: %d regions\n", t.size());
  int checked = 0;
  for (double x = 0.5; x <= 7.5; x += 0.0317) {
    for (double y = -2.0; y <= 2.0; y += 0.0291) {
      if (distanceToAnEdge(g, {x, y}) < 0.01) continue;
      const double h = sim::terrainHeight(g, x, y);
      // Where two surfaces cross the highest changes: not an edge of a footprint, but the
      // heights agree there anyway (both sides of the crossing have the same height on it).
      EXPECT_NEAR(t.heightAt({x, y}), h, 1e-9) << x << " " << y;
      ++checked;
    }
  }
  EXPECT_GT(checked, 20000);
  EXPECT_NO_THROW(sim::terrainFromScene(g, 0.03));
}

}  // namespace
