#pragma once
// The per-node shared work of the centroidal OCP: one call of
// model::computeNodeQuantitiesFromMomentum per node (kinematics, COM, A(q), v_b, contact
// positions/velocities/Jacobians and their q-derivatives, gravity, contact torques), and,
// when derivatives are asked for, the TOTAL derivatives w.r.t. the node's (dx, u) that
// every term reads (base twist, contact velocities through v_b, contact positions, contact
// frame yaw). All members are sized once at construction; compute() allocates nothing.
//
// Conventions: see robot.hpp (layout of x, dx, u; contact frames; side-by-side rule).
// "_dx" matrices have ndx columns [dq (6 + nj), dh (6)], "_du" ones nu columns
// [dv_J (nj), df (3 nc)].
#include <Eigen/Core>
#include <array>
#include <memory>
#include <vector>

#include "rollstep/centroidal/robot.hpp"
#include "rollstep/model/data.hpp"
#include "rollstep/model/node.hpp"
#include "rollstep/ocp/problem.hpp"
#include "rollstep/planning/foot_reference.hpp"

namespace rollstep::centroidal {

struct CentroidalCache : ocp::NodeCache {
  explicit CentroidalCache(const CentroidalRobot& robot);

  model::Data data;
  /// Model quantities at the node; contact frames = robot.frameIds(), v = (v_b, v_J),
  /// forces = the node's f (contactTorque = J^T f with the forces at the frame origins).
  model::NodeQuantities nq;

  Eigen::VectorXd x;  ///< the node's state (copy, nx)
  Eigen::VectorXd u;  ///< the node's input (copy, nu)

  lie::Vector6d vb = lie::Vector6d::Zero();  ///< base twist, base LOCAL frame [lin; ang]
  /// World rotation of each contact frame.
  std::vector<Eigen::Matrix3d> footRotation;
  /// Yaw of each contact frame [rad]: atan2 of its x axis projected on the world xy plane
  /// (undefined, and its derivative unbounded, when that axis is vertical: a frame pitched
  /// by 90 deg; Tachyon 3's shanks stay within about 45 deg plus the base tilt).
  Eigen::VectorXd footYaw;

  // ---- Filled only when compute() is called with derivatives = true.
  bool has_derivatives = false;
  Eigen::Matrix<double, 6, Eigen::Dynamic> dvb_dx;  ///< 6 x ndx: [dvb_dq, A_b^-1]
  Eigen::Matrix<double, 6, Eigen::Dynamic> dvb_du;  ///< 6 x nu:  [dvb_dvJ, 0]
  /// 3nc x ndx / 3nc x nu: TOTAL derivatives of each contact frame's world linear
  /// velocity (rows 3i..3i+2), through v_b(q, h, v_J).
  Eigen::MatrixXd footVelocity_dx;
  Eigen::MatrixXd footVelocity_du;
  Eigen::MatrixXd footPosition_dx;  ///< 3nc x ndx: [J_i (LOCAL_WORLD_ALIGNED), 0]
  /// 3nc x ndx: world angular Jacobian of each contact frame (dR_i = hat(w) R_i), 0 in dh.
  Eigen::MatrixXd footAngular_dx;
  Eigen::MatrixXd footYaw_dx;  ///< nc x ndx

  // ---- Filled by compute(ctx, ...) when the precomputation has a foot planner and ctx a
  // schedule: every foot's planner reference at the node (what the terrain and swing terms
  // ask for, once per node instead of once per term and call). See footReference().
  const planning::FootReferencePlanner* foot_refs_planner = nullptr;  ///< nullptr: not filled
  const ocp::ModeSchedule* foot_refs_schedule = nullptr;
  double foot_refs_time = 0.0;
  int foot_refs_count = 0;  ///< feet filled: min(nc, planner feet)
  std::array<planning::FootReference, kMaxContacts> footRef{};

  // ---- Views of the node's variables.
  Eigen::VectorBlock<const Eigen::VectorXd> q() const { return x.head(nq_); }
  Eigen::VectorBlock<const Eigen::VectorXd, 6> h() const { return x.tail<6>(); }
  Eigen::VectorBlock<const Eigen::VectorXd> vJ() const { return u.head(nj_); }
  Eigen::VectorBlock<const Eigen::VectorXd> forces() const { return u.tail(3 * nc_); }
  Eigen::VectorBlock<const Eigen::VectorXd, 3> force(int i) const {
    return u.segment<3>(nj_ + 3 * i);
  }
  /// World position of contact i's frame origin.
  Eigen::Block<const Eigen::Matrix3Xd, 3, 1, true> footPosition(int i) const {
    return nq.contactPositions.col(i);
  }
  /// World linear velocity of contact i's frame origin.
  Eigen::Block<const Eigen::Matrix3Xd, 3, 1, true> footVelocity(int i) const {
    return nq.contactVelocities.col(i);
  }

 private:
  int nq_, nj_, nc_;
};

class CentroidalPrecomputation final : public ocp::NodePrecomputation {
 public:
  /// Throws std::invalid_argument for a null robot.
  explicit CentroidalPrecomputation(std::shared_ptr<const CentroidalRobot> robot);
  /// With a foot planner (it must outlive this object), compute(ctx, ...) also stores
  /// every foot's planner reference at ctx in the cache (footReference() reads them).
  void setFootPlanner(std::shared_ptr<const planning::FootReferencePlanner> planner);
  const CentroidalRobot& robot() const { return *robot_; }
  const std::shared_ptr<const CentroidalRobot>& robotPtr() const { return robot_; }

  std::unique_ptr<ocp::NodeCache> createCache() const override;
  /// Fills `cache` (a CentroidalCache from createCache()) at (x, u). Allocation-free.
  void compute(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
               bool derivatives, ocp::NodeCache& cache) const override;
  /// Same, typed.
  void compute(ocp::ConstVecRef x, ocp::ConstVecRef u, bool derivatives,
               CentroidalCache& cache) const;

 private:
  std::shared_ptr<const CentroidalRobot> robot_;
  std::shared_ptr<const planning::FootReferencePlanner> planner_;
};

/// planner.query(*ctx.schedule, foot, ctx.time) (ctx.schedule must be set), read from the
/// node cache ctx.cache when it holds that planner's references at this ctx (a
/// CentroidalCache filled by compute(ctx, ...) of a precomputation with that planner).
planning::FootReference footReference(const ocp::NodeContext& ctx,
                                      const planning::FootReferencePlanner& planner, int foot);

/// The cache a term reads at this node: ctx.cache when present (it must be a
/// CentroidalCache computed at (x, u), with derivatives if `derivatives`), otherwise
/// `*fallback`, computed here. Throws std::logic_error if ctx.cache lacks derivatives that
/// are asked for, or if there is neither ctx.cache nor a fallback (a workspace from a
/// term's createDataWithNodeCache() used without the node cache).
const CentroidalCache& nodeCache(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                 ocp::ConstVecRef u, bool derivatives,
                                 const CentroidalPrecomputation& pre, CentroidalCache* fallback);

/// A term's own cache for calls without a node cache (createData(): a term evaluated
/// alone), or none (createDataWithNodeCache(): every call carries ctx.cache; a cache is
/// 55 kB for Tachyon 3, and an OCP node has about ten such terms).
inline std::unique_ptr<CentroidalCache> makeFallbackCache(const CentroidalRobot& robot,
                                                          bool node_cache) {
  return node_cache ? nullptr : std::make_unique<CentroidalCache>(robot);
}

}  // namespace rollstep::centroidal
