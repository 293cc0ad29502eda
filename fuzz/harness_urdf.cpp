// Fuzz harness: URDF text -> Model (rollstep::model::buildModelFromUrdfString).
// Fine: a Model, or a ModelError (the loader's documented error). Anything else fails: a
// crash, a sanitizer report, another exception type, a hang, and a loaded model whose
// kinematics at the neutral configuration are not finite (the loader let a bad number in).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "rollstep/model/all.hpp"

namespace {

[[noreturn]] void failure(const char* what) {
  std::fprintf(stderr, "harness_urdf: %s\n", what);
  std::abort();
}

void exercise(const rollstep::model::Model& m) {
  using namespace rollstep::model;
  if (m.nq != m.nqBase + m.nj || m.nv != m.nvBase + m.nj || m.nbodies() != m.nj + 1 ||
      !(m.totalMass > 0.0) || !std::isfinite(m.totalMass)) {
    failure("inconsistent model sizes or mass");
  }
  for (const Body& b : m.bodies) {
    if (!b.com.allFinite() || !b.inertia.allFinite() || !b.jointRotation.allFinite() ||
        !b.jointTranslation.allFinite() || !b.axis.allFinite()) {
      failure("a body holds a non-finite number");
    }
  }
  Data d(m);
  const Eigen::VectorXd q = neutralConfiguration(m);
  forwardKinematics(m, d, q);
  updateFramePlacements(m, d);
  for (int f = 0; f < m.nframes(); ++f) {
    if (!d.opf[static_cast<std::size_t>(f)].allFinite()) failure("non-finite frame placement");
  }
  if (!centerOfMass(m, d, q).allFinite()) failure("non-finite centre of mass");
  if (!computeGeneralizedGravity(m, d, q).allFinite()) failure("non-finite gravity");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string xml(reinterpret_cast<const char*>(data), size);
  for (const auto root :
       {rollstep::model::RootJoint::FreeFlyer, rollstep::model::RootJoint::Fixed}) {
    try {
      exercise(rollstep::model::buildModelFromUrdfString(xml, root));
    } catch (const rollstep::model::ModelError&) {
      // documented: the input is refused with a message
    }
  }
  return 0;
}
