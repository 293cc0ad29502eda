#pragma once
// Option validators and text helpers shared by the subcommands: every number option is
// decimal text, finite and in range, and a refusal names the text and the valid range.
#include <CLI/CLI.hpp>
#include <string>

#include "rollstep/common/number_text.hpp"
#include "rollstep/sim/robot_folder.hpp"

namespace rollstep::apps {

std::string numberText(double v);
/// Strict decimal number: [+-]digits[.digits][(e|E)[+-]digits]; nan/inf recognised only to
/// be refused (non_finite).
bool parseDecimal(const std::string& text, double& value, bool& non_finite);
/// A number option: decimal text, finite, in [min, max] (unit for messages).
CLI::Validator numberIn(double min, double max, const std::string& unit);
/// An integer option: digits only, in [min, max].
CLI::Validator integerIn(long min, long max);
/// A file or directory name option: not empty.
extern const CLI::Validator kNotEmpty;

/// The default robot's description: $ROLLSTEP_ROBOTS_DIR/tachyon3/centroidal.yaml if that
/// environment variable is set, else the source tree's robots/ folder.
std::string defaultRobotDescription();

/// Help of the --robot option of sim, plan, trials and report.
extern const char* const kRobotOptionHelp;
/// Refusal of the former --robot-description option.
extern const char* const kRobotDescriptionFolded;
/// The robot folder of a --robot value ("" = the default robot), its files checked against
/// each other (sim::requireConsistentRobotFolder). Throws CLI::ValidationError for a value
/// that is a file (the former --robot MJCF), InputError naming the folder and the problems.
sim::RobotFolder robotFolderOption(const std::string& value);
/// `name` in $ROLLSTEP_CONFIG_DIR if that environment variable is set (an installed
/// rollstep), else in the source tree's config/.
std::string configFile(const std::string& name);

/// The CBF-QP baseline's tuning: $ROLLSTEP_CONFIG_DIR/baseline.yaml if that environment
/// variable is set, else the source tree's config/baseline.yaml.
std::string defaultBaselineConfig();

/// The NMPC's default control settings file: none (empty: the library's defaults,
/// ControlSettings{}) on the scene's terrain; on terrain from perception
/// configFile("nmpc_perception.yaml"), what a terrain that changes with every scan adds.
std::string defaultNmpcConfig(bool perception);

/// The experiments of `rollstep report` and `rollstep trials`: configFile("experiments.yaml").
std::string defaultExperimentsFile();

}  // namespace rollstep::apps
