#include "log_table.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>

#include "rollstep/common/text_file.hpp"

namespace rollstep::experiments {

namespace {

std::vector<std::string> splitFields(const std::string& line) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    out.push_back(
        line.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

double toNumber(const std::string& text) {
  if (text.empty()) return std::numeric_limits<double>::quiet_NaN();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || errno == ERANGE) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  return v;
}

}  // namespace

LogTable LogTable::read(const std::string& path, const std::string& what) {
  return parse(readTextFile(path, what), what + " '" + path + "'");
}

LogTable LogTable::parse(const std::string& text, const std::string& source) {
  LogTable t;
  t.source_ = source;
  std::size_t pos = 0;
  int line_number = 0;
  bool header = true;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    std::vector<std::string> fields = splitFields(line);
    if (header) {
      for (std::size_t i = 0; i < fields.size(); ++i) {
        for (std::size_t k = 0; k < i; ++k) {
          if (fields[k] == fields[i]) {
            throw std::runtime_error(source + ": line 1: column '" + fields[i] + "' given twice");
          }
        }
      }
      t.names_ = std::move(fields);
      t.values_.resize(t.names_.size());
      t.texts_.resize(t.names_.size());
      header = false;
      continue;
    }
    if (fields.size() != t.names_.size()) {
      throw std::runtime_error(source + ": line " + std::to_string(line_number) + ": " +
                               std::to_string(fields.size()) + " fields, the header has " +
                               std::to_string(t.names_.size()));
    }
    for (std::size_t i = 0; i < fields.size(); ++i) {
      t.values_[i].push_back(toNumber(fields[i]));
      t.texts_[i].push_back(std::move(fields[i]));
    }
    ++t.rows_;
  }
  if (header) throw std::runtime_error(source + ": empty (no header line)");
  return t;
}

int LogTable::index(const std::string& name) const {
  for (std::size_t i = 0; i < names_.size(); ++i) {
    if (names_[i] == name) return static_cast<int>(i);
  }
  return -1;
}

const std::vector<double>& LogTable::column(const std::string& name) const {
  const int i = index(name);
  if (i < 0) throw std::runtime_error(source_ + ": no column '" + name + "'");
  return values_[static_cast<std::size_t>(i)];
}

const std::vector<std::string>& LogTable::text(const std::string& name) const {
  const int i = index(name);
  if (i < 0) throw std::runtime_error(source_ + ": no column '" + name + "'");
  return texts_[static_cast<std::size_t>(i)];
}

}  // namespace rollstep::experiments
