// The CBF-QP safety filter (cbf_qp.hpp): with no barrier active it is the weighted
// least-squares minimiser under the contact equalities (reference built from finite
// differences and a dense KKT solve); the analytic drift dJ v against finite differences
// along the motion; closed-loop barriers at 1 kHz (joint position and velocity limits,
// stance foothold region, swing wheel clearance) against the same integration without the
// barrier; infeasible barriers and invalid input give the documented fallback; no heap
// allocation; a quadruped works too; the time of one call.
#include "rollstep/control/cbf_qp.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <iostream>
#include <limits>
#include <random>
#include <vector>

#include "centroidal/fd_check.hpp"
#include "common/alloc_counter.hpp"
#include "rollstep/model/kinematics.hpp"

namespace {

using namespace rollstep;
using centroidal::CentroidalRobot;
using control::AccelerationTargets;
using control::CbfQpFilter;
using control::CbfQpSettings;
using control::CbfQpStatus;
using control::DenseQpStatus;
using control::FootRegionPlan;
using Eigen::MatrixXd;
using Eigen::Vector2d;
using Eigen::Vector3d;
using Eigen::VectorXd;
namespace ct = centroidal::test;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kDt = 1e-3;

// ---- robots and terrains ----------------------------------------------------------------

std::shared_ptr<const CentroidalRobot> quadrupedRobot() {
  static const auto robot = std::make_shared<const CentroidalRobot>(
      std::make_shared<const model::Model>(
          model::buildModelFromUrdfFile(std::string(ROLLSTEP_TEST_DATA_DIR) + "/quadruped.urdf")),
      std::vector<centroidal::ContactDescription>{
          {"FL_foot", true}, {"FR_foot", true}, {"HL_foot", true}, {"HR_foot", true}},
      std::vector<std::array<int, 2>>{{0, 1}, {2, 3}}, 0.02);
  return robot;
}

/// Joints at the middle of their limits (0 without limits), base upright at `height`.
VectorXd quadrupedConfiguration(const CentroidalRobot& robot, double height = 0.45) {
  VectorXd q = VectorXd::Zero(robot.nq());
  q[2] = height;
  q[6] = 1.0;
  const model::Model& m = robot.model();
  for (int j = 0; j < robot.nj(); ++j) {
    const double lo = m.lowerPositionLimit[j], hi = m.upperPositionLimit[j];
    q[7 + j] = std::isfinite(lo) && std::isfinite(hi) ? 0.5 * (lo + hi) : 0.0;
  }
  return q;
}

VectorXd tachyonConfiguration(const CentroidalRobot& robot, double height = 0.375) {
  return ct::nominalState(robot, height).head(robot.nq());
}

/// A flat floor at `height` over +-50 m (one region).
planning::TerrainModel flatTerrain(double height) {
  return planning::terrainFromBoxes({-50.0, 50.0, -50.0, 50.0, 0.0}, height, {});
}

planning::ConvexRegion rectangle(double x0, double x1, double y0, double y1, double height = 0.0) {
  return planning::ConvexRegion::fromPolygon({{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}, height);
}

// ---- kinematics by finite differences ---------------------------------------------------

/// World linear velocity of frame f's origin.
Vector3d frameVelocity(const model::Model& m, model::Data& d, int f, const VectorXd& q,
                       const VectorXd& v) {
  model::forwardKinematics(m, d, q, v);
  return model::getFrameVelocity(m, d, f, model::ReferenceFrame::LOCAL_WORLD_ALIGNED).head<3>();
}

/// The same as a dynamic vector (for the finite differences). Entry by entry: GCC 12 warns
/// (-Warray-bounds, a false positive) on the 4-wide AVX copy of a Vector3d temporary into a
/// VectorXd when the copy gets inlined.
VectorXd frameVelocityX(const model::Model& m, model::Data& d, int f, const VectorXd& q,
                        const VectorXd& v) {
  const Vector3d w = frameVelocity(m, d, f, q, v);
  VectorXd out(3);
  for (int k = 0; k < 3; ++k) out[k] = w[k];
  return out;
}

/// Lateral unit vector of frame f's yaw frame (x axis projected on the ground plane).
Vector3d lateralAxis(const model::Model& m, model::Data& d, int f, const VectorXd& q) {
  model::forwardKinematics(m, d, q);
  model::updateFramePlacement(m, d, f);
  const Vector3d x = d.oRf[static_cast<size_t>(f)].col(0);
  return Vector3d(-x.y(), x.x(), 0.0) / std::hypot(x.x(), x.y());
}

/// d/dt r(q(t), v(t)) at t = 0 along q(t) = q (+) t v, v(t) = v + t a (central difference).
template <typename Fn>
VectorXd alongMotion(const model::Model& m, const VectorXd& q, const VectorXd& v, const VectorXd& a,
                     Fn&& r, double eps = 1e-5) {
  VectorXd qp(q.size()), qm(q.size());
  model::integrate(m, q, eps * v, qp);
  model::integrate(m, q, -eps * v, qm);
  const VectorXd vp = v + eps * a, vm = v - eps * a;
  return (r(qp, vp) - r(qm, vm)) / (2.0 * eps);
}

/// The kept (or freed) velocity rows of stance foot i: c a + r0 = d/dt (row velocity).
struct ContactRow {
  Eigen::RowVectorXd c;
  double r0 = 0.0;     ///< d/dt row velocity at a = 0
  double value = 0.0;  ///< the row velocity
  bool kept = false;
};

std::vector<ContactRow> contactRows(const CentroidalRobot& robot, const VectorXd& q,
                                    const VectorXd& v, int mode) {
  const model::Model& m = robot.model();
  model::Data d(m);
  const VectorXd zero = VectorXd::Zero(robot.nv());
  std::vector<ContactRow> rows;
  for (int i = 0; i < robot.nc(); ++i) {
    if (!CentroidalRobot::inStance(mode, i)) continue;
    const int f = robot.frameIds()[static_cast<size_t>(i)];
    model::computeJointJacobians(m, d, q);
    MatrixXd J(6, robot.nv());
    model::getFrameJacobian(m, d, f, model::ReferenceFrame::LOCAL_WORLD_ALIGNED, J);
    ContactRow z;
    z.kept = robot.keepsVelocityConstraints(mode, i);
    z.c = J.row(2);
    z.value = frameVelocity(m, d, f, q, v).z();
    z.r0 = alongMotion(m, q, v, zero, [&](const VectorXd& qq, const VectorXd& vv) {
      return VectorXd::Constant(1, frameVelocity(m, d, f, qq, vv).z());
    })[0];
    rows.push_back(z);
    if (!robot.contact(i).drive_wheel) continue;
    ContactRow lat;
    lat.kept = z.kept;
    const Vector3d e = lateralAxis(m, d, f, q);
    lat.c = e.transpose() * J.topRows<3>();
    lat.value = e.dot(frameVelocity(m, d, f, q, v));
    lat.r0 = alongMotion(m, q, v, zero, [&](const VectorXd& qq, const VectorXd& vv) {
      return VectorXd::Constant(1, lateralAxis(m, d, f, qq).dot(frameVelocity(m, d, f, qq, vv)));
    })[0];
    rows.push_back(lat);
  }
  return rows;
}

/// The weighted least-squares minimiser under the contact equalities, built independently
/// of the filter (Jacobians from the model, drifts by finite differences, a dense KKT solve).
VectorXd referenceMinimiser(const CentroidalRobot& robot, const CbfQpSettings& s, const VectorXd& q,
                            const VectorXd& v, int mode, const AccelerationTargets& t) {
  const model::Model& m = robot.model();
  model::Data d(m);
  const int nv = robot.nv(), nj = robot.nj();
  MatrixXd H = MatrixXd::Zero(nv, nv);
  VectorXd g = VectorXd::Zero(nv);
  H.diagonal().head<6>() = s.base_weight;
  g.head<6>() = -s.base_weight.cwiseProduct(t.base);
  H.diagonal().tail(nj).array() += s.joint_weight;
  g.tail(nj) = -s.joint_weight * t.joints;
  H.diagonal().array() += s.damping;
  const VectorXd zero = VectorXd::Zero(nv);
  for (int i = 0; i < robot.nc(); ++i) {
    const int f = robot.frameIds()[static_cast<size_t>(i)];
    model::computeJointJacobians(m, d, q);
    MatrixXd J(6, nv);
    model::getFrameJacobian(m, d, f, model::ReferenceFrame::LOCAL_WORLD_ALIGNED, J);
    const VectorXd drift = alongMotion(m, q, v, zero, [&](const VectorXd& qq, const VectorXd& vv) {
      return frameVelocityX(m, d, f, qq, vv);
    });
    H += s.foot_weight * J.topRows<3>().transpose() * J.topRows<3>();
    g += s.foot_weight * J.topRows<3>().transpose() * (drift - t.feet.col(i));
  }
  const std::vector<ContactRow> rows = contactRows(robot, q, v, mode);
  std::vector<const ContactRow*> kept;
  for (const ContactRow& r : rows) {
    const double target = -s.contact_gain * r.value - r.r0;
    if (r.kept) {
      kept.push_back(&r);
    } else {
      H += s.freed_contact_weight * r.c.transpose() * r.c;
      g -= s.freed_contact_weight * target * r.c.transpose();
    }
  }
  const int me = static_cast<int>(kept.size());
  MatrixXd K = MatrixXd::Zero(nv + me, nv + me);
  VectorXd rhs(nv + me);
  K.topLeftCorner(nv, nv) = H;
  rhs.head(nv) = -g;
  for (int k = 0; k < me; ++k) {
    K.block(nv + k, 0, 1, nv) = kept[static_cast<size_t>(k)]->c;
    K.block(0, nv + k, nv, 1) = kept[static_cast<size_t>(k)]->c.transpose();
    rhs[nv + k] =
        -s.contact_gain * kept[static_cast<size_t>(k)]->value - kept[static_cast<size_t>(k)]->r0;
  }
  return K.completeOrthogonalDecomposition().solve(rhs).head(nv);
}

AccelerationTargets randomTargets(const CbfQpFilter& filter, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  AccelerationTargets t = filter.makeTargets();
  for (int k = 0; k < 6; ++k) t.base[k] = n(rng);
  for (int i = 0; i < t.feet.cols(); ++i) t.feet.col(i) = Vector3d(n(rng), n(rng), n(rng));
  for (int j = 0; j < t.joints.size(); ++j) t.joints[j] = n(rng);
  return t;
}

VectorXd randomVelocity(int nv, std::mt19937& rng, double scale) {
  std::normal_distribution<double> n(0.0, scale);
  VectorXd v(nv);
  for (int k = 0; k < nv; ++k) v[k] = n(rng);
  return v;
}

VectorXd fallbackOf(const CentroidalRobot& robot, const CbfQpSettings& s, const VectorXd& v) {
  VectorXd a = VectorXd::Zero(robot.nv());
  for (int j = 0; j < robot.nj(); ++j) {
    const double vj = v[6 + j];
    a[6 + j] = std::isfinite(vj) ? -vj / s.fallback_brake_time : 0.0;
  }
  return a;
}

// ---- (1) no barrier active: the weighted least-squares minimiser --------------------------

void expectLeastSquares(const std::shared_ptr<const CentroidalRobot>& robot, const VectorXd& q,
                        const std::vector<int>& modes, unsigned seed) {
  const planning::TerrainModel terrain = flatTerrain(-10.0);  // clearance far away
  CbfQpSettings s;
  CbfQpFilter filter(robot, terrain, s);
  std::mt19937 rng(seed);
  VectorXd a(robot->nv());
  for (int mode : modes) {
    for (int trial = 0; trial < 3; ++trial) {
      // Joint velocities well inside the knees' 0.8 m/s.
      const VectorXd v = randomVelocity(robot->nv(), rng, 0.15);
      const AccelerationTargets t = randomTargets(filter, rng);
      ASSERT_EQ(filter.filter(q, v, mode, nullptr, t, a), CbfQpStatus::Optimal);
      EXPECT_EQ(filter.activeBarriers(), 0);
      EXPECT_EQ(filter.correction(), 0.0);
      const VectorXd ref = referenceMinimiser(*robot, s, q, v, mode, t);
      EXPECT_LE((a - ref).lpNorm<Eigen::Infinity>(), 1e-5 * (1.0 + ref.lpNorm<Eigen::Infinity>()))
          << "mode " << mode << "\nfilter    " << a.transpose() << "\nreference "
          << ref.transpose();
      // The equalities of the QP hold to rounding.
      const auto& qp = filter.lastProblem();
      EXPECT_LE((qp.Aeq() * a - qp.beq()).lpNorm<Eigen::Infinity>(), 1e-9);
      // And they are what they should be: d/dt (row velocity) = -k row velocity, along the
      // motion with the filtered acceleration (finite differences).
      int kept = 0;
      for (const ContactRow& r : contactRows(*robot, q, v, mode)) {
        if (!r.kept) continue;
        ++kept;
        EXPECT_NEAR(r.c.dot(a) + r.r0, -s.contact_gain * r.value, 1e-6) << "mode " << mode;
      }
      EXPECT_EQ(qp.nEq(), kept);
    }
  }
}

TEST(CbfQp, WithoutActiveBarriersIsTheWeightedLeastSquaresMinimiser) {
  const auto robot = ct::tachyon3Robot();
  // All stance (side-by-side rule frees RF and RR), a trot phase, all swing, one swing.
  // Knees at mid-stroke, so that no joint barrier is near.
  VectorXd q = tachyonConfiguration(*robot);
  for (int j = 0; j < robot->nj(); ++j) {
    if (robot->model().jointNames[static_cast<size_t>(j)].find("knee") != std::string::npos) {
      q[7 + j] = 0.18;
    }
  }
  expectLeastSquares(robot, q, {63, 21, 42, 0, 62}, 1);
}

TEST(CbfQp, QuadrupedWithoutActiveBarriersIsTheWeightedLeastSquaresMinimiser) {
  const auto robot = quadrupedRobot();
  expectLeastSquares(robot, quadrupedConfiguration(*robot), {15, 9, 6, 0}, 2);
}

// ---- (2) drift against finite differences ------------------------------------------------

void expectDriftMatchesFiniteDifferences(const std::shared_ptr<const CentroidalRobot>& robot,
                                         unsigned seed) {
  const planning::TerrainModel terrain = flatTerrain(-10.0);
  CbfQpFilter filter(robot, terrain, CbfQpSettings{});
  const model::Model& m = robot->model();
  model::Data d(m);
  std::mt19937 rng(seed);
  VectorXd a(robot->nv());
  for (int trial = 0; trial < 10; ++trial) {
    const VectorXd q = ct::randomState(*robot, rng).head(robot->nq());
    const VectorXd v = randomVelocity(robot->nv(), rng, 1.0);
    const VectorXd acc = randomVelocity(robot->nv(), rng, 3.0);
    ASSERT_NE(filter.filter(q, v, 0, nullptr, filter.makeTargets(), a), CbfQpStatus::InvalidInput);
    for (int i = 0; i < robot->nc(); ++i) {
      const int f = robot->frameIds()[static_cast<size_t>(i)];
      auto vel = [&](const VectorXd& qq, const VectorXd& vv) {
        return frameVelocityX(m, d, f, qq, vv);
      };
      const Vector3d drift = filter.footDrift().col(i);
      const Vector3d fd0 = alongMotion(m, q, v, VectorXd::Zero(robot->nv()), vel);
      EXPECT_LE((drift - fd0).norm(), 1e-6 * (1.0 + fd0.norm())) << "foot " << i;
      const Vector3d analytic = filter.footJacobians().middleRows<3>(3 * i) * acc + drift;
      const Vector3d fd = alongMotion(m, q, v, acc, vel);
      EXPECT_LE((analytic - fd).norm(), 1e-6 * (1.0 + fd.norm())) << "foot " << i;
      // The drift is not trivially small: the check has teeth.
      if (trial == 0) {
        EXPECT_GT(fd0.norm(), 1e-2);
      }
    }
  }
}

TEST(CbfQp, DriftMatchesFiniteDifferencesTachyon3) {
  expectDriftMatchesFiniteDifferences(ct::tachyon3Robot(), 3);
}

TEST(CbfQp, DriftMatchesFiniteDifferencesQuadruped) {
  expectDriftMatchesFiniteDifferences(quadrupedRobot(), 4);
}

// ---- (3) closed loop at 1 kHz ------------------------------------------------------------

/// Integrates q, v with the acceleration `accel(q, v, a)` writes, semi-implicit Euler at
/// 1 kHz, calling `observe(q, v)` after every step.
void integrate(const model::Model& m, VectorXd& q, VectorXd& v, int steps,
               const std::function<void(const VectorXd&, const VectorXd&, VectorXd&)>& accel,
               const std::function<void(const VectorXd&, const VectorXd&)>& observe) {
  VectorXd a(m.nv);
  for (int k = 0; k < steps; ++k) {
    accel(q, v, a);
    v += kDt * a;
    model::integrate(m, q, kDt * v, q);
    observe(q, v);
  }
}

/// Feet targets consistent with a generalized acceleration (J_i a + dJ_i v), from the
/// filter's kinematics at this state (one filter() call first).
void consistentFeet(CbfQpFilter& filter, const VectorXd& q, const VectorXd& v, int mode,
                    const VectorXd& a_des, AccelerationTargets& t) {
  VectorXd scratch(a_des.size());
  filter.filter(q, v, mode, nullptr, t, scratch);
  for (int i = 0; i < t.feet.cols(); ++i) {
    t.feet.col(i) = filter.footJacobians().middleRows<3>(3 * i) * a_des + filter.footDrift().col(i);
  }
}

struct JointPush {
  int joint;         ///< pushed joint
  double target;     ///< PD target (beyond a limit) or NaN: constant acceleration
  double accel = 0;  ///< constant acceleration when target is NaN
};

/// Desired acceleration: base 0, every joint held at q0 by a PD except the pushed one.
VectorXd desiredAcceleration(const VectorXd& q0, const VectorXd& q, const VectorXd& v, int nj,
                             const JointPush& push) {
  VectorXd a = VectorXd::Zero(6 + nj);
  for (int j = 0; j < nj; ++j) a[6 + j] = 100.0 * (q0[7 + j] - q[7 + j]) - 20.0 * v[6 + j];
  const int j = push.joint;
  a[6 + j] =
      std::isnan(push.target) ? push.accel : 100.0 * (push.target - q[7 + j]) - 20.0 * v[6 + j];
  return a;
}

struct JointExtremes {
  double max_q = -kInf, min_q = kInf, max_v = -kInf, min_v = kInf;
  int not_optimal = 0;
  int last_joint_limits = 0;  ///< activeJointLimits() of the last step (filtered)
  std::uint64_t last_active_feet = 0;
};

/// All feet in swing, terrain far below: pushes one joint, filtered and unfiltered.
std::pair<JointExtremes, JointExtremes> pushJoint(
    const std::shared_ptr<const CentroidalRobot>& robot, const VectorXd& q0, const CbfQpSettings& s,
    const JointPush& push, int steps) {
  const planning::TerrainModel terrain = flatTerrain(-10.0);
  CbfQpFilter filter(robot, terrain, s);
  const model::Model& m = robot->model();
  const int nj = robot->nj(), j = push.joint;
  AccelerationTargets t = filter.makeTargets();
  JointExtremes filtered, unfiltered;
  auto record = [j](JointExtremes& e) {
    return [&e, j](const VectorXd& q, const VectorXd& v) {
      e.max_q = std::max(e.max_q, q[7 + j]);
      e.min_q = std::min(e.min_q, q[7 + j]);
      e.max_v = std::max(e.max_v, v[6 + j]);
      e.min_v = std::min(e.min_v, v[6 + j]);
    };
  };
  VectorXd q = q0, v = VectorXd::Zero(robot->nv());
  integrate(
      m, q, v, steps,
      [&](const VectorXd& qk, const VectorXd& vk, VectorXd& a) {
        const VectorXd a_des = desiredAcceleration(q0, qk, vk, nj, push);
        t.base = a_des.head<6>();
        t.joints = a_des.tail(nj);
        consistentFeet(filter, qk, vk, 0, a_des, t);
        if (filter.filter(qk, vk, 0, nullptr, t, a) != CbfQpStatus::Optimal) {
          ++filtered.not_optimal;
        }
        filtered.last_joint_limits = filter.activeJointLimits();
        filtered.last_active_feet = filter.activeFootBarriers();
      },
      record(filtered));
  q = q0;
  v.setZero();
  integrate(
      m, q, v, steps,
      [&](const VectorXd& qk, const VectorXd& vk, VectorXd& a) {
        a = desiredAcceleration(q0, qk, vk, nj, push);
      },
      record(unfiltered));
  return {filtered, unfiltered};
}

TEST(CbfQp, ClosedLoopJointPositionLimit) {
  const auto robot = ct::tachyon3Robot();
  const model::Model& m = robot->model();
  const VectorXd q0 = tachyonConfiguration(*robot);
  const CbfQpSettings s;
  {  // Hip (revolute) driven towards 1.5 rad, limit 0.785 rad.
    const int j = m.getJointId("LF_hip");
    const auto [f, u] = pushJoint(robot, q0, s, {j, 1.5}, 1500);
    const double limit = m.upperPositionLimit[j];
    EXPECT_EQ(f.not_optimal, 0);
    EXPECT_LE(f.max_q, limit + 1e-3);
    EXPECT_GT(f.max_q, limit - 0.02);  // it does get there
    EXPECT_GT(u.max_q, limit + 0.3);
    // Held there by its bound (the barrier log's qp_active_joints), no foot barrier.
    EXPECT_GE(f.last_joint_limits, 1);
    EXPECT_EQ(f.last_active_feet, 0u);
  }
  {  // Knee (prismatic) driven below its lower limit 0.
    const int j = m.getJointId("MR_knee");
    const auto [f, u] = pushJoint(robot, q0, s, {j, -0.2}, 1000);
    const double limit = m.lowerPositionLimit[j];
    EXPECT_EQ(f.not_optimal, 0);
    EXPECT_GE(f.min_q, limit - 1e-3);
    EXPECT_LT(u.min_q, limit - 0.1);
  }
  {  // With a margin: the joint stays that far from the limit.
    CbfQpSettings sm;
    sm.joint_position_margin = 0.1;
    const int j = m.getJointId("RR_hip");
    const auto [f, u] = pushJoint(robot, q0, sm, {j, -1.5}, 1500);
    const double limit = m.lowerPositionLimit[j] + 0.1;
    EXPECT_GE(f.min_q, limit - 1e-3);
    EXPECT_LT(u.min_q, limit - 0.3);
  }
}

TEST(CbfQp, ClosedLoopJointVelocityLimit) {
  const auto robot = ct::tachyon3Robot();
  const model::Model& m = robot->model();
  const VectorXd q0 = tachyonConfiguration(*robot);
  CbfQpSettings s;
  s.velocity_limit_scale = 0.2;
  {  // Hip: 5 rad/s * 0.2 = 1 rad/s, pushed at 10 rad/s^2 for 0.5 s.
    const int j = m.getJointId("MF_hip");
    JointPush push{j, std::nan(""), 10.0};
    const auto [f, u] = pushJoint(robot, q0, s, push, 500);
    const double vmax = 0.2 * m.velocityLimit[j];
    EXPECT_EQ(f.not_optimal, 0);
    EXPECT_LE(f.max_v, vmax * (1.0 + 1e-3));
    EXPECT_GT(f.max_v, 0.95 * vmax);
    EXPECT_GT(u.max_v, 3.0 * vmax);
  }
  {  // Knee: 0.8 m/s * 0.2, pulled back at -3 m/s^2 from 0.3 m (above the lower limit).
    const int j = m.getJointId("LR_knee");
    VectorXd q_start = q0;
    q_start[7 + j] = 0.3;
    const auto [f, u] = pushJoint(robot, q_start, s, {j, std::nan(""), -3.0}, 400);
    const double vmax = 0.2 * m.velocityLimit[j];
    EXPECT_EQ(f.not_optimal, 0);
    EXPECT_GE(f.min_v, -vmax * (1.0 + 1e-3));
    EXPECT_LT(u.min_v, -3.0 * vmax);
  }
}

TEST(CbfQp, QuadrupedClosedLoopJointPositionLimit) {
  const auto robot = quadrupedRobot();
  const model::Model& m = robot->model();
  const VectorXd q0 = quadrupedConfiguration(*robot);
  const int j = m.getJointId("FL_kfe");  // limits [-2.6, -0.1]
  const auto [f, u] = pushJoint(robot, q0, CbfQpSettings{}, {j, 0.5}, 1500);
  EXPECT_EQ(f.not_optimal, 0);
  EXPECT_LE(f.max_q, m.upperPositionLimit[j] + 1e-3);
  EXPECT_GT(u.max_q, m.upperPositionLimit[j] + 0.3);
}

/// All stance, the robot driven forward at 0.5 m/s (base and feet targets of a rigid
/// rolling motion, joints held) towards the front edge of the region under every foot.
struct RegionRun {
  double max_front_x = -kInf;  ///< largest x of a front wheel minus the front edge
  int not_optimal = 0;
  std::uint64_t last_active_feet = 0;  ///< activeFootBarriers() of the last step
};

RegionRun driveIntoEdge(const std::shared_ptr<const CentroidalRobot>& robot, const VectorXd& q0,
                        const std::vector<int>& front_feet, double edge, bool with_regions,
                        int steps, std::vector<double>* times = nullptr) {
  const planning::TerrainModel terrain(
      std::vector<planning::ConvexRegion>{rectangle(-3.0, edge, -3.0, 3.0)});
  CbfQpFilter filter(robot, terrain, CbfQpSettings{});
  const model::Model& m = robot->model();
  model::Data d(m);
  const int nc = robot->nc(), nj = robot->nj(), mode = (1 << nc) - 1;
  std::vector<FootRegionPlan> plan(static_cast<size_t>(nc));
  for (auto& p : plan) p.region = 0;
  AccelerationTargets t = filter.makeTargets();
  RegionRun run;
  VectorXd q = q0, v = VectorXd::Zero(robot->nv());
  integrate(
      m, q, v, steps,
      [&](const VectorXd& qk, const VectorXd& vk, VectorXd& a) {
        const Eigen::Matrix3d R = Eigen::Quaterniond(qk[6], qk[3], qk[4], qk[5]).toRotationMatrix();
        const Vector3d v_world = R * vk.head<3>();
        const double ax = 4.0 * (0.5 - v_world.x());
        t.base.setZero();
        t.base.head<3>() = R.transpose() * Vector3d(ax, 0.0, 0.0);
        for (int i = 0; i < nc; ++i) t.feet.col(i) = Vector3d(ax, 0.0, 0.0);
        for (int j = 0; j < nj; ++j) {
          t.joints[j] = 100.0 * (q0[7 + j] - qk[7 + j]) - 20.0 * vk[6 + j];
        }
        const auto start = std::chrono::steady_clock::now();
        const CbfQpStatus st =
            filter.filter(qk, vk, mode, with_regions ? plan.data() : nullptr, t, a);
        if (times != nullptr) {
          times->push_back(
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        }
        if (st != CbfQpStatus::Optimal) ++run.not_optimal;
        run.last_active_feet = filter.activeFootBarriers();
      },
      [&](const VectorXd& qk, const VectorXd&) {
        model::forwardKinematics(m, d, qk);
        for (int i : front_feet) {
          const int f = robot->frameIds()[static_cast<size_t>(i)];
          model::updateFramePlacement(m, d, f);
          run.max_front_x = std::max(run.max_front_x, d.opf[static_cast<size_t>(f)].x() - edge);
        }
      });
  return run;
}

TEST(CbfQp, ClosedLoopStanceFootStaysInItsRegion) {
  const auto robot = ct::tachyon3Robot();
  const VectorXd q0 = tachyonConfiguration(*robot);
  const double edge = 0.33 + 0.10;  // 10 cm ahead of the front wheels (x = 0.33)
  const std::vector<int> front{ct::LF, ct::MF, ct::RF};
  const RegionRun filtered = driveIntoEdge(robot, q0, front, edge, true, 1500);
  const RegionRun unfiltered = driveIntoEdge(robot, q0, front, edge, false, 1500);
  EXPECT_EQ(filtered.not_optimal, 0);
  EXPECT_EQ(unfiltered.not_optimal, 0);
  EXPECT_LE(filtered.max_front_x, 1e-3);
  EXPECT_GT(filtered.max_front_x, -0.02);  // it gets to the edge
  EXPECT_GT(unfiltered.max_front_x, 0.2);
  // Held at the edge by the front wheels' region rows (the barrier log's qp_active_<leg>),
  // the rear wheels' far from their edges; without regions none.
  for (int i = 0; i < 6; ++i) {
    const bool front_wheel = i == ct::LF || i == ct::MF || i == ct::RF;
    EXPECT_EQ(CbfQpFilter::footBarriers(filtered.last_active_feet, i),
              front_wheel ? 1 << control::kRegionBarrier : 0)
        << "foot " << i;
  }
  EXPECT_EQ(unfiltered.last_active_feet, 0u);
}

TEST(CbfQp, QuadrupedClosedLoopStanceFootStaysInItsRegion) {
  const auto robot = quadrupedRobot();
  const VectorXd q0 = quadrupedConfiguration(*robot);
  model::Data d(robot->model());
  model::forwardKinematics(robot->model(), d, q0);
  model::updateFramePlacements(robot->model(), d);
  const double front_x = d.opf[static_cast<size_t>(robot->frameIds()[0])].x();
  const double edge = front_x + 0.1;
  const RegionRun filtered = driveIntoEdge(robot, q0, {0, 1}, edge, true, 1000);
  const RegionRun unfiltered = driveIntoEdge(robot, q0, {0, 1}, edge, false, 1000);
  EXPECT_EQ(filtered.not_optimal, 0);
  EXPECT_LE(filtered.max_front_x, 1e-3);
  EXPECT_GT(unfiltered.max_front_x, 0.1);
}

/// LF in swing, pushed down at 3 m/s^2 from 3 cm above the floor (z = 0); the others hold.
double swingWheelLowest(const std::shared_ptr<const CentroidalRobot>& robot, double floor,
                        int* not_optimal, std::uint64_t* active_feet = nullptr) {
  const planning::TerrainModel terrain = flatTerrain(floor);
  CbfQpFilter filter(robot, terrain, CbfQpSettings{});
  const model::Model& m = robot->model();
  model::Data d(m);
  const VectorXd q0 = tachyonConfiguration(*robot, 0.375 + 0.03);
  const int mode = ct::kAllStance & ~(1 << ct::LF), nj = robot->nj();
  const int f = robot->frameIds()[ct::LF];
  AccelerationTargets t = filter.makeTargets();
  double lowest = kInf;
  VectorXd q = q0, v = VectorXd::Zero(robot->nv());
  integrate(
      m, q, v, 1000,
      [&](const VectorXd& qk, const VectorXd& vk, VectorXd& a) {
        t.base = -20.0 * vk.head<6>();
        t.feet.setZero();
        t.feet(2, ct::LF) = -3.0;
        for (int j = 0; j < nj; ++j) {
          t.joints[j] = 100.0 * (q0[7 + j] - qk[7 + j]) - 20.0 * vk[6 + j];
        }
        if (filter.filter(qk, vk, mode, nullptr, t, a) != CbfQpStatus::Optimal) ++*not_optimal;
        if (active_feet != nullptr) *active_feet = filter.activeFootBarriers();
      },
      [&](const VectorXd& qk, const VectorXd&) {
        model::forwardKinematics(m, d, qk);
        model::updateFramePlacement(m, d, f);
        lowest = std::min(lowest, d.opf[static_cast<size_t>(f)].z() - robot->contactOffset());
      });
  return lowest;
}

TEST(CbfQp, ClosedLoopSwingWheelStaysAboveTheGround) {
  const auto robot = ct::tachyon3Robot();
  int not_optimal = 0;
  std::uint64_t active = 0;
  const double filtered = swingWheelLowest(robot, 0.0, &not_optimal, &active);
  EXPECT_EQ(not_optimal, 0);
  // Resting on its clearance barrier at the end: LF's clearance row, nothing else.
  EXPECT_EQ(active, std::uint64_t{1}
                        << (control::kBarrierBitsPerFoot * ct::LF + control::kClearanceBarrier));
  EXPECT_GE(filtered, -1e-3);
  EXPECT_LT(filtered, 0.01);                                               // it does come down
  const double unfiltered = swingWheelLowest(robot, -10.0, &not_optimal);  // floor far below
  EXPECT_LT(unfiltered, -0.1);
}

// ---- (4) infeasible barriers, invalid input -----------------------------------------------

// Barriers without a common point: relaxed (the default), the contact rows and joint
// bounds exact, every barrier row broken by as little as the weights allow; the slacks are
// those of the relaxed problem's optimum (checked by its optimality conditions).
/// LF's region 50 m to the left, RF's 50 m to the right: the hips (about y) cannot move the
/// feet apart sideways at all; the plan that asks for it.
planning::TerrainModel farApartRegions() {
  return planning::TerrainModel(std::vector<planning::ConvexRegion>{
      rectangle(-1.0, 1.0, 49.5, 50.5), rectangle(-1.0, 1.0, -50.5, -49.5)});
}
std::vector<FootRegionPlan> farApartPlan() {
  std::vector<FootRegionPlan> plan(6);
  plan[ct::LF].region = 0;
  plan[ct::RF].region = 1;
  return plan;
}

TEST(CbfQp, InfeasibleBarriersAreRelaxedWithTheContactRowsAndJointBoundsExact) {
  const auto robot = ct::tachyon3Robot();
  const planning::TerrainModel terrain = farApartRegions();
  const CbfQpSettings s;
  CbfQpFilter filter(robot, terrain, s);
  const std::vector<FootRegionPlan> plan = farApartPlan();
  std::mt19937 rng(5);
  const VectorXd q = tachyonConfiguration(*robot);
  const VectorXd v = randomVelocity(robot->nv(), rng, 0.5);
  const AccelerationTargets targets = randomTargets(filter, rng);
  VectorXd a(robot->nv());
  ASSERT_EQ(filter.filter(q, v, ct::kAllStance, plan.data(), targets, a), CbfQpStatus::Relaxed);
  EXPECT_TRUE(filter.qpStatus() == DenseQpStatus::Infeasible ||
              filter.qpStatus() == DenseQpStatus::MaxIterations)
      << control::toString(filter.qpStatus());
  EXPECT_TRUE(std::isfinite(filter.correction()));
  const control::DenseQpProblem& p = filter.lastProblem();
  ASSERT_GT(p.nIneq(), 0);
  EXPECT_LE((p.Aeq() * a - p.beq()).lpNorm<Eigen::Infinity>(), 1e-8);
  for (int j = 0; j < robot->nv(); ++j) {
    EXPECT_GE(a[j], p.lb()[j] - 1e-9) << j;
    EXPECT_LE(a[j], p.ub()[j] + 1e-9) << j;
  }
  // Slack of each barrier row at a, and the optimality of a for the relaxed problem: with
  // the slacks eliminated, a minimises f(a) + w/2 sum max(0, l - C a)^2 subject to the
  // equalities and the bounds, so the gradient H a + g - w C^T max(0, l - C a) lies in the
  // span of the equality rows and the active bounds.
  const VectorXd viol = (p.l() - p.C() * a).cwiseMax(0.0);
  EXPECT_NEAR(filter.relaxation(), viol.maxCoeff(), 1e-9);
  EXPECT_GT(filter.relaxation(), 1e-3);
  const VectorXd grad = p.H() * a + p.g() - s.relaxation_weight * p.C().transpose() * viol;
  // It must be a combination of the equality rows and the unit vectors of the active bounds
  // (least-squares residual ~ 0 against its size).
  std::vector<int> active;
  for (int j = 0; j < robot->nv(); ++j) {
    if (a[j] <= p.lb()[j] + 1e-9 || a[j] >= p.ub()[j] - 1e-9) active.push_back(j);
  }
  Eigen::MatrixXd span =
      Eigen::MatrixXd::Zero(robot->nv(), p.nEq() + static_cast<int>(active.size()));
  span.leftCols(p.nEq()) = p.Aeq().transpose();
  for (std::size_t k = 0; k < active.size(); ++k)
    span(active[k], p.nEq() + static_cast<int>(k)) = 1.0;
  const VectorXd y = span.colPivHouseholderQr().solve(grad);
  const double scale = (s.relaxation_weight * p.C().transpose() * viol).lpNorm<Eigen::Infinity>();
  EXPECT_LE((span * y - grad).lpNorm<Eigen::Infinity>(), 1e-9 * scale);
}

TEST(CbfQp, InfeasibleBarriersWithoutRelaxationGiveTheFallback) {
  const auto robot = ct::tachyon3Robot();
  const planning::TerrainModel terrain = farApartRegions();
  CbfQpSettings s;
  s.relaxation_weight = 0.0;
  CbfQpFilter filter(robot, terrain, s);
  const std::vector<FootRegionPlan> plan = farApartPlan();
  std::mt19937 rng(5);
  const VectorXd q = tachyonConfiguration(*robot);
  const VectorXd v = randomVelocity(robot->nv(), rng, 0.5);
  VectorXd a(robot->nv());
  EXPECT_EQ(filter.filter(q, v, ct::kAllStance, plan.data(), randomTargets(filter, rng), a),
            CbfQpStatus::Fallback);
  EXPECT_TRUE(filter.qpStatus() == DenseQpStatus::Infeasible ||
              filter.qpStatus() == DenseQpStatus::MaxIterations)
      << control::toString(filter.qpStatus());
  EXPECT_EQ((a - fallbackOf(*robot, s, v)).lpNorm<Eigen::Infinity>(), 0.0);
  EXPECT_TRUE(a.head<6>().isZero(0.0));
  EXPECT_EQ(filter.correction(), kInf);
  // Without those regions the same tick is fine.
  EXPECT_EQ(filter.filter(q, v, ct::kAllStance, nullptr, randomTargets(filter, rng), a),
            CbfQpStatus::Optimal);
}

TEST(CbfQp, InvalidInputGivesAFiniteFallback) {
  const auto robot = ct::tachyon3Robot();
  const planning::TerrainModel terrain = flatTerrain(0.0);
  const CbfQpSettings s;
  CbfQpFilter filter(robot, terrain, s);
  std::mt19937 rng(6);
  const VectorXd q = tachyonConfiguration(*robot);
  const VectorXd v = randomVelocity(robot->nv(), rng, 0.5);
  const AccelerationTargets t = randomTargets(filter, rng);
  const double nan = std::nan("");
  VectorXd a(robot->nv());
  auto expectFallback = [&](const VectorXd& qq, const VectorXd& vv, int mode,
                            const FootRegionPlan* plan, const AccelerationTargets& tt,
                            const char* what) {
    a.setConstant(123.0);
    EXPECT_EQ(filter.filter(qq, vv, mode, plan, tt, a), CbfQpStatus::InvalidInput) << what;
    EXPECT_TRUE(a.allFinite()) << what;
    EXPECT_EQ((a - fallbackOf(*robot, s, vv)).lpNorm<Eigen::Infinity>(), 0.0) << what;
    EXPECT_EQ(filter.qpStatus(), DenseQpStatus::InvalidInput) << what;
  };
  VectorXd bad_q = q;
  bad_q[7 + 3] = nan;
  expectFallback(bad_q, v, 63, nullptr, t, "NaN in q");
  bad_q = q;
  bad_q[3] = 2.0;  // not a unit quaternion
  expectFallback(bad_q, v, 63, nullptr, t, "quaternion");
  VectorXd bad_v = v;
  bad_v[6 + 2] = nan;
  bad_v[1] = kInf;
  expectFallback(q, bad_v, 63, nullptr, t, "NaN in v");
  EXPECT_EQ(a[6 + 2], 0.0);  // the non-finite joint velocity counts as 0
  EXPECT_EQ(a[6 + 3], -v[6 + 3] / s.fallback_brake_time);
  AccelerationTargets bad_t = t;
  bad_t.base[4] = nan;
  expectFallback(q, v, 63, nullptr, bad_t, "NaN in base target");
  bad_t = t;
  bad_t.feet(1, 2) = nan;
  expectFallback(q, v, 63, nullptr, bad_t, "NaN in foot target");
  bad_t = t;
  bad_t.joints[5] = -kInf;
  expectFallback(q, v, 63, nullptr, bad_t, "Inf in joint target");
  expectFallback(q, v, 64, nullptr, t, "mode");
  expectFallback(q, v, -1, nullptr, t, "negative mode");
  std::vector<FootRegionPlan> plan(6);
  plan[1].region = terrain.size();
  expectFallback(q, v, 63, plan.data(), t, "region index");
  // The wrong size of a is refused without a write.
  VectorXd short_a = VectorXd::Constant(3, 7.0);
  EXPECT_EQ(filter.filter(q, v, 63, nullptr, t, short_a), CbfQpStatus::InvalidInput);
  EXPECT_TRUE(short_a.isConstant(7.0));
  // And the filter works again afterwards.
  EXPECT_EQ(filter.filter(q, v, 63, nullptr, t, a), CbfQpStatus::Optimal);
  EXPECT_EQ(filter.qpStatus(), DenseQpStatus::Optimal);
}

TEST(CbfQp, BadSettingsThrow) {
  const auto robot = ct::tachyon3Robot();
  const planning::TerrainModel terrain = flatTerrain(0.0);
  auto expectThrow = [&](auto change) {
    CbfQpSettings s;
    change(s);
    EXPECT_THROW(CbfQpFilter(robot, terrain, s), std::invalid_argument);
  };
  expectThrow([](CbfQpSettings& s) { s.damping = -1.0; });
  expectThrow([](CbfQpSettings& s) { s.foot_weight = std::nan(""); });
  expectThrow([](CbfQpSettings& s) { s.velocity_limit_scale = 1.5; });
  expectThrow([](CbfQpSettings& s) { s.relaxation_weight = -1.0; });
  expectThrow([](CbfQpSettings& s) { s.relaxation_weight = std::nan(""); });
  expectThrow([](CbfQpSettings& s) { s.region_gamma = 0.0; });
  expectThrow([](CbfQpSettings& s) { s.fallback_brake_time = 0.0; });
  expectThrow([](CbfQpSettings& s) { s.max_iterations = 0; });
  expectThrow([](CbfQpSettings& s) { s.joint_position_margin = 0.5; });  // hips: +-0.785
  expectThrow([](CbfQpSettings& s) {
    s.damping = 0.0;
    s.joint_weight = 0.0;
  });
  EXPECT_THROW(CbfQpFilter(nullptr, terrain, CbfQpSettings{}), std::invalid_argument);
}

// ---- conflicting joint barriers --------------------------------------------------------

TEST(CbfQp, ConflictingJointBarriersFavourTheVelocityLimit) {
  const auto robot = ct::tachyon3Robot();
  const model::Model& m = robot->model();
  const planning::TerrainModel terrain = flatTerrain(-10.0);
  const CbfQpSettings s;
  CbfQpFilter filter(robot, terrain, s);
  const int j = m.getJointId("LF_hip");
  const double up = m.upperPositionLimit[j], vmax = m.velocityLimit[j];
  VectorXd q = tachyonConfiguration(*robot);
  VectorXd v = VectorXd::Zero(robot->nv());
  VectorXd a(robot->nv());
  // Beyond the upper limit and moving down faster than the velocity limit: the position
  // barrier asks for a <= Up < 0, the velocity barrier for a >= Lv > Up.
  q[7 + j] = up + 0.5;
  v[6 + j] = -1.5 * vmax;
  const double gp = s.joint_position_gamma, gv = s.joint_velocity_gamma;
  const double Up = -2.0 * gp * v[6 + j] + gp * gp * (up - q[7 + j]);
  const double Lv = -gv * (vmax + v[6 + j]);
  ASSERT_GT(Lv, Up);
  ASSERT_EQ(filter.filter(q, v, 0, nullptr, filter.makeTargets(), a), CbfQpStatus::Optimal);
  EXPECT_EQ(filter.lastProblem().lb()[6 + j], Lv);
  EXPECT_EQ(filter.lastProblem().ub()[6 + j], Lv);
  EXPECT_NEAR(a[6 + j], Lv, 1e-12);
  // Below the lower limit, moving up too fast: pinned to the upper velocity bound.
  const double lo = m.lowerPositionLimit[j];
  q[7 + j] = lo - 0.6;
  v[6 + j] = 1.2 * vmax;
  const double Lp = -2.0 * gp * v[6 + j] - gp * gp * (q[7 + j] - lo);
  const double Uv = gv * (vmax - v[6 + j]);
  ASSERT_GT(Lp, Uv);
  ASSERT_EQ(filter.filter(q, v, 0, nullptr, filter.makeTargets(), a), CbfQpStatus::Optimal);
  EXPECT_EQ(filter.lastProblem().lb()[6 + j], Uv);
  EXPECT_EQ(filter.lastProblem().ub()[6 + j], Uv);
  // Without conflict the bounds are the barriers' own.
  q[7 + j] = 0.0;
  v[6 + j] = 0.0;
  ASSERT_EQ(filter.filter(q, v, 0, nullptr, filter.makeTargets(), a), CbfQpStatus::Optimal);
  EXPECT_DOUBLE_EQ(filter.lastProblem().ub()[6 + j], std::min(gp * gp * up, gv * vmax));
  EXPECT_EQ(filter.lastProblem().lb().head<6>()[0], -kInf);
}

TEST(CbfQp, RegionRowsFollowThePlan) {
  const auto robot = ct::tachyon3Robot();
  const planning::TerrainModel terrain(std::vector<planning::ConvexRegion>{
      rectangle(-3.0, 3.0, -3.0, 3.0),
      planning::ConvexRegion::fromPolygon({{-3.0, -3.0}, {3.0, -3.0}, {0.0, 3.0}}, 0.0)});
  CbfQpFilter filter(robot, terrain, CbfQpSettings{});
  const VectorXd q = tachyonConfiguration(*robot, 0.6);  // swing wheels well above the floor
  const VectorXd v = VectorXd::Zero(robot->nv());
  VectorXd a(robot->nv());
  std::vector<FootRegionPlan> plan(6);
  plan[ct::LF].region = 0;        // stance: 4 edges
  plan[ct::MF].swing_region = 1;  // swing, inactive: none
  plan[ct::LR].swing_region = 1;  // swing, active: 3 edges
  plan[ct::LR].swing_region_active = true;
  plan[ct::MR].region = 1;  // stance: 3 edges
  const int mode = ct::maskOf({ct::LF, ct::RF, ct::MR, ct::RR});
  ASSERT_EQ(filter.filter(q, v, mode, plan.data(), filter.makeTargets(), a), CbfQpStatus::Optimal);
  // 4 + 3 + 3 region rows and one clearance row per swing foot (MF, LR).
  EXPECT_EQ(filter.lastProblem().nIneq(), 4 + 3 + 3 + 2);
  // Kept rows: LF (z, lateral), MR (z), RR (z, lateral: its pair partner LR swings).
  EXPECT_EQ(filter.lastProblem().nEq(), 5);
}

// ---- (5) no allocation, timing -----------------------------------------------------------

TEST(CbfQp, FilterDoesNotAllocate) {
  const auto robot = ct::tachyon3Robot();
  const planning::TerrainModel terrain(std::vector<planning::ConvexRegion>{
      rectangle(-3.0, 0.40, -3.0, 3.0), rectangle(-1.0, 1.0, 49.5, 50.5),
      rectangle(-1.0, 1.0, -50.5, -49.5)});
  CbfQpFilter filter(robot, terrain, CbfQpSettings{});
  CbfQpSettings brake_settings;
  brake_settings.relaxation_weight = 0.0;  // infeasible barriers: the brake fallback
  CbfQpFilter brake(robot, terrain, brake_settings);
  std::mt19937 rng(7);
  const VectorXd q = tachyonConfiguration(*robot, 0.38);
  const VectorXd v = randomVelocity(robot->nv(), rng, 0.5);
  const AccelerationTargets t = randomTargets(filter, rng);
  std::vector<FootRegionPlan> plan(6);
  for (auto& p : plan) p.region = 0;
  std::vector<FootRegionPlan> infeasible(6);
  infeasible[ct::LF].region = 1;
  infeasible[ct::RF].region = 2;
  VectorXd bad_v = v;
  bad_v[0] = std::nan("");
  VectorXd a(robot->nv());
  filter.filter(q, v, 63, plan.data(), t, a);  // warm-up
  brake.filter(q, v, 63, plan.data(), t, a);
  int statuses[4] = {0, 0, 0, 0};
  double checksum = 0.0;
  {
    test::AllocationGuard guard;
    for (int rep = 0; rep < 3; ++rep) {
      for (int mode : {63, 21, 42, 0}) {
        ++statuses[static_cast<int>(filter.filter(q, v, mode, plan.data(), t, a))];
        checksum += a.sum() + filter.correction();
      }
      ++statuses[static_cast<int>(filter.filter(q, v, 63, infeasible.data(), t, a))];
      checksum += a.sum() + filter.relaxation();
      ++statuses[static_cast<int>(brake.filter(q, v, 63, infeasible.data(), t, a))];
      ++statuses[static_cast<int>(filter.filter(q, bad_v, 63, nullptr, t, a))];
      checksum += a.sum();
    }
    EXPECT_EQ(guard.count(), 0u);
  }
  EXPECT_EQ(statuses[static_cast<int>(CbfQpStatus::Optimal)], 12);
  EXPECT_EQ(statuses[static_cast<int>(CbfQpStatus::Relaxed)], 3);
  EXPECT_EQ(statuses[static_cast<int>(CbfQpStatus::Fallback)], 3);
  EXPECT_EQ(statuses[static_cast<int>(CbfQpStatus::InvalidInput)], 3);
  EXPECT_FALSE(std::isnan(checksum));
}

TEST(CbfQp, TimeOfOneCall) {
  const auto robot = ct::tachyon3Robot();
  std::vector<double> times;
  times.reserve(2000);
  const RegionRun run = driveIntoEdge(robot, tachyonConfiguration(*robot), {ct::LF, ct::RF}, 0.43,
                                      true, 2000, &times);
  EXPECT_EQ(run.not_optimal, 0);
  std::sort(times.begin(), times.end());
  const double median = times[times.size() / 2], p99 = times[times.size() * 99 / 100];
  std::cout << "CbfQpFilter::filter on Tachyon 3 (all stance, 6 foothold regions, joint "
               "limits; closed loop into a region edge): median "
            << median * 1e6 << " us, p99 " << p99 * 1e6 << " us, max " << times.back() * 1e6
            << " us over " << times.size() << " calls\n";
  RecordProperty("median_us", static_cast<int>(median * 1e6));
}

}  // namespace
