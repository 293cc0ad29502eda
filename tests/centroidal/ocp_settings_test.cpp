// OCP settings and the robot description from YAML: defaults documented by config/ocp.yaml,
// every error names the source, the line and the key.
#include "rollstep/centroidal/ocp_settings.hpp"

#include <gtest/gtest.h>

#include <string>

#include "rollstep/common/text_file.hpp"

namespace rollstep::centroidal {
namespace {

std::string errorOf(const std::string& text) {
  try {
    parseOcpSettings(text, "test.yaml");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}
bool has(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

TEST(OcpSettings, TheDocumentedFileEqualsTheDefaults) {
  const OcpSettings file =
      loadOcpSettings(std::string(ROLLSTEP_TEST_DATA_DIR) + "/../../config/ocp.yaml");
  EXPECT_EQ(toYaml(file), toYaml(OcpSettings{}));
  // Every key toYaml writes is documented in the file.
  const std::string text =
      readTextFile(std::string(ROLLSTEP_TEST_DATA_DIR) + "/../../config/ocp.yaml", "test", 1 << 20);
  const std::string all = toYaml(OcpSettings{});
  for (std::size_t start = 0; start < all.size();) {
    const std::size_t colon = all.find(':', start);
    const std::string key = all.substr(start, colon - start);
    if (key.rfind("  ", 0) != 0) {  // the nested solver keys are config/solver.yaml's
      EXPECT_TRUE(has(text, "\n" + key + ":") || has(text, "\n# " + key + ":")) << key;
    }
    start = all.find('\n', start) + 1;
  }
}

TEST(OcpSettings, RoundTripsAndReadsAnySubset) {
  OcpSettings s;
  s.horizon = 37;
  s.dt = 0.01;
  s.base_velocity_weight << 1, 2, 3, 4, 5, 6.5;
  s.soft_state_constraints = false;
  s.solver.mode = solver::SolverMode::RealTime;
  s.solver.num_threads = 2;
  const std::string text = toYaml(s);
  const OcpSettings back = parseOcpSettings(text, "round trip");
  EXPECT_EQ(toYaml(back), text);
  EXPECT_EQ(back.solver.num_threads, 2);
  const OcpSettings subset = parseOcpSettings("dt: 0.02\nsolver:\n  max_iterations: 7\n", "x");
  EXPECT_EQ(subset.dt, 0.02);
  EXPECT_EQ(subset.horizon, 100);
  EXPECT_EQ(subset.solver.max_iterations, 7);
  EXPECT_EQ(toYaml(parseOcpSettings("", "empty")), toYaml(OcpSettings{}));
}

TEST(OcpSettings, ErrorsNameTheSourceLineAndKey) {
  struct Case {
    const char* text;
    const char* needle;
  };
  const Case cases[] = {
      {"horizon: 10\nfoo: 1\n", "line 2: unknown key 'foo'"},
      {"dt: 0.01\ndt: 0.02\n", "line 2: dt: given twice (first on line 1)"},
      {"horizon: 2.5\n", "horizon: expected an integer, got '2.5'"},
      {"horizon: 0\n", "horizon: 0 is outside [1, 10000]"},
      {"dt: 0\n", "dt: 0 is outside (0, 10]"},
      {"dt: .nan\n", "dt: .nan is outside"},
      {"dt: fast\n", "dt: 'fast' is not a number"},
      {"dt: '0.1'\n", "(it is quoted or tagged)"},
      {"dt: [1]\n", "dt: expected a single number, got a list"},
      {"base_velocity_weight: [1, 2]\n", "expected a list of 6 numbers, got a list of 2"},
      {"base_position_weight: 3\n", "expected a list of 3 numbers, got a value"},
      {"momentum_weight: [1, 1, 1, 1, 1, -1]\n",
       "momentum_weight: -1 is outside [0, 1000000000000]"},
      {"soft_state_constraints: yes\n", "expected true or false, got 'yes'"},
      {"trot_duty: 1\n", "trot_duty: 1 is outside (0, 1)"},
      {"foothold_edge_clearance: 2\n", "foothold_edge_clearance: 2 is outside [0, 1]"},
      {"force_weight:\n", "force_weight: no value"},
      {"solver: 3\n", "line 1: solver: expected a mapping, got a value"},
      {"solver:\n  num_threads: 0\n", "line 2: solver.num_threads: 0 is outside [1, 256]"},
      {"solver:\n  bogus: 1\n", "line 2: unknown key 'solver.bogus' (known in solver: mode, "},
      {"- 1\n", "expected a mapping"},
      {"a: [1\n", "YAML error: line 2"},
      {"dt: 0.1\n---\ndt: 0.2\n", "more than one YAML document"},
  };
  for (const Case& c : cases) {
    const std::string e = errorOf(c.text);
    EXPECT_TRUE(has(e, "test.yaml") && has(e, c.needle)) << c.text << " -> " << e;
  }
}

TEST(RobotOcpDescription, Tachyon3FileReadsAndErrorsAreNamed) {
  const std::string path = std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/centroidal.yaml";
  const RobotOcpDescription d = loadRobotOcpDescription(path);
  EXPECT_EQ(d.contact_frames.size(), 6u);
  EXPECT_EQ(d.drive_wheels.size(), 4u);
  EXPECT_EQ(d.side_pairs.size(), 2u);
  EXPECT_EQ(d.nominal_joint_positions.size(), 12);
  ASSERT_EQ(d.servo_stiffness.size(), 12);
  EXPECT_EQ(d.servo_stiffness[0], 3000.0);   // LF hip
  EXPECT_EQ(d.servo_stiffness[1], 60000.0);  // LF knee
  EXPECT_EQ(d.trot_group_a.size(), 3u);
  EXPECT_TRUE(has(d.urdf, "tachyon3/tachyon3.urdf"));
  const auto error = [](const std::string& text) {
    try {
      parseRobotOcpDescription(text, "r.yaml");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string base = "urdf: a.urdf\ncontact_frames: [A, B]\nnominal_joint_positions: [0]\n";
  EXPECT_EQ(error(base), "");
  EXPECT_TRUE(
      has(error("urdf: a.urdf\ncontact_frames: [A]\n"), "missing key 'nominal_joint_positions'"));
  EXPECT_TRUE(
      has(error(base + "drive_wheels: [C]\n"), "line 4: drive_wheels: 'C' is not a contact frame"));
  EXPECT_TRUE(
      has(error(base + "side_pairs: [[A]]\n"), "line 4: side_pairs[0]: expected 2 names, got 1"));
  EXPECT_TRUE(
      has(error(base + "contact_offset: -1\n"), "line 4: contact_offset: -1 is outside [0, 10]"));
  EXPECT_TRUE(has(error(base + "colour: red\n"), "unknown key 'colour'"));
  EXPECT_TRUE(has(error("urdf: a\ncontact_frames: [A, A]\nnominal_joint_positions: [0]\n"),
                  "'A' given twice"));
  EXPECT_TRUE(has(error("urdf: a\ncontact_frames: [A]\nnominal_joint_positions: [x]\n"),
                  "line 3: nominal_joint_positions: 'x' is not a number"));
  EXPECT_EQ(error(base + "servo_stiffness: [100]\n"), "");
  EXPECT_TRUE(has(error(base + "servo_stiffness: [0]\n"),
                  "line 4: servo_stiffness: 0 is outside (0, inf)"));
  EXPECT_TRUE(has(error(base + "servo_stiffness: 5\n"), "servo_stiffness: expected a list"));
  // A trot's two groups hold every foot exactly once; a walk order lists every foot.
  EXPECT_EQ(error(base + "trot_groups: [[A], [B]]\nwalk_order: [B, A]\n"), "");
  EXPECT_TRUE(
      has(error(base + "trot_groups: [[A], []]\n"),
          "line 4: trot_groups: 'B' is in neither group (each contact frame in exactly one)"));
  EXPECT_TRUE(has(error(base + "trot_groups: [[A, B], [B]]\n"),
                  "line 4: trot_groups: 'B' is in both groups"));
  EXPECT_TRUE(has(error(base + "trot_groups: [[A, B]]\n"),
                  "line 4: trot_groups: expected 2 lists of names, got a list of 1"));
  EXPECT_TRUE(has(error(base + "side_pairs: [[A, C]]\n"),
                  "line 4: side_pairs: 'C' is not a contact frame"));
  EXPECT_TRUE(has(error("urdf: a\ncontact_frames: []\nnominal_joint_positions: [0]\n"),
                  "line 2: contact_frames: empty"));
  EXPECT_TRUE(has(error("urdf: a\ncontact_frames: [A]\nnominal_joint_positions: []\n"),
                  "line 3: nominal_joint_positions: expected at least 1 numbers, got 0"));
  EXPECT_TRUE(has(error(base + "urdf: b\n"), "line 4: urdf: given twice (first on line 1)"));
  EXPECT_TRUE(has(error(base + "walk_order: [B]\n"),
                  "line 4: walk_order: 'A' is missing (the order lists every contact frame once)"));
}

TEST(RobotOcpDescription, DocumentedListsEveryKeyWithItsDefault) {
  const std::string doc = documentedRobotDescription();
  for (const char* line :
       {"urdf: \"\"\n", "contact_frames: []\n", "drive_wheels: []\n", "side_pairs: []\n",
        "contact_offset: 0  # [m] [0, 10]\n", "nominal_joint_positions: []  # [rad or m]\n",
        "servo_stiffness: []  # [N m/rad or N/m] (0, inf)\n", "trot_groups: []\n",
        "walk_order: []\n"}) {
    EXPECT_TRUE(has(doc, line)) << line << " not in\n" << doc;
  }
}

}  // namespace
}  // namespace rollstep::centroidal
