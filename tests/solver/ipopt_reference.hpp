#pragma once
// Ipopt reference for any ocp::OptimalControlProblem (tests only).
//
// The problem is transcribed exactly as the rollstep solver does (direct multiple
// shooting): variables per node, x_0 fixed to x_init, defects x_{k+1} (-) F(x_k, u_k) = 0,
// equalities e_k = 0 (k < N), inequalities g_k >= 0 (k <= N), input and state bounds as
// Ipopt variable bounds, cost sum_k node cost.
//
// Lie-group states use a local chart: Ipopt's state variables are tangent perturbations
// delta_k around fixed points xbar_k (x_k = xbar_k (+) delta_k); first derivatives are
// the problem's tangent Jacobians chained with StateSpace::integrateJacobians. The
// Hessian of the Lagrangian is either the exact one by central finite differences of the
// (analytic) Lagrangian gradient, node by node, or Ipopt's limited-memory quasi-Newton.
//
// Soft inequalities / soft state bounds are not reproduced: with soft_as_hard they are
// enforced as hard constraints, otherwise the adapter throws std::invalid_argument.
#include <string>
#include <vector>

#include "rollstep/ocp/problem.hpp"

namespace rollstep::nltest {

struct IpoptOptions {
  double tol = 1e-10;
  double acceptable_tol = 1e-8;
  int max_iter = 3000;
  bool exact_hessian = true;  ///< finite-difference Hessian; false: limited-memory BFGS
  double hessian_fd_step = 1e-5;
  int print_level = 0;
  bool soft_as_hard = false;
  /// Re-centre the charts at the solution and solve again (Lie-group states), so the
  /// reported solution is not affected by a large chart perturbation.
  int recentre_passes = 1;
};

struct IpoptResult {
  bool success = false;  ///< Solve_Succeeded or Solved_To_Acceptable_Level
  int status = -1;       ///< Ipopt::ApplicationReturnStatus
  std::string status_string;
  double cost = 0.0;  ///< objective at the solution (sum of node costs)
  int iterations = 0;
  double max_violation = 0.0;  ///< our own measure (defects, e, g, bounds)
  std::vector<Eigen::VectorXd> xs, us;
  /// Ipopt's multipliers (its convention: L = f + lambda^T c), per node.
  std::vector<Eigen::VectorXd> defect_multipliers, equality_multipliers, inequality_multipliers;
};

/// Solves the problem from x_init with the given initial guess (N+1 states, N inputs).
IpoptResult solveWithIpopt(const ocp::OptimalControlProblem& problem, const Eigen::VectorXd& x_init,
                           const std::vector<Eigen::VectorXd>& xs_guess,
                           const std::vector<Eigen::VectorXd>& us_guess,
                           const IpoptOptions& options = {});

}  // namespace rollstep::nltest
