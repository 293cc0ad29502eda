#include "trials.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <map>
#include <set>
#include <stdexcept>

#include "document.hpp"
#include "rollstep/common/number_text.hpp"
#include "rollstep/common/settings_table.hpp"
#include "rollstep/common/text_file.hpp"
#include "rollstep/common/yaml_tree.hpp"

namespace rollstep::experiments {

namespace {

/// splitmix64: a fixed, portable sequence from the seed.
struct SplitMix64 {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform(double lo, double hi) {
    const double u = static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0);  // [0, 1)
    return lo + (hi - lo) * u;
  }
};

/// Numbers as text with 4 decimals: what the trial uses is what its file says.
double rounded(double v) { return std::round(v * 1e4) / 1e4; }

/// Length of the valid UTF-8 sequence at s[i], 0 if it is not one.
std::size_t utf8Length(const std::string& s, std::size_t i) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char c = byte(i);
  const std::size_t n = c < 0x80           ? 1
                        : (c >> 5) == 0x6  ? 2
                        : (c >> 4) == 0xe  ? 3
                        : (c >> 3) == 0x1e ? 4
                                           : 0;
  if (n == 0 || i + n > s.size()) return 0;
  for (std::size_t k = 1; k < n; ++k) {
    if ((byte(i + k) & 0xc0) != 0x80) return 0;
  }
  return n;
}

/// A YAML double-quoted scalar that reads back as `s`: quotes, backslashes, control
/// characters and line separators escaped (a YAML reader refuses or folds them raw); a byte
/// that is not UTF-8 (refused too) as '?'.
std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (std::size_t i = 0; i < s.size();) {
    const std::size_t n = utf8Length(s, i);
    if (n == 0) {
      out += '?';
      ++i;
      continue;
    }
    std::uint32_t cp =
        n == 1 ? static_cast<unsigned char>(s[i]) : static_cast<unsigned char>(s[i]) & (0x7fu >> n);
    for (std::size_t k = 1; k < n; ++k)
      cp = (cp << 6) | (static_cast<unsigned char>(s[i + k]) & 0x3fu);
    if (cp == '"' || cp == '\\') {
      out += '\\';
      out += static_cast<char>(cp);
    } else if (cp == '\n') {
      out += "\\n";
    } else if (cp < 0x20 || (cp >= 0x7f && cp <= 0x9f) || cp == 0x2028 || cp == 0x2029 ||
               cp == 0xfeff || cp >= 0xfffe) {
      char e[16];
      std::snprintf(e, sizeof e, cp > 0xffff ? "\\U%08x" : "\\u%04x", static_cast<unsigned>(cp));
      out += e;
    } else {
      out += s.substr(i, n);
    }
    i += n;
  }
  return out + "\"";
}

std::string numberOrNull(const std::optional<double>& v) {
  return v ? shortestNumberText(*v) : "null";
}

}  // namespace

double TrialParameters::sceneValue(const std::string& name) const {
  for (const SceneValue& v : scene) {
    if (v.name == name) return v.value;
  }
  throw std::out_of_range("trial " + std::to_string(seed) + " drew no scene number '" + name + "'");
}

TrialParameters drawTrial(std::uint64_t seed, const TrialRanges& r) {
  SplitMix64 rng{seed};
  TrialParameters p;
  p.seed = seed;
  for (const SceneDraw& d : r.scene) {
    p.scene.push_back({d.name, d.key, d.offset, rounded(rng.uniform(d.min, d.max))});
  }
  p.sensor_noise = rounded(rng.uniform(r.sensor_noise_min, r.sensor_noise_max));
  if (r.has_speed) p.speed = rounded(rng.uniform(r.speed_min, r.speed_max));
  return p;
}

sim::RunSpec specAtSpeed(const sim::RunSpec& spec, double speed) {
  if (speed <= 0.0) return spec;
  sim::RunSpec out = spec;
  if (spec.command.size() == 1) {
    // One constant command: its forward speed replaced, the run as long as the same way.
    const double v = spec.command.front().command.v_x;
    if (v == 0.0) return spec;
    out.command.front().command.v_x = std::copysign(speed, v);
    out.duration = spec.duration * std::abs(v) / speed + kTrialSpeedMargin;
    return out;
  }
  // A schedule: the speeds scaled by k, the times by 1 / k (the same path).
  double fastest = 0.0;
  for (const planning::TimedBaseCommand& c : spec.command) {
    fastest = std::max(fastest, std::abs(c.command.v_x));
  }
  if (fastest == 0.0) return spec;
  const double k = speed / fastest;
  for (planning::TimedBaseCommand& c : out.command) {
    c.time = rounded(c.time / k);
    c.command.v_x = rounded(c.command.v_x * k);
    c.command.v_y = rounded(c.command.v_y * k);
    c.command.yaw_rate = rounded(c.command.yaw_rate * k);
  }
  out.duration = spec.duration / k + kTrialSpeedMargin;
  return out;
}

Scenario trialScenario(const Scenario& s, const TrialParameters& p) {
  Scenario out = s;
  out.speed = p.speed;
  return out;
}

std::vector<sim::SceneNumberValue> trialSceneNumbers(const sim::SceneConfig& base,
                                                     const TrialParameters& p) {
  std::vector<sim::SceneNumberValue> numbers;
  for (const TrialParameters::SceneValue& v : p.scene) {
    if (!sim::hasSceneNumber(base, v.key)) continue;  // e.g. the step height on the flat
    numbers.push_back({v.key, v.offset ? sim::sceneNumber(base, v.key) + v.value : v.value});
  }
  return numbers;
}

sim::SceneConfig trialScene(const sim::SceneConfig& base, const TrialParameters& p) {
  sim::SceneConfig s = base;
  for (const sim::SceneNumberValue& n : trialSceneNumbers(base, p)) {
    sim::setSceneNumber(s, n.name, n.value);
  }
  return s;
}

sim::SensorNoiseConfig trialSensorNoise(const TrialParameters& p) {
  sim::SensorNoiseConfig c;
  c.seed = static_cast<double>(p.seed);
  const double k = p.sensor_noise;
  for (double* v : {&c.gyro_noise_density, &c.gyro_bias_random_walk, &c.gyro_initial_bias,
                    &c.accel_noise_density, &c.accel_bias_random_walk, &c.accel_initial_bias,
                    &c.joint_position_noise, &c.joint_velocity_noise, &c.wheel_velocity_noise,
                    &c.force_noise}) {
    *v *= k;
  }
  return c;
}

bool readsSensors(const Scenario& s) {
  return s.runSpec("out").state_source == sim::StateSourceKind::Inekf;
}

std::vector<std::uint64_t> parseSeeds(const std::string& text) {
  const auto bad = [&](const std::string& why) {
    return std::invalid_argument("--seeds '" + text + "': " + why +
                                 " (give seeds as 0-29, 7 or 1,5,9-12)");
  };
  const auto number = [&](const std::string& s) {
    if (s.empty() || s.size() > 9 ||
        !std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      throw bad("'" + s + "' is not a seed (an integer 0 to 999999999)");
    }
    return static_cast<std::uint64_t>(std::stoull(s));
  };
  std::vector<std::uint64_t> seeds;
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t comma = text.find(',', start);
    if (comma == std::string::npos) comma = text.size();
    const std::string part = text.substr(start, comma - start);
    const std::size_t dash = part.find('-');
    if (dash == std::string::npos) {
      seeds.push_back(number(part));
    } else {
      const std::uint64_t a = number(part.substr(0, dash)), b = number(part.substr(dash + 1));
      if (b < a) throw bad("the range " + part + " runs backwards");
      if (b - a >= 100000) throw bad("more than 100000 seeds in " + part);
      for (std::uint64_t s = a; s <= b; ++s) seeds.push_back(s);
    }
    start = comma + 1;
  }
  std::vector<std::uint64_t> sorted = seeds;
  std::sort(sorted.begin(), sorted.end());
  if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) {
    throw bad("a seed is given twice");
  }
  return seeds;
}

std::string toYaml(const TrialResult& r) {
  std::string out;
  out += "# rollstep trials: one randomized trial (parameters drawn from the seed)\n";
  out += "scenario: " + r.scenario + "\n";
  out += "controller: " + r.controller + "\n";
  out += "seed: " + std::to_string(r.parameters.seed) + "\n";
  for (const TrialParameters::SceneValue& v : r.parameters.scene) {
    out += v.name + ": " + shortestNumberText(v.value) + "\n";
  }
  out += "sensor_noise: " + shortestNumberText(r.parameters.sensor_noise) + "\n";
  if (r.parameters.speed > 0.0) {
    out += "speed: " + shortestNumberText(r.parameters.speed) + "\n";
  }
  out += std::string("sensor_noise_applied: ") + (r.sensor_noise_applied ? "true" : "false") + "\n";
  out += std::string("passed: ") + (r.passed ? "true" : "false") + "\n";
  out += "failure: " + quoted(r.failure) + "\n";
  out += "traverse_time: " + numberOrNull(r.traverse_time) + "\n";
  out += "mean_abs_vz: " + numberOrNull(r.mean_abs_vz) + "\n";
  out += "mean_abs_wy: " + numberOrNull(r.mean_abs_wy) + "\n";
  out += "command: " + quoted(r.command) + "\n";
  return out;
}

namespace {

using settings::Range;

// Every field of a result file is checked as an input would be: its type and its range (a
// result file may come from anywhere: --collect, report --trials).

/// A number in `range`; "<path>: 1e+308 is outside [0, 1000000]".
double resultNumber(const yaml::Node& v, const Range& range, settings::Reader& reader,
                    const std::string& path) {
  const double x = settings::detail::readNumber(v, Range::anyFinite(), reader, path);
  if (auto problem = settings::detail::rangeProblem(x, range))
    reader.fail(v, path + ": " + *problem);
  return x;
}

std::string resultText(const yaml::Node& v, settings::Reader& reader, const std::string& path) {
  if (!v.isScalar()) reader.fail(v, path + ": expected text, not a list or mapping");
  if (v.scalar().size() > 10000) reader.fail(v, path + ": text of more than 10000 characters");
  return v.scalar();
}

/// Scenario and controller names appear in tables: names as the experiments file allows.
std::string resultName(const yaml::Node& v, settings::Reader& reader, const std::string& path) {
  const std::string n = resultText(v, reader, path);
  const bool ok = !n.empty() && n.size() <= 100 && std::all_of(n.begin(), n.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
  });
  if (!ok)
    reader.fail(v, path + ": '" + n.substr(0, 100) + "' is not a name (letters, digits, _ - .)");
  return n;
}

using ResultRead =
    std::function<void(const yaml::Node&, TrialResult&, settings::Reader&, const std::string&)>;

/// A key only read (toYaml writes the file: its order and the drawn numbers' keys); a
/// `nullable` one reads null too.
settings::Table<TrialResult>& readOnly(settings::Table<TrialResult>& table, const char* key,
                                       ResultRead read, bool nullable = false) {
  return table.custom(
      key, std::move(read), [](const TrialResult&, const std::string&) { return std::string(); },
      nullable);
}

/// An optional number (null: not measured) in `range`.
ResultRead optionalNumber(std::optional<double> TrialResult::*member, Range range) {
  return [member, range](const yaml::Node& v, TrialResult& r, settings::Reader& reader,
                         const std::string& path) {
    r.*member = std::nullopt;
    if (!v.isNull()) r.*member = resultNumber(v, range, reader, path);
  };
}

const settings::Table<TrialResult>& resultTable() {
  static const settings::Table<TrialResult> table = [] {
    settings::Table<TrialResult> t;
    readOnly(t, "scenario",
             [](const yaml::Node& v, TrialResult& r, settings::Reader& reader,
                const std::string& path) { r.scenario = resultName(v, reader, path); })
        .required();
    readOnly(t, "controller",
             [](const yaml::Node& v, TrialResult& r, settings::Reader& reader,
                const std::string& path) { r.controller = resultName(v, reader, path); })
        .required();
    readOnly(
        t, "seed",
        [](const yaml::Node& v, TrialResult& r, settings::Reader& reader, const std::string& path) {
          // As --seeds takes them: digits only (no 1e30, no sign, no 2^64 wrapping around).
          const std::string s = v.isScalar() ? v.scalar() : std::string();
          if (s.empty() || s.size() > 9 ||
              !std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; })) {
            reader.fail(
                v, path + ": '" + s.substr(0, 40) + "' is not a seed (an integer 0 to 999999999)");
          }
          r.parameters.seed = std::stoull(s);
        })
        .required();
    readOnly(
        t, "sensor_noise",
        [](const yaml::Node& v, TrialResult& r, settings::Reader& reader, const std::string& path) {
          r.parameters.sensor_noise = resultNumber(v, Range::closed(0, 100), reader, path);
        })
        .required();
    readOnly(
        t, "speed",
        [](const yaml::Node& v, TrialResult& r, settings::Reader& reader, const std::string& path) {
          r.parameters.speed = resultNumber(v, Range::closed(0, 100), reader, path);
        });
    t.field("sensor_noise_applied", &TrialResult::sensor_noise_applied);
    t.field("passed", &TrialResult::passed).required();
    readOnly(t, "failure",
             [](const yaml::Node& v, TrialResult& r, settings::Reader& reader,
                const std::string& path) { r.failure = resultText(v, reader, path); });
    readOnly(
        t, "traverse_time",
        [](const yaml::Node& v, TrialResult& r, settings::Reader& reader, const std::string& path) {
          // A run lasts at most 1e6 s.
          optionalNumber(&TrialResult::traverse_time, Range::closed(0, 1e6))(v, r, reader, path);
          if (r.traverse_time && !(*r.traverse_time > 0.0)) {
            reader.fail(v, path + ": 0 is not a traverse time");
          }
        },
        /*nullable=*/true);  // null: not measured
    readOnly(t, "mean_abs_vz", optionalNumber(&TrialResult::mean_abs_vz, Range::closed(0, 1000)),
             true);
    readOnly(t, "mean_abs_wy", optionalNumber(&TrialResult::mean_abs_wy, Range::closed(0, 1000)),
             true);
    readOnly(t, "command",
             [](const yaml::Node& v, TrialResult& r, settings::Reader& reader,
                const std::string& path) { r.command = resultText(v, reader, path); });
    return t;
  }();
  return table;
}

}  // namespace

TrialResult parseTrialResult(const std::string& text, const std::string& source) {
  TrialResult r;
  r.source = source;
  const yaml::Document doc = yaml::parseDocument(text, source + ": ");
  const yaml::Node root = doc.root();
  if (!root.isMapping()) throw std::runtime_error(source + ": not a trial result (no mapping)");
  settings::Reader reader(source + ": ");
  const settings::Table<TrialResult>& table = resultTable();
  for (std::size_t i = 0; i < root.size(); ++i) {
    const yaml::Node key = root.key(i), v = root.value(i);
    if (key.isScalar() && table.find(key.scalar()) == nullptr && isDrawName(key.scalar()) &&
        v.isScalar() && v.plain()) {
      // Any other name with a number: a scene number the trial drew (TrialRanges::scene).
      reader.note(key.scalar(), key, v);
      r.parameters.scene.push_back(
          {key.scalar(), "", false,
           resultNumber(v, Range::closed(-1e6, 1e6), reader, key.scalar())});
      continue;
    }
    if (key.isScalar() && table.find(key.scalar()) == nullptr) {
      reader.fail(key, "unknown key '" + key.scalar() + "' (known: " + table.keys() +
                           ", or a drawn scene number's name with its number)");
    }
    table.readEntry(key, v, r, reader);
  }
  // The trial's parameters too: a result without them does not say what was run.
  for (const settings::Field<TrialResult>& f : table.fields()) {
    if (f.required && reader.seen(f.key) == nullptr) {
      throw std::runtime_error(source + ": missing key '" + f.key + "'");
    }
  }
  if (r.passed && !r.failure.empty()) {
    throw std::runtime_error(source + ": passed: true with a failure ('" +
                             r.failure.substr(0, 100) + "')");
  }
  return r;
}

Spread spreadOf(const std::vector<double>& values) {
  Spread s;
  s.n = static_cast<int>(values.size());
  if (values.empty()) return s;
  double sum = 0.0;
  s.min = s.max = values[0];
  for (double v : values) {
    sum += v;
    s.min = std::min(s.min, v);
    s.max = std::max(s.max, v);
  }
  s.mean = sum / s.n;
  double sq = 0.0;
  for (double v : values) sq += (v - s.mean) * (v - s.mean);
  s.stddev = s.n > 1 ? std::sqrt(sq / (s.n - 1)) : 0.0;  // sample standard deviation
  return s;
}

std::vector<TrialAggregate> aggregate(std::vector<TrialResult> results) {
  std::stable_sort(results.begin(), results.end(), [](const TrialResult& a, const TrialResult& b) {
    return a.parameters.seed < b.parameters.seed;
  });
  std::vector<std::string> order;
  std::map<std::string, std::vector<const TrialResult*>> groups;
  for (const TrialResult& r : results) {
    if (groups.count(r.scenario) == 0) order.push_back(r.scenario);
    auto& group = groups[r.scenario];
    for (const TrialResult* other : group) {
      if (other->parameters.seed == r.parameters.seed) {
        throw std::runtime_error("seed " + std::to_string(r.parameters.seed) + " of " + r.scenario +
                                 " is in two result files: " + other->source + " and " + r.source);
      }
    }
    group.push_back(&r);
  }
  std::vector<TrialAggregate> out;
  for (const std::string& name : order) {
    TrialAggregate a;
    a.scenario = name;
    std::vector<double> t, vz, wy;
    for (const TrialResult* r : groups[name]) {
      a.controller = r->controller;
      ++a.trials;
      if (r->passed) {
        ++a.passed;
        if (r->traverse_time) t.push_back(*r->traverse_time);
        if (r->mean_abs_vz) vz.push_back(*r->mean_abs_vz);
        if (r->mean_abs_wy) wy.push_back(*r->mean_abs_wy);
      } else {
        a.failures.push_back("seed " + std::to_string(r->parameters.seed) + ": " +
                             literalText(r->failure));
      }
    }
    a.traverse_time = spreadOf(t);
    a.mean_abs_vz = spreadOf(vz);
    a.mean_abs_wy = spreadOf(wy);
    out.push_back(std::move(a));
  }
  return out;
}

PairedComparison compareTrials(const std::vector<TrialResult>& results,
                               const std::string& candidate, const std::string& baseline) {
  PairedComparison c;
  c.candidate = candidate;
  c.baseline = baseline;
  std::map<std::uint64_t, const TrialResult*> base;
  for (const TrialResult& r : results) {
    if (r.scenario != baseline) continue;
    ++c.baseline_trials;
    c.baseline_passed += r.passed ? 1 : 0;
    base[r.parameters.seed] = &r;
  }
  const auto complete = [](const TrialResult& r) {
    return r.passed && r.traverse_time && r.mean_abs_vz && r.mean_abs_wy;
  };
  for (const TrialResult& r : results) {
    if (r.scenario != candidate) continue;
    ++c.candidate_trials;
    c.candidate_passed += r.passed ? 1 : 0;
    const auto it = base.find(r.parameters.seed);
    if (it == base.end()) continue;
    ++c.common;
    const TrialResult& b = *it->second;
    if (!complete(r) || !complete(b)) continue;
    ++c.paired;
    c.candidate_traverse_time += *r.traverse_time;
    c.baseline_traverse_time += *b.traverse_time;
    c.candidate_mean_abs_vz += *r.mean_abs_vz;
    c.baseline_mean_abs_vz += *b.mean_abs_vz;
    c.candidate_mean_abs_wy += *r.mean_abs_wy;
    c.baseline_mean_abs_wy += *b.mean_abs_wy;
  }
  if (c.paired > 0) {
    for (double* v :
         {&c.candidate_traverse_time, &c.baseline_traverse_time, &c.candidate_mean_abs_vz,
          &c.baseline_mean_abs_vz, &c.candidate_mean_abs_wy, &c.baseline_mean_abs_wy}) {
      *v /= c.paired;
    }
  }
  return c;
}

std::string aggregateMarkdown(const std::vector<TrialAggregate>& aggregates) {
  std::string out;
  char line[600];
  const auto cell = [&](const Spread& s, int digits) {
    if (s.n == 0) return std::string("-");
    char c[200];
    std::snprintf(c, sizeof c, "%.*f ± %.*f (%.*f to %.*f)", digits, s.mean, digits, s.stddev,
                  digits, s.min, digits, s.max);
    return std::string(c);
  };
  out +=
      "| scenario | controller | trials | passed | success rate | traverse time [s] | mean "
      "\\|v_z\\| [m/s] | mean \\|w_y\\| [rad/s] |\n|---|---|---|---|---|---|---|---|\n";
  for (const TrialAggregate& a : aggregates) {
    std::snprintf(line, sizeof line, "| %s | %s | %d | %d | %.1f %% | %s | %s | %s |\n",
                  a.scenario.c_str(), a.controller.c_str(), a.trials, a.passed,
                  100.0 * a.successRate(), cell(a.traverse_time, 2).c_str(),
                  cell(a.mean_abs_vz, 4).c_str(), cell(a.mean_abs_wy, 4).c_str());
    out += line;
  }
  out += "\nMetrics over the passed trials: mean ± sample standard deviation (min to max).\n";
  for (const TrialAggregate& a : aggregates) {
    if (a.failures.empty()) continue;
    out += "\nFailed trials of " + a.scenario + ":\n\n";
    for (const std::string& f : a.failures) out += "- " + f + "\n";
  }
  return out;
}

namespace fs = std::filesystem;

namespace {

/// Whether `name` is a trial folder's name as `rollstep trials` writes it: <scenario>_seed<digits>.
bool trialFolderName(const std::string& name) {
  const std::size_t at = name.rfind("_seed");
  if (at == std::string::npos || at == 0 || at + 5 == name.size()) return false;
  return std::all_of(name.begin() + static_cast<std::ptrdiff_t>(at + 5), name.end(),
                     [](char c) { return c >= '0' && c <= '9'; });
}

std::string firstLine(const fs::path& file) {
  try {
    std::string text = readTextFile(file.string(), "FAILED", 1 << 16);
    text = text.substr(0, text.find('\n'));
    return text;
  } catch (const std::exception& e) {
    return e.what();
  }
}

void collectFolder(const fs::path& dir, std::set<fs::path>& visited, TrialCollection& out) {
  std::error_code ec;
  const fs::path real = fs::canonical(dir, ec);
  if (ec || !visited.insert(real).second) return;  // a loop of links, or seen already
  const fs::path result = dir / "result.yaml";
  const bool has_result = fs::symlink_status(result, ec).type() != fs::file_type::not_found;
  if (has_result || trialFolderName(dir.filename().string())) {
    ++out.folders;
    if (!has_result) {
      const std::string why = fs::exists(dir / "FAILED", ec)
                                  ? firstLine(dir / "FAILED")
                                  : "no result.yaml (the trial did not end)";
      out.uncounted.push_back({dir.string(), "unfinished: " + why, false});
      return;
    }
    try {
      out.results.push_back(
          parseTrialResult(readTextFile(result.string(), "trial result"), result.string()));
    } catch (const std::exception& e) {
      out.uncounted.push_back({dir.string(), std::string("unreadable: ") + e.what(), true});
    }
    return;
  }
  std::vector<fs::path> children;
  for (auto it = fs::directory_iterator(dir, ec); !ec && it != fs::directory_iterator();
       it.increment(ec)) {
    std::error_code type_ec;
    if (fs::is_directory(it->path(), type_ec)) children.push_back(it->path());  // links followed
  }
  if (ec) {
    out.uncounted.push_back(
        {dir.string(), "unreadable: cannot list the folder: " + ec.message(), true});
    ++out.folders;
    return;
  }
  std::sort(children.begin(), children.end());
  for (const fs::path& child : children) collectFolder(child, visited, out);
}

}  // namespace

TrialCollection collectTrials(const std::vector<std::string>& dirs) {
  TrialCollection out;
  std::set<fs::path> visited;
  for (const std::string& d : dirs) {
    std::error_code ec;
    if (!fs::is_directory(d, ec))
      throw InputError("trial results folder '" + d + "': not a directory");
    collectFolder(fs::path(d), visited, out);
  }
  return out;
}

std::vector<TrialResult> collectResults(const std::vector<std::string>& dirs) {
  TrialCollection c = collectTrials(dirs);
  if (!c.uncounted.empty()) {
    const UncountedTrial& u = c.uncounted.front();
    throw std::runtime_error(
        "trial folder '" + u.dir + "': " + u.reason +
        (c.uncounted.size() > 1
             ? " (and " + std::to_string(c.uncounted.size() - 1) + " more folders without a result)"
             : std::string()));
  }
  return std::move(c.results);
}

}  // namespace rollstep::experiments
