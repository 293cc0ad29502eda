// The C++ API's results for the Python tests to compare bit for bit (hexadecimal floats).
//   rollstep_python_reference model URDF        reads "q h h ..." and "v h h ..." lines on
//                                                stdin; prints the model functions' results
//   rollstep_python_reference ocp ROBOT_YAML OCP_YAML SCENE GAIT VX
//                                                builds and solves the OCP as `rollstep plan`
//   rollstep_python_reference error KIND PATH    prints the message of the exception the
//                                                loader of KIND (urdf, ocp_settings, scene,
//                                                robot) throws on PATH
// Output: one line per array, "name rows cols h h ...", column-major.
#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "rollstep/centroidal/centroidal_ocp.hpp"
#include "rollstep/model/all.hpp"
#include "rollstep/sim/scene.hpp"
#include "rollstep/sim/scene_terrain.hpp"
#include "rollstep/solver/solver.hpp"

namespace {

using namespace rollstep;

void print(const char* name, const Eigen::MatrixXd& m) {
  std::printf("%s %ld %ld", name, static_cast<long>(m.rows()), static_cast<long>(m.cols()));
  for (Eigen::Index c = 0; c < m.cols(); ++c) {
    for (Eigen::Index r = 0; r < m.rows(); ++r) std::printf(" %a", m(r, c));
  }
  std::printf("\n");
}

Eigen::VectorXd readVector(const std::string& line) {
  std::istringstream in(line);
  std::string tag, word;
  in >> tag;
  std::vector<double> values;
  while (in >> word) values.push_back(std::strtod(word.c_str(), nullptr));
  return Eigen::Map<Eigen::VectorXd>(values.data(), static_cast<Eigen::Index>(values.size()));
}

int runModel(const std::string& urdf) {
  const model::Model mo = model::buildModelFromUrdfFile(urdf);
  model::Data d(mo);
  std::string line_q, line_v;
  std::getline(std::cin, line_q);
  std::getline(std::cin, line_v);
  const Eigen::VectorXd q = readVector(line_q), v = readVector(line_v);
  const int foot = mo.getFrameId("LF_wheel");
  model::forwardKinematics(mo, d, q, v);
  model::updateFramePlacements(mo, d);
  const lie::SE3 T = model::getFramePlacement(mo, d, foot);
  print("placement_R", T.rotation.toRotationMatrix());
  print("placement_p", T.translation);
  print("velocity_local", model::getFrameVelocity(mo, d, foot, model::ReferenceFrame::LOCAL));
  model::computeJointJacobians(mo, d, q);
  Eigen::MatrixXd J(6, mo.nv);
  model::getFrameJacobian(mo, d, foot, model::ReferenceFrame::LOCAL_WORLD_ALIGNED, J);
  print("jacobian_lwa", J);
  print("com", model::centerOfMass(mo, d, q));
  print("Jcom", model::jacobianCenterOfMass(mo, d, q));
  print("hg", model::computeCentroidalMomentum(mo, d, q, v));
  model::computeCentroidalMomentumDerivatives(mo, d, q, v);
  print("dhg_dq", d.dhg_dq);
  print("Ag", d.Ag);
  print("g", model::computeGeneralizedGravity(mo, d, q));
  print("dg_dq", model::computeGeneralizedGravityDerivatives(mo, d, q));
  Eigen::VectorXd qi(mo.nq);
  model::integrate(mo, q, v, qi);
  print("integrate", qi);
  return 0;
}

int runOcp(const std::string& robot_file, const std::string& settings_file,
           const std::string& scene_name, const std::string& gait, double vx) {
  const centroidal::RobotOcpDescription robot = centroidal::loadRobotOcpDescription(robot_file);
  const centroidal::OcpSettings settings = centroidal::loadOcpSettings(settings_file);
  const sim::SceneConfig scene = sim::loadScene(scene_name);
  centroidal::CentroidalOcp ocp(
      robot, settings,
      sim::terrainFromScene(scene, centroidal::footholdRegionMargin(robot, settings)),
      centroidal::gaitKindFromString(gait));
  ocp.reset(0.0, lie::SE3::Identity(), planning::BaseVelocityCommand{vx, 0.0, 0.0});
  solver::Solver solver(ocp.problem(), settings.solver);
  std::vector<Eigen::VectorXd> xs, us;
  ocp.initialGuess(xs, us);
  solver.setInitialGuess(xs, us);
  const Eigen::VectorXd x0 = ocp.standingState(0.0, 0.0, 0.0);
  solver.solve(x0);
  std::printf("status %s\n", solver::toString(solver.status()));
  Eigen::MatrixXd X(static_cast<Eigen::Index>(xs.size()),
                    robot.nominal_joint_positions.size() + 13);
  for (std::size_t k = 0; k < solver.states().size(); ++k) {
    X.row(static_cast<Eigen::Index>(k)) = solver.states()[k].transpose();
  }
  Eigen::MatrixXd U(static_cast<Eigen::Index>(us.size()), us.front().size());
  for (std::size_t k = 0; k < solver.inputs().size(); ++k) {
    U.row(static_cast<Eigen::Index>(k)) = solver.inputs()[k].transpose();
  }
  print("states", X);
  print("inputs", U);
  Eigen::VectorXd cost(1);
  cost[0] = solver.cost();
  print("cost", cost);
  return 0;
}

int printError(const std::string& kind, const std::string& path) {
  try {
    if (kind == "urdf") model::buildModelFromUrdfFile(path);
    if (kind == "ocp_settings") centroidal::loadOcpSettings(path);
    if (kind == "scene") sim::loadSceneConfig(path);
    if (kind == "robot") centroidal::loadRobotOcpDescription(path);
  } catch (const std::exception& e) {
    std::printf("%s", e.what());
    return 0;
  }
  return 3;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string mode = argc > 1 ? argv[1] : "";
    if (mode == "model" && argc == 3) return runModel(argv[2]);
    if (mode == "error" && argc == 4) return printError(argv[2], argv[3]);
    if (mode == "ocp" && argc == 7) {
      return runOcp(argv[2], argv[3], argv[4], argv[5], std::strtod(argv[6], nullptr));
    }
    std::fprintf(stderr, "usage: see the file comment of python/tests/reference.cpp\n");
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
