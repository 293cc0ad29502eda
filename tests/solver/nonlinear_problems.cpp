#include "nonlinear_problems.hpp"

#include <Eigen/Geometry>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include "rollstep/ocp/cost.hpp"
#include "rollstep/ocp/residuals.hpp"

namespace rollstep::nltest {

namespace {

Eigen::Matrix3d skew(const Eigen::Vector3d& a) {
  Eigen::Matrix3d S;
  S << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
  return S;
}

std::shared_ptr<const ocp::Dynamics> discretise(std::shared_ptr<const ocp::ContinuousDynamics> f,
                                                bool rk4) {
  if (rk4) return std::make_shared<ocp::RungeKutta4>(std::move(f));
  return std::make_shared<ocp::ExplicitEuler>(std::move(f));
}

void fillGuess(ProblemInstance& inst) {
  const auto& pb = *inst.problem;
  inst.xs_guess.assign(static_cast<size_t>(pb.horizon() + 1), inst.x0);
  inst.us_guess.assign(static_cast<size_t>(pb.horizon()), VectorXd::Zero(pb.nu()));
}

}  // namespace

// =====================================================================================
// Cart-pole

CartPoleDynamics::CartPoleDynamics(const CartPoleParams& p)
    : ContinuousDynamics(std::make_shared<ocp::EuclideanSpace>(4), 1), p_(p) {}

std::unique_ptr<ocp::DynamicsData> CartPoleDynamics::createData() const {
  return std::make_unique<ocp::DynamicsData>();
}

void CartPoleDynamics::calc(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u,
                            ocp::DynamicsData&, VecRef xdot) const {
  const double mc = p_.cart_mass, mp = p_.pole_mass, l = p_.length, g = p_.gravity;
  const double th = x[1], w = x[3], F = u[0];
  const double s = std::sin(th), c = std::cos(th);
  const double D = mc + mp * s * s;
  xdot[0] = x[2];
  xdot[1] = w;
  xdot[2] = (F + mp * s * (l * w * w + g * c)) / D;
  xdot[3] = (-F * c - mp * l * w * w * c * s - (mc + mp) * g * s) / (l * D);
}

void CartPoleDynamics::calcDiff(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u,
                                ocp::DynamicsData&, MatRef fx, MatRef fu) const {
  const double mc = p_.cart_mass, mp = p_.pole_mass, l = p_.length, g = p_.gravity;
  const double th = x[1], w = x[3], F = u[0];
  const double s = std::sin(th), c = std::cos(th);
  const double D = mc + mp * s * s;
  const double dD = 2.0 * mp * s * c;
  const double N1 = F + mp * s * (l * w * w + g * c);
  const double N1_th = mp * (l * w * w * c + g * (c * c - s * s));
  const double N1_w = 2.0 * mp * s * l * w;
  const double N2 = -F * c - mp * l * w * w * c * s - (mc + mp) * g * s;
  const double N2_th = F * s - mp * l * w * w * (c * c - s * s) - (mc + mp) * g * c;
  const double N2_w = -2.0 * mp * l * w * c * s;
  fx.setZero();
  fu.setZero();
  fx(0, 2) = 1.0;
  fx(1, 3) = 1.0;
  fx(2, 1) = (N1_th * D - N1 * dD) / (D * D);
  fx(2, 3) = N1_w / D;
  fx(3, 1) = (N2_th * D - N2 * dD) / (l * D * D);
  fx(3, 3) = N2_w / (l * D);
  fu(2, 0) = 1.0 / D;
  fu(3, 0) = -c / (l * D);
}

ProblemInstance makeCartPole(const CartPoleOptions& o) {
  auto f = std::make_shared<CartPoleDynamics>(o.params);
  auto space = f->spacePtr();
  auto pb = std::make_shared<ocp::OptimalControlProblem>(discretise(f, o.rk4), o.horizon, o.dt);
  ProblemInstance inst;
  inst.name = "cartpole";
  inst.problem = pb;
  inst.x0 = VectorXd::Zero(4);
  inst.x_goal = VectorXd::Zero(4);
  inst.x_goal[1] = M_PI;

  auto state_err = std::make_shared<ocp::StateErrorResidual>(space, 1, inst.x_goal);
  auto input_err = std::make_shared<ocp::InputErrorResidual>(4, VectorXd::Zero(1));
  pb->addCost("state", std::make_shared<ocp::LeastSquaresCost>(
                           state_err, VectorXd::Constant(4, o.state_weight)));
  pb->addCost("input", std::make_shared<ocp::LeastSquaresCost>(
                           input_err, VectorXd::Constant(1, o.input_weight)));
  pb->addCost(
      "terminal",
      std::make_shared<ocp::LeastSquaresCost>(state_err, VectorXd::Constant(4, o.terminal_weight)),
      ocp::Stage::Terminal);
  pb->setInputBounds(VectorXd::Constant(1, -o.force_limit), VectorXd::Constant(1, o.force_limit));
  if (o.track_limit > 0.0) {
    VectorXd lo = VectorXd::Constant(4, -ocp::OptimalControlProblem::kInfinity);
    VectorXd hi = VectorXd::Constant(4, ocp::OptimalControlProblem::kInfinity);
    lo[0] = -o.track_limit;
    hi[0] = o.track_limit;
    pb->setStateBounds(lo, hi);
  }
  fillGuess(inst);
  return inst;
}

// =====================================================================================
// Unicycle

UnicycleDynamics::UnicycleDynamics()
    : ContinuousDynamics(std::make_shared<ocp::EuclideanSpace>(3), 2) {}

std::unique_ptr<ocp::DynamicsData> UnicycleDynamics::createData() const {
  return std::make_unique<ocp::DynamicsData>();
}

void UnicycleDynamics::calc(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u,
                            ocp::DynamicsData&, VecRef xdot) const {
  xdot[0] = u[0] * std::cos(x[2]);
  xdot[1] = u[0] * std::sin(x[2]);
  xdot[2] = u[1];
}

void UnicycleDynamics::calcDiff(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u,
                                ocp::DynamicsData&, MatRef fx, MatRef fu) const {
  const double c = std::cos(x[2]), s = std::sin(x[2]);
  fx.setZero();
  fu.setZero();
  fx(0, 2) = -u[0] * s;
  fx(1, 2) = u[0] * c;
  fu(0, 0) = c;
  fu(1, 0) = s;
  fu(2, 1) = 1.0;
}

CircleObstacleResidual::CircleObstacleResidual(std::shared_ptr<const ocp::StateSpace> space, int nu,
                                               std::vector<Circle> circles, int ix, int iy)
    : Residual(space->ndx(), nu, static_cast<int>(circles.size())),
      circles_(std::move(circles)),
      ix_(ix + space->nx() - space->ndx()),
      iy_(iy + space->nx() - space->ndx()) {
  if (ix < space->euclideanTangentOffset() || iy < space->euclideanTangentOffset())
    throw std::invalid_argument("CircleObstacleResidual: coordinates must be Euclidean");
}

void CircleObstacleResidual::calc(const ocp::NodeContext&, ConstVecRef x, ConstVecRef,
                                  ocp::ResidualData& d) const {
  for (size_t i = 0; i < circles_.size(); ++i) {
    const Circle& c = circles_[i];
    const double dx = x[ix_] - c.cx, dy = x[iy_] - c.cy;
    d.r[static_cast<Eigen::Index>(i)] = dx * dx + dy * dy - c.radius * c.radius;
  }
}

void CircleObstacleResidual::calcDiff(const ocp::NodeContext&, ConstVecRef x, ConstVecRef,
                                      ocp::ResidualData& d) const {
  const int off = static_cast<int>(x.size()) - ndx();
  const int rows = static_cast<int>(circles_.size());
  d.Rx.topRows(rows).setZero();
  d.Ru.topRows(rows).setZero();
  for (int i = 0; i < rows; ++i) {
    const Circle& c = circles_[static_cast<size_t>(i)];
    d.Rx(i, ix_ - off) = 2.0 * (x[ix_] - c.cx);
    d.Rx(i, iy_ - off) = 2.0 * (x[iy_] - c.cy);
  }
}

SpeedProfileResidual::SpeedProfileResidual(double gain, double cruise_speed, double goal_x,
                                           double goal_y)
    : Residual(3, 2, 1), gain_(gain), cruise_(cruise_speed), gx_(goal_x), gy_(goal_y) {
  if (!(cruise_speed > 0.0)) throw std::invalid_argument("SpeedProfileResidual: cruise speed");
}

double SpeedProfileResidual::speed(ConstVecRef x) const {
  const double s = (gx_ - x[0]) * std::cos(x[2]) + (gy_ - x[1]) * std::sin(x[2]);
  return cruise_ * std::tanh(gain_ * s / cruise_);
}

void SpeedProfileResidual::calc(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u,
                                ocp::ResidualData& d) const {
  d.r[0] = u[0] - speed(x);
}

void SpeedProfileResidual::calcDiff(const ocp::NodeContext&, ConstVecRef x, ConstVecRef,
                                    ocp::ResidualData& d) const {
  const double c = std::cos(x[2]), s = std::sin(x[2]);
  const double along = (gx_ - x[0]) * c + (gy_ - x[1]) * s;
  const double t = std::tanh(gain_ * along / cruise_);
  const double dv = gain_ * (1.0 - t * t);  // d v_path / d along
  d.Rx(0, 0) = dv * c;
  d.Rx(0, 1) = dv * s;
  d.Rx(0, 2) = -dv * (-(gx_ - x[0]) * s + (gy_ - x[1]) * c);
  d.Ru(0, 0) = 1.0;
  d.Ru(0, 1) = 0.0;
}

ProblemInstance makeUnicycle(const UnicycleOptions& o) {
  auto f = std::make_shared<UnicycleDynamics>();
  auto space = f->spacePtr();
  auto pb = std::make_shared<ocp::OptimalControlProblem>(discretise(f, o.rk4), o.horizon, o.dt);
  ProblemInstance inst;
  inst.name = "unicycle";
  inst.problem = pb;
  inst.x0 = o.x0;
  inst.x_goal = VectorXd::Zero(3);
  inst.x_goal << o.goal_x, o.goal_y, 0.0;

  // Position error p - goal as an affine residual around the goal.
  MatrixXd C = MatrixXd::Zero(2, 3);
  C(0, 0) = 1.0;
  C(1, 1) = 1.0;
  auto pos_err = std::make_shared<ocp::AffineResidual>(space, inst.x_goal, C, MatrixXd::Zero(2, 2),
                                                       VectorXd::Zero(2));
  MatrixXd Dw = MatrixXd::Zero(1, 2);
  Dw(0, 1) = 1.0;
  auto turn = std::make_shared<ocp::AffineResidual>(space, inst.x_goal, MatrixXd::Zero(1, 3), Dw,
                                                    VectorXd::Zero(1));
  pb->addCost("position", std::make_shared<ocp::LeastSquaresCost>(
                              pos_err, VectorXd::Constant(2, o.position_weight)));
  pb->addCost("turn_rate",
              std::make_shared<ocp::LeastSquaresCost>(turn, VectorXd::Constant(1, o.turn_weight)));
  pb->addCost(
      "terminal_position",
      std::make_shared<ocp::LeastSquaresCost>(pos_err, VectorXd::Constant(2, o.terminal_weight)),
      ocp::Stage::Terminal);
  auto profile =
      std::make_shared<SpeedProfileResidual>(o.speed_gain, o.cruise_speed, o.goal_x, o.goal_y);
  pb->addEquality("speed_profile", profile);
  if (!o.hard_obstacles.empty()) {
    auto obs = std::make_shared<CircleObstacleResidual>(space, 2, o.hard_obstacles);
    pb->addInequality("obstacles", obs,
                      o.terminal_obstacles ? ocp::Stage::All : ocp::Stage::Running);
  }
  if (!o.soft_obstacles.empty()) {
    ocp::InequalityOptions soft;
    soft.soft = true;
    soft.relaxation = o.soft_relaxation;
    soft.weight = o.soft_weight;
    pb->addInequality("soft_obstacles",
                      std::make_shared<CircleObstacleResidual>(space, 2, o.soft_obstacles),
                      ocp::Stage::Running, soft);
  }
  VectorXd lo(2), hi(2);
  lo << -o.speed_limit, -o.turn_rate_limit;
  hi << o.speed_limit, o.turn_rate_limit;
  pb->setInputBounds(lo, hi);
  // Initial guess: drive straight on with the profile speed (omega = 0), which satisfies
  // the dynamics and the speed profile (possibly not the obstacles).
  fillGuess(inst);
  auto d = pb->createNodeData();
  for (int k = 0; k < o.horizon; ++k) {
    const auto kk = static_cast<size_t>(k);
    inst.us_guess[kk][0] = profile->speed(inst.xs_guess[kk]);
    pb->evaluate(k, inst.xs_guess[kk], inst.us_guess[kk], *d);
    inst.xs_guess[kk + 1] = d->xnext;
  }
  return inst;
}

// =====================================================================================
// Rigid body

RigidBodyDynamics::RigidBodyDynamics(const RigidBodyParams& p)
    : ContinuousDynamics(std::make_shared<ocp::SE3xEuclideanSpace>(6), 6), p_(p) {}

std::unique_ptr<ocp::DynamicsData> RigidBodyDynamics::createData() const {
  return std::make_unique<ocp::DynamicsData>();
}

void RigidBodyDynamics::calc(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u,
                             ocp::DynamicsData&, VecRef xdot) const {
  const Eigen::Quaterniond q(x[6], x[3], x[4], x[5]);
  const Eigen::Matrix3d R = q.normalized().toRotationMatrix();
  const Eigen::Vector3d v = x.segment<3>(7), w = x.segment<3>(10);
  const Eigen::Vector3d f = u.segment<3>(0), tau = u.segment<3>(3);
  const Eigen::Vector3d I = p_.inertia;
  xdot.segment<3>(0) = v;
  xdot.segment<3>(3) = w;
  xdot.segment<3>(6) = f / p_.mass + R.transpose() * p_.gravity - w.cross(v);
  xdot.segment<3>(9) = (tau - w.cross(I.cwiseProduct(w))).cwiseQuotient(I);
}

void RigidBodyDynamics::calcDiff(const ocp::NodeContext&, ConstVecRef x, ConstVecRef,
                                 ocp::DynamicsData&, MatRef fx, MatRef fu) const {
  const Eigen::Quaterniond q(x[6], x[3], x[4], x[5]);
  const Eigen::Matrix3d R = q.normalized().toRotationMatrix();
  const Eigen::Vector3d v = x.segment<3>(7), w = x.segment<3>(10);
  const Eigen::Vector3d I = p_.inertia;
  const Eigen::Matrix3d Iinv = I.cwiseInverse().asDiagonal();
  fx.setZero();
  fu.setZero();
  fx.block<3, 3>(0, 6).setIdentity();
  fx.block<3, 3>(3, 9).setIdentity();
  // (R Exp(th))^T g = R^T g + [R^T g]x th to first order.
  fx.block<3, 3>(6, 3) = skew(R.transpose() * p_.gravity);
  fx.block<3, 3>(6, 6) = -skew(w);
  fx.block<3, 3>(6, 9) = skew(v);
  fx.block<3, 3>(9, 9) =
      Iinv * (skew(I.cwiseProduct(w)) - skew(w) * Eigen::Matrix3d(I.asDiagonal()));
  fu.block<3, 3>(6, 0) = Eigen::Matrix3d::Identity() / p_.mass;
  fu.block<3, 3>(9, 3) = Iinv;
}

ProblemInstance makeRigidBody(const RigidBodyOptions& o) {
  auto f = std::make_shared<RigidBodyDynamics>(o.params);
  auto space = f->spacePtr();
  auto pb = std::make_shared<ocp::OptimalControlProblem>(std::make_shared<ocp::ExplicitEuler>(f),
                                                         o.horizon, o.dt);
  ProblemInstance inst;
  inst.name = "rigid_body";
  inst.problem = pb;
  inst.x0 = VectorXd::Zero(13);
  inst.x0[6] = 1.0;  // identity quaternion (w last)
  inst.x_goal = VectorXd::Zero(13);
  inst.x_goal.head<3>() = o.target_position;
  const Eigen::Quaterniond qt(Eigen::AngleAxisd(o.target_angle, o.target_axis.normalized()));
  inst.x_goal[3] = qt.x();
  inst.x_goal[4] = qt.y();
  inst.x_goal[5] = qt.z();
  inst.x_goal[6] = qt.w();

  auto state_err = std::make_shared<ocp::StateErrorResidual>(space, 6, inst.x_goal);
  VectorXd wr(12), wt(12);
  wr << VectorXd::Constant(6, o.running_pose_weight), VectorXd::Constant(6, o.running_twist_weight);
  wt << VectorXd::Constant(6, o.terminal_pose_weight),
      VectorXd::Constant(6, o.terminal_twist_weight);
  pb->addCost("state", std::make_shared<ocp::LeastSquaresCost>(state_err, wr));
  pb->addCost("input", std::make_shared<ocp::LeastSquaresCost>(
                           std::make_shared<ocp::InputErrorResidual>(12, VectorXd::Zero(6)),
                           VectorXd::Constant(6, o.input_weight)));
  pb->addCost("terminal", std::make_shared<ocp::LeastSquaresCost>(state_err, wt),
              ocp::Stage::Terminal);
  VectorXd hi(6);
  hi << VectorXd::Constant(3, o.force_limit), VectorXd::Constant(3, o.torque_limit);
  pb->setInputBounds(-hi, hi);
  fillGuess(inst);
  return inst;
}

// =====================================================================================
// Two-link arm

TwoLinkArmDynamics::TwoLinkArmDynamics(const TwoLinkArmParams& p)
    : ContinuousDynamics(std::make_shared<ocp::EuclideanSpace>(4), 2), p_(p) {}

std::unique_ptr<ocp::DynamicsData> TwoLinkArmDynamics::createData() const {
  return std::make_unique<ocp::DynamicsData>();
}

Eigen::Vector2d TwoLinkArmDynamics::gravityTorque(double q1, double q2) const {
  const double c1 = std::cos(q1), c12 = std::cos(q1 + q2);
  const double g = p_.gravity;
  return {g * ((p_.mass1 + p_.mass2) * p_.length1 * c1 + p_.mass2 * p_.length2 * c12),
          g * p_.mass2 * p_.length2 * c12};
}

Eigen::Vector2d TwoLinkArmDynamics::endEffector(double q1, double q2) const {
  return {p_.length1 * std::cos(q1) + p_.length2 * std::cos(q1 + q2),
          p_.length1 * std::sin(q1) + p_.length2 * std::sin(q1 + q2)};
}

namespace {

struct ArmTerms {
  Eigen::Matrix2d M;
  Eigen::Vector2d r;  ///< tau - C dq - G - b dq
};

ArmTerms armTerms(const TwoLinkArmParams& p, ConstVecRef x, ConstVecRef u) {
  const double m1 = p.mass1, m2 = p.mass2, l1 = p.length1, l2 = p.length2, g = p.gravity;
  const double q1 = x[0], q2 = x[1], dq1 = x[2], dq2 = x[3];
  const double c2 = std::cos(q2), s2 = std::sin(q2);
  const double c1 = std::cos(q1), c12 = std::cos(q1 + q2);
  ArmTerms t;
  t.M(0, 0) = m1 * l1 * l1 + m2 * (l1 * l1 + 2.0 * l1 * l2 * c2 + l2 * l2);
  t.M(0, 1) = m2 * (l1 * l2 * c2 + l2 * l2);
  t.M(1, 0) = t.M(0, 1);
  t.M(1, 1) = m2 * l2 * l2;
  const double h = m2 * l1 * l2 * s2;
  t.r[0] = u[0] + h * (2.0 * dq1 * dq2 + dq2 * dq2) - g * ((m1 + m2) * l1 * c1 + m2 * l2 * c12) -
           p.friction * dq1;
  t.r[1] = u[1] - h * dq1 * dq1 - g * m2 * l2 * c12 - p.friction * dq2;
  return t;
}

}  // namespace

void TwoLinkArmDynamics::calc(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u,
                              ocp::DynamicsData&, VecRef xdot) const {
  const ArmTerms t = armTerms(p_, x, u);
  xdot[0] = x[2];
  xdot[1] = x[3];
  xdot.segment<2>(2) = t.M.inverse() * t.r;
}

void TwoLinkArmDynamics::calcDiff(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u,
                                  ocp::DynamicsData&, MatRef fx, MatRef fu) const {
  const double m1 = p_.mass1, m2 = p_.mass2, l1 = p_.length1, l2 = p_.length2, g = p_.gravity;
  const double q1 = x[0], q2 = x[1], dq1 = x[2], dq2 = x[3];
  const double c2 = std::cos(q2), s2 = std::sin(q2);
  const double s1 = std::sin(q1), s12 = std::sin(q1 + q2);
  const ArmTerms t = armTerms(p_, x, u);
  const Eigen::Matrix2d Minv = t.M.inverse();
  const Eigen::Vector2d ddq = Minv * t.r;
  const double h = m2 * l1 * l2 * s2, dh = m2 * l1 * l2 * c2;
  // dr / d[q1, q2, dq1, dq2]
  Eigen::Matrix<double, 2, 4> dr;
  dr(0, 0) = g * ((m1 + m2) * l1 * s1 + m2 * l2 * s12);
  dr(0, 1) = dh * (2.0 * dq1 * dq2 + dq2 * dq2) + g * m2 * l2 * s12;
  dr(1, 0) = g * m2 * l2 * s12;
  dr(1, 1) = -dh * dq1 * dq1 + g * m2 * l2 * s12;
  dr(0, 2) = 2.0 * h * dq2 - p_.friction;
  dr(0, 3) = h * (2.0 * dq1 + 2.0 * dq2);
  dr(1, 2) = -2.0 * h * dq1;
  dr(1, 3) = -p_.friction;
  // dM / dq2 (M does not depend on q1).
  Eigen::Matrix2d dM;
  dM << -2.0 * m2 * l1 * l2 * s2, -m2 * l1 * l2 * s2, -m2 * l1 * l2 * s2, 0.0;
  dr.col(1) -= dM * ddq;
  fx.setZero();
  fu.setZero();
  fx(0, 2) = 1.0;
  fx(1, 3) = 1.0;
  fx.bottomRows<2>() = Minv * dr;
  fu.bottomRows<2>() = Minv;
}

AcrobotDynamics::AcrobotDynamics(const TwoLinkArmParams& p)
    : ContinuousDynamics(std::make_shared<ocp::EuclideanSpace>(4), 1), arm_(p) {}

std::unique_ptr<ocp::DynamicsData> AcrobotDynamics::createData() const {
  return std::make_unique<ocp::DynamicsData>();
}

void AcrobotDynamics::calc(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u,
                           ocp::DynamicsData& d, VecRef xdot) const {
  const Eigen::Vector2d tau(0.0, u[0]);
  arm_.calc(ctx, x, tau, d, xdot);
}

void AcrobotDynamics::calcDiff(const ocp::NodeContext& ctx, ConstVecRef x, ConstVecRef u,
                               ocp::DynamicsData& d, MatRef fx, MatRef fu) const {
  const Eigen::Vector2d tau(0.0, u[0]);
  Eigen::Matrix<double, 4, 2> fu_arm;
  arm_.calcDiff(ctx, x, tau, d, fx, fu_arm);
  fu = fu_arm.col(1);
}

ProblemInstance makeAcrobot(const AcrobotOptions& o) {
  auto f = std::make_shared<AcrobotDynamics>(o.params);
  auto space = f->spacePtr();
  auto pb = std::make_shared<ocp::OptimalControlProblem>(discretise(f, true), o.horizon, o.dt);
  ProblemInstance inst;
  inst.name = "acrobot";
  inst.problem = pb;
  inst.x0 = VectorXd::Zero(4);
  inst.x0[0] = -M_PI / 2;
  inst.x_goal = VectorXd::Zero(4);
  inst.x_goal[0] = M_PI / 2;
  auto state_err = std::make_shared<ocp::StateErrorResidual>(space, 1, inst.x_goal);
  pb->addCost("state", std::make_shared<ocp::LeastSquaresCost>(
                           state_err, VectorXd::Constant(4, o.state_weight)));
  pb->addCost("input", std::make_shared<ocp::LeastSquaresCost>(
                           std::make_shared<ocp::InputErrorResidual>(4, VectorXd::Zero(1)),
                           VectorXd::Constant(1, o.input_weight)));
  pb->addCost(
      "terminal",
      std::make_shared<ocp::LeastSquaresCost>(state_err, VectorXd::Constant(4, o.terminal_weight)),
      ocp::Stage::Terminal);
  pb->setInputBounds(VectorXd::Constant(1, -o.torque_limit), VectorXd::Constant(1, o.torque_limit));
  VectorXd lo = VectorXd::Constant(4, -ocp::OptimalControlProblem::kInfinity);
  VectorXd hi = VectorXd::Constant(4, ocp::OptimalControlProblem::kInfinity);
  lo.tail<2>().setConstant(-o.velocity_limit);
  hi.tail<2>().setConstant(o.velocity_limit);
  pb->setStateBounds(lo, hi);
  fillGuess(inst);
  return inst;
}

ArmKeepOutResidual::ArmKeepOutResidual(int ndx, int nu, double length1, double length2,
                                       std::vector<Circle> discs)
    : Residual(ndx, nu, static_cast<int>(discs.size())),
      l1_(length1),
      l2_(length2),
      discs_(std::move(discs)) {
  if (ndx < 2) throw std::invalid_argument("ArmKeepOutResidual: needs q1, q2 in the state");
}

void ArmKeepOutResidual::calc(const ocp::NodeContext&, ConstVecRef x, ConstVecRef,
                              ocp::ResidualData& d) const {
  const double px = l1_ * std::cos(x[0]) + l2_ * std::cos(x[0] + x[1]);
  const double py = l1_ * std::sin(x[0]) + l2_ * std::sin(x[0] + x[1]);
  for (size_t i = 0; i < discs_.size(); ++i) {
    const Circle& c = discs_[i];
    const double dx = px - c.cx, dy = py - c.cy;
    d.r[static_cast<Eigen::Index>(i)] = dx * dx + dy * dy - c.radius * c.radius;
  }
}

void ArmKeepOutResidual::calcDiff(const ocp::NodeContext&, ConstVecRef x, ConstVecRef,
                                  ocp::ResidualData& d) const {
  const double c1 = std::cos(x[0]), s1 = std::sin(x[0]);
  const double c12 = std::cos(x[0] + x[1]), s12 = std::sin(x[0] + x[1]);
  const double px = l1_ * c1 + l2_ * c12, py = l1_ * s1 + l2_ * s12;
  Eigen::Matrix2d J;  // d p_ee / d q
  J << -l1_ * s1 - l2_ * s12, -l2_ * s12, l1_ * c1 + l2_ * c12, l2_ * c12;
  const int rows = static_cast<int>(discs_.size());
  d.Rx.topRows(rows).setZero();
  d.Ru.topRows(rows).setZero();
  for (int i = 0; i < rows; ++i) {
    const Circle& c = discs_[static_cast<size_t>(i)];
    const Eigen::Vector2d e(px - c.cx, py - c.cy);
    d.Rx.block(i, 0, 1, 2) = 2.0 * e.transpose() * J;
  }
}

ProblemInstance makeTwoLinkArm(const TwoLinkArmOptions& o) {
  auto f = std::make_shared<TwoLinkArmDynamics>(o.params);
  auto space = f->spacePtr();
  auto pb = std::make_shared<ocp::OptimalControlProblem>(discretise(f, true), o.horizon, o.dt);
  ProblemInstance inst;
  inst.name = "two_link_arm";
  inst.problem = pb;
  inst.x0 = VectorXd::Zero(4);
  inst.x0[0] = o.q_start[0];
  inst.x0[1] = o.q_start[1];
  inst.x_goal = VectorXd::Zero(4);
  inst.x_goal[0] = o.q_goal[0];
  inst.x_goal[1] = o.q_goal[1];

  auto state_err = std::make_shared<ocp::StateErrorResidual>(space, 2, inst.x_goal);
  VectorXd wr(4);
  wr << o.state_weight, o.state_weight, o.velocity_weight, o.velocity_weight;
  pb->addCost("state", std::make_shared<ocp::LeastSquaresCost>(state_err, wr));
  // Plain VectorXd copies of the 2-vectors (a fixed-size to dynamic copy trips GCC 12's
  // -Warray-bounds with AVX).
  const Eigen::Vector2d hold = f->gravityTorque(o.q_goal[0], o.q_goal[1]);
  VectorXd u_ref(2), tau_max(2);
  u_ref << hold[0], hold[1];
  tau_max << o.torque_limit[0], o.torque_limit[1];
  pb->addCost("input", std::make_shared<ocp::LeastSquaresCost>(
                           std::make_shared<ocp::InputErrorResidual>(4, u_ref),
                           VectorXd::Constant(2, o.input_weight)));
  pb->addCost(
      "terminal",
      std::make_shared<ocp::LeastSquaresCost>(state_err, VectorXd::Constant(4, o.terminal_weight)),
      ocp::Stage::Terminal);
  if (!o.keep_out.empty()) {
    pb->addInequality(
        "keep_out",
        std::make_shared<ArmKeepOutResidual>(4, 2, o.params.length1, o.params.length2, o.keep_out),
        ocp::Stage::All);
  }
  pb->setInputBounds(-tau_max, tau_max);
  VectorXd lo(4), hi(4);
  lo << o.joint_lower[0], o.joint_lower[1], -o.velocity_limit, -o.velocity_limit;
  hi << o.joint_upper[0], o.joint_upper[1], o.velocity_limit, o.velocity_limit;
  pb->setStateBounds(lo, hi);
  fillGuess(inst);
  const Eigen::Vector2d hold0 = f->gravityTorque(o.q_start[0], o.q_start[1]);
  for (auto& u : inst.us_guess) {
    for (int i = 0; i < 2; ++i) u[i] = std::clamp(hold0[i], -tau_max[i], tau_max[i]);
  }
  return inst;
}

// =====================================================================================
// Planar quadrotor

PlanarQuadrotorDynamics::PlanarQuadrotorDynamics(const PlanarQuadrotorParams& p)
    : ContinuousDynamics(std::make_shared<ocp::EuclideanSpace>(6), 2), p_(p) {}

std::unique_ptr<ocp::DynamicsData> PlanarQuadrotorDynamics::createData() const {
  return std::make_unique<ocp::DynamicsData>();
}

void PlanarQuadrotorDynamics::calc(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u,
                                   ocp::DynamicsData&, VecRef xdot) const {
  const double th = x[2], F = u[0] + u[1];
  xdot.head<3>() = x.segment<3>(3);
  xdot[3] = -F * std::sin(th) / p_.mass;
  xdot[4] = F * std::cos(th) / p_.mass - p_.gravity;
  xdot[5] = p_.arm * (u[0] - u[1]) / p_.inertia;
}

void PlanarQuadrotorDynamics::calcDiff(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u,
                                       ocp::DynamicsData&, MatRef fx, MatRef fu) const {
  const double th = x[2], F = u[0] + u[1];
  const double s = std::sin(th), c = std::cos(th);
  fx.setZero();
  fu.setZero();
  fx.topRightCorner<3, 3>().setIdentity();
  fx(3, 2) = -F * c / p_.mass;
  fx(4, 2) = -F * s / p_.mass;
  fu(3, 0) = fu(3, 1) = -s / p_.mass;
  fu(4, 0) = fu(4, 1) = c / p_.mass;
  fu(5, 0) = p_.arm / p_.inertia;
  fu(5, 1) = -p_.arm / p_.inertia;
}

ProblemInstance makePlanarQuadrotor(const PlanarQuadrotorOptions& o) {
  auto f = std::make_shared<PlanarQuadrotorDynamics>(o.params);
  auto space = f->spacePtr();
  auto pb = std::make_shared<ocp::OptimalControlProblem>(discretise(f, true), o.horizon, o.dt);
  ProblemInstance inst;
  inst.name = "planar_quadrotor";
  inst.problem = pb;
  inst.x0 = VectorXd::Zero(6);
  inst.x0[0] = o.start[0];
  inst.x0[1] = o.start[1];
  inst.x_goal = VectorXd::Zero(6);
  inst.x_goal[0] = o.goal[0];
  inst.x_goal[1] = o.goal[1];

  auto state_err = std::make_shared<ocp::StateErrorResidual>(space, 2, inst.x_goal);
  VectorXd wr(6);
  wr << o.position_weight, o.position_weight, VectorXd::Constant(4, o.attitude_weight);
  pb->addCost("state", std::make_shared<ocp::LeastSquaresCost>(state_err, wr));
  const double hover = 0.5 * o.params.mass * o.params.gravity;
  pb->addCost("input",
              std::make_shared<ocp::LeastSquaresCost>(
                  std::make_shared<ocp::InputErrorResidual>(6, VectorXd::Constant(2, hover)),
                  VectorXd::Constant(2, o.input_weight)));
  pb->addCost(
      "terminal",
      std::make_shared<ocp::LeastSquaresCost>(state_err, VectorXd::Constant(6, o.terminal_weight)),
      ocp::Stage::Terminal);
  if (!o.keep_out.empty()) {
    pb->addInequality("keep_out", std::make_shared<CircleObstacleResidual>(space, 2, o.keep_out),
                      ocp::Stage::All);
  }
  pb->setInputBounds(VectorXd::Zero(2), VectorXd::Constant(2, o.thrust_max));
  VectorXd lo = VectorXd::Constant(6, -ocp::OptimalControlProblem::kInfinity);
  VectorXd hi = VectorXd::Constant(6, ocp::OptimalControlProblem::kInfinity);
  lo[1] = o.floor_height;
  lo[2] = -o.tilt_limit;
  hi[2] = o.tilt_limit;
  pb->setStateBounds(lo, hi);
  fillGuess(inst);
  for (auto& u : inst.us_guess) u.setConstant(hover);
  return inst;
}

// =====================================================================================
// Kinematic bicycle

BicycleDynamics::BicycleDynamics(double wheelbase)
    : ContinuousDynamics(std::make_shared<ocp::EuclideanSpace>(4), 2), wheelbase_(wheelbase) {}

std::unique_ptr<ocp::DynamicsData> BicycleDynamics::createData() const {
  return std::make_unique<ocp::DynamicsData>();
}

void BicycleDynamics::calc(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u,
                           ocp::DynamicsData&, VecRef xdot) const {
  const double th = x[2], v = x[3];
  xdot[0] = v * std::cos(th);
  xdot[1] = v * std::sin(th);
  xdot[2] = v * std::tan(u[1]) / wheelbase_;
  xdot[3] = u[0];
}

void BicycleDynamics::calcDiff(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u,
                               ocp::DynamicsData&, MatRef fx, MatRef fu) const {
  const double th = x[2], v = x[3];
  const double c = std::cos(th), s = std::sin(th), cd = std::cos(u[1]);
  fx.setZero();
  fu.setZero();
  fx(0, 2) = -v * s;
  fx(0, 3) = c;
  fx(1, 2) = v * c;
  fx(1, 3) = s;
  fx(2, 3) = std::tan(u[1]) / wheelbase_;
  fu(2, 1) = v / (wheelbase_ * cd * cd);
  fu(3, 0) = 1.0;
}

ProblemInstance makeBicycle(const BicycleOptions& o) {
  auto f = std::make_shared<BicycleDynamics>(o.wheelbase);
  auto space = f->spacePtr();
  auto pb = std::make_shared<ocp::OptimalControlProblem>(discretise(f, true), o.horizon, o.dt);
  ProblemInstance inst;
  inst.name = "bicycle";
  inst.problem = pb;
  inst.x0 = VectorXd::Zero(4);
  inst.x_goal = VectorXd::Zero(4);
  inst.x_goal << o.goal[0], o.goal[1], o.goal_heading, 0.0;

  MatrixXd C = MatrixXd::Zero(2, 4);
  C(0, 0) = 1.0;
  C(1, 1) = 1.0;
  auto pos_err = std::make_shared<ocp::AffineResidual>(space, inst.x_goal, C, MatrixXd::Zero(2, 2),
                                                       VectorXd::Zero(2));
  pb->addCost("position", std::make_shared<ocp::LeastSquaresCost>(
                              pos_err, VectorXd::Constant(2, o.position_weight)));
  pb->addCost("input", std::make_shared<ocp::LeastSquaresCost>(
                           std::make_shared<ocp::InputErrorResidual>(4, VectorXd::Zero(2)),
                           VectorXd::Constant(2, o.input_weight)));
  pb->addCost("terminal",
              std::make_shared<ocp::LeastSquaresCost>(
                  std::make_shared<ocp::StateErrorResidual>(space, 2, inst.x_goal),
                  VectorXd::Constant(4, o.terminal_weight)),
              ocp::Stage::Terminal);
  if (!o.keep_out.empty()) {
    pb->addInequality("keep_out", std::make_shared<CircleObstacleResidual>(space, 2, o.keep_out),
                      ocp::Stage::All);
  }
  VectorXd ulim(2);
  ulim << o.acceleration_limit, o.steering_limit;
  pb->setInputBounds(-ulim, ulim);
  VectorXd lo = VectorXd::Constant(4, -ocp::OptimalControlProblem::kInfinity);
  VectorXd hi = VectorXd::Constant(4, ocp::OptimalControlProblem::kInfinity);
  lo[3] = -0.5;
  hi[3] = o.speed_limit;
  pb->setStateBounds(lo, hi);
  fillGuess(inst);
  return inst;
}

// =====================================================================================
// Maratos circle

namespace {
class SingleIntegrator final : public ocp::ContinuousDynamics {
 public:
  SingleIntegrator() : ContinuousDynamics(std::make_shared<ocp::EuclideanSpace>(2), 2) {}
  bool isLinear() const override { return true; }
  std::unique_ptr<ocp::DynamicsData> createData() const override {
    return std::make_unique<ocp::DynamicsData>();
  }
  void calc(const ocp::NodeContext&, ConstVecRef, ConstVecRef u, ocp::DynamicsData&,
            VecRef xdot) const override {
    xdot = u;
  }
  void calcDiff(const ocp::NodeContext&, ConstVecRef, ConstVecRef, ocp::DynamicsData&, MatRef fx,
                MatRef fu) const override {
    fx.setZero();
    fu.setIdentity();
  }
};
}  // namespace

CircleStepResidual::CircleStepResidual(double dt, double radius)
    : Residual(2, 2, 1), dt_(dt), radius_(radius) {}

void CircleStepResidual::calc(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u,
                              ocp::ResidualData& d) const {
  const Eigen::Vector2d p = x.head<2>() + dt_ * u.head<2>();
  d.r[0] = p.squaredNorm() - radius_ * radius_;
}

void CircleStepResidual::calcDiff(const ocp::NodeContext&, ConstVecRef x, ConstVecRef u,
                                  ocp::ResidualData& d) const {
  const Eigen::Vector2d p = x.head<2>() + dt_ * u.head<2>();
  d.Rx.row(0) = 2.0 * p.transpose();
  d.Ru.row(0) = 2.0 * dt_ * p.transpose();
}

ProblemInstance makeMaratosCircle(const MaratosCircleOptions& o) {
  auto f = std::make_shared<SingleIntegrator>();
  auto space = f->spacePtr();
  auto pb = std::make_shared<ocp::OptimalControlProblem>(discretise(f, false), o.horizon, o.dt);
  ProblemInstance inst;
  inst.name = "maratos_circle";
  inst.problem = pb;
  const auto onCircle = [&o](double a) {
    VectorXd p(2);
    p << o.radius * std::cos(a), o.radius * std::sin(a);
    return p;
  };
  inst.x0 = onCircle(o.start_angle);
  inst.x_goal = onCircle(0.0);
  // 2 (|p|^2 - r^2) - p_x = 2 |p - (1/4, 0)|^2 - const: LeastSquaresCost is 1/2 w |r|^2.
  VectorXd centre(2);
  centre << 0.25, 0.0;
  auto pos = std::make_shared<ocp::AffineResidual>(space, centre, MatrixXd::Identity(2, 2),
                                                   MatrixXd::Zero(2, 2), VectorXd::Zero(2));
  MatrixXd D = MatrixXd::Identity(2, 2);
  auto vel = std::make_shared<ocp::AffineResidual>(space, centre, MatrixXd::Zero(2, 2), D,
                                                   VectorXd::Zero(2));
  pb->addCost("position", std::make_shared<ocp::LeastSquaresCost>(pos, VectorXd::Constant(2, 4.0)),
              ocp::Stage::All);
  pb->addCost("velocity",
              std::make_shared<ocp::LeastSquaresCost>(vel, VectorXd::Constant(2, o.input_weight)));
  pb->addEquality("on_circle", std::make_shared<CircleStepResidual>(o.dt, o.radius));
  fillGuess(inst);
  for (int k = 0; k <= o.horizon; ++k) {
    const double a = o.start_angle + (0.3 - o.start_angle) * k / o.horizon;
    inst.xs_guess[static_cast<std::size_t>(k)] = onCircle(a);
  }
  for (int k = 0; k < o.horizon; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    inst.us_guess[kk] = (inst.xs_guess[kk + 1] - inst.xs_guess[kk]) / o.dt;
  }
  return inst;
}

ProblemInstance makeNamedProblem(const std::string& name) {
  if (name == "two_link_arm") return makeTwoLinkArm();
  if (name == "planar_quadrotor") return makePlanarQuadrotor();
  if (name == "bicycle") return makeBicycle();
  if (name == "cartpole") return makeCartPole();
  if (name == "unicycle") return makeUnicycle();
  if (name == "rigid_body") return makeRigidBody();
  if (name == "maratos_circle") return makeMaratosCircle();
  if (name == "rigid_body_g") {
    RigidBodyOptions o;
    o.params.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
    o.force_limit = 25.0;
    o.torque_limit = 0.6;
    return makeRigidBody(o);
  }
  if (name == "unicycle2") {
    UnicycleOptions o;
    o.hard_obstacles = {{1.5, -0.15, 0.4}, {3.0, 0.35, 0.3}};
    return makeUnicycle(o);
  }
  if (name == "acrobot") return makeAcrobot();
  if (name == "cartpole_euler") {
    CartPoleOptions o;
    o.rk4 = false;
    return makeCartPole(o);
  }
  throw std::invalid_argument("unknown problem " + name);
}

// =====================================================================================
// Helpers

std::vector<VectorXd> interpolatedStates(const ProblemInstance& inst) {
  const auto& space = inst.problem->stateSpace();
  const int N = inst.problem->horizon();
  VectorXd delta(space.ndx());
  space.difference(inst.x0, inst.x_goal, delta);
  std::vector<VectorXd> xs(static_cast<size_t>(N + 1), inst.x0);
  for (int k = 0; k <= N; ++k)
    space.integrate(inst.x0, (static_cast<double>(k) / N) * delta, xs[static_cast<size_t>(k)]);
  return xs;
}

std::vector<NamedStart> twoStarts(const ProblemInstance& inst) {
  return {{"default", inst.xs_guess, inst.us_guess},
          {"interpolated", interpolatedStates(inst), inst.us_guess}};
}

ActiveSetCount countActive(const ocp::OptimalControlProblem& problem,
                           const std::vector<VectorXd>& xs, const std::vector<VectorXd>& us,
                           double tol) {
  ActiveSetCount n;
  auto count = [tol](const ocp::BoundSet& b, ConstVecRef v, int offset) {
    int c = 0;
    for (int j = 0; j < b.size(); ++j) {
      const auto jj = static_cast<size_t>(j);
      if (b.options.soft) continue;
      const double vj = v[b.index[jj] + offset];
      if (b.has_lower[jj] && vj - b.lower[j] <= tol) ++c;
      if (b.has_upper[jj] && b.upper[j] - vj <= tol) ++c;
    }
    return c;
  };
  const auto& space = problem.stateSpace();
  const int off = space.nx() - space.ndx();
  auto d = problem.createNodeData();
  const VectorXd u0 = VectorXd::Zero(problem.nu());
  for (int k = 0; k <= problem.horizon(); ++k) {
    const auto kk = static_cast<size_t>(k);
    const bool term = k == problem.horizon();
    if (!term) n.input_bounds += count(problem.inputBounds(), us[kk], 0);
    if (k >= 1) n.state_bounds += count(problem.stateBounds(), xs[kk], off);
    problem.evaluate(k, xs[kk], term ? u0 : us[kk], *d);
    for (int i = 0; i < d->ni; ++i)
      if (!d->soft[i] && d->g[i] <= tol) ++n.inequalities;
  }
  return n;
}

std::vector<VectorXd> rollout(const ocp::OptimalControlProblem& problem, const VectorXd& x0,
                              const std::vector<VectorXd>& us) {
  auto d = problem.createNodeData();
  std::vector<VectorXd> xs(static_cast<size_t>(problem.horizon() + 1), x0);
  for (int k = 0; k < problem.horizon(); ++k) {
    problem.evaluate(k, xs[static_cast<size_t>(k)], us[static_cast<size_t>(k)], *d);
    xs[static_cast<size_t>(k + 1)] = d->xnext;
  }
  return xs;
}

double totalCost(const ocp::OptimalControlProblem& problem, const std::vector<VectorXd>& xs,
                 const std::vector<VectorXd>& us) {
  auto d = problem.createNodeData();
  double c = 0.0;
  const VectorXd u0 = VectorXd::Zero(problem.nu());
  for (int k = 0; k <= problem.horizon(); ++k) {
    const auto kk = static_cast<size_t>(k);
    problem.evaluate(k, xs[kk], k < problem.horizon() ? us[kk] : u0, *d);
    c += d->cost;
  }
  return c;
}

namespace {
double boundViolation(const ocp::BoundSet& b, ConstVecRef v, int offset) {
  double m = 0.0;
  for (int j = 0; j < b.size(); ++j) {
    if (b.options.soft) continue;
    const double vj = v[b.index[static_cast<size_t>(j)] + offset];
    if (b.has_lower[static_cast<size_t>(j)]) m = std::max(m, b.lower[j] - vj);
    if (b.has_upper[static_cast<size_t>(j)]) m = std::max(m, vj - b.upper[j]);
  }
  return m;
}
}  // namespace

double maxViolation(const ocp::OptimalControlProblem& problem, const VectorXd& x_init,
                    const std::vector<VectorXd>& xs, const std::vector<VectorXd>& us) {
  const auto& space = problem.stateSpace();
  auto d = problem.createNodeData();
  VectorXd diff(space.ndx());
  space.difference(x_init, xs[0], diff);
  double m = diff.lpNorm<Eigen::Infinity>();
  const VectorXd u0 = VectorXd::Zero(problem.nu());
  const int off = space.nx() - space.ndx();
  for (int k = 0; k <= problem.horizon(); ++k) {
    const auto kk = static_cast<size_t>(k);
    const bool term = k == problem.horizon();
    problem.evaluate(k, xs[kk], term ? u0 : us[kk], *d);
    if (!term) {
      space.difference(d->xnext, xs[kk + 1], diff);
      m = std::max(m, diff.lpNorm<Eigen::Infinity>());
      if (d->ne > 0) m = std::max(m, d->e.head(d->ne).lpNorm<Eigen::Infinity>());
      m = std::max(m, boundViolation(problem.inputBounds(), us[kk], 0));
    }
    for (int i = 0; i < d->ni; ++i)
      if (!d->soft[i]) m = std::max(m, -d->g[i]);
    m = std::max(m, boundViolation(problem.stateBounds(), xs[kk], off));
    if (!std::isfinite(m)) return m;
  }
  return m;
}

void finiteDifference(const ocp::StateSpace& space, ConstVecRef x, ConstVecRef u,
                      const std::function<void(ConstVecRef, ConstVecRef, VecRef)>& v, int rows,
                      MatRef Jx, MatRef Ju, double h) {
  const int ndx = space.ndx(), nu = static_cast<int>(u.size());
  VectorXd xp(space.nx()), xm(space.nx()), dx(ndx), vp(rows), vm(rows);
  for (int i = 0; i < ndx; ++i) {
    dx.setZero();
    dx[i] = h;
    space.integrate(x, dx, xp);
    dx[i] = -h;
    space.integrate(x, dx, xm);
    v(xp, u, vp);
    v(xm, u, vm);
    Jx.col(i) = (vp - vm) / (2.0 * h);
  }
  VectorXd up = u, um = u;
  for (int i = 0; i < nu; ++i) {
    up = u;
    um = u;
    up[i] += h;
    um[i] -= h;
    v(x, up, vp);
    v(x, um, vm);
    Ju.col(i) = (vp - vm) / (2.0 * h);
  }
}

double KktReport::max() const {
  return std::max(std::max(stationarity, primal), std::max(complementarity, dual_sign));
}

KktReport kktResidual(const ocp::OptimalControlProblem& problem, const VectorXd& x_init,
                      const std::vector<VectorXd>& xs, const std::vector<VectorXd>& us,
                      const KktInputs& in) {
  // Unknowns: costates lambda_k (k < N, multiplier of c_k = x_{k+1} (-) F(x_k, u_k)),
  // plus (when not given) equality multipliers, inequality duals, and the duals of
  // active simple bounds. Equations: stationarity w.r.t. x_1..x_N and u_0..u_{N-1}.
  const auto& space = problem.stateSpace();
  const int N = problem.horizon(), ndx = problem.ndx(), nu = problem.nu();
  const int off = space.nx() - ndx;
  const int n_eq_rows = N * ndx + N * nu;
  auto xrow = [&](int j) { return (j - 1) * ndx; };  // j >= 1
  auto urow = [&](int k) { return N * ndx + k * nu; };

  std::vector<std::unique_ptr<ocp::NodeData>> nd;
  for (int k = 0; k <= N; ++k) nd.push_back(problem.createNodeData());
  const VectorXd uzero = VectorXd::Zero(nu);
  for (int k = 0; k <= N; ++k) {
    const auto kk = static_cast<size_t>(k);
    problem.linearize(k, xs[kk], k < N ? us[kk] : uzero, *nd[kk]);
  }

  KktReport rep;
  rep.primal = maxViolation(problem, x_init, xs, us);

  VectorXd rhs = VectorXd::Zero(n_eq_rows);
  std::vector<VectorXd> cols;   // extra unknown columns (dense, n_eq_rows)
  std::vector<int> col_sign;    // 0 free, +1 must be >= 0
  std::vector<double> col_gap;  // |g| or bound gap of the fitted dual (complementarity)
  MatrixXd Alam = MatrixXd::Zero(n_eq_rows, N * ndx);
  MatrixXd J0(ndx, ndx), J1(ndx, ndx);

  for (int k = 0; k <= N; ++k) {
    const auto& d = *nd[static_cast<size_t>(k)];
    const bool term = k == N;
    // cost gradient
    if (k >= 1) rhs.segment(xrow(k), ndx) -= d.lx;
    if (!term) rhs.segment(urow(k), nu) -= d.lu;
    // defect c_k = difference(F_k, x_{k+1})
    if (!term) {
      space.differenceJacobians(d.xnext, xs[static_cast<size_t>(k + 1)], J0, J1);
      if (k >= 1) Alam.block(xrow(k), k * ndx, ndx, ndx) = (J0 * d.Fx).transpose();
      Alam.block(urow(k), k * ndx, nu, ndx) = (J0 * d.Fu).transpose();
      Alam.block(xrow(k + 1), k * ndx, ndx, ndx) = J1.transpose();
    }
    // equalities (+ sign * nu^T e)
    if (d.ne > 0) {
      if (in.equality_multipliers) {
        const VectorXd nu_k = in.equality_multipliers(k) * in.equality_sign;
        if (nu_k.size() != d.ne) throw std::invalid_argument("kktResidual: multiplier size");
        if (k >= 1) rhs.segment(xrow(k), ndx) -= d.Ex.topRows(d.ne).transpose() * nu_k;
        rhs.segment(urow(k), nu) -= d.Eu.topRows(d.ne).transpose() * nu_k;
      } else {
        for (int i = 0; i < d.ne; ++i) {
          VectorXd col = VectorXd::Zero(n_eq_rows);
          if (k >= 1) col.segment(xrow(k), ndx) = d.Ex.row(i).transpose();
          col.segment(urow(k), nu) = d.Eu.row(i).transpose();
          cols.push_back(col);
          col_sign.push_back(0);
          col_gap.push_back(0.0);
        }
      }
    }
    // general inequalities (- z^T g)
    if (d.ni > 0) {
      if (in.inequality_duals) {
        const VectorXd z = in.inequality_duals(k);
        if (z.size() != d.ni) throw std::invalid_argument("kktResidual: dual size");
        for (int i = 0; i < d.ni; ++i) {
          rep.dual_sign = std::max(rep.dual_sign, -z[i]);
          if (!d.soft[i])
            rep.complementarity = std::max(rep.complementarity, std::abs(z[i] * d.g[i]));
        }
        if (k >= 1) rhs.segment(xrow(k), ndx) += d.Gx.topRows(d.ni).transpose() * z;
        if (!term) rhs.segment(urow(k), nu) += d.Gu.topRows(d.ni).transpose() * z;
      } else {
        for (int i = 0; i < d.ni; ++i) {
          if (d.g[i] > in.active_tolerance) continue;  // inactive: z = 0
          VectorXd col = VectorXd::Zero(n_eq_rows);
          if (k >= 1) col.segment(xrow(k), ndx) = -d.Gx.row(i).transpose();
          if (!term) col.segment(urow(k), nu) = -d.Gu.row(i).transpose();
          cols.push_back(col);
          col_sign.push_back(1);
          col_gap.push_back(std::abs(d.g[i]));
        }
      }
    }
    // simple bounds (active ones, fitted)
    auto addBounds = [&](const ocp::BoundSet& b, ConstVecRef v, int voff, int row0,
                         const std::function<VectorXd(int)>& duals) {
      if (duals) {
        const VectorXd z = duals(k);
        if (z.size() != 2 * b.size()) throw std::invalid_argument("kktResidual: bound duals size");
        for (int j = 0; j < b.size(); ++j) {
          const auto jj = static_cast<size_t>(j);
          const int idx = b.index[jj];
          const double vj = v[idx + voff];
          const double zl = z[j], zu = z[b.size() + j];
          rep.dual_sign = std::max(rep.dual_sign, std::max(-zl, -zu));
          if (b.has_lower[jj]) {
            rep.complementarity = std::max(rep.complementarity, std::abs(zl * (vj - b.lower[j])));
          } else {
            rep.dual_sign = std::max(rep.dual_sign, std::abs(zl));
          }
          if (b.has_upper[jj]) {
            rep.complementarity = std::max(rep.complementarity, std::abs(zu * (b.upper[j] - vj)));
          } else {
            rep.dual_sign = std::max(rep.dual_sign, std::abs(zu));
          }
          rhs[row0 + idx] -= -zl + zu;
        }
        return;
      }
      for (int j = 0; j < b.size(); ++j) {
        const auto jj = static_cast<size_t>(j);
        const int idx = b.index[jj];
        const double vj = v[idx + voff];
        if (b.has_lower[jj] && vj - b.lower[j] <= in.active_tolerance) {
          VectorXd col = VectorXd::Zero(n_eq_rows);
          col[row0 + idx] = -1.0;
          cols.push_back(col);
          col_sign.push_back(1);
          col_gap.push_back(std::abs(vj - b.lower[j]));
        }
        if (b.has_upper[jj] && b.upper[j] - vj <= in.active_tolerance) {
          VectorXd col = VectorXd::Zero(n_eq_rows);
          col[row0 + idx] = 1.0;
          cols.push_back(col);
          col_sign.push_back(1);
          col_gap.push_back(std::abs(b.upper[j] - vj));
        }
      }
    };
    if (!term)
      addBounds(problem.inputBounds(), us[static_cast<size_t>(k)], 0, urow(k),
                in.input_bound_duals);
    if (k >= 1)
      addBounds(problem.stateBounds(), xs[static_cast<size_t>(k)], off, xrow(k),
                in.state_bound_duals);
  }

  const int nlam = N * ndx, nextra = static_cast<int>(cols.size());
  MatrixXd A(n_eq_rows, nlam + nextra);
  A.leftCols(nlam) = Alam;
  for (int i = 0; i < nextra; ++i) A.col(nlam + i) = cols[static_cast<size_t>(i)];
  const VectorXd y = A.colPivHouseholderQr().solve(rhs);
  rep.stationarity = (A * y - rhs).lpNorm<Eigen::Infinity>();
  for (int i = 0; i < nextra; ++i)
    if (col_sign[static_cast<size_t>(i)] > 0) rep.dual_sign = std::max(rep.dual_sign, -y[nlam + i]);
  for (int i = 0; i < nextra; ++i)
    rep.complementarity =
        std::max(rep.complementarity, std::abs(y[nlam + i] * col_gap[static_cast<size_t>(i)]));
  if (!std::isfinite(rep.stationarity)) rep.stationarity = std::numeric_limits<double>::infinity();
  return rep;
}

}  // namespace rollstep::nltest
