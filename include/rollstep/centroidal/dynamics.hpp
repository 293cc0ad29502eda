#pragma once
// Full-centroidal dynamics (DESIGN.md section 2, paper eq. stateEquation) as the tangent
// velocity of the state x = (q_b, q_J, h) (layout in robot.hpp):
//
//   f(x, u) = [ v_b ;  v_J ;  sum_i f_i + m g ;  sum_i (p_i - d e_z - c) x f_i ],
//   v_b = A_b(q)^-1 (h - A_J(q) v_J),
//
// p_i the world position of contact frame i, d the robot's contact offset (the force acts
// at the ground contact point below a wheel centre), c the COM, g the model's gravity.
// Every force is in the sum whatever the mode: the swing-force equality makes swing
// forces zero. Discretise with ocp::ExplicitEuler (x_{k+1} = x_k (+) dt f on SE(3) x R^n).
//
// Jacobians are analytic: fx = [[dvb_dq, A_b^-1]; 0; 0; [-sum_i hat(f_i) (J_i - J_com), 0]],
// fu = [[dvb_dvJ, 0]; [I, 0]; [0, I ... I]; [0, hat(p_i - d e_z - c) ...]].
// calc/calcDiff read the node cache (ctx.cache, a CentroidalCache) when present and
// compute their own otherwise. Allocation-free.
#include <memory>

#include "rollstep/centroidal/precomputation.hpp"
#include "rollstep/ocp/dynamics.hpp"

namespace rollstep::centroidal {

class CentroidalDynamics final : public ocp::ContinuousDynamics {
 public:
  /// Throws std::invalid_argument for a null precomputation.
  explicit CentroidalDynamics(std::shared_ptr<const CentroidalPrecomputation> pre);
  const CentroidalRobot& robot() const { return pre_->robot(); }

  std::unique_ptr<ocp::DynamicsData> createData() const override;
  std::unique_ptr<ocp::DynamicsData> createDataWithNodeCache() const override;
  void calc(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
            ocp::DynamicsData& d, ocp::VecRef xdot) const override;
  void calcDiff(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
                ocp::DynamicsData& d, ocp::MatRef fx, ocp::MatRef fu) const override;

 private:
  std::shared_ptr<const CentroidalPrecomputation> pre_;
};

}  // namespace rollstep::centroidal
