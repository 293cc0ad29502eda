#pragma once
// The whole full-centroidal OCP of the paper, composed once from a robot description, the
// OCP settings, a terrain model and a gait: the model and its node precomputation, the
// dynamics (explicit Euler on SE(3) x R^(nj+6)), every equality, inequality and cost of
// DESIGN.md section 3, and the planning inputs they read (gait schedule, base reference,
// foot references). What the `rollstep plan` command and the control pipeline build on.
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
// planning objects point at the terrain and at each other.
#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "rollstep/centroidal/ocp_settings.hpp"
#include "rollstep/centroidal/precomputation.hpp"
#include "rollstep/centroidal/robot.hpp"
#include "rollstep/lie/se3.hpp"
#include "rollstep/model/data.hpp"
#include "rollstep/ocp/problem.hpp"
#include "rollstep/planning/base_reference.hpp"
#include "rollstep/planning/contact_schedule.hpp"
#include "rollstep/planning/edge_holds.hpp"
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

  /// Starts the references at t0 from `start` (its x, y and yaw) with `command`, and fills
  /// the mode schedule for the horizon starting at t0.
  void reset(double t0, const lie::SE3& start, const planning::BaseVelocityCommand& command);
  /// Same with a command schedule (planning::BaseReference::reset; allocates when longer
  /// than any before).
  void resetSchedule(double t0, const lie::SE3& start,
                     const std::vector<planning::TimedBaseCommand>& schedule);
  /// Moves the horizon to start at t0 (same references): the problem's initial time and
  /// mode schedule, the gait read through gaitClock() after planning its edge holds
  /// (settings step_down_max_hold, step_up_max_hold; planning/edge_holds.hpp) over the
  /// horizon.
  void advance(double t0);
  /// The gait's clock the schedule is filled with (no holds unless step_down_max_hold or
  /// step_up_max_hold > 0).
  const planning::GaitClock& gaitClock() const { return clock_; }
  /// Takes another instance's clock (the real-time side takes the plan's). Never allocates.
  void setGaitClock(const planning::GaitClock& clock) noexcept { clock_ = clock; }
  /// Keeps the base reference within a leash of the robot's base pose at t (max_distance
  /// [m], max_yaw [rad], 0: free; planning::BaseReference::follow): every term and planner
  /// reads the moved reference from then on. Never allocates; returns whether it moved.
  bool followRobot(double t, const lie::SE3& base_pose, double max_distance, double max_yaw);
  /// Gives the base reference the planar correction of another copy of it (the MPC's, so
  /// that the real-time side plans footholds on the reference the solution was solved on).
  /// Refuses (false) a non-finite one.
  bool setReferenceCorrection(const lie::SE3& correction) noexcept;
  /// Whether `terrain` can replace the current one: non-empty when the current one is (the
  /// region constraints exist only then), empty when it is empty, regions of at most
  /// regionEdgeCapacity() edges. Reads only what is fixed at construction: may be called
  /// from another thread than the one that swaps.
  bool acceptsTerrain(const planning::TerrainModel& terrain) const noexcept;
  /// Replaces the terrain every term and planner reads by `terrain`'s regions (exchanged:
  /// `terrain` receives the old ones), if acceptsTerrain(terrain); else changes nothing and
  /// returns false. Never allocates: the hand-over of a new (perceived) terrain between
  /// solves.
  bool swapTerrain(planning::TerrainModel& terrain) noexcept;
  /// Anchors every foot in stance at t under `schedule` at its position in state x (the
  /// measured state): that stance's region and height, and the lift-off end of the swing
  /// after it, are taken where the foot stands (planning::FootReferencePlanner::
  /// anchorStance), not at its nominal foothold (settings anchor_stance_feet). With
  /// latch_touchdowns, every foot in swing at t keeps the touch-down region chosen at the
  /// first call in that swing (FootReferencePlanner::latchTouchdown). A non-finite or
  /// wrongly sized x changes nothing. Never allocates.
  void anchorStanceFeet(const ocp::ModeSchedule& schedule, double t,
                        const Eigen::VectorXd& x) noexcept;
  /// Late touch-downs (settings late_touchdown_*; planning::FootReferencePlanner's file
  /// comment): every foot whose stance under `schedule` began before t (at most
  /// late_touchdown_max_delay of its swing ago) while its contact point in state x (the
  /// measured state) is still more than late_touchdown_tolerance above that stance's
  /// surface gets its stance start moved to a landing time in `schedule`
  /// (planning::delayTouchdown: the schedule given to the problem, or a controller's copy
  /// of it), with a descent from where it is to the surface until then (planned at the
  /// first call that finds the stance late and kept; a foot still up at its landing time
  /// gets a new one from where it is). Once a foot of a
  /// stance is seen on its surface (or the delay runs out) that stance is settled and is
  /// never delayed again. Call after advance() / anchorStanceFeet() on a freshly filled
  /// schedule, once per solve or tick. Returns the mask of the feet delayed now. A
  /// non-finite or wrongly sized x delays nothing. Never allocates.
  int landLateFeet(ocp::ModeSchedule& schedule, double t, const Eigen::VectorXd& x) noexcept;
  int regionEdgeCapacity() const { return region_edge_capacity_; }

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
  const CentroidalRobot& robot() const { return *robot_; }
  const std::shared_ptr<const CentroidalRobot>& robotPtr() const { return robot_; }
  const CentroidalPrecomputation& precomputation() const { return *pre_; }
  const OcpSettings& settings() const { return settings_; }
  const planning::TerrainModel& terrain() const { return *terrain_; }
  const planning::BaseReference& baseReference() const { return *base_; }
  const planning::FootReferencePlanner& footPlanner() const { return *feet_; }
  const planning::Gait& gait() const { return scheduler_->gait(); }
  /// Body-frame (x, y) of each foot at the nominal posture, and the base height above
  /// the ground there [m] (from the URDF and the contact offset).
  const std::vector<Eigen::Vector2d>& nominalFeet() const { return nominal_feet_; }
  double nominalHeight() const { return nominal_height_; }
  const Eigen::VectorXd& nominalJointPositions() const { return q_joint_ref_; }
  /// The joints' servo stiffness of the robot description (nj), empty if not given.
  const Eigen::VectorXd& servoStiffness() const { return servo_stiffness_; }
  /// Contact frame names in mode-mask order.
  const std::vector<std::string>& contactNames() const { return contact_names_; }

 private:
  OcpSettings settings_;
  std::shared_ptr<const CentroidalRobot> robot_;
  std::shared_ptr<const CentroidalPrecomputation> pre_;
  std::unique_ptr<planning::TerrainModel> terrain_;
  std::shared_ptr<planning::BaseReference> base_;
  std::shared_ptr<planning::FootReferencePlanner> feet_;
  std::unique_ptr<planning::GaitScheduler> scheduler_;
  planning::GaitClock clock_;
  planning::EdgeHoldConfig hold_config_;
  std::shared_ptr<ocp::OptimalControlProblem> problem_;
  std::vector<Eigen::Vector2d> nominal_feet_;
  double nominal_height_ = 0.0;
  int region_edge_capacity_ = 0;
  bool has_regions_ = false;  // of the constructor's terrain (swapTerrain keeps it so)
  Eigen::VectorXd q_joint_ref_;
  Eigen::VectorXd servo_stiffness_;
  std::vector<std::string> contact_names_;
  std::unique_ptr<CentroidalCache> scratch_;  // for the non-real-time helpers above
  // anchorStanceFeet: placements only (the node quantities' gravity and centroidal
  // derivative passes are not needed for foot positions, on the 1 kHz tick).
  std::unique_ptr<model::Data> anchor_data_;
  // landLateFeet: per foot, the start of the stance whose landing is settled (NaN: none).
  std::vector<double> settled_stance_;
  // landLateFeet: the descent of each foot's late stance (its start), kept between calls.
  struct LandingPlan {
    bool valid = false;
    double stance = 0.0, from = 0.0, z_from = 0.0, landing = 0.0;
  };
  std::vector<LandingPlan> landings_;
};

}  // namespace rollstep::centroidal
