// SolverSettings from YAML: defaults, every key, type and range errors, round trip.
#include "rollstep/solver/settings_yaml.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
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
  s.bound_push = 0.0;
  s.slack_reset = false;
  s.line_search = false;
  s.exact_hessian = false;
  s.max_line_search_steps = 5;
  s.rank_tolerance = 1e-12;
  s.num_threads = 2;
  s.thread_spin_us = 0;
  s.divergence_threshold = std::numeric_limits<double>::infinity();
  s.infeasibility_tolerance = 0.0;
  s.filter_reset_trigger = 0;
  s.max_filter_resets = 12;
  s.max_second_order_corrections = 3;
  const std::string text = toYaml(s);
  const SolverSettings r = parseSolverSettings(text);
  EXPECT_EQ(toYaml(r), text);
  EXPECT_EQ(r.kkt_tolerance, s.kkt_tolerance);
  EXPECT_EQ(r.barrier_initial, s.barrier_initial);
  EXPECT_EQ(r.barrier_decrease, s.barrier_decrease);
  EXPECT_FALSE(r.slack_reset);
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
  EXPECT_TRUE(has(e, "line 1: max_iterations: expected an integer, got '2.5'")) << e;
  e = errorOf("line_search: maybe\n");
  EXPECT_TRUE(has(e, "line 1: line_search: expected true or false, got 'maybe'")) << e;
  e = errorOf("kkt_tolerance: small\n");
  EXPECT_TRUE(has(e, "line 1: kkt_tolerance: 'small' is not a number")) << e;
  e = errorOf("mode: fast\n");
  EXPECT_TRUE(has(e, "line 1: mode: expected converging or realtime, got 'fast'")) << e;
  e = errorOf("num_threads: [1, 2]\n");
  EXPECT_TRUE(has(e, "line 1: num_threads: expected an integer, got a list")) << e;
  e = errorOf("num_threads: 2\nnum_threads: 1\n");
  EXPECT_TRUE(has(e, "line 2: num_threads: given twice (first on line 1)")) << e;
  // Values checkSettings rejects, after parsing.
  e = errorOf("fraction_to_boundary: 1.5\n");
  EXPECT_TRUE(has(e, "fraction_to_boundary must be in (0, 1)")) << e;
  e = errorOf("bound_push: 0.5\n");
  EXPECT_TRUE(has(e, "bound_push must be in [0, 0.5)")) << e;
  e = errorOf("barrier_min: 1\nbarrier_initial: 0.1\n");
  EXPECT_TRUE(has(e, "barrier_min must be <= barrier_initial")) << e;
  e = errorOf("kkt_tolerance: .nan\n");
  EXPECT_TRUE(has(e, "kkt_tolerance")) << e;
  // Not a mapping, broken YAML, a missing file.
  EXPECT_TRUE(has(errorOf("- 1\n- 2\n"), "mapping"));
  EXPECT_TRUE(has(errorOf("a: [1, 2\n"), "YAML error"));
  EXPECT_THROW(loadSolverSettings("/nonexistent/solver.yaml"), std::runtime_error);
}

bool has(const std::string& error, const std::string& part) {
  return error.find(part) != std::string::npos;
}

// Failure classes of issue 16, from the classes rather than single examples.

TEST(SolverSettingsYaml, NonFiniteValuesAreRefusedUnlessInfMeansNever) {
  // Every floating-point key, with NaN and both infinities: an error naming the key, unless
  // the documented meaning of .inf is "never" (divergence_threshold, infeasibility_tolerance).
  const std::string keys[] = {
      "kkt_tolerance",        "barrier_initial",        "barrier_min", "barrier_decrease",
      "barrier_realtime",     "fraction_to_boundary",   "bound_push",  "rank_tolerance",
      "divergence_threshold", "infeasibility_tolerance"};
  for (const std::string& key : keys) {
    for (const std::string value : {".nan", ".NaN", "-.inf", ".inf"}) {
      const bool allowed =
          value == ".inf" && (key == "divergence_threshold" || key == "infeasibility_tolerance");
      const std::string e = errorOf(key + ": " + value + "\n");
      if (allowed) {
        EXPECT_EQ(e, "") << key << ": " << value;
      } else {
        EXPECT_TRUE(has(e, "test.yaml") && has(e, key) && has(e, "'" + value + "' in the file"))
            << key << ": " << value << " -> " << e;
      }
    }
  }
  // barrier_min above the default barrier_initial: both keys named, the one not in the
  // file as its default.
  const std::string e = errorOf("barrier_min: 0.5\n");
  EXPECT_TRUE(has(e, "barrier_min: '0.5' in the file") && has(e, "barrier_initial: default")) << e;
}

TEST(SolverSettingsYaml, AbsurdIntegersAreRefusedWithTheRange) {
  struct Case {
    const char* text;
    const char* needle;
  };
  const Case cases[] = {
      {"num_threads: 20000\n", "line 1: num_threads: 20000 is outside [1, 256]"},
      {"num_threads: 0\n", "line 1: num_threads: 0 is outside [1, 256]"},
      {"max_iterations: -3\n", "line 1: max_iterations: -3 is outside [1, 1000000]"},
      {"max_line_search_steps: 5000\n", "line 1: max_line_search_steps: 5000 is outside [1, 1000]"},
      {"thread_spin_us: -1\n", "line 1: thread_spin_us: -1 is outside [0, 1000000]"},
      {"thread_spin_us: 99999999999\n",
       "line 1: thread_spin_us: expected an integer, got '99999999999'"},
      {"filter_reset_trigger: -1\n", "line 1: filter_reset_trigger: -1 is outside [0, 1000000]"},
      {"max_filter_resets: -2\n", "line 1: max_filter_resets: -2 is outside [0, 1000000]"},
      {"max_second_order_corrections: 101\n",
       "line 1: max_second_order_corrections: 101 is outside [0, 100]"},
      {"max_iterations: .inf\n", "line 1: max_iterations: expected an integer, got '.inf'"},
      {"max_iterations: 1e3\n", "line 1: max_iterations: expected an integer, got '1e3'"},
  };
  for (const Case& c : cases) {
    const std::string e = errorOf(c.text);
    EXPECT_TRUE(has(e, "test.yaml") && has(e, c.needle)) << c.text << " -> " << e;
  }
  EXPECT_EQ(parseSolverSettings("num_threads: 256\nthread_spin_us: 0\n").num_threads, 256);
}

TEST(SolverSettingsYaml, StructuralErrorsNameTheFile) {
  // A second document is not ignored.
  std::string e = errorOf("num_threads: 2\n---\nnum_threads: 3\n");
  EXPECT_TRUE(has(e, "test.yaml") && has(e, "more than one YAML document") &&
              has(e, "starts on line 2"))
      << e;
  e = errorOf("---\n---\n");
  EXPECT_TRUE(has(e, "more than one YAML document")) << e;
  // One document with an explicit start marker is fine.
  EXPECT_EQ(parseSolverSettings("---\nnum_threads: 2\n...\n").num_threads, 2);
  // Keys that are not plain names (a sequence, a mapping, null) are errors naming the file.
  for (const std::string text : {"? [a, b]\n: 1\n", "? {a: 1}\n: 2\n", "~: 1\n"}) {
    e = errorOf(text);
    EXPECT_TRUE(has(e, "test.yaml") && has(e, "not a plain name")) << text << " -> " << e;
  }
  e = errorOf("max_iterations:\n");
  EXPECT_TRUE(has(e, "line 1: max_iterations: no value")) << e;
  e = errorOf("mode: {a: 1}\n");
  EXPECT_TRUE(has(e, "line 1: mode: expected converging or realtime, got a mapping")) << e;
  // Texts yaml-cpp 0.7 looped forever on (found by fuzz_settings; libyaml now parses every
  // configuration): each a prompt error naming the file.
  for (const std::string text : {",", ",a: 1\n", "--- ,\n", "num_threads: 2\n---\n&x ,\n", "!w ,",
                                 "!w ---\n!w ,,l", "'',", ">\n,", "&x:,"}) {
    e = errorOf(text);
    EXPECT_EQ(e.rfind("solver settings test.yaml: ", 0), 0u) << text << " -> " << e;
  }
  // Deep nesting is an error, not a stack overflow.
  e = errorOf("mode: " + std::string(100000, '[') + "\n");
  EXPECT_TRUE(has(e, "test.yaml")) << e.substr(0, 200);
  // Anchors and aliases resolve to the scalar they name.
  EXPECT_EQ(parseSolverSettings("max_iterations: &n 7\nmax_line_search_steps: *n\n")
                .max_line_search_steps,
            7);
  // Every error is a std::runtime_error whose message starts with "solver settings <file>".
  for (const std::string text : {"a: 1\n", "mode: 3\n", "[\n", "\"x\n", "num_threads: 1\n---\n"}) {
    e = errorOf(text);
    EXPECT_EQ(e.rfind("solver settings test.yaml: ", 0), 0u) << text << " -> " << e;
  }
}

TEST(SolverSettingsYaml, LoadRefusesWhatIsNotARegularFile) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("rollstep_settings_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto loadError = [](const std::string& path) {
    try {
      loadSolverSettings(path);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  // A directory used to give the defaults.
  std::string e = loadError(dir.string());
  EXPECT_TRUE(has(e, "solver settings '" + dir.string() + "'") && has(e, "directory")) << e;
  // A FIFO is refused at once instead of blocking until a writer appears.
  const std::string fifo = (dir / "fifo.yaml").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  e = loadError(fifo);
  EXPECT_TRUE(has(e, "FIFO")) << e;
  e = loadError("/dev/zero");  // a device would be read forever
  EXPECT_TRUE(has(e, "character device")) << e;
  e = loadError((dir / "missing.yaml").string());
  EXPECT_TRUE(has(e, "missing.yaml") && has(e, "No such file")) << e;
  // Errors in a file name the file.
  const std::string bad = (dir / "bad.yaml").string();
  {
    std::ofstream out(bad);
    out << "num_threads: 2\nnum_threads: 3\n";
  }
  e = loadError(bad);
  EXPECT_TRUE(
      has(e, "solver settings " + bad + ": line 2: num_threads: given twice (first on line 1)"))
      << e;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace rollstep::solver
