#pragma once
// SolverSettings from and to YAML. The keys are the field names of SolverSettings
// (solver.hpp documents each one and its default; config/solver.yaml lists them all).

#include <string>

#include "rollstep/common/yaml_tree.hpp"
#include "rollstep/solver/solver.hpp"

namespace rollstep::solver {

/// Reads settings from YAML text: a mapping of field name to value, any subset; a missing
/// key keeps its default, an empty document gives the defaults. mode is "converging" or
/// "realtime". Unknown keys, values of the wrong type (2.5 for an integer, "yes please"
/// for a flag), integers outside a sanity range (max_iterations [1, 1e6],
/// max_line_search_steps [1, 1000], num_threads [1, 256], thread_spin_us [0, 1e6]) and
/// values that checkSettings rejects are errors: std::runtime_error naming source_name, the
/// key, the value given and the valid range. So are a key given twice, a key that is not a
/// plain name and a second YAML document ('---').
SolverSettings parseSolverSettings(const std::string& yaml_text,
                                   const std::string& source_name = "<text>");

/// The same from a node of a parsed document (a `solver:` mapping nested in another
/// configuration file; a null node gives `defaults`): keys not given keep their value in
/// `defaults`. Errors name source_name.
SolverSettings parseSolverSettings(const yaml::Node& node, const std::string& source_name,
                                   const SolverSettings& defaults = SolverSettings{});

/// parseSolverSettings on the contents of a file. A missing file, a directory, anything
/// that is not a regular file (a FIFO is refused, not waited on) and a file above 1 MiB are
/// errors too (rollstep::InputError, a std::runtime_error, from readTextFile).
SolverSettings loadSolverSettings(const std::string& yaml_file);

/// Every field, one "key: value" line each, in the order of the struct; doubles are
/// written so that parseSolverSettings reads them back exactly.
std::string toYaml(const SolverSettings& settings);

}  // namespace rollstep::solver
