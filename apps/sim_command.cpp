// `rollstep sim`: the plant demo. Loads a scene with the Tachyon 3 MJCF, runs a simple
// controller (stand: hold the nominal posture; drive: hold it and roll on the drive
// wheels) for a duration, writes DIR/log.csv and DIR/summary.txt, prints the summary.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include "commands.hpp"
#include "rollstep/sim/plant.hpp"
#include "rollstep/sim/scenario.hpp"
#include "rollstep/sim/scene.hpp"
#include "rollstep/sim/simple_controllers.hpp"

namespace rollstep::apps {

namespace {

struct SimOptions {
  std::string scene = "flat";
  std::string scene_config;
  std::string controller = "stand";
  double duration = 10.0;
  std::string out = "out/sim";
  double speed = 0.5;
  double turn_speed = 0.0;
  int log_every = 10;
  std::string robot;
};

void runSim(const SimOptions& o, bool scene_given) {
  sim::SceneConfig scene;
  if (!o.scene_config.empty()) scene = sim::loadSceneConfig(o.scene_config);
  if (scene_given || o.scene_config.empty()) scene.kind = sim::sceneKindFromString(o.scene);

  sim::PlantOptions plant_options;
  plant_options.robot_file = o.robot;
  sim::Plant plant(scene, plant_options);

  std::unique_ptr<sim::Controller> controller;
  std::string controller_text;
  if (o.controller == "stand") {
    controller = std::make_unique<sim::StandController>(plant.nominalCommand());
    controller_text = "stand (nominal posture, wheels at rest)";
  } else {
    sim::DriveController::Params p;
    p.speed = o.speed;
    p.turn_speed = o.turn_speed;
    controller =
        std::make_unique<sim::DriveController>(plant.nominalCommand(), plant.wheelRadius(0), p);
    std::ostringstream s;
    s << "drive (nominal posture, wheel surface speed " << o.speed << " m/s, turn " << o.turn_speed
      << " m/s)";
    controller_text = s.str();
  }

  std::filesystem::create_directories(o.out);
  const std::string log_path = (std::filesystem::path(o.out) / "log.csv").string();
  const std::string summary_path = (std::filesystem::path(o.out) / "summary.txt").string();
  sim::RunSummary s;
  {
    sim::CsvLog log(log_path);
    s = sim::runScenario(plant, *controller, o.duration, &log, o.log_every);
  }

  const double deg = 180.0 / M_PI;
  char text[2048];
  std::snprintf(
      text, sizeof text,
      "rollstep sim: scene %s, controller %s\n"
      "  robot      %s\n"
      "  simulated  %.3f s at %.0f Hz in %.3f s wall time (%.1fx real time)\n"
      "  base       start (%.3f, %.3f, %.3f) m -> end (%.3f, %.3f, %.3f) m, distance %.3f m, "
      "yaw change %.2f deg\n"
      "  height     min %.4f m, max %.4f m; mean forward speed %.3f m/s\n"
      "  contacts   all six wheels on the ground %.1f %% of the time\n"
      "  MuJoCo     %d warnings\n"
      "  outputs    %s (CSV, every %d ms), %s\n",
      std::string(sim::toString(scene.kind)).c_str(), controller_text.c_str(),
      plant.robotFile().c_str(), s.sim_time, 1.0 / plant.controlPeriod(), s.wall_time,
      s.real_time_factor, s.start_position.x(), s.start_position.y(), s.start_position.z(),
      s.end_position.x(), s.end_position.y(), s.end_position.z(),
      (s.end_position - s.start_position).head<2>().norm(), s.yaw_change * deg, s.min_base_height,
      s.max_base_height, s.mean_forward_speed, 100.0 * s.all_feet_contact_fraction, s.warnings,
      log_path.c_str(), static_cast<int>(std::lround(o.log_every * plant.controlPeriod() * 1000.0)),
      summary_path.c_str());
  std::fputs(text, stdout);
  if (std::FILE* f = std::fopen(summary_path.c_str(), "w")) {
    std::fputs(text, f);
    std::fclose(f);
  } else {
    throw std::runtime_error("cannot write " + summary_path);
  }
}

}  // namespace

void registerSimCommand(CLI::App& app) {
  auto options = std::make_shared<SimOptions>();
  CLI::App* cmd = app.add_subcommand(
      "sim",
      "Run the MuJoCo plant (Tachyon 3 in a scene) with a simple controller; write a CSV "
      "log (time, base pose and twist, joint positions, commands, contacts) and print a "
      "summary.");
  CLI::Option* scene =
      cmd->add_option("--scene", options->scene,
                      "Scene: flat, step20 (0.20 m block 1.0 m ahead) or stairs2 (0.20 m + "
                      "0.165 m steps). Overrides the scene key of --scene-config.")
          ->check(CLI::IsMember({"flat", "step20", "stairs2"}))
          ->capture_default_str();
  cmd->add_option("--scene-config", options->scene_config,
                  "YAML file of scene parameters (keys: scene, friction, start_x, width, "
                  "step1_height, step1_length, step2_height, step2_length; unknown keys "
                  "are errors)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--controller", options->controller,
                  "stand: hold the nominal posture; drive: hold it and roll on the four "
                  "drive wheels at --speed (turning with --turn-speed)")
      ->check(CLI::IsMember({"stand", "drive"}))
      ->capture_default_str();
  cmd->add_option("--duration", options->duration, "Simulated time [s]")
      ->check(CLI::Range(0.001, 3600.0))
      ->capture_default_str();
  cmd->add_option("--out", options->out, "Output directory (created if needed)")
      ->capture_default_str();
  cmd->add_option("--speed", options->speed,
                  "drive: forward wheel surface speed [m/s], ramped at 1 m/s^2")
      ->check(CLI::Range(-1.8, 1.8))
      ->capture_default_str();
  cmd->add_option("--turn-speed", options->turn_speed,
                  "drive: right minus left wheel surface speed, halved [m/s] (turn in place "
                  "with --speed 0)")
      ->check(CLI::Range(-1.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--log-every", options->log_every,
                  "Write a log row every N control periods (1 ms each)")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  cmd->add_option("--robot", options->robot,
                  "Robot MJCF (default: robots/tachyon3/tachyon3.xml of the source tree, "
                  "or $ROLLSTEP_ROBOTS_DIR/tachyon3/tachyon3.xml)");
  cmd->final_callback([options, scene] { runSim(*options, scene->count() > 0); });
}

}  // namespace rollstep::apps
