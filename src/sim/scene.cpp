#include "rollstep/sim/scene.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace rollstep::sim {

std::string_view toString(SceneKind kind) {
  switch (kind) {
    case SceneKind::kFlat:
      return "flat";
    case SceneKind::kStep20:
      return "step20";
    case SceneKind::kStairs2:
      return "stairs2";
  }
  return "?";
}

SceneKind sceneKindFromString(std::string_view name) {
  if (name == "flat") return SceneKind::kFlat;
  if (name == "step20") return SceneKind::kStep20;
  if (name == "stairs2") return SceneKind::kStairs2;
  throw std::invalid_argument("unknown scene '" + std::string(name) +
                              "' (expected flat, step20 or stairs2)");
}

void SceneConfig::validate() const {
  const auto check = [](double value, const char* name, bool allow_zero) {
    if (!std::isfinite(value) || value < 0.0 || (!allow_zero && value == 0.0)) {
      throw std::invalid_argument(std::string("scene parameter ") + name + " = " +
                                  std::to_string(value) +
                                  (allow_zero ? " must be >= 0" : " must be > 0"));
    }
  };
  check(friction, "friction", false);
  check(start_x, "start_x", true);
  check(width, "width", false);
  check(step1_height, "step1_height", false);
  check(step1_length, "step1_length", false);
  check(step2_height, "step2_height", false);
  check(step2_length, "step2_length", false);
}

SceneConfig parseSceneConfig(const std::string& yaml_text, const std::string& source_name) {
  const auto fail = [&](const std::string& what) -> void {
    throw std::runtime_error("scene config " + source_name + ": " + what);
  };
  SceneConfig config;
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    fail(std::string("YAML error: ") + e.what());
  }
  if (root.IsNull()) return config;  // empty file: all defaults
  if (!root.IsMap()) fail("expected a mapping of key: value");
  for (const auto& item : root) {
    const std::string key = item.first.as<std::string>();
    const YAML::Node& value = item.second;
    try {
      if (key == "scene") {
        config.kind = sceneKindFromString(value.as<std::string>());
        continue;
      }
      double* target = nullptr;
      if (key == "friction") target = &config.friction;
      if (key == "start_x") target = &config.start_x;
      if (key == "width") target = &config.width;
      if (key == "step1_height") target = &config.step1_height;
      if (key == "step1_length") target = &config.step1_length;
      if (key == "step2_height") target = &config.step2_height;
      if (key == "step2_length") target = &config.step2_length;
      if (target == nullptr) {
        fail("unknown key '" + key +
             "' (known: scene, friction, start_x, width, step1_height, step1_length, "
             "step2_height, step2_length)");
      }
      *target = value.as<double>();
    } catch (const YAML::Exception& e) {
      fail("bad value for '" + key + "': " + e.what());
    } catch (const std::invalid_argument& e) {
      fail("bad value for '" + key + "': " + e.what());
    }
  }
  try {
    config.validate();
  } catch (const std::invalid_argument& e) {
    fail(e.what());
  }
  return config;
}

SceneConfig loadSceneConfig(const std::string& yaml_file) {
  std::ifstream in(yaml_file);
  if (!in) throw std::runtime_error("scene config " + yaml_file + ": cannot open file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return parseSceneConfig(buffer.str(), yaml_file);
}

std::vector<TerrainBox> terrainBoxes(const SceneConfig& c) {
  std::vector<TerrainBox> boxes;
  const auto add = [&](double x0, double length, double height) {
    boxes.push_back(TerrainBox{Eigen::Vector3d(x0 + 0.5 * length, 0.0, 0.5 * height),
                               Eigen::Vector3d(0.5 * length, 0.5 * c.width, 0.5 * height)});
  };
  switch (c.kind) {
    case SceneKind::kFlat:
      break;
    case SceneKind::kStep20:
      add(c.start_x, c.step1_length, c.step1_height);
      break;
    case SceneKind::kStairs2:
      // Lower block runs under the top landing so that there is no gap.
      add(c.start_x, c.step1_length + c.step2_length, c.step1_height);
      add(c.start_x + c.step1_length, c.step2_length, c.step1_height + c.step2_height);
      break;
  }
  return boxes;
}

double terrainHeight(const SceneConfig& config, double x, double y) {
  double h = 0.0;
  for (const TerrainBox& b : terrainBoxes(config)) {
    if (std::abs(x - b.center.x()) <= b.half_size.x() &&
        std::abs(y - b.center.y()) <= b.half_size.y()) {
      h = std::max(h, b.center.z() + b.half_size.z());
    }
  }
  return h;
}

std::string terrainMjcf(const SceneConfig& config) {
  config.validate();
  std::string xml;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "    <light name=\"sun\" directional=\"true\" pos=\"0 0 5\" dir=\"0.3 0.2 -1\"/>\n"
                "    <geom name=\"floor\" type=\"plane\" size=\"50 50 0.1\" group=\"0\" "
                "contype=\"1\" conaffinity=\"1\" friction=\"%.17g 0.005 0.0001\" "
                "rgba=\"0.55 0.6 0.55 1\"/>\n",
                config.friction);
  xml += buf;
  int i = 0;
  for (const TerrainBox& b : terrainBoxes(config)) {
    std::snprintf(buf, sizeof buf,
                  "    <geom name=\"block%d\" type=\"box\" pos=\"%.17g %.17g %.17g\" "
                  "size=\"%.17g %.17g %.17g\" group=\"0\" contype=\"1\" conaffinity=\"1\" "
                  "friction=\"%.17g 0.005 0.0001\" rgba=\"0.6 0.55 0.5 1\"/>\n",
                  i++, b.center.x(), b.center.y(), b.center.z(), b.half_size.x(), b.half_size.y(),
                  b.half_size.z(), config.friction);
    xml += buf;
  }
  return xml;
}

}  // namespace rollstep::sim
