#pragma once
// Settings of the 1 kHz control pipeline (paper Sec. 3.3, DESIGN.md section 5): the MPC
// runner's timing, the time-lag refinement, the acceleration feedback gains, the CBF-QP
// safety filter and the internal state integrator, with the OCP's settings (which nest
// the solver's) inside. config/control.yaml lists every key with its default and meaning;
// loadControlSettings reads it (any subset; unknown or repeated keys, wrong types and
// values out of range are errors naming the file, line and key).
//
// Robot-specific numbers (limits, posture, contacts) are not here: they come from the
// URDF and the robot description (robots/<robot>/centroidal.yaml).
#include <Eigen/Core>
#include <array>
#include <set>
#include <string>

#include "rollstep/centroidal/ocp_settings.hpp"
#include "rollstep/common/enum_names.hpp"
#include "rollstep/common/settings_table.hpp"
#include "rollstep/common/yaml_tree.hpp"

namespace rollstep::control {

using Vector6 = Eigen::Matrix<double, 6, 1>;

/// How the MPC is run next to the real-time loop.
enum class MpcTiming {
  /// A solve every MpcSettings::period of the loop's own (simulated) time, started from the
  /// state of that tick and made available MpcSettings::latency later: bit-for-bit
  /// reproducible, what the tests use.
  Deterministic,
  /// A real thread solving as fast as it can on the latest state (wall clock), as on the
  /// robot; results are not reproducible.
  Asynchronous,
};
constexpr std::array<EnumName<MpcTiming>, 2> enumNames(MpcTiming) {
  return {{{MpcTiming::Deterministic, "deterministic"}, {MpcTiming::Asynchronous, "asynchronous"}}};
}
const char* toString(MpcTiming timing);

/// How the joint commands are made from the filtered accelerations.
enum class IntegratorMode {
  /// The internal state integrator: integrates the filtered accelerations into its own
  /// state and blends the measured state in every tick with the time constants below
  /// (paper Fig. 8).
  Internal,
  /// Naive state feedback, for the comparison of the paper's Fig. 8: the commanded state
  /// restarts from the measured state whenever a new MPC solution is taken (as a controller
  /// that commands the MPC's plan from the latest measurement does) and is integrated
  /// open-loop in between; the time constants are not used.
  Naive,
};
constexpr std::array<EnumName<IntegratorMode>, 2> enumNames(IntegratorMode) {
  return {{{IntegratorMode::Internal, "internal"}, {IntegratorMode::Naive, "naive"}}};
}
const char* toString(IntegratorMode mode);

struct MpcSettings {
  MpcTiming timing = MpcTiming::Deterministic;
  /// [s] Deterministic: a solve every period of loop time. Asynchronous: the least time
  /// between the starts of two solves (0: back to back).
  double period = 0.02;
  /// [s] Deterministic: a solve's result is used from this long after the state it started
  /// from (the modelled solve time); a multiple of the control period is exact.
  double latency = 0.02;
  /// Iteration limit of the converging solve from a cold start that gives the first
  /// solution (at initialisation, not real-time).
  int initial_iterations = 100;
  /// [s] Stale-solution watchdog: once the solution in use is older than this (its state's
  /// time to now: a stalled or failing MPC), the pipeline holds a safe posture (the
  /// reference frozen at that moment, at rest) until a new solution arrives.
  double max_solution_age = 0.2;
  /// [m] Reference leash: at every solve the base reference is kept within this distance of
  /// the measured base (x, y), moved rigidly when the robot falls further behind or aside
  /// (planning::BaseReference::follow); 0: off, the reference runs open loop from its start.
  double reference_leash = 0.0;
  /// [rad] The same for the yaw; 0: off.
  double reference_leash_yaw = 0.0;
  /// [m] The same for the sideways part of the robot's offset from its reference (across
  /// the reference's heading) alone: a robot that moves sideways only by slip and yaw falls
  /// behind a sideways command, and a reference that ran on sideways places the footholds
  /// beside legs that cannot reach sideways; 0: off (a sideways command is then tracked
  /// more closely: the robot catches up).
  double reference_leash_lateral = 0.0;
};

struct RefinementSettings {
  /// [s] Span of a new solution re-integrated from the latest state with its optimal inputs
  /// (paper Fig. 7); beyond it the solution's own states are used, shifted by the offset at
  /// the end of the span. At least the MPC period plus latency is sensible.
  double horizon = 0.12;
  /// Explicit Euler steps per node interval of the solution (1: the OCP's own transcription).
  int substeps = 1;
};

/// Acceleration command = feedforward (from the refined solution) + kp (reference -
/// internal state) + kd (reference velocity - internal velocity), per task.
struct FeedbackSettings {
  Vector6 base_kp = (Vector6() << 100, 100, 100, 100, 100, 100).finished();  ///< [1/s^2]
  Vector6 base_kd = (Vector6() << 20, 20, 20, 20, 20, 20).finished();        ///< [1/s]
  double foot_kp = 400.0;  ///< [1/s^2], every axis
  double foot_kd = 40.0;   ///< [1/s]
  double joint_kp = 100.0;
  double joint_kd = 20.0;
};

/// The CBF-QP safety filter (cbf_qp.hpp). Second-order barriers h(q) >= 0 are imposed as
/// h'' + 2 gamma h' + gamma^2 h >= 0 (a critically damped exponential CBF), first-order ones
/// as h' + gamma h >= 0.
struct CbfQpSettings {
  // Task weights of the cost (diagonal, on the squared acceleration errors).
  Vector6 base_weight = (Vector6() << 1, 1, 1, 1, 1, 1).finished();
  double foot_weight = 1.0;
  double joint_weight = 0.01;
  /// Added to every variable's diagonal (keeps the Hessian definite) [-].
  double damping = 1e-6;
  /// [1/s] Contact consistency: a stance foot's kept velocity rows (vertical, drive-wheel
  /// lateral; the OCP's side-by-side rule) are equalities a_row = -contact_gain v_row.
  double contact_gain = 20.0;
  /// Weight of the stance rows the side-by-side rule frees (a cost instead of a row).
  double freed_contact_weight = 100.0;
  double joint_position_gamma = 20.0;  ///< [1/s] second-order, URDF position limits
  double joint_position_margin = 0.0;  ///< [rad or m] kept from each position limit
  double joint_velocity_gamma = 50.0;  ///< [1/s] first-order, URDF velocity limits
  double velocity_limit_scale = 1.0;   ///< share of the URDF velocity limits, (0, 1]
  double region_gamma = 10.0;          ///< [1/s] second-order, foothold and swing regions
  double clearance_gamma = 20.0;       ///< [1/s] second-order, swing wheel above the terrain
  double clearance = 0.0;              ///< [m] least height of a swing wheel's bottom
  int max_iterations = 100;            ///< active-set changes per solve
  /// [s] Fallback when the QP fails: joint accelerations -v_J / fallback_brake_time (the
  /// commanded joints brake to rest where they are), base acceleration 0.
  double fallback_brake_time = 0.1;
  /// When the barriers have no common point (the QP is infeasible), a second QP relaxes
  /// them instead of braking: every barrier row r gets a slack s_r >= 0 (C_r a + s_r >= l_r)
  /// with the cost 0.5 relaxation_weight s_r^2 (rows are in m/s^2 of a point's
  /// acceleration, as the foot cost), so the command breaks the barriers as little as it
  /// can while the contact rows and joint bounds hold exactly. 0: off (brake at once).
  double relaxation_weight = 1e4;
  // Barrier families of the CBF-QP baseline (DESIGN.md section 6), each off when its gamma
  // is 0 (the defaults: the NMPC pipeline does not use them). clearance_gamma = 0 also
  // turns the region-plane clearance above off (its height jumps at a region edge; the
  // smoothed collision barrier replaces it in the baseline).
  /// [1/s] second-order: the COM's ground projection inside the support polygon (0: off).
  double support_gamma = 0.0;
  double support_margin = 0.0;  ///< [m] kept between the COM projection and every edge
  /// [1/s] second-order: leg/terrain collision, smoothed distance of each wheel to every
  /// terrain prism higher than the ground under it (collision_distance.hpp; 0: off).
  double collision_gamma = 0.0;
  double collision_sharpness = 100.0;  ///< [1/m] k of the log-sum-exp smooth maximum
  double collision_clearance = 0.0;    ///< [m] kept between a wheel and an obstacle
  double collision_range = 0.3;        ///< [m] prisms farther than this give no row
};

/// The reactive planner of the CBF-QP baseline (control/baseline_pipeline.hpp): the
/// paper's previous controller (Takasugi et al. 2023), no MPC. Its CBF-QP, feedback gains
/// and integrator are the sections above (config/baseline.yaml is its tuning).
struct BaselineSettings {
  double gait_period = 1.6;       ///< [s] one trot cycle
  double trot_duty = 0.6;         ///< stance share of the cycle, in (0.5, 1)
  double swing_clearance = 0.05;  ///< [m] swing apex above the higher end of the swing
  /// [m] a swing lands on the terrain this far ahead of its nominal foothold (along the
  /// command) when that terrain is higher or lower: the foot steps onto the next surface
  /// instead of stopping at its edge.
  double foothold_lookahead = 0.12;
  /// [m] a swing down onto a lower surface aims this far ahead of its nominal foothold
  /// (along the command): its wheel must clear the edge by its radius to come down.
  double descent_offset = 0.15;
  /// [m] the body height follows the highest terrain under the support polygon widened by
  /// this much along the command (it rises before the feet reach a step).
  double height_lookahead = 0.3;
  double height_offset = 0.02;    ///< [m] added to the nominal height while the terrain differs
  double max_height_rate = 0.25;  ///< [m/s] rate limit of the body height reference
  /// [m] the foothold regions are the terrain's surfaces shrunk by this (they bound the
  /// wheel centres; whoever builds the baseline's terrain applies it).
  double foothold_margin = 0.03;
  double stance_foot_gain = 1.0;  ///< scales foot_kp, foot_kd for stance feet (rolling wheels)
  /// [m] The base x, y reference runs along the command, at most this far from the internal
  /// state, on level ground (reactive_planner.hpp): the body keeps the commanded speed
  /// instead of settling below it. 0: x, y of the internal state (myopic, no position
  /// along the command).
  double position_leash = 0.0;
};

struct IntegratorSettings {
  IntegratorMode mode = IntegratorMode::Internal;
  /// [s] Time constants of the blend of the measured state into the internal one: each tick
  /// moves the internal position (velocity) by dt / tau of its difference to the measured one.
  double position_time_constant = 0.5;
  double velocity_time_constant = 0.2;
  /// [-] Share of the servos' static deflection added to the joint position commands: a
  /// position servo of stiffness K carrying torque tau sits tau / K short of its command, so
  /// the command becomes q + gain tau / K with tau the static joint torque of the planned
  /// contact forces (model::computeStaticTorque) and K the robot description's
  /// servo_stiffness. Without it the body sags under the servos' compliance, more on three
  /// legs than on six, i.e. at every lift-off of a trot. The CBF-QP baseline, which plans no
  /// forces, takes the weight spread evenly over its stance feet. 0: off.
  double deflection_compensation = 1.0;
};

/// Drive-wheel velocity commands under skid steering (pipeline.hpp, "Skid steering"). Used
/// only when the OCP lets the drive wheels slide sideways (ocp.lateral_slip_weight > 0); the
/// defaults change nothing even then.
struct WheelSettings {
  /// [-] Effective track width over the geometric one (Mandow et al. 2007): the share of a
  /// drive wheel's ground speed due to the commanded yaw rate is multiplied by it, because
  /// the sliding wheels realize only about 1 / factor of the yaw rate their speed
  /// difference gives without slip. 1: no compensation.
  double skid_track_factor = 1.0;
  /// [-] Feedback of the yaw-rate error (commanded, i.e. the internal state's, minus
  /// measured, world z) into the same differential wheel speeds: the yaw rate the wheels
  /// are commanded for is factor * w_cmd + gain * (w_cmd - w_measured). 0: none.
  double skid_yaw_rate_gain = 0.0;
  /// [-] Feedback of the base's planar velocity error (the base reference's, i.e. the
  /// command's, minus measured, world x y) into the drive-wheel speeds: each wheel gets
  /// gain * error along its heading. Sliding wheels whose forces cancel leave the body's
  /// velocity to whatever breaks that balance (a wheel unloaded for a moment), and the
  /// commands, taken at the internal state and planned from the measured one, then follow
  /// the drift instead of braking it. 0: none.
  double skid_velocity_gain = 0.0;
  /// [1/s] Same for the planar position error (the base reference's minus measured): a
  /// drift that happened is driven back. 0: none.
  double skid_position_gain = 0.0;
};

struct ControlSettings {
  double control_period = 0.001;  ///< [s] the real-time tick (1 kHz)
  MpcSettings mpc;
  RefinementSettings refinement;
  FeedbackSettings feedback;
  CbfQpSettings cbf_qp;
  IntegratorSettings integrator;
  WheelSettings wheels;
  BaselineSettings baseline;  ///< only the CBF-QP baseline reads it
  /// Nested `ocp:` mapping (config/ocp.yaml's keys, its `solver:` nested in turn). The
  /// pipeline runs the solver in real-time mode whatever ocp.solver.mode says.
  centroidal::OcpSettings ocp;
};

/// Throws std::invalid_argument naming the first bad field (what the YAML loader checks).
void checkSettings(const ControlSettings& settings);

/// Reads ControlSettings from YAML text (a mapping of the sections above, any subset of
/// keys). Errors: std::runtime_error "control settings <source>: line L: <key>: <what>".
/// A top-level `extends: FILE` starts from FILE's settings instead of the defaults (FILE
/// relative to the directory of the file that names it; for text, to the working
/// directory; `library:NAME` is the library's config/NAME, $ROLLSTEP_CONFIG_DIR/NAME when
/// that is set), and the keys given here override them one by one (`ocp:` and its `solver:`
/// too); chains up to 8 files deep.
ControlSettings parseControlSettings(const std::string& yaml_text, const std::string& source_name);
/// Same, from a file; `sections_given` (when not null) receives the top-level keys the file
/// or a file it extends gives ("baseline", "mpc", ...).
ControlSettings loadControlSettings(const std::string& yaml_file,
                                    std::set<std::string>* sections_given = nullptr);
/// The settings of a mapping inside another file (a run spec's `control:`), read over
/// `start` (the defaults; an `extends:` replaces it) through `reader` (its head names the
/// file); keys are named prefix + key ("control.mpc.period") in errors; `extends:` is
/// relative to base_directory ("": the working directory). A null node gives `start`.
ControlSettings readControlSettings(const yaml::Node& node, settings::Reader& reader,
                                    const std::string& prefix,
                                    const std::string& base_directory = "",
                                    const ControlSettings& start = ControlSettings{});
/// Every key with its value, read back by parseControlSettings exactly; `indent` in front
/// of every line (a section of another file).
std::string toYaml(const ControlSettings& settings, const std::string& indent = "");

}  // namespace rollstep::control
