#pragma once
// A command's outputs in its --out folder, replaced as a whole (README "Outputs"):
//   OutputFolder folder("report", dir, {"report.md", "report.html", "snapshots_*"});
//   folder.create();   // with the inputs: --out is a folder or nothing; nothing deleted
//   ... load and check every input ...
//   folder.begin();    // interrupts deferred; the previous outputs and FAILED removed
//   try { ... write each output atomically ... } catch (const std::exception& e) {
//     folder.fail(e.what()); throw; }
// fail() removes every output of the command (a name ending in '*' is a prefix) and writes
// FAILED with the reason, so that a failed, interrupted or part-written run leaves the folder
// holding only FAILED, never new files beside old ones.
#include <string>
#include <vector>

namespace rollstep::apps {

/// Removes the temporaries ".<name>.tmp.*" of the outputs (a name ending in '*' is a
/// prefix) that a killed run (SIGKILL: no cleanup is possible) left in `dir`.
void removeStaleTemporaries(const std::string& dir, const std::vector<std::string>& outputs);

class OutputFolder {
 public:
  OutputFolder(std::string command, std::string dir, std::vector<std::string> outputs);

  /// Refuses an --out that exists and is not a directory, creates it (OutputError).
  void create() const;
  /// Defers interrupts (rollstep/common/interrupt.hpp), throws Interrupted if one came
  /// already, removes the previous outputs and FAILED (OutputError naming a file that
  /// cannot be removed).
  void begin() const;
  /// Removes the outputs and writes DIR/FAILED "rollstep <command> failed: <reason>". Returns
  /// false (with a warning on stderr) if FAILED could not be written.
  bool fail(const std::string& reason) const noexcept;

  const std::string& dir() const { return dir_; }
  std::string failedPath() const { return dir_ + "/FAILED"; }

 private:
  void removeOutputs(bool throw_on_error) const;

  std::string command_, dir_;
  std::vector<std::string> outputs_;
};

}  // namespace rollstep::apps
