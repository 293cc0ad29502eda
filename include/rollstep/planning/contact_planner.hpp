#pragma once
// The contact planner: when each foot is in contact and where, from a gait, the terrain and
// a base velocity command. One object that both the MPC's problem (centroidal::CentroidalOcp)
// and the 1 kHz side (control::ControlPipeline, the baseline's reactive planner) use, so
// that neither builds the other's machinery to get at it. It owns:
//   - the terrain model every reference reads (swapped in place when perception updates it);
//   - the base reference (base_reference.hpp) and the foot reference planner
//     (foot_reference.hpp: footholds, swing heights, anchors, touch-down latches, landings);
//   - the gait, its scheduler and its clock with the edge holds (edge_holds.hpp);
//   - what the measured feet change: stance anchors and late touch-downs.
// It knows contact points, not a robot model: the measured calls take the world positions
// of the contact frames (3 x numFeet), which the caller computes from its state.
//
// Rules that depend on the commanded speed, where to change them:
//   - step length: a foothold is the nominal foot position placed by the base reference at
//     the touch-down time (FootReferencePlanner::nominalFoothold), so a step is the distance
//     the reference travels in a gait cycle: speed x gait period;
//   - swing: the height spline between the lift-off and touch-down surfaces
//     (SwingHeightSpline; ContactPlannerSettings swing_clearance, swing_apex_margin), the
//     landing descent of a late foot (late_touchdown_speed);
//   - gait timing: GaitTiming (period and duty of each gait), made into a Gait by makeGait;
//     the clock's holds at edges (ContactPlannerSettings::edge_holds).
//
// Construction allocates and may throw std::invalid_argument naming the bad value; every
// other call allocates nothing (resetSchedule with a longer command schedule than any before
// excepted). Not copyable or movable: the references point at the terrain and at each other.
#include <Eigen/Core>
#include <memory>
#include <vector>

#include "rollstep/lie/se3.hpp"
#include "rollstep/ocp/mode_schedule.hpp"
#include "rollstep/planning/base_reference.hpp"
#include "rollstep/planning/contact_schedule.hpp"
#include "rollstep/planning/edge_holds.hpp"
#include "rollstep/planning/foot_reference.hpp"
#include "rollstep/planning/gait.hpp"
#include "rollstep/planning/gait_clock.hpp"
#include "rollstep/planning/terrain.hpp"

namespace rollstep::planning {

/// Period and duty of each gait (the robot's groups are in GaitGroups).
struct GaitTiming {
  double period = 1.0;       ///< [s] of trot (and the bookkeeping period of standing, rolling)
  double trot_duty = 0.6;    ///< stance fraction of a trot foot, in (0, 1)
  double walk_period = 2.0;  ///< [s] of static_walk
  double walk_duty = 0.85;   ///< stance fraction of a static_walk foot, in (0, 1)
};

/// The robot's feet as the gaits group them (contact masks / indices in contact order).
struct GaitGroups {
  int trot_a = 0;               ///< feet in stance first in a trot (Gait::trot group_a)
  int trot_b = 0;               ///< the other trot group
  std::vector<int> walk_order;  ///< swing order of static_walk
};

/// The gait of `kind` for `num_feet` feet. Throws std::invalid_argument for a trot without
/// both groups, a static walk without an order, a custom gait (it needs its table:
/// Gait::fromTable) or bad timing (Gait's factories).
Gait makeGait(GaitKind kind, int num_feet, const GaitTiming& timing, const GaitGroups& groups);

/// The robot at its nominal posture, as the planner sees it.
struct NominalStance {
  /// Body-frame (x, y) of each foot's contact frame [m], in contact (mode mask) order.
  std::vector<Eigen::Vector2d> feet;
  /// Base frame height above the ground under the feet [m].
  double height = 0.0;
  /// Height of the contact frame above the ground contact [m] (the wheel radius).
  double foot_height_offset = 0.0;
};

/// What the planner decides by. Defaults are neutral (no holds, anchors or landings); the
/// robot OCP's values come from its settings (centroidal::contactPlannerSettings, whose
/// config/ocp.yaml documents each key).
struct ContactPlannerSettings {
  /// [s] The longest horizon a schedule is filled over (the MPC's N dt).
  double horizon = 0.0;
  GaitTiming gait;
  // Footholds and swings (FootReferenceConfig).
  double swing_clearance = 0.0;     ///< [m] swing apex above the higher end
  double swing_apex_margin = 0.5;   ///< apex placement in (0, 1/2] (SwingHeightSpline)
  double foothold_gap_reach = 0.0;  ///< [m] FootReferenceConfig::gap_reach
  // Base height over the terrain (BaseReferenceConfig).
  double base_height_reach = 0.0;  ///< [m]
  double base_height_slope = 0.0;  ///< [-]
  bool base_height_rate = false;
  /// Holds of the gait's clock at terrain edges (planSchedule).
  EdgeHoldConfig edge_holds{};
  /// anchorStanceFeet: anchor stance feet where they stand / latch touch-down regions.
  bool anchor_stance_feet = false;
  bool latch_touchdowns = false;
  /// landLateFeet: [m] height above its surface at which a foot whose stance began is late
  /// (<= 0: never); [-] the longest delay as a fraction of its swing; [m/s] the speed of
  /// its descent; [s] the shortest descent.
  double late_touchdown_tolerance = 0.0;
  double late_touchdown_max_delay = 0.5;
  double late_touchdown_speed = 0.5;
  double late_touchdown_min_time = 0.0;
};

class ContactPlanner {
 public:
  /// `region_edge_capacity`: the most edges a region of any terrain given later
  /// (swapTerrain) may have; 0 = the most of `terrain`. Throws std::invalid_argument for a
  /// negative capacity, a gait for another number of feet than the stance has, or what the
  /// references refuse. Starts at t = 0 at the identity pose, standing still.
  ContactPlanner(const ContactPlannerSettings& settings, NominalStance stance, Gait gait,
                 TerrainModel terrain, int region_edge_capacity = 0);
  ContactPlanner(const ContactPlanner&) = delete;
  ContactPlanner& operator=(const ContactPlanner&) = delete;

  /// Starts the base reference at t0 from `start` (its x, y and yaw) with `command`, and
  /// forgets every anchor, latch, landing and hold.
  void reset(double t0, const lie::SE3& start, const BaseVelocityCommand& command);
  /// Same with a command schedule (BaseReference::resetSchedule).
  void resetSchedule(double t0, const lie::SE3& start,
                     const std::vector<TimedBaseCommand>& schedule);

  /// Capacity a ModeSchedule needs for planSchedule / fillSchedule: the gait's switches over
  /// the horizon and one landing per foot (landLateFeet).
  int scheduleCapacity() const;
  /// The MPC's schedule from t0: plans the clock's edge holds over the horizon
  /// (planEdgeHolds), then fills `out` over it through the clock.
  void planSchedule(double t0, ocp::ModeSchedule& out);
  /// Fills `out` from t0 over `horizon` (<= settings().horizon) through the clock as it is
  /// (the 1 kHz side, with the clock of the solution it follows).
  void fillSchedule(double t0, double horizon, ocp::ModeSchedule& out);
  const GaitClock& gaitClock() const { return clock_; }
  /// Takes another planner's clock (the real-time side takes the MPC's). Never allocates.
  void setGaitClock(const GaitClock& clock) noexcept { clock_ = clock; }

  /// Anchors every foot in stance at t under `schedule` where it stands (`feet`: world
  /// positions of the contact frames, 3 x numFeet): that stance's region and height, and the
  /// lift-off end of the swing after it, are taken there (FootReferencePlanner::anchorStance),
  /// not at its nominal foothold (settings anchor_stance_feet). With latch_touchdowns, every
  /// foot in swing at t keeps the touch-down region chosen at the first call in that swing
  /// (FootReferencePlanner::latchTouchdown). Wrongly sized or non-finite feet change nothing.
  void anchorStanceFeet(const ocp::ModeSchedule& schedule, double t,
                        const Eigen::Matrix3Xd& feet) noexcept;
  /// Late touch-downs (settings late_touchdown_*; FootReferencePlanner's file comment): every
  /// foot whose stance under `schedule` began before t (at most late_touchdown_max_delay of
  /// its swing ago) while its contact frame in `feet` is still more than
  /// late_touchdown_tolerance above that stance's surface gets its stance start moved to a
  /// landing time in `schedule` (delayTouchdown: the problem's schedule, or a controller's
  /// copy of it), with a descent from where it is to the surface until then (planned at the
  /// first call that finds the stance late and kept; a foot still up at its landing time gets
  /// a new one from where it is). Once a foot of a stance is seen on its surface (or the
  /// delay runs out) that stance is settled and is never delayed again. Call after
  /// planSchedule / fillSchedule and anchorStanceFeet on a freshly filled schedule, once per
  /// solve or tick. Returns the mask of the feet delayed now. Wrongly sized or non-finite
  /// feet delay nothing.
  int landLateFeet(ocp::ModeSchedule& schedule, double t, const Eigen::Matrix3Xd& feet) noexcept;
  /// Whether anchorStanceFeet or landLateFeet do anything with these settings (the caller
  /// may skip measuring the feet otherwise).
  bool usesMeasuredFeet() const {
    return settings_.anchor_stance_feet || settings_.latch_touchdowns ||
           settings_.late_touchdown_tolerance > 0.0;
  }

  /// Keeps the base reference within a leash of the robot's base pose at t
  /// (BaseReference::follow). Never allocates; returns whether it moved.
  bool followRobot(double t, const lie::SE3& base_pose, double max_distance, double max_yaw,
                   double max_lateral = 0.0);
  /// Gives the base reference the planar correction of another copy of it (the MPC's, so
  /// that the real-time side plans footholds on the reference the solution was solved on).
  /// Refuses (false) a non-finite one.
  bool setReferenceCorrection(const lie::SE3& correction) noexcept;

  /// Whether `terrain` can replace the current one: non-empty when the current one is,
  /// empty when it is empty, regions of at most regionEdgeCapacity() edges. Reads only what
  /// is fixed at construction: may be called from another thread than the one that swaps.
  bool acceptsTerrain(const TerrainModel& terrain) const noexcept;
  /// Replaces the terrain every reference reads by `terrain`'s regions (exchanged: `terrain`
  /// receives the old ones), if acceptsTerrain(terrain); else changes nothing and returns
  /// false. Never allocates.
  bool swapTerrain(TerrainModel& terrain) noexcept;
  int regionEdgeCapacity() const { return region_edge_capacity_; }

  int numFeet() const { return static_cast<int>(stance_.feet.size()); }
  const ContactPlannerSettings& settings() const { return settings_; }
  const NominalStance& stance() const { return stance_; }
  const TerrainModel& terrain() const { return *terrain_; }
  const BaseReference& baseReference() const { return *base_; }
  const FootReferencePlanner& footPlanner() const { return *feet_; }
  const Gait& gait() const { return scheduler_->gait(); }

 private:
  ContactPlannerSettings settings_;
  NominalStance stance_;
  int region_edge_capacity_ = 0;
  bool has_regions_ = false;  // of the constructor's terrain (swapTerrain keeps it so)
  std::unique_ptr<TerrainModel> terrain_;
  std::unique_ptr<BaseReference> base_;
  std::unique_ptr<FootReferencePlanner> feet_;
  std::unique_ptr<GaitScheduler> scheduler_;
  GaitClock clock_;
  // landLateFeet: per foot, the start of the stance whose landing is settled (NaN: none).
  std::vector<double> settled_stance_;
  // landLateFeet: the descent of each foot's late stance (its start), kept between calls.
  struct LandingPlan {
    bool valid = false;
    double stance = 0.0, from = 0.0, z_from = 0.0, landing = 0.0;
  };
  std::vector<LandingPlan> landings_;
};

}  // namespace rollstep::planning
