#pragma once
// A run spec (run_spec.hpp) built: the scene, the robot folder, the plant and the
// controller with its terrain source (the scene's regions or perception in closed loop) and
// state source (ground truth or the state estimator). `rollstep sim` and the Python
// Simulation build every run here, so that the two run the same thing for the same spec.
#include <memory>
#include <string>

#include "rollstep/control/control_settings.hpp"
#include "rollstep/planning/terrain.hpp"
#include "rollstep/sim/cbfqp_controller.hpp"
#include "rollstep/sim/nmpc_controller.hpp"
#include "rollstep/sim/plant.hpp"
#include "rollstep/sim/robot_folder.hpp"
#include "rollstep/sim/run_spec.hpp"
#include "rollstep/sim/scenario.hpp"
#include "rollstep/sim/scene.hpp"

namespace rollstep::sim {

/// plan.csv.gz keeps every 5th node of each plan (and the last): 20 of the 100 nodes, enough
/// to draw the planned paths.
inline constexpr int kPlanNodeStride = 5;

struct BuiltRun {
  RunSpec spec;
  SceneConfig scene;
  RobotFolder robot;
  std::unique_ptr<Plant> plant;
  std::unique_ptr<Controller> controller;  ///< destroyed before the plant it drives
  NmpcController* nmpc = nullptr;          ///< the controller, when it is one
  CbfQpController* cbfqp = nullptr;
  /// What runs, for the summary: "nmpc (gait trot, command ...; terrain ...)".
  std::string controller_text;
  /// The foothold regions in use at the start (the replay page draws them) and whence.
  planning::TerrainModel start_regions;
  std::string start_regions_source = "none (this controller plans no footholds)";
  /// The perception of the controller, when it has one (nullptr otherwise).
  OnlinePerception* perception() const;
};

/// Builds the run of `spec` (checkRunSpec first): loads the scene, the robot folder (its
/// files cross-checked), the plant with its sensors, and the controller; the NMPC's first
/// solve and perception's first terrain happen here. Nothing is written (the map log's
/// files are opened by the caller: OnlinePerception::openLog). Errors: RunSpecError naming
/// a key for values that do not fit this robot (drive speeds, a control file without a
/// baseline section), InputError or std::runtime_error naming a file.
BuiltRun buildRun(const RunSpec& spec);

/// `name` in $ROLLSTEP_CONFIG_DIR if that environment variable is set (an installed
/// rollstep), else in the source tree's config/.
std::string projectConfigFile(const std::string& name);

}  // namespace rollstep::sim
