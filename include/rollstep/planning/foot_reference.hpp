#pragma once
// Everything an OCP term asks about one foot at one node, in one query: stance or swing
// (from the node's ModeSchedule, mode id = contact mask), the swing's lift-off and
// touch-down times and phase, the swing height reference z_ref(t), z_dot_ref(t), the
// convex region constraining a stance foot, and for a swing whether it ascends or
// descends, which region avoids collisions and whether that constraint is on at t.
//
// Footholds are nominal: the robot-specific body-frame foot positions (an argument)
// placed by the base reference at the time in question; heights come from the terrain
// under them. A stance foot keeps the foothold of its touch-down for the whole stance
// (stanceFoothold): its wheel may roll, but not up or down a step, so the region (and
// height) of a stance, and the lift-off end of the next swing, are those under the
// nominal foothold at the touch-down that began the stance, not under the one at t
// (which moves on with the base and would switch region mid-stance at an edge). Built once
// (allocates); query() allocates nothing. The terrain and base reference are held by pointer and
// must outlive the planner.
//
// Anchors: the nominal foothold of a stance is where the foot should have landed; a robot
// lagging its base reference (a climb slows it down) lands short of it, and near a step's
// edge the two are on different surfaces: the foot stands on the landing while the nominal
// foothold already lies on the step, and its swing would be planned level at the step's
// height instead of up onto it. anchorStance() records where a stance foot actually stands
// (the controller measures it); that stance's region and height, and the lift-off end of
// the swing after it, are then taken at the measured point (TerrainModel::regionAt: the
// region under it, or the nearest), and every later stance stays nominal.
//
// Touch-down latches: the touch-down region of a swing is chosen from the nominal foothold
// at the touch-down time, and near an edge a new terrain (the perceived edge moves by a
// cell) or a gap rule can switch it mid-swing, from up onto a step to level before it: the
// swing's height reference drops and the wheel strikes the riser. latchTouchdown() keeps
// the choice made at that moment for the rest of the swing and the stance after it, as a
// point of the chosen region (the nominal foothold moved into it) and its height, which
// later terrains resolve to the same surface: the nearest region at that height.
//
// Late touch-downs: a foot still in the air when its stance was due (the knee's velocity
// limit, an edge it met, a body too high for the leg to reach down) is not held there by
// the stance's zero vertical velocity: the controller (ContactPlanner::landLateFeet) moves
// that stance's start to a landing time in the schedule (delayTouchdown), and setLanding()
// tells this planner. The swing then ends on a descent from the measured height to the
// stance's surface (a smoothstep in time, zero vertical velocity at both ends), and the
// stance that begins at the landing keeps the foothold, anchor and latch of the touch-down
// it replaces.
#include <Eigen/Core>
#include <vector>

#include "rollstep/ocp/mode_schedule.hpp"
#include "rollstep/planning/base_reference.hpp"
#include "rollstep/planning/contact_schedule.hpp"
#include "rollstep/planning/swing_trajectory.hpp"
#include "rollstep/planning/terrain.hpp"

namespace rollstep::planning {

struct FootReferenceConfig {
  /// Body-frame (x, y) of each foot's nominal contact point [m], in the contact order
  /// of the mode masks.
  std::vector<Eigen::Vector2d> nominal_feet;
  /// Swing apex above the higher end [m].
  double swing_clearance = 0.0;
  /// Height of the constrained foot point above the ground contact [m] (e.g. the wheel
  /// radius when the foot frame is the wheel centre).
  double foot_height_offset = 0.0;
  /// Height difference [m] below which a swing counts as level.
  double level_tolerance = 1e-3;
  /// [m] A nominal foothold in a gap between regions takes the region ahead along the
  /// direction of travel when it begins within this distance (TerrainModel::regionAhead);
  /// 0: the nearest region.
  double gap_reach = 0.0;
  /// Apex placement of the swing height spline, in (0, 1/2] (SwingHeightSpline): 1/2 puts
  /// the apex at mid-swing; less lets it move towards the end of a swing up a step (the
  /// start of one down) so that the rise is not faster than the fall.
  double swing_apex_margin = 0.5;
};

struct FootReference {
  FootPhase timing;  ///< stance / swing, lift-off, touch-down, phase
  /// Stance: the region under the nominal foothold at t. Swing: the touch-down region.
  int region = -1;
  SwingDirection direction = SwingDirection::Level;  ///< swing only
  /// Swing only: the collision-avoidance region (the lower one: lift-off region when
  /// ascending, touch-down region when descending), -1 on the level.
  int swing_region = -1;
  /// Swing only: first half of an ascending swing, second half of a descending one.
  bool swing_region_active = false;
  /// Foot point height reference [m] and its rate [m/s] (stance: ground + offset, 0).
  double z_ref = 0.0;
  double z_dot_ref = 0.0;
};

class FootReferencePlanner {
 public:
  /// Throws std::invalid_argument naming the bad field (no feet, more than kMaxFeet,
  /// non-finite positions, negative clearance or tolerance, non-finite offset).
  FootReferencePlanner(const TerrainModel& terrain, const BaseReference& base,
                       FootReferenceConfig config);

  int numFeet() const { return static_cast<int>(config_.nominal_feet.size()); }
  const FootReferenceConfig& config() const { return config_; }
  const TerrainModel& terrain() const { return *terrain_; }
  /// World (x, y) velocity of the base reference at time t [m/s] (the direction of travel
  /// the foothold rule looks along).
  Eigen::Vector2d travelVelocity(double t) const;
  /// World (x, y) of foot `foot`'s nominal contact at time t.
  Eigen::Vector2d nominalFoothold(int foot, double t) const;
  /// World (x, y) of the foothold of the stance of `foot` that contains t: the nominal
  /// foothold at the touch-down that began it, or at t when the stance began before the
  /// schedule's first switch (GaitScheduler fills one period before t0, so only a gait
  /// without switches, standing or rolling, falls back). For a t in a swing: the foothold
  /// at t.
  Eigen::Vector2d stanceFoothold(const ocp::ModeSchedule& schedule, int foot, double t) const;
  /// The swing height spline of a swing of `foot` between the given times, from the
  /// nominal footholds at those times (query() takes the lift-off end from stanceFoothold).
  SwingHeightSpline swingSpline(int foot, double t_liftoff, double t_touchdown) const;
  /// Everything about `foot` at time t under `schedule`. A swing whose lift-off or
  /// touch-down the schedule does not contain holds z_ref at the apex over the current
  /// nominal foothold, with no swing region.
  FootReference query(const ocp::ModeSchedule& schedule, int foot, double t) const;
  /// The region of a foothold p chosen at time t (regionAhead along the base reference's
  /// direction of travel at t, with gap_reach), -1 for an empty terrain.
  int footholdRegion(const Eigen::Vector2d& p, double t) const;

  /// Anchors the stance of `foot` that began at `stance_start` (the schedule's switching
  /// time that began it, -inf for one that began before the schedule's first switch) at the
  /// measured world (x, y) `p` of the foot (see the file comment). One anchor per foot, the
  /// last given; it applies to the stance whose start matches within 1e-6 s. A non-finite
  /// p or an out-of-range foot clears that foot's anchor. Never allocates.
  void anchorStance(int foot, double stance_start, const Eigen::Vector2d& p) noexcept;
  /// Latches the touch-down of the swing of `foot` that ends at `touchdown` [s] (see the
  /// file comment): its region is the one chosen now, and stays so for that swing and the
  /// stance it begins. One latch per foot; calling again for the same touch-down (within
  /// 1e-6 s) keeps the first choice, another touch-down replaces it. A non-finite time, an
  /// out-of-range foot or an empty terrain clears that foot's latch. Never allocates.
  void latchTouchdown(int foot, double touchdown) noexcept;
  /// Late touch-down of `foot` (see the file comment): its stance scheduled to begin at
  /// `touchdown` begins at `landing` (> from) instead, and from time `from` to then its
  /// height reference descends from z_from to z_to [m]. One per foot, the last given; a
  /// non-finite value or an out-of-range foot clears that foot's landing. Never allocates.
  void setLanding(int foot, double touchdown, double from, double z_from, double landing,
                  double z_to) noexcept;
  void clearLanding(int foot) noexcept;
  /// Forgets every anchor, touch-down latch and landing (all footholds nominal).
  void clearAnchors() noexcept;
  /// The start time of the stance of `foot` containing t under `schedule` (as
  /// anchorStance() takes it), or NaN when the foot is not in stance at t.
  static double stanceStartAt(const ocp::ModeSchedule& schedule, int foot, double t);

 private:
  struct Anchor {
    bool valid = false;
    double start = 0.0;
    Eigen::Vector2d p = Eigen::Vector2d::Zero();
  };
  struct Latch {
    bool valid = false;
    double touchdown = 0.0;
    Eigen::Vector2d p = Eigen::Vector2d::Zero();  ///< a point of the chosen region
    double z = 0.0;                               ///< its surface's height there [m]
  };
  struct Landing {
    bool valid = false;
    double touchdown = 0.0, landing = 0.0;  ///< the scheduled and the delayed stance start
    double from = 0.0, z_from = 0.0, z_to = 0.0;
  };
  /// A stance start (or swing touch-down) of `foot` as the anchors and latches know it: the
  /// scheduled touch-down for a delayed landing, else `start` itself.
  double scheduledStart(int foot, double start) const;
  /// Latched surfaces are found again on a new terrain by height within this [m].
  static constexpr double kLatchHeightTolerance = 0.02;
  /// The region of a latch on the current terrain: the nearest one at its height (a new
  /// terrain renumbers regions and moves their edges), else the nearest.
  int latchedRegion(const Latch& l) const;
  /// The latch of `foot`'s swing ending at (or stance starting at) `t`, or nullptr.
  const Latch* latchFor(int foot, double t) const;
  double heightIn(int region, const Eigen::Vector2d& p) const;
  /// The anchor of `foot`'s stance that began at `start`, or nullptr.
  const Anchor* anchorFor(int foot, double start) const;
  /// The foothold (and its region) of `foot`'s stance that began at `start`: its anchor
  /// (the region under it), else its touch-down latch, else the nominal foothold at
  /// t_nominal (footholdAt). A NaN start has no anchor or latch.
  Eigen::Vector2d stanceFootholdAt(int foot, double start, double t_nominal, int& region) const;
  /// nominalFoothold(foot, t) and footholdRegion of it at t, from one evaluation of the
  /// base reference's pose at t (query() needs both at the same times).
  Eigen::Vector2d footholdAt(int foot, double t, int& region) const;
  int regionOf(const Eigen::Vector2d& p, double t, const lie::SE3& pose) const;
  /// travelVelocity(t) with the base reference's pose at t given.
  Eigen::Vector2d travelVelocity(double t, const lie::SE3& pose) const;
  std::vector<Anchor> anchors_;
  std::vector<Latch> latches_;
  std::vector<Landing> landings_;

  const TerrainModel* terrain_;
  const BaseReference* base_;
  FootReferenceConfig config_;
};

}  // namespace rollstep::planning
