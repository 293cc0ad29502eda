#pragma once
// The swing height equality of the centroidal OCP (paper Sec. 2.3, DESIGN.md section 3):
// for every swing contact, v_z,i - z_dot_ref(t) + Kp (p_z,i - z_ref(t)) = 0 with z_ref from
// planning::FootReferencePlanner::query (its foot_height_offset must match the contact
// frames: the wheel radius for wheel-centre frames). Rows in contact order, one per swing
// contact.
//
// The contact velocities are total derivatives through v_b(q, h, v_J) (precomputation.hpp).
// calc/calcDiff read the node cache (ctx.cache) when present and compute their own
// otherwise; they never allocate.
#include <memory>
#include <string>

#include "rollstep/centroidal/precomputation.hpp"
#include "rollstep/centroidal/residual_data.hpp"
#include "rollstep/ocp/residual.hpp"
#include "rollstep/planning/foot_reference.hpp"

namespace rollstep::centroidal {

/// Swing contacts: v_z - z_dot_ref(t) + Kp (p_z - z_ref(t)) = 0. Needs ctx.schedule.
/// With max_correction > 0 the feedback term Kp e is saturated smoothly,
/// max_correction tanh(Kp e / max_correction): a foot far from its spline (a new horizon
/// tail, a foot held back in closed loop) is asked for at most that much extra vertical
/// speed, not for one the joint velocity bounds cannot give (the hard equality and bounds
/// then had no feasible point and the real-time iteration's step collapsed).
class SwingHeightResidual final : public ocp::Residual {
 public:
  /// @param kp position-error gain [1/s], finite and >= 0 (std::invalid_argument otherwise,
  /// also for a null argument or a planner with a different number of feet).
  SwingHeightResidual(std::shared_ptr<const CentroidalPrecomputation> pre,
                      std::shared_ptr<const planning::FootReferencePlanner> planner, double kp,
                      double max_correction = 0.0);
  int rows(const ocp::NodeContext& ctx) const override;
  std::string rowName(const ocp::NodeContext& ctx, int row) const override;
  double kp() const { return kp_; }
  double maxCorrection() const { return max_correction_; }
  std::unique_ptr<ocp::ResidualData> createData() const override;
  std::unique_ptr<ocp::ResidualData> createDataWithNodeCache() const override;
  /// Throws std::invalid_argument if ctx.schedule is null and some contact swings.
  void calc(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
            ocp::ResidualData& d) const override;
  void calcDiff(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
                ocp::ResidualData& d) const override;
  /// Writes every entry of Rx and Ru (rows(ctx) rows).
  void calcDiffInto(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
                    ocp::ResidualData& d, ocp::MatRef Rx, ocp::MatRef Ru) const override;

 private:
  std::shared_ptr<const CentroidalPrecomputation> pre_;
  std::shared_ptr<const planning::FootReferencePlanner> planner_;
  double kp_;
  double max_correction_;                  // [m/s], 0: no saturation
  double correction(double e) const;       // Kp e, saturated
  double correctionSlope(double e) const;  // its derivative by e
};

}  // namespace rollstep::centroidal
