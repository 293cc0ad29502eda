// The planning terrain built from each reference scene agrees with the scene's own
// ground-truth height everywhere (away from block edges), and classifies the step
// edges as the robot meets them.
#include "rollstep/sim/scene_terrain.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace {

using namespace rollstep;

TEST(SceneTerrain, HeightsMatchTheSceneGroundTruth) {
  for (sim::SceneKind kind :
       {sim::SceneKind::kFlat, sim::SceneKind::kStep20, sim::SceneKind::kStairs2}) {
    sim::SceneConfig c;
    c.kind = kind;
    const planning::TerrainModel t = sim::terrainFromScene(c);
    SCOPED_TRACE(std::string(sim::toString(kind)));
    EXPECT_EQ(t.size(), kind == sim::SceneKind::kFlat     ? 1
                        : kind == sim::SceneKind::kStep20 ? 5    // 3 along x, 2 beside
                                                          : 6);  // 4 along x, 2 beside
    for (int i = 0; i < 120; ++i) {
      for (int j = 0; j < 9; ++j) {
        const double x = -1.0 + 0.05 * i + 0.0123, y = -2.0 + 0.5 * j + 0.0123;
        EXPECT_DOUBLE_EQ(t.heightAt({x, y}), sim::terrainHeight(c, x, y)) << x << " " << y;
      }
    }
  }
}

TEST(SceneTerrain, EveryStartPositionGivesTheSameRegions) {
  // The trials move start_x at random; the boxes' shared edges then differ by rounding for
  // about half of the values (stairs2's top landing ends at start_x + (l1 + l2) and
  // (start_x + l1) + l2), which once gave a region of zero width and an error.
  for (sim::SceneKind kind : {sim::SceneKind::kStep20, sim::SceneKind::kStairs2}) {
    for (int k = 0; k <= 40; ++k) {
      sim::SceneConfig c;
      c.kind = kind;
      c.start_x = 0.8 + 0.0113 * k;
      SCOPED_TRACE(std::string(sim::toString(kind)) + " start_x " + std::to_string(c.start_x));
      const planning::TerrainModel t = sim::terrainFromScene(c, 0.085);
      EXPECT_EQ(t.size(), kind == sim::SceneKind::kStep20 ? 5 : 6);
      EXPECT_NEAR(t.heightAt({c.start_x + 0.1, 0.0}), c.step1_height, 1e-12);
    }
  }
}

TEST(SceneTerrain, Stairs2EdgesAndBadConfig) {
  sim::SceneConfig c;
  c.kind = sim::SceneKind::kStairs2;
  const planning::TerrainModel t = sim::terrainFromScene(c, 0.03);
  const double x1 = c.start_x, x2 = c.start_x + c.step1_length;
  EXPECT_EQ(t.classifySwing({x1 - 0.1, 0}, {x1 + 0.1, 0}), planning::SwingDirection::Ascending);
  EXPECT_EQ(t.classifySwing({x2 - 0.1, 0}, {x2 + 0.1, 0}), planning::SwingDirection::Ascending);
  EXPECT_EQ(t.classifySwing({x2 + 0.1, 0}, {x2 - 0.1, 0}), planning::SwingDirection::Descending);
  EXPECT_NEAR(t.heightAt({x2 + 0.5, 0}), c.step1_height + c.step2_height, 1e-12);
  c.step1_height = std::nan("");
  EXPECT_THROW(sim::terrainFromScene(c), std::invalid_argument);
}

}  // namespace
