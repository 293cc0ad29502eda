#include "rollstep/solver/settings_yaml.hpp"

#include <yaml-cpp/yaml.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <type_traits>
#include <variant>

namespace rollstep::solver {
namespace {

// One table drives both directions, so the reader and the writer cannot drift apart.
using Field = std::variant<double SolverSettings::*, int SolverSettings::*, bool SolverSettings::*,
                           SolverMode SolverSettings::*>;
struct Entry {
  const char* key;
  Field field;
};
// A new SolverSettings field goes here and into config/solver.yaml.
const std::array<Entry, 16> kFields{{
    {"mode", &SolverSettings::mode},
    {"max_iterations", &SolverSettings::max_iterations},
    {"kkt_tolerance", &SolverSettings::kkt_tolerance},
    {"barrier_initial", &SolverSettings::barrier_initial},
    {"barrier_min", &SolverSettings::barrier_min},
    {"barrier_decrease", &SolverSettings::barrier_decrease},
    {"barrier_realtime", &SolverSettings::barrier_realtime},
    {"fraction_to_boundary", &SolverSettings::fraction_to_boundary},
    {"line_search", &SolverSettings::line_search},
    {"exact_hessian", &SolverSettings::exact_hessian},
    {"max_line_search_steps", &SolverSettings::max_line_search_steps},
    {"rank_tolerance", &SolverSettings::rank_tolerance},
    {"num_threads", &SolverSettings::num_threads},
    {"thread_spin_us", &SolverSettings::thread_spin_us},
    {"divergence_threshold", &SolverSettings::divergence_threshold},
    {"infeasibility_tolerance", &SolverSettings::infeasibility_tolerance},
}};
constexpr std::size_t kNumFields = kFields.size();

SolverMode modeFromString(const std::string& name) {
  if (name == "converging") return SolverMode::Converging;
  if (name == "realtime") return SolverMode::RealTime;
  throw std::invalid_argument("expected converging or realtime, got '" + name + "'");
}

const char* modeName(SolverMode mode) {
  return mode == SolverMode::RealTime ? "realtime" : "converging";
}

/// The shortest decimal text that reads back as exactly v (YAML's .inf for infinities).
std::string numberText(double v) {
  if (std::isinf(v)) return v > 0 ? ".inf" : "-.inf";
  char buf[32];
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

std::string knownKeys() {
  std::string keys;
  for (std::size_t i = 0; i < kNumFields; ++i)
    keys += (i ? ", " : "") + std::string(kFields[i].key);
  return keys;
}

}  // namespace

SolverSettings parseSolverSettings(const std::string& yaml_text, const std::string& source_name) {
  const auto fail = [&](const std::string& what) {
    throw std::runtime_error("solver settings " + source_name + ": " + what);
  };
  SolverSettings settings;
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    fail(std::string("YAML error: ") + e.what());
  }
  if (root.IsNull()) return settings;
  if (!root.IsMap()) fail("expected a mapping of key: value");
  std::array<bool, kNumFields> seen{};
  for (const auto& item : root) {
    const std::string key = item.first.as<std::string>();
    const YAML::Node& value = item.second;
    const Entry* entry = nullptr;
    for (std::size_t i = 0; i < kNumFields && !entry; ++i) {
      if (key == kFields[i].key) entry = &kFields[i];
    }
    if (!entry) fail("unknown key '" + key + "' (known: " + knownKeys() + ")");
    // YAML forbids a repeated key, but yaml-cpp keeps both; the last would win silently.
    bool& was_seen = seen[static_cast<std::size_t>(entry - kFields.data())];
    if (was_seen) fail("key '" + key + "' given twice");
    was_seen = true;
    if (!value.IsScalar()) fail("bad value for '" + key + "': expected a single value");
    try {
      std::visit(
          [&](auto member) {
            using T = std::decay_t<decltype(settings.*member)>;
            if constexpr (std::is_same_v<T, SolverMode>) {
              settings.*member = modeFromString(value.as<std::string>());
            } else {
              settings.*member = value.as<T>();
            }
          },
          entry->field);
    } catch (const YAML::Exception&) {
      fail("bad value for '" + key + "': '" + value.Scalar() + "' is not " +
           (std::holds_alternative<int SolverSettings::*>(entry->field)    ? "an integer"
            : std::holds_alternative<bool SolverSettings::*>(entry->field) ? "true or false"
                                                                           : "a number"));
    } catch (const std::invalid_argument& e) {
      fail("bad value for '" + key + "': " + e.what());
    }
  }
  try {
    checkSettings(settings);
  } catch (const std::invalid_argument& e) {
    fail(e.what());
  }
  return settings;
}

SolverSettings loadSolverSettings(const std::string& yaml_file) {
  std::ifstream in(yaml_file);
  if (!in) throw std::runtime_error("solver settings " + yaml_file + ": cannot open file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return parseSolverSettings(buffer.str(), yaml_file);
}

std::string toYaml(const SolverSettings& settings) {
  std::string out;
  for (std::size_t i = 0; i < kNumFields; ++i) {
    out += kFields[i].key;
    out += ": ";
    std::visit(
        [&](auto member) {
          using T = std::decay_t<decltype(settings.*member)>;
          const T& v = settings.*member;
          if constexpr (std::is_same_v<T, SolverMode>) {
            out += modeName(v);
          } else if constexpr (std::is_same_v<T, bool>) {
            out += v ? "true" : "false";
          } else if constexpr (std::is_same_v<T, int>) {
            out += std::to_string(v);
          } else {
            out += numberText(v);
          }
        },
        kFields[i].field);
    out += '\n';
  }
  return out;
}

}  // namespace rollstep::solver
