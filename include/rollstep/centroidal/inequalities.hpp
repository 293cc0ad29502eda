#pragma once
// The inequality constraints of the full-centroidal OCP (paper Sec. 2.4, DESIGN.md
// section 3), each a small ocp::Residual g(x, u) >= 0 of one node, plus the joint limits
// as simple bounds for OptimalControlProblem::setStateBounds / setInputBounds:
//
//   StaticTorqueLimitResidual  tau_min <= S (g(q) - J(q)^T f) <= tau_max   (state-input)
//   FrictionPyramidResidual    linearised friction cone per stance foot     (input, affine)
//   FootRegionResidual         A [x y]^T_foot + b >= 0, stance foothold or swing
//                              collision-avoidance region                    (state only)
//   jointLimitBounds           q_J and v_J limits from the model
//
// Conventions: the robot layout of robot.hpp (x, dx, u; f_i world forces acting ON the
// robot); contact i is in stance at a node iff bit i of NodeContext::mode is set. Terms
// that need the robot's kinematics read the node's CentroidalCache (ctx.cache, filled by
// CentroidalPrecomputation with derivatives when calcDiff follows, see nodeCache); without
// one (ctx.cache null) they compute their own into a cache held by their data. Regions and terrain
// normals come from a TerrainReferences (terrain model + foot reference planner, both optional,
// both must outlive the terms). Construction allocates; rows/calc/calcDiff never do. The terrain
// terms ask the planner once per foot in rows() and once in calc(); calcDiff reuses what
// calc found, so it must follow calc with the same arguments (as ocp::Residual specifies).
#include <memory>
#include <string>
#include <vector>

#include "rollstep/centroidal/precomputation.hpp"
#include "rollstep/centroidal/robot.hpp"
#include "rollstep/ocp/residual.hpp"
#include "rollstep/planning/foot_reference.hpp"
#include "rollstep/planning/terrain.hpp"

namespace rollstep::centroidal {

/// Where the terms find the terrain: the regions (for sizing, normals and constraints) and
/// the planner that says which region foot i uses at a node's time (queried with the
/// node's ctx.schedule). Either may be null: no terrain = flat ground with normal +z and no
/// region constraints. The planner must be built on the same terrain model.
struct TerrainReferences {
  const planning::TerrainModel* terrain = nullptr;
  const planning::FootReferencePlanner* planner = nullptr;
  /// The region index that constrains foot i at ctx (stance: the foothold region under
  /// its nominal foothold; swing: the collision-avoidance region while it is active),
  /// -1 for none (no terrain, no planner, no schedule, or no region at that time).
  int stanceRegion(const ocp::NodeContext& ctx, int foot) const;
  int swingRegion(const ocp::NodeContext& ctx, int foot) const;
  /// Unit terrain normal under foot i at ctx: the normal of its stance region, +z without one.
  Eigen::Vector3d normal(const ocp::NodeContext& ctx, int foot) const;
  /// The largest number of edges of any region of the terrain (0 without terrain).
  int maxRegionEdges() const;
};

// ---- joint torque limits ---------------------------------------------------------------------

struct TorqueLimitOptions {
  /// Limits [N m or N] per joint, size nj, used when non-empty (+-infinity = no limit on
  /// that side). Empty: tau_max = scale * effortLimit, tau_min = -tau_max from the model,
  /// where an effort of 0 (URDF's "no limit") or a non-finite one gives no rows.
  Eigen::VectorXd lower, upper;
  /// Fraction of the model's effort limit used (in (0, 1]; ignored with explicit limits).
  double scale = 1.0;
  /// true: each force acts at the robot's contact point p_i - contact_offset e_z (the
  /// point robot.hpp defines, the lever arm of the momentum dynamics), i.e. J is the
  /// Jacobian of that point moving with contact i's body: tau gains the moment of the
  /// offset, + contact_offset J_w,i^T (e_z x f_i) (J_w,i the body's world angular
  /// Jacobian). For Tachyon 3 this is about r f_x at each hip (the traction force's moment about
  /// the wheel centre, reacted by the wheel motor on the shank). false: the forces act at
  /// the frame origins, exactly model::computeStaticTorque with the robot's frames.
  bool force_at_contact_point = true;
};

/// tau = S (g(q) - J(q)^T f) (model::computeStaticTorque: f acting ON the robot, every
/// contact's force included, swing forces being zero by their equality anyway; J at the
/// contact points or the frame origins, see TorqueLimitOptions::force_at_contact_point),
/// rows tau_max - tau_j >= 0 for every joint with a finite upper limit, then
/// tau_j - tau_min >= 0 for every joint with a finite lower limit (joint order within each
/// block). The row count is the same at every node.
class StaticTorqueLimitResidual final : public ocp::Residual {
 public:
  /// Throws std::invalid_argument naming the option: null robot, limits of the wrong size,
  /// NaN limits, lower > upper, scale outside (0, 1].
  StaticTorqueLimitResidual(std::shared_ptr<const CentroidalRobot> robot,
                            const TorqueLimitOptions& options = {});
  /// The static joint torques (size nj) at (x, u), the values the rows bound, in a new
  /// vector (allocates: for reports and tests). `d` from createData().
  Eigen::VectorXd torques(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
                          ocp::ResidualData& d) const;
  /// The upper limits (size nj, +inf where none) and lower ones (-inf where none).
  const Eigen::VectorXd& upperLimits() const { return upper_; }
  const Eigen::VectorXd& lowerLimits() const { return lower_; }
  int rows(const ocp::NodeContext& ctx) const override;
  std::string rowName(const ocp::NodeContext& ctx, int row) const override;
  /// nj when every joint is limited on both sides (row j + nj is the lower limit of the
  /// joint of row j), 0 otherwise.
  int mirroredRows(const ocp::NodeContext& ctx) const override;
  /// The configuration's columns (rho, theta, q_J) and the contact forces: no momentum,
  /// no joint velocities.
  ocp::ColumnRange stateColumns() const override { return {0, robot_->nv()}; }
  ocp::ColumnRange inputColumns() const override {
    return {robot_->nj(), robot_->nu() - robot_->nj()};
  }
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
  void staticTorques(const CentroidalCache& c, Eigen::VectorXd& tau) const;
  /// d tau / dx (nj x ndx) and d tau / du (nj x nu) of the joints' static torques, every
  /// entry written.
  void torqueDerivatives(const CentroidalCache& c, ocp::MatRef tau_dx, ocp::MatRef tau_du) const;
  std::shared_ptr<const CentroidalRobot> robot_;
  CentroidalPrecomputation pre_;  // for nodes without a shared cache
  Eigen::VectorXd lower_, upper_;
  bool at_contact_point_;
  std::vector<int> upper_rows_, lower_rows_;  // joints with a finite upper / lower limit
};

// ---- friction pyramid ------------------------------------------------------------------------

struct FrictionPyramidOptions {
  double mu = 0.7;                ///< friction coefficient (> 0)
  double min_normal_force = 0.0;  ///< f_n >= min_normal_force [N] (>= 0)
  /// true: the pyramid inscribed in the cone, |f_t1|, |f_t2| <= mu / sqrt(2) f_n (every
  /// force it admits is inside the true cone, as in Katayama et al. 2022). false: the
  /// circumscribed one, |f_t1|, |f_t2| <= mu f_n.
  bool inscribed = true;
};

/// For each stance foot i (in contact order), in the terrain frame (n, t1, t2) of its
/// region (n the region's unit normal, t1 = world x projected onto the plane, t2 = n x t1;
/// flat ground n = e_z, t1 = e_x, t2 = e_y), with f_n = n.f_i, f_tk = tk.f_i,
/// m = mu (or mu / sqrt(2) when inscribed), 5 rows:
///   m f_n - f_t1 >= 0, m f_n + f_t1 >= 0, m f_n - f_t2 >= 0, m f_n + f_t2 >= 0,
///   f_n - min_normal_force >= 0.
/// Affine in u and independent of x: isLinear() is true.
class FrictionPyramidResidual final : public ocp::Residual {
 public:
  static constexpr int kRowsPerFoot = 5;
  /// Throws std::invalid_argument naming the option: null robot, mu not finite and > 0,
  /// min_normal_force not finite and >= 0.
  FrictionPyramidResidual(std::shared_ptr<const CentroidalRobot> robot, TerrainReferences terrain,
                          const FrictionPyramidOptions& options = {});
  int rows(const ocp::NodeContext& ctx) const override;
  std::string rowName(const ocp::NodeContext& ctx, int row) const override;
  bool dependsOnState() const override { return false; }
  bool isLinear() const override { return true; }
  /// The contact forces.
  ocp::ColumnRange inputColumns() const override {
    return {robot_->nj(), robot_->nu() - robot_->nj()};
  }
  const FrictionPyramidOptions& options() const { return options_; }
  std::unique_ptr<ocp::ResidualData> createData() const override;
  /// The terrain frame of the file comment as the columns (t1, t2, n) of a rotation.
  static Eigen::Matrix3d terrainFrame(const Eigen::Vector3d& normal);
  void calc(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
            ocp::ResidualData& d) const override;
  void calcDiff(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
                ocp::ResidualData& d) const override;
  /// Writes every entry of Rx and Ru (rows(ctx) rows).
  void calcDiffInto(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
                    ocp::ResidualData& d, ocp::MatRef Rx, ocp::MatRef Ru) const override;

 private:
  /// The 5 x 3 row block of foot i at ctx: rows(f_i) - [0 0 0 0 min_normal_force].
  Eigen::Matrix<double, kRowsPerFoot, 3> block(const ocp::NodeContext& ctx, int foot) const;
  std::shared_ptr<const CentroidalRobot> robot_;
  TerrainReferences terrain_;
  FrictionPyramidOptions options_;
};

// ---- foothold and swing regions -----------------------------------------------------------

enum class RegionUse {
  Stance,  ///< stance feet in the foothold region under their nominal foothold
  Swing,   ///< swing feet in their collision-avoidance region while it is active
};

/// A [x y]^T_i + b >= 0 for each foot i the region rule selects at the node (rows = the
/// region's edges, A with unit inward rows, so each row is the signed distance of the
/// foot to an edge line; feet in contact order). (x, y) is the horizontal position of
/// contact i's frame origin, which is exactly that of the point the force acts at (the
/// robot's contact point is the origin offset along world z, robot.hpp). State only, so
/// it may be used as a soft (relaxed-barrier) inequality.
class FootRegionResidual final : public ocp::Residual {
 public:
  /// max_edges: the most edges a region may have; 0 = terrain.maxRegionEdges() (a region
  /// with more edges met later throws std::length_error from rows()). Throws
  /// std::invalid_argument for a null robot or a negative max_edges.
  FootRegionResidual(std::shared_ptr<const CentroidalRobot> robot, TerrainReferences terrain,
                     RegionUse use, int max_edges = 0);
  int rows(const ocp::NodeContext& ctx) const override;
  std::string rowName(const ocp::NodeContext& ctx, int row) const override;
  bool dependsOnInput() const override { return false; }
  /// The configuration's columns (rho, theta, q_J): the feet do not move with the momentum.
  ocp::ColumnRange stateColumns() const override { return {0, robot_->nv()}; }
  RegionUse use() const { return use_; }
  int maxEdges() const { return max_edges_; }
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
  int regionOf(const ocp::NodeContext& ctx, int foot) const;
  std::shared_ptr<const CentroidalRobot> robot_;
  CentroidalPrecomputation pre_;  // for nodes without a shared cache
  TerrainReferences terrain_;
  RegionUse use_;
  int max_edges_;
};

// ---- joint position and velocity limits as simple bounds -------------------------------------

struct JointLimitBoundOptions {
  /// Each finite position limit is moved inwards by this much [rad or m] (>= 0, and at most
  /// half of every finite range).
  double position_margin = 0.0;
  /// Fraction of the model's velocity limit used, in (0, 1]. A velocity limit of 0 (URDF's
  /// "no limit") or a non-finite one gives no bound.
  double velocity_scale = 1.0;
};

/// The vectors OptimalControlProblem::setStateBounds (size ndx) and setInputBounds (size nu)
/// take: tangent entries 6..6+nj-1 (q_J) bounded by the model's position limits, input
/// entries 0..nj-1 (v_J) by -+ its velocity limits, +-infinity everywhere else.
struct JointLimitBounds {
  Eigen::VectorXd state_lower, state_upper;  ///< size ndx
  Eigen::VectorXd input_lower, input_upper;  ///< size nu
};
/// Throws std::invalid_argument naming the option for a negative or non-finite margin, a
/// margin that empties a joint's range, a scale outside (0, 1].
JointLimitBounds jointLimitBounds(const CentroidalRobot& robot,
                                  const JointLimitBoundOptions& options = {});

}  // namespace rollstep::centroidal
