#pragma once
// The replay of a run: an interactive 3D page (file://, no server) drawn from the run's own
// outputs (docs/REPLAY.md). `rollstep sim` writes the static part, replay.json (the plant's
// MuJoCo model as drawn: bodies, joints, geoms and meshes of the robot from its own file and
// the terrain; the foothold regions), beside log.csv and, for nmpc, plan.csv.gz (the MPC's plans
// in use). writeReplayPage packs them into one HTML page beside a copy of the page's script
// (three.js and uPlot bundled at build time from pinned npm packages).
#include <string>

#include "rollstep/planning/terrain.hpp"
#include "rollstep/sim/plant.hpp"

namespace rollstep::experiments {

/// replay.json of a run on `plant`: its model as drawn and `regions` (the foothold regions in
/// use at the start; `regions_source` says where they come from).
std::string replayModelJson(const sim::Plant& plant, const planning::TerrainModel& regions,
                            const std::string& regions_source);

/// The page's script: $ROLLSTEP_REPLAY_SCRIPT, else the build's bundle.
std::string replayScriptPath();

/// Writes `page` (an .html file) replaying the `rollstep sim` output folder `run_dir` (its
/// replay.json and log.csv, plan.csv.gz (or an older run's plan.csv) when present) and copies the
/// page's script beside it (replay.js). The page and the script are written complete or not at all.
/// Throws std::runtime_error naming the file for a missing or malformed input or a missing script.
/// `map_dir`: the run's map log (rollstep sim --log-map); empty = run_dir/map if it exists.
void writeReplayPage(const std::string& run_dir, const std::string& page, const std::string& title,
                     const std::string& map_dir = "");

}  // namespace rollstep::experiments
