// `rollstep view DIR`: the replay page of a `rollstep sim` output folder, DIR/replay.html
// (with its script DIR/replay.js): opens from disk in a browser, no server (docs/REPLAY.md).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "cli_util.hpp"
#include "commands.hpp"
#include "experiments/replay.hpp"

namespace rollstep::apps {

void registerViewCommand(CLI::App& app) {
  auto dir = std::make_shared<std::string>();
  auto map_dir = std::make_shared<std::string>();
  CLI::App* cmd = app.add_subcommand(
      "view",
      "Write the interactive 3D replay of a `rollstep sim` output folder: DIR/replay.html "
      "(open it from disk; no server, no network) and its script DIR/replay.js.");
  cmd->footer(
      "The page shows the robot drawn from its own model file, the terrain, the contact "
      "forces, the foothold regions and the MPC's plan in use at the slider's time, with "
      "plots of the main signals (docs/REPLAY.md). It reads DIR/replay.json and DIR/log.csv "
      "(and DIR/plan.csv.gz for --controller nmpc), written by `rollstep sim`, and the map log in "
      "DIR/map/ if there is one (--log-map DIR/map), or the one --map names.");
  cmd->add_option("DIR", *dir, "A `rollstep sim --out` folder")->required()->check(kNotEmpty);
  cmd->add_option("--map", *map_dir,
                  "The run's map log when it is not DIR/map (the folder given to rollstep sim "
                  "--log-map): the page then shows the elevation map and the foothold regions "
                  "of each snapshot")
      ->check(kNotEmpty);
  cmd->final_callback([dir, map_dir] {
    namespace fs = std::filesystem;
    std::error_code ec;
    if (!fs::is_directory(*dir, ec)) {
      throw CLI::ValidationError("DIR", "'" + *dir + "' is not a directory");
    }
    if (!map_dir->empty() && !fs::is_directory(*map_dir, ec)) {
      throw CLI::ValidationError("--map", "'" + *map_dir + "' is not a directory");
    }
    const std::string page = (fs::path(*dir) / "replay.html").string();
    experiments::writeReplayPage(
        *dir, page, fs::absolute(*dir).lexically_normal().filename().string(), *map_dir);
    std::printf("rollstep view: %s (open it in a browser)\n", page.c_str());
  });
}

}  // namespace rollstep::apps
