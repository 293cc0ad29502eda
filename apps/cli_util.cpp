// Helpers shared by the subcommands (cli_util.hpp).
#include "cli_util.hpp"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <system_error>

#include "rollstep/common/number_text.hpp"

namespace rollstep::apps {

std::string numberText(double v) { return shortestNumberText(v); }

/// Strict decimal number: [+-]digits[.digits][(e|E)[+-]digits] (also ".5", "5."); no
/// hexadecimal, no spaces, no trailing text. nan/inf are recognised only to be refused.
bool parseDecimal(const std::string& text, double& value, bool& non_finite) {
  non_finite = false;
  std::size_t i = 0;
  const std::size_t n = text.size();
  if (i < n && (text[i] == '+' || text[i] == '-')) ++i;
  std::string rest = text.substr(i);
  for (char& c : rest) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (rest == "nan" || rest == "inf" || rest == "infinity" || rest == ".nan" || rest == ".inf") {
    non_finite = true;
    return true;
  }
  std::size_t digits = 0;
  while (i < n && std::isdigit(static_cast<unsigned char>(text[i]))) ++i, ++digits;
  if (i < n && text[i] == '.') {
    ++i;
    while (i < n && std::isdigit(static_cast<unsigned char>(text[i]))) ++i, ++digits;
  }
  if (digits == 0) return false;
  if (i < n && (text[i] == 'e' || text[i] == 'E')) {
    ++i;
    if (i < n && (text[i] == '+' || text[i] == '-')) ++i;
    std::size_t exponent_digits = 0;
    while (i < n && std::isdigit(static_cast<unsigned char>(text[i]))) ++i, ++exponent_digits;
    if (exponent_digits == 0) return false;
  }
  if (i != n) return false;
  value = std::strtod(text.c_str(), nullptr);
  non_finite = !std::isfinite(value);  // 1e400 overflows
  return true;
}

/// A number option: decimal text, finite, in [min, max] (unit for messages).
CLI::Validator numberIn(double min, double max, const std::string& unit) {
  const std::string range = "valid range: " + numberText(min) + " to " + numberText(max) +
                            (unit.empty() ? "" : " " + unit);
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        double v = 0.0;
        bool non_finite = false;
        if (!parseDecimal(text, v, non_finite)) return "'" + text + "' is not a number; " + range;
        if (non_finite) return "'" + text + "' is not a finite number; " + range;
        if (v < min || v > max) return "'" + text + "' is out of range; " + range;
        return {};
      },
      "NUMBER in [" + numberText(min) + ", " + numberText(max) + "]" +
          (unit.empty() ? "" : " " + unit));
}

/// An integer option: digits only, in [min, max].
CLI::Validator integerIn(long min, long max) {
  const std::string range =
      "valid range: " + std::to_string(min) + " to " + std::to_string(max) + " (an integer)";
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        std::size_t i = (!text.empty() && (text[0] == '+' || text[0] == '-')) ? 1 : 0;
        if (i == text.size()) return "'" + text + "' is not an integer; " + range;
        for (std::size_t k = i; k < text.size(); ++k) {
          if (!std::isdigit(static_cast<unsigned char>(text[k]))) {
            return "'" + text + "' is not an integer; " + range;
          }
        }
        errno = 0;
        const long v = std::strtol(text.c_str(), nullptr, 10);
        if (errno == ERANGE || v < min || v > max) {
          return "'" + text + "' is out of range; " + range;
        }
        return {};
      },
      "INTEGER in [" + std::to_string(min) + ", " + std::to_string(max) + "]");
}

/// A file or directory name option: not empty.
const CLI::Validator kNotEmpty(
    [](std::string& text) -> std::string {
      return text.empty() ? std::string("an empty name; give a file or directory") : "";
    },
    "NAME");

std::string defaultRobotDescription() {
  if (const char* dir = std::getenv("ROLLSTEP_ROBOTS_DIR"); dir != nullptr && *dir != '\0') {
    return std::string(dir) + "/tachyon3/centroidal.yaml";
  }
  return std::string(ROLLSTEP_ROBOTS_DIR) + "/tachyon3/centroidal.yaml";
}

const char* const kRobotOptionHelp =
    "The robot: a name under robots/ (tachyon3; $ROLLSTEP_ROBOTS_DIR/NAME if set) or a robot "
    "folder path (centroidal.yaml, the URDF it names, <folder name>.xml; docs/ROBOTS.md). "
    "Its files are cross-checked before the run. Default: tachyon3";

const char* const kRobotDescriptionFolded =
    "was folded into --robot NAME_OR_DIR: a robot folder holds the description "
    "(centroidal.yaml) and the MJCF (docs/ROBOTS.md)";

sim::RobotFolder robotFolderOption(const std::string& value) {
  std::error_code ec;
  if (!value.empty() && std::filesystem::is_regular_file(value, ec)) {
    throw CLI::ValidationError(
        "--robot", "'" + value +
                       "' is a file; --robot takes a robot name (robots/NAME) or a robot folder "
                       "holding centroidal.yaml and the MJCF <folder name>.xml (docs/ROBOTS.md)");
  }
  const sim::RobotFolder folder =
      value.empty() ? sim::defaultRobotFolder() : sim::findRobotFolder(value);
  sim::requireConsistentRobotFolder(folder);
  return folder;
}

std::string configFile(const std::string& name) {
  if (const char* dir = std::getenv("ROLLSTEP_CONFIG_DIR"); dir != nullptr && *dir != '\0') {
    return std::string(dir) + "/" + name;
  }
  return std::string(ROLLSTEP_CONFIG_DIR) + "/" + name;
}

std::string defaultBaselineConfig() { return configFile("baseline.yaml"); }

std::string defaultNmpcConfig(bool perception) {
  return perception ? configFile("nmpc_perception.yaml") : std::string();
}

std::string defaultExperimentsFile() { return configFile("experiments.yaml"); }

}  // namespace rollstep::apps
