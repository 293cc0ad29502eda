#pragma once
// A CSV log read back by column name (the `rollstep sim` log.csv and mpc.csv: a header of
// names with units in brackets, then one row per sample). The experiments' metrics and
// checks read only these files, so any controller's run can be reported.
#include <cstddef>
#include <string>
#include <vector>

namespace rollstep::experiments {

class LogTable {
 public:
  /// Reads `path` (a regular file; `what` names it in errors). Throws std::runtime_error
  /// "<what> '<path>': line L: <problem>" for an empty file, a row with another number of
  /// fields than the header or a repeated column name. Fields that are not numbers (a status
  /// word) read as NaN; their text is kept (text()).
  static LogTable read(const std::string& path, const std::string& what = "log");
  /// Same from text; `source` names it in errors.
  static LogTable parse(const std::string& text, const std::string& source);

  std::size_t rows() const { return rows_; }
  const std::vector<std::string>& names() const { return names_; }
  bool has(const std::string& name) const { return index(name) >= 0; }
  /// The values of column `name` (with its unit: "time[s]"). Throws std::runtime_error naming
  /// the source and the column if there is none.
  const std::vector<double>& column(const std::string& name) const;
  /// The text of column `name` (for word columns like a status).
  const std::vector<std::string>& text(const std::string& name) const;

 private:
  int index(const std::string& name) const;
  std::string source_;
  std::vector<std::string> names_;
  std::vector<std::vector<double>> values_;
  std::vector<std::vector<std::string>> texts_;
  std::size_t rows_ = 0;
};

}  // namespace rollstep::experiments
