#pragma once
// Small nonlinear optimal control problems written with the ocp API, reusable by the
// solver tests, the Ipopt comparison, benchmarks and examples:
//   - cart-pole swing-up (Euclidean, RK4, force bounds, track limits, terminal cost);
//   - unicycle driving to a goal around circular obstacles, with a speed-profile
//     state-input equality v = k (goal - p) . heading and input bounds;
//   - a rigid body on SE(3) x R^6 (pose + body twist, body wrench input, explicit
//     Euler on the manifold) steered to a target pose.
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
// Helpers.

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
