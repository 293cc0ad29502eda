// Fuzz harness: YAML text -> SolverSettings (rollstep::solver::parseSolverSettings).
// Fine: settings that checkSettings accepts and that survive a toYaml round trip exactly,
// or a std::runtime_error whose message starts with "solver settings <source>: " (the
// documented error). Anything else fails: a crash, a sanitizer report, an escaped parser
// error (rollstep::yaml::YamlError names no file), another exception type, a hang.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "rollstep/solver/settings_yaml.hpp"

namespace {
[[noreturn]] void failure(const std::string& what) {
  std::fprintf(stderr, "harness_settings: %s\n", what.c_str());
  std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace rollstep::solver;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const SolverSettings s = parseSolverSettings(text, "fuzz.yaml");
    checkSettings(s);  // throws std::invalid_argument: not a runtime_error, so it fails
    const std::string yaml = toYaml(s);
    if (toYaml(parseSolverSettings(yaml, "round-trip")) != yaml) failure("round trip differs");
  } catch (const std::runtime_error& e) {
    const std::string message = e.what();
    if (message.rfind("solver settings fuzz.yaml: ", 0) != 0) {
      failure("error message does not name the source: " + message);
    }
  }
  return 0;
}
