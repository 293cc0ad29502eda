// Control settings from YAML: defaults documented by config/control.yaml, a round trip of
// every key, errors naming the source, the line and the full key path, the nested ocp:
// mapping read by the centroidal layer (and its solver: by the solver layer).
#include "rollstep/control/control_settings.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "rollstep/common/text_file.hpp"

namespace rollstep::control {
namespace {

const std::string kConfigFile = std::string(ROLLSTEP_TEST_DATA_DIR) + "/../../config/control.yaml";

std::string errorOf(const std::string& text) {
  try {
    parseControlSettings(text, "test.yaml");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}
bool has(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

TEST(ControlSettings, EnumNames) {
  EXPECT_STREQ(toString(MpcTiming::Deterministic), "deterministic");
  EXPECT_STREQ(toString(MpcTiming::Asynchronous), "asynchronous");
  EXPECT_STREQ(toString(IntegratorMode::Internal), "internal");
  EXPECT_STREQ(toString(IntegratorMode::Naive), "naive");
}

TEST(ControlSettings, TheDocumentedFileEqualsTheDefaults) {
  const ControlSettings file = loadControlSettings(kConfigFile);
  EXPECT_EQ(toYaml(file), toYaml(ControlSettings{}));
  EXPECT_NO_THROW(checkSettings(ControlSettings{}));
  // Every key toYaml writes outside ocp: is documented in the file, in its section.
  const std::string text = readTextFile(kConfigFile, "test", 1 << 20);
  const std::string all = toYaml(ControlSettings{});
  bool in_ocp = false;
  for (std::size_t start = 0; start < all.size();) {
    const std::size_t end = all.find('\n', start);
    const std::string line = all.substr(start, end - start);
    start = end + 1;
    const std::string key = line.substr(0, line.find(':'));
    if (key.rfind("  ", 0) != 0) in_ocp = key == "ocp";
    if (in_ocp) continue;  // config/ocp.yaml's keys
    EXPECT_TRUE(has(text, "\n" + key + ":")) << key;
  }
}

// The ocp fuzz harness's seed of every control key (fuzz/corpus/ocp/control_defaults.yaml)
// is the table's own writing of the defaults, so it names every key (ocp: and its solver:
// included) and cannot fall behind a new one. Rewritten from the table with
// ROLLSTEP_WRITE_FUZZ_SEEDS=1 in the environment (fuzz/README.md).
TEST(ControlSettings, TheFuzzSeedHasEveryKey) {
  const std::string path =
      std::string(ROLLSTEP_TEST_DATA_DIR) + "/../../fuzz/corpus/ocp/control_defaults.yaml";
  const std::string expected =
      "# Every control settings key with its default, written by the settings table\n"
      "# (tests/control/control_settings_test.cpp: TheFuzzSeedHasEveryKey).\n" +
      toYaml(ControlSettings{});
  if (const char* write = std::getenv("ROLLSTEP_WRITE_FUZZ_SEEDS"); write && *write == '1') {
    std::ofstream(path) << expected;
  }
  const std::string seed = readTextFile(path, "fuzz seed", 1 << 20);
  EXPECT_EQ(seed, expected) << "the seed is not the table's defaults: run this test with "
                               "ROLLSTEP_WRITE_FUZZ_SEEDS=1 to write it";
  EXPECT_EQ(toYaml(parseControlSettings(seed, "seed")), toYaml(ControlSettings{}));
  // Every key path the table writes is in the seed, sections included.
  std::vector<std::string> open;  // the sections around the line
  const std::string all = toYaml(ControlSettings{});
  std::size_t keys = 0;
  for (std::size_t start = 0; start < all.size();) {
    const std::size_t end = all.find('\n', start);
    const std::string line = all.substr(start, end - start);
    start = end + 1;
    const std::size_t depth = line.find_first_not_of(' ') / 2;
    open.resize(std::min(open.size(), depth));
    const std::string key = line.substr(2 * depth, line.find(':') - 2 * depth);
    open.push_back(key);
    std::string at;
    for (const std::string& k : open) at += (at.empty() ? "" : ".") + k;
    EXPECT_NE(seed.find("\n" + std::string(2 * depth, ' ') + key + ":"), std::string::npos) << at;
    ++keys;
  }
  EXPECT_GT(keys, 100u);  // the sections of control, ocp and solver
}

TEST(ControlSettings, RoundTripsNonDefaultValues) {
  ControlSettings s;
  s.control_period = 0.002;
  s.mpc.timing = MpcTiming::Asynchronous;
  s.mpc.period = 0.0;
  s.mpc.latency = 0.03;
  s.mpc.initial_iterations = 7;
  s.refinement.horizon = 0.1 / 3.0;
  s.refinement.substeps = 4;
  s.feedback.base_kp << 1, 2, 3, 4, 5, 6.25;
  s.feedback.base_kd << 0.1, 0.2, 0.3, 0.4, 0.5, 0.6;
  s.feedback.foot_kp = 123.456;
  s.feedback.foot_kd = 1e-7;
  s.feedback.joint_kp = 0;
  s.feedback.joint_kd = 3;
  s.cbf_qp.base_weight << 6, 5, 4, 3, 2, 1;
  s.cbf_qp.foot_weight = 2;
  s.cbf_qp.joint_weight = 0.5;
  s.cbf_qp.damping = 1e-9;
  s.cbf_qp.contact_gain = 11;
  s.cbf_qp.freed_contact_weight = 12;
  s.cbf_qp.joint_position_gamma = 13;
  s.cbf_qp.joint_position_margin = 0.01;
  s.cbf_qp.joint_velocity_gamma = 14;
  s.cbf_qp.velocity_limit_scale = 0.9;
  s.cbf_qp.region_gamma = 15;
  s.cbf_qp.clearance_gamma = 16;
  s.cbf_qp.clearance = 0.02;
  s.cbf_qp.max_iterations = 17;
  s.cbf_qp.fallback_brake_time = 0.3;
  s.integrator.mode = IntegratorMode::Naive;
  s.integrator.position_time_constant = 0;
  s.integrator.velocity_time_constant = 0.05;
  s.wheels.skid_track_factor = 3.75;
  s.wheels.skid_yaw_rate_gain = 2.5;
  s.wheels.skid_velocity_gain = 1.25;
  s.wheels.skid_position_gain = 0.75;
  s.baseline.position_leash = 0.0625;
  s.ocp.horizon = 37;
  s.ocp.dt = 0.01;
  s.ocp.base_velocity_weight << 1, 2, 3, 4, 5, 6.5;
  s.ocp.solver.num_threads = 2;
  s.ocp.solver.barrier_realtime = 1e-4;
  EXPECT_NO_THROW(checkSettings(s));
  const std::string text = toYaml(s);
  EXPECT_NE(text, toYaml(ControlSettings{}));
  const ControlSettings back = parseControlSettings(text, "round trip");
  EXPECT_EQ(toYaml(back), text);
  EXPECT_EQ(back.refinement.horizon, s.refinement.horizon);  // exactly
  EXPECT_EQ(back.feedback.foot_kd, 1e-7);
  EXPECT_EQ(back.mpc.timing, MpcTiming::Asynchronous);
  EXPECT_EQ(back.integrator.mode, IntegratorMode::Naive);
  EXPECT_EQ(back.wheels.skid_track_factor, 3.75);
  EXPECT_EQ(back.wheels.skid_yaw_rate_gain, 2.5);
  EXPECT_EQ(back.wheels.skid_velocity_gain, 1.25);
  EXPECT_EQ(back.wheels.skid_position_gain, 0.75);
  EXPECT_EQ(back.baseline.position_leash, 0.0625);
  EXPECT_EQ(back.ocp.horizon, 37);
  EXPECT_EQ(back.ocp.solver.num_threads, 2);
  EXPECT_EQ(back.ocp.solver.barrier_realtime, 1e-4);
}

TEST(ControlSettings, ReadsAnySubsetAndTheNestedOcp) {
  const ControlSettings s = parseControlSettings(
      "mpc:\n  latency: 0.005\nocp:\n  horizon: 20\n  dt: 0.02\n  solver:\n"
      "    max_iterations: 9\n    exact_hessian: true\n",
      "subset.yaml");
  EXPECT_EQ(s.mpc.latency, 0.005);
  EXPECT_EQ(s.mpc.period, 0.02);  // default kept
  EXPECT_EQ(s.control_period, 0.001);
  EXPECT_EQ(s.ocp.horizon, 20);
  EXPECT_EQ(s.ocp.dt, 0.02);
  EXPECT_EQ(s.ocp.torque_limit_scale, 1.0);
  EXPECT_EQ(s.ocp.solver.max_iterations, 9);
  EXPECT_TRUE(s.ocp.solver.exact_hessian);
  // Solver keys not given keep the OCP's solver defaults (Gauss-Newton).
  EXPECT_FALSE(parseControlSettings("ocp:\n  solver:\n    max_iterations: 3\n", "x")
                   .ocp.solver.exact_hessian);
  EXPECT_EQ(toYaml(parseControlSettings("", "empty")), toYaml(ControlSettings{}));
  EXPECT_EQ(toYaml(parseControlSettings("mpc:\nocp:\n", "empty sections")),
            toYaml(ControlSettings{}));
  // The text-level OCP parser reads the same keys as before the node-level overload.
  const centroidal::OcpSettings o = centroidal::parseOcpSettings("horizon: 20\ndt: 0.02\n", "o");
  EXPECT_EQ(o.horizon, 20);
  EXPECT_EQ(o.dt, 0.02);
  EXPECT_FALSE(o.solver.exact_hessian);
}

TEST(ControlSettings, ErrorsNameTheSourceLineAndFullKey) {
  struct Case {
    const char* text;
    const char* needle;
  };
  const Case cases[] = {
      // unknown, repeated
      {"control_period: 0.001\nfoo: 1\n", "line 2: unknown key 'foo'"},
      {"mpc:\n  period: 0.02\n  perod: 0.01\n", "line 3: unknown key 'mpc.perod'"},
      {"integrator:\n  mode: naive\n  gain: 1\n", "line 3: unknown key 'integrator.gain'"},
      {"mpc:\n  period: 0.02\n  period: 0.03\n",
       "line 3: mpc.period: given twice (first on line 2)"},
      {"mpc:\n  period: 0.02\nmpc:\n  latency: 0.01\n",
       "line 3: mpc: given twice (first on line 1)"},
      {"control_period: 0.001\ncontrol_period: 0.002\n",
       "line 2: control_period: given twice (first on line 1)"},
      // wrong types
      {"mpc: 3\n", "line 1: mpc: expected a mapping, got a value"},
      {"feedback: [1, 2]\n", "line 1: feedback: expected a mapping, got a list"},
      {"mpc:\n  initial_iterations: 2.5\n",
       "line 2: mpc.initial_iterations: expected an integer, got '2.5'"},
      {"refinement:\n  horizon: fast\n", "line 2: refinement.horizon: 'fast' is not a number"},
      {"refinement:\n  horizon: '0.1'\n",
       "refinement.horizon: '0.1' is not a number (it is quoted"},
      {"feedback:\n  foot_kp: [1]\n",
       "line 2: feedback.foot_kp: expected a single number, got a list"},
      {"cbf_qp:\n  foot_weight:\n", "line 2: cbf_qp.foot_weight: no value"},
      {"mpc:\n  timing: sometimes\n",
       "line 2: mpc.timing: expected deterministic or asynchronous, got 'sometimes'"},
      {"integrator:\n  mode: 'naive'\n", "line 2: integrator.mode: expected internal or naive"},
      // vector length
      {"feedback:\n  base_kp: [1, 2]\n",
       "line 2: feedback.base_kp: expected a list of 6 numbers, got a list of 2"},
      {"cbf_qp:\n  base_weight: 1\n",
       "line 2: cbf_qp.base_weight: expected a list of 6 numbers, got a value"},
      // out of range
      {"control_period: 0\n", "line 1: control_period: 0 is outside (0, 0.1]"},
      {"control_period: 0.5\n", "line 1: control_period: 0.5 is outside (0, 0.1]"},
      {"mpc:\n  latency: -0.01\n", "line 2: mpc.latency: -0.01 is outside [0, 1]"},
      {"mpc:\n  initial_iterations: 0\n", "line 2: mpc.initial_iterations: 0 is outside"},
      {"refinement:\n  substeps: 101\n", "line 2: refinement.substeps: 101 is outside [1, 100]"},
      {"feedback:\n  base_kd: [1, 1, 1, 1, 1, -1]\n", "line 2: feedback.base_kd: -1 is outside"},
      {"feedback:\n  joint_kp: .nan\n", "line 2: feedback.joint_kp: .nan is outside"},
      {"cbf_qp:\n  damping: 0\n", "line 2: cbf_qp.damping: 0 is outside (0, 1000000]"},
      {"cbf_qp:\n  velocity_limit_scale: 1.5\n",
       "cbf_qp.velocity_limit_scale: 1.5 is outside (0, 1]"},
      {"cbf_qp:\n  max_iterations: 0\n", "line 2: cbf_qp.max_iterations: 0 is outside [1, 100000]"},
      {"cbf_qp:\n  fallback_brake_time: 0\n", "cbf_qp.fallback_brake_time: 0 is outside (0, 100]"},
      {"integrator:\n  position_time_constant: -1\n",
       "line 2: integrator.position_time_constant: -1 is outside"},
      {"wheels:\n  skid_track_factor: 0\n",
       "line 2: wheels.skid_track_factor: 0 is outside (0, 100]"},
      {"wheels:\n  skid_yaw_rate_gain: -1\n",
       "line 2: wheels.skid_yaw_rate_gain: -1 is outside [0, 1000]"},
      {"wheels:\n  skid_velocity_gain: -1\n",
       "line 2: wheels.skid_velocity_gain: -1 is outside [0, 1000]"},
      {"wheels:\n  skid_position_gain: nan\n", "line 2: wheels.skid_position_gain"},
      {"baseline:\n  position_leash: 2\n", "line 2: baseline.position_leash: 2 is outside [0, 1]"},
      {"wheels:\n  gain: 1\n", "line 2: unknown key 'wheels.gain'"},
      // contradictions between keys: the line of the first key named
      {"mpc:\n  timing: deterministic\n  period: 0\n", "line 3: mpc.period: 0 is allowed in"},
      {"mpc:\n  period: 0.01\n  latency: 0.02\n", "line 3: mpc.latency: 0.02 is above mpc.period"},
      {"mpc:\n  period: 0.005\n", "line 2: mpc.latency: 0.02 is above mpc.period"},
      {"ocp:\n  step_down_max_hold: 0.5\n  edge_hold_lead: 0.1\n",
       "ocp.edge_hold_lead: 0.1 is below mpc.max_solution_age (0.2)"},
      // the nested OCP and solver
      {"ocp: 3\n", "line 1: ocp: expected a mapping, got a value"},
      {"ocp:\n  horizon: 0\n", "line 2: ocp.horizon: 0 is outside [1, 10000]"},
      {"ocp:\n  horizon: 10\n  bogus: 1\n", "line 3: unknown key 'ocp.bogus'"},
      {"ocp:\n  dt: 0.01\n  dt: 0.02\n", "line 3: ocp.dt: given twice (first on line 2)"},
      {"ocp:\n  base_velocity_weight: [1, 2]\n", "ocp.base_velocity_weight: expected a list of 6"},
      {"ocp:\n  solver: 3\n", "line 2: ocp.solver: expected a mapping, got a value"},
      {"ocp:\n  solver:\n    bogus: 1\n", "line 3: unknown key 'ocp.solver.bogus'"},
      {"ocp:\n  solver:\n    num_threads: 0\n",
       "line 3: ocp.solver.num_threads: 0 is outside [1, 256]"},
      // the document
      {"- 1\n", "line 1: expected a mapping"},
      {"a: [1\n", "YAML error: line 2"},
      {"mpc: {}\n---\nmpc: {}\n", "more than one YAML document"},
  };
  for (const Case& c : cases) {
    const std::string e = errorOf(c.text);
    EXPECT_TRUE(has(e, "test.yaml") && has(e, c.needle)) << c.text << " -> " << e;
  }
  // The control layer's own errors start with its name.
  EXPECT_EQ(errorOf("mpc:\n  latency: 2\n").rfind("control settings test.yaml: line 2: ", 0), 0u);
  EXPECT_EQ(errorOf("ocp:\n  dt: 0\n").rfind("control settings test.yaml: line 2: ocp.dt: ", 0),
            0u);
}

TEST(ControlSettings, CheckSettingsNamesTheFirstBadField) {
  const auto error = [](const ControlSettings& s) {
    try {
      checkSettings(s);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  ControlSettings s;
  s.feedback.foot_kp = -1;
  EXPECT_TRUE(has(error(s), "feedback.foot_kp: -1 is outside")) << error(s);
  s = ControlSettings{};
  s.feedback.base_kp[3] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(has(error(s), "feedback.base_kp: entry 3")) << error(s);
  s = ControlSettings{};
  s.mpc.timing = static_cast<MpcTiming>(7);
  EXPECT_TRUE(has(error(s), "mpc.timing: not deterministic or asynchronous")) << error(s);
  s = ControlSettings{};
  s.mpc.period = 0;
  EXPECT_TRUE(has(error(s), "mpc.period: 0 is allowed in asynchronous timing only")) << error(s);
  s.mpc.timing = MpcTiming::Asynchronous;
  EXPECT_EQ(error(s), "");
  s = ControlSettings{};
  s.ocp.horizon = 0;
  EXPECT_TRUE(has(error(s), "control settings: ocp.horizon: 0 is outside [1, 10000]")) << error(s);
  s = ControlSettings{};
  s.ocp.solver.barrier_realtime = -1;
  EXPECT_TRUE(has(error(s), "ocp.solver: ") && has(error(s), "barrier_realtime")) << error(s);
}

TEST(ControlSettings, LoadNamesTheFile) {
  try {
    loadControlSettings("/nonexistent/control.yaml");
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_TRUE(has(e.what(), "/nonexistent/control.yaml")) << e.what();
  }
}

TEST(ControlSettings, ExtendsStartsFromAnotherFileAndOverridesKeyByKey) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / "rollstep_control_settings_extends";
  std::filesystem::create_directories(dir / "sub");
  const auto write = [&](const std::filesystem::path& file, const std::string& text) {
    std::ofstream(dir / file) << text;
  };
  write("base.yaml",
        "mpc:\n  period: 0.04\n  latency: 0.02\nintegrator:\n  velocity_time_constant: 0.2\n"
        "ocp:\n  gait_period: 1.8\n  swing_clearance: 0.04\n  solver:\n"
        "    realtime_iterations: 2\n    barrier_realtime: 0.01\n");
  write("sub/child.yaml",
        "mpc:\n  latency: 0.03\nextends: ../base.yaml\nocp:\n  swing_clearance: 0.06\n"
        "  solver:\n    realtime_iterations: 3\n");
  write("sub/grandchild.yaml", "extends: child.yaml\nfeedback:\n  foot_kp: 300\n");
  const ControlSettings defaults;
  const ControlSettings c = loadControlSettings((dir / "sub/grandchild.yaml").string());
  EXPECT_EQ(c.mpc.period, 0.04);   // base
  EXPECT_EQ(c.mpc.latency, 0.03);  // child over base (extends stands after it)
  EXPECT_EQ(c.integrator.velocity_time_constant, 0.2);
  EXPECT_EQ(c.ocp.gait_period, 1.8);
  EXPECT_EQ(c.ocp.swing_clearance, 0.06);
  EXPECT_EQ(c.ocp.solver.realtime_iterations, 3);
  EXPECT_EQ(c.ocp.solver.barrier_realtime, 0.01);  // the nested solver: key by key too
  EXPECT_EQ(c.feedback.foot_kp, 300.0);
  EXPECT_EQ(c.feedback.foot_kd, defaults.feedback.foot_kd);  // given nowhere
  EXPECT_EQ(c.ocp.horizon, defaults.ocp.horizon);

  // Errors name the file and line that extends, and the cause.
  const auto errorOfFile = [&](const std::string& file) -> std::string {
    try {
      loadControlSettings((dir / file).string());
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "";
  };
  write("missing.yaml", "extends: nowhere.yaml\n");
  std::string e = errorOfFile("missing.yaml");
  EXPECT_TRUE(has(e, "missing.yaml: line 1: extends: ") && has(e, "nowhere.yaml")) << e;
  write("loop.yaml", "extends: loop.yaml\n");
  e = errorOfFile("loop.yaml");
  EXPECT_TRUE(has(e, "more than 8 files deep")) << e;
  write("bad_base.yaml", "mpc:\n  periode: 1\n");
  write("uses_bad.yaml", "\nextends: bad_base.yaml\n");
  e = errorOfFile("uses_bad.yaml");
  EXPECT_TRUE(has(e, "uses_bad.yaml: line 2: extends: ") && has(e, "mpc.periode")) << e;
  EXPECT_TRUE(has(errorOf("extends: [a, b]\n"), "test.yaml: line 1: extends: expected the path"));
  EXPECT_TRUE(has(errorOf("extends: a.yaml\nextends: b.yaml\n"), "given twice"))
      << errorOf("extends: a.yaml\nextends: b.yaml\n");
  std::filesystem::remove_all(dir);
}

// A robot folder anywhere (not two levels under the source tree) starts from the library's
// files by name: `library:NAME` is config/NAME, wherever the file that names it lies.
TEST(ControlSettings, ExtendsLibraryNamesTheLibrarysConfigFile) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / "rollstep_control_settings_library";
  std::filesystem::create_directories(dir);
  const std::string file = (dir / "baseline.yaml").string();
  std::ofstream(file)
      << "extends: library:baseline.yaml\nintegrator:\n  deflection_compensation: 1\n";
  const std::string library = std::string(ROLLSTEP_TEST_DATA_DIR) + "/../../config/baseline.yaml";
  ControlSettings expected = loadControlSettings(library);
  expected.integrator.deflection_compensation = 1;
  EXPECT_EQ(toYaml(loadControlSettings(file)), toYaml(expected));
  EXPECT_NE(toYaml(loadControlSettings(library)), toYaml(ControlSettings{}));
  std::ofstream(file) << "extends: library:no_such_file.yaml\n";
  try {
    loadControlSettings(file);
    ADD_FAILURE() << "a missing library file was accepted";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("baseline.yaml: line 1: extends: "), std::string::npos) << what;
    EXPECT_NE(what.find("no_such_file.yaml"), std::string::npos) << what;
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace rollstep::control
