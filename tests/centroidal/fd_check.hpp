#pragma once
// Test helpers of the centroidal layer: the Tachyon 3 robot, random states and inputs,
// node contexts, and central finite-difference checks ON THE MANIFOLD (x perturbed by
// space.integrate(x, eps e_i)) of residuals, continuous and discrete dynamics and costs.
// The node cache is recomputed by the precomputation at every perturbed point, so terms
// that read ctx.cache are checked through it.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>

#include "rollstep/centroidal/precomputation.hpp"
#include "rollstep/centroidal/robot.hpp"
#include "rollstep/model/model.hpp"
#include "rollstep/ocp/cost.hpp"
#include "rollstep/ocp/dynamics.hpp"
#include "rollstep/ocp/mode_schedule.hpp"
#include "rollstep/ocp/residual.hpp"
#include "rollstep/planning/base_reference.hpp"
#include "rollstep/planning/contact_schedule.hpp"
#include "rollstep/planning/foot_reference.hpp"
#include "rollstep/planning/gait.hpp"
#include "rollstep/planning/terrain.hpp"

// GCC 12 at -O2 reports false "potential null pointer dereference" on element writes into
// freshly sized Eigen dynamic vectors in these helpers (as in tests/solver/ipopt_reference.cpp).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wnull-dereference"
#endif

namespace rollstep::centroidal::test {

// ---- Tachyon 3 -------------------------------------------------------------------------

/// Contact order LF MF RF LR MR RR (mode bits 0..5).
enum Tachyon3Foot { LF = 0, MF = 1, RF = 2, LR = 3, MR = 4, RR = 5 };
inline constexpr double kTachyon3WheelRadius = 0.075;
inline constexpr int kAllStance = 63;

inline int maskOf(std::initializer_list<int> stance) {
  int m = 0;
  for (int i : stance) m |= 1 << i;
  return m;
}

inline std::shared_ptr<const model::Model> tachyon3Model() {
  static const auto model = std::make_shared<const model::Model>(
      model::buildModelFromUrdfFile(std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/tachyon3.urdf"));
  return model;
}

/// Contacts at the wheel centres (LF_wheel ...), drive wheels LF RF LR RR, side pairs
/// {LF, RF} and {LR, RR}, contact offset = wheel radius.
inline std::shared_ptr<const CentroidalRobot> tachyon3Robot() {
  std::vector<ContactDescription> contacts{{"LF_wheel", true},  {"MF_wheel", false},
                                           {"RF_wheel", true},  {"LR_wheel", true},
                                           {"MR_wheel", false}, {"RR_wheel", true}};
  return std::make_shared<const CentroidalRobot>(
      tachyon3Model(), contacts, std::vector<std::array<int, 2>>{{LF, RF}, {LR, RR}},
      kTachyon3WheelRadius);
}

/// Nominal posture (hips 0, knees 0.05 m), base at `height`, zero momentum.
inline Eigen::VectorXd nominalState(const CentroidalRobot& robot, double height = 0.375) {
  Eigen::VectorXd x = Eigen::VectorXd::Zero(robot.nx());
  x[2] = height;
  x[6] = 1.0;  // quaternion w
  const model::Model& m = robot.model();
  for (int j = 0; j < robot.nj(); ++j) {
    const std::string& name = m.jointNames[static_cast<size_t>(j)];
    if (name.find("knee") != std::string::npos) x[7 + j] = 0.05;
  }
  return x;
}

/// Random state: base position ~ N(0, 1) (z around 0.4), yaw uniform, roll and pitch
/// within +-max_tilt, joints uniform inside their limits (5% margin), momentum ~ N(0, s).
inline Eigen::VectorXd randomState(const CentroidalRobot& robot, std::mt19937& rng,
                                   double max_tilt = 0.5, double momentum_scale = 5.0) {
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  Eigen::VectorXd x(robot.nx());
  x.head<3>() = Eigen::Vector3d(n(rng), n(rng), 0.4 + 0.1 * n(rng));
  const Eigen::Quaterniond qr = Eigen::AngleAxisd(M_PI * uni(rng), Eigen::Vector3d::UnitZ()) *
                                Eigen::AngleAxisd(max_tilt * uni(rng), Eigen::Vector3d::UnitY()) *
                                Eigen::AngleAxisd(max_tilt * uni(rng), Eigen::Vector3d::UnitX());
  x.segment<4>(3) = qr.normalized().coeffs();
  const model::Model& m = robot.model();
  for (int j = 0; j < robot.nj(); ++j) {
    const double lo = m.lowerPositionLimit[j], hi = m.upperPositionLimit[j];
    const double mid = 0.5 * (lo + hi), half = 0.45 * (hi - lo);
    x[7 + j] = mid + half * uni(rng);
  }
  for (int k = 0; k < 6; ++k) x[robot.stateMomentumIndex() + k] = momentum_scale * n(rng);
  return x;
}

/// Random input: v_J ~ N(0, 0.5), forces ~ weight / nc + N(0, 30) in z, N(0, 30) in x, y.
/// Residual::calcDiffInto writes exactly the rows calcDiff writes (bit for bit), into
/// blocks of larger matrices pre-filled with NaN (as the problem's stacked rows hold
/// other nodes' values), touching no entry outside them and leaving none of them unset.
inline void expectCalcDiffIntoMatchesCalcDiff(const ocp::Residual& r, const ocp::NodeContext& ctx,
                                              const Eigen::VectorXd& x, const Eigen::VectorXd& u,
                                              const std::string& what) {
  const auto a = r.createData(), b = r.createData();
  const int rows = r.rows(ctx);
  a->rows = b->rows = rows;
  r.calc(ctx, x, u, *a);
  r.calcDiff(ctx, x, u, *a);
  r.calc(ctx, x, u, *b);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Eigen::MatrixXd X = Eigen::MatrixXd::Constant(rows + 5, r.ndx() + 2, nan);
  Eigen::MatrixXd U = Eigen::MatrixXd::Constant(rows + 4, r.nu(), nan);
  r.calcDiffInto(ctx, x, u, *b, X.block(3, 1, rows, r.ndx()), U.middleRows(2, rows));
  EXPECT_TRUE(X.block(3, 1, rows, r.ndx()) == a->Rx.topRows(rows)) << what;
  EXPECT_TRUE(U.middleRows(2, rows) == a->Ru.topRows(rows)) << what;
  EXPECT_EQ(X.array().isNaN().count(), X.size() - rows * r.ndx()) << what;
  EXPECT_EQ(U.array().isNaN().count(), U.size() - rows * r.nu()) << what;
}

inline Eigen::VectorXd randomInput(const CentroidalRobot& robot, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::VectorXd u(robot.nu());
  for (int j = 0; j < robot.nj(); ++j) u[j] = 0.5 * n(rng);
  const double fz = robot.mass() * 9.81 / robot.nc();
  for (int i = 0; i < robot.nc(); ++i) {
    u.segment<3>(robot.inputForceIndex(i)) =
        Eigen::Vector3d(30.0 * n(rng), 30.0 * n(rng), fz + 30.0 * n(rng));
  }
  return u;
}

/// A running node context in `mode` at `time` (dt 0.015), reading `schedule` and `cache`.
inline ocp::NodeContext makeContext(int mode, double time, const ocp::ModeSchedule* schedule,
                                    ocp::NodeCache* cache, double dt = 0.015) {
  ocp::NodeContext ctx;
  ctx.node = 0;
  ctx.terminal = false;
  ctx.time = time;
  ctx.dt = dt;
  ctx.mode = mode;
  ctx.schedule = schedule;
  ctx.cache = cache;
  return ctx;
}

/// Body-frame (x, y) of the Tachyon 3 wheels (robot/tachyon3.md), contact order.
inline std::vector<Eigen::Vector2d> tachyon3NominalFeet() {
  return {{0.33, 0.22}, {0.33, 0.0}, {0.33, -0.22}, {-0.33, 0.22}, {-0.33, 0.0}, {-0.33, -0.22}};
}

/// Planning objects of a test scene: flat ground (optionally with a block), a base
/// reference moving at `speed`, the foot reference planner (foot point = wheel centre) and
/// a gait scheduler writing `schedule`. Owned through shared_ptr so that the pointers the
/// planners keep stay valid; build with makeTachyon3Scene().
struct Tachyon3Scene {
  std::shared_ptr<planning::TerrainModel> terrain;
  std::shared_ptr<planning::BaseReference> base;
  std::shared_ptr<const planning::FootReferencePlanner> feet;
  std::shared_ptr<planning::GaitScheduler> scheduler;
  std::shared_ptr<ocp::ModeSchedule> schedule;

  /// A time in [t0, t0 + span) whose mode is `mode` (the middle of its first phase), NaN
  /// if none.
  double timeInMode(int mode, double t0 = 0.0, double span = 3.0) const {
    const double step = 1e-3;
    for (double t = t0; t < t0 + span; t += step) {
      if (schedule->modeAt(t) != mode) continue;
      double end = t;
      while (end + step < t0 + span && schedule->modeAt(end + step) == mode) end += step;
      return 0.5 * (t + end);
    }
    return std::nan("");
  }
};

/// Gaits: "trot" (the paper's: [LF RF MR] / [MF LR RR], period 0.8 s, duty 0.6),
/// "walk" (static walk LF MF RF LR MR RR, period 3 s, duty 5/6), "stand".
inline Tachyon3Scene makeTachyon3Scene(const std::string& gait, double speed = 0.3,
                                       double block_height = 0.0) {
  Tachyon3Scene s;
  std::vector<planning::TerrainBox> blocks;
  if (block_height > 0.0) blocks.push_back({1.0, 2.2, -1.5, 1.5, block_height});
  s.terrain = std::make_shared<planning::TerrainModel>(
      planning::terrainFromBoxes({-5.0, 10.0, -1.5, 1.5, 0.0}, 0.0, blocks));
  s.base = std::make_shared<planning::BaseReference>(
      *s.terrain, planning::BaseReferenceConfig{0.375, tachyon3NominalFeet()});
  s.base->reset(0.0, lie::SE3(), {speed, 0.0, 0.1});
  s.feet = std::make_shared<const planning::FootReferencePlanner>(
      *s.terrain, *s.base,
      planning::FootReferenceConfig{tachyon3NominalFeet(), 0.08, kTachyon3WheelRadius});
  planning::Gait g = planning::Gait::standing(6);
  if (gait == "trot") {
    g = planning::Gait::trot(6, 0.8, 0.6, maskOf({LF, RF, MR}), maskOf({MF, LR, RR}));
  } else if (gait == "walk") {
    g = planning::Gait::staticWalk(6, 3.0, 5.0 / 6.0, {LF, MF, RF, LR, MR, RR});
  }
  s.scheduler = std::make_shared<planning::GaitScheduler>(g, 1.5);
  s.schedule = std::make_shared<ocp::ModeSchedule>(s.scheduler->requiredCapacity());
  s.scheduler->fill(0.0, 1.5, *s.schedule);
  return s;
}

// ---- Finite differences ---------------------------------------------------------------

struct FdTolerance {
  double eps = 1e-6;   ///< perturbation
  double rtol = 1e-5;  ///< relative to max(|analytic|, |numeric|)
  double atol = 1e-6;  ///< absolute
};

/// Compares two matrices entry by entry: |a - b| <= atol + rtol * max(|a|, |b|).
inline ::testing::AssertionResult matricesClose(const Eigen::MatrixXd& analytic,
                                                const Eigen::MatrixXd& numeric,
                                                const FdTolerance& tol, const std::string& what) {
  if (analytic.rows() != numeric.rows() || analytic.cols() != numeric.cols()) {
    return ::testing::AssertionFailure()
           << what << ": size " << analytic.rows() << "x" << analytic.cols() << " vs "
           << numeric.rows() << "x" << numeric.cols();
  }
  for (int i = 0; i < analytic.rows(); ++i) {
    for (int j = 0; j < analytic.cols(); ++j) {
      const double a = analytic(i, j), b = numeric(i, j);
      const double bound = tol.atol + tol.rtol * std::max(std::abs(a), std::abs(b));
      if (!(std::abs(a - b) <= bound)) {
        return ::testing::AssertionFailure()
               << what << "(" << i << ", " << j << "): analytic " << a << " vs finite "
               << "difference " << b << " (difference " << a - b << ", bound " << bound << ")";
      }
    }
  }
  return ::testing::AssertionSuccess();
}

/// Evaluation hook: recomputes the cache (if any) at (x, u) and returns the context to use.
struct NodeEvaluator {
  const ocp::NodePrecomputation* pre = nullptr;  ///< may be null (terms then use no cache)
  ocp::NodeCache* cache = nullptr;
  ocp::NodeContext ctx;

  bool hasCache() const { return pre != nullptr && cache != nullptr; }
  ocp::NodeContext at(ocp::ConstVecRef x, ocp::ConstVecRef u, bool derivatives) const {
    ocp::NodeContext c = ctx;
    c.cache = (pre != nullptr) ? cache : nullptr;
    if (hasCache()) pre->compute(c, x, u, derivatives, *cache);
    return c;
  }
};

/// The workspace a term gets where it is evaluated with ev: createDataWithNodeCache() when
/// every call carries a node cache (as in OptimalControlProblem::createNodeData with a
/// precomputation), createData() otherwise.
template <class Term>
auto workspaceFor(const Term& term, const NodeEvaluator& ev) {
  return ev.hasCache() ? term.createDataWithNodeCache() : term.createData();
}

/// A term that keeps a cache of its own for calls without a node cache leaves it out of
/// its createDataWithNodeCache() workspace: such a workspace refuses a call without one.
inline ::testing::AssertionResult refusesCallsWithoutNodeCache(const ocp::Residual& res,
                                                               ocp::NodeContext ctx,
                                                               const Eigen::VectorXd& x,
                                                               const Eigen::VectorXd& u) {
  ctx.cache = nullptr;
  auto d = res.createDataWithNodeCache();
  d->rows = res.rows(ctx);
  try {
    res.calc(ctx, x, u, *d);
  } catch (const std::logic_error&) {
    return ::testing::AssertionSuccess();
  }
  return ::testing::AssertionFailure() << "calc without a node cache did not throw";
}

/// Perturbs x along tangent direction i by `step`.
inline Eigen::VectorXd perturbState(const ocp::StateSpace& space, const Eigen::VectorXd& x, int i,
                                    double step) {
  Eigen::VectorXd dx = Eigen::VectorXd::Zero(space.ndx());
  dx[i] = step;
  Eigen::VectorXd out(space.nx());
  space.integrate(x, dx, out);
  return out;
}

/// Residual value at (x, u) (cache recomputed there), rows from `rows`.
inline Eigen::VectorXd residualValue(const ocp::Residual& res, const NodeEvaluator& ev,
                                     const Eigen::VectorXd& x, const Eigen::VectorXd& u,
                                     ocp::ResidualData& d) {
  const ocp::NodeContext c = ev.at(x, u, false);
  d.rows = res.rows(c);
  res.calc(c, x, u, d);
  return d.r.head(d.rows);
}

/// Checks res.calcDiff (Rx, Ru) against central differences on the manifold at (x, u).
/// Also checks that rows(ctx) fits in maxRows and that Ru == 0 when !dependsOnInput().
inline ::testing::AssertionResult checkResidualDerivatives(
    const ocp::Residual& res, const ocp::StateSpace& space, const NodeEvaluator& ev,
    const Eigen::VectorXd& x, const Eigen::VectorXd& u, const FdTolerance& tol = {}) {
  auto d = workspaceFor(res, ev);
  const ocp::NodeContext c = ev.at(x, u, true);
  const int rows = res.rows(c);
  if (rows < 0 || rows > res.maxRows()) {
    return ::testing::AssertionFailure()
           << "rows " << rows << " outside [0, " << res.maxRows() << "]";
  }
  d->rows = rows;
  res.calc(c, x, u, *d);
  res.calcDiff(c, x, u, *d);
  const Eigen::MatrixXd Rx = d->Rx.topRows(rows);
  const Eigen::MatrixXd Ru = d->Ru.topRows(rows);
  const Eigen::VectorXd r0 = d->r.head(rows);
  if (ev.hasCache()) {
    // Alone (no node cache, the term's own): the same rows, bit for bit.
    auto a = res.createData();
    ocp::NodeContext alone = c;
    alone.cache = nullptr;
    a->rows = rows;
    res.calc(alone, x, u, *a);
    res.calcDiff(alone, x, u, *a);
    if (a->r.head(rows) != r0 || a->Rx.topRows(rows) != Rx || a->Ru.topRows(rows) != Ru) {
      return ::testing::AssertionFailure() << "alone and with the node cache differ";
    }
  }

  auto dn = workspaceFor(res, ev);
  Eigen::MatrixXd Nx(rows, space.ndx()), Nu(rows, u.size());
  for (int i = 0; i < space.ndx(); ++i) {
    const Eigen::VectorXd rp = residualValue(res, ev, perturbState(space, x, i, tol.eps), u, *dn);
    const Eigen::VectorXd rm = residualValue(res, ev, perturbState(space, x, i, -tol.eps), u, *dn);
    Nx.col(i) = (rp - rm) / (2.0 * tol.eps);
  }
  for (int i = 0; i < u.size(); ++i) {
    Eigen::VectorXd up = u, um = u;
    up[i] += tol.eps;
    um[i] -= tol.eps;
    Nu.col(i) =
        (residualValue(res, ev, x, up, *dn) - residualValue(res, ev, x, um, *dn)) / (2.0 * tol.eps);
  }
  // Leave the cache consistent with (x, u) for the caller.
  ev.at(x, u, true);
  const Eigen::VectorXd r1 = residualValue(res, ev, x, u, *dn);
  if (!(r1 - r0).isZero(0.0)) {
    return ::testing::AssertionFailure() << "calc is not repeatable";
  }
  auto rx = matricesClose(Rx, Nx, tol, "Rx");
  if (!rx) return rx;
  if (!res.dependsOnInput() && !Ru.isZero(0.0)) {
    return ::testing::AssertionFailure() << "dependsOnInput() is false but Ru != 0";
  }
  if (!res.dependsOnState() && !Rx.isZero(0.0)) {
    return ::testing::AssertionFailure() << "dependsOnState() is false but Rx != 0";
  }
  return matricesClose(Ru, Nu, tol, "Ru");
}

/// Checks ContinuousDynamics::calcDiff (fx, fu) against central differences.
inline ::testing::AssertionResult checkContinuousDynamicsDerivatives(
    const ocp::ContinuousDynamics& f, const NodeEvaluator& ev, const Eigen::VectorXd& x,
    const Eigen::VectorXd& u, const FdTolerance& tol = {}) {
  const ocp::StateSpace& space = f.space();
  const int ndx = space.ndx(), nu = f.nu();
  auto d = workspaceFor(f, ev);
  Eigen::VectorXd xdot(ndx);
  Eigen::MatrixXd fx(ndx, ndx), fu(ndx, nu);
  ocp::NodeContext c = ev.at(x, u, true);
  f.calc(c, x, u, *d, xdot);
  f.calcDiff(c, x, u, *d, fx, fu);
  if (ev.hasCache()) {
    // Alone (no node cache, the term's own): the same values, bit for bit.
    auto a = f.createData();
    ocp::NodeContext alone = c;
    alone.cache = nullptr;
    Eigen::VectorXd xdot_a(ndx);
    Eigen::MatrixXd fx_a(ndx, ndx), fu_a(ndx, nu);
    f.calc(alone, x, u, *a, xdot_a);
    f.calcDiff(alone, x, u, *a, fx_a, fu_a);
    if (xdot_a != xdot || fx_a != fx || fu_a != fu) {
      return ::testing::AssertionFailure() << "alone and with the node cache differ";
    }
  }
  auto value = [&](const Eigen::VectorXd& xx, const Eigen::VectorXd& uu) {
    Eigen::VectorXd out(ndx);
    const ocp::NodeContext cc = ev.at(xx, uu, false);
    f.calc(cc, xx, uu, *d, out);
    return out;
  };
  Eigen::MatrixXd Nx(ndx, ndx), Nu(ndx, nu);
  for (int i = 0; i < ndx; ++i) {
    Nx.col(i) = (value(perturbState(space, x, i, tol.eps), u) -
                 value(perturbState(space, x, i, -tol.eps), u)) /
                (2.0 * tol.eps);
  }
  for (int i = 0; i < nu; ++i) {
    Eigen::VectorXd up = u, um = u;
    up[i] += tol.eps;
    um[i] -= tol.eps;
    Nu.col(i) = (value(x, up) - value(x, um)) / (2.0 * tol.eps);
  }
  ev.at(x, u, true);
  auto rx = matricesClose(fx, Nx, tol, "fx");
  if (!rx) return rx;
  return matricesClose(fu, Nu, tol, "fu");
}

/// Checks discrete Dynamics::calcDiff: F(x (+) dx, u + du) ~= F(x, u) (+) (Fx dx + Fu du),
/// the columns found as (F(x, u) (-) F(x (+) eps e_i)) - (... - eps e_i), over 2 eps.
inline ::testing::AssertionResult checkDynamicsDerivatives(const ocp::Dynamics& F,
                                                           const NodeEvaluator& ev,
                                                           const Eigen::VectorXd& x,
                                                           const Eigen::VectorXd& u,
                                                           const FdTolerance& tol = {}) {
  const ocp::StateSpace& space = F.space();
  const int ndx = space.ndx(), nx = space.nx(), nu = F.nu();
  auto d = workspaceFor(F, ev);
  Eigen::VectorXd x1(nx);
  Eigen::MatrixXd Fx(ndx, ndx), Fu(ndx, nu);
  ocp::NodeContext c = ev.at(x, u, true);
  F.calc(c, x, u, *d, x1);
  F.calcDiff(c, x, u, *d, Fx, Fu);
  auto tangent = [&](const Eigen::VectorXd& xx, const Eigen::VectorXd& uu) {
    Eigen::VectorXd out(nx), dv(ndx);
    const ocp::NodeContext cc = ev.at(xx, uu, false);
    F.calc(cc, xx, uu, *d, out);
    space.difference(x1, out, dv);
    return dv;
  };
  Eigen::MatrixXd Nx(ndx, ndx), Nu(ndx, nu);
  for (int i = 0; i < ndx; ++i) {
    Nx.col(i) = (tangent(perturbState(space, x, i, tol.eps), u) -
                 tangent(perturbState(space, x, i, -tol.eps), u)) /
                (2.0 * tol.eps);
  }
  for (int i = 0; i < nu; ++i) {
    Eigen::VectorXd up = u, um = u;
    up[i] += tol.eps;
    um[i] -= tol.eps;
    Nu.col(i) = (tangent(x, up) - tangent(x, um)) / (2.0 * tol.eps);
  }
  ev.at(x, u, true);
  auto rx = matricesClose(Fx, Nx, tol, "Fx");
  if (!rx) return rx;
  return matricesClose(Fu, Nu, tol, "Fu");
}

/// Checks a cost's gradient (lx, lu, with scale 1) against central differences of calc.
inline ::testing::AssertionResult checkCostGradient(
    const ocp::CostTerm& cost, const ocp::StateSpace& space, const NodeEvaluator& ev,
    const Eigen::VectorXd& x, const Eigen::VectorXd& u, const FdTolerance& tol = {}) {
  const int ndx = space.ndx(), nu = cost.nu();
  auto d = workspaceFor(cost, ev);
  Eigen::VectorXd lx = Eigen::VectorXd::Zero(ndx), lu = Eigen::VectorXd::Zero(nu);
  Eigen::MatrixXd Lxx = Eigen::MatrixXd::Zero(ndx, ndx), Luu = Eigen::MatrixXd::Zero(nu, nu),
                  Lux = Eigen::MatrixXd::Zero(nu, ndx);
  ocp::NodeContext c = ev.at(x, u, true);
  cost.calc(c, x, u, *d);
  cost.calcDiff(c, x, u, *d, 1.0, lx, lu, Lxx, Luu, Lux);
  auto value = [&](const Eigen::VectorXd& xx, const Eigen::VectorXd& uu) {
    const ocp::NodeContext cc = ev.at(xx, uu, false);
    return cost.calc(cc, xx, uu, *d);
  };
  Eigen::VectorXd nlx(ndx), nlu(nu);
  for (int i = 0; i < ndx; ++i) {
    nlx[i] = (value(perturbState(space, x, i, tol.eps), u) -
              value(perturbState(space, x, i, -tol.eps), u)) /
             (2.0 * tol.eps);
  }
  for (int i = 0; i < nu; ++i) {
    Eigen::VectorXd up = u, um = u;
    up[i] += tol.eps;
    um[i] -= tol.eps;
    nlu[i] = (value(x, up) - value(x, um)) / (2.0 * tol.eps);
  }
  ev.at(x, u, true);
  auto rx = matricesClose(lx, nlx, tol, "lx");
  if (!rx) return rx;
  return matricesClose(lu, nlu, tol, "lu");
}

/// Rank of a matrix (SVD, singular values above rel times the largest).
inline int numericalRank(const Eigen::MatrixXd& m, double rel = 1e-9) {
  if (m.size() == 0) return 0;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(m);
  const auto& s = svd.singularValues();
  int r = 0;
  for (int i = 0; i < s.size(); ++i) {
    if (s[i] > rel * s[0]) ++r;
  }
  return r;
}
}  // namespace rollstep::centroidal::test
