#pragma once
// Time-lag refinement and command extraction (paper Sec. 3.3, Fig. 7).
//
// An MPC solution was computed from a state that is already old when it arrives. refine()
// re-integrates the state equation (the full-centroidal dynamics, explicit Euler on
// SE(3) x R^(nj+6), the OCP's own transcription with RefinementSettings::substeps steps per
// node) from the LATEST state with the solution's optimal inputs (held over each node
// interval), over RefinementSettings::horizon; sample() extends the integration lazily when
// asked for later times, up to the end of the solution's horizon, and holds the last state
// at rest beyond it.
//
// sample(t) extracts what the acceleration tasks need at time t: the model configuration
// q (nq), velocity v = (v_b LOCAL, v_J) (nv) and acceleration a (nv); the world position,
// velocity and acceleration of every contact frame. Positions and velocities are
// interpolated between the refined nodes (on SE(3) for the base), accelerations are the
// differences of the node velocities (constant over a node interval).
//
// Memory: sized at construction for the solution horizon; refine() and sample() never
// allocate, lock or throw.
#include <Eigen/Core>
#include <memory>
#include <vector>

#include "rollstep/centroidal/dynamics.hpp"
#include "rollstep/centroidal/precomputation.hpp"
#include "rollstep/control/control_settings.hpp"
#include "rollstep/control/mpc_runner.hpp"

namespace rollstep::control {

/// The reference at one time.
struct ReferenceSample {
  double time = 0.0;
  Eigen::VectorXd q;                   ///< nq, model configuration
  Eigen::VectorXd v;                   ///< nv, (v_b LOCAL, v_J)
  Eigen::VectorXd a;                   ///< nv, feedforward acceleration
  Eigen::Matrix3Xd foot_position;      ///< 3 x nc, world
  Eigen::Matrix3Xd foot_velocity;      ///< 3 x nc, world
  Eigen::Matrix3Xd foot_acceleration;  ///< 3 x nc, world
  Eigen::VectorXd forces;              ///< 3 nc, the solution's contact forces (world)
};

class ReferenceTrajectory {
 public:
  /// `horizon`: N of the solutions to be refined. Throws std::invalid_argument for a null
  /// precomputation, horizon < 1, or bad settings (horizon < 0, substeps < 1).
  ReferenceTrajectory(std::shared_ptr<const centroidal::CentroidalPrecomputation> pre,
                      const RefinementSettings& settings, int horizon);

  /// Adopts `solution` (its inputs, grid and horizon are copied) and re-integrates from
  /// x_now (centroidal state) at t_now. Returns false, keeping the previous reference, if the
  /// solution does not fit (horizon, sizes), is not usable, or x_now is not finite. Returns
  /// false with no reference left (hasReference() false) if the state equation is not finite
  /// at x_now with the solution's first input.
  bool refine(const MpcSolution& solution, double t_now, const Eigen::VectorXd& x_now) noexcept;
  /// The reference at time t (clamped to the refined start). Requires a reference
  /// (hasReference()); `out` sized by makeSample().
  void sample(double t, ReferenceSample& out) noexcept;

  ReferenceSample makeSample() const;
  bool hasReference() const { return count_ > 0; }
  double startTime() const { return t_start_; }
  /// Time of the last refined node so far.
  double refinedUntil() const { return t_start_ + (count_ - 1) * step_; }
  /// End of the solution's horizon (beyond it the reference holds its last state).
  double endTime() const { return t_end_; }
  /// The refined state (centroidal layout) of node j (0 <= j < refinedNodes()).
  const Eigen::VectorXd& refinedState(int j) const { return nodes_[static_cast<size_t>(j)].x; }
  int refinedNodes() const { return count_; }
  double step() const { return step_; }

 private:
  struct Node {
    Eigen::VectorXd x;       // nx
    Eigen::VectorXd v;       // nv
    Eigen::VectorXd xdot;    // ndx, the state equation at the node
    Eigen::Matrix3Xd p, pv;  // feet
    Eigen::VectorXd forces;  // 3 nc
  };
  void extendTo(double t);         // integrates until the refined span covers t
  bool computeNode(int j);         // fills v, p, pv, forces of node j from its x and input
  int inputIndex(double t) const;  // the solution node whose input holds at t

  std::shared_ptr<const centroidal::CentroidalPrecomputation> pre_;
  centroidal::CentroidalDynamics dynamics_;
  std::unique_ptr<ocp::DynamicsData> dyn_data_;
  std::unique_ptr<centroidal::CentroidalCache> cache_;
  RefinementSettings settings_;
  int horizon_;
  int nq_, nv_, nx_, ndx_, nc_, nj_;

  // The adopted solution.
  double t0_ = 0.0, dt_ = 0.0, t_end_ = 0.0;
  std::vector<Eigen::VectorXd> us_;

  // Refined nodes t_start_ + j step_.
  double t_start_ = 0.0, step_ = 0.0;
  int count_ = 0;
  bool failed_ = false;  // integration hit a non-finite value: no further extension
  std::vector<Node> nodes_;
  Eigen::VectorXd xdot_, dx_, x_interp_;
};

}  // namespace rollstep::control
