#pragma once
// The myopic reactive planner of the CBF-QP baseline (the paper's previous controller,
// Takasugi et al. 2023; DESIGN.md section 6): from the base velocity command and the state
// of this tick only, with no prediction, the references of the CBF-QP's tasks. It uses the
// NMPC pipeline's planning layer: the same gait (GaitScheduler, footPhase), the same swing
// height splines (SwingHeightSpline), the base reference's nominal footholds
// (BaseReference, FootReferencePlanner) and the terrain model.
//
// Every tick, at the measured base pose:
// - Anchor: the base reference restarts at the measured planar pose (x, y, yaw) with the
//   command, so the nominal footholds move with the robot: if it stalls at a step, nothing
//   runs ahead of it (myopic: no base position is tracked along the command).
// - Gait: the contact mode at t; the support feet are those in stance at t and still at
//   t + the all-stance overlap (trot_duty - 1/2) gait_period, so the COM is already inside
//   the next support polygon when a group lifts off.
// - Swing of foot i (planned at its lift-off, from the internal state's foot position):
//   the touch-down foothold is the nominal foothold at the touch-down time, moved onto the
//   surface foothold_lookahead ahead of it (along the command) when that surface is higher
//   or lower: the foot steps onto the next surface instead of stopping at its edge, as the
//   closest point of that surface's (shrunk) region; onto a lower surface it aims
//   descent_offset ahead of the nominal foothold (the wheel must clear the edge by its
//   radius before it can come down). Its region and height are fixed at
//   lift-off; (x, y) moves from the lift-off point to the foothold (updated every tick,
//   projected into that region) with a smoothstep of the swing phase; z is the swing height
//   spline from the lift-off height to the touch-down surface + the contact offset, apex
//   swing_clearance above the higher end.
// - Late touch-down (reactive): a swing whose wheel centre is still more than 1 cm above its
//   surface at the scheduled touch-down (the knee's velocity limit, or the collision barrier
//   holding it over an edge, made it lag) stays a swing, out of the mode and the support
//   feet, aimed straight down at the surface, until it lands or half a swing has passed.
// - Stance of foot i: the foothold region under the foot where its stance began (where it
//   really landed: a swing may end short of its foothold) and the nominal foothold at t,
//   projected into that region, as the (x, y) target (the wheels roll, the hips return to
//   their nominal angle), z on that surface.
// - Body: x, y from the internal state (myopic); with position_leash > 0 from the command
//   integrated over time instead, kept within position_leash of the internal state, while
//   the terrain under and ahead of the feet (as for the height below) is level: the position
//   feedback then makes up what the velocity feedback alone loses against the integrator's
//   fast blend of the measured velocity (the body settles below the commanded speed
//   otherwise), and a stalled robot is never asked for more than the leash; at a step it
//   stays myopic.
// - Body: yaw rate from the command (yaw integrated from the start), roll and pitch
//   0, height = nominal height + the highest terrain under the support polygon's footholds
//   (the nominal footholds at t, and each moved height_lookahead ahead along the command) +
//   height_offset where those heights differ, rate-limited to max_height_rate: the
//   telescopic legs' stroke is the binding limit on a step (a foot can rise onto a 20 cm
//   step only from a raised body), so the body rises before the feet reach it.
//
// Built once (allocates); reset() and plan() never allocate, lock or throw.
#include <Eigen/Core>
#include <memory>
#include <vector>

#include "rollstep/centroidal/loaded_robot.hpp"
#include "rollstep/control/cbf_qp.hpp"
#include "rollstep/control/control_settings.hpp"
#include "rollstep/planning/base_reference.hpp"
#include "rollstep/planning/contact_schedule.hpp"
#include "rollstep/planning/foot_reference.hpp"
#include "rollstep/planning/swing_trajectory.hpp"

namespace rollstep::control {

/// The references of one tick.
struct ReactivePlan {
  int mode = 0;          ///< contact mask at t
  int support_mask = 0;  ///< feet of the support polygon
  Eigen::VectorXd q;     ///< nq: base (x, y of the state, planned z, level, yaw), nominal joints
  Eigen::VectorXd v;     ///< nv: base twist LOCAL (of the state's orientation), joints 0
  Eigen::Matrix3Xd foot_position, foot_velocity;  ///< 3 x nc, world, contact frame origins
  std::vector<FootRegionPlan> regions;            ///< nc
  double terrain_high = 0.0;                      ///< highest terrain under the height samples [m]
  double terrain_low = 0.0;                       ///< lowest [m]
};

class ReactivePlanner {
 public:
  /// `robot` supplies the robot and its nominal posture; `contacts` the gait, the nominal
  /// stance and the foothold terrain; `collision_terrain` the prisms of the collision barrier
  /// (a swing's support prism: its lift-off one on the first half, its touch-down one on the
  /// second). All must outlive the planner. Throws std::invalid_argument for bad settings.
  ReactivePlanner(const centroidal::LoadedRobot& robot, const planning::ContactPlanner& contacts,
                  const planning::TerrainModel& collision_terrain,
                  const BaselineSettings& settings);

  /// Starts at time t at the model state (q, v) with `command`: the yaw reference starts at
  /// q's yaw, the height reference at q's height, no swing planned. Never allocates.
  void reset(double t, const Eigen::VectorXd& q, const planning::BaseVelocityCommand& command);
  /// A new base velocity command from the next plan() on (the yaw and height references
  /// continue). Never allocates.
  void setCommand(const planning::BaseVelocityCommand& command) { command_ = command; }
  const planning::BaseVelocityCommand& command() const { return command_; }
  /// The plan at time t from the measured configuration q_meas (the anchor: its planar pose)
  /// and the internal one q_int (the base reference's x, y and the twist's frame), with
  /// foot_positions (3 x nc) the contact frame origins at the internal state (where swings
  /// start, whether they have landed). Never allocates.
  void plan(double t, const Eigen::VectorXd& q_meas, const Eigen::VectorXd& q_int,
            const Eigen::Matrix3Xd& foot_positions, ReactivePlan& out) noexcept;

  /// After the foothold terrain (the contact planner's) and the collision terrain changed in place
  /// (a new perceived terrain; `old_terrain`: the foothold terrain before): the region and prism
  /// indices the planner holds are moved to the new terrains, each to the region under the point it
  /// served (a swing's goal on the old terrain, its start); stance feet take the region they stand
  /// in at the next plan(). Never allocates.
  void remapRegions(const planning::TerrainModel& old_terrain) noexcept;

  ReactivePlan makePlan() const;
  const planning::Gait& gait() const { return scheduler_->gait(); }
  const BaselineSettings& settings() const { return settings_; }

 private:
  struct Swing {
    bool planned = false;
    double liftoff = 0.0, touchdown = 0.0;
    Eigen::Vector2d start = Eigen::Vector2d::Zero();
    int region = -1;     ///< touch-down region
    double shift = 0.0;  ///< [m] the foothold's shift along the command (descent_offset)
    int liftoff_prism = -1, touchdown_prism = -1;  ///< of the collision terrain
    planning::SwingHeightSpline spline;
  };
  /// The touch-down foothold of foot i for a swing ending at t_td: the nominal foothold
  /// shifted by `shift` along the command, projected onto `region`. With region < 0 it
  /// chooses the region (and the shift of a descent) first.
  Eigen::Vector2d footholdFor(int i, double t_td, int& region, double& shift) const;
  /// footholdFor on a given terrain.
  Eigen::Vector2d footholdOn(const planning::TerrainModel& terrain, int i, double t_td, int& region,
                             double& shift) const;

  const centroidal::LoadedRobot* robot_;
  const planning::ContactPlanner* contacts_;
  const planning::TerrainModel* solids_;
  BaselineSettings settings_;
  std::unique_ptr<planning::BaseReference> base_;
  std::unique_ptr<planning::FootReferencePlanner> feet_;
  std::unique_ptr<planning::GaitScheduler> scheduler_;
  ocp::ModeSchedule schedule_;
  planning::BaseVelocityCommand command_;
  std::vector<Swing> swings_;
  std::vector<int> stance_region_;
  double yaw_ref_ = 0.0, yaw_time_ = 0.0;
  double height_ref_ = 0.0, height_time_ = 0.0;
  Eigen::Vector2d xy_ref_ = Eigen::Vector2d::Zero();  ///< world x, y (position_leash > 0)
  double xy_time_ = 0.0;
  double support_preview_ = 0.0;
};

}  // namespace rollstep::control
