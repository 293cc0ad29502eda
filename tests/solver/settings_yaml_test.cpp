// SolverSettings from YAML: defaults, every key, type and range errors, round trip.
#include "rollstep/solver/settings_yaml.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

namespace rollstep::solver {
namespace {

std::string errorOf(const std::string& yaml) {
  try {
    parseSolverSettings(yaml, "test.yaml");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(SolverSettingsYaml, ShippedFileListsEveryFieldWithItsDefault) {
  const std::string path = std::string(ROLLSTEP_SOURCE_DIR) + "/config/solver.yaml";
  const SolverSettings read = loadSolverSettings(path);
  EXPECT_EQ(toYaml(read), toYaml(SolverSettings{}));
  // Every key toYaml writes appears in the file (so it documents all of them).
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  std::istringstream keys(toYaml(SolverSettings{}));
  for (std::string line; std::getline(keys, line);) {
    const std::string key = line.substr(0, line.find(':'));
    EXPECT_NE(text.str().find("\n" + key + ":"), std::string::npos) << key;
  }
}

TEST(SolverSettingsYaml, EmptyDocumentGivesTheDefaults) {
  EXPECT_EQ(toYaml(parseSolverSettings("")), toYaml(SolverSettings{}));
  EXPECT_EQ(toYaml(parseSolverSettings("# nothing\n")), toYaml(SolverSettings{}));
}

TEST(SolverSettingsYaml, ReadsEveryKindOfField) {
  const SolverSettings s = parseSolverSettings(
      "mode: realtime\nmax_iterations: 7\nbarrier_realtime: 2.5e-3\nline_search: false\n"
      "num_threads: 3\ndivergence_threshold: .inf\n");
  EXPECT_EQ(s.mode, SolverMode::RealTime);
  EXPECT_EQ(s.max_iterations, 7);
  EXPECT_EQ(s.barrier_realtime, 2.5e-3);
  EXPECT_FALSE(s.line_search);
  EXPECT_EQ(s.num_threads, 3);
  EXPECT_TRUE(std::isinf(s.divergence_threshold));
  // Untouched fields keep their defaults.
  EXPECT_EQ(s.kkt_tolerance, SolverSettings{}.kkt_tolerance);
  EXPECT_TRUE(s.exact_hessian);
}

TEST(SolverSettingsYaml, RoundTripIsExact) {
  SolverSettings s;
  s.mode = SolverMode::RealTime;
  s.max_iterations = 42;
  s.kkt_tolerance = 1.0 / 3.0 * 1e-7;
  s.barrier_initial = 0.1 + 0.2;  // not representable in few digits
  s.barrier_min = 1e-11;
  s.barrier_decrease = 0.123456789012345;
  s.barrier_realtime = 7e-4;
  s.fraction_to_boundary = 0.99;
  s.line_search = false;
  s.exact_hessian = false;
  s.max_line_search_steps = 5;
  s.rank_tolerance = 1e-12;
  s.num_threads = 2;
  s.thread_spin_us = 0;
  s.divergence_threshold = std::numeric_limits<double>::infinity();
  s.infeasibility_tolerance = 0.0;
  const std::string text = toYaml(s);
  const SolverSettings r = parseSolverSettings(text);
  EXPECT_EQ(toYaml(r), text);
  EXPECT_EQ(r.kkt_tolerance, s.kkt_tolerance);
  EXPECT_EQ(r.barrier_initial, s.barrier_initial);
  EXPECT_EQ(r.barrier_decrease, s.barrier_decrease);
  EXPECT_NE(text, toYaml(SolverSettings{}));
}

TEST(SolverSettingsYaml, BadInputIsAnErrorNamingTheKey) {
  const auto has = [](const std::string& error, const std::string& part) {
    return error.find(part) != std::string::npos;
  };
  std::string e = errorOf("max_iteratons: 10\n");
  EXPECT_TRUE(has(e, "test.yaml") && has(e, "unknown key 'max_iteratons'") &&
              has(e, "max_iterations"))
      << e;
  e = errorOf("max_iterations: 2.5\n");
  EXPECT_TRUE(has(e, "'max_iterations'") && has(e, "integer")) << e;
  e = errorOf("line_search: maybe\n");
  EXPECT_TRUE(has(e, "'line_search'") && has(e, "true or false")) << e;
  e = errorOf("kkt_tolerance: small\n");
  EXPECT_TRUE(has(e, "'kkt_tolerance'") && has(e, "number")) << e;
  e = errorOf("mode: fast\n");
  EXPECT_TRUE(has(e, "'mode'") && has(e, "converging or realtime")) << e;
  e = errorOf("num_threads: [1, 2]\n");
  EXPECT_TRUE(has(e, "'num_threads'") && has(e, "single value")) << e;
  e = errorOf("num_threads: 2\nnum_threads: 1\n");
  EXPECT_TRUE(has(e, "'num_threads' given twice")) << e;
  // Values checkSettings rejects, after parsing.
  e = errorOf("fraction_to_boundary: 1.5\n");
  EXPECT_TRUE(has(e, "fraction_to_boundary must be in (0, 1)")) << e;
  e = errorOf("barrier_min: 1\nbarrier_initial: 0.1\n");
  EXPECT_TRUE(has(e, "barrier_min must be <= barrier_initial")) << e;
  e = errorOf("kkt_tolerance: .nan\n");
  EXPECT_TRUE(has(e, "kkt_tolerance")) << e;
  // Not a mapping, broken YAML, a missing file.
  EXPECT_TRUE(has(errorOf("- 1\n- 2\n"), "mapping"));
  EXPECT_TRUE(has(errorOf("a: [1, 2\n"), "YAML error"));
  EXPECT_THROW(loadSolverSettings("/nonexistent/solver.yaml"), std::runtime_error);
}

}  // namespace
}  // namespace rollstep::solver
