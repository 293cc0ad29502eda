// The inequality terms of the centroidal OCP (inequalities.hpp): values against the model
// and the terrain, rows per mode (stand, trot phases, static walk, swings over the step20
// block), Jacobians against central finite differences on the manifold with the node
// cache recomputed at every perturbed point, no allocation in rows/calc/calcDiff, and the
// joint limit bounds.
#include "rollstep/centroidal/inequalities.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/alloc_counter.hpp"
#include "fd_check.hpp"
#include "rollstep/centroidal/dynamics.hpp"
#include "rollstep/model/gravity.hpp"
#include "rollstep/ocp/problem.hpp"
#include "rollstep/planning/gait.hpp"

namespace {

using namespace rollstep;
using namespace rollstep::centroidal;
using namespace rollstep::centroidal::test;
using Eigen::Vector2d;
using Eigen::Vector3d;
using Eigen::VectorXd;

constexpr double kInf = std::numeric_limits<double>::infinity();
const std::vector<std::string> kFeet{"LF", "MF", "RF", "LR", "MR", "RR"};
const std::vector<Vector2d> kNominal{{0.33, 0.22},  {0.33, 0.0},  {0.33, -0.22},
                                     {-0.33, 0.22}, {-0.33, 0.0}, {-0.33, -0.22}};
constexpr double kClearance = 0.08;

/// The robot on the step20 block (a 20 cm box from x = 1.0 to 2.2), trotting at 0.5 m/s,
/// with a schedule long enough to cover the climb and the descent.
struct StepScene {
  planning::TerrainModel terrain =
      planning::terrainFromBoxes({-5.0, 10.0, -1.5, 1.5, 0.0}, 0.0, {{1.0, 2.2, -1.5, 1.5, 0.20}});
  planning::BaseReference base{terrain, {0.375, kNominal}};
  planning::FootReferencePlanner planner{
      terrain, base, {kNominal, kClearance, kTachyon3WheelRadius}};
  planning::GaitScheduler scheduler{
      planning::Gait::trot(6, 0.8, 0.6, planning::contactMask(kFeet, {"LF", "RF", "MR"}),
                           planning::contactMask(kFeet, {"MF", "LR", "RR"})),
      8.0};
  ocp::ModeSchedule schedule{scheduler.requiredCapacity()};
  StepScene() {
    base.reset(0.0, lie::SE3(), {0.5, 0.0, 0.0});
    scheduler.fill(0.0, 8.0, schedule);
  }
  TerrainReferences references() const { return {&terrain, &planner}; }
};

struct Fixture : ::testing::Test {
  std::shared_ptr<const CentroidalRobot> robot = tachyon3Robot();
  CentroidalPrecomputation pre{robot};
  std::unique_ptr<ocp::NodeCache> cache = pre.createCache();
  std::mt19937 rng{7};

  NodeEvaluator evaluator(int mode, double time, const ocp::ModeSchedule* schedule) {
    NodeEvaluator ev;
    ev.pre = &pre;
    ev.cache = cache.get();
    ev.ctx = makeContext(mode, time, schedule, cache.get());
    return ev;
  }
};

/// The mode classes every term is checked in: standing, both trot phases, all-stance
/// overlap, each static-walk swing, a flight phase.
std::vector<int> modeClasses() {
  std::vector<int> modes{kAllStance, maskOf({LF, RF, MR}), maskOf({MF, LR, RR}), 0};
  for (int i = 0; i < 6; ++i) modes.push_back(kAllStance & ~(1 << i));
  return modes;
}

int stanceCount(int mode) {
  int n = 0;
  for (int i = 0; i < 6; ++i) n += CentroidalRobot::inStance(mode, i) ? 1 : 0;
  return n;
}

// ---- static torque limits ----------------------------------------------------------------

TEST_F(Fixture, TorqueRowsAreTheModelsStaticTorqueAgainstTheEffortLimits) {
  TorqueLimitOptions at_frames;
  at_frames.force_at_contact_point = false;
  const StaticTorqueLimitResidual res(robot, at_frames);
  const model::Model& m = robot->model();
  ASSERT_EQ(res.maxRows(), 2 * robot->nj());
  model::Data data(m);
  auto d = res.createData();
  for (int trial = 0; trial < 10; ++trial) {
    const VectorXd x = randomState(*robot, rng), u = randomInput(*robot, rng);
    for (int mode : modeClasses()) {
      const NodeEvaluator ev = evaluator(mode, 0.0, nullptr);
      const VectorXd r = residualValue(res, ev, x, u, *d);
      ASSERT_EQ(r.size(), 2 * robot->nj());  // every Tachyon 3 joint has an effort limit
      const VectorXd tau =
          model::computeStaticTorque(m, data, x.head(m.nq), robot->frameIds(), u.tail(18))
              .tail(m.nj);
      for (int j = 0; j < m.nj; ++j) {
        EXPECT_NEAR(r[j], m.effortLimit[j] - tau[j], 1e-9 * (1 + std::abs(tau[j])));
        EXPECT_NEAR(r[m.nj + j], tau[j] + m.effortLimit[j], 1e-9 * (1 + std::abs(tau[j])));
      }
    }
  }
}

TEST_F(Fixture, TorqueLimitsFromOptions) {
  const model::Model& m = robot->model();
  TorqueLimitOptions half;
  half.scale = 0.5;
  const StaticTorqueLimitResidual scaled(robot, half);
  EXPECT_DOUBLE_EQ(scaled.upperLimits()[0], 0.5 * m.effortLimit[0]);
  EXPECT_DOUBLE_EQ(scaled.lowerLimits()[0], -0.5 * m.effortLimit[0]);

  // Explicit limits: infinite sides give no rows; rows are uppers then lowers.
  TorqueLimitOptions o;
  o.force_at_contact_point = false;
  o.upper = VectorXd::Constant(robot->nj(), 50.0);
  o.lower = VectorXd::Constant(robot->nj(), -kInf);
  o.upper[3] = kInf;
  o.lower[1] = -10.0;
  const StaticTorqueLimitResidual res(robot, o);
  const ocp::NodeContext ctx = makeContext(kAllStance, 0.0, nullptr, nullptr);
  EXPECT_EQ(res.rows(ctx), robot->nj());  // 11 uppers + 1 lower
  const VectorXd x = randomState(*robot, rng), u = randomInput(*robot, rng);
  auto d = res.createData();
  const VectorXd r = residualValue(res, evaluator(kAllStance, 0.0, nullptr), x, u, *d);
  model::Data data(m);
  const VectorXd tau =
      model::computeStaticTorque(m, data, x.head(m.nq), robot->frameIds(), u.tail(18)).tail(m.nj);
  EXPECT_NEAR(r[2], 50.0 - tau[2], 1e-9);
  EXPECT_NEAR(r[3], 50.0 - tau[4], 1e-9);  // joint 3 has no upper row
  EXPECT_NEAR(r[11], tau[1] + 10.0, 1e-9);
  // The row-gathering path (not every side limited) has the right Jacobians too.
  EXPECT_TRUE(
      checkResidualDerivatives(res, *robot->space(), evaluator(kAllStance, 0.0, nullptr), x, u));

  // Bad options name themselves.
  TorqueLimitOptions bad;
  bad.scale = 1.5;
  EXPECT_THROW(StaticTorqueLimitResidual(robot, bad), std::invalid_argument);
  bad = {};
  bad.upper = VectorXd::Zero(3);
  bad.lower = VectorXd::Zero(3);
  EXPECT_THROW(StaticTorqueLimitResidual(robot, bad), std::invalid_argument);
  bad.upper = VectorXd::Constant(robot->nj(), -1.0);
  bad.lower = VectorXd::Constant(robot->nj(), 1.0);
  try {
    StaticTorqueLimitResidual r2(robot, bad);
    FAIL() << "lower > upper accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("LF_hip"), std::string::npos) << e.what();
  }
  EXPECT_THROW(StaticTorqueLimitResidual(nullptr), std::invalid_argument);
}

TEST_F(Fixture, TorqueWithTheForcesAtTheGroundContactPoints) {
  // With the base level and the hips at 0 every shank is vertical, so the ground contact
  // point p_i - r e_z is the URDF's <leg>_contact frame: the default term must give
  // model::computeStaticTorque at those frames.
  const StaticTorqueLimitResidual res(robot);
  TorqueLimitOptions at_frames;
  at_frames.force_at_contact_point = false;
  const StaticTorqueLimitResidual centres(robot, at_frames);
  const model::Model& m = robot->model();
  std::vector<model::FrameIndex> ground;
  for (const std::string& f : kFeet) ground.push_back(m.getFrameId(f + "_contact"));
  model::Data data(m);
  auto d = res.createData();
  auto dc = centres.createData();
  const NodeEvaluator ev = evaluator(kAllStance, 0.0, nullptr);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  for (int trial = 0; trial < 10; ++trial) {
    VectorXd x = randomState(*robot, rng);
    const VectorXd u = randomInput(*robot, rng);
    x.segment<4>(3) =
        Eigen::Quaterniond(Eigen::AngleAxisd(M_PI * uni(rng), Vector3d::UnitZ())).coeffs();
    for (int j = 0; j < m.nj; ++j) {
      if (m.jointNames[static_cast<size_t>(j)].find("hip") != std::string::npos) x[7 + j] = 0.0;
    }
    ev.at(x, u, false);
    const VectorXd tau = res.torques(ev.ctx, x, u, *d);
    const VectorXd expected =
        model::computeStaticTorque(m, data, x.head(m.nq), ground, u.tail(18)).tail(m.nj);
    EXPECT_LE((tau - expected).cwiseAbs().maxCoeff(), 1e-9) << tau.transpose() << "\n"
                                                            << expected.transpose();
    // The hips see the moment of the traction force about the wheel centre; the
    // prismatic knees see no moment.
    const VectorXd at_centres = centres.torques(ev.ctx, x, u, *dc);
    EXPECT_GT((tau - at_centres).cwiseAbs().maxCoeff(), 0.1);
    for (int j = 0; j < m.nj; ++j) {
      if (m.jointNames[static_cast<size_t>(j)].find("knee") != std::string::npos) {
        EXPECT_NEAR(tau[j], at_centres[j], 1e-9);
      }
    }
  }
}

TEST_F(Fixture, TorqueJacobiansMatchFiniteDifferences) {
  TorqueLimitOptions at_frames;
  at_frames.force_at_contact_point = false;
  const StaticTorqueLimitResidual res(robot);
  const StaticTorqueLimitResidual centres(robot, at_frames);
  EXPECT_TRUE(res.dependsOnInput());
  EXPECT_FALSE(res.isLinear());
  // Both sides of every joint: row j + nj is the lower limit of row j's joint, whose
  // Jacobians are the exact negatives (the solver condenses the pair with one product).
  const int nj = robot->nj();
  const ocp::NodeContext ctx = makeContext(kAllStance, 0.0, nullptr, nullptr);
  EXPECT_EQ(res.mirroredRows(ctx), nj);
  {
    auto d = res.createData();
    const VectorXd x = randomState(*robot, rng), u = randomInput(*robot, rng);
    d->rows = res.rows(ctx);
    res.calc(ctx, x, u, *d);
    res.calcDiff(ctx, x, u, *d);
    EXPECT_TRUE(d->Rx.middleRows(nj, nj) == -d->Rx.topRows(nj));
    EXPECT_TRUE(d->Ru.middleRows(nj, nj) == -d->Ru.topRows(nj));
    EXPECT_FALSE(d->Ru.topRows(nj).isZero(0.0));
  }
  TorqueLimitOptions one_sided;
  one_sided.upper = VectorXd::Constant(nj, 50.0);
  one_sided.lower = VectorXd::Constant(nj, -kInf);
  one_sided.lower[1] = -10.0;
  EXPECT_EQ(StaticTorqueLimitResidual(robot, one_sided).mirroredRows(ctx), 0);
  for (int trial = 0; trial < 5; ++trial) {
    const VectorXd x = randomState(*robot, rng), u = randomInput(*robot, rng);
    for (int mode : {kAllStance, maskOf({LF, RF, MR}), maskOf({MF, LR, RR})}) {
      for (const StaticTorqueLimitResidual* term : {&res, &centres}) {
        EXPECT_TRUE(
            checkResidualDerivatives(*term, *robot->space(), evaluator(mode, 0.0, nullptr), x, u))
            << "trial " << trial << " mode " << mode;
      }
    }
  }
  // Without a shared cache the term computes its own: same Jacobians.
  NodeEvaluator alone;
  alone.ctx = makeContext(kAllStance, 0.0, nullptr, nullptr);
  EXPECT_TRUE(checkResidualDerivatives(res, *robot->space(), alone, randomState(*robot, rng),
                                       randomInput(*robot, rng)));
  EXPECT_TRUE(refusesCallsWithoutNodeCache(res, alone.ctx, randomState(*robot, rng),
                                           randomInput(*robot, rng)));
}

// ---- friction pyramid ----------------------------------------------------------------------

TEST_F(Fixture, FrictionRowsPerModeAndTheirJacobians) {
  StepScene s;
  const FrictionPyramidResidual res(robot, s.references());
  EXPECT_TRUE(res.isLinear());
  EXPECT_FALSE(res.dependsOnState());
  EXPECT_EQ(res.maxRows(), 5 * 6);
  for (int mode : modeClasses()) {
    const NodeEvaluator ev = evaluator(mode, 0.3, &s.schedule);
    EXPECT_EQ(res.rows(ev.ctx), 5 * stanceCount(mode)) << mode;
    const VectorXd x = randomState(*robot, rng), u = randomInput(*robot, rng);
    EXPECT_TRUE(checkResidualDerivatives(res, *robot->space(), ev, x, u)) << mode;
    // Affine in u, exactly: r(u + du) = r(u) + Ru du.
    auto d = res.createData();
    const VectorXd r0 = residualValue(res, ev, x, u, *d);
    res.calcDiff(ev.ctx, x, u, *d);
    const Eigen::MatrixXd Ru = d->Ru.topRows(d->rows);
    const VectorXd du = randomInput(*robot, rng);
    const VectorXd r1 = residualValue(res, ev, randomState(*robot, rng), u + du, *d);
    ASSERT_EQ(r1.size(), r0.size());
    EXPECT_LE((r1 - r0 - Ru * du).norm(), 1e-9);
  }
}

TEST_F(Fixture, FrictionRowsAreNonNegativeExactlyInsideThePyramid) {
  for (bool inscribed : {true, false}) {
    FrictionPyramidOptions o;
    o.mu = 0.6;
    o.min_normal_force = 5.0;
    o.inscribed = inscribed;
    const FrictionPyramidResidual res(robot, {}, o);  // no terrain: flat ground
    const double m = inscribed ? o.mu / std::sqrt(2.0) : o.mu;
    const int mode = maskOf({MF});
    const NodeEvaluator ev = evaluator(mode, 0.0, nullptr);
    auto d = res.createData();
    const VectorXd x = nominalState(*robot);
    VectorXd u = VectorXd::Zero(robot->nu());
    auto rowsFor = [&](const Vector3d& f) {
      u.segment<3>(robot->inputForceIndex(MF)) = f;
      return VectorXd(residualValue(res, ev, x, u, *d));
    };
    ASSERT_EQ(rowsFor({0, 0, 100}).size(), 5);
    EXPECT_NEAR(rowsFor({0, 0, 100})[4], 95.0, 1e-12);
    // Inside on every facet: all rows >= 0.
    for (const Vector3d& f : {Vector3d(0.99 * m * 100, 0, 100), Vector3d(0, -0.99 * m * 100, 100),
                              Vector3d(0.7 * m * 100, 0.7 * m * 100, 100), Vector3d(0, 0, 5)}) {
      const VectorXd r = rowsFor(f);
      EXPECT_GE(r.minCoeff(), 0.0) << f.transpose() << " -> " << r.transpose();
    }
    // Outside through each facet or the normal-force floor: exactly one row negative.
    for (const Vector3d& f :
         {Vector3d(1.01 * m * 100, 0, 100), Vector3d(-1.01 * m * 100, 0, 100),
          Vector3d(0, 1.01 * m * 100, 100), Vector3d(0, -1.01 * m * 100, 100), Vector3d(0, 0, 4)}) {
      const VectorXd r = rowsFor(f);
      EXPECT_EQ((r.array() < 0.0).count(), 1) << f.transpose() << " -> " << r.transpose();
    }
    // The inscribed pyramid admits only forces inside the true cone.
    if (inscribed) {
      const VectorXd r = rowsFor({0.99 * o.mu * 100, 0, 100});  // inside the cone, not the pyramid
      EXPECT_LT(r.minCoeff(), 0.0);
    }
  }
}

TEST_F(Fixture, FrictionPyramidFollowsTheTerrainNormal) {
  // One big region tilted by 0.3 rad about world y: the pyramid turns with its normal.
  const double a = 0.3;
  const Vector3d n(std::sin(a), 0.0, std::cos(a));
  planning::TerrainModel terrain(
      {planning::ConvexRegion::fromPolygon({{-5, -5}, {5, -5}, {5, 5}, {-5, 5}}, 0.0, n)});
  planning::BaseReference base(terrain, {0.375, kNominal});
  base.reset(0.0, lie::SE3(), {});
  planning::FootReferencePlanner planner(terrain, base, {kNominal, kClearance, 0.075});
  ocp::ModeSchedule schedule(4);
  schedule.setConstant(kAllStance);
  FrictionPyramidOptions o;
  o.mu = 0.5;
  o.inscribed = false;
  const FrictionPyramidResidual res(robot, {&terrain, &planner}, o);

  const Eigen::Matrix3d R = FrictionPyramidResidual::terrainFrame(n);
  EXPECT_NEAR((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-12);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
  EXPECT_NEAR((R.col(2) - n).norm(), 0.0, 1e-12);
  EXPECT_NEAR(R.col(1).dot(Vector3d::UnitY()), 1.0, 1e-12);  // t2 = y for a tilt about y

  const NodeEvaluator ev = evaluator(kAllStance, 0.0, &schedule);
  auto d = res.createData();
  VectorXd u = VectorXd::Zero(robot->nu());
  for (int i = 0; i < 6; ++i) u.segment<3>(robot->inputForceIndex(i)) = 100.0 * n;
  const VectorXd x = nominalState(*robot);
  VectorXd r = residualValue(res, ev, x, u, *d);
  ASSERT_EQ(r.size(), 30);
  EXPECT_NEAR(r[4], 100.0, 1e-9);  // f_n along the tilted normal
  EXPECT_NEAR(r[0], 50.0, 1e-9);   // mu f_n - f_t1, f_t1 = 0
  // A world-vertical force has the tangential part -100 sin a along t1: inside the cone
  // while tan a < mu (0.31 < 0.5)...
  u.segment<3>(robot->inputForceIndex(LF)) = 100.0 * Vector3d::UnitZ();
  r = residualValue(res, ev, x, u, *d);
  EXPECT_NEAR(r[4], 100.0 * std::cos(a), 1e-9);
  EXPECT_NEAR(r[0], 0.5 * 100.0 * std::cos(a) + 100.0 * std::sin(a), 1e-9);
  EXPECT_NEAR(r[1], 0.5 * 100.0 * std::cos(a) - 100.0 * std::sin(a), 1e-9);
  EXPECT_GE(r.head<5>().minCoeff(), 0.0);
  // ... and on this slope a force tilted 0.3 rad further down-slope leaves the cone.
  u.segment<3>(robot->inputForceIndex(LF)) = 100.0 * Vector3d(-std::sin(a), 0.0, std::cos(a));
  r = residualValue(res, ev, x, u, *d);
  EXPECT_LT(r.head<5>().minCoeff(), 0.0);

  FrictionPyramidOptions bad;
  bad.mu = 0.0;
  EXPECT_THROW(FrictionPyramidResidual(robot, {}, bad), std::invalid_argument);
  bad = {};
  bad.min_normal_force = -1.0;
  EXPECT_THROW(FrictionPyramidResidual(robot, {}, bad), std::invalid_argument);
}

// ---- foothold regions ------------------------------------------------------------------------

TEST_F(Fixture, StanceRegionRowsAreTheSignedEdgeDistances) {
  StepScene s;
  const FootRegionResidual res(robot, s.references(), RegionUse::Stance);
  EXPECT_FALSE(res.dependsOnInput());
  EXPECT_EQ(res.maxEdges(), 4);  // rectangles
  EXPECT_EQ(res.maxRows(), 6 * 4);
  EXPECT_TRUE(refusesCallsWithoutNodeCache(res, evaluator(kAllStance, 0.0, &s.schedule).ctx,
                                           randomState(*robot, rng), randomInput(*robot, rng)));
  auto d = res.createData();
  int checked = 0;
  for (double t = 0.0; t < 6.0; t += 0.05) {
    const int mode = s.schedule.modeAt(t);
    const NodeEvaluator ev = evaluator(mode, t, &s.schedule);
    const VectorXd x = randomState(*robot, rng), u = randomInput(*robot, rng);
    const VectorXd r = residualValue(res, ev, x, u, *d);
    const auto& c = static_cast<const CentroidalCache&>(*cache);
    int row = 0;
    for (int i = 0; i < 6; ++i) {
      if (!CentroidalRobot::inStance(mode, i)) continue;
      const int region = s.planner.query(s.schedule, i, t).region;
      ASSERT_GE(region, 0);
      // The region under the foothold where this stance began (the wheel may roll, not
      // climb): FootReferencePlanner::stanceFoothold.
      EXPECT_EQ(region, s.terrain.regionAt(s.planner.stanceFoothold(s.schedule, i, t)));
      const planning::ConvexRegion& reg = s.terrain.region(region);
      const Vector2d p = c.footPosition(i).head<2>();
      ASSERT_LE(row + reg.A.rows(), r.size());
      EXPECT_NEAR(r.segment(row, reg.A.rows()).minCoeff(), reg.margin(p), 1e-12);
      EXPECT_NEAR((r.segment(row, reg.A.rows()) - (reg.A * p + reg.b)).norm(), 0.0, 1e-12);
      row += static_cast<int>(reg.A.rows());
      ++checked;
    }
    EXPECT_EQ(row, r.size()) << "t = " << t;
    if (static_cast<int>(std::lround(t / 0.05)) % 10 == 0) {
      EXPECT_TRUE(checkResidualDerivatives(res, *robot->space(), ev, x, u)) << "t = " << t;
    }
  }
  EXPECT_GT(checked, 100);

  // The nominal posture over the flat start region is inside it, a foot far to the side
  // is not.
  const NodeEvaluator ev = evaluator(kAllStance, 0.0, &s.schedule);
  VectorXd x = nominalState(*robot);
  EXPECT_GT(residualValue(res, ev, x, VectorXd::Zero(robot->nu()), *d).minCoeff(), 0.0);
  x[1] = 1.6;  // base moved 1.6 m to the left: the left feet leave the floor (|y| <= 1.5)
  EXPECT_LT(residualValue(res, ev, x, VectorXd::Zero(robot->nu()), *d).minCoeff(), 0.0);

  // No terrain, no planner or no schedule: no rows.
  const FootRegionResidual none(robot, {}, RegionUse::Stance);
  EXPECT_EQ(none.maxRows(), 0);
  EXPECT_EQ(none.rows(makeContext(kAllStance, 0.0, &s.schedule, nullptr)), 0);
  EXPECT_EQ(res.rows(makeContext(kAllStance, 0.0, nullptr, nullptr)), 0);
  EXPECT_THROW(FootRegionResidual(robot, s.references(), RegionUse::Stance, -1),
               std::invalid_argument);
  // Capacity smaller than a region: rows() refuses instead of overrunning.
  const FootRegionResidual small(robot, s.references(), RegionUse::Stance, 3);
  EXPECT_THROW(small.rows(makeContext(kAllStance, 0.0, &s.schedule, nullptr)), std::length_error);
}

TEST_F(Fixture, SwingRegionOnlyInTheColliderHalfOfAStepSwing) {
  StepScene s;
  const FootRegionResidual res(robot, s.references(), RegionUse::Swing);
  const int floor_before = s.terrain.regionAt({0.0, 0.0});
  const int floor_after = s.terrain.regionAt({3.0, 0.0});
  auto d = res.createData();
  int ascending = 0, descending = 0, inactive_swings = 0, fd_checks = 0;
  for (double t = 0.0; t < 7.5; t += 0.01) {
    const int mode = s.schedule.modeAt(t);
    const NodeEvaluator ev = evaluator(mode, t, &s.schedule);
    const VectorXd x = randomState(*robot, rng), u = randomInput(*robot, rng);
    const VectorXd r = residualValue(res, ev, x, u, *d);
    const auto& c = static_cast<const CentroidalCache&>(*cache);
    int row = 0;
    for (int i = 0; i < 6; ++i) {
      const planning::FootReference ref = s.planner.query(s.schedule, i, t);
      EXPECT_EQ(ref.timing.stance, CentroidalRobot::inStance(mode, i));
      if (ref.timing.stance) continue;
      // Lift-off end: the foothold of the stance that ends there.
      const Vector2d p_lo =
          s.planner.stanceFoothold(s.schedule, i, std::nextafter(ref.timing.liftoff, -1e300));
      const Vector2d p_td = s.planner.nominalFoothold(i, ref.timing.touchdown);
      bool active = false;
      if (p_lo.x() < 1.0 && p_td.x() > 1.0) {  // up the front edge: first half, floor before
        active = ref.timing.phase <= 0.5;
        EXPECT_EQ(ref.swing_region, floor_before);
        ascending += active ? 1 : 0;
      } else if (p_lo.x() < 2.2 && p_td.x() > 2.2) {  // down the back edge: second half
        active = ref.timing.phase >= 0.5;
        EXPECT_EQ(ref.swing_region, floor_after);
        descending += active ? 1 : 0;
      }
      inactive_swings += active ? 0 : 1;
      EXPECT_EQ(ref.swing_region_active, active) << "foot " << i << " t " << t;
      if (!active) continue;
      const planning::ConvexRegion& reg = s.terrain.region(ref.swing_region);
      const Vector2d p = c.footPosition(i).head<2>();
      ASSERT_LE(row + reg.A.rows(), r.size());
      EXPECT_NEAR((r.segment(row, reg.A.rows()) - (reg.A * p + reg.b)).norm(), 0.0, 1e-12);
      row += static_cast<int>(reg.A.rows());
    }
    EXPECT_EQ(row, r.size()) << "t = " << t;
    if (r.size() > 0 && fd_checks < 6) {
      EXPECT_TRUE(checkResidualDerivatives(res, *robot->space(), ev, x, u)) << "t = " << t;
      ++fd_checks;
    }
  }
  EXPECT_GT(ascending, 10);
  EXPECT_GT(descending, 10);
  EXPECT_GT(inactive_swings, 100);
  EXPECT_EQ(fd_checks, 6);
  // Stance feet never get swing rows.
  EXPECT_EQ(res.rows(makeContext(kAllStance, 1.0, &s.schedule, nullptr)), 0);
}

// ---- no allocation -------------------------------------------------------------------------

TEST_F(Fixture, RowsCalcAndCalcDiffDoNotAllocate) {
  StepScene s;
  const StaticTorqueLimitResidual torque(robot);
  const FrictionPyramidResidual friction(robot, s.references());
  const FootRegionResidual stance(robot, s.references(), RegionUse::Stance);
  const FootRegionResidual swing(robot, s.references(), RegionUse::Swing);
  const std::vector<const ocp::Residual*> terms{&torque, &friction, &stance, &swing};
  std::vector<std::unique_ptr<ocp::ResidualData>> data;
  for (const auto* t : terms) data.push_back(t->createData());
  const VectorXd x = randomState(*robot, rng), u = randomInput(*robot, rng);
  int swing_rows = 0;
  for (double t = 0.0; t < 7.5; t += 0.05) {
    const ocp::NodeContext shared = makeContext(s.schedule.modeAt(t), t, &s.schedule, cache.get());
    ocp::NodeContext alone = shared;
    alone.cache = nullptr;
    pre.compute(shared, x, u, true, *cache);
    rollstep::test::AllocationGuard guard;
    for (const ocp::NodeContext& ctx : {shared, alone}) {
      for (std::size_t k = 0; k < terms.size(); ++k) {
        data[k]->rows = terms[k]->rows(ctx);
        terms[k]->calc(ctx, x, u, *data[k]);
        terms[k]->calcDiff(ctx, x, u, *data[k]);
      }
      swing_rows += data[3]->rows;
    }
    EXPECT_EQ(guard.count(), 0u) << "t = " << t;
  }
  EXPECT_GT(swing_rows, 0);
  // The guard does count in this executable (createData allocates).
  rollstep::test::AllocationGuard guard;
  const auto extra = torque.createData();
  EXPECT_GT(guard.count(), 0u);
}

TEST_F(Fixture, CalcDiffIntoWritesTheRowsOfCalcDiffAndNothingElse) {
  StepScene s;
  const StaticTorqueLimitResidual torque(robot);
  TorqueLimitOptions upper_limits;  // no lower limits: the rows are gathered one by one
  upper_limits.lower = Eigen::VectorXd::Constant(robot->nj(), -kInf);
  upper_limits.upper = Eigen::VectorXd::Constant(robot->nj(), 30.0);
  const StaticTorqueLimitResidual upper_only(robot, upper_limits);
  const FrictionPyramidResidual friction(robot, s.references());
  const FootRegionResidual stance(robot, s.references(), RegionUse::Stance);
  const FootRegionResidual swing(robot, s.references(), RegionUse::Swing);
  const std::vector<const ocp::Residual*> terms{&torque, &upper_only, &friction, &stance, &swing};
  const VectorXd x = randomState(*robot, rng), u = randomInput(*robot, rng);
  int swing_rows = 0;
  for (double t = 0.0; t < 7.5; t += 0.1) {
    const ocp::NodeContext ctx = makeContext(s.schedule.modeAt(t), t, &s.schedule, cache.get());
    pre.compute(ctx, x, u, true, *cache);
    for (std::size_t k = 0; k < terms.size(); ++k) {
      expectCalcDiffIntoMatchesCalcDiff(*terms[k], ctx, x, u,
                                        "term " + std::to_string(k) + " t " + std::to_string(t));
    }
    swing_rows += swing.rows(ctx);
  }
  EXPECT_GT(swing_rows, 0);
}

// The solver keeps of the inequality Jacobians only the columns the terms declare
// (Residual::stateColumns, inputColumns): every entry outside them must be exactly zero, in
// every mode, at any state and input.
TEST_F(Fixture, JacobiansAreZeroOutsideTheDeclaredColumns) {
  StepScene s;
  const StaticTorqueLimitResidual torque(robot);
  TorqueLimitOptions at_origins;
  at_origins.force_at_contact_point = false;
  const StaticTorqueLimitResidual torque_at_origins(robot, at_origins);
  const FrictionPyramidResidual friction(robot, s.references());
  const FootRegionResidual stance(robot, s.references(), RegionUse::Stance);
  const FootRegionResidual swing(robot, s.references(), RegionUse::Swing);
  const std::vector<const ocp::Residual*> terms{&torque, &torque_at_origins, &friction, &stance,
                                                &swing};
  // The configuration's columns and the contact forces: narrower than the whole Jacobian.
  EXPECT_EQ(torque.stateColumns().first, 0);
  EXPECT_EQ(torque.stateColumns().count, robot->nv());
  EXPECT_EQ(torque.inputColumns().first, robot->nj());
  EXPECT_EQ(torque.inputColumns().count, 3 * robot->nc());
  EXPECT_EQ(friction.stateColumns().count, 0);
  EXPECT_EQ(stance.inputColumns().count, 0);
  std::vector<std::unique_ptr<ocp::ResidualData>> data;
  for (const auto* t : terms) data.push_back(t->createData());
  std::vector<int> rows_seen(terms.size(), 0);
  for (int trial = 0; trial < 4; ++trial) {
    const VectorXd x = randomState(*robot, rng), u = randomInput(*robot, rng);
    for (double t = 0.0; t < 7.5; t += 0.05) {
      const ocp::NodeContext ctx = makeContext(s.schedule.modeAt(t), t, &s.schedule, cache.get());
      pre.compute(ctx, x, u, true, *cache);
      for (std::size_t k = 0; k < terms.size(); ++k) {
        ocp::ResidualData& d = *data[k];
        d.rows = terms[k]->rows(ctx);
        d.Rx.setConstant(std::numeric_limits<double>::quiet_NaN());
        d.Ru.setConstant(std::numeric_limits<double>::quiet_NaN());
        terms[k]->calc(ctx, x, u, d);
        terms[k]->calcDiff(ctx, x, u, d);
        rows_seen[k] += d.rows;
        const ocp::ColumnRange cx = terms[k]->stateColumns(), cu = terms[k]->inputColumns();
        for (int i = 0; i < d.rows; ++i) {
          for (int c = 0; c < robot->ndx(); ++c) {
            if (c >= cx.first && c < cx.first + cx.count) continue;
            ASSERT_EQ(d.Rx(i, c), 0.0) << "term " << k << " row " << i << " x column " << c;
          }
          for (int c = 0; c < robot->nu(); ++c) {
            if (c >= cu.first && c < cu.first + cu.count) continue;
            ASSERT_EQ(d.Ru(i, c), 0.0) << "term " << k << " row " << i << " u column " << c;
          }
        }
      }
    }
  }
  for (std::size_t k = 0; k < terms.size(); ++k) EXPECT_GT(rows_seen[k], 0) << "term " << k;
}

// ---- joint limit bounds ----------------------------------------------------------------------

TEST_F(Fixture, JointLimitBoundsFromTheModel) {
  const model::Model& m = robot->model();
  const JointLimitBounds b = jointLimitBounds(*robot);
  ASSERT_EQ(b.state_lower.size(), robot->ndx());
  ASSERT_EQ(b.state_upper.size(), robot->ndx());
  ASSERT_EQ(b.input_lower.size(), robot->nu());
  ASSERT_EQ(b.input_upper.size(), robot->nu());
  for (int k = 0; k < robot->ndx(); ++k) {
    const int j = k - robot->tangentJointIndex();
    if (j >= 0 && j < m.nj) {
      EXPECT_EQ(b.state_lower[k], m.lowerPositionLimit[j]);
      EXPECT_EQ(b.state_upper[k], m.upperPositionLimit[j]);
    } else {
      EXPECT_EQ(b.state_lower[k], -kInf);
      EXPECT_EQ(b.state_upper[k], kInf);
    }
  }
  for (int k = 0; k < robot->nu(); ++k) {
    if (k < m.nj) {
      EXPECT_EQ(b.input_upper[k], m.velocityLimit[k]);
      EXPECT_EQ(b.input_lower[k], -m.velocityLimit[k]);
    } else {
      EXPECT_EQ(b.input_lower[k], -kInf);
      EXPECT_EQ(b.input_upper[k], kInf);
    }
  }
  // The knee (prismatic, [0, 0.36] m) and hip limits shrink by the margin; velocities scale.
  const JointLimitBounds s = jointLimitBounds(*robot, {0.01, 0.5});
  const int knee = m.getJointId("LF_knee");
  EXPECT_NEAR(s.state_lower[6 + knee], 0.01, 1e-15);
  EXPECT_NEAR(s.state_upper[6 + knee], 0.35, 1e-15);
  EXPECT_NEAR(s.input_upper[knee], 0.4, 1e-15);
  EXPECT_NEAR(s.input_lower[knee], -0.4, 1e-15);

  EXPECT_THROW(jointLimitBounds(*robot, {-0.01, 1.0}), std::invalid_argument);
  EXPECT_THROW(jointLimitBounds(*robot, {0.2, 1.0}), std::invalid_argument);  // empties knees
  EXPECT_THROW(jointLimitBounds(*robot, {0.0, 0.0}), std::invalid_argument);
  EXPECT_THROW(jointLimitBounds(*robot, {0.0, 1.1}), std::invalid_argument);
}

// ---- composed into the problem ------------------------------------------------------------

TEST_F(Fixture, ComposedIntoTheProblemOverTheStep) {
  StepScene s;
  auto pre_ptr = std::make_shared<const CentroidalPrecomputation>(robot);
  auto F =
      std::make_shared<const ocp::ExplicitEuler>(std::make_shared<CentroidalDynamics>(pre_ptr));
  const int N = 100;
  ocp::OptimalControlProblem problem(F, N, 0.015, s.scheduler.requiredCapacity());
  problem.setPrecomputation(pre_ptr);
  auto torque = std::make_shared<const StaticTorqueLimitResidual>(robot);
  auto friction = std::make_shared<const FrictionPyramidResidual>(robot, s.references());
  auto stance =
      std::make_shared<const FootRegionResidual>(robot, s.references(), RegionUse::Stance);
  auto swing = std::make_shared<const FootRegionResidual>(robot, s.references(), RegionUse::Swing);
  ocp::InequalityOptions soft;
  soft.soft = true;
  problem.addInequality("torque", torque);
  problem.addInequality("friction", friction);
  // State-only: accepted as soft rows and on the terminal node.
  problem.addInequality("stance_region", stance, ocp::Stage::All, soft);
  problem.addInequality("swing_region", swing, ocp::Stage::All, soft);
  const JointLimitBounds b = jointLimitBounds(*robot, {0.01, 0.9});
  problem.setStateBounds(b.state_lower, b.state_upper, soft);
  problem.setInputBounds(b.input_lower, b.input_upper);
  EXPECT_EQ(problem.stateBounds().size(), robot->nj());
  EXPECT_EQ(problem.inputBounds().size(), robot->nj());
  EXPECT_EQ(problem.maxInequalities(), 24 + 30 + 24 + 24);

  // Linearise every node of horizons sliding over the climb: the rows are the terms' rows,
  // the soft flags follow the state-only terms, and nothing allocates.
  auto nd = problem.createNodeData();
  const VectorXd x = nominalState(*robot), u = randomInput(*robot, rng);
  int swing_nodes = 0;
  for (double t0 = 0.0; t0 < 4.0; t0 += 0.5) {
    s.scheduler.fill(t0, N * 0.015, problem.modeSchedule());
    problem.setInitialTime(t0);
    for (int k = 0; k <= N; ++k) {
      const ocp::NodeContext ctx = problem.context(k);
      rollstep::test::AllocationGuard guard;
      problem.linearize(k, x, u, *nd);
      EXPECT_EQ(guard.count(), 0u) << "t0 " << t0 << " k " << k;
      const int rt = k < N ? torque->rows(ctx) : 0;
      const int rf = k < N ? friction->rows(ctx) : 0;
      const int rs = stance->rows(ctx), rw = swing->rows(ctx);
      ASSERT_EQ(nd->ni, rt + rf + rs + rw) << "t0 " << t0 << " k " << k;
      for (int r = 0; r < nd->ni; ++r) EXPECT_EQ(nd->soft[r], r >= rt + rf) << r;
      swing_nodes += rw > 0 ? 1 : 0;
    }
  }
  EXPECT_GT(swing_nodes, 0);
}

}  // namespace
