#include "rollstep/centroidal/precomputation.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "rollstep/ocp/small_products.hpp"

namespace rollstep::centroidal {

CentroidalCache::CentroidalCache(const CentroidalRobot& robot)
    : data(robot.model()),
      nq(robot.model(), robot.frameIds()),
      x(Eigen::VectorXd::Zero(robot.nx())),
      u(Eigen::VectorXd::Zero(robot.nu())),
      footRotation(static_cast<size_t>(robot.nc()), Eigen::Matrix3d::Identity()),
      footYaw(Eigen::VectorXd::Zero(robot.nc())),
      dvb_dx(Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, robot.ndx())),
      dvb_du(Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, robot.nu())),
      footVelocity_dx(Eigen::MatrixXd::Zero(3 * robot.nc(), robot.ndx())),
      footVelocity_du(Eigen::MatrixXd::Zero(3 * robot.nc(), robot.nu())),
      footPosition_dx(Eigen::MatrixXd::Zero(3 * robot.nc(), robot.ndx())),
      footAngular_dx(Eigen::MatrixXd::Zero(3 * robot.nc(), robot.ndx())),
      footYaw_dx(Eigen::MatrixXd::Zero(robot.nc(), robot.ndx())),
      nq_(robot.nq()),
      nj_(robot.nj()),
      nc_(robot.nc()) {}

CentroidalPrecomputation::CentroidalPrecomputation(std::shared_ptr<const CentroidalRobot> robot)
    : robot_(std::move(robot)) {
  if (!robot_) throw std::invalid_argument("CentroidalPrecomputation: null robot");
}

std::unique_ptr<ocp::NodeCache> CentroidalPrecomputation::createCache() const {
  return std::make_unique<CentroidalCache>(*robot_);
}

void CentroidalPrecomputation::setFootPlanner(
    std::shared_ptr<const planning::FootReferencePlanner> planner) {
  planner_ = std::move(planner);
}

void CentroidalPrecomputation::compute(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                       ocp::ConstVecRef u, bool derivatives,
                                       ocp::NodeCache& cache) const {
  auto& c = static_cast<CentroidalCache&>(cache);
  compute(x, u, derivatives, c);
  if (planner_ && ctx.schedule != nullptr) {
    const int nf = std::min(robot_->nc(), planner_->numFeet());
    for (int i = 0; i < nf; ++i) {
      c.footRef[static_cast<std::size_t>(i)] = planner_->query(*ctx.schedule, i, ctx.time);
    }
    c.foot_refs_planner = planner_.get();
    c.foot_refs_schedule = ctx.schedule;
    c.foot_refs_time = ctx.time;
    c.foot_refs_count = nf;
  }
}

planning::FootReference footReference(const ocp::NodeContext& ctx,
                                      const planning::FootReferencePlanner& planner, int foot) {
  if (ctx.cache != nullptr) {
    const auto& c = static_cast<const CentroidalCache&>(*ctx.cache);
    if (c.foot_refs_planner == &planner && c.foot_refs_schedule == ctx.schedule &&
        c.foot_refs_time == ctx.time && foot >= 0 && foot < c.foot_refs_count) {
      return c.footRef[static_cast<std::size_t>(foot)];
    }
  }
  return planner.query(*ctx.schedule, foot, ctx.time);
}

void CentroidalPrecomputation::compute(ocp::ConstVecRef x, ocp::ConstVecRef u, bool derivatives,
                                       CentroidalCache& c) const {
  const CentroidalRobot& robot = *robot_;
  const model::Model& model = robot.model();
  const int nj = robot.nj();
  const int nv = robot.nv();
  const int nc = robot.nc();
  c.x = x;
  c.u = u;
  c.foot_refs_planner = nullptr;  // compute(ctx, ...) fills them again
  const lie::Vector6d h = x.tail<6>();
  model::computeNodeQuantitiesFromMomentum(model, c.data, x.head(robot.nq()), h, u.head(nj),
                                           u.tail(3 * nc), c.nq);
  c.vb = c.nq.v.head<6>();
  for (int i = 0; i < nc; ++i) {
    const model::Frame& frame = model.frames[static_cast<size_t>(robot.frameIds()[i])];
    Eigen::Matrix3d& R = c.footRotation[static_cast<size_t>(i)];
    R.noalias() = c.data.oRb[static_cast<size_t>(frame.body)] * frame.rotation;
    c.footYaw[i] = std::atan2(R(1, 0), R(0, 0));
  }
  c.has_derivatives = derivatives;
  if (!derivatives) return;

  const model::NodeQuantities& nq = c.nq;
  c.dvb_dx.leftCols(nv) = nq.dvb_dq;
  c.dvb_dx.rightCols<6>() = nq.AbInverse;
  c.dvb_du.leftCols(nj) = nq.dvb_dvJ;  // force columns stay zero
  // Total derivatives of the contact velocities through v_b: d v_i = (partial) + J_i,b dv_b
  // with J_i,b the base columns of the (LOCAL_WORLD_ALIGNED) contact Jacobian: one
  // 3nc x 6 x (ndx + nj) product of depth 6 for all contacts.
  const int nf = 3 * nc;
  const auto Jb = nq.contactJacobians.leftCols<6>();
  c.footVelocity_dx.leftCols(nv) = nq.contactVelocityDerivatives;
  c.footVelocity_dx.rightCols<6>().setZero();
  ocp::smallDepthProduct(c.footVelocity_dx, Jb, c.dvb_dx, 1.0, true);
  c.footVelocity_du.leftCols(nj) = nq.contactJacobians.rightCols(nj);
  ocp::smallDepthProduct(c.footVelocity_du.leftCols(nj), Jb, c.dvb_du.leftCols(nj), 1.0, true);
  c.footPosition_dx.topLeftCorner(nf, nv) = nq.contactJacobians;
  for (int i = 0; i < nc; ++i) {
    const int r = 3 * i;
    // Angular Jacobian of the frame's body: only its support columns are non-zero (the
    // others were zeroed at construction and are never written).
    auto wdx = c.footAngular_dx.middleRows<3>(r);
    for (int col : robot.supportColumns(i)) wdx.col(col) = c.data.J.block<3, 1>(3, col);
    // yaw = atan2(a_y, a_x), a = R e_x, da = w x a: dyaw = (a x l) . w,
    // l = (-a_y, a_x, 0) / (a_x^2 + a_y^2).
    const Eigen::Vector3d a = c.footRotation[static_cast<size_t>(i)].col(0);
    const double n2 = a.x() * a.x() + a.y() * a.y();
    const Eigen::Vector3d l = Eigen::Vector3d(-a.y(), a.x(), 0.0) / n2;
    const Eigen::Vector3d g = a.cross(l);
    for (int col : robot.supportColumns(i)) c.footYaw_dx(i, col) = g.dot(wdx.col(col));
  }
}

const CentroidalCache& nodeCache(const ocp::NodeContext& ctx, ocp::ConstVecRef x,
                                 ocp::ConstVecRef u, bool derivatives,
                                 const CentroidalPrecomputation& pre, CentroidalCache* fallback) {
  if (ctx.cache != nullptr) {
    const auto& c = static_cast<const CentroidalCache&>(*ctx.cache);
    if (derivatives && !c.has_derivatives) {
      throw std::logic_error(
          "centroidal: the node cache was computed without derivatives but a term's "
          "calcDiff needs them");
    }
    return c;
  }
  if (fallback == nullptr) {
    throw std::logic_error(
        "centroidal: a term's workspace made for nodes with a shared cache "
        "(createDataWithNodeCache) was used without one");
  }
  // No shared cache: compute our own, with derivatives so that calcDiff (called right
  // after calc with the same x, u) reuses it.
  if (!(fallback->has_derivatives && fallback->x == x && fallback->u == u)) {
    pre.compute(x, u, true, *fallback);
  }
  return *fallback;
}

}  // namespace rollstep::centroidal
