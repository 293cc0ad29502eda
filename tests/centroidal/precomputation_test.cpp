// CentroidalRobot validation and the CentroidalPrecomputation totals (base twist, contact
// velocities through v_b, positions, yaw) against central differences on the manifold.
#include <gtest/gtest.h>

#include "centroidal/fd_check.hpp"
#include "common/alloc_counter.hpp"

namespace rollstep::centroidal::test {
namespace {

std::vector<ContactDescription> tachyonContacts() {
  return {{"LF_wheel", true}, {"MF_wheel", false}, {"RF_wheel", true},
          {"LR_wheel", true}, {"MR_wheel", false}, {"RR_wheel", true}};
}

TEST(CentroidalRobot, Tachyon3Dimensions) {
  const auto robot = tachyon3Robot();
  EXPECT_EQ(robot->nc(), 6);
  EXPECT_EQ(robot->nj(), 12);
  EXPECT_EQ(robot->nx(), 25);
  EXPECT_EQ(robot->ndx(), 24);
  EXPECT_EQ(robot->nu(), 30);
  EXPECT_EQ(robot->space()->nx(), 25);
  EXPECT_EQ(robot->space()->ndx(), 24);
  EXPECT_EQ(robot->partnerOf(LF), RF);
  EXPECT_EQ(robot->partnerOf(RR), LR);
  EXPECT_EQ(robot->partnerOf(MF), -1);
  EXPECT_NEAR(robot->mass(), 60.4, 0.5);
  EXPECT_EQ(robot->supportColumns(LF).size(), 8u);
  EXPECT_EQ(robot->inputForceIndex(2), 18);
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(robot->contact(i).drive_wheel, i != MF && i != MR) << i;
    EXPECT_EQ(robot->contact(i).frame, tachyonContacts()[static_cast<size_t>(i)].frame);
  }
}

TEST(CentroidalRobot, SideBySideRule) {
  const auto robot = tachyon3Robot();
  // Both of a pair in stance: only the first keeps its velocity constraints.
  EXPECT_TRUE(robot->keepsVelocityConstraints(kAllStance, LF));
  EXPECT_FALSE(robot->keepsVelocityConstraints(kAllStance, RF));
  EXPECT_TRUE(robot->keepsVelocityConstraints(kAllStance, LR));
  EXPECT_FALSE(robot->keepsVelocityConstraints(kAllStance, RR));
  EXPECT_TRUE(robot->keepsVelocityConstraints(kAllStance, MF));
  // Only the second in stance: it keeps them.
  EXPECT_TRUE(robot->keepsVelocityConstraints(maskOf({RF, MF, RR}), RF));
  EXPECT_TRUE(robot->keepsVelocityConstraints(maskOf({RF, MF, RR}), RR));
  EXPECT_FALSE(robot->keepsVelocityConstraints(maskOf({RF}), LF));  // swing
}

TEST(CentroidalRobot, RejectsBadDescriptions) {
  const auto model = tachyon3Model();
  const std::vector<std::array<int, 2>> pairs{{0, 2}, {3, 5}};
  auto expectThrowNaming = [](auto&& make, const std::string& needle) {
    try {
      make();
      ADD_FAILURE() << "no exception, expected one naming '" << needle << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  auto contacts = tachyonContacts();
  contacts[4].frame = "XX_wheel";
  expectThrowNaming([&] { CentroidalRobot(model, contacts, pairs, 0.075); }, "XX_wheel");
  contacts = tachyonContacts();
  contacts[4].frame = "LF_wheel";
  expectThrowNaming([&] { CentroidalRobot(model, contacts, pairs, 0.075); }, "repeated");
  expectThrowNaming([&] { CentroidalRobot(model, tachyonContacts(), {{0, 6}}, 0.075); }, "6");
  expectThrowNaming([&] { CentroidalRobot(model, tachyonContacts(), {{1, 1}}, 0.075); }, "itself");
  expectThrowNaming(
      [&] {
        CentroidalRobot(model, tachyonContacts(), {{0, 1}, {1, 2}}, 0.075);
      },
      "another pair");
  expectThrowNaming([&] { CentroidalRobot(model, tachyonContacts(), pairs, -0.1); }, "-0.1");
  expectThrowNaming([&] { CentroidalRobot(model, {}, pairs, 0.0); }, "0 contacts");
  std::vector<ContactDescription> many(17, ContactDescription{"LF_wheel", false});
  expectThrowNaming([&] { CentroidalRobot(model, many, {}, 0.0); }, "17 contacts");
  auto fixed = std::make_shared<const model::Model>(model::buildModelFromUrdfFile(
      std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/tachyon3.urdf", model::RootJoint::Fixed));
  expectThrowNaming([&] { CentroidalRobot(fixed, tachyonContacts(), pairs, 0.0); }, "free-flyer");
  expectThrowNaming([&] { CentroidalRobot(nullptr, tachyonContacts(), pairs, 0.0); }, "null");
}

// Values of the cache stacked into one vector: [vb, foot velocities, positions, yaws].
Eigen::VectorXd cacheValues(const CentroidalCache& c) {
  const int nc = static_cast<int>(c.footYaw.size());
  Eigen::VectorXd out(6 + 7 * nc);
  out.head<6>() = c.vb;
  for (int i = 0; i < nc; ++i) {
    out.segment<3>(6 + 3 * i) = c.footVelocity(i);
    out.segment<3>(6 + 3 * nc + 3 * i) = c.footPosition(i);
  }
  out.tail(nc) = c.footYaw;
  return out;
}

TEST(CentroidalPrecomputation, TotalDerivativesMatchFiniteDifferences) {
  const auto robot = tachyon3Robot();
  const CentroidalPrecomputation pre(robot);
  auto base = pre.createCache();
  auto& cache = static_cast<CentroidalCache&>(*base);
  CentroidalCache scratch(*robot);
  const auto& space = *robot->space();
  const int nc = robot->nc(), ndx = robot->ndx(), nu = robot->nu();
  std::mt19937 rng(7);
  const double eps = 1e-6;
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::VectorXd x = randomState(*robot, rng);
    const Eigen::VectorXd u = randomInput(*robot, rng);
    pre.compute(makeContext(kAllStance, 0.0, nullptr, nullptr), x, u, true, cache);
    ASSERT_TRUE(cache.has_derivatives);
    Eigen::MatrixXd analytic_x(6 + 7 * nc, ndx), analytic_u(6 + 7 * nc, nu);
    analytic_x << cache.dvb_dx, cache.footVelocity_dx, cache.footPosition_dx, cache.footYaw_dx;
    analytic_u << cache.dvb_du, cache.footVelocity_du, Eigen::MatrixXd::Zero(4 * nc, nu);
    Eigen::MatrixXd nx(6 + 7 * nc, ndx), nuu(6 + 7 * nc, nu);
    for (int i = 0; i < ndx; ++i) {
      pre.compute(perturbState(space, x, i, eps), u, false, scratch);
      const Eigen::VectorXd vp = cacheValues(scratch);
      pre.compute(perturbState(space, x, i, -eps), u, false, scratch);
      nx.col(i) = (vp - cacheValues(scratch)) / (2 * eps);
    }
    for (int i = 0; i < nu; ++i) {
      Eigen::VectorXd up = u, um = u;
      up[i] += eps;
      um[i] -= eps;
      pre.compute(x, up, false, scratch);
      const Eigen::VectorXd vp = cacheValues(scratch);
      pre.compute(x, um, false, scratch);
      nuu.col(i) = (vp - cacheValues(scratch)) / (2 * eps);
    }
    const FdTolerance tol{eps, 1e-5, 1e-6};
    EXPECT_TRUE(matricesClose(analytic_x, nx, tol, "d cache / dx")) << "trial " << trial;
    EXPECT_TRUE(matricesClose(analytic_u, nuu, tol, "d cache / du")) << "trial " << trial;
    EXPECT_FALSE(scratch.has_derivatives);
  }
}

TEST(CentroidalPrecomputation, ViewsAndAllocationFree) {
  const auto robot = tachyon3Robot();
  const CentroidalPrecomputation pre(robot);
  auto cache = pre.createCache();
  std::mt19937 rng(3);
  const Eigen::VectorXd x = randomState(*robot, rng);
  const Eigen::VectorXd u = randomInput(*robot, rng);
  const auto ctx = makeContext(kAllStance, 0.0, nullptr, cache.get());
  {
    rollstep::test::AllocationGuard guard;
    pre.compute(ctx, x, u, true, *cache);
    pre.compute(ctx, x, u, false, *cache);
    EXPECT_EQ(guard.count(), 0u);
  }
  const auto& c = static_cast<const CentroidalCache&>(*cache);
  EXPECT_EQ(c.q(), x.head(19));
  EXPECT_EQ(c.h(), x.tail<6>());
  EXPECT_EQ(c.vJ(), u.head(12));
  EXPECT_EQ(c.force(5), u.tail<3>());
  EXPECT_EQ(c.forces(), u.tail(18));
  // The momentum recomputed from v = (v_b, v_J) is the state's.
  EXPECT_TRUE(c.nq.h.isApprox(x.tail<6>(), 1e-9));
}

}  // namespace
}  // namespace rollstep::centroidal::test
