// Uses the installed package: loads a URDF with the model layer and checks a Lie-group
// round trip. Exit code 0 on success.
#include <cstdio>
#include <rollstep/lie/so3.hpp>
#include <rollstep/model/model.hpp>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: consumer URDF\n");
    return 2;
  }
  const Eigen::Vector3d w(0.1, -0.2, 0.3);
  const double err = (rollstep::lie::logSO3(rollstep::lie::expSO3(w)) - w).norm();
  const rollstep::model::Model model = rollstep::model::buildModelFromUrdfFile(argv[1]);
  std::printf("consumer: log(exp(w)) error %.1e, model nq %d nv %d\n", err, model.nq, model.nv);
  return (err < 1e-12 && model.nv > 6) ? 0 : 1;
}
