#pragma once
// Settings of the full-centroidal OCP (weights, gains, limits, horizon) and the robot's
// description for it, both read from YAML.
//
// Two files, two owners: the OCP settings (config/ocp.yaml lists every key with its
// default and meaning) are the controller's tuning and are generic; the robot description
// (robots/<robot>/centroidal.yaml) holds what is specific to one robot: its URDF, contact
// frames, drive wheels, side-by-side pairs, the contact offset, the nominal posture and
// the foot groups of its gaits. Robot-specific numbers never appear in code.
#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "rollstep/common/settings_table.hpp"
#include "rollstep/common/yaml_tree.hpp"
#include "rollstep/solver/solver.hpp"

namespace rollstep::centroidal {

/// Every weight is a diagonal entry of a least-squares cost 0.5 r^T W r (running costs are
/// integrated over dt). Defaults are the values of config/ocp.yaml: the NMPC's default
/// behaviour, which walks on level ground and trots up and down steps at any commanded
/// speed (the climbing values below and the speed rule; how each was found:
/// docs/CLIMBING.md). `rollstep sim`, `rollstep plan` and the Python bindings all start
/// from them.
struct OcpSettings {
  // --- horizon ---------------------------------------------------------------------------
  int horizon = 100;  ///< N, nodes of the horizon (1..10000)
  double dt = 0.015;  ///< [s] node step (> 0); horizon length = N dt (1.5 s)
  // --- costs -----------------------------------------------------------------------------
  /// Base local velocity tracking v_b(x, u) - v_ref: [vx vy vz wx wy wz].
  Eigen::Matrix<double, 6, 1> base_velocity_weight =
      (Eigen::Matrix<double, 6, 1>() << 10.0, 10.0, 300.0, 5.0, 100.0, 5.0).finished();
  /// State tracking x (-) x_ref(t): base position (world-aligned, local tangent), base
  /// orientation, every joint position, centroidal momentum [linear; angular].
  Eigen::Vector3d base_position_weight = Eigen::Vector3d(100.0, 100.0, 2000.0);
  Eigen::Vector3d base_orientation_weight = Eigen::Vector3d(100.0, 100.0, 100.0);
  double joint_position_weight = 5.0;
  Eigen::Matrix<double, 6, 1> momentum_weight =
      (Eigen::Matrix<double, 6, 1>() << 1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3).finished();
  /// Input tracking u - u_ref(t): joint velocities and contact forces (u_ref: stance
  /// normal forces carry the weight equally).
  /// 2.5: with 0.1 a stance wheel, free to roll along, chattered at +-2 m/s node to node and
  /// the Euler integration drifted it up by centimetres (the step20 traverse).
  double joint_velocity_weight = 2.5;
  double force_weight = 0.001;
  /// Stance velocities the side-by-side rule frees from the equalities (z, drive-wheel
  /// lateral) as a cost: [(m/s)^-2] (StanceRows::Freed in contact_equalities.hpp says why).
  double freed_stance_velocity_weight = 1e5;
  /// Lateral velocity of the stance drive wheels [(m/s)^-2]. 0 (the paper): a drive wheel
  /// cannot slide sideways, an equality of the side-by-side rule. > 0: every stance drive
  /// wheel's lateral velocity is a least-squares cost of this weight instead, so the wheels
  /// may slide sideways: skid steering. Four drive wheels with fixed headings at the corners
  /// (Tachyon 3) can only turn on the spot that way: with no sideways slip the front and
  /// rear axles would need two centres of rotation.
  double lateral_slip_weight = 0.0;
  /// The terminal cost is the state tracking cost times this factor (>= 0).
  double terminal_weight_scale = 10.0;
  // --- equalities ------------------------------------------------------------------------
  /// [1/s] Kp of the swing height equality (>= 0); 50 (1 - Kp dt = 0.25): with 20 the
  /// Euler-integrated swing lagged its spline and a wheel touched down 7.5 mm low.
  double swing_height_gain = 50.0;
  /// [m/s] Saturation of that feedback, max_correction tanh(Kp e / max_correction) (>= 0;
  /// 0: none): a foot far from its spline is asked for at most this much extra vertical
  /// speed, so that the equality stays compatible with the joint velocity bounds.
  double swing_height_max_correction = 0.1;
  // --- inequalities ----------------------------------------------------------------------
  double friction_coefficient = 0.6;  ///< mu of the friction pyramid (> 0), below the scene's
  double min_normal_force = 0.0;      ///< [N] lower bound on a stance normal force (>= 0)
  double torque_limit_scale = 1.0;    ///< share of the effort limits used, in (0, 1]
  double joint_limit_margin = 0.01;   ///< [rad or m] kept from each joint position limit (>= 0)
  double velocity_limit_scale = 1.0;  ///< share of the joint velocity limits used, in (0, 1]
  /// State-only inequalities (joint positions, foothold and swing regions) as soft
  /// (relaxed barrier) rows: they may be violated where the horizon starts infeasible.
  /// Off by default: a soft row's fixed-weight barrier keeps pushing at the solution (the
  /// knees work 5 cm from their stop: standing moved 2 % of the weight between feet).
  bool soft_state_constraints = false;
  /// The foothold rows alone (stance and swing regions) as relaxed-barrier rows; the joint
  /// position bounds stay hard. For a terrain that changes under the horizon (perception):
  /// a new map can move a region away from where a future stance must be, and a hard row
  /// that no iterate can meet then wrecks the whole real-time iteration, its first nodes
  /// included. A soft row is violated there instead, until the footholds are planned
  /// anew. The joint bounds are the robot's own and stay hard: soft, their stiff relaxed
  /// barrier left the cold first solve stuck (line search steps of 1e-4, then Infeasible)
  /// where the hard rows converge. Off by default; soft_state_constraints implies it.
  bool soft_region_constraints = false;
  /// The joint velocity bounds (inputs) as relaxed-barrier rows too (with soft_relaxation
  /// and soft_weight). Off by default. In a real-time iteration a hard velocity bound that
  /// the linearisation cannot meet (a swing spline or the measured state asking a knee for
  /// more than its limit) cuts the whole step by the fraction to the boundary, so that the
  /// iterate hardly moves for as long as the conflict lasts.
  bool soft_velocity_limits = false;
  double soft_relaxation = 1e-3;  ///< relaxed barrier delta (> 0)
  double soft_weight = 1e-3;      ///< relaxed barrier weight (> 0)
  // --- planning inputs -------------------------------------------------------------------
  /// [m] swing apex above the higher end (>= 0). The knees stand 5 cm off their stop: a
  /// swing higher than that needs the hips or the body (0.08 left a static walk infeasible).
  double swing_clearance = 0.03;
  /// Apex placement of the swing height spline, in (0, 0.5] (planning::SwingHeightSpline):
  /// 0.5 = mid-swing (the paper); less lets the apex of a swing up a step move later, to
  /// rise / (rise + fall) of the swing but no further than 1 - margin, so that the knee
  /// is not asked for a faster rise than its velocity limit allows.
  double swing_apex_margin = 0.2;
  /// [m] The base height reference's terrain (planning::BaseReferenceConfig): 0 averages the
  /// terrain under the nominal feet; > 0 takes the highest terrain within this distance of
  /// a nominal foot along the travel, lowered by base_height_slope per metre, so that the
  /// body rises before a step up and comes down after a step down. In [0, 10].
  double base_height_reach = 0.45;
  double base_height_slope = 0.5;  ///< [-] grade of that ramp, in [0, 100]
  /// The base velocity cost's vertical reference is that ramp's rate (planning::
  /// BaseReference::velocityAt) instead of 0, so that a large vertical-rate weight damps
  /// the trot's bobbing without holding the body back on the ramps. Needs
  /// base_height_reach > 0 (otherwise the reference has no rate and this changes nothing).
  bool base_height_rate = true;
  /// The current stances' regions and heights, and the lift-off end of the swings under
  /// way, from where the feet stand in the measured state (CentroidalOcp::anchorStanceFeet,
  /// planning::FootReferencePlanner::anchorStance) instead of their nominal footholds,
  /// which a robot lagging its base reference has not reached. Off by default (when on,
  /// the step20 climb on the estimator's state fell; on perception it helps, see
  /// config/nmpc_perception.yaml).
  bool anchor_stance_feet = false;
  /// The touch-down region of each swing under way stays the one chosen when the swing was
  /// first planned after its lift-off (planning::FootReferencePlanner::latchTouchdown, by
  /// CentroidalOcp::anchorStanceFeet): a new terrain or the gap rule cannot switch it mid-
  /// swing from up onto a step to level before it. Off by default (see
  /// config/nmpc_perception.yaml).
  bool latch_touchdowns = false;
  /// [m] Late touch-downs (CentroidalOcp::landLateFeet): a foot whose stance has begun while
  /// its contact point is still more than this above the stance's surface (in the measured
  /// state) stays in swing and comes down to the surface first, instead of being held in
  /// the air by the stance's zero vertical velocity. 0: off. In [0, 1].
  double late_touchdown_tolerance = 0.01;
  /// [m/s] Mean descent speed of such a landing (its duration: height / speed, at least two
  /// nodes). In (0, 100].
  double late_touchdown_speed = 0.5;
  /// The longest delay of a stance's start, as a share of the swing before it; later, the
  /// stance begins wherever the foot is. In [0, 10].
  double late_touchdown_max_delay = 0.5;
  /// [m] A nominal foothold in a gap between (shrunk) regions goes onto the region ahead
  /// along the travel when that begins within this distance (planning::FootReferenceConfig::
  /// gap_reach); 0: onto the nearest region, which at a step edge is the one the foot is
  /// leaving, so it stops at that region's edge until a later swing. In [0, 10].
  double foothold_gap_reach = 0.2;
  /// [s] The longest the gait may wait, every foot in stance and rolling with the base,
  /// so that a swing that would touch down on the brink of a step down steps past it
  /// instead (planning::planEdgeHolds; needs foothold_gap_reach across the gap); 0:
  /// never (the paper's fixed gait timing). In [0, 10].
  double step_down_max_hold = 0.9;
  /// [s] Such a wait begins at least this long after the state a plan starts from, so that
  /// the real-time side has the plan (and its gait clock) before it begins: at least the
  /// oldest plan it uses (control.yaml's mpc.max_solution_age). In [0, 10].
  double edge_hold_lead = 0.2;
  /// [m] How far short of the lower surface's foothold region a held swing's nominal
  /// touch-down may be (the leg reaches that far forward and down onto the step): less
  /// waits longer and lands the foot nearer under its hip. In [0, 1].
  double step_down_reach = 0.12;
  /// [s] The same before a step up: a swing that would touch down on the surface before it,
  /// short of its end, waits until it lands step_up_setback short of that end, so that the
  /// next swing climbs from close to the riser. 0: never. In [0, 10].
  double step_up_max_hold = 1.5;
  /// [m] See step_up_max_hold. In [0, 1].
  double step_up_setback = 0.02;
  /// [m] A swing whose nominal touch-down lies in the gap before a riser (the foothold rule
  /// sends it up onto the step) waits, at most step_up_max_hold, until it is at most this
  /// short of the step's foothold region: the leg clears the riser first and cannot reach
  /// far ahead of its hip. 0: no such wait. In [0, 1].
  double step_up_reach = 0.0;
  /// [m] The foothold regions are the terrain's surfaces shrunk by the robot's contact
  /// offset (the wheel radius: the regions bound the wheel centres) plus this clearance, so
  /// that a wheel keeps off the edges and risers; used where the regions are made from a
  /// terrain (`rollstep plan`, `rollstep sim --controller nmpc`). In [0, 1].
  double foothold_edge_clearance = 0.01;
  double gait_period = 1.8;  ///< [s] one gait cycle (> 0)
  double trot_duty = 0.6;    ///< stance share of a trot cycle, in (0, 1)
  double walk_duty = 0.85;   ///< stance share of a static-walk cycle, in (0, 1)
  /// [s] one static-walk cycle (> 0): each foot swings (1 - walk_duty) of it, 0.36 s here;
  /// with gait_period's 0.8 s a 0.12 s swing would need knee speeds above the limit.
  double walk_period = 2.4;
  // --- speed adaptation (planning/speed_adaptation.hpp) ----------------------------------
  /// The trot's timing from the commanded speed and the robot's limits, and the command
  /// slowed down near steps to what that timing can cross and ramped from rest (the
  /// controller applies it when it is given its command schedule: sim::NmpcController,
  /// control::ControlPipeline). With it, gait_period is ignored for a trot and trot_duty is
  /// its stance share at low speed. With it too, the sideways part of a command is held back
  /// while a foot crosses a step (planning::holdSidewaysAtSteps, within step_speed_reach).
  /// Off: the fixed timing of gait_period (the paper's), nothing held.
  bool speed_adaptation = true;
  /// [m] The tallest step a trot's swing is timed to climb (with swing_clearance above it).
  /// In (0, 2].
  double max_step_height = 0.2;
  /// Share of the knees' velocity limit the swing's steepest rise may ask, in (0, 1]: the
  /// rest is left to the swing height feedback and the servos' lag.
  double swing_knee_speed_share = 0.75;
  /// Share of the hips' sweep (the wheel's travel over the narrowest hip range at the
  /// nominal leg length) the body may pass over a stance foot held at a riser, in (0, 10].
  double stance_stroke_share = 1.0;
  /// [m] Derived, not a key of the file: the stance stroke the speed rule found for the
  /// robot (stance_stroke_share of the hips' sweep), set with the trot's timing
  /// (control::timeTrotForSchedule); the edge holds never carry the body further than this
  /// over a stance foot stopped at a riser (planning::EdgeHoldConfig::stance_stroke). 0:
  /// unchecked (no speed rule).
  double edge_hold_stance_stroke = 0.0;
  /// [m] A step counts for the slowdown when it lies within this distance ahead of or behind
  /// a nominal foot along the travel. In [0, 10].
  double step_speed_reach = 0.3;
  /// [m/s^2] Largest change of the reference speed (from rest, between commands, into and
  /// out of a slowdown); 0: none. In [0, 100].
  double command_acceleration = 0.5;
  /// The approach to the first step timed to the gait where the gait cannot wait at an edge
  /// (a trot with no phase of every foot in stance, as at the step speed limit): the command
  /// dips before the step so that the first touch-down onto it lands at most a quarter
  /// period's travel past the riser (planning/speed_adaptation.hpp). Needs speed_adaptation.
  bool approach_timing = true;
  /// With approach_timing: every next row of feet meeting a riser (the hind row's climb, each
  /// row's step down) is timed the same way, by a dip between the touch-downs timed before
  /// and its own, and every edge timed lands at least half its target past the riser (clear
  /// of the band where no foothold lies); false: the first touch-down onto a step only.
  bool approach_timing_every_edge = false;
  // --- the solver ------------------------------------------------------------------------
  /// Nested `solver:` mapping (config/solver.yaml's keys). Defaults: the solver's, but a
  /// Gauss-Newton Hessian (exact_hessian false) as in the paper: on Tachyon 3 standing it
  /// converges in the same 9 iterations as the exact one, 15x faster (finite differences
  /// of 54 gradient columns per node).
  solver::SolverSettings solver = defaultSolverSettings();

  static solver::SolverSettings defaultSolverSettings() {
    solver::SolverSettings s;
    s.exact_hessian = false;
    s.realtime_iterations = 2;
    return s;
  }
};

/// Reads OcpSettings from YAML text: a mapping of the keys above, any subset; `solver:` a
/// nested mapping of solver settings. Unknown or repeated keys, wrong types, vectors of the
/// wrong length and values out of range are errors: std::runtime_error
/// "OCP settings <source>: line L: <key>: <what>".
OcpSettings parseOcpSettings(const std::string& yaml_text, const std::string& source_name);
OcpSettings loadOcpSettings(const std::string& yaml_file);
/// The table of OcpSettings' keys (common/settings_table.hpp), `solver` a nested section.
const settings::Table<OcpSettings>& ocpSettingsTable();
/// Reads an `ocp:` mapping nested in another configuration file into `settings` (keys not
/// given keep their values; `prefix` names the keys: "ocp." names ocp.horizon); errors go
/// through `reader`: "<head>line L: <prefix><key>: <what>".
void readOcpSettings(const yaml::Node& node, OcpSettings& settings, settings::Reader& reader,
                     const std::string& prefix);
/// The same from a node of a parsed document, over the defaults or over `base`; errors:
/// std::runtime_error "<description> <source_name>: line L: <key_path><key>: <what>" (the
/// nested solver keys too: <key_path>solver.<key>).
OcpSettings parseOcpSettings(const yaml::Node& node, const std::string& source_name,
                             const std::string& key_path = "",
                             const std::string& description = "OCP settings");
OcpSettings parseOcpSettings(const yaml::Node& node, const OcpSettings& base,
                             const std::string& source_name, const std::string& key_path,
                             const std::string& description);
/// Every key, one "key: value" line each (vectors as flow lists), `solver:` nested; read
/// back by parseOcpSettings exactly.
std::string toYaml(const OcpSettings& settings);

/// What the OCP needs to know about one robot besides its URDF's rigid bodies.
struct RobotOcpDescription {
  std::string urdf;  ///< path; relative paths are relative to the description file
  std::vector<std::string> contact_frames;             ///< in mode-mask bit order
  std::vector<std::string> drive_wheels;               ///< subset of contact_frames
  std::vector<std::array<std::string, 2>> side_pairs;  ///< first keeps the velocity rows
  double contact_offset = 0.0;              ///< [m] wheel radius if the frames are centres
  Eigen::VectorXd nominal_joint_positions;  ///< q_J,ref (nj, URDF joint order)
  /// Stiffness of each joint's position servo (nj, URDF joint order) [N m/rad or N/m], for
  /// the controller's deflection compensation; empty: not known.
  Eigen::VectorXd servo_stiffness;
  std::vector<std::string> trot_group_a, trot_group_b;  ///< the two trot groups
  std::vector<std::string> walk_order;                  ///< static walk: one foot at a time
  std::string source;  ///< where it was read from (the file): errors found later name it
};

/// Reads a robot description (keys: urdf, contact_frames, drive_wheels, side_pairs,
/// contact_offset, nominal_joint_positions, servo_stiffness, trot_groups, walk_order; all
/// required but drive_wheels, side_pairs, contact_offset, servo_stiffness, trot_groups and
/// walk_order). Names are checked against each other here (trot groups holding every
/// contact frame once, a walk order listing each) and against the URDF when the OCP is
/// built (one entry per joint, the posture inside the joint limits: std::invalid_argument
/// "robot description <source>: ..."). Errors: std::runtime_error "robot description
/// <source>: line L: <key>: <what>".
RobotOcpDescription parseRobotOcpDescription(const std::string& yaml_text,
                                             const std::string& source_name,
                                             const std::string& base_directory = "");
RobotOcpDescription loadRobotOcpDescription(const std::string& yaml_file);
/// The keys of a robot description file, one line each with its default, unit and range.
std::string documentedRobotDescription();

/// [m] How far the foothold regions made from a terrain keep inside its surfaces: the
/// robot's contact offset (the regions bound the wheel centres) plus
/// settings.foothold_edge_clearance. The one place that sum is written (`rollstep plan`,
/// `rollstep sim --controller nmpc`, the perceived terrains).
inline double footholdRegionMargin(const RobotOcpDescription& robot, const OcpSettings& settings) {
  return robot.contact_offset + settings.foothold_edge_clearance;
}

}  // namespace rollstep::centroidal
