// The CBF-QP baseline's barriers (barriers.hpp, cbf_qp.hpp): the smoothed prism distance
// against the true distance (equal away from the edges, within its bound everywhere), its
// gradient and Hessian against finite differences; the support polygon; the filter's
// support-polygon and collision rows against their definitions (value, and the row's
// acceleration against finite differences along the motion); in closed loop at 1 kHz the
// COM stays inside the support polygon and a rolling wheel stops at a block's face, where
// the same runs without the barrier leave the polygon and run into the face.
#include "rollstep/control/barriers.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "centroidal/fd_check.hpp"
#include "rollstep/control/cbf_qp.hpp"
#include "rollstep/model/center_of_mass.hpp"
#include "rollstep/model/kinematics.hpp"

namespace {

using namespace rollstep;
using centroidal::CentroidalRobot;
using control::CbfQpFilter;
using control::CbfQpSettings;
using control::CbfQpStatus;
using Eigen::Vector2d;
using Eigen::Vector3d;
using Eigen::VectorXd;
namespace ct = centroidal::test;

/// The step20 block: x in [1, 2.2], y in [-1.5, 1.5], top 0.2 m.
planning::ConvexRegion block() {
  return planning::ConvexRegion::fromPolygon({{1.0, -1.5}, {2.2, -1.5}, {2.2, 1.5}, {1.0, 1.5}},
                                             0.2);
}

TEST(SmoothPrismDistance, EqualsTheTrueDistanceAwayFromTheEdges) {
  const planning::ConvexRegion b = block();
  const double k = 100.0;
  // In front of the near face (the top 10 cm and more lower), above the top, behind the far
  // face: the true distance to 1e-6.
  for (const Vector3d& p :
       {Vector3d(0.9, 0.0, 0.05), Vector3d(0.8, 0.3, 0.0), Vector3d(1.6, 0.2, 0.35),
        Vector3d(1.5, -0.4, 0.275), Vector3d(2.35, 0.0, 0.0)}) {
    const double truth = control::prismDistance(b, p);
    EXPECT_NEAR(control::smoothPrismDistance(b, p, k).value, truth, 1e-6) << p.transpose();
    EXPECT_NEAR(control::prismFaceDistance(b, p), truth, 1e-12);
  }
  // Everywhere: max face distance <= d <= max + log(5 faces) / k, and the max face distance
  // never exceeds the true one; at the edge the smoothing rounds the corner.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> x(0.7, 2.5), z(-0.1, 0.5), y(-0.5, 0.5);
  for (int trial = 0; trial < 2000; ++trial) {
    const Vector3d p(x(rng), y(rng), z(rng));
    const double m = control::prismFaceDistance(b, p);
    const double d = control::smoothPrismDistance(b, p, k).value;
    EXPECT_GE(d, m - 1e-12);
    EXPECT_LE(d, m + std::log(5.0) / k + 1e-12);
    if (m > 0.0) {
      EXPECT_LE(m, control::prismDistance(b, p) + 1e-12);
    }
  }
  // Exactly above the near edge the two faces tie: d = s + log(2) / k (the top and near
  // face both at 0.05; the other faces 1.2 m and more away).
  const Vector3d corner(0.95, 0.0, 0.25);
  EXPECT_NEAR(control::smoothPrismDistance(b, corner, k).value, 0.05 + std::log(2.0) / k, 1e-9);
}

TEST(SmoothPrismDistance, DoesNotJumpAcrossTheEdge) {
  // Along a wheel's path over the near edge at 0.3 m height the smoothed distance changes
  // by no more than the path length per step (1-Lipschitz), where the height of the terrain
  // under the point jumps by 0.2 m at x = 1.
  const planning::ConvexRegion b = block();
  double previous = control::smoothPrismDistance(b, Vector3d(0.8, 0.0, 0.3), 100.0).value;
  for (int s = 1; s <= 400; ++s) {
    const Vector3d p(0.8 + 0.001 * s, 0.0, 0.3);
    const double d = control::smoothPrismDistance(b, p, 100.0).value;
    EXPECT_LE(std::abs(d - previous), 0.001 + 1e-12);
    previous = d;
  }
}

TEST(SmoothPrismDistance, GradientAndHessianMatchFiniteDifferences) {
  const planning::ConvexRegion b = block();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> x(0.8, 2.4), z(0.0, 0.45), y(-0.5, 0.5);
  const double eps = 1e-6;
  for (int trial = 0; trial < 300; ++trial) {
    // Half of the points within 3 cm of an edge, where the smoothing matters.
    Vector3d p(x(rng), y(rng), z(rng));
    if (trial % 2 == 0)
      p = Vector3d(trial % 4 == 0 ? 1.0 : 2.2, p.y(), 0.2) +
          0.03 * Vector3d(x(rng) - 1.6, 0.0, z(rng) - 0.2).normalized();
    const control::SmoothDistance d = control::smoothPrismDistance(b, p, 100.0);
    for (int c = 0; c < 3; ++c) {
      const Vector3d e = eps * Vector3d::Unit(c);
      const control::SmoothDistance dp = control::smoothPrismDistance(b, p + e, 100.0);
      const control::SmoothDistance dm = control::smoothPrismDistance(b, p - e, 100.0);
      EXPECT_NEAR(d.gradient[c], (dp.value - dm.value) / (2 * eps), 1e-6) << p.transpose();
      const Vector3d column = (dp.gradient - dm.gradient) / (2 * eps);
      EXPECT_LE((d.hessian.col(c) - column).norm(), 1e-4 * (1.0 + column.norm())) << p.transpose();
    }
    EXPECT_NEAR(d.gradient.norm(), 1.0, 0.5);  // a convex combination of unit normals
  }
}

TEST(ConvexHull, CounterClockwiseWithoutInnerOrCollinearPoints) {
  const std::vector<Vector2d> points{{1, 1}, {0, 0}, {0.5, 0.5}, {1, 0}, {0, 1}, {0.5, 0}};
  int hull[7];
  const int n = control::convexHull(points.data(), 6, hull);
  ASSERT_EQ(n, 4);
  double area = 0.0;
  for (int k = 0; k < n; ++k) {
    const Vector2d& a = points[static_cast<size_t>(hull[k])];
    const Vector2d& b = points[static_cast<size_t>(hull[(k + 1) % n])];
    area += 0.5 * (a.x() * b.y() - a.y() * b.x());
    EXPECT_NE(hull[k], 2);  // inner
    EXPECT_NE(hull[k], 5);  // on an edge
  }
  EXPECT_NEAR(area, 1.0, 1e-12);  // positive: counter-clockwise
  const std::vector<Vector2d> line{{0, 0}, {1, 1}, {2, 2}};
  EXPECT_EQ(control::convexHull(line.data(), 3, hull), 0);
  EXPECT_EQ(control::convexHull(points.data(), 2, hull), 0);
}

// ---- the filter's rows ------------------------------------------------------------------

/// d/dt f(q(t), v(t)) at t = 0 along q(t) = q (+) t v, v(t) = v + t a.
template <typename Fn>
double alongMotion(const model::Model& m, const VectorXd& q, const VectorXd& v, const VectorXd& a,
                   Fn&& f, double eps = 1e-5) {
  VectorXd qp(q.size()), qm(q.size());
  model::integrate(m, q, eps * v, qp);
  model::integrate(m, q, -eps * v, qm);
  return (f(qp, v + eps * a) - f(qm, v - eps * a)) / (2.0 * eps);
}

struct FootKinematics {
  Eigen::Matrix3Xd p, v;
};

FootKinematics feet(const CentroidalRobot& r, const VectorXd& q, const VectorXd& v) {
  const model::Model& m = r.model();
  model::Data d(m);
  model::forwardKinematics(m, d, q, v);
  FootKinematics k{Eigen::Matrix3Xd(3, r.nc()), Eigen::Matrix3Xd(3, r.nc())};
  for (int i = 0; i < r.nc(); ++i) {
    const int f = r.frameIds()[static_cast<size_t>(i)];
    model::updateFramePlacement(m, d, f);
    k.p.col(i) = d.opf[static_cast<size_t>(f)];
    k.v.col(i) =
        model::getFrameVelocity(m, d, f, model::ReferenceFrame::LOCAL_WORLD_ALIGNED).head<3>();
  }
  return k;
}

Vector3d comVelocity(const CentroidalRobot& r, const VectorXd& q, const VectorXd& v) {
  model::Data d(r.model());
  return model::jacobianCenterOfMass(r.model(), d, q) * v;
}

Vector3d com(const CentroidalRobot& r, const VectorXd& q) {
  model::Data d(r.model());
  return model::centerOfMass(r.model(), d, q);
}

TEST(CbfQpBaselineBarriers, SupportRowsMatchTheirDefinition) {
  const auto robot = ct::tachyon3Robot();
  const model::Model& m = robot->model();
  const planning::TerrainModel terrain = planning::terrainFromBoxes({-50, 50, -50, 50, 0}, 0.0, {});
  CbfQpSettings s;
  s.clearance_gamma = 0.0;
  s.support_gamma = 15.0;
  s.support_margin = 0.02;
  CbfQpFilter filter(robot, terrain, s);
  std::mt19937 rng(5);
  std::normal_distribution<double> n01(0.0, 1.0);
  // The trot's stance triangle LF RF MR.
  const int mode = (1 << ct::LF) | (1 << ct::RF) | (1 << ct::MR);
  const int triangle[3] = {ct::LF, ct::MR, ct::RF};  // counter-clockwise seen from above
  VectorXd a(robot->nv());
  for (int trial = 0; trial < 5; ++trial) {
    VectorXd q = ct::nominalState(*robot).head(robot->nq());
    for (int j = 0; j < robot->nj(); ++j) q[7 + j] += 0.02 * n01(rng);
    q.head<2>() += 0.05 * Vector2d(n01(rng), n01(rng));
    VectorXd v(robot->nv()), acc(robot->nv());
    for (int c = 0; c < robot->nv(); ++c) {
      v[c] = 0.3 * n01(rng);
      acc[c] = 2.0 * n01(rng);
    }
    ASSERT_NE(filter.filter(q, v, mode, nullptr, filter.makeTargets(), a),
              CbfQpStatus::InvalidInput);
    const auto& qp = filter.lastProblem();
    ASSERT_EQ(qp.nIneq(), 3);
    const FootKinematics f0 = feet(*robot, q, v);
    for (int row = 0; row < 3; ++row) {
      // Which edge: the row's value h + margin is the COM's distance to that edge's line.
      bool matched = false;
      for (int e = 0; e < 3 && !matched; ++e) {
        const int ia = triangle[e], ib = triangle[(e + 1) % 3];
        const Vector2d edge = f0.p.col(ib).head<2>() - f0.p.col(ia).head<2>();
        const Vector2d nrm = Vector2d(-edge.y(), edge.x()).normalized();
        const Vector2d mid = 0.5 * (f0.p.col(ia) + f0.p.col(ib)).head<2>();
        const double h = nrm.dot(com(*robot, q).head<2>() - mid) - s.support_margin;
        // h' and its derivative along the motion with n held.
        auto hdot = [&](const VectorXd& qq, const VectorXd& vv) {
          const FootKinematics f = feet(*robot, qq, vv);
          return nrm.dot(comVelocity(*robot, qq, vv).head<2>() -
                         0.5 * (f.v.col(ia) + f.v.col(ib)).head<2>());
        };
        const double hd = hdot(q, v);
        const double hdd = alongMotion(m, q, v, acc, hdot);
        // Row: C a >= l, l = -drift - 2 g hd - g^2 h: h'' = C a + drift = C a - l - 2 g hd - g^2 h.
        const double g = s.support_gamma;
        const double predicted = qp.C().row(row).dot(acc) - qp.l()[row] - 2 * g * hd - g * g * h;
        if (std::abs(predicted - hdd) < 1e-5 * (1.0 + std::abs(hdd))) matched = true;
      }
      EXPECT_TRUE(matched) << "row " << row << " trial " << trial;
    }
  }
}

TEST(CbfQpBaselineBarriers, CollisionRowsMatchTheirDefinition) {
  const auto robot = ct::tachyon3Robot();
  const model::Model& m = robot->model();
  // The block 1 m ahead; LF's wheel 4 cm before its face, raised 10 cm (between the floor
  // and the top: the smoothed corner is in play).
  const planning::TerrainModel terrain =
      planning::terrainFromBoxes({-50, 50, -50, 50, 0}, 0.0, {{1.0, 2.2, -1.5, 1.5, 0.2}});
  CbfQpSettings s;
  s.clearance_gamma = 0.0;
  s.collision_gamma = 12.0;
  s.collision_clearance = 0.01;
  CbfQpFilter filter(robot, terrain, s);
  std::mt19937 rng(9);
  std::normal_distribution<double> n01(0.0, 1.0);
  VectorXd a(robot->nv());
  const int mode = ct::kAllStance & ~(1 << ct::LF);
  int rows_checked = 0;
  for (int trial = 0; trial < 5; ++trial) {
    VectorXd q = ct::nominalState(*robot).head(robot->nq());
    const FootKinematics nominal = feet(*robot, q, VectorXd::Zero(robot->nv()));
    q[0] = 1.0 - 0.075 - 0.04 - nominal.p(0, ct::LF) + 0.01 * n01(rng);
    q[2] += 0.10 + 0.02 * n01(rng);  // every wheel 10 cm up: the block is in range of LF, MF, RF
    VectorXd v(robot->nv()), acc(robot->nv());
    for (int c = 0; c < robot->nv(); ++c) {
      v[c] = 0.3 * n01(rng);
      acc[c] = 2.0 * n01(rng);
    }
    ASSERT_EQ(filter.filter(q, v, mode, nullptr, filter.makeTargets(), a), CbfQpStatus::Optimal);
    const auto& qp = filter.lastProblem();
    ASSERT_GE(qp.nIneq(), 1);
    const planning::ConvexRegion& b = terrain.region(terrain.regionAt(Vector2d(1.5, 0.0)));
    int row = 0;
    for (int i = 0; i < robot->nc(); ++i) {
      const FootKinematics f0 = feet(*robot, q, v);
      const control::SmoothDistance d = control::smoothPrismDistance(b, f0.p.col(i), 100.0);
      if (control::prismFaceDistance(b, f0.p.col(i)) - robot->contactOffset() > s.collision_range) {
        continue;
      }
      const double h = d.value - robot->contactOffset() - s.collision_clearance;
      auto hdot = [&](const VectorXd& qq, const VectorXd& vv) {
        const FootKinematics f = feet(*robot, qq, vv);
        return control::smoothPrismDistance(b, f.p.col(i), 100.0).gradient.dot(f.v.col(i));
      };
      const double hd = hdot(q, v);
      const double hdd = alongMotion(m, q, v, acc, hdot);
      const double g = s.collision_gamma;
      const double predicted = qp.C().row(row).dot(acc) - qp.l()[row] - 2 * g * hd - g * g * h;
      EXPECT_NEAR(predicted, hdd, 1e-5 * (1.0 + std::abs(hdd))) << "foot " << i;
      ++row;
      ++rows_checked;
    }
    EXPECT_EQ(row, qp.nIneq());
  }
  EXPECT_GE(rows_checked, 10);
}

// ---- closed loop at 1 kHz: the kinematic model driven by the filter ----------------------

/// Pushes the base forward (a_x = 2 m/s^2, other base axes damped) for 2 s in all-stance,
/// every foot held by a PD at its start (or, with `roll`, pushed forward like the base),
/// joints weakly at their start; integrates the
/// filtered acceleration (semi-implicit Euler) and calls observe(q) every step. Returns the
/// number of non-Optimal filter results.
int pushForward(CbfQpFilter& filter, VectorXd q, int support_mask, bool roll,
                const std::function<void(const VectorXd&)>& observe) {
  const CentroidalRobot& robot = filter.robot();
  const model::Model& m = robot.model();
  VectorXd v = VectorXd::Zero(robot.nv()), a(robot.nv());
  const FootKinematics start = feet(robot, q, v);
  const VectorXd q0 = q;
  control::AccelerationTargets t = filter.makeTargets();
  filter.setSupportFeet(support_mask);
  int not_optimal = 0;
  for (int k = 0; k < 2000; ++k) {
    const FootKinematics f = feet(robot, q, v);
    t.base = -10.0 * v.head<6>();
    t.base[0] = 2.0;
    for (int i = 0; i < robot.nc(); ++i) {
      t.feet.col(i) = 100.0 * (start.p.col(i) - f.p.col(i)) - 20.0 * f.v.col(i);
      if (roll) t.feet(0, i) = 2.0;
    }
    t.joints = 100.0 * (q0.tail(robot.nj()) - q.tail(robot.nj())) - 20.0 * v.tail(robot.nj());
    if (filter.filter(q, v, ct::kAllStance, nullptr, t, a) != CbfQpStatus::Optimal) ++not_optimal;
    v += 1e-3 * a;
    model::integrate(m, q, 1e-3 * v, q);
    observe(q);
  }
  return not_optimal;
}

TEST(CbfQpBaselineBarriers, ClosedLoopComStaysInsideTheSupportPolygon) {
  const auto robot = ct::tachyon3Robot();
  const planning::TerrainModel terrain = planning::terrainFromBoxes({-50, 50, -50, 50, 0}, 0.0, {});
  // The support triangle LF RF MR: its front edge runs through LF and RF. ((front edge x -
  // margin) - COM x: 0.18 m at the start.)
  const int triangle = (1 << ct::LF) | (1 << ct::RF) | (1 << ct::MR);
  auto run = [&](double gamma, int* not_optimal) {
    CbfQpSettings s;
    s.clearance_gamma = 0.0;
    s.support_gamma = gamma;
    s.support_margin = 0.15;  // inside the reach of the hips (+-45 deg)
    s.base_weight.setConstant(10.0);
    CbfQpFilter filter(robot, terrain, s);
    double worst = 1e9;  // least (front edge x - margin) - COM x over the run
    *not_optimal = pushForward(filter, ct::nominalState(*robot).head(robot->nq()), triangle, false,
                               [&](const VectorXd& q) {
                                 const FootKinematics f =
                                     feet(*robot, q, VectorXd::Zero(robot->nv()));
                                 const double edge = 0.5 * (f.p(0, ct::LF) + f.p(0, ct::RF));
                                 worst = std::min(worst, edge - 0.15 - com(*robot, q).x());
                               });
    return worst;
  };
  int not_optimal = 0;
  const double filtered = run(20.0, &not_optimal);
  EXPECT_EQ(not_optimal, 0);
  EXPECT_GE(filtered, -2e-3);                // the COM stops at the margin
  EXPECT_LE(filtered, 0.02);                 // and does get there
  EXPECT_LT(run(0.0, &not_optimal), -0.05);  // without the barrier it crosses the margin
}

TEST(CbfQpBaselineBarriers, ClosedLoopRollingWheelStopsAtTheFace) {
  const auto robot = ct::tachyon3Robot();
  const planning::TerrainModel terrain =
      planning::terrainFromBoxes({-50, 50, -50, 50, 0}, 0.0, {{1.0, 2.2, -1.5, 1.5, 0.2}});
  VectorXd q = ct::nominalState(*robot).head(robot->nq());
  const FootKinematics nominal = feet(*robot, q, VectorXd::Zero(robot->nv()));
  q[0] = 1.0 - 0.2 - nominal.p(0, ct::LF);  // the front wheel centres 20 cm before the face
  auto run = [&](double gamma, int* not_optimal) {
    CbfQpSettings s;
    s.clearance_gamma = 0.0;
    s.collision_gamma = gamma;
    s.collision_clearance = 0.02;
    CbfQpFilter filter(robot, terrain, s);
    double front = -1e9;  // the most forward front wheel centre
    *not_optimal = pushForward(filter, q, -1, true, [&](const VectorXd& qk) {
      const FootKinematics f = feet(*robot, qk, VectorXd::Zero(robot->nv()));
      for (const int i : {ct::LF, ct::MF, ct::RF}) front = std::max(front, f.p(0, i));
    });
    return front;
  };
  int not_optimal = 0;
  const double stop = 1.0 - robot->contactOffset() - 0.02;  // face - radius - clearance
  const double filtered = run(10.0, &not_optimal);
  EXPECT_EQ(not_optimal, 0);
  EXPECT_LE(filtered, stop + 2e-3);
  EXPECT_GE(filtered, stop - 0.02);        // it rolls up to the face
  EXPECT_GT(run(0.0, &not_optimal), 1.2);  // without the barrier it runs into the block
}

}  // namespace
