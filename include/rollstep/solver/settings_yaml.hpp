#pragma once
// SolverSettings from and to YAML. The keys are the field names of SolverSettings
// (solver.hpp documents each one and its default; config/solver.yaml lists them all).

#include <string>

#include "rollstep/common/settings_table.hpp"
#include "rollstep/common/yaml_tree.hpp"
#include "rollstep/solver/solver.hpp"

namespace rollstep::solver {

/// The table of SolverSettings' keys (common/settings_table.hpp): key, member, range of the
/// integers; the doubles are checked by checkSettings.
const settings::Table<SolverSettings>& solverSettingsTable();

/// Reads settings from YAML text: a mapping of field name to value, any subset; a missing
/// key keeps its default, an empty document gives the defaults. mode is "converging" or
/// "realtime". Unknown keys, values of the wrong type (2.5 for an integer, "yes please"
/// for a flag), integers outside a sanity range (max_iterations [1, 1e6],
/// max_line_search_steps [1, 1000], num_threads [1, 256], thread_spin_us [0, 1e6]) and
/// values that checkSettings rejects are errors: std::runtime_error
/// "solver settings <source_name>: line <L>: <key>: <problem>" naming the value given and
/// the valid range. So are a key given twice, a key that is not a plain name and a second
/// YAML document ('---').
SolverSettings parseSolverSettings(const std::string& yaml_text,
                                   const std::string& source_name = "<text>");

/// The same for a `solver:` mapping nested in another configuration file (`prefix` is its
/// key path, "solver." or "ocp.solver."; a null node keeps `s`): keys not given keep their
/// value in `s`; errors go through `reader` (the enclosing file's head and lines).
void readSolverSettings(const yaml::Node& node, SolverSettings& s, settings::Reader& reader,
                        const std::string& prefix);

/// parseSolverSettings on the contents of a file. A missing file, a directory, anything
/// that is not a regular file (a FIFO is refused, not waited on) and a file above 1 MiB are
/// errors too (rollstep::InputError, a std::runtime_error, from readTextFile).
SolverSettings loadSolverSettings(const std::string& yaml_file);

/// Every field, one "key: value" line each, in the order of the struct; doubles are
/// written so that parseSolverSettings reads them back exactly.
std::string toYaml(const SolverSettings& settings);

}  // namespace rollstep::solver
