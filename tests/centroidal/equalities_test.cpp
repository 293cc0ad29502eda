// Equality constraints: swing forces, stance velocities (side-by-side rule, foot yaw),
// swing heights. Values, Jacobians against central differences on the manifold in every
// mode class of Tachyon 3's gaits, rows per mode, row rank in u, no allocation.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <string>
#include <vector>

#include "centroidal/fd_check.hpp"
#include "common/alloc_counter.hpp"
#include "rollstep/centroidal/contact_equalities.hpp"
#include "rollstep/centroidal/swing_height.hpp"

namespace rollstep::centroidal::test {
namespace {

constexpr double kKp = 10.0;

struct Fixture {
  explicit Fixture(const std::string& gait = "trot") : scene(makeTachyon3Scene(gait)) {}
  std::shared_ptr<const CentroidalRobot> robot = tachyon3Robot();
  std::shared_ptr<const CentroidalPrecomputation> pre =
      std::make_shared<const CentroidalPrecomputation>(robot);
  std::unique_ptr<ocp::NodeCache> cache = pre->createCache();
  Tachyon3Scene scene;
  SwingForceResidual force{robot};
  StanceVelocityResidual velocity{pre};
  StanceVelocityResidual freed{pre, StanceRows::Freed};
  SwingHeightResidual height{pre, scene.feet, kKp};
  /// The equality constraints (the freed rows are a cost, not stacked with them).
  std::vector<const ocp::Residual*> constraints() const { return {&force, &velocity, &height}; }
  std::vector<const ocp::Residual*> all() const { return {&force, &velocity, &freed, &height}; }
};

const int kTrotA = maskOf({LF, RF, MR});
const int kTrotB = maskOf({MF, LR, RR});

/// Every mode class: all stance, both trot phases, the six single swings of the static
/// walk, all swing. With the gait whose schedule contains the mode.
struct ModeCase {
  std::string gait;
  int mode;
};
std::vector<ModeCase> modeClasses() {
  std::vector<ModeCase> cases{{"trot", kAllStance}, {"trot", kTrotA}, {"trot", kTrotB}};
  for (int i = 0; i < 6; ++i) cases.push_back({"walk", kAllStance & ~(1 << i)});
  return cases;
}

TEST(Equalities, RowsPerMode) {
  Fixture s;
  auto rows = [&](const ocp::Residual& r, int mode) {
    return r.rows(makeContext(mode, 0.0, s.scene.schedule.get(), nullptr));
  };
  // All stance: LF (z, lateral), MF (z), LR (z, lateral), MR (z); RF and RR dropped.
  EXPECT_EQ(rows(s.velocity, kAllStance), 6);
  EXPECT_EQ(rows(s.force, kAllStance), 0);
  EXPECT_EQ(rows(s.height, kAllStance), 0);
  // Trot A: LF (2) keeps, RF dropped (its partner LF stands), MR (1).
  EXPECT_EQ(rows(s.velocity, kTrotA), 3);
  EXPECT_EQ(rows(s.force, kTrotA), 9);
  EXPECT_EQ(rows(s.height, kTrotA), 3);
  // Trot B: MF (1), LR (2) keeps, RR dropped.
  EXPECT_EQ(rows(s.velocity, kTrotB), 3);
  EXPECT_EQ(rows(s.force, kTrotB), 9);
  EXPECT_EQ(rows(s.height, kTrotB), 3);
  // LF and LR swing: their partners RF and RR keep their rows.
  const int right = maskOf({MF, RF, MR, RR});
  EXPECT_EQ(rows(s.velocity, right), 6);
  EXPECT_EQ(rows(s.force, right), 6);
  EXPECT_EQ(rows(s.height, right), 2);
  // All swing.
  EXPECT_EQ(rows(s.velocity, 0), 0);
  EXPECT_EQ(rows(s.force, 0), 18);
  EXPECT_EQ(rows(s.height, 0), 6);
  EXPECT_EQ(s.velocity.maxRows(), 10);
  EXPECT_EQ(s.force.maxRows(), 18);
  EXPECT_EQ(s.height.maxRows(), 6);
  EXPECT_TRUE(s.force.isLinear());
  EXPECT_FALSE(s.velocity.isLinear());
  EXPECT_FALSE(s.force.dependsOnState());
}

TEST(Equalities, TheFreedRowsAreTheStanceRowsTheRuleDrops) {
  Fixture s;
  for (const ModeCase& mc : modeClasses()) {
    const auto ctx = makeContext(mc.mode, 0.0, s.scene.schedule.get(), nullptr);
    int all = 0;  // every stance row: z, and lateral for a drive wheel
    for (int i = 0; i < s.robot->nc(); ++i) {
      if (CentroidalRobot::inStance(mc.mode, i)) all += s.robot->contact(i).drive_wheel ? 2 : 1;
    }
    EXPECT_EQ(s.velocity.rows(ctx) + s.freed.rows(ctx), all) << "mode " << mc.mode;
  }
  // All stance: RF and RR are freed (z + lateral each).
  EXPECT_EQ(s.freed.rows(makeContext(kAllStance, 0.0, s.scene.schedule.get(), nullptr)), 4);
}

TEST(Equalities, JacobiansMatchFiniteDifferencesInEveryModeClass) {
  std::mt19937 rng(21);
  for (const ModeCase& mc : modeClasses()) {
    Fixture s(mc.gait);
    const double t = s.scene.timeInMode(mc.mode);
    ASSERT_TRUE(std::isfinite(t)) << "mode " << mc.mode << " not in the " << mc.gait;
    for (int trial = 0; trial < 3; ++trial) {
      const Eigen::VectorXd x = randomState(*s.robot, rng);
      const Eigen::VectorXd u = randomInput(*s.robot, rng);
      const auto ctx = makeContext(mc.mode, t, s.scene.schedule.get(), nullptr);
      const NodeEvaluator with{s.pre.get(), s.cache.get(), ctx};
      const NodeEvaluator without{nullptr, nullptr, ctx};
      for (const ocp::Residual* r : s.all()) {
        EXPECT_TRUE(checkResidualDerivatives(*r, *s.robot->space(), with, x, u))
            << "mode " << mc.mode << " trial " << trial << " " << typeid(*r).name();
        EXPECT_TRUE(checkResidualDerivatives(*r, *s.robot->space(), without, x, u))
            << "mode " << mc.mode << " trial " << trial << " " << typeid(*r).name();
      }
    }
  }
  // All swing (a flight phase): constant schedule, heights held at the apex.
  Fixture s;
  ocp::ModeSchedule flight;
  flight.setConstant(0);
  const Eigen::VectorXd x = randomState(*s.robot, rng);
  const Eigen::VectorXd u = randomInput(*s.robot, rng);
  const NodeEvaluator ev{s.pre.get(), s.cache.get(), makeContext(0, 0.3, &flight, nullptr)};
  for (const ocp::Residual* r : s.all()) {
    EXPECT_TRUE(checkResidualDerivatives(*r, *s.robot->space(), ev, x, u));
  }
  // The terms that read the kinematics keep no cache of their own for nodes that have one.
  const auto stance = makeContext(kAllStance, 0.0, s.scene.schedule.get(), nullptr);
  EXPECT_TRUE(refusesCallsWithoutNodeCache(s.velocity, stance, x, u));
  EXPECT_TRUE(refusesCallsWithoutNodeCache(s.height, ev.ctx, x, u));
}

TEST(Equalities, StanceRowsFollowTheTerrainNormalOnASlope) {
  // One big region tilted 0.15 rad about world y (a ramp rising along +x): each stance
  // row is the foot velocity along the region's normal, n^T v, not its world z velocity.
  const double a = 0.15;
  const Eigen::Vector3d n(-std::sin(a), 0.0, std::cos(a));
  const auto terrain = std::make_shared<planning::TerrainModel>(std::vector<planning::ConvexRegion>{
      planning::ConvexRegion::fromPolygon({{-5, -5}, {5, -5}, {5, 5}, {-5, 5}}, 0.0, n)});
  Tachyon3Scene scene = makeTachyon3Scene("trot");
  const auto base = std::make_shared<planning::BaseReference>(
      *terrain, planning::BaseReferenceConfig{0.375, tachyon3NominalFeet()});
  base->reset(0.0, lie::SE3(), {0.3, 0.0, 0.1});
  const planning::FootReferencePlanner planner(
      *terrain, *base,
      planning::FootReferenceConfig{tachyon3NominalFeet(), 0.08, kTachyon3WheelRadius});
  Fixture s;
  const StanceVelocityResidual sloped(s.pre, StanceRows::Kept, StanceComponents::All,
                                      {terrain.get(), &planner});
  const StanceVelocityResidual sloped_freed(s.pre, StanceRows::Freed, StanceComponents::All,
                                            {terrain.get(), &planner});
  const StanceVelocityResidual sloped_vertical(
      s.pre, StanceRows::Kept, StanceComponents::VerticalOnly, {terrain.get(), &planner});
  std::mt19937 rng(23);
  const int trot_a = maskOf({LF, RF, MR});
  for (const int mode : {kAllStance, trot_a, maskOf({MF, LR, RR})}) {
    const double t = scene.timeInMode(mode);
    ASSERT_TRUE(std::isfinite(t)) << "mode " << mode;
    const auto ctx = makeContext(mode, t, scene.schedule.get(), nullptr);
    for (int trial = 0; trial < 3; ++trial) {
      const Eigen::VectorXd x = randomState(*s.robot, rng);
      const Eigen::VectorXd u = randomInput(*s.robot, rng);
      const NodeEvaluator with{s.pre.get(), s.cache.get(), ctx};
      const NodeEvaluator without{nullptr, nullptr, ctx};
      for (const ocp::Residual* r :
           std::vector<const ocp::Residual*>{&sloped, &sloped_freed, &sloped_vertical}) {
        EXPECT_TRUE(checkResidualDerivatives(*r, *s.robot->space(), with, x, u))
            << "mode " << mode << " trial " << trial;
        EXPECT_TRUE(checkResidualDerivatives(*r, *s.robot->space(), without, x, u))
            << "mode " << mode << " trial " << trial;
      }
    }
  }
  // Values: in trot A, LF keeps (normal, lateral), MR (normal); against the foot velocities.
  const double t = scene.timeInMode(trot_a);
  const auto ctx = makeContext(trot_a, t, scene.schedule.get(), nullptr);
  const Eigen::VectorXd x = randomState(*s.robot, rng);
  const Eigen::VectorXd u = randomInput(*s.robot, rng);
  CentroidalCache c(*s.robot);
  s.pre->compute(x, u, false, c);
  const NodeEvaluator ev{nullptr, nullptr, ctx};
  auto d = sloped.createData();
  const Eigen::VectorXd r = residualValue(sloped, ev, x, u, *d);
  ASSERT_EQ(r.size(), 3);
  const Eigen::Vector3d v_lf = c.footVelocity(LF), v_mr = c.footVelocity(MR);
  EXPECT_NEAR(r[0], n.dot(v_lf), 1e-12);
  EXPECT_NEAR(r[2], n.dot(v_mr), 1e-12);
  EXPECT_GT(std::abs(r[0] - v_lf.z()), 1e-3);  // not the world z velocity
  // Without terrain the same rows are the world z velocity.
  auto dz = s.velocity.createData();
  EXPECT_NEAR(residualValue(s.velocity, ev, x, u, *dz)[0], v_lf.z(), 1e-12);  // flat: z
  EXPECT_NE(sloped.rowName(ctx, 0).find("normal velocity"), std::string::npos);
}

TEST(Equalities, TheFiniteDifferenceCheckCatchesAWrongJacobian) {
  // A residual whose Rx is off by 1 %: the helper must reject it.
  struct Wrong final : ocp::Residual {
    explicit Wrong(const StanceVelocityResidual& inner)
        : Residual(inner.ndx(), inner.nu(), inner.maxRows()), r(inner) {}
    int rows(const ocp::NodeContext& c) const override { return r.rows(c); }
    std::unique_ptr<ocp::ResidualData> createData() const override { return r.createData(); }
    void calc(const ocp::NodeContext& c, ocp::ConstVecRef x, ocp::ConstVecRef u,
              ocp::ResidualData& d) const override {
      r.calc(c, x, u, d);
    }
    void calcDiff(const ocp::NodeContext& c, ocp::ConstVecRef x, ocp::ConstVecRef u,
                  ocp::ResidualData& d) const override {
      r.calcDiff(c, x, u, d);
      d.Rx *= 1.01;
    }
    const StanceVelocityResidual& r;
  };
  Fixture s;
  const Wrong wrong(s.velocity);
  std::mt19937 rng(22);
  const Eigen::VectorXd x = randomState(*s.robot, rng);
  const Eigen::VectorXd u = randomInput(*s.robot, rng);
  const NodeEvaluator ev{s.pre.get(), s.cache.get(),
                         makeContext(kAllStance, 0.0, s.scene.schedule.get(), nullptr)};
  EXPECT_TRUE(checkResidualDerivatives(s.velocity, *s.robot->space(), ev, x, u));
  EXPECT_FALSE(checkResidualDerivatives(wrong, *s.robot->space(), ev, x, u));
}

TEST(Equalities, ValuesMatchTheirDefinition) {
  Fixture s;
  const CentroidalRobot& r = *s.robot;
  std::mt19937 rng(23);
  for (int trial = 0; trial < 4; ++trial) {
    // Level base with a random yaw: the foot yaw is the base yaw (legs only pitch).
    Eigen::VectorXd x = randomState(r, rng, 0.0);
    const Eigen::VectorXd u = randomInput(r, rng);
    const Eigen::Quaterniond qb(x[6], x[3], x[4], x[5]);
    const double base_yaw = std::atan2(qb.toRotationMatrix()(1, 0), qb.toRotationMatrix()(0, 0));
    model::Data data(r.model());
    model::NodeQuantities nq(r.model(), r.frameIds());
    const lie::Vector6d h = x.tail<6>();
    model::computeNodeQuantitiesFromMomentum(r.model(), data, x.head(r.nq()), h, u.head(12),
                                             u.tail(18), nq);
    const Eigen::Vector3d e_lat(-std::sin(base_yaw), std::cos(base_yaw), 0.0);
    // Velocity rows in all stance: LF z, LF lat, MF z, LR z, LR lat, MR z.
    auto d = s.velocity.createData();
    auto ctx = makeContext(kAllStance, 0.0, s.scene.schedule.get(), nullptr);
    d->rows = s.velocity.rows(ctx);
    s.velocity.calc(ctx, x, u, *d);
    const auto v = nq.contactVelocities;
    Eigen::VectorXd expected(6);
    expected << v(2, LF), e_lat.dot(v.col(LF)), v(2, MF), v(2, LR), e_lat.dot(v.col(LR)), v(2, MR);
    EXPECT_TRUE(d->r.head(6).isApprox(expected, 1e-10)) << d->r.head(6).transpose();
    // Swing forces and heights in trot phase A (MF, LR, RR swing).
    const double t = s.scene.timeInMode(kTrotA);
    ctx = makeContext(kTrotA, t, s.scene.schedule.get(), nullptr);
    auto df = s.force.createData();
    df->rows = s.force.rows(ctx);
    s.force.calc(ctx, x, u, *df);
    EXPECT_EQ(
        df->r.head(9),
        (Eigen::VectorXd(9) << u.segment<3>(15), u.segment<3>(21), u.segment<3>(27)).finished());
    auto dh = s.height.createData();
    dh->rows = s.height.rows(ctx);
    s.height.calc(ctx, x, u, *dh);
    int row = 0;
    for (int foot : {MF, LR, RR}) {
      const planning::FootReference ref = s.scene.feet->query(*s.scene.schedule, foot, t);
      EXPECT_FALSE(ref.timing.stance);
      EXPECT_GT(ref.z_ref, kTachyon3WheelRadius);  // lifted
      EXPECT_NEAR(dh->r[row++],
                  v(2, foot) - ref.z_dot_ref + kKp * (nq.contactPositions(2, foot) - ref.z_ref),
                  1e-10);
    }
  }
}

// The saturated feedback: values c tanh(Kp e / c) (at most c [m/s] of extra vertical speed
// however far the foot is from its spline, Kp e for a small error), Jacobians against
// central differences.
TEST(Equalities, SaturatedSwingHeightFeedback) {
  Fixture s;
  constexpr double kMax = 0.1;
  const SwingHeightResidual sat{s.pre, s.scene.feet, kKp, kMax};
  EXPECT_DOUBLE_EQ(sat.maxCorrection(), kMax);
  EXPECT_THROW(SwingHeightResidual(s.pre, s.scene.feet, kKp, -0.1), std::invalid_argument);
  EXPECT_THROW(SwingHeightResidual(s.pre, s.scene.feet, kKp, std::nan("")), std::invalid_argument);
  std::mt19937 rng(5);
  const double t = s.scene.timeInMode(kTrotA);
  const auto ctx = makeContext(kTrotA, t, s.scene.schedule.get(), nullptr);
  for (int trial = 0; trial < 3; ++trial) {
    const Eigen::VectorXd x = randomState(*s.robot, rng);
    const Eigen::VectorXd u = randomInput(*s.robot, rng);
    const NodeEvaluator ev{s.pre.get(), s.cache.get(), ctx};
    EXPECT_TRUE(checkResidualDerivatives(sat, *s.robot->space(), ev, x, u)) << trial;
    auto plain = s.height.createData();
    auto capped = sat.createData();
    plain->rows = capped->rows = sat.rows(ctx);
    s.height.calc(ctx, x, u, *plain);
    sat.calc(ctx, x, u, *capped);
    const CentroidalRobot& r = *s.robot;
    model::Data data(r.model());
    model::NodeQuantities nq(r.model(), r.frameIds());
    const lie::Vector6d h = x.tail<6>();
    model::computeNodeQuantitiesFromMomentum(r.model(), data, x.head(r.nq()), h, u.head(12),
                                             u.tail(18), nq);
    int row = 0;
    for (int foot : {MF, LR, RR}) {
      const planning::FootReference ref = s.scene.feet->query(*s.scene.schedule, foot, t);
      const double e = nq.contactPositions(2, foot) - ref.z_ref;
      const double open = nq.contactVelocities(2, foot) - ref.z_dot_ref;
      EXPECT_NEAR(capped->r[row], open + kMax * std::tanh(kKp * e / kMax), 1e-10);
      EXPECT_LE(std::abs(capped->r[row] - open), kMax + 1e-12);
      EXPECT_NEAR(plain->r[row], open + kKp * e, 1e-10);
      ++row;
    }
  }
}

/// Ru of the stacked equalities at (x, u) in `mode`.
Eigen::MatrixXd stackedRu(const Fixture& s, int mode, double t, const Eigen::VectorXd& x,
                          const Eigen::VectorXd& u) {
  const auto ctx = makeContext(mode, t, s.scene.schedule.get(), nullptr);
  int rows = 0;
  for (const ocp::Residual* r : s.constraints()) rows += r->rows(ctx);
  Eigen::MatrixXd Ru(rows, s.robot->nu());
  int at = 0;
  for (const ocp::Residual* r : s.constraints()) {
    auto d = r->createData();
    d->rows = r->rows(ctx);
    r->calc(ctx, x, u, *d);
    r->calcDiff(ctx, x, u, *d);
    Ru.middleRows(at, d->rows) = d->Ru.topRows(d->rows);
    at += d->rows;
  }
  return Ru;
}

TEST(Equalities, FullRowRankInUAtTheNominalPosture) {
  for (const ModeCase& mc : modeClasses()) {
    Fixture s(mc.gait);
    const double t = s.scene.timeInMode(mc.mode);
    const Eigen::VectorXd x = nominalState(*s.robot);
    Eigen::VectorXd u = Eigen::VectorXd::Zero(s.robot->nu());
    const int n = planning::contactCount(mc.mode);
    for (int i = 0; i < 6; ++i) {
      if (CentroidalRobot::inStance(mc.mode, i)) u[12 + 3 * i + 2] = s.robot->mass() * 9.81 / n;
    }
    const Eigen::MatrixXd Ru = stackedRu(s, mc.mode, t, x, u);
    EXPECT_EQ(numericalRank(Ru, 1e-8), Ru.rows()) << "mode " << mc.mode << "\n" << Ru;
    // Also at random states.
    std::mt19937 rng(24);
    const Eigen::VectorXd xr = randomState(*s.robot, rng, 0.2);
    const Eigen::MatrixXd Rr = stackedRu(s, mc.mode, t, xr, randomInput(*s.robot, rng));
    EXPECT_EQ(numericalRank(Rr, 1e-8), Rr.rows()) << "random state, mode " << mc.mode;
  }
}

TEST(Equalities, WithoutTheSideBySideRuleTheStanceRowsAreDependent) {
  // The paper's reason for the rule: with every stance row of both side pairs, the
  // velocity rows lose rank in v_J (the pitch motion is constrained twice).
  const auto model = tachyon3Model();
  auto robot = std::make_shared<const CentroidalRobot>(
      model,
      std::vector<ContactDescription>{{"LF_wheel", true},
                                      {"MF_wheel", false},
                                      {"RF_wheel", true},
                                      {"LR_wheel", true},
                                      {"MR_wheel", false},
                                      {"RR_wheel", true}},
      std::vector<std::array<int, 2>>{}, kTachyon3WheelRadius);
  auto pre = std::make_shared<const CentroidalPrecomputation>(robot);
  const StanceVelocityResidual all_rows(pre);
  const Eigen::VectorXd x = nominalState(*robot);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(robot->nu());
  const auto ctx = makeContext(kAllStance, 0.0, nullptr, nullptr);
  auto d = all_rows.createData();
  d->rows = all_rows.rows(ctx);
  ASSERT_EQ(d->rows, 10);
  all_rows.calc(ctx, x, u, *d);
  all_rows.calcDiff(ctx, x, u, *d);
  const Eigen::MatrixXd Ru = d->Ru.topRows(10);
  const int rank = numericalRank(Ru, 1e-8);
  EXPECT_LT(rank, 10);
  // With the rule (the Tachyon 3 robot of the other tests), all 6 rows are independent.
  Fixture s;
  const Eigen::MatrixXd Rs = stackedRu(s, kAllStance, 0.0, x, u);
  EXPECT_EQ(numericalRank(Rs, 1e-8), 6);
  std::cout << "all-stance velocity rows in v_J: rank " << rank << " of 10 without the rule\n";
}

TEST(Equalities, AllocationFree) {
  Fixture s;
  std::mt19937 rng(25);
  const Eigen::VectorXd x = randomState(*s.robot, rng);
  const Eigen::VectorXd u = randomInput(*s.robot, rng);
  const std::vector<const ocp::Residual*> terms = s.all();
  std::vector<std::unique_ptr<ocp::ResidualData>> data;
  for (const ocp::Residual* r : terms) data.push_back(r->createData());
  for (int mode : {kAllStance, kTrotA, kTrotB}) {
    const double t = s.scene.timeInMode(mode);
    for (ocp::NodeCache* cache : {s.cache.get(), static_cast<ocp::NodeCache*>(nullptr)}) {
      const auto ctx = makeContext(mode, t, s.scene.schedule.get(), cache);
      rollstep::test::AllocationGuard guard;
      if (cache != nullptr) s.pre->compute(ctx, x, u, true, *cache);
      for (std::size_t k = 0; k < data.size(); ++k) {
        data[k]->rows = terms[k]->rows(ctx);
        terms[k]->calc(ctx, x, u, *data[k]);
        terms[k]->calcDiff(ctx, x, u, *data[k]);
      }
      EXPECT_EQ(guard.count(), 0u) << "mode " << mode;
    }
  }
}

TEST(Equalities, CalcDiffIntoWritesTheRowsOfCalcDiffAndNothingElse) {
  for (const ModeCase& c : modeClasses()) {
    Fixture s(c.gait);
    std::mt19937 rng(31);
    const Eigen::VectorXd x = randomState(*s.robot, rng);
    const Eigen::VectorXd u = randomInput(*s.robot, rng);
    const auto ctx =
        makeContext(c.mode, s.scene.timeInMode(c.mode), s.scene.schedule.get(), s.cache.get());
    s.pre->compute(ctx, x, u, true, *s.cache);
    const std::vector<const ocp::Residual*> terms = s.all();
    for (std::size_t k = 0; k < terms.size(); ++k) {
      expectCalcDiffIntoMatchesCalcDiff(
          *terms[k], ctx, x, u, "term " + std::to_string(k) + " mode " + std::to_string(c.mode));
    }
  }
}

TEST(Equalities, RejectsBadArguments) {
  Fixture s;
  EXPECT_THROW(SwingForceResidual(nullptr), std::invalid_argument);
  EXPECT_THROW(StanceVelocityResidual(nullptr), std::invalid_argument);
  EXPECT_THROW(SwingHeightResidual(s.pre, nullptr, 1.0), std::invalid_argument);
  EXPECT_THROW(SwingHeightResidual(s.pre, s.scene.feet, -1.0), std::invalid_argument);
  EXPECT_THROW(SwingHeightResidual(s.pre, s.scene.feet, std::nan("")), std::invalid_argument);
  std::mt19937 rng(26);
  const Eigen::VectorXd x = randomState(*s.robot, rng);
  const Eigen::VectorXd u = randomInput(*s.robot, rng);
  auto d = s.height.createData();
  EXPECT_THROW(s.height.calc(makeContext(kTrotA, 0.0, nullptr, nullptr), x, u, *d),
               std::invalid_argument);
}

}  // namespace
}  // namespace rollstep::centroidal::test
