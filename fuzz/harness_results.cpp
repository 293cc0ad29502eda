// Fuzz harness: YAML text -> TrialResult (rollstep::experiments::parseTrialResult, the
// result.yaml files that `rollstep trials --collect` and `report --trials` read from
// anywhere), and its line in the aggregate.
// Fine: a result whose every field is in its documented range, that survives a toYaml
// round trip exactly, and whose aggregate has as many lines as any other (text from the
// file never makes a line or a table row of its own, never raw markup); or a
// std::runtime_error whose message starts with "fuzz.yaml: " (the documented error).
// Anything else fails: a crash, a sanitizer report, another exception type, a hang.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <stdexcept>
#include <string>

#include "experiments/trials.hpp"

namespace {
[[noreturn]] void failure(const std::string& what) {
  std::fprintf(stderr, "harness_results: %s\n", what.c_str());
  std::abort();
}

bool within(const std::optional<double>& v, double lo, double hi) {
  return !v || (std::isfinite(*v) && *v >= lo && *v <= hi);
}

std::size_t lines(const std::string& text) {
  std::size_t n = 0;
  for (char c : text) n += c == '\n' ? 1 : 0;
  return n;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace rollstep::experiments;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const TrialResult r = parseTrialResult(text, "fuzz.yaml");
    const TrialParameters& p = r.parameters;
    for (const TrialParameters::SceneValue& v : p.scene) {
      if (!isDrawName(v.name) || !(v.value >= -1e6 && v.value <= 1e6)) {
        failure("accepted a scene number outside its range or with a bad name: " + v.name);
      }
    }
    if (p.seed > 999999999 || !(p.sensor_noise >= 0 && p.sensor_noise <= 100) ||
        !within(r.traverse_time, 1e-300, 1e6) || !within(r.mean_abs_vz, 0, 1000) ||
        !within(r.mean_abs_wy, 0, 1000)) {
      failure("accepted a field outside its range");
    }
    if (r.passed && !r.failure.empty()) failure("accepted a passed trial with a failure");
    const std::string yaml = toYaml(r);
    if (toYaml(parseTrialResult(yaml, "round-trip")) != yaml) failure("round trip differs");
    // The aggregate of this result has the lines of the same result with a plain failure.
    TrialResult plain = r;
    plain.failure = r.failure.empty() ? "" : "x";
    const std::string md = aggregateMarkdown(aggregate({r}));
    if (lines(md) != lines(aggregateMarkdown(aggregate({plain})))) {
      failure("text from the file changed the aggregate's lines: " + md);
    }
    if (md.find("<script") != std::string::npos && md.find("`") == std::string::npos) {
      failure("raw markup in the aggregate");
    }
  } catch (const std::runtime_error& e) {
    if (std::string(e.what()).rfind("fuzz.yaml: ", 0) != 0) {
      failure(std::string("error message does not name the source: ") + e.what());
    }
  }
  return 0;
}
