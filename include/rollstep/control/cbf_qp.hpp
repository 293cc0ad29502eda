#pragma once
// The CBF-QP safety filter (paper Sec. 3.3; DESIGN.md sections 5 and 6): at every 1 kHz
// tick it turns the desired accelerations of the base, the feet and the joints into the
// closest generalized acceleration a = dv/dt (the model's v: base twist LOCAL, then the
// joints) that keeps the commanded state safe:
//
//   minimise   |a_b - a_b,des|^2_Wb + sum_i |J_i a + dJ_i v - a_i,des|^2_Wf
//              + |a_J - a_J,des|^2_Wj + freed stance rows + damping |a|^2
//   subject to contact consistency: each stance foot's kept velocity rows (vertical, and
//                lateral in the foot's yaw frame for a drive wheel; the OCP's side-by-side
//                rule decides which feet keep them) as equalities a_row = -k v_row;
//              joint position limits (second-order CBF) and joint velocity limits
//                (first-order CBF), on the joint accelerations;
//              foothold regions: a stance foot's (x, y) inside its region's half-planes
//                (second-order CBF per edge); a swing foot inside its collision region
//                while that constraint is on (the planner's swing_region_active);
//              leg/terrain clearance: a swing wheel's bottom above the terrain under it
//                (second-order CBF; clearance_gamma = 0: off);
//              the baseline's families (DESIGN.md section 6), each off unless its gamma > 0:
//                static stability, the COM's ground projection inside the support polygon
//                with a margin; leg/terrain collision with analytically smoothed distances
//                (second-order CBFs, below).
//
// Every foot term is about the origin of contact i's frame (the wheel centre; world axes):
// p_i, its velocity v_i = J_i v (J_i: linear rows of the LOCAL_WORLD_ALIGNED frame
// Jacobian) and its classical acceleration J_i a + dJ_i v, the drift dJ_i v computed
// analytically from the body velocities (footDrift()). The foot cost runs over every foot,
// stance or swing. Precisely:
// - Row velocities: v_z = e_z . v_i; for a drive wheel v_lat = e_lat . v_i with
//   e_lat = (-sin yaw, cos yaw, 0), yaw = atan2 of the contact frame's x axis projected on
//   the ground plane (as the OCP's StanceVelocityResidual). a_row is d/dt v_row along the
//   motion: for the lateral row e_lat . (J_i a + dJ_i v) - yaw_rate (e_fwd . v_i), the
//   second term from the rotation of e_lat (e_fwd = (cos yaw, sin yaw, 0)), so that a
//   wheel rolling on a curve keeps v_lat = 0. Kept rows are equalities a_row = -k v_row
//   (k = contact_gain); rows freed by the side-by-side rule are the cost
//   freed_contact_weight |a_row + k v_row|^2.
// - The cost above is halved into the QP (0.5 a^T H a + g^T a, same minimiser).
// - Second-order barriers h >= 0: h'' + 2 gamma h' + gamma^2 h >= 0; first-order:
//   h' + gamma h >= 0 (CbfQpSettings).
// - Joint j with finite URDF position limits [lo, up]: h = q_j - (lo + margin) and
//   h = (up - margin) - q_j (joint_position_gamma, joint_position_margin); with a non-zero
//   URDF velocity limit, vmax = velocity_limit_scale * limit: h = vmax - v_j and
//   h = vmax + v_j (joint_velocity_gamma). Both are bounds on a_j: the position barrier
//   gives [Lp, Up], the velocity barrier [Lv, Uv] (each never empty on its own). When they
//   conflict (Lp > Uv or Lv > Up: a joint beyond, or racing towards, a position limit
//   faster than its velocity limit allows it to be stopped or brought back), the rows are
//   made consistent rather than handed to the QP as an empty set: the position bounds are
//   clamped into the velocity interval, lb = max(Lv, min(Lp, Uv)), ub = min(Uv, max(Up,
//   Lv)). So the velocity barrier wins and a_j is pinned to the velocity bound on the side
//   the position barrier pushes: the joint is driven back towards its range at no more than
//   its velocity limit (a first-order barrier on a motor limit is never broken to satisfy
//   a second-order one). Continuous joints and zero URDF velocity limits give no bound.
// - Foothold / swing region row e (unit inward A_e, offset b_e):
//   h = A_e . (x_i, y_i) + b_e, one inequality per edge of the region.
// - Clearance of swing foot i: h = z_i - contactOffset() - H(x_i, y_i) - clearance, with H
//   the plane of the terrain region under the wheel (TerrainModel::regionAt; its slope
//   enters h'), or the plane z = 0 for an empty terrain model.
// - Support polygon (support_gamma > 0): the convex hull (barriers.hpp) of the (x, y) of
//   the support feet's contact frames (setSupportFeet(), by default the stance feet), at
//   least 3 feet not on a line (else no row). Edge k from foot a to foot b (counter-
//   clockwise), inward unit normal n, midpoint m = (p_a + p_b) / 2: h = n . (c - m) -
//   support_margin with c the COM (x, y). The feet roll, so h' = n . (c' - m') and h'' =
//   n . (c'' - m'') with n held (its rotation as the feet move is left out: second order in
//   the feet's relative motion, zero when they move alike); c'' = Jcom a + the COM drift
//   (mass-weighted classical accelerations of the bodies' COMs at a = 0).
// - Collision (collision_gamma > 0): for each foot i and each prism j of the collision
//   terrain (the constructor's, default the filter's own) that is nearer than
//   collision_range (face distance) and is neither the foot's support prism
//   (FootRegionPlan::support_prism, by default the one under the wheel centre) nor level
//   with it within 1 mm (a wheel rolls from one such surface onto the other):
//   h = d_j(p_i) - contactOffset() - collision_clearance
//   with d_j the smoothed distance of barriers.hpp (the wheel as a sphere of the contact
//   offset, its radius); h' = grad d . v_i, h'' = v_i^T Hess d v_i + grad d . (J_i a +
//   dJ_i v). Stance feet too: a rolling wheel stops at a step's face.
// - `regions` may be nullptr (no region constraints). An index must be < terrain.size()
//   and its region have at most maxRegionEdges() edges (sized at construction: the most
//   edges of any region of the terrain then, at least 8), else InvalidInput.
//
// The state (q, v) is the internal integrator's: the filter keeps the COMMANDED motion
// safe. Solved by DenseQpSolver (dense_qp.hpp), warm-started from the last tick.
// Relaxation: when the QP is infeasible (the barriers have no common point with the contact
// rows and joint bounds: a foot asked to stay in a region that its joint limits pull it out
// of, a swing wheel under a rising clearance plane) or hits its iteration cap, a second QP
// gives every barrier row a slack s_r >= 0, C_r a + s_r >= l_r, at the cost
// 0.5 relaxation_weight s_r^2: the command that breaks the barriers least, by weight,
// while the contact rows and the joint bounds hold exactly (status Relaxed). Braking the
// joints instead (the fallback below) stops a climbing swing in mid-air.
// Fallback (a documented rule): when neither QP ends Optimal (the contact rows and joint
// bounds alone inconsistent, bad data; or relaxation_weight = 0), a = fallback: zero base
// acceleration and joint accelerations -v_J / fallback_brake_time, so the commanded joints
// come to rest where they are; the status says so.
// InvalidInput (the QP is not solved): a non-finite or wrongly sized q, v or target, a
// quaternion whose norm is not 1 within 1e-3, a mode outside [0, 2^nc), a bad region
// index; a gets the fallback with 0 for every non-finite (or missing) v_J. When a itself is
// not nv long nothing is written.
//
// Each constraint family is one function of cbf_rows.hpp (with its own tests); filter()
// checks the input, sizes the QP, calls them and solves.
//
// Memory: sized at construction; filter() never allocates, locks or throws.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "rollstep/centroidal/robot.hpp"
#include "rollstep/common/enum_names.hpp"
#include "rollstep/control/control_settings.hpp"
#include "rollstep/control/dense_qp.hpp"
#include "rollstep/model/data.hpp"
#include "rollstep/planning/terrain.hpp"

namespace rollstep::control {

/// Which regions constrain foot i this tick (from planning::FootReferencePlanner::query).
struct FootRegionPlan {
  int region = -1;        ///< stance: the foothold region (-1: none)
  int swing_region = -1;  ///< swing: the collision-avoidance region (-1: none)
  bool swing_region_active = false;
  /// Collision barrier only: the prism of the collision terrain the foot rests on, lifts off
  /// from or lands on, left out of its collision rows (with the prisms level with it); -1:
  /// the prism under the wheel centre.
  int support_prism = -1;
};

/// Desired accelerations, each feedforward + feedback, sized for the robot.
struct AccelerationTargets {
  Eigen::Matrix<double, 6, 1> base = Eigen::Matrix<double, 6, 1>::Zero();  ///< d/dt v_b (LOCAL)
  Eigen::Matrix3Xd feet;   ///< 3 x nc, world linear accelerations of the contact frames
  Eigen::VectorXd joints;  ///< nj
};

enum class CbfQpStatus {
  Optimal,       ///< the QP's solution
  Relaxed,       ///< the barriers had no common point: the relaxed QP's solution (the least
                 ///< weighted violation of the barrier rows; relaxation() says how much)
  Fallback,      ///< the QP failed (qpStatus() says how); the fallback acceleration
  InvalidInput,  ///< non-finite state or targets; the fallback acceleration (with v = 0 where
                 ///< v is not finite)
};
constexpr std::array<EnumName<CbfQpStatus>, 4> enumNames(CbfQpStatus) {
  return {{{CbfQpStatus::Optimal, "Optimal"},
           {CbfQpStatus::Relaxed, "Relaxed"},
           {CbfQpStatus::Fallback, "Fallback"},
           {CbfQpStatus::InvalidInput, "InvalidInput"}}};
}
const char* toString(CbfQpStatus status);

/// The kinds of a foot's barrier rows, as bit indices in CbfQpFilter::activeFootBarriers()
/// (and in the logs' qp_active_<leg>[-]: 1 region, 2 clearance, 4 collision).
enum BarrierKind : int {
  kRegionBarrier = 0,     ///< its foothold region's (stance) or swing region's edges
  kClearanceBarrier = 1,  ///< a swing wheel's clearance above the terrain
  kCollisionBarrier = 2,  ///< leg/terrain collision with the solids
};
constexpr int kBarrierBitsPerFoot = 3;

class CbfQpFilter {
 public:
  /// `terrain` must outlive the filter. Throws std::invalid_argument for bad settings.
  /// `lateral_slip_weight`: the OCP's (OcpSettings::lateral_slip_weight): 0, drive wheels
  /// keep their lateral rows (equalities, or costs for freed rows); > 0 (skid steering),
  /// the filter has no lateral rows: the MPC's plan weighs the slip a turn needs.
  /// `collision_terrain` (must outlive the filter; nullptr: `terrain`): the solids of the
  /// collision barrier, unshrunk (the foothold regions of `terrain` are usually shrunk).
  /// `collision_prism_capacity`: the most prisms the collision terrain may have when it is
  /// changed in place later (a perceived terrain); 0: its size now.
  CbfQpFilter(std::shared_ptr<const centroidal::CentroidalRobot> robot,
              const planning::TerrainModel& terrain, const CbfQpSettings& settings,
              double lateral_slip_weight = 0.0,
              const planning::TerrainModel* collision_terrain = nullptr,
              int collision_prism_capacity = 0);
  ~CbfQpFilter();  // out of line: Work is incomplete here
  CbfQpFilter(CbfQpFilter&&) noexcept;
  CbfQpFilter& operator=(CbfQpFilter&&) noexcept;
  CbfQpFilter(const CbfQpFilter&) = delete;
  CbfQpFilter& operator=(const CbfQpFilter&) = delete;

  /// Filters `targets` at the internal state (q: nq, v: nv) in contact mode `mode` (contact
  /// mask, bit i = foot i in stance) with the region plan of every foot (nc entries).
  /// Writes the acceleration (nv) to `a`. Never allocates, locks or throws.
  CbfQpStatus filter(const Eigen::Ref<const Eigen::VectorXd>& q,
                     const Eigen::Ref<const Eigen::VectorXd>& v, int mode,
                     const FootRegionPlan* regions, const AccelerationTargets& targets,
                     Eigen::Ref<Eigen::VectorXd> a) noexcept;

  /// An AccelerationTargets sized for the robot (zero).
  AccelerationTargets makeTargets() const;
  /// The feet (contact mask) whose support polygon holds the COM from the next filter() on;
  /// -1 (the default): the stance feet of filter()'s mode. Only with support_gamma > 0.
  void setSupportFeet(int mask) { support_mask_ = mask; }

  // --- about the last filter() ---------------------------------------------------------
  /// The QP's status (DenseQpStatus::InvalidInput when filter() refused its input and
  /// solved nothing).
  DenseQpStatus qpStatus() const { return qp_status_; }
  int qpIterations() const { return qp_iterations_; }
  /// Inequality sides active at the solution (barriers that changed the command; the joint
  /// bounds count once per active side).
  int activeBarriers() const { return active_barriers_; }
  /// Which barriers those are, per foot i: bits kBarrierBitsPerFoot * i + BarrierKind set
  /// when any row of that kind of foot i is active (its foothold or swing region's edges,
  /// its clearance, its collision rows). Zero unless the status was Optimal or Relaxed.
  std::uint64_t activeFootBarriers() const { return active_foot_barriers_; }
  /// Active joint bounds (position or velocity barrier, either side) and active support
  /// polygon edges, of the last filter().
  int activeJointLimits() const { return active_joint_limits_; }
  int activeSupportEdges() const { return active_support_edges_; }
  /// Foot i's BarrierKind bits of activeFootBarriers() (0 to 7).
  static int footBarriers(std::uint64_t active, int i) {
    return static_cast<int>((active >> (kBarrierBitsPerFoot * i)) & 7u);
  }
  /// |a - a_free|_inf: how far the barriers moved the acceleration from the minimiser of
  /// the same cost and equalities without them (0 when no barrier is active; +infinity
  /// when the result is not Optimal: a is then the fallback, not a filtered command).
  double correction() const { return correction_; }
  /// Rows of the last QP: equalities and inequality rows (for logs and tests).
  const DenseQpProblem& lastProblem() const { return qp_; }
  /// Largest slack of the last filter() [m/s^2]: how far the command breaks a barrier row
  /// (0 unless the status was Relaxed).
  double relaxation() const { return relaxation_; }
  /// Foot kinematics of the last filter() that got past its input checks: J_i (rows 3 i ..
  /// 3 i + 2, nv columns, world linear velocity of contact frame i's origin) and the drift
  /// dJ_i v (column i, the frame origin's classical acceleration at a = 0, world axes).
  const Eigen::MatrixXd& footJacobians() const;
  const Eigen::Matrix3Xd& footDrift() const;
  /// Most edges a region may have (see the file comment).
  int maxRegionEdges() const { return max_region_edges_; }
  /// Most prisms the collision terrain may have (rows are sized for them).
  int maxCollisionPrisms() const { return max_collision_prisms_; }

  const CbfQpSettings& settings() const { return settings_; }
  const centroidal::CentroidalRobot& robot() const { return *robot_; }

 private:
  // The stages of filter() (cbf_rows.hpp holds the rows' formulas).
  bool acceptsInput(const Eigen::Ref<const Eigen::VectorXd>& q,
                    const Eigen::Ref<const Eigen::VectorXd>& v, int mode,
                    const FootRegionPlan* regions, const AccelerationTargets& targets,
                    Eigen::Index a_size) const noexcept;
  /// The region constraining foot i's barrier rows (-1: none).
  static int barrierRegion(int mode, const FootRegionPlan* regions, int i) noexcept;
  bool collisionObstacle(const FootRegionPlan* regions, int i, int j) const noexcept;
  int countFootBarriers(int mode, const FootRegionPlan* regions, int i) const noexcept;
  /// Foot i's region, clearance and collision rows from `row` on; returns how many.
  int writeFootBarriers(int mode, const FootRegionPlan* regions, int i, int row) noexcept;
  CbfQpStatus solve(int n_eq, int n_ineq, Eigen::Ref<Eigen::VectorXd> a,
                    const Eigen::Ref<const Eigen::VectorXd>& v) noexcept;
  bool solveRelaxed(int n_eq, int n_ineq, Eigen::Ref<Eigen::VectorXd> a) noexcept;
  void writeFallback(const Eigen::Ref<const Eigen::VectorXd>& v,
                     Eigen::Ref<Eigen::VectorXd> a) const noexcept;
  void clearActiveBarriers() noexcept;
  /// activeFootBarriers(), activeJointLimits() and activeSupportEdges() from `solver`'s
  /// active set (rows tagged by writeFootBarriers and filter()).
  void tallyActiveBarriers(const DenseQpSolver& solver, int n_ineq) noexcept;

  std::shared_ptr<const centroidal::CentroidalRobot> robot_;
  const planning::TerrainModel* terrain_;
  const planning::TerrainModel* collision_terrain_;
  int max_collision_prisms_ = 0;
  int support_mask_ = -1;
  CbfQpSettings settings_;
  double lateral_slip_weight_ = 0.0;
  double relaxation_ = 0.0;
  DenseQpProblem qp_;
  DenseQpSolver qp_solver_;
  int max_region_edges_ = 0;
  DenseQpStatus qp_status_ = DenseQpStatus::InvalidInput;
  int qp_iterations_ = 0;
  int active_barriers_ = 0;
  std::uint64_t active_foot_barriers_ = 0;
  int active_joint_limits_ = 0;
  int active_support_edges_ = 0;
  double correction_ = 0.0;
  // Workspaces (kinematics, Jacobians, drifts), sized at construction.
  struct Work;
  std::unique_ptr<Work> work_;
};

}  // namespace rollstep::control
