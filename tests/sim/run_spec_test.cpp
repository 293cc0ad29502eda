// The run spec: written and read back equal, strict reading with file, line and key in
// every error, the checks of keys that only apply together, paths relative to the file.
#include "rollstep/sim/run_spec.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "rollstep/sim/run.hpp"

namespace rollstep::sim {
namespace {

std::string errorOf(const std::string& text) {
  try {
    parseRunSpec(text, "run spec 'r.yaml'");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "no error";
}

RunSpec everyKeySet() {
  RunSpec s;
  s.robot = "robots/my robot";  // a path with a space: written quoted
  s.scene_file = "/scenes/step20_custom.yaml";
  s.controller = ControllerKind::Nmpc;
  s.duration = 44.125;
  s.gait = planning::GaitKind::Trot;
  s.command = {{0.0, {0.15, 0.0, 0.0}}, {19.0, {0.0, 0.1, -0.3}}, {21.5, {-0.15, 0.0, 0.0}}};
  s.control_config = "behaviours/climb.yaml";
  s.mpc_timing = TimingChoice::Deterministic;
  s.integrator = IntegratorChoice::Naive;
  s.terrain = TerrainSource::Perception;
  s.lidar_config = "lidar.yaml";
  s.perception_config = "true";  // a word YAML reads as a flag: written quoted
  s.perception_timing = TimingChoice::Asynchronous;
  s.state_source = StateSourceKind::Inekf;
  s.estimator_config = "estimation.yaml";
  s.sensor_config = "";
  s.out = "out/a";
  s.log_every = 3;
  s.map_log = "out/a/map";
  s.map_log_rate = 0.1;
  s.log_violations = true;
  return s;
}

TEST(RunSpec, WrittenAndReadBackEqual) {
  for (const RunSpec& s : {RunSpec{}, everyKeySet()}) {
    const std::string text = toYaml(s);
    const RunSpec back = parseRunSpec(text, "run spec 'r.yaml'");
    EXPECT_TRUE(back == s) << text;
    EXPECT_EQ(toYaml(back), text);
  }
  // Every key is written, and a default spec's text names each default.
  const std::string defaults = runSpecDefaults();
  for (const char* key : {"robot:", "scene: flat", "controller: stand", "duration: 10  # [s]",
                          "command: [[0, 0, 0, 0]]", "mpc_timing: default",
                          "state_source: ground_truth", "log_every: 10", "out: out/sim"}) {
    EXPECT_NE(defaults.find(key), std::string::npos) << key << " in\n" << defaults;
  }
  // A file gives only what differs; vy and yaw rate may be left out of a command entry.
  const RunSpec short_form = parseRunSpec(
      "scene: step20\ncontroller: cbfqp\ngait: trot\ncommand: [[0, 0.15]]\n", "run spec 'r.yaml'");
  EXPECT_EQ(short_form.scene, "step20");
  EXPECT_EQ(short_form.controller, ControllerKind::CbfQp);
  ASSERT_EQ(short_form.command.size(), 1u);
  EXPECT_EQ(short_form.command[0].command.v_x, 0.15);
  EXPECT_EQ(short_form.command[0].command.yaw_rate, 0.0);
  EXPECT_EQ(short_form.duration, 10.0);
}

TEST(RunSpec, ErrorsNameFileLineAndKey) {
  EXPECT_EQ(errorOf("scene: flat\nspeed: 3\n"),
            "run spec 'r.yaml': line 2: unknown key 'speed' (known: robot, scene, scene_file, "
            "inline_scene, scene_parameters, controller, duration, gait, command, drive_speed, "
            "drive_turn_speed, control_config, control, mpc_timing, integrator, terrain, "
            "lidar_config, perception_config, "
            "perception_timing, state_source, estimator_config, sensor_config, out, log_every, "
            "map_log, map_log_rate, log_violations)");
  EXPECT_EQ(errorOf("duration: 5\nduration: 6\n"),
            "run spec 'r.yaml': line 2: duration: given twice (first on line 1)");
  EXPECT_EQ(errorOf("\nduration: 0\n"),
            "run spec 'r.yaml': line 2: duration: 0 is outside "
            "[0.001, 3600]");
  EXPECT_EQ(errorOf("controller: fly\n"),
            "run spec 'r.yaml': line 1: controller: expected stand, drive, nmpc or cbfqp, got "
            "'fly'");
  EXPECT_EQ(errorOf("controller: nmpc\ncommand: [[0, 0.1], [0.5]]\n"),
            "run spec 'r.yaml': line 2: command[1]: expected [time, vx, vy, yaw_rate] (2 to 4 "
            "numbers)");
  EXPECT_EQ(errorOf("controller: nmpc\nduration: 5\ncommand: [[0, 0.1], [6, 0]]\n"),
            "run spec 'r.yaml': line 3: command: entry 1: time 6 s is not before the run's end "
            "(duration 5 s): the entry would never apply");
  EXPECT_EQ(errorOf("controller: nmpc\ncommand: [[0, 1.5]]\n"),
            "run spec 'r.yaml': line 2: command: entry 0: vx 1.5 outside [-1, 1] m/s");
  // Keys that apply to other controllers or terrains only.
  EXPECT_EQ(errorOf("controller: stand\ngait: trot\n"),
            "run spec 'r.yaml': line 2: gait: is used only by the nmpc and cbfqp controllers");
  EXPECT_EQ(errorOf("controller: cbfqp\n\nmpc_timing: deterministic\n"),
            "run spec 'r.yaml': line 3: mpc_timing: is used only by the nmpc controller");
  EXPECT_EQ(errorOf("controller: nmpc\nmap_log: m\n"),
            "run spec 'r.yaml': line 2: map_log: is used only with terrain perception");
  EXPECT_EQ(errorOf("controller: nmpc\nestimator_config: e.yaml\n"),
            "run spec 'r.yaml': line 2: estimator_config: is used only with state_source inekf "
            "(the state here is the simulator's ground truth)");
  EXPECT_EQ(errorOf("controller: cbfqp\ngait: static_walk\n"),
            "run spec 'r.yaml': line 2: gait: static_walk is not a gait of the cbfqp baseline "
            "(standing, rolling or trot)");
  EXPECT_EQ(errorOf("scene: step20\nscene_file: s.yaml\n"),
            "run spec 'r.yaml': line 2: scene_file: and scene exclude each other (the file names "
            "its scene)");
  EXPECT_EQ(errorOf("out:\n"), "run spec 'r.yaml': line 1: out: no value");
  EXPECT_EQ(errorOf("[1, 2]\n"), "run spec 'r.yaml': line 1: expected a mapping of key: value");
  // A spec made in code: the same checks, naming the key.
  RunSpec s;
  s.drive_speed = 0.3;
  s.controller = ControllerKind::Nmpc;
  try {
    checkRunSpec(s);
    ADD_FAILURE() << "no error";
  } catch (const RunSpecError& e) {
    EXPECT_EQ(e.key(), "drive_speed");
    EXPECT_STREQ(e.what(), "drive_speed: is used only by the drive controller");
  }
}

TEST(RunSpec, ControlSettingsInline) {
  RunSpec s;
  s.scene = "step20";
  s.controller = ControllerKind::Nmpc;
  s.gait = planning::GaitKind::Trot;
  s.control = control::ControlSettings{};
  s.control->mpc.period = 0.04;
  s.control->feedback.foot_kp = 300.0;
  s.control->ocp.horizon = 40;
  const std::string text = toYaml(s);
  EXPECT_NE(text.find("\ncontrol:\n  control_period: 0.001\n  mpc:\n"), std::string::npos) << text;
  const RunSpec back = parseRunSpec(text, "run spec 'r.yaml'");
  ASSERT_TRUE(back.control.has_value());
  EXPECT_EQ(back.control->mpc.period, 0.04);
  EXPECT_EQ(back.control->ocp.horizon, 40);
  EXPECT_TRUE(back == s);
  EXPECT_EQ(toYaml(back), text);
  // Without settings inline: null, and the defaults document the key.
  EXPECT_NE(toYaml(RunSpec{}).find("\ncontrol: null\n"), std::string::npos);
  EXPECT_NE(runSpecDefaults().find("control: null  # "), std::string::npos);
  // A file gives only the keys that differ from the library's defaults.
  const RunSpec given = parseRunSpec(
      "controller: nmpc\ncontrol:\n  mpc: {period: 0.04, latency: 0.02}\n", "run spec 'r.yaml'");
  ASSERT_TRUE(given.control.has_value());
  EXPECT_EQ(given.control->mpc.period, 0.04);
  EXPECT_EQ(given.control->feedback.foot_kp, control::ControlSettings{}.feedback.foot_kp);
  // Read over a spec (Python's assignments): the keys given replace values, the others stay.
  const RunSpec updated =
      parseRunSpec("control:\n  feedback: {foot_kp: 250}\n", "run spec 'r.yaml'", "", given);
  EXPECT_EQ(updated.control->mpc.period, 0.04);
  EXPECT_EQ(updated.control->feedback.foot_kp, 250.0);
  // The control settings' own checks, named inside the spec with their lines.
  EXPECT_EQ(errorOf("controller: nmpc\ncontrol:\n  mpc:\n    period: -1\n"),
            "run spec 'r.yaml': line 4: control.mpc.period: -1 is outside [0, 10]");
  EXPECT_EQ(
      errorOf("controller: nmpc\ncontrol:\n  mpcc: {}\n")
          .rfind("run spec 'r.yaml': line 3: unknown key 'control.mpcc' (known in control: ", 0),
      0u)
      << errorOf("controller: nmpc\ncontrol:\n  mpcc: {}\n");
  EXPECT_EQ(errorOf("controller: nmpc\ncontrol:\n  ocp: {horizon: 0}\n")
                .rfind("run spec 'r.yaml': line 3: control.ocp.horizon: ", 0),
            0u)
      << errorOf("controller: nmpc\ncontrol:\n  ocp: {horizon: 0}\n");
  EXPECT_EQ(errorOf("controller: nmpc\ncontrol:\n  mpc: {period: 0.01, latency: 0.02}\n"),
            "run spec 'r.yaml': line 3: control.mpc.latency: 0.02 is above mpc.period (0.01): in "
            "deterministic timing a solve takes at most a period");
  EXPECT_EQ(errorOf("controller: nmpc\ncontrol_config: c.yaml\ncontrol: {}\n"),
            "run spec 'r.yaml': line 3: control: and control_config exclude each other (give one)");
  // Made in code: checked as a file is.
  RunSpec bad = s;
  bad.control->mpc.latency = 0.05;
  try {
    checkRunSpec(bad);
    ADD_FAILURE() << "no error";
  } catch (const RunSpecError& e) {
    EXPECT_EQ(e.key(), "control");
    EXPECT_EQ(e.problem().rfind("control.mpc.latency: 0.05 is above mpc.period", 0), 0u)
        << e.what();
  }
  EXPECT_EQ(errorOf("controller: stand\ncontrol: {}\n"),
            "run spec 'r.yaml': line 2: control: is used only by the nmpc and cbfqp controllers");
}

TEST(RunSpec, SceneParametersCheckedAgainstTheScene) {
  const RunSpec s = parseRunSpec(
      "scene: step20\nscene_parameters:\n  step1_height: 0.15\n  friction: 0.7\n"
      "  start_x: 1.1\n",
      "run spec 'r.yaml'");
  ASSERT_EQ(s.scene_parameters.size(), 3u);
  EXPECT_EQ(s.scene_parameters[0].name, "step1_height");
  const SceneConfig scene = sceneOf(s);
  EXPECT_EQ(sceneNumber(scene, "step1_height"), 0.15);
  EXPECT_EQ(sceneNumber(scene, "friction"), 0.7);
  EXPECT_EQ(resolveScene(scene).solids[0].center.x(), 1.1 + 0.5 * 1.2);
  // Written and read back equal (a key path is written quoted).
  RunSpec paths = s;
  paths.scene_parameters.push_back({"boxes[0].size[1]", 2.5});
  EXPECT_TRUE(parseRunSpec(toYaml(paths), "run spec 'r.yaml'") == paths) << toYaml(paths);
  EXPECT_EQ(sceneNumber(sceneOf(paths), "boxes[0].size[1]"), 2.5);
  EXPECT_NE(toYaml(RunSpec{}).find("\nscene_parameters: {}\n"), std::string::npos);
  // A number the scene does not have, on its line, with the ones it has.
  EXPECT_EQ(
      errorOf("scene: step20\nscene_parameters:\n  step1_height: 0.1\n  hight: 0.2\n"),
      "run spec 'r.yaml': line 4: scene_parameters: 'hight' is not a number of scene step20 (its "
      "parameters and friction: friction, start_x, width, step1_height, step1_length; or a key "
      "path such as boxes[0].size[2])");
  EXPECT_EQ(
      errorOf("scene: flat\nscene_parameters: {step1_height: 0.1}\n")
          .rfind("run spec 'r.yaml': line 2: scene_parameters: 'step1_height' is not a number of "
                 "scene flat",
                 0),
      0u);
  // A value the scene's checks refuse.
  const std::string bad = errorOf("scene: step20\nscene_parameters:\n  friction: 9\n");
  EXPECT_EQ(
      bad.rfind("run spec 'r.yaml': line 3: scene_parameters: the scene with these numbers: ", 0),
      0u)
      << bad;
  EXPECT_NE(bad.find("friction"), std::string::npos) << bad;
  EXPECT_EQ(errorOf("scene_parameters: [1]\n"),
            "run spec 'r.yaml': line 1: scene_parameters: expected a mapping of name: number");
  EXPECT_EQ(errorOf("scene: step20\nscene_parameters: {width: 2, width: 3}\n"),
            "run spec 'r.yaml': line 2: scene_parameters.width: given twice (first on line 2)");
  EXPECT_EQ(errorOf("scene: step20\nscene_parameters: {width: wide}\n")
                .rfind("run spec 'r.yaml': line 2: scene_parameters.width: ", 0),
            0u);
}

// A scene given in code (the Python Simulation's SceneConfig) is the spec's inline_scene,
// `scene` its name: written whole, read back to the same numbers, checked as a scene file
// is under inline_scene.<key>, and the run built from the spec runs on it.
TEST(RunSpec, InlineSceneRunsAndReadsBackEqual) {
  SceneConfig scene = loadScene("step20");
  setSceneNumber(scene, "boxes[0].size[1]", 2.5);
  ASSERT_EQ(scene.parameters[0].name, "start_x");
  scene.parameters[0].value = 1.5;  // the block 0.5 m further
  RunSpec s;
  s.scene = "step20_moved";
  s.inline_scene = scene;
  s.scene_parameters = {{"step1_height", 0.1}};
  const std::string text = toYaml(s);
  EXPECT_NE(text.find("inline_scene:\n  parameters:\n    start_x: 1.5\n"), std::string::npos)
      << text;
  const RunSpec back = parseRunSpec(text, "run spec 'r.yaml'");
  EXPECT_TRUE(back == s) << text;
  EXPECT_EQ(toYaml(back), text);
  ASSERT_TRUE(back.inline_scene.has_value());
  EXPECT_EQ(back.inline_scene->name, "step20_moved");
  RunSpec other = s;
  setSceneNumber(*other.inline_scene, "friction", 0.5);
  EXPECT_FALSE(other == s);
  // The run's scene: the inline one with the spec's numbers over it, named by `scene`.
  const SceneConfig ran = sceneOf(back);
  EXPECT_EQ(ran.name, "step20_moved");
  EXPECT_DOUBLE_EQ(sceneNumber(ran, "start_x"), 1.5);
  EXPECT_DOUBLE_EQ(sceneNumber(ran, "step1_height"), 0.1);
  EXPECT_DOUBLE_EQ(sceneNumber(ran, "boxes[0].size[1]"), 2.5);
  EXPECT_EQ(terrainHeight(ran, 1.2, 0.0), 0.0);  // step20's block starts at 1 m
  EXPECT_NEAR(terrainHeight(ran, 1.6, 1.2), 0.1, 1e-12);
  const BuiltRun run = buildRun(back);
  EXPECT_EQ(run.scene.name, "step20_moved");
  EXPECT_NEAR(terrainHeight(run.scene, 1.6, 1.2), 0.1, 1e-12);
  // Errors: the scene's own, named under inline_scene with the spec's line. Each case: the
  // spec's text with `from` replaced by `to`, and a part of its message.
  const struct {
    const char* from;
    const char* to;
    const char* message;
  } cases[] = {
      {"    start_x: 1.5", "    start_x: [1]",
       "line 6: inline_scene.parameters.start_x: expected a number, got a list"},
      {"inline_scene:\n", "inline_scene:\n  base: flat\n",
       "inline_scene.base: not in an inline scene"},
      {"inline_scene:\n", "inline_scene:\n  walls: 1\n", "unknown key 'inline_scene.walls'"},
      {"    step1_height: 0.2", "    step1_height: -1", "inline_scene: line "},
      {"scene_file: \"\"", "scene_file: a.yaml", "inline_scene: and scene_file exclude each other"},
      {"  step1_height: 0.1", "  height: 0.1", "'height' is not a number of scene step20_moved"},
      {text.c_str(), "inline_scene: 3\n", "inline_scene: expected a mapping"},
  };
  for (const auto& c : cases) {
    std::string t = text;
    t.replace(t.find(c.from), std::string(c.from).size(), c.to);
    const std::string error = errorOf(t);
    EXPECT_NE(error.find(c.message), std::string::npos) << error;
  }
}

TEST(RunSpec, PathsRelativeToTheFileAndNamesKept) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "rollstep_run_spec_test";
  fs::create_directories(dir);
  const fs::path file = dir / "run.yaml";
  {
    std::ofstream out(file);
    out << "robot: tachyon3\nscene: step20\ncontroller: nmpc\ncontrol_config: c/climb.yaml\n"
           "state_source: inekf\nestimator_config: /abs/e.yaml\nout: o\n";
  }
  const RunSpec s = loadRunSpec(file.string());
  EXPECT_EQ(s.robot, "tachyon3");  // names stay names
  EXPECT_EQ(s.scene, "step20");
  EXPECT_EQ(s.control_config, (dir / "c/climb.yaml").string());
  EXPECT_EQ(s.estimator_config, "/abs/e.yaml");
  EXPECT_EQ(s.out, (dir / "o").string());
  // Written with absolute paths, the spec reads back equal from anywhere.
  const RunSpec absolute = withAbsolutePaths(s);
  EXPECT_TRUE(parseRunSpec(toYaml(absolute), "x", "/elsewhere") == absolute);
  fs::remove_all(dir);
}

TEST(RunSpec, BuildRefusesWhatDoesNotFitTheRobot) {
  RunSpec s;
  s.controller = ControllerKind::Drive;
  s.drive_speed = 1.5;
  s.drive_turn_speed = 0.9;
  try {
    buildRun(s);
    ADD_FAILURE() << "no error";
  } catch (const RunSpecError& e) {
    EXPECT_EQ(e.key(), "drive_speed");
    EXPECT_NE(std::string(e.what()).find("needs a wheel surface speed of 2.4 m/s"),
              std::string::npos)
        << e.what();
  }
  // The cbfqp controller's control file must give the baseline's tuning, itself or through
  // a file it extends.
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "rollstep_run_spec_baseline_test";
  fs::create_directories(dir);
  {
    std::ofstream(dir / "nmpc_only.yaml") << "mpc: {period: 0.02}\n";
    std::ofstream(dir / "extends.yaml")
        << "extends: " << projectConfigFile("baseline.yaml") << "\ncbf_qp: {damping: 1e-5}\n";
  }
  s = RunSpec{};
  s.controller = ControllerKind::CbfQp;
  s.scene = "step20";
  s.control_config = (dir / "nmpc_only.yaml").string();
  try {
    buildRun(s);
    ADD_FAILURE() << "no error";
  } catch (const RunSpecError& e) {
    EXPECT_EQ(e.key(), "control_config");
    EXPECT_NE(e.problem().find("has no baseline: section"), std::string::npos) << e.what();
  }
  s.control_config = (dir / "extends.yaml").string();
  EXPECT_NE(buildRun(s).cbfqp, nullptr);
  fs::remove_all(dir);
  // A stand run builds: the plant at the scene's start, the nominal posture.
  s = RunSpec{};
  const BuiltRun run = buildRun(s);
  EXPECT_EQ(run.scene.name, "flat");
  EXPECT_EQ(run.nmpc, nullptr);
  EXPECT_EQ(run.perception(), nullptr);
  EXPECT_NE(run.controller_text.find("stand"), std::string::npos);
}

}  // namespace
}  // namespace rollstep::sim
