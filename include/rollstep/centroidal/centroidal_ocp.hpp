#pragma once
// The whole full-centroidal OCP of the paper, composed once from a robot description, the
// OCP settings, a terrain model and a gait: the model and its node precomputation, the
// dynamics (explicit Euler on SE(3) x R^(nj+6)), every equality, inequality and cost of
// DESIGN.md section 3. The planning inputs they read (gait schedule, base reference, foot
// references) come from its contact planner (planning::ContactPlanner, contactPlanner()).
// What the `rollstep plan` command and the MPC runner build on.
//
//   costs        base_velocity (v_b - v_ref), state (x (-) x_ref(t), running and terminal),
//                input (u - u_ref(t))
//   equalities   swing_force, stance_velocity (z, drive-wheel lateral; side-by-side rule),
//                swing_height (spline z_ref, Kp)
//   inequalities torque (static joint torque limits), friction (pyramid per stance foot),
//                stance_region, swing_region (state-only: soft when configured),
//                joint positions (state bounds, soft when configured), joint velocities
//                (input bounds)
//
// Construction allocates and may throw (std::invalid_argument / std::runtime_error naming
// what is wrong); reset() and advance() do not allocate. Not copyable or movable: the
// terms point at the planner's references.
#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "rollstep/centroidal/loaded_robot.hpp"
#include "rollstep/centroidal/ocp_settings.hpp"
#include "rollstep/centroidal/precomputation.hpp"
#include "rollstep/centroidal/robot.hpp"
#include "rollstep/lie/se3.hpp"
#include "rollstep/model/data.hpp"
#include "rollstep/ocp/problem.hpp"
#include "rollstep/planning/base_reference.hpp"
#include "rollstep/planning/contact_planner.hpp"
#include "rollstep/planning/foot_reference.hpp"
#include "rollstep/planning/gait.hpp"
#include "rollstep/planning/gait_clock.hpp"
#include "rollstep/planning/terrain.hpp"

namespace rollstep::centroidal {

/// "standing", "rolling", "trot", "static_walk" <-> GaitKind (Custom has no name here).
planning::GaitKind gaitKindFromString(const std::string& name);
const char* toString(planning::GaitKind kind);

/// The largest violation of each constraint group of a trajectory (xs: N+1 states, us: N
/// inputs), evaluated afresh: "dynamics" (defects, tangent inf-norm), every equality by
/// name (|e|), every inequality by name (max(0, -g)), "state_bounds" and "input_bounds".
struct ConstraintViolation {
  std::string group;
  double value = 0.0;  ///< >= 0; 0 when satisfied
  int node = -1;       ///< where the largest one is (-1: none)
  /// Which row of the group there (Residual::rowName: "LF_contact: edge 2 of region 5";
  /// for dynamics and state bounds the tangent coordinate's name, for input bounds the
  /// input's: OptimalControlProblem::tangentName / inputName, "MF_knee position",
  /// "LF_hip velocity"; "tangent 9" / "input 3" without names); empty: none.
  std::string row;
};
std::vector<ConstraintViolation> constraintViolations(const ocp::OptimalControlProblem& problem,
                                                      const std::vector<Eigen::VectorXd>& xs,
                                                      const std::vector<Eigen::VectorXd>& us);

class CentroidalOcp {
 public:
  /// Loads the URDF of `robot`, checks the description against it (frames, joint count of
  /// the nominal posture, gait groups the gait needs) and composes the problem.
  /// `region_edge_capacity`: the most edges a region of any terrain given later
  /// (swapTerrain) may have; 0 = the most of `terrain` (rows are sized for it).
  CentroidalOcp(const RobotOcpDescription& robot, const OcpSettings& settings,
                planning::TerrainModel terrain, planning::GaitKind gait,
                int region_edge_capacity = 0);
  CentroidalOcp(const CentroidalOcp&) = delete;
  CentroidalOcp& operator=(const CentroidalOcp&) = delete;

  /// Starts the references at t0 from `start` (its x, y and yaw) with `command`
  /// (ContactPlanner::reset), and fills the mode schedule for the horizon starting at t0.
  void reset(double t0, const lie::SE3& start, const planning::BaseVelocityCommand& command);
  /// Same with a command schedule (planning::BaseReference::reset; allocates when longer
  /// than any before).
  void resetSchedule(double t0, const lie::SE3& start,
                     const std::vector<planning::TimedBaseCommand>& schedule);
  /// Moves the horizon to start at t0 (same references): the problem's initial time and
  /// its mode schedule, planned by the contact planner (ContactPlanner::planSchedule: the
  /// gait through its clock, with the edge holds of settings step_down_max_hold and
  /// step_up_max_hold over the horizon).
  void advance(double t0);
  /// ContactPlanner::anchorStanceFeet and landLateFeet at the feet of state x (the measured
  /// state): a non-finite or wrongly sized x changes nothing. Never allocate.
  void anchorStanceFeet(const ocp::ModeSchedule& schedule, double t,
                        const Eigen::VectorXd& x) noexcept;
  int landLateFeet(ocp::ModeSchedule& schedule, double t, const Eigen::VectorXd& x) noexcept;
  /// The contact planner's (shorthands of contactPlanner()'s).
  bool followRobot(double t, const lie::SE3& base_pose, double max_distance, double max_yaw,
                   double max_lateral = 0.0) {
    return planner_->followRobot(t, base_pose, max_distance, max_yaw, max_lateral);
  }
  bool acceptsTerrain(const planning::TerrainModel& terrain) const noexcept {
    return planner_->acceptsTerrain(terrain);
  }
  bool swapTerrain(planning::TerrainModel& terrain) noexcept {
    return planner_->swapTerrain(terrain);
  }
  int regionEdgeCapacity() const { return planner_->regionEdgeCapacity(); }
  const planning::GaitClock& gaitClock() const { return planner_->gaitClock(); }

  /// The nominal standing state at the planar pose (x, y, yaw): base at the nominal height
  /// above the terrain under the feet, level, nominal joints, zero momentum.
  Eigen::VectorXd standingState(double x, double y, double yaw) const;
  /// A cold-start guess over the horizon: the standing state along the base reference at
  /// each node time, and u_ref (zero joint velocities, stance feet sharing the weight).
  void initialGuess(std::vector<Eigen::VectorXd>& xs, std::vector<Eigen::VectorXd>& us) const;
  /// World positions (3 x nc) of the contact frames at state x.
  Eigen::Matrix3Xd footPositions(const Eigen::VectorXd& x) const;
  /// World linear velocities (3 x nc) of the contact frames at state x and input u.
  Eigen::Matrix3Xd footVelocities(const Eigen::VectorXd& x, const Eigen::VectorXd& u) const;
  /// Base twist v_b (local) at state x and input u.
  lie::Vector6d baseTwist(const Eigen::VectorXd& x, const Eigen::VectorXd& u) const;
  /// Static joint torques S (g - J^T f) at x, u (forces at the contact points).
  Eigen::VectorXd jointTorques(const Eigen::VectorXd& x, const Eigen::VectorXd& u) const;

  const std::shared_ptr<ocp::OptimalControlProblem>& problem() const { return problem_; }
  /// The planner the problem's schedule and references come from.
  planning::ContactPlanner& contactPlanner() { return *planner_; }
  const planning::ContactPlanner& contactPlanner() const { return *planner_; }
  const LoadedRobot& loadedRobot() const { return loaded_; }
  const CentroidalRobot& robot() const { return *loaded_.robot; }
  const std::shared_ptr<const CentroidalRobot>& robotPtr() const { return loaded_.robot; }
  const CentroidalPrecomputation& precomputation() const { return *pre_; }
  const OcpSettings& settings() const { return settings_; }
  const planning::TerrainModel& terrain() const { return planner_->terrain(); }
  const planning::BaseReference& baseReference() const { return planner_->baseReference(); }
  const planning::FootReferencePlanner& footPlanner() const { return planner_->footPlanner(); }
  const planning::Gait& gait() const { return planner_->gait(); }
  const Eigen::VectorXd& nominalJointPositions() const {
    return loaded_.description.nominal_joint_positions;
  }
  /// Contact frame names in mode-mask order.
  const std::vector<std::string>& contactNames() const {
    return loaded_.description.contact_frames;
  }

 private:
  OcpSettings settings_;
  LoadedRobot loaded_;
  std::shared_ptr<const CentroidalPrecomputation> pre_;
  // Shared: the terms hold its references (aliasing pointers) and keep it alive.
  std::shared_ptr<planning::ContactPlanner> planner_;
  std::shared_ptr<ocp::OptimalControlProblem> problem_;
  std::unique_ptr<CentroidalCache> scratch_;  // for the non-real-time helpers above
  // anchorStanceFeet, landLateFeet: placements only (the node quantities' gravity and
  // centroidal derivative passes are not needed for foot positions).
  std::unique_ptr<model::Data> feet_data_;
  Eigen::Matrix3Xd feet_;
};

}  // namespace rollstep::centroidal
