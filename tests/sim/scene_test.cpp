// Scene parameters: defaults of the spec, YAML loading with strict keys, geometry.
#include "rollstep/sim/scene.hpp"

#include <gtest/gtest.h>

#include <stdexcept>

namespace rollstep::sim {
namespace {

TEST(SceneConfig, DefaultsAreTheSpecValues) {
  const SceneConfig c;
  EXPECT_EQ(c.kind, SceneKind::kFlat);
  EXPECT_DOUBLE_EQ(c.friction, 0.8);
  EXPECT_DOUBLE_EQ(c.start_x, 1.0);
  EXPECT_DOUBLE_EQ(c.width, 3.0);
  EXPECT_DOUBLE_EQ(c.step1_height, 0.20);
  EXPECT_DOUBLE_EQ(c.step1_length, 1.20);
  EXPECT_DOUBLE_EQ(c.step2_height, 0.165);
  EXPECT_DOUBLE_EQ(c.step2_length, 1.50);
}

TEST(SceneConfig, KindNamesRoundTrip) {
  for (SceneKind k : {SceneKind::kFlat, SceneKind::kStep20, SceneKind::kStairs2}) {
    EXPECT_EQ(sceneKindFromString(toString(k)), k);
  }
  EXPECT_THROW(sceneKindFromString("steps"), std::invalid_argument);
}

TEST(SceneConfig, YamlOverridesDefaults) {
  const SceneConfig c = parseSceneConfig("scene: step20\nstep1_height: 0.15\nstart_x: 2\n", "t");
  EXPECT_EQ(c.kind, SceneKind::kStep20);
  EXPECT_DOUBLE_EQ(c.step1_height, 0.15);
  EXPECT_DOUBLE_EQ(c.start_x, 2.0);
  EXPECT_DOUBLE_EQ(c.step1_length, 1.20);
  EXPECT_EQ(parseSceneConfig("", "empty").kind, SceneKind::kFlat);
}

void expectError(const std::string& yaml, const std::string& needle) {
  try {
    parseSceneConfig(yaml, "my.yaml");
    FAIL() << "no error for: " << yaml;
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("my.yaml"), std::string::npos) << what;
    EXPECT_NE(what.find(needle), std::string::npos) << what;
  }
}

TEST(SceneConfig, StrictYaml) {
  expectError("step_height: 0.2\n", "unknown key 'step_height'");
  expectError("step1_height: high\n", "step1_height");
  expectError("step1_height: -0.1\n", "step1_height");
  expectError("scene: mountain\n", "mountain");
  expectError("[1, 2]\n", "mapping");
  expectError("a: [\n", "YAML");
  EXPECT_THROW(loadSceneConfig("/nonexistent/scene.yaml"), std::runtime_error);
}

TEST(SceneGeometry, Step20Block) {
  SceneConfig c;
  c.kind = SceneKind::kStep20;
  const auto boxes = terrainBoxes(c);
  ASSERT_EQ(boxes.size(), 1u);
  EXPECT_DOUBLE_EQ(boxes[0].center.x() - boxes[0].half_size.x(), 1.0);
  EXPECT_DOUBLE_EQ(boxes[0].center.x() + boxes[0].half_size.x(), 2.2);
  EXPECT_DOUBLE_EQ(2 * boxes[0].half_size.y(), 3.0);
  EXPECT_DOUBLE_EQ(terrainHeight(c, 0.99, 0.0), 0.0);
  EXPECT_DOUBLE_EQ(terrainHeight(c, 1.01, 0.0), 0.20);
  EXPECT_DOUBLE_EQ(terrainHeight(c, 2.21, 0.0), 0.0);
}

TEST(SceneGeometry, Stairs2Profile) {
  SceneConfig c;
  c.kind = SceneKind::kStairs2;
  EXPECT_DOUBLE_EQ(terrainHeight(c, 0.5, 0.0), 0.0);
  EXPECT_DOUBLE_EQ(terrainHeight(c, 1.5, 0.0), 0.20);
  EXPECT_DOUBLE_EQ(terrainHeight(c, 2.5, 0.0), 0.365);
  EXPECT_DOUBLE_EQ(terrainHeight(c, 3.69, 0.0), 0.365);
  EXPECT_DOUBLE_EQ(terrainHeight(c, 3.71, 0.0), 0.0);
  EXPECT_TRUE(terrainBoxes(SceneConfig{}).empty());
}

}  // namespace
}  // namespace rollstep::sim
