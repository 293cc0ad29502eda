// The second robot, wheelquad (robots/wheelquad): a wheeled quadruped with three revolute
// joints per leg and four drive wheels. Its description loads and the model matches the
// geometry of wheelquad.md (mass, centre of mass, nominal stance, computed here by hand from
// the documented bodies); the full-centroidal OCP stands, trots at 0.3 m/s, rolls at 1 m/s
// and turns on the spot, converging from a cold start with every constraint group held and
// physical contact forces.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>

#include "centroidal/plan_fixture.hpp"
#include "rollstep/model/center_of_mass.hpp"

namespace rollstep::centroidal {
namespace {

constexpr double kGravity = 9.81;
constexpr double kMass = 51.6;  // wheelquad.md: base 28 kg + 4 x (1.6 + 2.2 + 0.6 + 1.5)
constexpr double kFlexion = 0.8, kKnee = -1.6;  // nominal posture [rad]
constexpr double kWheelRadius = 0.085;

RobotOcpDescription wheelquadDescription() {
  return loadRobotOcpDescription(std::string(ROLLSTEP_ROBOTS_DIR) + "/wheelquad/centroidal.yaml");
}

planning::TerrainModel flatTerrain() {
  return planning::terrainFromBoxes({-20.0, 20.0, -5.0, 5.0, 0.0}, 0.0, {});
}

/// The centre of mass at the nominal posture from wheelquad.md's bodies (base frame): per
/// leg the hip (1.6 kg, 0.07 m outward of the abduction axis), the thigh (knee motor 1 kg
/// on the flexion axis, tube 1.2 kg at its middle, 0.3 m long), the shank (0.6 kg at its
/// middle, 0.3 m) and the wheel (1.5 kg at the shank's end); the base (28 kg) at the origin.
/// The thigh points along (-sin a, 0, -cos a), a the flexion; the shank along the
/// flexion + knee angle. Front and hind legs, left and right, cancel in x and y but for the
/// legs' own offsets behind their hips.
Eigen::Vector3d documentedCentreOfMass() {
  const double a = kFlexion, b = kFlexion + kKnee;
  const Eigen::Vector3d thigh(-std::sin(a), 0.0, -std::cos(a)),
      shank(-std::sin(b), 0.0, -std::cos(b));
  const Eigen::Vector3d moment_per_leg =  // about the leg's flexion joint
      1.2 * 0.15 * thigh + 0.6 * (0.3 * thigh + 0.15 * shank) + 1.5 * (0.3 * thigh + 0.3 * shank);
  return 4.0 * moment_per_leg / kMass;
}

/// One solved plan of wheelquad (test::PlanRun is Tachyon 3's).
struct WheelquadPlan {
  OcpSettings settings;
  std::unique_ptr<CentroidalOcp> ocp;
  std::unique_ptr<solver::Solver> solver;

  WheelquadPlan(planning::GaitKind gait, const planning::BaseVelocityCommand& command,
                const OcpSettings& custom = OcpSettings{})
      : settings(custom) {
    ocp = std::make_unique<CentroidalOcp>(wheelquadDescription(), settings, flatTerrain(), gait);
    ocp->reset(0.0, lie::SE3::Identity(), command);
    solver = std::make_unique<solver::Solver>(ocp->problem(), settings.solver);
    test::solveAndCheck(*ocp, *solver, ocp->standingState(0.0, 0.0, 0.0));
  }
  const Eigen::VectorXd& x(int k) const { return solver->states()[static_cast<std::size_t>(k)]; }
  const Eigen::VectorXd& u(int k) const { return solver->inputs()[static_cast<std::size_t>(k)]; }
  int N() const { return ocp->problem()->horizon(); }
  int nc() const { return ocp->robot().nc(); }
  int mode(int k) const { return ocp->problem()->context(k).mode; }
  Eigen::Vector3d force(int k, int foot) const {
    return u(k).segment<3>(ocp->robot().inputForceIndex(foot));
  }
  double yaw(int k) const {
    const Eigen::Quaterniond q(x(k)[6], x(k)[3], x(k)[4], x(k)[5]);
    const Eigen::Vector3d forward = q * Eigen::Vector3d::UnitX();
    return std::atan2(forward.y(), forward.x());
  }
};

/// Forces a ground can give: stance normal forces >= 0 and none above the weight of the
/// robot times `peak`, tangential forces inside the friction cone; swing feet carry none;
/// the base stays within `height_band` of its nominal height and upright.
void expectPhysical(const WheelquadPlan& p, double peak, double height_band) {
  const double weight = p.ocp->robot().mass() * kGravity;
  const double mu = p.settings.friction_coefficient;
  const double height = p.ocp->loadedRobot().stance.height;
  for (int k = 0; k < p.N(); ++k) {
    for (int i = 0; i < p.nc(); ++i) {
      const Eigen::Vector3d f = p.force(k, i);
      if (CentroidalRobot::inStance(p.mode(k), i)) {
        EXPECT_GE(f.z(), -1e-6) << "node " << k << " foot " << i;
        EXPECT_LE(f.z(), peak * weight) << "node " << k << " foot " << i;
        EXPECT_LE(f.head<2>().norm(), std::sqrt(2.0) * mu * f.z() + 1e-6)  // the pyramid's corner
            << "node " << k << " foot " << i;
      } else {
        EXPECT_LT(f.norm(), 1e-6) << "swing foot carries a force, node " << k << " foot " << i;
      }
    }
    EXPECT_NEAR(p.x(k)[2], height, height_band) << "base height, node " << k;
    const Eigen::Quaterniond q(p.x(k)[6], p.x(k)[3], p.x(k)[4], p.x(k)[5]);
    EXPECT_GT((q * Eigen::Vector3d::UnitZ()).z(), std::cos(0.1)) << "base tilts, node " << k;
  }
}

TEST(Wheelquad, ModelMatchesTheDocumentedGeometry) {
  const LoadedRobot loaded = loadRobot(wheelquadDescription());
  const CentroidalRobot& robot = *loaded.robot;
  EXPECT_EQ(robot.nj(), 12);
  EXPECT_EQ(robot.nc(), 4);
  EXPECT_NEAR(robot.mass(), kMass, 1e-9);
  for (int i = 0; i < robot.nc(); ++i) EXPECT_TRUE(robot.contact(i).drive_wheel) << i;
  EXPECT_TRUE(robot.sidePairs().empty());
  // Joint order: the URDF tree depth-first, children by joint name (LF LH RF RH).
  const std::vector<std::string>& names = robot.model().jointNames;
  ASSERT_EQ(names.size(), 12u);
  EXPECT_EQ(names[0], "LF_HAA");
  EXPECT_EQ(names[2], "LF_KFE");
  EXPECT_EQ(names[3], "LH_HAA");
  EXPECT_EQ(names[11], "RH_KFE");

  // Centre of mass at the nominal posture, from the model and from the documented bodies.
  const model::Model& m = robot.model();
  model::Data data(m);
  Eigen::VectorXd q(m.nq);
  q << Eigen::Vector3d::Zero(), 0.0, 0.0, 0.0, 1.0, loaded.description.nominal_joint_positions;
  const Eigen::Vector3d com = model::centerOfMass(m, data, q);
  EXPECT_LT((com - documentedCentreOfMass()).norm(), 1e-9) << com.transpose();

  // Nominal stance: wheels under the flexion axes at (+-0.30, +-0.20), the base
  // 0.6 cos(0.8) + the wheel radius above the ground.
  ASSERT_EQ(loaded.stance.feet.size(), 4u);
  const double xs[] = {0.3, 0.3, -0.3, -0.3}, ys[] = {0.2, -0.2, 0.2, -0.2};  // LF RF LH RH
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(loaded.stance.feet[static_cast<std::size_t>(i)].x(), xs[i], 1e-9) << i;
    EXPECT_NEAR(loaded.stance.feet[static_cast<std::size_t>(i)].y(), ys[i], 1e-9) << i;
  }
  EXPECT_NEAR(loaded.stance.height, 0.6 * std::cos(kFlexion) + kWheelRadius, 1e-9);
}

TEST(Wheelquad, StandsInStaticEquilibrium) {
  const WheelquadPlan p(planning::GaitKind::Standing, {0.0, 0.0, 0.0});
  expectPhysical(p, 0.5, 0.01);
  // Where the cold start's transient has settled (the middle of the horizon): the normal
  // forces carry the weight and have no moment about the centre of mass (which the legs
  // shift a few millimetres from the nominal posture's), left and right alike, the hind
  // wheels more than the front ones (the centre of mass lies behind the middle).
  const double weight = kMass * kGravity;
  const model::Model& m = p.ocp->robot().model();
  model::Data data(m);
  for (int k = p.N() / 4; k < 3 * p.N() / 4; ++k) {
    const Eigen::Vector3d com = model::centerOfMass(m, data, p.x(k).head(m.nq));
    const Eigen::Matrix3Xd feet = p.ocp->footPositions(p.x(k));
    Eigen::Vector3d total = Eigen::Vector3d::Zero(), moment = Eigen::Vector3d::Zero();
    for (int i = 0; i < p.nc(); ++i) {
      const Eigen::Vector3d contact = feet.col(i) - kWheelRadius * Eigen::Vector3d::UnitZ();
      total += p.force(k, i);
      moment += (contact - com).cross(p.force(k, i));
    }
    EXPECT_NEAR(total.z(), weight, 0.005 * weight) << "node " << k;
    EXPECT_LT(total.head<2>().norm(), 0.005 * weight) << "node " << k;
    EXPECT_LT(moment.norm(), 0.5) << "[N m] node " << k << ": " << moment.transpose();
    EXPECT_NEAR(p.force(k, 0).z(), p.force(k, 1).z(), 1e-6 * weight) << "front, node " << k;
    EXPECT_NEAR(p.force(k, 2).z(), p.force(k, 3).z(), 1e-6 * weight) << "hind, node " << k;
    EXPECT_GT(p.force(k, 2).z(), p.force(k, 0).z()) << "node " << k;
  }
  EXPECT_LT((p.x(p.N()).head<3>() - p.x(0).head<3>()).norm(), 2e-3);
}

TEST(Wheelquad, TrotsForwardOnTheDiagonals) {
  const WheelquadPlan p(planning::GaitKind::Trot, {0.3, 0.0, 0.0});
  expectPhysical(p, 0.75, 0.03);
  // The gait lifts the diagonals in turn (LF with RH, RF with LH) and each swing carries
  // the body's weight on the other pair.
  int diagonal_swings = 0;
  for (int k = 0; k < p.N(); ++k) {
    const int mode = p.mode(k);
    const bool lf = CentroidalRobot::inStance(mode, 0), rf = CentroidalRobot::inStance(mode, 1),
               lh = CentroidalRobot::inStance(mode, 2), rh = CentroidalRobot::inStance(mode, 3);
    EXPECT_EQ(lf, rh) << "node " << k;
    EXPECT_EQ(rf, lh) << "node " << k;
    if (!lf || !rf) ++diagonal_swings;
  }
  EXPECT_GT(diagonal_swings, p.N() / 4);
  // It advances at about the command (from rest).
  const double travelled = p.x(p.N())[0] - p.x(0)[0];
  EXPECT_GT(travelled, 0.8 * 0.3 * p.N() * p.settings.dt);
  EXPECT_LT(travelled, 1.1 * 0.3 * p.N() * p.settings.dt);
  EXPECT_LT(std::abs(p.x(p.N())[1]), 0.02);
}

TEST(Wheelquad, RollsAtOneMetrePerSecondOnFourWheels) {
  const WheelquadPlan p(planning::GaitKind::Rolling, {1.0, 0.0, 0.0});
  expectPhysical(p, 0.6, 0.02);
  // Every wheel on the ground rolls forward with the base, none sideways or up.
  Eigen::VectorXd mean_vx = Eigen::VectorXd::Zero(p.nc());
  for (int k = 0; k < p.N(); ++k) {
    EXPECT_EQ(p.mode(k), 0b1111) << "node " << k;
    const Eigen::Matrix3Xd v = p.ocp->footVelocities(p.x(k), p.u(k));
    mean_vx += v.row(0).transpose() / p.N();
    for (int i = 0; i < p.nc(); ++i) {
      EXPECT_NEAR(v(2, i), 0.0, 1e-3) << "node " << k << " foot " << i;
      EXPECT_NEAR(v(1, i), 0.0, 1e-3) << "node " << k << " foot " << i;
    }
  }
  for (int i = 0; i < p.nc(); ++i) EXPECT_NEAR(mean_vx[i], 1.0, 0.05) << "foot " << i;
}

TEST(Wheelquad, TurnsOnTheSpotSkidSteering) {
  // Four drive wheels with the body's heading can only turn on the spot by sliding sideways
  // (config/behaviours/turn_in_place.yaml): their lateral velocity becomes a cost.
  OcpSettings s;
  s.lateral_slip_weight = 10.0;
  const WheelquadPlan p(planning::GaitKind::Rolling, {0.0, 0.0, 0.3}, s);
  expectPhysical(p, 0.5, 0.01);
  const double T = p.N() * p.settings.dt;
  EXPECT_NEAR(p.yaw(p.N()), 0.3 * T, 0.1 * 0.3 * T);
  EXPECT_LT(p.x(p.N()).head<2>().norm(), 0.01);  // on the spot
}

}  // namespace
}  // namespace rollstep::centroidal
