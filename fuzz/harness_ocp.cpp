// Fuzz harness: YAML text -> OcpSettings, RobotOcpDescription and ControlSettings
// (rollstep::centroidal::parseOcpSettings / parseRobotOcpDescription,
// rollstep::control::parseControlSettings, which nests the OCP's and the solver's).
// Fine: settings that survive a toYaml round trip exactly and a description whose names
// are contacts (trot groups sharing no foot and holding all, a walk order listing each
// once), or a std::runtime_error whose message starts with the documented prefix
// naming the source. Anything else fails: a crash, a sanitizer report, an escaped parser
// error (YamlError names no file), another exception type, a hang.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include "rollstep/centroidal/ocp_settings.hpp"
#include "rollstep/control/control_settings.hpp"

namespace {
[[noreturn]] void failure(const std::string& what) {
  std::fprintf(stderr, "harness_ocp: %s\n", what.c_str());
  std::abort();
}

bool isContact(const rollstep::centroidal::RobotOcpDescription& d, const std::string& name) {
  for (const std::string& c : d.contact_frames) {
    if (c == name) return true;
  }
  return false;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace rollstep::centroidal;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const OcpSettings s = parseOcpSettings(text, "fuzz.yaml");
    const std::string yaml = toYaml(s);
    if (toYaml(parseOcpSettings(yaml, "round-trip")) != yaml) failure("round trip differs");
  } catch (const std::runtime_error& e) {
    if (std::string(e.what()).rfind("OCP settings fuzz.yaml: ", 0) != 0 &&
        std::string(e.what()).rfind("solver settings fuzz.yaml", 0) != 0) {
      failure(std::string("error message does not name the source: ") + e.what());
    }
  }
  try {
    const RobotOcpDescription d = parseRobotOcpDescription(text, "fuzz.yaml");
    for (const auto* names : {&d.drive_wheels, &d.walk_order, &d.trot_group_a, &d.trot_group_b}) {
      for (const std::string& n : *names) {
        if (!isContact(d, n)) failure("accepted a name that is not a contact: " + n);
      }
    }
    if (d.contact_frames.empty() || d.nominal_joint_positions.size() == 0) {
      failure("accepted a description without contacts or posture");
    }
    // Trot groups share no foot and hold all of them; a walk order lists every foot.
    const auto count = [](const std::vector<std::string>& names, const std::string& n) {
      int k = 0;
      for (const std::string& x : names) k += x == n ? 1 : 0;
      return k;
    };
    for (const std::string& c : d.contact_frames) {
      if (!d.trot_group_a.empty() && count(d.trot_group_a, c) + count(d.trot_group_b, c) != 1) {
        failure("accepted trot groups that do not hold " + c + " exactly once");
      }
      if (!d.walk_order.empty() && count(d.walk_order, c) != 1) {
        failure("accepted a walk order that does not list " + c + " once");
      }
    }
  } catch (const std::runtime_error& e) {
    if (std::string(e.what()).rfind("robot description fuzz.yaml: ", 0) != 0) {
      failure(std::string("error message does not name the source: ") + e.what());
    }
  }
  try {
    const rollstep::control::ControlSettings s =
        rollstep::control::parseControlSettings(text, "fuzz.yaml");
    const std::string yaml = rollstep::control::toYaml(s);
    if (rollstep::control::toYaml(rollstep::control::parseControlSettings(yaml, "round-trip")) !=
        yaml) {
      failure("control settings round trip differs");
    }
  } catch (const std::runtime_error& e) {
    if (std::string(e.what()).rfind("control settings fuzz.yaml: ", 0) != 0 &&
        std::string(e.what()).rfind("solver settings fuzz.yaml", 0) != 0) {
      failure(std::string("control settings error does not name the source: ") + e.what());
    }
  }
  return 0;
}
