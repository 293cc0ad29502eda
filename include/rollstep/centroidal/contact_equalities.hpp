#pragma once
// The contact equality constraints of the centroidal OCP (paper Sec. 2.3, DESIGN.md section
// 3), one residual per family; each stacks the rows of the feet it applies to in the node's
// mode (mode = contact mask, bit i = contact i in stance), in contact order. Each is full
// row rank in u on its own, and so is their stack with the swing height rows
// (swing_height.hpp) in the modes of Tachyon 3's gaits (the side-by-side rule of robot.hpp
// removes the dependent stance rows), which the projection of the equalities needs.
//
//  - SwingForceResidual: r = [f_i] for every swing contact i (3 rows each; affine).
//  - StanceVelocityResidual: for every stance contact that keeps its velocity
//    constraints (CentroidalRobot::keepsVelocityConstraints), the velocity of its frame
//    origin along the terrain normal n_i of its stance region, n_i^T v_i (the world z
//    velocity on flat ground or without terrain: a rolling wheel follows a slope), and for
//    a drive wheel then its lateral velocity in the yaw frame of the contact frame:
//    e_lat^T v_i, e_lat = (-sin yaw_i, cos yaw_i, 0), yaw_i the yaw of the contact frame's
//    x axis (for Tachyon 3, whose legs only pitch, the base yaw). Rows ordered per
//    contact: normal, then lateral.
//
// The contact velocities are total derivatives through v_b(q, h, v_J) (precomputation.hpp).
// calc/calcDiff read the node cache (ctx.cache) when present and compute their own
// otherwise; they never allocate.
#include <memory>
#include <string>

#include "rollstep/centroidal/inequalities.hpp"
#include "rollstep/centroidal/precomputation.hpp"
#include "rollstep/centroidal/residual_data.hpp"
#include "rollstep/ocp/residual.hpp"

namespace rollstep::centroidal {

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
  VerticalOnly,  ///< the velocity along the terrain normal only
  LateralOnly,   ///< a drive wheel's lateral velocity only (none for other feet)
};

/// Stance contacts: zero velocity along the terrain normal, zero lateral velocity for drive
/// wheels, with the side-by-side rule (`rows` selects the kept or the freed ones,
/// `components` which rows of each of them). `terrain` gives each stance foot's normal
/// (TerrainReferences::normal: +z without terrain or region).
class StanceVelocityResidual final : public ocp::Residual {
 public:
  explicit StanceVelocityResidual(std::shared_ptr<const CentroidalPrecomputation> pre,
                                  StanceRows rows = StanceRows::Kept,
                                  StanceComponents components = StanceComponents::All,
                                  TerrainReferences terrain = {});
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
  TerrainReferences terrain_;
  bool vertical() const { return components_ != StanceComponents::LateralOnly; }
  bool lateral(int i) const;  // drive wheel and lateral rows wanted
};

}  // namespace rollstep::centroidal
