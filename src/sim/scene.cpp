#include "rollstep/sim/scene.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

#include "rollstep/common/number_text.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/common/yaml_tree.hpp"

namespace rollstep::sim {

namespace {
constexpr std::size_t kMaxSceneConfigBytes = std::size_t{1} << 20;
// Every scene kind, in declaration order: the one list the names are read from.
constexpr SceneKind kSceneKinds[] = {SceneKind::kFlat, SceneKind::kStep20, SceneKind::kStairs2};
}  // namespace

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
  for (const SceneKind kind : kSceneKinds) {
    if (toString(kind) == name) return kind;
  }
  throw std::invalid_argument("unknown scene '" + std::string(name) + "' (expected " +
                              sceneNamesText() + ")");
}

const std::vector<std::string>& sceneNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> v;
    for (const SceneKind kind : kSceneKinds) v.emplace_back(toString(kind));
    return v;
  }();
  return names;
}

std::string sceneNamesText() {
  const std::vector<std::string>& names = sceneNames();
  std::string text;
  for (std::size_t i = 0; i < names.size(); ++i) {
    text += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + names[i];
  }
  return text;
}

bool isSceneName(std::string_view name) {
  for (const std::string& s : sceneNames()) {
    if (s == name) return true;
  }
  return false;
}

namespace {

// The one table of numeric scene parameters (docs/USER_GUIDE.md "Scene parameters" mirrors it).
// Ranges: what the terrain model and MuJoCo's collision handle well and what a scene of
// this robot can sensibly be; the robot-dependent lower bound of start_x is the Plant's.
const std::array<SceneField, kNumSceneFields> kSceneFields{{
    {"friction", &SceneConfig::friction, "", 0.01, 5.0, "terrain friction coefficient"},
    {"start_x", &SceneConfig::start_x, "m", 0.0, 50.0,
     "robot start (base centre at x = 0) to the near edge of block 1"},
    {"width", &SceneConfig::width, "m", 0.1, 100.0, "lateral extent of the blocks"},
    {"step1_height", &SceneConfig::step1_height, "m", 0.001, 1.0,
     "step20 block height / stairs2 first rise"},
    {"step1_length", &SceneConfig::step1_length, "m", 0.01, 50.0,
     "step20 block length / stairs2 first landing"},
    {"step2_height", &SceneConfig::step2_height, "m", 0.001, 1.0, "stairs2 second rise"},
    {"step2_length", &SceneConfig::step2_length, "m", 0.01, 50.0, "stairs2 top landing"},
}};

std::string numberText(double v) { return shortestNumberText(v); }

std::string withUnit(double v, const SceneField& f) {
  return numberText(v) + (*f.unit ? std::string(" ") + f.unit : std::string());
}

std::string rangeText(const SceneField& f) {
  return "valid range [" + numberText(f.min) + ", " + numberText(f.max) + "]" +
         (*f.unit ? std::string(" ") + f.unit : std::string()) + " (" + f.meaning + ")";
}

/// Empty if v is a valid value of f, else what is wrong with it.
std::string problemWith(const SceneField& f, double v) {
  if (!std::isfinite(v)) return numberText(v) + " is not a finite number; " + rangeText(f);
  if (v < f.min || v > f.max) return withUnit(v, f) + " is out of range; " + rangeText(f);
  return {};
}

std::string knownKeys() {
  std::string keys = "scene";
  for (const SceneField& f : kSceneFields) keys += std::string(", ") + f.key;
  return keys;
}

/// A YAML plain scalar as a number: [+-]digits[.digits][(e|E)[+-]digits] (no hexadecimal,
/// octal or trailing text), or YAML's .inf/.nan (and nan/inf), which parse to be refused
/// as not finite. Returns false if the text is not a number.
bool parseNumber(const std::string& text, double& value) {
  std::string lower;
  for (char c : text) lower += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const std::size_t sign = (!lower.empty() && (lower[0] == '+' || lower[0] == '-')) ? 1 : 0;
  const std::string unsigned_text = lower.substr(sign);
  if (unsigned_text == ".nan" || unsigned_text == "nan") {
    value = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  if (unsigned_text == ".inf" || unsigned_text == "inf" || unsigned_text == "infinity") {
    value = (lower[0] == '-' ? -1.0 : 1.0) * std::numeric_limits<double>::infinity();
    return true;
  }
  const auto digit = [&](std::size_t i) {
    return i < lower.size() && std::isdigit(static_cast<unsigned char>(lower[i]));
  };
  std::size_t i = sign, digits = 0;
  while (digit(i)) ++i, ++digits;
  if (i < lower.size() && lower[i] == '.') {
    ++i;
    while (digit(i)) ++i, ++digits;
  }
  if (digits == 0) return false;
  if (i < lower.size() && lower[i] == 'e') {
    ++i;
    if (i < lower.size() && (lower[i] == '+' || lower[i] == '-')) ++i;
    if (!digit(i)) return false;
    while (digit(i)) ++i;
  }
  if (i != lower.size()) return false;
  value = std::strtod(text.c_str(), nullptr);  // 1e400 overflows to inf: refused as such
  return true;
}

}  // namespace

const std::array<SceneField, kNumSceneFields>& sceneFields() { return kSceneFields; }

void SceneConfig::validate() const {
  for (const SceneField& f : kSceneFields) {
    const std::string problem = problemWith(f, this->*f.member);
    if (!problem.empty()) throw std::invalid_argument(std::string(f.key) + ": " + problem);
  }
}

SceneConfig parseSceneConfig(const std::string& yaml_text, const std::string& source_name) {
  const std::string where = "scene config '" + source_name + "': ";
  const auto fail = [&](const std::string& what) -> void {
    throw std::runtime_error(where + what);
  };
  const auto line = [](const yaml::Node& node) {
    return "line " + std::to_string(node.line()) + ": ";
  };
  SceneConfig config;
  config.source = "scene config '" + source_name + "'";
  // libyaml's parse (yaml_tree.hpp): malformed text and a second document are errors.
  yaml::Document document = [&]() {
    try {
      return yaml::Document::parse(yaml_text);
    } catch (const yaml::YamlError& e) {
      const std::string what = e.what();
      if (what.rfind("holds more than one", 0) == 0) {
        fail(what + "; a scene config is one mapping of key: value");
      }
      fail("YAML error: " + what);
      throw;  // unreachable: fail throws
    }
  }();
  const yaml::Node root = document.root();
  if (root.isNull()) return config;  // empty file or comments only: all defaults
  if (!root.isMapping()) fail(line(root) + "expected a mapping of key: value");
  std::map<std::string, int> seen;  // key -> line (1-based) where it was first given
  for (std::size_t item = 0; item < root.size(); ++item) {
    const yaml::Node key_node = root.key(item);
    const yaml::Node value = root.value(item);
    if (!key_node.isScalar()) fail(line(key_node) + "a key must be a plain name");
    const std::string key = key_node.scalar();
    const int key_line = key_node.line();
    const std::string at = line(key_node) + key + ": ";
    const SceneField* field = nullptr;
    for (const SceneField& f : kSceneFields) {
      if (key == f.key) field = &f;
    }
    if (field == nullptr && key != "scene") {
      fail(line(key_node) + "unknown key '" + key + "' (known: " + knownKeys() + ")");
    }
    // YAML forbids a repeated key; the last would otherwise win silently.
    if (const auto it = seen.find(key); it != seen.end()) {
      fail(line(key_node) + "key '" + key + "' given twice (first on line " +
           std::to_string(it->second) + ")");
    }
    seen.emplace(key, key_line);
    if (value.isNull()) fail(at + "no value");
    if (!value.isScalar()) fail(at + "expected a single value, got " + value.kindName());
    const std::string& text = value.scalar();
    if (field == nullptr) {  // scene
      try {
        config.kind = sceneKindFromString(text);
      } catch (const std::invalid_argument& e) {
        fail(at + e.what());
      }
      continue;
    }
    double number = 0.0;
    if (!value.plain() || !parseNumber(text, number)) {
      const std::string why = value.plain()         ? ""
                              : value.tag().empty() ? " (it is quoted)"
                                                    : " (it has the tag " + value.tag() + ")";
      fail(at + "'" + text + "' is not a number" + why + "; " + rangeText(*field));
    }
    if (!std::isfinite(number)) {
      fail(at + "'" + text + "' is not a finite number; " + rangeText(*field));
    }
    const std::string problem = problemWith(*field, number);
    if (!problem.empty()) fail(at + problem);
    config.*(field->member) = number;
  }
  try {
    config.validate();
  } catch (const std::invalid_argument& e) {
    fail(e.what());
  }
  return config;
}

SceneConfig loadSceneConfig(const std::string& yaml_file) {
  std::string text;
  try {
    text = readTextFile(yaml_file, "scene config", kMaxSceneConfigBytes);
  } catch (const InputError& e) {
    throw std::runtime_error(e.what());
  }
  return parseSceneConfig(text, yaml_file);
}

std::string toYaml(const SceneConfig& config) {
  std::string out = "scene: " + std::string(toString(config.kind)) + "\n";
  for (const SceneField& f : kSceneFields) {
    out += std::string(f.key) + ": " + numberText(config.*f.member) + "\n";
  }
  return out;
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
