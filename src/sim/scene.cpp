#include "rollstep/sim/scene.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include "rollstep/common/number_text.hpp"
#include "rollstep/common/settings_table.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/common/yaml_tree.hpp"

namespace rollstep::sim {

namespace {

constexpr std::size_t kMaxSceneConfigBytes = std::size_t{1} << 20;
constexpr int kMaxBaseDepth = 8;  // base chains longer than this are a loop
constexpr double kDegree = 3.14159265358979323846 / 180.0;

std::string numberText(double v) { return shortestNumberText(v); }

bool isName(std::string_view s) {
  if (s.empty() || !(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
  });
}

/// A scene name: letters, digits, _ and - (a file NAME.yaml of the scenes directory).
bool isSceneFileName(std::string_view s) {
  return !s.empty() && s.size() <= 100 && s[0] != '-' &&
         std::all_of(s.begin(), s.end(), [](char c) {
           return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
         });
}

// ---- Expressions: numbers and parameter names with + - * / and parentheses. ----

class Expression {
 public:
  Expression(const std::string& text, const std::vector<SceneParameter>& parameters)
      : text_(text), parameters_(parameters) {}

  /// The value, or throws std::invalid_argument saying what is wrong with the text.
  double evaluate() {
    skipSpace();
    if (at_ == text_.size()) fail("no value");
    const double v = sum();
    if (at_ != text_.size()) fail("unexpected '" + text_.substr(at_, 1) + "'");
    return v;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw std::invalid_argument("'" + text_ + "' is not a number or an expression of the " +
                                "scene's parameters (" + what + ")");
  }
  void skipSpace() {
    while (at_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[at_]))) ++at_;
  }
  bool take(char c) {
    skipSpace();
    if (at_ < text_.size() && text_[at_] == c) {
      ++at_;
      return true;
    }
    return false;
  }
  double sum() {
    double v = product();
    while (true) {
      if (take('+')) {
        v = v + product();
      } else if (take('-')) {
        v = v - product();
      } else {
        return v;
      }
    }
  }
  double product() {
    double v = factor();
    while (true) {
      if (take('*')) {
        v = v * factor();
      } else if (take('/')) {
        v = v / factor();
      } else {
        return v;
      }
    }
  }
  double factor() {
    if (++depth_ > 64) fail("nested too deeply");
    double v = 0.0;
    if (take('-')) {
      v = -factor();
    } else if (take('+')) {
      v = factor();
    } else if (take('(')) {
      v = sum();
      if (!take(')')) fail("a '(' is not closed");
    } else {
      skipSpace();
      v = atom();
    }
    --depth_;
    return v;
  }
  double atom() {
    const auto digit = [&](std::size_t i) {
      return i < text_.size() && std::isdigit(static_cast<unsigned char>(text_[i]));
    };
    const std::size_t start = at_;
    if (at_ < text_.size() &&
        (std::isalpha(static_cast<unsigned char>(text_[at_])) || text_[at_] == '_')) {
      while (at_ < text_.size() &&
             (std::isalnum(static_cast<unsigned char>(text_[at_])) || text_[at_] == '_')) {
        ++at_;
      }
      const std::string name = text_.substr(start, at_ - start);
      for (const SceneParameter& p : parameters_) {
        if (p.name == name) return p.value;
      }
      std::string known;
      for (const SceneParameter& p : parameters_) known += (known.empty() ? "" : ", ") + p.name;
      fail("'" + name +
           "' is not a parameter; the scene's parameters: " + (known.empty() ? "none" : known));
    }
    // [digits][.digits][(e|E)[+-]digits], at least one digit: a decimal number.
    std::size_t digits = 0;
    while (digit(at_)) ++at_, ++digits;
    if (at_ < text_.size() && text_[at_] == '.') {
      ++at_;
      while (digit(at_)) ++at_, ++digits;
    }
    if (digits == 0) {
      fail(at_ < text_.size() ? "unexpected '" + text_.substr(at_, 1) + "'" : "a value is missing");
    }
    if (at_ < text_.size() && (text_[at_] == 'e' || text_[at_] == 'E')) {
      ++at_;
      if (at_ < text_.size() && (text_[at_] == '+' || text_[at_] == '-')) ++at_;
      if (!digit(at_)) fail("an exponent has no digits");
      while (digit(at_)) ++at_;
    }
    return std::strtod(text_.substr(start, at_ - start).c_str(), nullptr);
  }

  const std::string& text_;
  const std::vector<SceneParameter>& parameters_;
  std::size_t at_ = 0;
  int depth_ = 0;
};

// ---- Checks of resolved numbers. ----

/// "<where>: <path>: " for messages.
std::string at(const std::string& where, const std::string& path) {
  return (where.empty() ? std::string() : where + ": ") + path + ": ";
}

double valueOf(const SceneValue& v, const std::vector<SceneParameter>& parameters,
               const std::string& path) {
  double x = 0.0;
  try {
    x = Expression(v.text, parameters).evaluate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(at(v.where, path) + e.what());
  }
  if (!std::isfinite(x)) {
    throw std::invalid_argument(at(v.where, path) + "'" + v.text + "' = " + numberText(x) +
                                " is not a finite number");
  }
  return x;
}

std::string label(const char* list, std::size_t i) {
  return std::string(list) + "[" + std::to_string(i) + "]";
}

SceneSolid resolveSolid(const SceneSolidSpec& s, bool ramp, const std::string& name,
                        const std::vector<SceneParameter>& parameters) {
  SceneSolid out;
  out.ramp = ramp;
  out.label = name + (s.where.empty() ? "" : " (" + s.where + ")");
  for (int k = 0; k < 3; ++k) {
    const std::string index = "[" + std::to_string(k) + "]";
    out.center[k] = valueOf(s.position[k], parameters, name + ".position" + index);
    const double size = valueOf(s.size[k], parameters, name + ".size" + index);
    if (!(size > 0.0) || size > kSceneMaxSize) {
      throw std::invalid_argument(
          at(s.size[k].where, name + ".size" + index) + numberText(size) +
          " m is out of range; a size must be > 0 and <= " + numberText(kSceneMaxSize) + " m");
    }
    out.half_size[k] = 0.5 * size;
  }
  const double yaw_deg = valueOf(s.yaw_deg, parameters, name + ".yaw_deg");
  if (std::abs(yaw_deg) > 360.0) {
    throw std::invalid_argument(at(s.yaw_deg.where, name + ".yaw_deg") + numberText(yaw_deg) +
                                " deg is out of range [-360, 360] deg");
  }
  out.yaw = yaw_deg * kDegree;
  if (ramp) {
    const double slope_deg = valueOf(s.slope_deg, parameters, name + ".slope_deg");
    if (std::abs(slope_deg) > kSceneMaxSlopeDeg) {
      throw std::invalid_argument(at(s.slope_deg.where, name + ".slope_deg") +
                                  numberText(slope_deg) + " deg is steeper than the " +
                                  numberText(kSceneMaxSlopeDeg) + " deg a ramp may have");
    }
    out.slope = slope_deg * kDegree;
  }
  // Everything on the floor (seen from above) and not absurdly high.
  for (const Eigen::Vector2d& c : out.topFootprint()) {
    if (std::abs(c.x()) > kSceneMaxExtent || std::abs(c.y()) > kSceneMaxExtent) {
      throw std::invalid_argument(at(s.where, name) + "reaches beyond the floor (|x|, |y| <= " +
                                  numberText(kSceneMaxExtent) + " m)");
    }
  }
  if (std::abs(out.center.z()) > kSceneMaxSize) {
    throw std::invalid_argument(at(s.position[2].where, name + ".position[2]") +
                                numberText(out.center.z()) + " m is out of range [-" +
                                numberText(kSceneMaxSize) + ", " + numberText(kSceneMaxSize) +
                                "] m");
  }
  return out;
}

}  // namespace

// ---- SceneSolid ----

Eigen::Matrix3d SceneSolid::rotation() const {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(-slope, Eigen::Vector3d::UnitY()))
      .toRotationMatrix();
}

Eigen::Vector3d SceneSolid::topNormal() const {
  if (yaw == 0.0 && slope == 0.0) return Eigen::Vector3d::UnitZ();
  return rotation().col(2);
}

Eigen::Vector3d SceneSolid::topCenter() const {
  // Axis-aligned: exactly the centre plus the half height (as the terrain always was).
  if (yaw == 0.0 && slope == 0.0) {
    return Eigen::Vector3d(center.x(), center.y(), center.z() + half_size.z());
  }
  return center + rotation().col(2) * half_size.z();
}

std::array<Eigen::Vector2d, 4> SceneSolid::topFootprint() const {
  const Eigen::Vector3d t = topCenter();
  const double hx = half_size.x() * std::cos(slope), hy = half_size.y();
  const Eigen::Vector2d ex(std::cos(yaw), std::sin(yaw)), ey(-std::sin(yaw), std::cos(yaw));
  const Eigen::Vector2d c(t.x(), t.y());
  return {c - hx * ex - hy * ey, c + hx * ex - hy * ey, c + hx * ex + hy * ey,
          c - hx * ex + hy * ey};
}

bool SceneSolid::coversTop(double x, double y) const {
  const Eigen::Vector3d t = topCenter();
  const double dx = x - t.x(), dy = y - t.y();
  if (yaw == 0.0 && slope == 0.0) {
    return std::abs(dx) <= half_size.x() && std::abs(dy) <= half_size.y();
  }
  const double c = std::cos(yaw), s = std::sin(yaw);
  const double u = c * dx + s * dy, v = -s * dx + c * dy;
  return std::abs(u) <= half_size.x() * std::cos(slope) && std::abs(v) <= half_size.y();
}

double SceneSolid::topHeightAt(double x, double y) const {
  const Eigen::Vector3d t = topCenter();
  if (slope == 0.0) return t.z();
  const double u = std::cos(yaw) * (x - t.x()) + std::sin(yaw) * (y - t.y());
  return t.z() + std::tan(slope) * u;
}

// ---- Resolving and checking ----

SceneGeometry resolveScene(const SceneConfig& config) {
  SceneGeometry g;
  g.name = config.name;
  g.friction = valueOf(config.friction, config.parameters, "friction");
  if (g.friction < kSceneMinFriction || g.friction > kSceneMaxFriction) {
    throw std::invalid_argument(at(config.friction.where, "friction") + numberText(g.friction) +
                                " is out of range; valid range [" + numberText(kSceneMinFriction) +
                                ", " + numberText(kSceneMaxFriction) +
                                "] (terrain friction coefficient)");
  }
  for (std::size_t i = 0; i < config.boxes.size(); ++i) {
    g.solids.push_back(resolveSolid(config.boxes[i], false, label("boxes", i), config.parameters));
  }
  for (std::size_t i = 0; i < config.ramps.size(); ++i) {
    g.solids.push_back(resolveSolid(config.ramps[i], true, label("ramps", i), config.parameters));
  }
  return g;
}

void SceneConfig::validate() const { resolveScene(*this); }

// ---- Scene names ----

std::string scenesDirectory() {
  if (const char* dir = std::getenv("ROLLSTEP_SCENES_DIR"); dir != nullptr && *dir != '\0') {
    return dir;
  }
  return ROLLSTEP_SCENES_DIR;
}

std::vector<std::string> sceneNames() {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(scenesDirectory(), ec)) {
    const std::filesystem::path& p = entry.path();
    if (p.extension() == ".yaml" && isSceneFileName(p.stem().string()) &&
        entry.is_regular_file(ec)) {
      names.push_back(p.stem().string());
    }
  }
  std::sort(names.begin(), names.end());
  return names;
}

bool isSceneName(std::string_view name) {
  if (!isSceneFileName(name)) return false;
  const std::vector<std::string> names = sceneNames();
  return std::find(names.begin(), names.end(), name) != names.end();
}

std::string sceneNamesText() {
  const std::vector<std::string> names = sceneNames();
  if (names.empty()) return "none (no NAME.yaml in " + scenesDirectory() + ")";
  std::string text;
  for (std::size_t i = 0; i < names.size(); ++i) {
    text += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + names[i];
  }
  return text;
}

namespace {

bool looksLikeFile(const std::string& s) {
  return s.find('/') != std::string::npos ||
         (s.size() > 5 && s.compare(s.size() - 5, 5, ".yaml") == 0);
}

SceneConfig parseScene(const std::string& yaml_text, const std::string& source_name, int depth);

SceneConfig loadSceneFile(const std::string& yaml_file, int depth) {
  std::string text;
  try {
    text = readTextFile(yaml_file, "scene config", kMaxSceneConfigBytes);
  } catch (const InputError& e) {
    throw std::runtime_error(e.what());
  }
  return parseScene(text, yaml_file, depth);
}

SceneConfig loadSceneNamed(const std::string& name_or_file, int depth) {
  if (looksLikeFile(name_or_file)) return loadSceneFile(name_or_file, depth);
  if (!isSceneName(name_or_file)) {
    throw std::invalid_argument("unknown scene '" + name_or_file + "' (expected " +
                                sceneNamesText() + ", or a scene file)");
  }
  return loadSceneFile(scenesDirectory() + "/" + name_or_file + ".yaml", depth);
}

// ---- The reader: the scene's settings table (numbers are texts: expressions). ----

/// "scene config 'FILE': line N": where a value was written, for messages of later checks.
std::string whereOf(const settings::Reader& r, const yaml::Node& node) {
  const std::string& head = r.head();
  return head.substr(0, head.size() - 2) + ": line " + std::to_string(node.line());
}

/// An expression on one line: a plain scalar folded over several lines holds its line breaks
/// (one per empty line), which would not read back the same once written; each run of
/// whitespace with a line break becomes one space (the expression means the same).
std::string onOneLine(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size();) {
    std::size_t j = i;
    bool line_break = false;
    while (j < text.size() &&
           (text[j] == ' ' || text[j] == '\t' || text[j] == '\n' || text[j] == '\r')) {
      line_break = line_break || text[j] == '\n' || text[j] == '\r';
      ++j;
    }
    if (j == i) {
      out += text[i++];
    } else {
      out.append(line_break ? std::string(" ") : text.substr(i, j - i));
      i = j;
    }
  }
  return out;
}

/// A number or an expression: a plain scalar (a quoted one is text, not a number).
SceneValue readValue(const yaml::Node& node, settings::Reader& r, const std::string& path) {
  if (node.isNull()) r.fail(node, path + ": no value");
  if (!node.isScalar()) r.fail(node, path + ": expected a number, got " + node.kindName());
  if (!node.plain()) {
    r.fail(node, path + ": '" + node.scalar() + "' is not a number (it is " +
                     (node.tag().empty() ? "quoted" : "tagged " + node.tag()) + ")");
  }
  return SceneValue{onOneLine(node.scalar()), whereOf(r, node)};
}

std::array<SceneValue, 3> readTriple(const yaml::Node& node, settings::Reader& r,
                                     const std::string& path) {
  if (!node.isSequence() || node.size() != 3) {
    r.fail(node, path + ": expected a list of 3 numbers [x, y, z], got " +
                     (node.isSequence() ? std::to_string(node.size()) + " items"
                                        : std::string(node.kindName())));
  }
  std::array<SceneValue, 3> out;
  for (std::size_t k = 0; k < 3; ++k) {
    out[k] = readValue(node.item(k), r, path + "[" + std::to_string(k) + "]");
  }
  return out;
}

/// A SceneValue member: read by readValue, written as its text.
template <typename S>
settings::Table<S>& valueField(settings::Table<S>& table, const char* key, SceneValue S::*member) {
  return table.custom(
      key,
      [member](const yaml::Node& v, S& s, settings::Reader& r, const std::string& path) {
        s.*member = readValue(v, r, path);
      },
      [member](const S& s, const std::string&) { return " " + (s.*member).text; });
}

/// A triple [x, y, z] of SceneValues.
settings::Table<SceneSolidSpec>& tripleField(settings::Table<SceneSolidSpec>& table,
                                             const char* key,
                                             std::array<SceneValue, 3> SceneSolidSpec::*member) {
  return table.custom(
      key,
      [member](const yaml::Node& v, SceneSolidSpec& s, settings::Reader& r,
               const std::string& path) { s.*member = readTriple(v, r, path); },
      [member](const SceneSolidSpec& s, const std::string&) {
        const auto& v = s.*member;
        return " [" + v[0].text + ", " + v[1].text + ", " + v[2].text + "]";
      });
}

/// A box, or a ramp (a box with a slope).
settings::Table<SceneSolidSpec> solidTable(bool ramp) {
  settings::Table<SceneSolidSpec> table;
  tripleField(table, "position", &SceneSolidSpec::position).required();
  tripleField(table, "size", &SceneSolidSpec::size).required();
  valueField(table, "yaw_deg", &SceneSolidSpec::yaw_deg);
  if (ramp) valueField(table, "slope_deg", &SceneSolidSpec::slope_deg).required();
  return table;
}

settings::ListOptions<SceneSolidSpec> solidList() {
  settings::ListOptions<SceneSolidSpec> options;
  options.append = true;  // a file's solids add to its base's
  options.omit_when_empty = true;
  // Messages about an item's defaults (yaw 0) name the item.
  options.finish = [](const yaml::Node& item, SceneSolidSpec& s, settings::Reader& r,
                      const std::string& path) {
    s.where = whereOf(r, item);
    if (r.seen(path + ".yaw_deg") == nullptr) s.yaw_deg.where = s.where;
    if (r.seen(path + ".slope_deg") == nullptr) s.slope_deg.where = s.where;
  };
  return options;
}

const char* const kReservedNames[] = {"friction", "boxes", "ramps", "base", "parameters"};

/// `parameters:` a mapping of name: number. Over a base, only the base's parameters may be
/// given (new values); without one, each name given is a new parameter.
void readParameters(const yaml::Node& v, SceneConfig& config, settings::Reader& r,
                    const std::string& path, bool has_base) {
  if (v.isNull()) return;
  if (!v.isMapping()) r.fail(v, path + ": expected a mapping, got " + v.kindName());
  const std::size_t inherited = config.parameters.size();
  for (std::size_t i = 0; i < v.size(); ++i) {
    const yaml::Node k = v.key(i);
    const std::string name = k.isScalar() ? k.scalar() : std::string();
    const std::string sub = path + "." + name;
    if (!isName(name)) {
      r.fail(k, path + ": '" + name + "' is not a parameter name (letters, digits, _)");
    }
    for (const char* reserved : kReservedNames) {
      if (name == reserved) r.fail(k, sub + ": '" + name + "' is a key of the scene file");
    }
    const yaml::Node value = v.value(i);
    r.note(sub, k, value);
    // A parameter's value is a plain number (expressions are for the geometry).
    double number = 0.0;
    if (!value.isScalar() || !value.toDouble(number)) {
      r.fail(value,
             sub + ": " +
                 (value.isScalar() ? "'" + value.scalar() + "' is not a number"
                                   : std::string("expected a number, got ") + value.kindName()));
    }
    if (!std::isfinite(number)) {
      r.fail(value, sub + ": '" + value.scalar() + "' is not a finite number");
    }
    const auto end = config.parameters.begin() + static_cast<std::ptrdiff_t>(inherited);
    const auto it = std::find_if(config.parameters.begin(), end,
                                 [&](const SceneParameter& p) { return p.name == name; });
    if (it != end) {
      it->value = number;
      it->where = whereOf(r, value);
    } else if (has_base) {
      std::string known;
      for (std::size_t j = 0; j < inherited; ++j) {
        known += (known.empty() ? "" : ", ") + config.parameters[j].name;
      }
      r.fail(k, sub + ": '" + name + "' is not a parameter of the base scene (it has: " +
                    (known.empty() ? "none" : known) + ")");
    } else {
      config.parameters.push_back({name, number, whereOf(r, value)});
    }
  }
}

/// The scene file's keys; `base:` is read before the others (parseScene), whatever its
/// place in the file.
settings::Table<SceneConfig> makeSceneTable(bool has_base) {
  settings::Table<SceneConfig> table;
  table.custom(
      "base", [](const yaml::Node&, SceneConfig&, settings::Reader&, const std::string&) {},
      [](const SceneConfig&, const std::string&) { return std::string(); });
  table.custom(
      "parameters",
      [has_base](const yaml::Node& v, SceneConfig& c, settings::Reader& r,
                 const std::string& path) { readParameters(v, c, r, path, has_base); },
      [](const SceneConfig& c, const std::string& indent) {
        std::string out;
        for (const SceneParameter& p : c.parameters) {
          out += "\n" + indent + "  " + p.name + ": " + numberText(p.value);
        }
        return out;
      },
      /*is_section=*/true);
  valueField(table, "friction", &SceneConfig::friction);
  table.sections("boxes", &SceneConfig::boxes, solidTable(false), solidList());
  table.sections("ramps", &SceneConfig::ramps, solidTable(true), solidList());
  return table;
}

const settings::Table<SceneConfig>& sceneTable(bool has_base) {
  static const settings::Table<SceneConfig> alone = makeSceneTable(false);
  static const settings::Table<SceneConfig> over_base = makeSceneTable(true);
  return has_base ? over_base : alone;
}

SceneConfig parseScene(const std::string& yaml_text, const std::string& source_name, int depth) {
  const std::string head = "scene config '" + source_name + "': ";
  if (depth > kMaxBaseDepth) {
    throw std::runtime_error(head + "base: scenes based on each other more than " +
                             std::to_string(kMaxBaseDepth) +
                             " deep (a file that is its own base?)");
  }
  SceneConfig config;
  config.source = "scene config '" + source_name + "'";
  {
    const std::string stem = std::filesystem::path(source_name).stem().string();
    config.name = stem.empty() ? source_name : stem;
  }
  settings::Reader r(head);
  const yaml::Document document = yaml::parseDocument(yaml_text, head);
  const yaml::Node root = document.root();
  if (root.isNull()) return config;  // empty file: the floor alone
  if (!root.isMapping()) r.fail(root, "expected a mapping (parameters, friction, boxes, ramps)");
  // The base first, whatever the order of the keys: the rest changes or extends it.
  bool has_base = false;
  for (std::size_t i = 0; i < root.size(); ++i) {
    if (!root.key(i).isScalar() || root.key(i).scalar() != "base") continue;
    const yaml::Node v = root.value(i);
    if (!v.isScalar() || v.scalar().empty()) r.fail(v, "base: expected a scene name or file");
    std::string base = v.scalar();
    if (looksLikeFile(base) && base[0] != '/') {
      const std::filesystem::path dir = std::filesystem::path(source_name).parent_path();
      base = (dir / base).string();
    }
    try {
      const std::string name = config.name, source = config.source;
      config = loadSceneNamed(base, depth + 1);
      config.name = name;
      config.source = source;
    } catch (const std::exception& e) {  // a bad file, or an unknown name
      r.fail(v, std::string("base: ") + e.what());
    }
    has_base = true;
  }
  sceneTable(has_base).read(root, config, r);
  try {
    config.validate();
  } catch (const std::invalid_argument& e) {
    // "<this file>: " once: the message names the file of the bad number (a base's).
    throw std::runtime_error(std::string(e.what()).rfind(head, 0) == 0 ? e.what()
                                                                       : head + e.what());
  }
  return config;
}

}  // namespace

SceneConfig loadScene(const std::string& name_or_file) { return loadSceneNamed(name_or_file, 0); }

SceneConfig loadSceneConfig(const std::string& yaml_file) { return loadSceneFile(yaml_file, 0); }

SceneConfig parseSceneConfig(const std::string& yaml_text, const std::string& source_name) {
  return parseScene(yaml_text, source_name, 0);
}

std::string toYaml(const SceneConfig& config) {
  return "# scene " + config.name + "\n" + sceneTable(false).write(config);
}

SceneConfig readSceneConfig(const yaml::Node& node, settings::Reader& reader,
                            const std::string& prefix, const std::string& name) {
  SceneConfig config;
  config.name = name;
  config.source = reader.head().substr(0, reader.head().size() - 2);
  const std::string section = prefix.substr(0, prefix.size() - 1);
  if (!node.isMapping()) {
    reader.fail(node,
                section + ": expected a mapping of a scene file's keys, got " + node.kindName());
  }
  for (std::size_t i = 0; i < node.size(); ++i) {
    if (node.key(i).isScalar() && node.key(i).scalar() == "base") {
      reader.fail(node.key(i), prefix + "base: not in an inline scene (give the scene's keys)");
    }
  }
  sceneTable(false).read(node, config, reader, prefix);
  try {
    config.validate();
  } catch (const std::invalid_argument& e) {  // names the line of the bad number
    const std::string what = e.what();
    const std::string head = config.source + ": ";
    throw std::runtime_error(head + section + ": " +
                             (what.rfind(head, 0) == 0 ? what.substr(head.size()) : what));
  }
  return config;
}

std::string sceneYaml(const SceneConfig& config, const std::string& indent) {
  return sceneTable(false).write(config, indent);
}

std::string documentedScene() { return sceneTable(false).documented(); }

// ---- Numbers by key path ----

namespace {

/// The SceneValue at `path` ("friction", "boxes[0].size[2]", ...), or nullptr; parameters
/// are not SceneValues (see sceneNumber).
template <class Config>
auto* valueAt(Config& config, const std::string& path) {
  using Value = std::conditional_t<std::is_const_v<Config>, const SceneValue, SceneValue>;
  Value* none = nullptr;
  if (path == "friction") return &config.friction;
  for (const char* list : {"boxes", "ramps"}) {
    const std::string head = std::string(list) + "[";
    if (path.rfind(head, 0) != 0) continue;
    auto& solids = std::string(list) == "boxes" ? config.boxes : config.ramps;
    std::size_t close = path.find(']');
    if (close == std::string::npos || close == head.size()) return none;
    const std::string index = path.substr(head.size(), close - head.size());
    if (!std::all_of(index.begin(), index.end(),
                     [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }) ||
        index.size() > 6) {
      return none;
    }
    const std::size_t i = static_cast<std::size_t>(std::stoul(index));
    if (i >= solids.size()) return none;
    auto& s = solids[i];
    const std::string rest = path.substr(close + 1);
    if (rest == ".yaw_deg") return &s.yaw_deg;
    if (rest == ".slope_deg" && std::string(list) == "ramps") return &s.slope_deg;
    for (int k = 0; k < 3; ++k) {
      const std::string kk = "[" + std::to_string(k) + "]";
      if (rest == ".position" + kk) return &s.position[static_cast<std::size_t>(k)];
      if (rest == ".size" + kk) return &s.size[static_cast<std::size_t>(k)];
    }
    return none;
  }
  return none;
}

[[noreturn]] void noSuchNumber(const SceneConfig& config, const std::string& path) {
  std::string keys = "friction";
  for (const SceneParameter& p : config.parameters) keys += ", " + p.name;
  if (!config.boxes.empty()) {
    keys += ", boxes[0.." + std::to_string(config.boxes.size() - 1) +
            "].position[0..2] / .size[0..2] / .yaw_deg";
  }
  if (!config.ramps.empty()) {
    keys += ", ramps[0.." + std::to_string(config.ramps.size() - 1) +
            "].position[0..2] / .size[0..2] / .yaw_deg / .slope_deg";
  }
  throw std::invalid_argument("scene " + config.name + " has no number '" + path +
                              "' (it has: " + keys + ")");
}

}  // namespace

double sceneNumber(const SceneConfig& config, const std::string& path) {
  for (const SceneParameter& p : config.parameters) {
    if (p.name == path) return p.value;
  }
  const SceneValue* v = valueAt(config, path);
  if (v == nullptr) noSuchNumber(config, path);
  return valueOf(*v, config.parameters, path);
}

bool hasSceneNumber(const SceneConfig& config, const std::string& path) {
  for (const SceneParameter& p : config.parameters) {
    if (p.name == path) return true;
  }
  return valueAt(config, path) != nullptr;
}

void setSceneNumber(SceneConfig& config, const std::string& path, double value) {
  for (SceneParameter& p : config.parameters) {
    if (p.name == path) {
      p.value = value;
      return;
    }
  }
  SceneValue* v = valueAt(config, path);
  if (v == nullptr) noSuchNumber(config, path);
  v->text = numberText(value);
}

// ---- Queries ----

double terrainHeight(const SceneGeometry& geometry, double x, double y) {
  double h = 0.0;
  for (const SceneSolid& s : geometry.solids) {
    if (s.coversTop(x, y)) h = std::max(h, s.topHeightAt(x, y));
  }
  return h;
}

double terrainHeight(const SceneConfig& config, double x, double y) {
  return terrainHeight(resolveScene(config), x, y);
}

double firstRise(const SceneGeometry& geometry) {
  return geometry.solids.empty() ? 0.0 : geometry.solids.front().topCenter().z();
}

std::string terrainMjcf(const SceneConfig& config) {
  const SceneGeometry g = resolveScene(config);
  std::string xml;
  char buf[640];
  std::snprintf(buf, sizeof buf,
                "    <light name=\"sun\" directional=\"true\" pos=\"0 0 5\" dir=\"0.3 0.2 -1\"/>\n"
                "    <geom name=\"floor\" type=\"plane\" size=\"50 50 0.1\" group=\"0\" "
                "contype=\"1\" conaffinity=\"1\" friction=\"%.17g 0.005 0.0001\" "
                "rgba=\"0.55 0.6 0.55 1\"/>\n",
                g.friction);
  xml += buf;
  int boxes = 0, ramps = 0;
  for (const SceneSolid& s : g.solids) {
    // A rotation only when there is one: an axis-aligned box is written as it always was.
    std::string quat;
    if (s.yaw != 0.0 || s.slope != 0.0) {
      const Eigen::Quaterniond q(s.rotation());
      std::snprintf(buf, sizeof buf, " quat=\"%.17g %.17g %.17g %.17g\"", q.w(), q.x(), q.y(),
                    q.z());
      quat = buf;
    }
    std::snprintf(buf, sizeof buf,
                  "    <geom name=\"%s%d\" type=\"box\" pos=\"%.17g %.17g %.17g\"%s "
                  "size=\"%.17g %.17g %.17g\" group=\"0\" contype=\"1\" conaffinity=\"1\" "
                  "friction=\"%.17g 0.005 0.0001\" rgba=\"0.6 0.55 0.5 1\"/>\n",
                  s.ramp ? "ramp" : "block", s.ramp ? ramps++ : boxes++, s.center.x(), s.center.y(),
                  s.center.z(), quat.c_str(), s.half_size.x(), s.half_size.y(), s.half_size.z(),
                  g.friction);
    xml += buf;
  }
  return xml;
}

const SceneSolid* solidAtStart(const SceneGeometry& geometry, double half_extent) {
  for (const SceneSolid& s : geometry.solids) {
    // The solid seen from above is a rectangle along its yaw (the slope tilts it within
    // that vertical plane); separating axes: the square's and the rectangle's.
    const double c = std::cos(s.yaw), sn = std::sin(s.yaw);
    const double hx =
        s.half_size.x() * std::cos(s.slope) + s.half_size.z() * std::abs(std::sin(s.slope));
    const double hy = s.half_size.y();
    const Eigen::Vector2d center(s.center.x(), s.center.y());
    const Eigen::Vector2d ex(c, sn), ey(-sn, c);
    bool separated = false;
    // The square's axes: the rectangle's extent along x and y.
    const double rx = hx * std::abs(ex.x()) + hy * std::abs(ey.x());
    const double ry = hx * std::abs(ex.y()) + hy * std::abs(ey.y());
    if (center.x() - rx >= half_extent || center.x() + rx <= -half_extent) separated = true;
    if (center.y() - ry >= half_extent || center.y() + ry <= -half_extent) separated = true;
    // The rectangle's axes: the square's extent along them.
    for (const auto& [axis, h] : {std::pair{ex, hx}, std::pair{ey, hy}}) {
      const double reach = half_extent * (std::abs(axis.x()) + std::abs(axis.y()));
      if (std::abs(axis.dot(center)) >= h + reach) separated = true;
    }
    if (!separated) return &s;
  }
  return nullptr;
}

}  // namespace rollstep::sim
