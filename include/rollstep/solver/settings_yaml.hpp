#pragma once
// SolverSettings from and to YAML. The keys are the field names of SolverSettings
// (solver.hpp documents each one and its default; config/solver.yaml lists them all).

#include <string>

#include "rollstep/solver/solver.hpp"

namespace rollstep::solver {

/// Reads settings from YAML text: a mapping of field name to value, any subset; a missing
/// key keeps its default, an empty document gives the defaults. mode is "converging" or
/// "realtime". Unknown keys, values of the wrong type (2.5 for an integer, "yes please"
/// for a flag) and values that checkSettings rejects are errors: std::runtime_error
/// naming source_name and the key. So is a key given twice.
SolverSettings parseSolverSettings(const std::string& yaml_text,
                                   const std::string& source_name = "<text>");

/// parseSolverSettings on the contents of a file (a missing file is an error too).
SolverSettings loadSolverSettings(const std::string& yaml_file);

/// Every field, one "key: value" line each, in the order of the struct; doubles are
/// written so that parseSolverSettings reads them back exactly.
std::string toYaml(const SolverSettings& settings);

}  // namespace rollstep::solver
