// Fuzz harness: YAML text -> ExperimentSet (rollstep::experiments::parseExperimentSet, the
// experiments file that `rollstep report` and `rollstep trials` read: scenarios with their
// `rollstep sim` args, criteria, acceptance, trial ranges, speed sweep).
// Fine: a set whose every scenario (the speed sweep's runs included) gives a run spec, and
// whose trials give one at the fastest and slowest speeds they may draw; or a
// std::runtime_error whose message starts with "fuzz.yaml: " (the documented error: file,
// line, key). Anything else fails: a crash, a sanitizer report, another exception type, a
// hang, a file accepted whose runs would be refused only when they start.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "experiments/scenarios.hpp"
#include "experiments/trials.hpp"

namespace {
[[noreturn]] void failure(const std::string& what) {
  std::fprintf(stderr, "harness_experiments: %s\n", what.c_str());
  std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace rollstep::experiments;
  const std::string text(reinterpret_cast<const char*>(data), size);
  ExperimentSet set;
  try {
    set = parseExperimentSet(text, "fuzz.yaml", "/nonexistent-fuzz-dir");
  } catch (const std::runtime_error& e) {
    if (std::string(e.what()).rfind("fuzz.yaml: ", 0) != 0) {
      failure(std::string("error message does not name the source: ") + e.what());
    }
    return 0;
  }
  if (set.scenarios.empty()) failure("accepted a file without scenarios");
  for (const Scenario& s : set.scenarios) {
    try {
      (void)s.runSpec("/o");
      if (set.trials.has_speed) {
        for (double speed : {set.trials.speed_min, set.trials.speed_max}) {
          TrialParameters p;
          p.speed = speed;
          (void)trialScenario(s, p).runSpec("/o");
        }
      }
    } catch (const std::exception& e) {
      failure("accepted scenario '" + s.name + "' whose run is refused: " + e.what());
    }
  }
  return 0;
}
