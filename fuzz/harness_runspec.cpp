// Fuzz harness: YAML text -> RunSpec (rollstep::sim::parseRunSpec, the run.yaml files that
// `rollstep sim --spec`, the report's and the trials' child runs and the Python Simulation
// read), with its inline control settings and scene numbers.
// Fine: a spec that checkRunSpec accepts and that survives a toYaml round trip exactly; or a
// std::runtime_error whose message starts with "fuzz.yaml: " (the documented error: file,
// line, key). Anything else fails: a crash, a sanitizer report, another exception type (a
// RunSpecError escaping the reader), a hang.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "rollstep/sim/run_spec.hpp"

namespace {
[[noreturn]] void failure(const std::string& what) {
  std::fprintf(stderr, "harness_runspec: %s\n", what.c_str());
  std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace rollstep::sim;
  const std::string text(reinterpret_cast<const char*>(data), size);
  RunSpec spec;
  try {
    spec = parseRunSpec(text, "fuzz.yaml");
  } catch (const std::runtime_error& e) {
    if (std::string(e.what()).rfind("fuzz.yaml: ", 0) != 0) {
      failure(std::string("error message does not name the source: ") + e.what());
    }
    return 0;
  }
  try {
    checkRunSpec(spec);
  } catch (const RunSpecError& e) {
    failure(std::string("read a spec that checkRunSpec refuses: ") + e.what());
  }
  const std::string yaml = toYaml(spec);
  RunSpec back;
  try {
    back = parseRunSpec(yaml, "round-trip");
  } catch (const std::runtime_error& e) {
    failure(std::string("the written spec does not read back: ") + e.what() + "\n" + yaml);
  }
  if (!(back == spec) || toYaml(back) != yaml) failure("round trip differs:\n" + yaml);
  return 0;
}
