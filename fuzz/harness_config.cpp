// Fuzz harness: YAML text -> the number-section configurations and the sensing settings:
// rollstep::sim::parseSensorNoiseConfig (robots/tachyon3/sensors.yaml),
// rollstep::estimation::parseInekfSettings (robots/tachyon3/estimation.yaml),
// rollstep::perception::parsePerceptionSettings (config/perception.yaml) and
// rollstep::sim::parseLidarSettings (config/lidar.yaml).
// Fine: settings that survive their writer's round trip exactly (the lidar settings have no
// writer: their values must be finite and inside the ranges config/lidar.yaml documents), or
// a std::runtime_error whose message starts with the loader's prefix naming the source.
// Anything else fails: a crash, a sanitizer report, an escaped parser error (YamlError names
// no file), std::invalid_argument from a validate() that escaped, a hang.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "rollstep/estimation/invariant_ekf.hpp"
#include "rollstep/perception/terrain_perception.hpp"
#include "rollstep/sim/lidar.hpp"
#include "rollstep/sim/sensor_model.hpp"

namespace {
[[noreturn]] void failure(const std::string& what) {
  std::fprintf(stderr, "harness_config: %s\n", what.c_str());
  std::abort();
}

void requirePrefix(const std::runtime_error& e, const std::string& prefix) {
  if (std::string(e.what()).rfind(prefix, 0) != 0) {
    failure("error message does not start with '" + prefix + "': " + e.what());
  }
}

bool in(double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; }

// The ranges config/lidar.yaml documents, checked here independently of validate().
void checkLidar(const rollstep::sim::LidarSettings& s) {
  for (int i = 0; i < 3; ++i) {
    if (!in(s.mount_position[i], -10.0, 10.0)) failure("lidar: accepted mount_position");
  }
  if (!in(s.mount_pitch_deg, -90.0, 90.0)) failure("lidar: accepted mount_pitch_deg");
  if (s.beams < 1 || s.beams > 256) failure("lidar: accepted beams");
  if (!in(s.min_elevation_deg, -90.0, 90.0)) failure("lidar: accepted min_elevation_deg");
  if (!in(s.max_elevation_deg, s.min_elevation_deg, 90.0)) {
    failure("lidar: accepted max_elevation_deg");
  }
  if (!in(s.horizontal_fov_deg, 0.0, 360.0) || s.horizontal_fov_deg == 0.0) {
    failure("lidar: accepted horizontal_fov_deg");
  }
  if (!in(s.horizontal_resolution_deg, 0.05, s.horizontal_fov_deg)) {
    failure("lidar: accepted horizontal_resolution_deg");
  }
  if (!in(s.rate, 0.0, 1000.0) || s.rate == 0.0) failure("lidar: accepted rate");
  if (!in(s.max_range, 0.0, 1000.0) || s.max_range == 0.0) failure("lidar: accepted max_range");
  if (!in(s.range_noise, 0.0, 1.0)) failure("lidar: accepted range_noise");
  if (!in(s.dropout, 0.0, 1.0)) failure("lidar: accepted dropout");
  if (s.seed < 0) failure("lidar: accepted seed");
  if (s.columns() < 1 || s.columns() > 7200) failure("lidar: columns out of range");
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const rollstep::sim::SensorNoiseConfig c =
        rollstep::sim::parseSensorNoiseConfig(text, "fuzz.yaml");
    const std::string yaml = c.toYaml();
    if (rollstep::sim::parseSensorNoiseConfig(yaml, "round-trip").toYaml() != yaml) {
      failure("sensor config round trip differs");
    }
    if (!(c.seed >= 0.0) || c.seed != std::floor(c.seed)) failure("sensor config: accepted seed");
  } catch (const std::runtime_error& e) {
    requirePrefix(e, "sensor config 'fuzz.yaml'");
  }
  try {
    using namespace rollstep::estimation;
    const InekfSettings s = parseInekfSettings(text, "fuzz.yaml");
    const std::string yaml = toYaml(s);
    if (toYaml(parseInekfSettings(yaml, "round-trip")) != yaml) {
      failure("estimator settings round trip differs");
    }
    if (s.gate_recovery_ticks < 1) failure("estimator settings: accepted gate_recovery_ticks");
  } catch (const std::runtime_error& e) {
    requirePrefix(e, "estimator settings 'fuzz.yaml'");
  }
  try {
    using namespace rollstep::perception;
    const PerceptionSettings s = parsePerceptionSettings(text, "fuzz.yaml");
    s.validate();  // std::invalid_argument would escape: accepted settings out of range
    const std::string yaml = toYaml(s);
    if (toYaml(parsePerceptionSettings(yaml, "round-trip")) != yaml) {
      failure("perception settings round trip differs");
    }
  } catch (const std::runtime_error& e) {
    requirePrefix(e, "perception settings 'fuzz.yaml': ");
  }
  try {
    checkLidar(rollstep::sim::parseLidarSettings(text, "fuzz.yaml"));
  } catch (const std::runtime_error& e) {
    requirePrefix(e, "lidar settings 'fuzz.yaml': ");
  }
  return 0;
}
