#include "rollstep/solver/settings_yaml.hpp"

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <stdexcept>
#include <type_traits>
#include <variant>
#include <vector>

#include "rollstep/common/text_file.hpp"
#include "rollstep/common/yaml_tree.hpp"

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
const std::array<Entry, 26> kFields{{
    {"mode", &SolverSettings::mode},
    {"max_iterations", &SolverSettings::max_iterations},
    {"kkt_tolerance", &SolverSettings::kkt_tolerance},
    {"barrier_initial", &SolverSettings::barrier_initial},
    {"barrier_min", &SolverSettings::barrier_min},
    {"barrier_decrease", &SolverSettings::barrier_decrease},
    {"barrier_realtime", &SolverSettings::barrier_realtime},
    {"realtime_iterations", &SolverSettings::realtime_iterations},
    {"fraction_to_boundary", &SolverSettings::fraction_to_boundary},
    {"bound_push", &SolverSettings::bound_push},
    {"slack_reset", &SolverSettings::slack_reset},
    {"line_search", &SolverSettings::line_search},
    {"exact_hessian", &SolverSettings::exact_hessian},
    {"max_line_search_steps", &SolverSettings::max_line_search_steps},
    {"rank_tolerance", &SolverSettings::rank_tolerance},
    {"num_threads", &SolverSettings::num_threads},
    {"thread_spin_us", &SolverSettings::thread_spin_us},
    {"divergence_threshold", &SolverSettings::divergence_threshold},
    {"infeasibility_tolerance", &SolverSettings::infeasibility_tolerance},
    {"filter_reset_trigger", &SolverSettings::filter_reset_trigger},
    {"max_filter_resets", &SolverSettings::max_filter_resets},
    {"max_second_order_corrections", &SolverSettings::max_second_order_corrections},
    {"acceptable_tolerance", &SolverSettings::acceptable_tolerance},
    {"acceptable_iterations", &SolverSettings::acceptable_iterations},
    {"predictor_corrector", &SolverSettings::predictor_corrector},
    {"huge_pages", &SolverSettings::huge_pages},
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

/// The ranges checkSettings enforces on the integer fields (solver.hpp), by key, so that a
/// refusal names the value the file gave and the range.
struct IntRange {
  const char* key;
  IntSettingRange range;
};
constexpr std::array<IntRange, 9> kIntRanges{{
    {"max_iterations", kIterationCountRange},
    {"realtime_iterations", kRealtimeIterationRange},
    {"acceptable_iterations", kIterationCountRange},
    {"max_line_search_steps", kLineSearchStepsRange},
    {"num_threads", kThreadCountRange},
    {"thread_spin_us", kThreadSpinRange},
    {"filter_reset_trigger", kFilterResetRange},
    {"max_filter_resets", kFilterResetRange},
    {"max_second_order_corrections", kSecondOrderCorrectionRange},
}};

std::optional<IntSettingRange> intRange(const std::string& key) {
  for (const IntRange& r : kIntRanges) {
    if (key == r.key) return r.range;
  }
  return std::nullopt;
}

bool isKeyChar(char c) { return (c >= 'a' && c <= 'z') || c == '_'; }

std::string knownKeys() {
  std::string keys;
  for (std::size_t i = 0; i < kNumFields; ++i)
    keys += (i ? ", " : "") + std::string(kFields[i].key);
  return keys;
}

}  // namespace

SolverSettings parseSolverSettings(const std::string& yaml_text, const std::string& source_name) {
  try {
    const yaml::Document document = yaml::Document::parse(yaml_text);
    return parseSolverSettings(document.root(), source_name);
  } catch (const yaml::YamlError& e) {
    throw std::runtime_error("solver settings " + source_name + ": YAML error: " + e.what());
  }
}

SolverSettings parseSolverSettings(const yaml::Node& root, const std::string& source_name,
                                   const SolverSettings& defaults) {
  const auto fail = [&](const std::string& what) {
    throw std::runtime_error("solver settings " + source_name + ": " + what);
  };
  SolverSettings settings = defaults;
  if (root.isNull()) return settings;
  if (!root.isMapping()) fail("expected a mapping of key: value");
  std::array<bool, kNumFields> seen{};
  std::array<std::string, kNumFields> given;  // the text of each value read, for messages
  for (std::size_t item = 0; item < root.size(); ++item) {
    const yaml::Node key_node = root.key(item);
    if (!key_node.isScalar()) fail("a key is not a plain name (known: " + knownKeys() + ")");
    const std::string key = key_node.scalar();
    const yaml::Node value = root.value(item);
    const Entry* entry = nullptr;
    for (std::size_t i = 0; i < kNumFields && !entry; ++i) {
      if (key == kFields[i].key) entry = &kFields[i];
    }
    if (!entry) fail("unknown key '" + key + "' (known: " + knownKeys() + ")");
    const std::size_t index = static_cast<std::size_t>(entry - kFields.data());
    // YAML forbids a repeated key; the last would otherwise win silently.
    if (seen[index]) fail("key '" + key + "' given twice");
    seen[index] = true;
    if (value.isNull()) fail("bad value for '" + key + "': no value given");
    if (!value.isScalar()) fail("bad value for '" + key + "': expected a single value");
    given[index] = value.scalar();
    try {
      const bool read = std::visit(
          [&](auto member) {
            using T = std::decay_t<decltype(settings.*member)>;
            if constexpr (std::is_same_v<T, SolverMode>) {
              settings.*member = modeFromString(value.scalar());
              return true;
            } else if constexpr (std::is_same_v<T, double>) {
              return value.toDouble(settings.*member);
            } else if constexpr (std::is_same_v<T, int>) {
              return value.toInt(settings.*member);
            } else {
              return value.toBool(settings.*member);
            }
          },
          entry->field);
      if (!read) {
        fail("bad value for '" + key + "': '" + value.scalar() + "' is not " +
             (std::holds_alternative<int SolverSettings::*>(entry->field)    ? "an integer"
              : std::holds_alternative<bool SolverSettings::*>(entry->field) ? "true or false"
                                                                             : "a number"));
      }
    } catch (const std::invalid_argument& e) {
      fail("bad value for '" + key + "': " + e.what());
    }
    if (const auto range = intRange(key)) {
      const int v = settings.*std::get<int SolverSettings::*>(entry->field);
      if (v < range->min || v > range->max) {
        fail("bad value for '" + key + "': " + std::to_string(v) + " is outside [" +
             std::to_string(range->min) + ", " + std::to_string(range->max) + "]");
      }
    }
  }
  try {
    checkSettings(settings);
  } catch (const std::invalid_argument& e) {
    // checkSettings names the keys and the valid range; add the values the file gave them.
    const std::string message = e.what();
    std::string values;
    for (std::size_t i = 0; i < kNumFields; ++i) {
      const std::string key = kFields[i].key;
      for (std::size_t at = message.find(key); at != std::string::npos;
           at = message.find(key, at + 1)) {
        const std::size_t end = at + key.size();
        if ((at > 0 && isKeyChar(message[at - 1])) ||
            (end < message.size() && isKeyChar(message[end]))) {
          continue;  // part of a longer word
        }
        values += (values.empty() ? " (" : ", ") + key + ": " +
                  (seen[i] ? "'" + given[i] + "' in the file" : "default");
        break;
      }
    }
    fail(message + (values.empty() ? "" : values + ")"));
  }
  return settings;
}

SolverSettings loadSolverSettings(const std::string& yaml_file) {
  // Refuses a directory, a FIFO or device (which would block), a missing or huge file.
  const std::string text = readTextFile(yaml_file, "solver settings", std::size_t{1} << 20);
  return parseSolverSettings(text, yaml_file);
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
