// Fuzz harness: YAML text -> SceneConfig (rollstep::sim::parseSceneConfig).
// Fine: a scene that resolves (resolveScene) to finite geometry inside the documented
// ranges, whose terrain MJCF has no NaN and that survives a toYaml round trip exactly; or a
// std::runtime_error whose message starts with "scene config 'fuzz.yaml': " (the
// documented error). Anything else fails: a crash, a sanitizer report, an escaped parser
// error (YamlError names no file), another exception type, a hang.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "rollstep/sim/scene.hpp"

namespace {
[[noreturn]] void failure(const std::string& what) {
  std::fprintf(stderr, "harness_scene: %s\n", what.c_str());
  std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace rollstep::sim;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const SceneConfig c = parseSceneConfig(text, "fuzz.yaml");
    const SceneGeometry g = resolveScene(c);  // std::invalid_argument: not a runtime_error
    if (!std::isfinite(g.friction) || g.friction < kSceneMinFriction ||
        g.friction > kSceneMaxFriction) {
      failure("accepted friction");
    }
    for (const SceneSolid& s : g.solids) {
      if (!s.center.allFinite() || !s.half_size.allFinite() || (s.half_size.array() <= 0).any() ||
          !std::isfinite(s.yaw) || !std::isfinite(s.slope) ||
          std::abs(s.slope) > kSceneMaxSlopeDeg * 3.14159265358979323846 / 180.0 + 1e-12) {
        failure("solid not finite, empty or too steep: " + s.label);
      }
    }
    if (terrainMjcf(c).find("nan") != std::string::npos) failure("nan in the terrain MJCF");
    const std::string yaml = toYaml(c);
    // The same name (the file's stem), another file: an error there is not the documented one.
    if (toYaml(parseSceneConfig(yaml, "round-trip/fuzz.yaml")) != yaml) {
      failure("round trip differs");
    }
  } catch (const std::runtime_error& e) {
    const std::string message = e.what();
    if (message.rfind("scene config 'fuzz.yaml': ", 0) != 0) {
      failure("error message does not name the source: " + message);
    }
  }
  return 0;
}
