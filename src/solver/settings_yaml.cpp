#include "rollstep/solver/settings_yaml.hpp"

#include <cstdlib>
#include <stdexcept>

#include "rollstep/common/text_file.hpp"

namespace rollstep::solver {
namespace {

using settings::Range;

Range intRange(IntSettingRange r) { return Range::closed(r.min, r.max); }

// A new SolverSettings field goes here and into config/solver.yaml. The doubles' ranges
// are checkSettings' (solver.hpp), which names the values the file gave (below).
settings::Table<SolverSettings> makeTable() {
  using S = SolverSettings;
  const Range any = Range::unchecked();
  return settings::Table<S>()
      .field("mode", &S::mode)
      .field("max_iterations", &S::max_iterations, "", intRange(kIterationCountRange))
      .field("kkt_tolerance", &S::kkt_tolerance, "", any)
      .field("barrier_initial", &S::barrier_initial, "", any)
      .field("barrier_min", &S::barrier_min, "", any)
      .field("barrier_decrease", &S::barrier_decrease, "", any)
      .field("barrier_realtime", &S::barrier_realtime, "", any)
      .field("realtime_iterations", &S::realtime_iterations, "", intRange(kRealtimeIterationRange))
      .field("fraction_to_boundary", &S::fraction_to_boundary, "", any)
      .field("bound_push", &S::bound_push, "", any)
      .field("slack_reset", &S::slack_reset)
      .field("line_search", &S::line_search)
      .field("exact_hessian", &S::exact_hessian)
      .field("max_line_search_steps", &S::max_line_search_steps, "",
             intRange(kLineSearchStepsRange))
      .field("rank_tolerance", &S::rank_tolerance, "", any)
      .field("num_threads", &S::num_threads, "", intRange(kThreadCountRange))
      .field("thread_spin_us", &S::thread_spin_us, "us", intRange(kThreadSpinRange))
      .field("divergence_threshold", &S::divergence_threshold, "", any)
      .field("infeasibility_tolerance", &S::infeasibility_tolerance, "", any)
      .field("filter_reset_trigger", &S::filter_reset_trigger, "", intRange(kFilterResetRange))
      .field("max_filter_resets", &S::max_filter_resets, "", intRange(kFilterResetRange))
      .field("max_second_order_corrections", &S::max_second_order_corrections, "",
             intRange(kSecondOrderCorrectionRange))
      .field("acceptable_tolerance", &S::acceptable_tolerance, "", any)
      .field("acceptable_iterations", &S::acceptable_iterations, "", intRange(kIterationCountRange))
      .field("predictor_corrector", &S::predictor_corrector)
      .field("huge_pages", &S::huge_pages);
}

bool isKeyChar(char c) { return (c >= 'a' && c <= 'z') || c == '_'; }

}  // namespace

const settings::Table<SolverSettings>& solverSettingsTable() {
  static const settings::Table<SolverSettings> table = makeTable();
  return table;
}

void readSolverSettings(const yaml::Node& node, SolverSettings& s, settings::Reader& reader,
                        const std::string& prefix) {
  solverSettingsTable().read(node, s, reader, prefix);
  try {
    checkSettings(s);
  } catch (const std::invalid_argument& e) {
    // checkSettings names the keys and the valid range; add the values the file gave them,
    // and point at the first of them the file gave.
    const std::string message = e.what();
    std::string values;
    int line = node.line();
    bool line_found = false;
    for (const settings::Field<SolverSettings>& f : solverSettingsTable().fields()) {
      const std::string& key = f.key;
      for (std::size_t at = message.find(key); at != std::string::npos;
           at = message.find(key, at + 1)) {
        const std::size_t end = at + key.size();
        if ((at > 0 && isKeyChar(message[at - 1])) ||
            (end < message.size() && isKeyChar(message[end]))) {
          continue;  // part of a longer word
        }
        const settings::Reader::Seen* seen = reader.seen(prefix + key);
        if (seen != nullptr && !line_found) {
          line = seen->line;
          line_found = true;
        }
        values += (values.empty() ? " (" : ", ") + key + ": " +
                  (seen != nullptr ? "'" + seen->text + "' in the file" : "default");
        break;
      }
    }
    reader.failAtLine(line, (prefix.empty() ? "" : prefix.substr(0, prefix.size() - 1) + ": ") +
                                message + (values.empty() ? "" : values + ")"));
  }
}

SolverSettings parseSolverSettings(const std::string& yaml_text, const std::string& source_name) {
  const std::string head = "solver settings " + source_name + ": ";
  const yaml::Document document = yaml::parseDocument(yaml_text, head + "YAML error: ");
  SolverSettings settings;
  settings::Reader reader(head);
  readSolverSettings(document.root(), settings, reader, "");
  return settings;
}

SolverSettings loadSolverSettings(const std::string& yaml_file) {
  // Refuses a directory, a FIFO or device (which would block), a missing or huge file.
  const std::string text = readTextFile(yaml_file, "solver settings", std::size_t{1} << 20);
  return parseSolverSettings(text, yaml_file);
}

std::string toYaml(const SolverSettings& settings) { return solverSettingsTable().write(settings); }

}  // namespace rollstep::solver
