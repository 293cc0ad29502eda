#pragma once
// A robot description loaded: the centroidal robot of its URDF and its nominal posture, what
// both the MPC's problem (CentroidalOcp) and the 1 kHz side (the control pipelines) are built
// from; and the contact planner made from it with the OCP settings (makeContactPlanner), so
// that the real-time side gets its planner without building a problem.
#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "rollstep/centroidal/ocp_settings.hpp"
#include "rollstep/centroidal/robot.hpp"
#include "rollstep/model/data.hpp"
#include "rollstep/planning/contact_planner.hpp"
#include "rollstep/planning/terrain.hpp"

namespace rollstep::centroidal {

struct LoadedRobot {
  /// What was loaded (its nominal_joint_positions, servo_stiffness, contact_frames and gait
  /// groups are the robot's; checked against the URDF).
  RobotOcpDescription description;
  std::shared_ptr<const CentroidalRobot> robot;
  /// The feet's body-frame (x, y) and the base height above the ground at the nominal
  /// posture (from the URDF and the contact offset).
  planning::NominalStance stance;
};

/// Loads the URDF of `description` and checks the description against it (frames, one
/// nominal position and servo stiffness per joint). Throws std::invalid_argument /
/// std::runtime_error naming what is wrong.
LoadedRobot loadRobot(const RobotOcpDescription& description);

/// The contact planner's settings in the OCP settings (horizon N dt, gait timing, swings,
/// footholds, base height, edge holds, anchors, late touch-downs).
planning::ContactPlannerSettings contactPlannerSettings(const OcpSettings& settings);

/// The contact planner of `robot` walking `gait` on `terrain` with the OCP settings.
/// `region_edge_capacity`: ContactPlanner's. Throws std::invalid_argument when the robot
/// description gives no groups for the gait.
std::unique_ptr<planning::ContactPlanner> makeContactPlanner(const LoadedRobot& robot,
                                                             const OcpSettings& settings,
                                                             planning::TerrainModel terrain,
                                                             planning::GaitKind gait,
                                                             int region_edge_capacity = 0);

/// World positions (3 x nc) of the contact frames at the configuration of state x (its
/// first nq entries), into `out` (sized 3 x nc), with `data` (of robot's model) as
/// workspace: what the contact planner's measured calls take. False, and `out` all NaN, for
/// an x of the wrong size or with a non-finite entry. Never allocates.
bool contactPositionsOfState(const CentroidalRobot& robot, model::Data& data,
                             const Eigen::VectorXd& x, Eigen::Matrix3Xd& out) noexcept;

}  // namespace rollstep::centroidal
