// Scene files: the shipped scenes, the format (expressions, base scenes, key paths), strict
// errors naming file, line and key, and the geometry of boxes and ramps.
#include "rollstep/sim/scene.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace rollstep::sim {
namespace {

std::string writeTemp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

TEST(SceneFiles, ShippedScenesAreFoundByName) {
  const std::vector<std::string> names = sceneNames();
  for (const char* name : {"flat", "step20", "stairs2", "step20_custom", "step12"}) {
    EXPECT_TRUE(isSceneName(name)) << name;
    EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
    EXPECT_EQ(loadScene(name).name, name);
  }
  EXPECT_FALSE(isSceneName("steps"));
  EXPECT_FALSE(isSceneName("../step20"));
  try {
    loadScene("moon");
    FAIL() << "no error for an unknown scene";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("unknown scene 'moon' (expected flat, "),
              std::string::npos)
        << e.what();
  }
  // A path loads that file.
  const std::string path = writeTemp("scene_by_path.yaml", "friction: 0.5\n");
  EXPECT_EQ(resolveScene(loadScene(path)).friction, 0.5);
}

// The reference scenes' numbers, as the code that built them before they were files
// computed them (bit for bit: the MuJoCo world and the terrain depend on every bit).
TEST(SceneFiles, Step20AndStairs2AreTheReferenceGeometry) {
  const SceneGeometry flat = resolveScene(loadScene("flat"));
  EXPECT_EQ(flat.friction, 0.8);
  EXPECT_TRUE(flat.solids.empty());
  const SceneGeometry step = resolveScene(loadScene("step20"));
  ASSERT_EQ(step.solids.size(), 1u);
  const double start_x = 1.0, width = 3.0, h1 = 0.20, l1 = 1.20, h2 = 0.165, l2 = 1.50;
  EXPECT_EQ(step.solids[0].center, Eigen::Vector3d(start_x + 0.5 * l1, 0.0, 0.5 * h1));
  EXPECT_EQ(step.solids[0].half_size, Eigen::Vector3d(0.5 * l1, 0.5 * width, 0.5 * h1));
  EXPECT_EQ(step.solids[0].yaw, 0.0);
  const SceneGeometry stairs = resolveScene(loadScene("stairs2"));
  ASSERT_EQ(stairs.solids.size(), 2u);
  EXPECT_EQ(stairs.solids[0].center, Eigen::Vector3d(start_x + 0.5 * (l1 + l2), 0.0, 0.5 * h1));
  EXPECT_EQ(stairs.solids[0].half_size, Eigen::Vector3d(0.5 * (l1 + l2), 0.5 * width, 0.5 * h1));
  const double x0 = start_x + l1;
  EXPECT_EQ(stairs.solids[1].center, Eigen::Vector3d(x0 + 0.5 * l2, 0.0, 0.5 * (h1 + h2)));
  EXPECT_EQ(stairs.solids[1].half_size, Eigen::Vector3d(0.5 * l2, 0.5 * width, 0.5 * (h1 + h2)));
  // Heights seen from above.
  EXPECT_DOUBLE_EQ(terrainHeight(stairs, 0.5, 0.0), 0.0);
  EXPECT_DOUBLE_EQ(terrainHeight(stairs, 1.5, 0.0), 0.20);
  EXPECT_DOUBLE_EQ(terrainHeight(stairs, 2.5, 0.0), 0.365);
  EXPECT_DOUBLE_EQ(terrainHeight(stairs, 3.71, 0.0), 0.0);
  EXPECT_DOUBLE_EQ(firstRise(step), 0.20);
  EXPECT_DOUBLE_EQ(firstRise(flat), 0.0);
}

TEST(SceneFiles, ABaseSceneIsChangedAndExtended) {
  const SceneConfig custom = loadScene("step20_custom");
  EXPECT_EQ(sceneNumber(custom, "start_x"), 1.5);
  EXPECT_EQ(sceneNumber(custom, "friction"), 0.6);
  const SceneGeometry g = resolveScene(custom);
  ASSERT_EQ(g.solids.size(), 1u);
  EXPECT_DOUBLE_EQ(g.solids[0].center.x(), 1.5 + 0.5);
  EXPECT_DOUBLE_EQ(g.solids[0].topCenter().z(), 0.15);
  // A file next to another, based on it by a relative path, adding a ramp.
  writeTemp("scene_base.yaml",
            "parameters: {h: 0.1}\nboxes:\n  - {position: [3, 0, 0.5 * h], size: [1, 1, h]}\n");
  const std::string derived =
      writeTemp("scene_derived.yaml",
                "base: scene_base.yaml\nparameters: {h: 0.3}\nramps:\n"
                "  - {position: [-3, 0, 0], size: [2, 1, 0.1], slope_deg: 10}\n");
  const SceneGeometry d = resolveScene(loadSceneConfig(derived));
  ASSERT_EQ(d.solids.size(), 2u);
  EXPECT_DOUBLE_EQ(d.solids[0].topCenter().z(), 0.3);
  EXPECT_TRUE(d.solids[1].ramp);
}

TEST(SceneFiles, ToYamlRoundTrips) {
  for (const char* name : {"flat", "step20", "stairs2", "step20_custom", "step12"}) {
    SceneConfig c = loadScene(name);
    if (name != std::string("flat")) setSceneNumber(c, "start_x", 1.2345678901234567);
    setSceneNumber(c, "friction", 0.123456789);
    const SceneConfig back = parseSceneConfig(toYaml(c), std::string("copy/") + name + ".yaml");
    const SceneGeometry a = resolveScene(c), b = resolveScene(back);
    EXPECT_EQ(a.friction, b.friction) << name;
    ASSERT_EQ(a.solids.size(), b.solids.size()) << name;
    for (std::size_t i = 0; i < a.solids.size(); ++i) {
      EXPECT_EQ(a.solids[i].center, b.solids[i].center) << name;
      EXPECT_EQ(a.solids[i].half_size, b.solids[i].half_size) << name;
    }
    EXPECT_EQ(toYaml(back), toYaml(c)) << name;
  }
}

// An expression folded over several lines (a flow list broken across empty lines) holds line
// breaks as YAML reads it; written back on one line it must read back the same.
TEST(SceneFiles, AnExpressionFoldedOverLinesRoundTrips) {
  const SceneConfig c = parseSceneConfig(
      "parameters: {h: 0.2, g: 0.1}\nboxes:\n  - position: [1, 0, 0.5 * h]\n"
      "    size: [1, 2, h +\n\n\n      g]\n",
      "folded.yaml");
  const std::string yaml = toYaml(c);
  EXPECT_EQ(toYaml(parseSceneConfig(yaml, "copy/folded.yaml")), yaml);
  EXPECT_DOUBLE_EQ(sceneNumber(c, "boxes[0].size[2]"), 0.3);
}

TEST(SceneNumbers, KeyPathsReadAndSetEveryNumber) {
  SceneConfig c = parseSceneConfig(
      "parameters: {h: 0.2}\nboxes:\n  - {position: [2, 0, 0.5 * h], size: [1, 1, h], yaw_deg: "
      "10}\n"
      "ramps:\n  - {position: [-3, 0, 0], size: [2, 1, 0.1], slope_deg: 10}\n",
      "k.yaml");
  EXPECT_EQ(sceneNumber(c, "h"), 0.2);
  EXPECT_EQ(sceneNumber(c, "boxes[0].position[2]"), 0.1);
  EXPECT_EQ(sceneNumber(c, "boxes[0].yaw_deg"), 10.0);
  EXPECT_EQ(sceneNumber(c, "ramps[0].slope_deg"), 10.0);
  setSceneNumber(c, "h", 0.4);  // what is computed from it follows
  EXPECT_DOUBLE_EQ(resolveScene(c).solids[0].topCenter().z(), 0.4);
  setSceneNumber(c, "boxes[0].size[2]", 0.3);  // that number alone
  EXPECT_DOUBLE_EQ(resolveScene(c).solids[0].half_size.z(), 0.15);
  EXPECT_DOUBLE_EQ(resolveScene(c).solids[0].center.z(), 0.2);
  for (const char* bad : {"g", "boxes[1].size[0]", "boxes[0].size[3]", "boxes[0].slope_deg",
                          "ramps[x].yaw_deg", "boxes[0]", ""}) {
    try {
      setSceneNumber(c, bad, 1.0);
      ADD_FAILURE() << "no error for " << bad;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("has no number '" + std::string(bad) + "'"),
                std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find("boxes[0..0].position[0..2]"), std::string::npos);
    }
  }
}

TEST(SceneNumbers, ExpressionsEvaluateLeftToRightAsCppDoes) {
  const auto value = [](const std::string& expression) {
    const SceneConfig c = parseSceneConfig(
        "parameters: {a: 0.1, b: 0.7, c: 3}\nfriction: " + expression + "\n", "e.yaml");
    return resolveScene(c).friction;
  };
  const double a = 0.1, b = 0.7, c = 3;
  EXPECT_EQ(value("a + b * c - 1"), a + b * c - 1);
  EXPECT_EQ(value("(a + b) / c + a"), (a + b) / c + a);
  EXPECT_EQ(value("-a + 2 * -(-b)"), -a + 2 * -(-b));
  EXPECT_EQ(value("1.5e-1"), 0.15);
  EXPECT_EQ(value("a - b - -1"), a - b - -1);
}

void expectError(const std::string& yaml, const std::vector<std::string>& needles) {
  try {
    parseSceneConfig(yaml, "my.yaml");
    ADD_FAILURE() << "no error for: " << yaml;
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("scene config 'my.yaml': ", 0), 0u) << what;
    for (const std::string& needle : needles) {
      EXPECT_NE(what.find(needle), std::string::npos) << what << "\n(expected: " << needle << ")";
    }
  }
}

const char* const kBox = "boxes:\n  - position: [2, 0, 0.1]\n    size: [1, 1, 0.2]\n";

TEST(SceneErrors, NameFileLineAndKey) {
  expectError("step1_height: 0.2\n", {"line 1: unknown key 'step1_height' (known: base, "});
  expectError(
      std::string(kBox) + "    colour: red\n",
      {"line 4: unknown key 'boxes[0].colour' (known in boxes[0]: position, size, yaw_deg)"});
  expectError(std::string(kBox) + "    slope_deg: 5\n",
              {"line 4: unknown key 'boxes[0].slope_deg'"});
  expectError("boxes:\n  - position: [2, 0, 0.1]\n    size: [1, -1, 0.2]\n",
              {"line 3: boxes[0].size[1]: -1 m is out of range; a size must be > 0"});
  expectError("boxes:\n  - position: [2, 0, 0.1]\n    size: [1, 1, 0]\n",
              {"line 3: boxes[0].size[2]: 0 m is out of range"});
  expectError("boxes:\n  - position: [2, 0]\n    size: [1, 1, 1]\n",
              {"line 2: boxes[0].position: expected a list of 3 numbers [x, y, z], got 2 items"});
  expectError("boxes:\n  - size: [1, 1, 1]\n", {"line 2: missing key 'boxes[0].position'"});
  expectError("ramps:\n  - {position: [2, 0, 0], size: [2, 1, 0.1]}\n",
              {"line 2: missing key 'ramps[0].slope_deg'"});
  expectError("ramps:\n  - position: [2, 0, 0]\n    size: [2, 1, 0.1]\n    slope_deg: 20.5\n",
              {"line 4: ramps[0].slope_deg: 20.5 deg is steeper than the 20 deg a ramp may have"});
  expectError("ramps:\n  - position: [2, 0, 0]\n    size: [2, 1, 0.1]\n    slope_deg: -21\n",
              {"ramps[0].slope_deg: -21 deg is steeper"});
  expectError("friction: 0\n", {"line 1: friction: 0 is out of range; valid range [0.01, 5]"});
  expectError("friction: high\n", {"line 1: friction: 'high' is not a number or an expression"});
  expectError("friction: \"0.5\"\n", {"line 1: friction: '0.5' is not a number (it is quoted)"});
  expectError("friction: [1]\n", {"line 1: friction: expected a number, got a list"});
  expectError("friction:\n", {"line 1: friction: no value"});
  expectError("friction: 1 / 0\n", {"friction: '1 / 0' = inf is not a finite number"});
  expectError("friction: 0.5 +\n", {"friction: '0.5 +' is not a number", "a value is missing"});
  expectError("friction: (0.5\n", {"a '(' is not closed"});
  expectError("friction: 0x10\n", {"unexpected 'x'"});
  expectError("friction: .nan\n", {"friction: '.nan' is not a number"});
  expectError("friction: mu\n", {"'mu' is not a parameter; the scene's parameters: none"});
  expectError("parameters: {h: 0.1}\nfriction: 2 * hh\n",
              {"line 2: friction: ", "'hh' is not a parameter; the scene's parameters: h"});
  expectError("parameters: {h: 1e400}\n", {"line 1: parameters.h: '1e400' is not a finite number"});
  expectError("parameters: {h: 1 + 2}\n", {"parameters.h: '1 + 2' is not a number"});
  expectError("parameters: {2h: 1}\n", {"'2h' is not a parameter name"});
  expectError("parameters: {friction: 1}\n", {"parameters.friction: 'friction' is a key"});
  expectError("parameters:\n  h: 1\n  h: 2\n",
              {"line 3: parameters.h: given twice (first on line 2)"});
  expectError("friction: 1\nfriction: 2\n", {"line 2: friction: given twice (first on line 1)"});
  expectError("boxes:\n  - position: [60, 0, 0.1]\n    size: [1, 1, 0.2]\n",
              {"line 2: boxes[0]: reaches beyond the floor"});
  expectError("boxes:\n  - position: [2, 0, 0.1]\n    size: [1, 1, 0.2]\n    yaw_deg: 400\n",
              {"boxes[0].yaw_deg: 400 deg is out of range"});
  expectError("- a\n", {"line 1: expected a mapping"});
  expectError("boxes: {a: 1}\n", {"line 1: boxes: expected a list, got a mapping"});
  expectError("a: [\n", {"scene config 'my.yaml': "});
  expectError("friction: 1\n---\nfriction: 2\n", {"more than one YAML document"});
  expectError("base: moon\n", {"line 1: base: unknown scene 'moon'"});
  expectError("base: step20\nparameters: {height: 0.1}\n",
              {"line 2: parameters.height: 'height' is not a parameter of the base scene (it "
               "has: start_x, width, step1_height, step1_length)"});
  expectError("base: step20\nparameters: {step1_height: -0.1}\n",
              {"step20.yaml': line 13: boxes[0].size[2]: -0.1 m is out of range"});
  // A file that is its own base.
  const std::string loop = writeTemp("scene_loop.yaml", "base: scene_loop.yaml\n");
  try {
    loadSceneConfig(loop);
    ADD_FAILURE() << "no error for a loop";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("based on each other more than 8 deep"), std::string::npos)
        << e.what();
  }
}

TEST(SceneErrors, FileThatIsNotARegularFileIsRefusedWithoutReading) {
  const std::string dir = ::testing::TempDir() + "scene_dir_test";
  ::mkdir(dir.c_str(), 0700);
  const std::string fifo = ::testing::TempDir() + "scene_fifo_test";
  std::remove(fifo.c_str());
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  for (const std::string& path :
       {dir, fifo, std::string("/dev/zero"), std::string("/nonexistent/scene.yaml")}) {
    try {
      loadSceneConfig(path);  // a FIFO would block here if it were opened for reading
      ADD_FAILURE() << "no error for " << path;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("scene config '" + path + "'"), std::string::npos)
          << e.what();
    }
  }
  std::remove(fifo.c_str());
}

// Every input that ever failed the scene fuzz harness (fuzz/regressions/scene) is now a
// quick, documented error or a valid scene.
TEST(SceneErrors, FuzzRegressionsAreErrorsOrValid) {
  const std::string dir = std::string(ROLLSTEP_SOURCE_DIR) + "/fuzz/regressions/scene";
  int n = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    std::ifstream in(entry.path(), std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    try {
      parseSceneConfig(text.str(), "regression").validate();
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()).rfind("scene config 'regression': ", 0), 0u) << e.what();
    }
    ++n;
  }
  EXPECT_GE(n, 1);
}

TEST(SceneGeometry, YawedBoxAndRamp) {
  const SceneConfig c = parseSceneConfig(
      "boxes:\n  - {position: [3, 1, 0.1], size: [2, 1, 0.2], yaw_deg: 90}\n"
      "ramps:\n  - {position: [-3, 0, 0], size: [2, 1, 0.1], slope_deg: 10}\n",
      "g.yaml");
  const SceneGeometry g = resolveScene(c);
  // The yawed box: 2 m along y, 1 m along x.
  EXPECT_DOUBLE_EQ(terrainHeight(g, 3.4, 1.9), 0.2);
  EXPECT_DOUBLE_EQ(terrainHeight(g, 3.6, 1.0), 0.0);
  // The ramp rises towards +x: 10 deg from its top face's centre.
  const SceneSolid& ramp = g.solids[1];
  const Eigen::Vector3d top = ramp.topCenter();
  EXPECT_NEAR(top.x(), -3.0 - 0.05 * std::sin(10 * M_PI / 180), 1e-12);
  EXPECT_NEAR(ramp.topHeightAt(top.x() + 0.5, 0.3), top.z() + 0.5 * std::tan(10 * M_PI / 180),
              1e-12);
  EXPECT_NEAR(ramp.topNormal().x(), -std::sin(10 * M_PI / 180), 1e-12);
  EXPECT_FALSE(ramp.coversTop(top.x() + std::cos(10 * M_PI / 180) + 0.01, 0.0));
  EXPECT_TRUE(ramp.coversTop(top.x() + std::cos(10 * M_PI / 180) - 0.01, 0.0));
  // The MJCF carries the rotations, and an axis-aligned box none.
  const std::string xml = terrainMjcf(c);
  EXPECT_NE(xml.find("name=\"block0\" type=\"box\" pos=\"3 1 0.10000000000000001\" quat=\""),
            std::string::npos)
      << xml;
  EXPECT_NE(xml.find("name=\"ramp0\""), std::string::npos) << xml;
  EXPECT_EQ(terrainMjcf(loadScene("step20")).find("quat"), std::string::npos);
}

TEST(SceneGeometry, SolidsAtTheStartAreFound) {
  const auto at_start = [](const std::string& solid) {
    return solidAtStart(resolveScene(parseSceneConfig(solid, "s.yaml")), 0.5) != nullptr;
  };
  EXPECT_TRUE(at_start("boxes:\n  - {position: [0.9, 0, 0.1], size: [1, 1, 0.2]}\n"));
  EXPECT_FALSE(at_start("boxes:\n  - {position: [1.1, 0, 0.1], size: [1, 1, 0.2]}\n"));
  EXPECT_TRUE(at_start("boxes:\n  - {position: [-0.9, 0.9, 0.1], size: [1, 1, 0.2]}\n"));
  // A box 45 deg yawed whose corner points at the start: its bounding box reaches into the
  // square, the box does not.
  EXPECT_FALSE(
      at_start("boxes:\n  - {position: [1.1, 1.1, 0.1], size: [1, 1, 0.2], yaw_deg: 45}\n"));
  EXPECT_TRUE(
      at_start("boxes:\n  - {position: [0.8, 0.8, 0.1], size: [1, 1, 0.2], yaw_deg: 45}\n"));
  // A ramp's bottom reaches further than its top face.
  EXPECT_TRUE(at_start("ramps:\n  - {position: [1.5, 0, 0], size: [2, 1, 0.4], slope_deg: 20}\n"));
}

}  // namespace
}  // namespace rollstep::sim
