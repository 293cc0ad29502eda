#pragma once
// Small nonlinear optimal control problems written with the ocp API, reusable by the
// solver tests, the Ipopt comparison, benchmarks and examples:
//   - cart-pole swing-up (Euclidean, RK4, force bounds, track limits, terminal cost);
//   - unicycle driving to a goal around circular obstacles, with a speed-profile
//     state-input equality v = k (goal - p) . heading and input bounds;
//   - a rigid body on SE(3) x R^6 (pose + body twist, body wrench input, explicit
//     Euler on the manifold) steered to a target pose;
//   - many active bounds (issue 17): a planar two-link arm with torque, joint and
//     velocity limits and an end-effector keep-out disc; a planar quadrotor with rotor
//     thrust and tilt bounds flying around keep-out discs; a kinematic bicycle with
//     steering, acceleration and speed bounds around a keep-out disc.
// Every ContinuousDynamics / Residual here has analytic derivatives (checked against
// central finite differences on the manifold in nonlinear_problems_test.cpp).
// The file also holds small helpers shared by the tests: finite differences on a state
// space, rollouts, and an independent KKT residual of a multiple-shooting solution.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "rollstep/ocp/dynamics.hpp"
#include "rollstep/ocp/problem.hpp"
#include "rollstep/ocp/residual.hpp"
#include "rollstep/ocp/state_space.hpp"

namespace rollstep::nltest {

using ocp::ConstVecRef;
using ocp::MatRef;
using ocp::MatrixXd;
using ocp::VecRef;
using ocp::VectorXd;

/// A composed problem with its initial state and a default initial guess.
struct ProblemInstance {
  std::string name;
  std::shared_ptr<ocp::OptimalControlProblem> problem;
  VectorXd x0;                     ///< initial state (representation)
  VectorXd x_goal;                 ///< target state (representation)
  std::vector<VectorXd> xs_guess;  ///< N+1 states
  std::vector<VectorXd> us_guess;  ///< N inputs
};

// =====================================================================================
// Cart-pole: x = [p, theta, p_dot, theta_dot] (theta = 0 hanging down, pi upright),
// u = [F] horizontal force on the cart.
struct CartPoleParams {
  double cart_mass = 1.0;
  double pole_mass = 0.3;
  double length = 0.5;  ///< pivot to point mass
  double gravity = 9.81;
};

class CartPoleDynamics final : public ocp::ContinuousDynamics {
 public:
  explicit CartPoleDynamics(const CartPoleParams& p = {});
  std::unique_ptr<ocp::DynamicsData> createData() const override;
  void calc(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u, ocp::DynamicsData& d,
            VecRef xdot) const override;
  void calcDiff(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u, ocp::DynamicsData& d,
                MatRef fx, MatRef fu) const override;
  const CartPoleParams& params() const { return p_; }

 private:
  CartPoleParams p_;
};

struct CartPoleOptions {
  CartPoleParams params;
  int horizon = 50;
  double dt = 0.05;
  bool rk4 = true;            ///< false: explicit Euler
  double force_limit = 20.0;  ///< |F| <= force_limit (input bounds)
  double track_limit = 2.0;   ///< |p| <= track_limit (state bounds); <= 0: none
  double terminal_weight = 200.0;
  double input_weight = 1e-2;
  double state_weight = 1e-1;  ///< running weight on x - x_goal
};
ProblemInstance makeCartPole(const CartPoleOptions& o = {});

// =====================================================================================
// Unicycle: x = [px, py, theta], u = [v, omega].
class UnicycleDynamics final : public ocp::ContinuousDynamics {
 public:
  UnicycleDynamics();
  std::unique_ptr<ocp::DynamicsData> createData() const override;
  void calc(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u, ocp::DynamicsData& d,
            VecRef xdot) const override;
  void calcDiff(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u, ocp::DynamicsData& d,
                MatRef fx, MatRef fu) const override;
};

struct Circle {
  double cx = 0.0, cy = 0.0, radius = 0.0;
};

/// g_i = (x[ix] - cx_i)^2 + (x[iy] - cy_i)^2 - r_i^2 >= 0, one row per circle. State-only.
/// ix, iy are tangent indices of the Euclidean part of the state.
class CircleObstacleResidual final : public ocp::Residual {
 public:
  CircleObstacleResidual(std::shared_ptr<const ocp::StateSpace> space, int nu,
                         std::vector<Circle> circles, int ix = 0, int iy = 1);
  bool dependsOnInput() const override { return false; }
  void calc(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u,
            ocp::ResidualData& d) const override;
  void calcDiff(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u,
                ocp::ResidualData& d) const override;
  const std::vector<Circle>& circles() const { return circles_; }

 private:
  std::vector<Circle> circles_;
  int ix_, iy_;  ///< representation indices
};

/// Speed-profile equality of the unicycle: e = v - v_path(x) with
/// v_path = V tanh(gain * s / V), s = (goal - p) . (cos th, sin th) the distance to the goal
/// along the heading: cruise at V far away, v ~ gain * s near the goal.
/// Row rank 1 in u everywhere (de/dv = 1).
class SpeedProfileResidual final : public ocp::Residual {
 public:
  SpeedProfileResidual(double gain, double cruise_speed, double goal_x, double goal_y);
  void calc(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u,
            ocp::ResidualData& d) const override;
  void calcDiff(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u,
                ocp::ResidualData& d) const override;
  /// The profile speed v_path(x).
  double speed(ConstVecRef x) const;

 private:
  double gain_, cruise_, gx_, gy_;
};

struct UnicycleOptions {
  int horizon = 60;
  double dt = 0.1;
  bool rk4 = true;
  VectorXd x0 = VectorXd::Zero(3);
  double goal_x = 4.0, goal_y = 0.0;
  double speed_gain = 1.0;       ///< speed profile slope near the goal [1/s]
  double cruise_speed = 1.0;     ///< speed profile far from the goal
  double speed_limit = 1.5;      ///< |v| <= speed_limit
  double turn_rate_limit = 2.0;  ///< |omega| <= turn_rate_limit
  std::vector<Circle> hard_obstacles{{2.0, -0.2, 0.5}};
  std::vector<Circle> soft_obstacles{};
  double soft_relaxation = 1e-2;
  double soft_weight = 1e-3;       ///< fixed weight of the soft obstacles' relaxed barrier
  bool terminal_obstacles = true;  ///< hard obstacles also at the terminal node
  double position_weight = 1.0;    ///< running, on p - goal
  /// Running, on omega. With 0.1 the Gauss-Newton iteration (which drops the curvature
  /// -2 z I of the active obstacle rows and lambda^T F'') stalls near KKT 1e-7; with 1.0 it
  /// converges in ~60 iterations.
  double turn_weight = 1.0;
  double terminal_weight = 50.0;  ///< on p - goal
};
ProblemInstance makeUnicycle(const UnicycleOptions& o = {});

// =====================================================================================
// Rigid body on SE(3) x R^6: x = [p, quat xyzw, v_body, w_body], dx = [rho, theta, dv, dw],
// u = [force, torque] in the body frame. m (v' + w x v) = f + m R^T g,
// I w' + w x I w = tau. The tangent velocity is [v, w, v', w'].
struct RigidBodyParams {
  double mass = 2.0;
  Eigen::Vector3d inertia{0.10, 0.15, 0.20};  ///< principal moments (body frame)
  Eigen::Vector3d gravity{0.0, 0.0, 0.0};     ///< world frame
};

class RigidBodyDynamics final : public ocp::ContinuousDynamics {
 public:
  explicit RigidBodyDynamics(const RigidBodyParams& p = {});
  std::unique_ptr<ocp::DynamicsData> createData() const override;
  void calc(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u, ocp::DynamicsData& d,
            VecRef xdot) const override;
  void calcDiff(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u, ocp::DynamicsData& d,
                MatRef fx, MatRef fu) const override;

 private:
  RigidBodyParams p_;
};

struct RigidBodyOptions {
  RigidBodyParams params;
  int horizon = 30;
  double dt = 0.05;
  Eigen::Vector3d target_position{1.0, -0.5, 0.3};
  Eigen::Vector3d target_axis{1.0, 1.0, 0.0};  ///< normalised internally
  double target_angle = 1.5707963267948966;
  double force_limit = 15.0;
  double torque_limit = 1.0;
  double running_pose_weight = 1.0;
  double running_twist_weight = 0.1;
  double input_weight = 1e-2;
  double terminal_pose_weight = 200.0;
  double terminal_twist_weight = 20.0;
};
ProblemInstance makeRigidBody(const RigidBodyOptions& o = {});

// =====================================================================================
// Planar two-link arm (issue 17): x = [q1, q2, dq1, dq2], u = [tau1, tau2]. q1 is the
// angle of link 1 from the world x axis, q2 that of link 2 relative to link 1 (gravity
// along -y). Point masses m1, m2 at the link tips, viscous joint friction:
//   M(q) ddq + C(q, dq) dq + G(q) + b dq = tau,
//   M11 = m1 l1^2 + m2 (l1^2 + 2 l1 l2 cos q2 + l2^2), M12 = m2 (l1 l2 cos q2 + l2^2),
//   M22 = m2 l2^2, C dq = h [-(2 dq1 dq2 + dq2^2), dq1^2] with h = m2 l1 l2 sin q2,
//   G = g [(m1 + m2) l1 cos q1 + m2 l2 cos(q1 + q2), m2 l2 cos(q1 + q2)].
// Derivatives: ddq = M^-1 r(q, dq, tau), d ddq / dq = M^-1 (dr/dq - dM/dq ddq).
struct TwoLinkArmParams {
  double mass1 = 1.0, mass2 = 0.5;      ///< [kg] point masses at the link tips
  double length1 = 0.5, length2 = 0.5;  ///< [m]
  double friction = 0.1;                ///< [N m s / rad] viscous, both joints
  double gravity = 9.81;
};

class TwoLinkArmDynamics final : public ocp::ContinuousDynamics {
 public:
  explicit TwoLinkArmDynamics(const TwoLinkArmParams& p = {});
  std::unique_ptr<ocp::DynamicsData> createData() const override;
  void calc(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u, ocp::DynamicsData& d,
            VecRef xdot) const override;
  void calcDiff(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u, ocp::DynamicsData& d,
                MatRef fx, MatRef fu) const override;
  const TwoLinkArmParams& params() const { return p_; }
  /// G(q): the torque that holds the arm still at q.
  Eigen::Vector2d gravityTorque(double q1, double q2) const;
  /// End-effector (tip of link 2) position.
  Eigen::Vector2d endEffector(double q1, double q2) const;

 private:
  TwoLinkArmParams p_;
};

/// Keep-out discs for the arm's end effector: g_i = |p_ee(q) - c_i|^2 - r_i^2 >= 0, one
/// row per disc. State-only, on x = [q1, q2, ...] (the first two coordinates).
class ArmKeepOutResidual final : public ocp::Residual {
 public:
  ArmKeepOutResidual(int ndx, int nu, double length1, double length2, std::vector<Circle> discs);
  bool dependsOnInput() const override { return false; }
  void calc(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u,
            ocp::ResidualData& d) const override;
  void calcDiff(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u,
                ocp::ResidualData& d) const override;

 private:
  double l1_, l2_;
  std::vector<Circle> discs_;
};

struct TwoLinkArmOptions {
  TwoLinkArmParams params;
  int horizon = 50;
  double dt = 0.04;
  Eigen::Vector2d q_start{-1.2, 0.3};
  Eigen::Vector2d q_goal{1.7, 1.2};
  /// |tau_i| <= limit (input bounds). The shoulder cannot hold the arm out horizontally
  /// (gravity torque up to 9.8 N m): saturated on about a third of the rows.
  Eigen::Vector2d torque_limit{10.0, 3.0};
  /// Joint limits: the elbow's lower one is active at the optimum (it would dip to 0.03).
  Eigen::Vector2d joint_lower{-1.6, 0.1};
  Eigen::Vector2d joint_upper{2.2, 1.22};
  double velocity_limit = 2.5;  ///< |dq_i| <= limit (state bounds)
  /// Centred beyond the arm's reach (1 m) on the unconstrained path: the end effector
  /// must fold under it. (A disc hit head-on traps the default start in a local minimum
  /// pressed against it.)
  std::vector<Circle> keep_out{{0.95, 0.55, 0.2}};
  double state_weight = 1.0;      ///< running, on q - q_goal
  double velocity_weight = 1e-2;  ///< running, on dq
  double input_weight = 1e-2;     ///< running, on tau - G(q_goal)
  double terminal_weight = 100.0;
};
/// Default guess: x_start repeated with the inputs that hold the arm there (clamped to
/// the torque limits).
ProblemInstance makeTwoLinkArm(const TwoLinkArmOptions& o = {});

// =====================================================================================
// Acrobot: the two-link arm with a free shoulder, u = [elbow torque] (underactuated). Its
// swing-up from hanging down (q = (-pi/2, 0)) to upright (q = (pi/2, 0)) must pump energy
// with an elbow torque too weak to lift the links directly: a long, non-convex problem.
class AcrobotDynamics final : public ocp::ContinuousDynamics {
 public:
  explicit AcrobotDynamics(const TwoLinkArmParams& p = {});
  std::unique_ptr<ocp::DynamicsData> createData() const override;
  void calc(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u, ocp::DynamicsData& d,
            VecRef xdot) const override;
  void calcDiff(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u, ocp::DynamicsData& d,
                MatRef fx, MatRef fu) const override;

 private:
  TwoLinkArmDynamics arm_;
};

struct AcrobotOptions {
  TwoLinkArmParams params;
  int horizon = 80;
  double dt = 0.05;
  double torque_limit = 4.0;    ///< |tau| <= limit; lifting link 2 alone takes 2.45 N m
  double velocity_limit = 8.0;  ///< |dq_i| <= limit (state bounds)
  double state_weight = 0.1;    ///< running, on x - x_goal
  double input_weight = 1e-2;
  double terminal_weight = 100.0;
};
/// Default guess: hanging still, zero torque.
ProblemInstance makeAcrobot(const AcrobotOptions& o = {});

// =====================================================================================
// Planar quadrotor (issue 17): x = [px, pz, theta, vx, vz, omega], u = [f1, f2] rotor
// thrusts at +-arm from the centre:
//   m ax = -(f1 + f2) sin theta, m az = (f1 + f2) cos theta - m g,
//   I omega' = arm (f1 - f2).
struct PlanarQuadrotorParams {
  double mass = 1.0;
  double inertia = 0.01;  ///< [kg m^2]
  double arm = 0.15;      ///< [m] rotor to centre
  double gravity = 9.81;
};

class PlanarQuadrotorDynamics final : public ocp::ContinuousDynamics {
 public:
  explicit PlanarQuadrotorDynamics(const PlanarQuadrotorParams& p = {});
  std::unique_ptr<ocp::DynamicsData> createData() const override;
  void calc(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u, ocp::DynamicsData& d,
            VecRef xdot) const override;
  void calcDiff(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u, ocp::DynamicsData& d,
                MatRef fx, MatRef fu) const override;
  const PlanarQuadrotorParams& params() const { return p_; }

 private:
  PlanarQuadrotorParams p_;
};

struct PlanarQuadrotorOptions {
  PlanarQuadrotorParams params;
  int horizon = 50;
  double dt = 0.04;
  Eigen::Vector2d start{0.0, 0.0};
  Eigen::Vector2d goal{3.0, 0.5};
  double thrust_max = 7.0;  ///< 0 <= f_i <= thrust_max (input bounds); hover 4.9
  /// |theta| <= tilt_limit (state bound). At 0.7 the bound duals of Ipopt's optimum are
  /// not determined (kktResidual's least-squares fit fails): a degenerate active set.
  double tilt_limit = 0.8;
  double floor_height = -0.3;  ///< pz >= floor_height (state bound)
  /// Across the straight path (passed above) and just above the best path over it.
  std::vector<Circle> keep_out{{1.5, 0.0, 0.4}, {2.3, 0.8, 0.32}};
  double position_weight = 1.0;   ///< running, on p - goal
  double attitude_weight = 1e-2;  ///< running, on theta, v, omega
  double input_weight = 1e-2;     ///< running, on f - hover thrust
  double terminal_weight = 100.0;
};
/// Default guess: hover at the start.
ProblemInstance makePlanarQuadrotor(const PlanarQuadrotorOptions& o = {});

// =====================================================================================
// Kinematic bicycle (issue 17): x = [px, py, theta, v], u = [a, delta] (acceleration,
// steering angle): p' = v (cos theta, sin theta), theta' = v tan(delta) / L, v' = a.
class BicycleDynamics final : public ocp::ContinuousDynamics {
 public:
  explicit BicycleDynamics(double wheelbase = 0.5);
  std::unique_ptr<ocp::DynamicsData> createData() const override;
  void calc(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u, ocp::DynamicsData& d,
            VecRef xdot) const override;
  void calcDiff(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u, ocp::DynamicsData& d,
                MatRef fx, MatRef fu) const override;

 private:
  double wheelbase_;
};

struct BicycleOptions {
  double wheelbase = 0.5;
  int horizon = 50;
  double dt = 0.08;
  Eigen::Vector2d goal{4.0, 1.0};
  double goal_heading = 0.0;
  double acceleration_limit = 1.5;  ///< |a| <= limit
  double steering_limit = 0.5;      ///< |delta| <= limit [rad]
  double speed_limit = 1.5;         ///< -0.5 <= v <= speed_limit (state bound)
  std::vector<Circle> keep_out{{2.0, 0.45, 0.5}};
  double position_weight = 1.0;    ///< running, on p - goal
  double input_weight = 1e-2;      ///< running, on (a, delta)
  double terminal_weight = 100.0;  ///< on x - goal (speed 0)
};
/// Default guess: standing still at the origin, heading along +x.
ProblemInstance makeBicycle(const BicycleOptions& o = {});

// =====================================================================================
// Powell's example of the Maratos effect as an optimal control problem: a point p in the
// plane moved by its velocity (x = p, u = v, p' = v, explicit Euler) whose every next
// position lies on the unit circle (equality |p + dt v|^2 = 1, rank 1 in u), with the
// cost 2 (|p|^2 - 1) - p_x at every node (least squares: 2 |p - (1/4, 0)|^2 + const) and a
// small input weight. The constraint's curvature makes a full Newton step raise both the
// violation and the cost near the solution, so a filter line search without second-order
// corrections cuts the steps there.
class CircleStepResidual final : public ocp::Residual {
 public:
  CircleStepResidual(double dt, double radius);
  void calc(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u,
            ocp::ResidualData& d) const override;
  void calcDiff(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u,
                ocp::ResidualData& d) const override;

 private:
  double dt_, radius_;
};

struct MaratosCircleOptions {
  int horizon = 20;
  double dt = 0.1;
  double radius = 1.0;
  double start_angle = 1.2;    ///< x0 on the circle at this angle [rad]
  double input_weight = 1e-3;  ///< running, on v
};
/// Default guess: the positions on the circle at angles decreasing linearly from the start
/// to 0.3 rad (the velocities between them), near the solution's path.
ProblemInstance makeMaratosCircle(const MaratosCircleOptions& o = {});

/// The tests' problems by name: the defaults of two_link_arm, planar_quadrotor, bicycle,
/// cartpole, unicycle, rigid_body and maratos_circle, and variants of the comparison tests:
/// rigid_body_g (gravity, force and torque limits 25 and 0.6: active bounds), unicycle2 (two
/// obstacles), cartpole_euler (explicit Euler), acrobot. Throws std::invalid_argument on another
/// name.
ProblemInstance makeNamedProblem(const std::string& name);

// =====================================================================================
// Helpers.

/// A second start for the problems: the states interpolated from x0 to x_goal along the
/// geodesic of the state space, x_k = x0 (+) (k / N) (x_goal (-) x0), with the instance's
/// default input guess (not dynamically consistent: multiple shooting allows it).
std::vector<VectorXd> interpolatedStates(const ProblemInstance& inst);

/// The two starts the robustness tests use: "default" (the instance's guess) and
/// "interpolated" (interpolatedStates with the default inputs).
struct NamedStart {
  std::string name;
  std::vector<VectorXd> xs, us;
};
std::vector<NamedStart> twoStarts(const ProblemInstance& inst);

/// Hard bound and inequality rows within `tol` of their bound along a trajectory: input
/// bounds at nodes 0..N-1, state bounds at nodes 1..N (x_0 is fixed), general hard
/// inequality rows with g <= tol at every node.
struct ActiveSetCount {
  int input_bounds = 0, state_bounds = 0, inequalities = 0;
  int total() const { return input_bounds + state_bounds + inequalities; }
};
ActiveSetCount countActive(const ocp::OptimalControlProblem& problem,
                           const std::vector<VectorXd>& xs, const std::vector<VectorXd>& us,
                           double tol = 1e-6);

/// Rolls the discrete dynamics of the problem out from x0 with the inputs us.
std::vector<VectorXd> rollout(const ocp::OptimalControlProblem& problem, const VectorXd& x0,
                              const std::vector<VectorXd>& us);

/// Total cost sum_k node cost (evaluate).
double totalCost(const ocp::OptimalControlProblem& problem, const std::vector<VectorXd>& xs,
                 const std::vector<VectorXd>& us);

/// Largest constraint violation of a trajectory: defects, |e|, max(0, -g) on hard rows,
/// bounds (hard), and |x_0 (-) x_init|.
double maxViolation(const ocp::OptimalControlProblem& problem, const VectorXd& x_init,
                    const std::vector<VectorXd>& xs, const std::vector<VectorXd>& us);

/// Central finite differences of v(x (+) dx, u + du) at (x, u), for a vector function
/// whose output is compared by plain subtraction. Returns [dV/dx, dV/du].
void finiteDifference(const ocp::StateSpace& space, ConstVecRef x, ConstVecRef u,
                      const std::function<void(ConstVecRef, ConstVecRef, VecRef)>& v, int rows,
                      MatRef Jx, MatRef Ju, double h = 1e-6);

/// KKT residual of a multiple-shooting solution, computed independently of a solver's
/// own statistics from the problem's linearisation. Lagrangian (sign conventions as
/// arguments):
///   L = sum_k cost_k + sum_k lambda_{k+1}^T (F(x_k,u_k) (-) x_{k+1}) + nu_k^T e_k
///       - z_k^T g_k - (bound duals)
/// The costates lambda are eliminated exactly: they are recovered backwards from the
/// state stationarity, and the input stationarity is what is measured. The inequality
/// duals may come from the solver (z >= 0 expected) and so may the equality
/// multipliers; the bound duals (not exposed by the solver) are recovered as the
/// least-squares fit with the sign constraint (projected), which is what
/// `bound_duals_fit` means.
struct KktReport {
  double stationarity = 0.0;     ///< inf-norm of d L / d u_k over all nodes
  double primal = 0.0;           ///< maxViolation
  double complementarity = 0.0;  ///< max |z_i g_i| over inequality rows
  double dual_sign = 0.0;        ///< max(0, -z_i)
  double max() const;
};
struct KktInputs {
  /// Equality multipliers of node k (size ne_k); null: fitted by least squares.
  std::function<VectorXd(int)> equality_multipliers;
  /// Inequality duals of node k (size ni_k, general rows only); null: fitted.
  std::function<VectorXd(int)> inequality_duals;
  /// Duals of the input bounds of node k (k < N): [lower (nbu); upper (nbu)], >= 0, in
  /// the order of problem.inputBounds(); null: the active ones are fitted.
  std::function<VectorXd(int)> input_bound_duals;
  /// Duals of the state bounds of node k (k >= 1): [lower (nbx); upper (nbx)]; null: fitted.
  std::function<VectorXd(int)> state_bound_duals;
  double equality_sign = 1.0;  ///< +1: L contains + nu^T e, -1: - nu^T e
  double active_tolerance =
      1e-6;  ///< a bound/inequality within this is treated active when fitting
};
KktReport kktResidual(const ocp::OptimalControlProblem& problem, const VectorXd& x_init,
                      const std::vector<VectorXd>& xs, const std::vector<VectorXd>& us,
                      const KktInputs& in = {});

}  // namespace rollstep::nltest
