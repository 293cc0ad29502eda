#include "rollstep/common/settings_table.hpp"

#include <cctype>

#include "rollstep/common/number_text.hpp"

namespace rollstep::settings {

bool Range::contains(double v) const {
  if (!finite) return true;
  if (!std::isfinite(v)) return false;
  if (lower_open ? v <= lower : v < lower) return false;
  if (upper_open ? v >= upper : v > upper) return false;
  return true;
}

std::string Range::text() const {
  if (!bounded()) return "";
  return std::string(lower_open ? "(" : "[") + shortestNumberText(lower) + ", " +
         shortestNumberText(upper) + (upper_open ? ")" : "]");
}

std::string numberYaml(double v) {
  if (std::isnan(v)) return ".nan";
  if (std::isinf(v)) return v > 0 ? ".inf" : "-.inf";
  return shortestNumberText(v);
}

void Reader::fail(const yaml::Node& at, const std::string& what) const {
  failAtLine(at.line(), what);
}

void Reader::failAtLine(int line, const std::string& what) const {
  throw std::runtime_error(head_ + "line " + std::to_string(line) + ": " + what);
}

void Reader::note(const std::string& path, const yaml::Node& key_node, const yaml::Node& value) {
  if (const auto it = seen_.find(path); it != seen_.end()) {
    fail(key_node, path + ": given twice (first on line " + std::to_string(it->second.line) + ")");
  }
  seen_.emplace(path, Seen{key_node.line(), value.isScalar() ? value.scalar() : value.kindName()});
}

const Reader::Seen* Reader::seen(const std::string& path) const {
  const auto it = seen_.find(path);
  return it == seen_.end() ? nullptr : &it->second;
}

int Reader::lineOf(const std::vector<std::string>& paths, int fallback) const {
  for (const std::string& path : paths) {
    if (const Seen* s = seen(path)) return s->line;
  }
  return fallback;
}

std::string describe(const yaml::Node& node) {
  return node.isScalar() ? "'" + node.scalar() + "'" : std::string(node.kindName());
}

namespace detail {

std::optional<std::string> rangeProblem(double v, const Range& range) {
  if (range.contains(v)) return std::nullopt;
  if (!range.bounded()) return numberYaml(v) + " is not finite";
  return shortestNumberText(v) + " is outside " + range.text();
}

double readNumber(const yaml::Node& node, const Range& range, Reader& reader,
                  const std::string& path) {
  double v = 0.0;
  if (!node.isScalar() || !node.toDouble(v)) {
    reader.fail(node, path + ": " + describe(node) + " is not a number" +
                          (node.isScalar() && !node.plain() ? " (it is quoted or tagged)" : ""));
  }
  if (!range.contains(v)) {
    reader.fail(node, path + ": " + node.scalar() +
                          (range.bounded() ? " is outside " + range.text() : " is not finite"));
  }
  return v;
}

int readInt(const yaml::Node& value, const Range& range, Reader& reader, const std::string& path) {
  int v = 0;
  if (!value.isScalar() || !value.toInt(v)) {
    reader.fail(value, path + ": expected an integer, got " + describe(value));
  }
  if (!range.contains(v)) {
    reader.fail(value, path + ": " + std::to_string(v) + " is outside " + range.text());
  }
  return v;
}

bool readBool(const yaml::Node& value, Reader& reader, const std::string& path) {
  bool v = false;
  if (!value.isScalar() || !value.toBool(v)) {
    reader.fail(value, path + ": expected true or false, got " + describe(value));
  }
  return v;
}

std::vector<double> readNumbers(const yaml::Node& value, int size, const Range& range,
                                Reader& reader, const std::string& path) {
  const bool any_size = size < 0;
  if (!value.isSequence() || (!any_size && value.size() != static_cast<std::size_t>(size))) {
    const std::string wanted =
        any_size ? "a list of numbers" : "a list of " + std::to_string(size) + " numbers";
    reader.fail(value, path + ": expected " + wanted + ", got " +
                           (value.isSequence() ? "a list of " + std::to_string(value.size())
                                               : std::string(value.kindName())));
  }
  std::vector<double> out(value.size());
  for (std::size_t i = 0; i < value.size(); ++i) {
    out[i] = readNumber(value.item(i), range, reader, path);
  }
  return out;
}

std::vector<std::string> readNames(const yaml::Node& value, Reader& reader, const std::string& path,
                                   Repeats repeats) {
  if (!value.isSequence()) {
    reader.fail(value, path + ": expected a list of names, got " + value.kindName());
  }
  std::vector<std::string> out;
  for (std::size_t i = 0; i < value.size(); ++i) {
    const yaml::Node item = value.item(i);
    if (!item.isScalar()) reader.fail(item, path + ": expected a name, got " + item.kindName());
    for (const std::string& other : out) {
      if (repeats == Repeats::Refused && other == item.scalar()) {
        reader.fail(item, path + ": '" + other + "' given twice");
      }
    }
    out.push_back(item.scalar());
  }
  return out;
}

std::string readName(const yaml::Node& value, Reader& reader, const std::string& path) {
  if (!value.isScalar()) reader.fail(value, path + ": expected a name, got " + value.kindName());
  return value.scalar();
}

std::vector<std::vector<std::string>> readNameLists(const yaml::Node& value, std::size_t lists,
                                                    std::size_t names_per_list, Reader& reader,
                                                    const std::string& path) {
  const std::string wanted =
      (lists > 0 ? std::to_string(lists) + " lists" : std::string("a list of lists")) +
      " of names" + (names_per_list > 0 ? ", " + std::to_string(names_per_list) + " each" : "");
  if (!value.isSequence() || (lists > 0 && value.size() != lists)) {
    reader.fail(value, path + ": expected " + wanted + ", got " +
                           (value.isSequence() ? "a list of " + std::to_string(value.size())
                                               : std::string(value.kindName())));
  }
  std::vector<std::vector<std::string>> out;
  for (std::size_t i = 0; i < value.size(); ++i) {
    const yaml::Node item = value.item(i);
    const std::string item_path = path + "[" + std::to_string(i) + "]";
    std::vector<std::string> names = readNames(item, reader, item_path);
    if (names_per_list > 0 && names.size() != names_per_list) {
      reader.fail(item, item_path + ": expected " + std::to_string(names_per_list) +
                            " names, got " + std::to_string(names.size()));
    }
    out.push_back(std::move(names));
  }
  return out;
}

void requireSize(std::size_t size, std::size_t min_size, const char* what, const yaml::Node& value,
                 Reader& reader, const std::string& path) {
  if (size < min_size) {
    reader.fail(value, path + ": expected at least " + std::to_string(min_size) + " " + what +
                           ", got " + std::to_string(size));
  }
}

std::string nameYaml(const std::string& name) {
  bool plain = !name.empty();
  for (const char c : name) {
    plain = plain && (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' ||
                      c == '/' || c == '-');
  }
  if (plain && name[0] != '-' && name[0] != '.') return name;
  std::string out = "\"";
  for (const char c : name) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

std::string namesYaml(const std::vector<std::string>& names) {
  std::string out = "[";
  for (std::size_t i = 0; i < names.size(); ++i) out += (i ? ", " : "") + nameYaml(names[i]);
  return out + "]";
}

std::string numbersYaml(const double* values, std::size_t n) {
  std::string out = "[";
  for (std::size_t i = 0; i < n; ++i) out += (i ? ", " : "") + numberYaml(values[i]);
  return out + "]";
}

std::string indented(const std::string& text, const std::string& indent) {
  std::string out;
  for (std::size_t start = 0; start < text.size();) {
    const std::size_t end = text.find('\n', start);
    out += indent + text.substr(start, end - start) + "\n";
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return out;
}

}  // namespace detail

}  // namespace rollstep::settings
