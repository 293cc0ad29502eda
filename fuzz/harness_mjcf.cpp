// Fuzz harness: robot MJCF text -> the scene composition and Plant (rollstep::sim::Plant
// with PlantOptions::robot_xml): MuJoCo parses the robot file inside the scene MJCF that
// includes it, then the plant checks the robot's structure and the start position.
// Fine: a plant that loads and steps (or reports a diverging step as SimError), or a
// SimError naming the robot file (the documented error; the start check names it as
// "the robot '<file>'"). Anything else fails: a crash, a
// sanitizer report in our code, another exception type, a hang, or MuJoCo aborting the
// process (its error handler exits: the plant must refuse such models first).
// MuJoCo itself is not instrumented (Debian's shared library).
#include <mujoco/mujoco.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "rollstep/centroidal/ocp_settings.hpp"
#include "rollstep/sim/plant.hpp"

namespace {
[[noreturn]] void failure(const std::string& what) {
  std::fprintf(stderr, "harness_mjcf: %s\n", what.c_str());
  std::abort();
}
void mujocoError(const char* message) { failure(std::string("MuJoCo error: ") + message); }
void quiet(const char*) {}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace rollstep::sim;
  // MuJoCo's default handlers print and exit(1), and append to MUJOCO_LOG.TXT.
  mju_user_error = mujocoError;
  mju_user_warning = quiet;
  const std::string robot_file = "/nonexistent-fuzz-dir/robot.xml";
  // The default robot's legs (its description read once): the input is its MJCF.
  static const rollstep::centroidal::RobotOcpDescription description =
      rollstep::centroidal::loadRobotOcpDescription(defaultRobotDescriptionFile());
  PlantOptions options;
  options.robot_file = robot_file;
  options.contact_frames = description.contact_frames;
  options.drive_wheels = description.drive_wheels;
  options.robot_xml.assign(reinterpret_cast<const char*>(data), size);
  SceneConfig scene = loadScene("step20");
  try {
    Plant plant(scene, options);
    try {
      for (int k = 0; k < 5; ++k) plant.step();
    } catch (const SimError& e) {
      if (std::string(e.what()).find("diverged") == std::string::npos) throw;
    }
  } catch (const SimError& e) {
    const std::string message = e.what();
    if (message.find("'" + robot_file + "'") == std::string::npos) {
      failure("error message does not name the robot file: " + message);
    }
  }
  return 0;
}
