// The pieces of the CBF-QP (cbf_rows.hpp), each on its own: the contact kinematics against
// the model and finite differences; the tracking cost against the sum of its weighted
// squares; the contact rows against the contact velocities they hold; the joint bounds in
// a closed loop at 1 kHz; every barrier family (region, clearance, collision, support
// polygon) against its barrier function h, i.e. C a - l = h'' + 2 gamma h' + gamma^2 h along
// the motion (finite differences), for random states and accelerations; the obstacle rule
// and the support hull.
#include "rollstep/control/cbf_rows.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <vector>

#include "centroidal/fd_check.hpp"
#include "rollstep/control/barriers.hpp"
#include "rollstep/control/cbf_qp.hpp"
#include "rollstep/model/center_of_mass.hpp"
#include "rollstep/model/kinematics.hpp"

namespace {

using namespace rollstep;
using control::ContactKinematics;
using control::DenseQpDims;
using control::DenseQpProblem;
using Eigen::MatrixXd;
using Eigen::Vector2d;
using Eigen::Vector3d;
using Eigen::VectorXd;
namespace ct = centroidal::test;

constexpr double kInf = std::numeric_limits<double>::infinity();

VectorXd gaussian(int n, std::mt19937& rng, double scale) {
  std::normal_distribution<double> d(0.0, scale);
  VectorXd v(n);
  for (int k = 0; k < n; ++k) v[k] = d(rng);
  return v;
}

/// World position of contact i's frame origin at q.
Vector3d footPosition(const centroidal::CentroidalRobot& robot, model::Data& d, int i,
                      const VectorXd& q) {
  const model::FrameIndex f = robot.frameIds()[static_cast<size_t>(i)];
  model::forwardKinematics(robot.model(), d, q);
  model::updateFramePlacement(robot.model(), d, f);
  return d.opf[static_cast<size_t>(f)];
}

/// Along q(t) = q (+) t v, v(t) = v + t a: the first derivative of h(q) and the second,
/// by central differences of the first (which is itself a central difference).
struct Derivatives {
  double h = 0.0, hd = 0.0, hdd = 0.0;
};

Derivatives alongMotion(const model::Model& m, const VectorXd& q, const VectorXd& v,
                        const VectorXd& a, const std::function<double(const VectorXd&)>& h) {
  const double eps = 1e-4;
  auto rate = [&](const VectorXd& qq, const VectorXd& vv) {
    VectorXd qp(qq.size()), qm(qq.size());
    model::integrate(m, qq, eps * vv, qp);
    model::integrate(m, qq, -eps * vv, qm);
    return (h(qp) - h(qm)) / (2.0 * eps);
  };
  VectorXd qp(q.size()), qm(q.size());
  model::integrate(m, q, eps * v, qp);
  model::integrate(m, q, -eps * v, qm);
  Derivatives out;
  out.h = h(q);
  out.hd = rate(q, v);
  out.hdd = (rate(qp, v + eps * a) - rate(qm, v - eps * a)) / (2.0 * eps);
  return out;
}

/// Checks rows [first, first + count) of qp as barriers of the functions h[k]: for random
/// accelerations, C a - l = h'' + 2 gamma h' + gamma^2 h, and u = +inf.
void expectBarrierRows(const model::Model& m, const VectorXd& q, const VectorXd& v,
                       const DenseQpProblem& qp, int first,
                       const std::vector<std::function<double(const VectorXd&)>>& h, double gamma,
                       std::mt19937& rng, const char* what) {
  for (int trial = 0; trial < 3; ++trial) {
    const VectorXd a = gaussian(m.nv, rng, 2.0);
    for (size_t k = 0; k < h.size(); ++k) {
      const int row = first + static_cast<int>(k);
      const Derivatives d = alongMotion(m, q, v, a, h[k]);
      const double expected = d.hdd + 2.0 * gamma * d.hd + gamma * gamma * d.h;
      const double got = qp.C().row(row).dot(a) - qp.l()[row];
      EXPECT_NEAR(got, expected, 2e-5 * (1.0 + std::abs(expected)))
          << what << " row " << row << " (h " << d.h << ", h' " << d.hd << ", h'' " << d.hdd << ")";
      EXPECT_EQ(qp.u()[row], kInf) << what;
    }
  }
}

/// A random state of Tachyon 3 (joints inside their limits) with a random velocity.
struct State {
  VectorXd q, v;
};

State randomState(const centroidal::CentroidalRobot& robot, std::mt19937& rng) {
  State s;
  s.q = ct::randomState(robot, rng, 0.3).head(robot.nq());
  s.v = gaussian(robot.nv(), rng, 0.7);
  return s;
}

// ---- contact kinematics ------------------------------------------------------------------

TEST(CbfRows, ContactKinematicsMatchTheModelAndFiniteDifferences) {
  const auto robot = ct::tachyon3Robot();
  const model::Model& m = robot->model();
  model::Data data(m), d(m), dj(m);
  ContactKinematics kin(*robot);
  std::mt19937 rng(11);
  for (int trial = 0; trial < 5; ++trial) {
    const State s = randomState(*robot, rng);
    control::computeContactKinematics(*robot, data, s.q, s.v, kin);
    MatrixXd J(6, robot->nv());
    model::computeJointJacobians(m, dj, s.q);
    for (int i = 0; i < robot->nc(); ++i) {
      const model::FrameIndex f = robot->frameIds()[static_cast<size_t>(i)];
      J.setZero();
      model::updateFramePlacement(m, dj, f);  // the LWA Jacobian reads the frame's position
      model::getFrameJacobian(m, dj, f, model::ReferenceFrame::LOCAL_WORLD_ALIGNED, J);
      EXPECT_LE((kin.footJacobian(i) - J.topRows<3>()).norm(), 1e-12);
      EXPECT_LE((kin.position.col(i) - footPosition(*robot, d, i, s.q)).norm(), 1e-12);
      EXPECT_LE((kin.velocity.col(i) - J.topRows<3>() * s.v).norm(), 1e-10);
      // Each coordinate of the foot: p'' = J a + drift.
      const VectorXd a = gaussian(robot->nv(), rng, 3.0);
      for (int c = 0; c < 3; ++c) {
        const Derivatives fd = alongMotion(
            m, s.q, s.v, a, [&](const VectorXd& qq) { return footPosition(*robot, d, i, qq)[c]; });
        const double analytic = kin.footJacobian(i).row(c).dot(a) + kin.drift(c, i);
        EXPECT_NEAR(analytic, fd.hdd, 2e-5 * (1.0 + std::abs(fd.hdd))) << "foot " << i;
      }
    }
  }
}

// ---- tracking cost -----------------------------------------------------------------------

TEST(CbfRows, TrackingCostIsTheSumOfItsWeightedSquares) {
  const auto robot = ct::tachyon3Robot();
  const int nv = robot->nv(), nj = robot->nj(), nc = robot->nc();
  model::Data data(robot->model());
  ContactKinematics kin(*robot);
  std::mt19937 rng(12);
  const State s = randomState(*robot, rng);
  control::computeContactKinematics(*robot, data, s.q, s.v, kin);
  control::CbfQpSettings settings;
  settings.damping = 0.1;  // every term counts
  control::AccelerationTargets t;
  t.base = gaussian(6, rng, 1.0);
  t.feet = Eigen::Matrix3Xd::Random(3, nc);
  t.joints = gaussian(nj, rng, 1.0);
  DenseQpProblem qp(DenseQpDims{nv, 0, 0});
  qp.H().setConstant(7.0);  // overwritten, not added to
  control::writeTrackingCost(settings, kin, t, nj, qp);
  auto squares = [&](const VectorXd& a) {
    double e = (settings.base_weight.array() * (a.head<6>() - t.base).array().square()).sum();
    e += settings.joint_weight * (a.tail(nj) - t.joints).squaredNorm();
    e += settings.damping * a.squaredNorm();
    for (int i = 0; i < nc; ++i) {
      e += settings.foot_weight *
           (kin.footJacobian(i) * a + kin.drift.col(i) - t.feet.col(i)).squaredNorm();
    }
    return 0.5 * e;
  };
  auto quadratic = [&](const VectorXd& a) { return 0.5 * a.dot(qp.H() * a) + qp.g().dot(a); };
  const VectorXd a0 = gaussian(nv, rng, 1.0);
  for (int trial = 0; trial < 5; ++trial) {
    const VectorXd a = gaussian(nv, rng, 1.0);
    // Equal up to a constant.
    EXPECT_NEAR(quadratic(a) - quadratic(a0), squares(a) - squares(a0),
                1e-9 * (1.0 + std::abs(squares(a))));
  }
}

// ---- contact rows ------------------------------------------------------------------------

TEST(CbfRows, ContactRowsHoldTheStanceFeetsVelocities) {
  const auto robot = ct::tachyon3Robot();
  const model::Model& m = robot->model();
  const int nv = robot->nv();
  model::Data data(m), d(m);
  ContactKinematics kin(*robot);
  Eigen::RowVectorXd scratch(nv);
  control::CbfQpSettings settings;
  std::mt19937 rng(13);
  const State s = randomState(*robot, rng);
  control::computeContactKinematics(*robot, data, s.q, s.v, kin);
  // LF, MF, MR in stance: LF (a drive wheel whose side partner RF swings) keeps its z and
  // lateral rows, MF and MR their z rows.
  const int mode = ct::maskOf({ct::LF, ct::MF, ct::MR});
  DenseQpProblem qp(DenseQpDims{nv, 8, 0});
  qp.H().setZero();
  qp.g().setZero();
  const int n_eq = control::writeContactRows(*robot, settings, kin, mode, true, scratch, qp);
  ASSERT_EQ(n_eq, 4);
  // Without lateral rows (skid steering) only the z rows.
  DenseQpProblem skid(DenseQpDims{nv, 8, 0});
  skid.H().setZero();
  skid.g().setZero();
  EXPECT_EQ(control::writeContactRows(*robot, settings, kin, mode, false, scratch, skid), 3);
  qp.setDimensions(nv, n_eq, 0);
  // Any a on the rows makes each kept foot's vertical velocity decay: d/dt v_z = -k v_z.
  const VectorXd a = qp.Aeq().completeOrthogonalDecomposition().solve(qp.beq());
  ASSERT_LE((qp.Aeq() * a - qp.beq()).norm(), 1e-9);
  for (int i : {ct::LF, ct::MF, ct::MR}) {
    const Vector3d vi = kin.velocity.col(i);
    const Derivatives fd = alongMotion(
        m, s.q, s.v, a, [&](const VectorXd& qq) { return footPosition(*robot, d, i, qq).z(); });
    EXPECT_NEAR(fd.hdd, -settings.contact_gain * vi.z(), 2e-5 * (1.0 + std::abs(fd.hdd)))
        << "foot " << i;
  }
  // Freed rows (the side-by-side rule: all six in stance frees RF and RR) go to the cost.
  DenseQpProblem all(DenseQpDims{nv, 10, 0});
  all.H().setZero();
  all.g().setZero();
  const int kept =
      control::writeContactRows(*robot, settings, kin, ct::kAllStance, true, scratch, all);
  EXPECT_EQ(kept, 2 + 1 + 2 + 1);  // LF, MF, LR, MR
  MatrixXd freed = MatrixXd::Zero(nv, nv);
  for (int i : {ct::RF, ct::RR}) {
    const Eigen::RowVectorXd z = kin.footJacobian(i).row(2);
    const Eigen::RowVectorXd lateral = kin.lateral.col(i).transpose() * kin.footJacobian(i);
    freed += settings.freed_contact_weight * (z.transpose() * z + lateral.transpose() * lateral);
  }
  EXPECT_GT(freed.norm(), 0.0);
  EXPECT_LE((all.H() - freed).norm(), 1e-9 * freed.norm());

  // On a slope (normals tilted 0.15 rad about y): each kept foot's velocity along its
  // normal decays, d/dt (n . v) = -k (n . v), not its world z velocity.
  const Vector3d n(-std::sin(0.15), 0.0, std::cos(0.15));
  const Eigen::Matrix3Xd normals = n.replicate(1, robot->nc());
  DenseQpProblem sloped(DenseQpDims{nv, 8, 0});
  sloped.H().setZero();
  sloped.g().setZero();
  ASSERT_EQ(control::writeContactRows(*robot, settings, kin, mode, true, scratch, sloped, &normals),
            4);
  sloped.setDimensions(nv, 4, 0);
  const VectorXd as = sloped.Aeq().completeOrthogonalDecomposition().solve(sloped.beq());
  ASSERT_LE((sloped.Aeq() * as - sloped.beq()).norm(), 1e-9);
  for (int i : {ct::LF, ct::MF, ct::MR}) {
    const Vector3d vi = kin.velocity.col(i);
    const Derivatives fd = alongMotion(
        m, s.q, s.v, as, [&](const VectorXd& qq) { return n.dot(footPosition(*robot, d, i, qq)); });
    EXPECT_NEAR(fd.hdd, -settings.contact_gain * n.dot(vi), 2e-5 * (1.0 + std::abs(fd.hdd)))
        << "foot " << i;
  }
  // +z normals give the rows without normals exactly.
  const Eigen::Matrix3Xd up = Vector3d::UnitZ().replicate(1, robot->nc());
  DenseQpProblem level(DenseQpDims{nv, 8, 0});
  level.H().setZero();
  level.g().setZero();
  control::writeContactRows(*robot, settings, kin, mode, true, scratch, level, &up);
  level.setDimensions(nv, 4, 0);
  EXPECT_TRUE(MatrixXd(level.Aeq()) == MatrixXd(qp.Aeq()));
  EXPECT_TRUE(VectorXd(level.beq()) == VectorXd(qp.beq()));
}

// ---- joint bounds ------------------------------------------------------------------------

TEST(CbfRows, JointBoundsKeepAJointInsideItsLimitsInClosedLoop) {
  // One joint (the base's six unbounded), pushed at the largest acceleration the bounds
  // allow, first towards its lower position limit, then its upper one.
  const double lower = -0.5, upper = 0.4, vmax = 1.0, gp = 20.0, gv = 50.0;
  const VectorXd lo = VectorXd::Constant(1, lower), up = VectorXd::Constant(1, upper),
                 vm = VectorXd::Constant(1, vmax);
  DenseQpProblem qp(DenseQpDims{7, 0, 0});
  for (double push : {-1.0, 1.0}) {
    VectorXd q = VectorXd::Zero(8), v = VectorXd::Zero(7);
    q[6] = 1.0;
    double q_min = 0.0, q_max = 0.0, v_abs = 0.0;
    for (int k = 0; k < 3000; ++k) {
      control::writeJointBounds(q, v, lo, up, vm, gp, gv, qp);
      EXPECT_EQ(qp.lb()[0], -kInf);
      EXPECT_EQ(qp.ub()[5], kInf);
      ASSERT_LE(qp.lb()[6], qp.ub()[6]);
      const double a = push < 0.0 ? qp.lb()[6] : qp.ub()[6];
      v[6] += 1e-3 * a;
      q[7] += 1e-3 * v[6];
      q_min = std::min(q_min, q[7]);
      q_max = std::max(q_max, q[7]);
      v_abs = std::max(v_abs, std::abs(v[6]));
    }
    EXPECT_GE(q_min, lower - 1e-3);
    EXPECT_LE(q_max, upper + 1e-3);
    EXPECT_LE(v_abs, vmax + 1e-3);
    // And it gets there: the bounds do not hold it back more than needed.
    if (push < 0.0) {
      EXPECT_LE(q_min, lower + 1e-2);
    } else {
      EXPECT_GE(q_max, upper - 1e-2);
    }
  }
}

// ---- barrier families --------------------------------------------------------------------

planning::ConvexRegion rectangle(double x0, double x1, double y0, double y1, double height,
                                 const Vector3d& normal = Vector3d::UnitZ()) {
  return planning::ConvexRegion::fromPolygon({{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}, height,
                                             normal);
}

TEST(CbfRows, RegionRowsAreBarriersOfTheRegionsEdges) {
  const auto robot = ct::tachyon3Robot();
  const model::Model& m = robot->model();
  model::Data data(m), d(m);
  ContactKinematics kin(*robot);
  const planning::ConvexRegion region = planning::ConvexRegion::fromPolygon(
      {{-2.0, -2.5}, {3.0, -2.0}, {2.0, 3.0}, {-3.0, 1.0}}, 0.1);
  DenseQpProblem qp(DenseQpDims{robot->nv(), 0, 8});
  std::mt19937 rng(14);
  for (int trial = 0; trial < 3; ++trial) {
    const State s = randomState(*robot, rng);
    control::computeContactKinematics(*robot, data, s.q, s.v, kin);
    const int i = trial % robot->nc();
    const int first = 2;
    ASSERT_EQ(control::writeRegionRows(region, kin, i, 7.0, qp, first), 4);
    std::vector<std::function<double(const VectorXd&)>> h;
    for (int e = 0; e < 4; ++e) {
      h.push_back([&, e](const VectorXd& qq) {
        const Vector3d p = footPosition(*robot, d, i, qq);
        return region.A.row(e).dot(p.head<2>()) + region.b[e];
      });
    }
    expectBarrierRows(m, s.q, s.v, qp, first, h, 7.0, rng, "region");
  }
}

TEST(CbfRows, ClearanceRowIsABarrierAboveTheSlopedGroundUnderTheWheel) {
  const auto robot = ct::tachyon3Robot();
  const model::Model& m = robot->model();
  model::Data data(m), d(m);
  ContactKinematics kin(*robot);
  const Vector3d normal = Vector3d(0.2, -0.1, 1.0).normalized();
  const planning::TerrainModel terrain(
      std::vector<planning::ConvexRegion>{rectangle(-10.0, 10.0, -10.0, 10.0, -0.2, normal)});
  const planning::TerrainModel nothing(
      std::vector<planning::ConvexRegion>{rectangle(50.0, 51.0, 50.0, 51.0, 0.0)});
  const double offset = robot->contactOffset(), clearance = 0.03, gamma = 9.0;
  DenseQpProblem qp(DenseQpDims{robot->nv(), 0, 4});
  std::mt19937 rng(15);
  for (int trial = 0; trial < 3; ++trial) {
    const State s = randomState(*robot, rng);
    control::computeContactKinematics(*robot, data, s.q, s.v, kin);
    const int i = (trial + 1) % robot->nc();
    ASSERT_EQ(control::writeClearanceRow(terrain, offset, clearance, kin, i, gamma, qp, 1), 1);
    const planning::ConvexRegion& ground = terrain.region(0);
    expectBarrierRows(m, s.q, s.v, qp, 1, {[&](const VectorXd& qq) {
                        const Vector3d p = footPosition(*robot, d, i, qq);
                        return p.z() - offset - ground.heightAt(p.head<2>()) - clearance;
                      }},
                      gamma, rng, "clearance");
    // No region under the wheel: the ground is z = 0.
    ASSERT_EQ(control::writeClearanceRow(nothing, offset, clearance, kin, i, gamma, qp, 3), 1);
    expectBarrierRows(m, s.q, s.v, qp, 3, {[&](const VectorXd& qq) {
                        return footPosition(*robot, d, i, qq).z() - offset - clearance;
                      }},
                      gamma, rng, "clearance without ground");
  }
}

TEST(CbfRows, CollisionRowIsABarrierOfTheSmoothedPrismDistance) {
  const auto robot = ct::tachyon3Robot();
  const model::Model& m = robot->model();
  model::Data data(m), d(m);
  ContactKinematics kin(*robot);
  const double offset = robot->contactOffset(), clearance = 0.02, sharpness = 40.0, gamma = 12.0;
  DenseQpProblem qp(DenseQpDims{robot->nv(), 0, 2});
  std::mt19937 rng(16);
  for (int trial = 0; trial < 3; ++trial) {
    const State s = randomState(*robot, rng);
    control::computeContactKinematics(*robot, data, s.q, s.v, kin);
    const int i = (trial + 2) % robot->nc();
    // A block just ahead of the wheel, its top level with it.
    const Vector3d p = kin.position.col(i);
    const planning::ConvexRegion block =
        rectangle(p.x() + 0.15, p.x() + 0.6, p.y() - 0.3, p.y() + 0.3, p.z());
    ASSERT_EQ(control::writeCollisionRow(block, offset, clearance, sharpness, kin, i, gamma, qp, 1),
              1);
    expectBarrierRows(m, s.q, s.v, qp, 1, {[&](const VectorXd& qq) {
                        const Vector3d pq = footPosition(*robot, d, i, qq);
                        return control::smoothPrismDistance(block, pq, sharpness).value - offset -
                               clearance;
                      }},
                      gamma, rng, "collision");
  }
}

TEST(CbfRows, ObstaclesAreTheNearPrismsOtherThanAndNotLevelWithTheSupport) {
  const planning::TerrainModel solids(std::vector<planning::ConvexRegion>{
      rectangle(-1.0, 1.0, -1.0, 1.0, 0.0),    // 0: under the wheel
      rectangle(1.0, 2.0, -1.0, 1.0, 0.2),     // 1: a step up ahead
      rectangle(-1.0, 1.0, 1.0, 2.0, 0.0005),  // 2: level with the support
      rectangle(5.0, 6.0, -1.0, 1.0, 0.3)});   // 3: far away
  const Vector3d p(0.8, 0.0, 0.075);
  const double offset = 0.075, range = 0.3;
  EXPECT_FALSE(control::isCollisionObstacle(solids, 0, p, -1, offset, range));
  EXPECT_TRUE(control::isCollisionObstacle(solids, 1, p, -1, offset, range));
  EXPECT_FALSE(control::isCollisionObstacle(solids, 2, p, -1, offset, range));
  EXPECT_FALSE(control::isCollisionObstacle(solids, 3, p, -1, offset, range));
  // A given support prism replaces the one under the wheel: from the step's top, the
  // ground prism (0.2 lower) is an obstacle and the step is not.
  EXPECT_TRUE(control::isCollisionObstacle(solids, 0, p, 1, offset, range));
  EXPECT_FALSE(control::isCollisionObstacle(solids, 1, p, 1, offset, range));
}

TEST(CbfRows, SupportHullIsTheCounterClockwiseHullOfTheSupportFeet) {
  const auto robot = ct::tachyon3Robot();
  model::Data data(robot->model());
  ContactKinematics kin(*robot);
  control::computeContactKinematics(*robot, data, ct::nominalState(*robot).head(robot->nq()),
                                    VectorXd::Zero(robot->nv()), kin);
  const int nc = robot->nc();
  std::vector<Vector2d> xy(static_cast<size_t>(nc));
  std::vector<int> feet(static_cast<size_t>(nc)), hull(static_cast<size_t>(nc) + 1);
  // The four corner wheels: all four on the hull, counter-clockwise.
  const int corners = ct::maskOf({ct::LF, ct::RF, ct::LR, ct::RR});
  const int n = control::supportHull(kin, nc, corners, xy, feet, hull);
  ASSERT_EQ(n, 4);
  for (int e = 0; e < n; ++e) {
    const Vector2d a =
        kin.position.col(feet[static_cast<size_t>(hull[static_cast<size_t>(e)])]).head<2>();
    const Vector2d b =
        kin.position.col(feet[static_cast<size_t>(hull[static_cast<size_t>((e + 1) % n)])])
            .head<2>();
    const Vector2d c =
        kin.position.col(feet[static_cast<size_t>(hull[static_cast<size_t>((e + 2) % n)])])
            .head<2>();
    const Vector2d ab = b - a, bc = c - b;
    EXPECT_GT(ab.x() * bc.y() - ab.y() * bc.x(), 0.0) << "not counter-clockwise at " << e;
  }
  // Two feet: no polygon.
  EXPECT_LT(control::supportHull(kin, nc, ct::maskOf({ct::LF, ct::RR}), xy, feet, hull), 3);
}

TEST(CbfRows, SupportRowsAreBarriersOfTheComInsideTheSupportPolygon) {
  const auto robot = ct::tachyon3Robot();
  const model::Model& m = robot->model();
  model::Data data(m), d(m);
  ContactKinematics kin(*robot);
  const int nc = robot->nc();
  std::vector<Vector2d> xy(static_cast<size_t>(nc));
  std::vector<int> feet(static_cast<size_t>(nc)), hull(static_cast<size_t>(nc) + 1);
  const double margin = 0.02, gamma = 6.0;
  DenseQpProblem qp(DenseQpDims{robot->nv(), 0, nc});
  std::mt19937 rng(17);
  for (int trial = 0; trial < 3; ++trial) {
    // Near the nominal posture: the feet spread around the COM.
    VectorXd q = ct::nominalState(*robot).head(robot->nq());
    q.tail(robot->nj()) += gaussian(robot->nj(), rng, 0.02);
    const VectorXd v = gaussian(robot->nv(), rng, 0.5);
    control::computeContactKinematics(*robot, data, q, v, kin);
    const int n = control::supportHull(kin, nc, ct::kAllStance, xy, feet, hull);
    ASSERT_GE(n, 3);
    ASSERT_EQ(control::writeSupportRows(m, data, q, kin, feet, hull, n, margin, gamma, qp, 0), n);
    // Each edge's inward normal is held at its value now (the rows' convention); its
    // midpoint and the COM move with the motion.
    std::vector<std::function<double(const VectorXd&)>> h;
    for (int e = 0; e < n; ++e) {
      const int ia = feet[static_cast<size_t>(hull[static_cast<size_t>(e)])];
      const int ib = feet[static_cast<size_t>(hull[static_cast<size_t>((e + 1) % n)])];
      const Vector2d edge = (kin.position.col(ib) - kin.position.col(ia)).head<2>();
      const Vector2d normal = Vector2d(-edge.y(), edge.x()).normalized();
      h.push_back([&, ia, ib, normal](const VectorXd& qq) {
        const Vector2d mid =
            0.5 * (footPosition(*robot, d, ia, qq) + footPosition(*robot, d, ib, qq)).head<2>();
        const Vector3d com = model::centerOfMass(m, d, qq);
        return normal.dot(com.head<2>() - mid) - margin;
      });
      // The COM is inside: every h > 0 at the nominal posture.
      EXPECT_GT(h.back()(q), 0.0) << "edge " << e;
    }
    expectBarrierRows(m, q, v, qp, 0, h, gamma, rng, "support");
  }
}

}  // namespace
