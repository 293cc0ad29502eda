#pragma once
// Equality constraints of the centroidal OCP (paper Sec. 2.3, DESIGN.md section 3), one
// residual per family; each stacks the rows of the feet it applies to in the node's mode
// (mode = contact mask, bit i = contact i in stance), in contact order. Each is full row
// rank in u on its own, and so is their stack in the modes of Tachyon 3's gaits (the
// side-by-side rule of robot.hpp removes the dependent stance rows), which the projection
// of the equalities needs.
//
//  - SwingForceResidual: r = [f_i] for every swing contact i (3 rows each; affine).
//  - StanceVelocityResidual: for every stance contact that keeps its velocity
//    constraints (CentroidalRobot::keepsVelocityConstraints), the world z velocity of its
//    frame origin, and for a drive wheel then its lateral velocity in the yaw frame of the
//    contact frame: e_lat^T v_i, e_lat = (-sin yaw_i, cos yaw_i, 0), yaw_i the yaw of the
//    contact frame's x axis (for Tachyon 3, whose legs only pitch, the base yaw). Rows
//    ordered per contact: z, then lateral.
//  - SwingHeightResidual: for every swing contact, v_z,i - z_dot_ref(t) + Kp (p_z,i - z_ref(t))
//    with z_ref from planning::FootReferencePlanner::query (its foot_height_offset must
//    match the contact frames: the wheel radius for wheel-centre frames).
//
// The contact velocities are total derivatives through v_b(q, h, v_J) (precomputation.hpp).
// calc/calcDiff read the node cache (ctx.cache) when present and compute their own
// otherwise; they never allocate.
#include <memory>
#include <string>

#include "rollstep/centroidal/precomputation.hpp"
#include "rollstep/ocp/residual.hpp"
#include "rollstep/planning/foot_reference.hpp"

namespace rollstep::centroidal {

/// Workspace of the centroidal residuals: a fallback cache for calls without a node cache
/// (none when made for nodes that always have one, makeFallbackCache).
struct CentroidalResidualData : ocp::ResidualData {
  CentroidalResidualData(const CentroidalRobot& robot, int max_rows, bool node_cache)
      : ocp::ResidualData(max_rows, robot.ndx(), robot.nu()),
        fallback(makeFallbackCache(robot, node_cache)) {}
  std::unique_ptr<CentroidalCache> fallback;
};

/// f_i = 0 for every swing contact. Affine, input only.
class SwingForceResidual final : public ocp::Residual {
 public:
  explicit SwingForceResidual(std::shared_ptr<const CentroidalRobot> robot);
  int rows(const ocp::NodeContext& ctx) const override;
  std::string rowName(const ocp::NodeContext& ctx, int row) const override;
  bool dependsOnState() const override { return false; }
  bool isLinear() const override { return true; }
  void calc(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
            ocp::ResidualData& d) const override;
  void calcDiff(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
                ocp::ResidualData& d) const override;
  /// Writes every entry of Rx and Ru (rows(ctx) rows).
  void calcDiffInto(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
                    ocp::ResidualData& d, ocp::MatRef Rx, ocp::MatRef Ru) const override;

 private:
  std::shared_ptr<const CentroidalRobot> robot_;
};

/// Which stance velocity rows a StanceVelocityResidual carries.
enum class StanceRows {
  /// The rows the side-by-side rule keeps: the equality constraints.
  Kept,
  /// The rows it frees (a stance foot whose pair partner keeps them): not full rank with
  /// the kept ones, so no constraint, but a least-squares cost. Without it the optimum
  /// moves the freed foot freely (a stance wheel rose at 0.9 m/s in a trot on flat ground).
  Freed,
  /// Every stance foot's rows (for costs: the lateral slip of skid steering).
  All,
};

/// Which components of a selected stance foot's velocity a StanceVelocityResidual carries.
enum class StanceComponents {
  All,           ///< vertical, and lateral for a drive wheel
  VerticalOnly,  ///< the world z velocity only
  LateralOnly,   ///< a drive wheel's lateral velocity only (none for other feet)
};

/// Stance contacts: zero world z velocity, zero lateral velocity for drive wheels, with the
/// side-by-side rule (`rows` selects the kept or the freed ones, `components` which rows of
/// each of them).
class StanceVelocityResidual final : public ocp::Residual {
 public:
  explicit StanceVelocityResidual(std::shared_ptr<const CentroidalPrecomputation> pre,
                                  StanceRows rows = StanceRows::Kept,
                                  StanceComponents components = StanceComponents::All);
  int rows(const ocp::NodeContext& ctx) const override;
  std::string rowName(const ocp::NodeContext& ctx, int row) const override;
  std::unique_ptr<ocp::ResidualData> createData() const override;
  std::unique_ptr<ocp::ResidualData> createDataWithNodeCache() const override;
  void calc(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
            ocp::ResidualData& d) const override;
  void calcDiff(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
                ocp::ResidualData& d) const override;
  /// Writes every entry of Rx and Ru (rows(ctx) rows).
  void calcDiffInto(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
                    ocp::ResidualData& d, ocp::MatRef Rx, ocp::MatRef Ru) const override;

 private:
  /// Contact i has rows at `mode`.
  bool selected(int mode, int i) const;
  std::shared_ptr<const CentroidalPrecomputation> pre_;
  StanceRows which_;
  StanceComponents components_;
  bool vertical() const { return components_ != StanceComponents::LateralOnly; }
  bool lateral(int i) const;  // drive wheel and lateral rows wanted
};

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
