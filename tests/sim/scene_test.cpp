// Scene parameters: defaults of the spec, YAML loading with strict keys, geometry.
#include "rollstep/sim/scene.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

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
    EXPECT_TRUE(isSceneName(toString(k)));
  }
  EXPECT_THROW(sceneKindFromString("steps"), std::invalid_argument);
  EXPECT_EQ(sceneNames(), (std::vector<std::string>{"flat", "step20", "stairs2"}));
  EXPECT_FALSE(isSceneName("steps"));
  EXPECT_FALSE(isSceneName("step20_nmpc"));
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

std::string numberText(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// Every numeric key, for every way a number can be wrong: the message names the file,
// the line, the key and the valid range.
TEST(SceneConfig, EveryNumericKeyRefusesBadValues) {
  for (const SceneField& f : sceneFields()) {
    const std::string key = f.key;
    SCOPED_TRACE(key);
    for (const char* text : {".nan", ".NaN", ".inf", "-.inf", "1e400", "-1e400"}) {
      expectError("scene: step20\n" + key + ": " + text + "\n",
                  "line 2: " + key + ": '" + text + "' is not a finite");
    }
    for (const char* text : {"high", "0x10", "1.0.0", "2 m", "true", "1,5"}) {
      expectError(key + ": " + text + "\n", "line 1: " + key + ": '" + text + "' is not a number");
    }
    expectError(key + ": \"0.5\"\n", "is not a number (it is quoted)");
    expectError(key + ": !!str 0.5\n", "is not a number (it has the tag tag:yaml.org,2002:str)");
    expectError(key + ": [1, 2]\n", key + ": expected a single value, got a list");
    expectError(key + ": {a: 1}\n", key + ": expected a single value, got a mapping");
    expectError(key + ":\n", key + ": no value");
    const double below = f.min == 0.0 ? -1e-9 : f.min * (1 - 1e-9);
    const double above = f.max * (1 + 1e-9);
    for (double bad : {below, above, -f.max, 1e100, -1e100}) {
      expectError(key + ": " + numberText(bad) + "\n", key + ": ");
      expectError(key + ": " + numberText(bad) + "\n", "is out of range; valid range [");
    }
    // The bounds themselves are valid and read back exactly.
    for (double good : {f.min, f.max}) {
      const SceneConfig c = parseSceneConfig(key + ": " + numberText(good) + "\n", "t");
      EXPECT_EQ(c.*f.member, good);
    }
    // validate() names the key too (configs built in code).
    SceneConfig c;
    c.*f.member = std::numeric_limits<double>::quiet_NaN();
    try {
      c.validate();
      ADD_FAILURE() << "validate accepted NaN";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(key + ": nan is not a finite number"), std::string::npos)
          << e.what();
    }
    c.*f.member = f.max * 2 + 1;
    EXPECT_THROW(c.validate(), std::invalid_argument);
  }
}

TEST(SceneConfig, RepeatedKeysAreErrors) {
  expectError("scene: flat\nscene: step20\n", "line 2: key 'scene' given twice (first on line 1)");
  for (const SceneField& f : sceneFields()) {
    const std::string key = f.key;
    const std::string v = numberText(f.max);
    expectError(key + ": " + v + "\nscene: flat\n" + key + ": " + v + "\n",
                "line 3: key '" + key + "' given twice (first on line 1)");
  }
}

TEST(SceneConfig, OneDocumentOfKeyValuePairs) {
  expectError("scene: step20\n---\nfriction: 0.5\n", "more than one YAML document");
  expectError("---\nscene: step20\n---\n", "more than one YAML document");
  expectError("scene: step20\n...\n---\nscene: flat\n", "more than one YAML document");
  expectError("- scene\n", "mapping");
  expectError("just text\n", "mapping");
  expectError("? [a, b]\n: 1\n", "a key must be a plain name");
  expectError("scene: [flat]\n", "scene: expected a single value");
  expectError("scene: 3\n", "unknown scene '3'");
  // One document with explicit markers, comments only, or nothing: fine.
  EXPECT_EQ(parseSceneConfig("---\nscene: stairs2\n...\n", "t").kind, SceneKind::kStairs2);
  EXPECT_EQ(parseSceneConfig("# nothing\n", "t").kind, SceneKind::kFlat);
  EXPECT_EQ(parseSceneConfig("---\n", "t").kind, SceneKind::kFlat);
}

TEST(SceneConfig, ToYamlRoundTripsAndNamesSource) {
  SceneConfig c;
  c.kind = SceneKind::kStairs2;
  c.friction = 0.123456789;
  c.step2_length = 2.5;
  const SceneConfig back = parseSceneConfig(toYaml(c), "round trip");
  EXPECT_EQ(back.kind, c.kind);
  for (const SceneField& f : sceneFields()) EXPECT_EQ(back.*f.member, c.*f.member) << f.key;
  EXPECT_EQ(back.source, "scene config 'round trip'");
}

TEST(SceneConfig, FileThatIsNotARegularFileIsRefusedWithoutReading) {
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

// The user guide's scene block lists every key with the range of the table and its default.
TEST(SceneConfig, UserGuideDocumentsEveryKeyWithItsRange) {
  std::ifstream in(std::string(ROLLSTEP_SOURCE_DIR) + "/docs/USER_GUIDE.md");
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  const SceneConfig defaults;
  const auto text = [](double v) {
    std::ostringstream s;
    s << v;
    return s.str();
  };
  for (const SceneField& f : sceneFields()) {
    const std::string key = std::string(f.key) + ": ";
    const auto it = std::find_if(lines.begin(), lines.end(),
                                 [&](const std::string& l) { return l.rfind(key, 0) == 0; });
    ASSERT_NE(it, lines.end()) << "docs/USER_GUIDE.md has no line '" << key << "...'";
    const std::string range =
        f.min == 0.0 ? "up to " + text(f.max) : text(f.min) + " to " + text(f.max);
    EXPECT_NE(it->find(range), std::string::npos) << *it << " (expected " << range << ")";
    EXPECT_EQ(std::stod(it->substr(key.size())), defaults.*f.member) << *it;
  }
}

// Every input that ever failed the scene fuzz harness (fuzz/regressions/scene) is now a
// quick, documented error or a valid config. The first one made yaml-cpp 0.7's LoadAll
// loop forever.
TEST(SceneConfig, FuzzRegressionsAreErrorsOrValid) {
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

TEST(SceneConfig, ExampleScenesOfTheRepositoryAreValid) {
  for (const char* name : {"step20_custom.yaml"}) {
    const std::string path = std::string(ROLLSTEP_SOURCE_DIR) + "/config/scenes/" + name;
    const SceneConfig c = loadSceneConfig(path);
    EXPECT_EQ(c.kind, SceneKind::kStep20) << path;
  }
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
