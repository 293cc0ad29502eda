#pragma once
// One table of fields per settings struct that reads, checks and writes its YAML.
//
// A field is a key, the struct member it reads and writes, a unit, a valid range and (for
// enums) the enum's names (enum_names.hpp). The documented default of every key is the
// member's value in a default-constructed struct: the struct's member initializers are the
// only place a default is written. A section is a nested mapping read by its own table, a
// list of sections (`sections`) a list of such mappings, item i's keys named "key[i].name";
// a custom field reads and writes a key by functions of its own (a section another layer
// owns, a number written as an expression). A field marked required() must be given.
//
//   const settings::Table<MpcSettings> kMpc = settings::Table<MpcSettings>()
//       .field("timing", &MpcSettings::timing)
//       .field("period", &MpcSettings::period, "s", settings::Range::closed(0, 10));
//
// Reading is strict: an unknown key, a key given twice, a value of the wrong type or
// outside its range is an error, thrown as std::runtime_error
//   "<head>line <L>: <full.key.path>: <problem>"
// where head names the file ("OCP settings config/ocp.yaml: "). A key that is absent
// keeps the value it had (the default, or the value of a file extended). Writing gives
// every field, "key: value" lines nested two spaces per section, numbers in the shortest
// text that reads back exactly: read(write(s)) == s.
//
// Cross-field checks (one value against another) stay beside each table, in the file that
// owns the settings; Reader::lineOf finds the line of the keys they name.
#include <Eigen/Core>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "rollstep/common/enum_names.hpp"
#include "rollstep/common/yaml_tree.hpp"

namespace rollstep::settings {

/// The valid values of a number: [lower, upper], each bound open or closed; `finite`
/// refuses NaN and the infinities. Range::unchecked() lets every number through (the
/// owner's own check then names the problem).
struct Range {
  double lower = -std::numeric_limits<double>::infinity();
  double upper = std::numeric_limits<double>::infinity();
  bool lower_open = false;
  bool upper_open = false;
  bool finite = true;

  static Range closed(double lo, double hi) { return {lo, hi, false, false, true}; }
  static Range leftOpen(double lo, double hi) { return {lo, hi, true, false, true}; }  ///< (lo, hi]
  static Range rightOpen(double lo, double hi) {
    return {lo, hi, false, true, true};
  }  ///< [lo, hi)
  static Range open(double lo, double hi) { return {lo, hi, true, true, true}; }
  static Range anyFinite() { return {}; }
  static Range unchecked() {
    Range r;
    r.finite = false;
    return r;
  }

  bool contains(double v) const;
  bool bounded() const { return std::isfinite(lower) || std::isfinite(upper); }
  /// "[0, 1)"; "" when unbounded.
  std::string text() const;
};

/// A value written as YAML: the shortest decimal text that reads back exactly; .inf,
/// -.inf, .nan for the others.
std::string numberYaml(double v);

/// The reading of one document: the error head, and the line and value text of every key
/// read (full path), for repeated keys and for the messages of cross-field checks.
class Reader {
 public:
  explicit Reader(std::string head) : head_(std::move(head)) {}

  const std::string& head() const { return head_; }
  /// Throws std::runtime_error(head + "line <L>: " + what), L the line of `at`.
  [[noreturn]] void fail(const yaml::Node& at, const std::string& what) const;
  [[noreturn]] void failAtLine(int line, const std::string& what) const;

  /// Records that key `path` was read at `key_node` with `value`; a key read before is an
  /// error ("<path>: given twice (first on line L)").
  void note(const std::string& path, const yaml::Node& key_node, const yaml::Node& value);

  struct Seen {
    int line;
    std::string text;  ///< the value's text as written (scalars), else its kind
  };
  /// The key read at `path`, none when the file did not give it.
  const Seen* seen(const std::string& path) const;
  /// The line of the first of `paths` the file gave, `fallback` when it gave none of them
  /// (an error about several keys points at the first one given).
  int lineOf(const std::vector<std::string>& paths, int fallback) const;

 private:
  std::string head_;
  std::map<std::string, Seen> seen_;
};

/// Whether a list of names may give a name twice.
enum class Repeats { Refused, Allowed };

/// A field's problem found by Table::check: its full key path and what is wrong.
struct Problem {
  std::string path;
  std::string what;
};

/// The text of a node for a message: 'text' for a scalar, else "a list", "a mapping", ...
std::string describe(const yaml::Node& node);

namespace detail {
// Readers of one value; each fails through `reader` naming `path`.
double readNumber(const yaml::Node& node, const Range& range, Reader& reader,
                  const std::string& path);
int readInt(const yaml::Node& value, const Range& range, Reader& reader, const std::string& path);
bool readBool(const yaml::Node& value, Reader& reader, const std::string& path);
/// A list of `size` numbers (any size when size < 0).
std::vector<double> readNumbers(const yaml::Node& value, int size, const Range& range,
                                Reader& reader, const std::string& path);
std::vector<std::string> readNames(const yaml::Node& value, Reader& reader, const std::string& path,
                                   Repeats repeats = Repeats::Refused);
/// One name: a scalar (any text).
std::string readName(const yaml::Node& value, Reader& reader, const std::string& path);
/// `lists` (any number when 0) lists of names, each of `names_per_list` (any when 0).
std::vector<std::vector<std::string>> readNameLists(const yaml::Node& value, std::size_t lists,
                                                    std::size_t names_per_list, Reader& reader,
                                                    const std::string& path);
/// Fails at `value` when `size` < `min_size` ("expected at least N <what>, got M").
void requireSize(std::size_t size, std::size_t min_size, const char* what, const yaml::Node& value,
                 Reader& reader, const std::string& path);
/// A name as plain text when it is only letters, digits and _ . / -, else double-quoted.
std::string nameYaml(const std::string& name);
std::string namesYaml(const std::vector<std::string>& names);
std::string numbersYaml(const double* values, std::size_t n);
std::optional<std::string> rangeProblem(double v, const Range& range);
/// Indents every line of `text` by `indent`.
std::string indented(const std::string& text, const std::string& indent);
}  // namespace detail

/// How a list of sections is read and written.
template <typename Sub>
struct ListOptions {
  /// Items read are appended to the list the struct holds (a file over a base adds to
  /// the base's list) instead of replacing it.
  bool append = false;
  /// An empty list is not written (instead of `key: []`).
  bool omit_when_empty = false;
  /// Called after each item is read: its cross-field checks. `path` is "key[i]".
  std::function<void(const yaml::Node& item, Sub& sub, Reader& reader, const std::string& path)>
      finish;
};

/// One key of a table.
template <typename S>
struct Field {
  std::string key;
  std::string unit;  ///< "m", "s", "rad/s", ... ("" for counts, flags and names)
  Range range;       ///< of each number (unused for flags, names, enums, sections)
  bool is_section = false;
  bool required = false;  ///< a mapping read must give it (Table::required)
  /// Reads `value` into `s`; `path` is the full key path.
  std::function<void(const yaml::Node& value, S& s, Reader& reader, const std::string& path)> read;
  /// Writes the value: " text" for a scalar, "\n" + nested lines for a section (indent is
  /// the entry's own).
  std::function<std::string(const S& s, const std::string& indent)> write;
  /// The first problem of the value in `s` (ranges, enum values), none when valid.
  std::function<std::optional<Problem>(const S& s, const std::string& path)> check;
  /// Sections and lists of sections: the text after "key:" in Table::documented.
  std::function<std::string(const std::string& indent)> document;
};

template <typename S>
class Table {
 public:
  /// A number (double) in `range` [unit].
  Table& field(const char* key, double S::*member, const char* unit = "",
               Range range = Range::anyFinite()) {
    Field<S> f = base(key, unit, range);
    f.read = [member, range](const yaml::Node& v, S& s, Reader& r, const std::string& path) {
      if (!v.isScalar()) r.fail(v, path + ": expected a single number, got " + v.kindName());
      s.*member = detail::readNumber(v, range, r, path);
    };
    f.write = [member](const S& s, const std::string&) { return " " + numberYaml(s.*member); };
    f.check = [member, range](const S& s, const std::string& path) -> std::optional<Problem> {
      if (auto p = detail::rangeProblem(s.*member, range)) return Problem{path, *p};
      return std::nullopt;
    };
    return add(std::move(f));
  }

  /// An integer in `range` (any int by default; a count: unit "" unless it has one).
  Table& field(const char* key, int S::*member, const char* unit = "",
               Range range = Range::anyFinite()) {
    Field<S> f = base(key, unit, range);
    f.read = [member, range](const yaml::Node& v, S& s, Reader& r, const std::string& path) {
      s.*member = detail::readInt(v, range, r, path);
    };
    f.write = [member](const S& s, const std::string&) { return " " + std::to_string(s.*member); };
    f.check = [member, range](const S& s, const std::string& path) -> std::optional<Problem> {
      if (auto p = detail::rangeProblem(s.*member, range)) return Problem{path, *p};
      return std::nullopt;
    };
    return add(std::move(f));
  }

  /// A flag: true or false.
  Table& field(const char* key, bool S::*member) {
    Field<S> f = base(key, "", Range{});
    f.read = [member](const yaml::Node& v, S& s, Reader& r, const std::string& path) {
      s.*member = detail::readBool(v, r, path);
    };
    f.write = [member](const S& s, const std::string&) {
      return std::string(s.*member ? " true" : " false");
    };
    f.check = [](const S&, const std::string&) { return std::optional<Problem>(); };
    return add(std::move(f));
  }

  /// An enum, by the names of enumNames(E) (enum_names.hpp).
  template <typename E, typename = std::enable_if_t<std::is_enum_v<E>>>
  Table& field(const char* key, E S::*member) {
    Field<S> f = base(key, "", Range{});
    f.read = [member](const yaml::Node& v, S& s, Reader& r, const std::string& path) {
      std::optional<E> e;
      if (v.isScalar() && v.plain()) e = enumFromName<E>(v.scalar());
      if (!e) {
        r.fail(v, path + ": expected " + enumChoices<E>() + ", got " + describe(v) +
                      (v.isScalar() && !v.plain() ? " (it is quoted or tagged)" : ""));
      }
      s.*member = *e;
    };
    f.write = [member](const S& s, const std::string&) {
      return " " + std::string(enumName(s.*member));
    };
    f.check = [member](const S& s, const std::string& path) -> std::optional<Problem> {
      if (!enumFromName<E>(enumName(s.*member))) return Problem{path, "not " + enumChoices<E>()};
      return std::nullopt;
    };
    return add(std::move(f));
  }

  /// A fixed-size vector of numbers, each in `range`: a list of exactly N numbers.
  template <int N>
  Table& field(const char* key, Eigen::Matrix<double, N, 1> S::*member, const char* unit = "",
               Range range = Range::anyFinite()) {
    static_assert(N > 0, "a vector of any size is the Eigen::VectorXd field");
    Field<S> f = base(key, unit, range);
    f.read = [member, range](const yaml::Node& v, S& s, Reader& r, const std::string& path) {
      const std::vector<double> x = detail::readNumbers(v, N, range, r, path);
      for (int i = 0; i < N; ++i) (s.*member)[i] = x[static_cast<std::size_t>(i)];
    };
    f.write = [member](const S& s, const std::string&) {
      return " " + detail::numbersYaml((s.*member).data(), N);
    };
    f.check = [member, range](const S& s, const std::string& path) -> std::optional<Problem> {
      for (int i = 0; i < N; ++i) {
        if (auto p = detail::rangeProblem((s.*member)[i], range)) {
          return Problem{path, "entry " + std::to_string(i) + ", " + *p};
        }
      }
      return std::nullopt;
    };
    return add(std::move(f));
  }

  /// A list of numbers of any length (at least `min_size`), each in `range`.
  Table& field(const char* key, std::vector<double> S::*member, const char* unit = "",
               Range range = Range::anyFinite(), std::size_t min_size = 0) {
    Field<S> f = base(key, unit, range);
    f.read = [member, range, min_size](const yaml::Node& v, S& s, Reader& r,
                                       const std::string& path) {
      std::vector<double> x = detail::readNumbers(v, -1, range, r, path);
      if (x.size() < min_size) {
        r.fail(v, path + ": expected at least " + std::to_string(min_size) + " numbers, got " +
                      std::to_string(x.size()));
      }
      s.*member = std::move(x);
    };
    f.write = [member](const S& s, const std::string&) {
      return " " + detail::numbersYaml((s.*member).data(), (s.*member).size());
    };
    f.check = [member, range](const S& s, const std::string& path) -> std::optional<Problem> {
      for (std::size_t i = 0; i < (s.*member).size(); ++i) {
        if (auto p = detail::rangeProblem((s.*member)[i], range)) {
          return Problem{path, "entry " + std::to_string(i) + ", " + *p};
        }
      }
      return std::nullopt;
    };
    return add(std::move(f));
  }

  /// A vector of numbers of any length (at least `min_size`), each in `range`.
  Table& field(const char* key, Eigen::VectorXd S::*member, const char* unit = "",
               Range range = Range::anyFinite(), std::size_t min_size = 0) {
    Field<S> f = base(key, unit, range);
    f.read = [member, range, min_size](const yaml::Node& v, S& s, Reader& r,
                                       const std::string& path) {
      const std::vector<double> x = detail::readNumbers(v, -1, range, r, path);
      detail::requireSize(x.size(), min_size, "numbers", v, r, path);
      (s.*member) =
          Eigen::Map<const Eigen::VectorXd>(x.data(), static_cast<Eigen::Index>(x.size()));
    };
    f.write = [member](const S& s, const std::string&) {
      return " " +
             detail::numbersYaml((s.*member).data(), static_cast<std::size_t>((s.*member).size()));
    };
    f.check = [member, range](const S& s, const std::string& path) -> std::optional<Problem> {
      for (Eigen::Index i = 0; i < (s.*member).size(); ++i) {
        if (auto p = detail::rangeProblem((s.*member)[i], range)) {
          return Problem{path, "entry " + std::to_string(i) + ", " + *p};
        }
      }
      return std::nullopt;
    };
    return add(std::move(f));
  }

  /// One name (text): a scalar, plain or quoted.
  Table& field(const char* key, std::string S::*member) {
    Field<S> f = base(key, "", Range{});
    f.read = [member](const yaml::Node& v, S& s, Reader& r, const std::string& path) {
      s.*member = detail::readName(v, r, path);
    };
    f.write = [member](const S& s, const std::string&) {
      return " " + detail::nameYaml(s.*member);
    };
    f.check = [](const S&, const std::string&) { return std::optional<Problem>(); };
    return add(std::move(f));
  }

  /// A list of lists of names ([[a, b], [c]]), none given twice within a list: exactly
  /// `lists` lists when lists > 0, each of exactly `names_per_list` names when that is > 0.
  Table& field(const char* key, std::vector<std::vector<std::string>> S::*member,
               std::size_t lists = 0, std::size_t names_per_list = 0) {
    Field<S> f = base(key, "", Range{});
    f.read = [member, lists, names_per_list](const yaml::Node& v, S& s, Reader& r,
                                             const std::string& path) {
      s.*member = detail::readNameLists(v, lists, names_per_list, r, path);
    };
    f.write = [member](const S& s, const std::string&) {
      std::string out = " [";
      for (std::size_t i = 0; i < (s.*member).size(); ++i) {
        out += (i ? ", " : "") + detail::namesYaml((s.*member)[i]);
      }
      return out + "]";
    };
    f.check = [](const S&, const std::string&) { return std::optional<Problem>(); };
    return add(std::move(f));
  }

  /// A list of names (text), none given twice unless `repeats` allows it (a command's
  /// words).
  Table& field(const char* key, std::vector<std::string> S::*member,
               Repeats repeats = Repeats::Refused) {
    Field<S> f = base(key, "", Range{});
    f.read = [member, repeats](const yaml::Node& v, S& s, Reader& r, const std::string& path) {
      s.*member = detail::readNames(v, r, path, repeats);
    };
    f.write = [member](const S& s, const std::string&) {
      return " " + detail::namesYaml(s.*member);
    };
    f.check = [](const S&, const std::string&) { return std::optional<Problem>(); };
    return add(std::move(f));
  }

  /// A nested mapping `key:` read and written by `table` (an empty value keeps it as is).
  template <typename Sub>
  Table& section(const char* key, Sub S::*member, Table<Sub> table) {
    Field<S> f = base(key, "", Range{});
    f.is_section = true;
    f.read = [member, table](const yaml::Node& v, S& s, Reader& r, const std::string& path) {
      table.read(v, s.*member, r, path + ".");
    };
    f.write = [member, table](const S& s, const std::string& indent) {
      return "\n" + table.write(s.*member, indent + "  ");
    };
    f.check = [member, table](const S& s, const std::string& path) {
      return table.check(s.*member, path + ".");
    };
    f.document = [table](const std::string& indent) {
      return "\n" + table.documented(indent + "  ");
    };
    return add(std::move(f));
  }

  /// A list of mappings `key: [{...}, {...}]`, each item read and written by `table` from
  /// a default-constructed Sub; item i's keys are named "key[i].name".
  template <typename Sub>
  Table& sections(const char* key, std::vector<Sub> S::*member, Table<Sub> table,
                  ListOptions<Sub> options = {}) {
    Field<S> f = base(key, "", Range{});
    f.read = [member, table, options](const yaml::Node& v, S& s, Reader& r,
                                      const std::string& path) {
      if (!v.isSequence()) r.fail(v, path + ": expected a list, got " + v.kindName());
      std::vector<Sub> items;
      for (std::size_t i = 0; i < v.size(); ++i) {
        const yaml::Node item = v.item(i);
        const std::string item_path = path + "[" + std::to_string(i) + "]";
        if (!item.isMapping()) {
          r.fail(item, item_path + ": expected a mapping, got " + item.kindName());
        }
        Sub sub{};
        table.read(item, sub, r, item_path + ".");
        if (options.finish) options.finish(item, sub, r, item_path);
        items.push_back(std::move(sub));
      }
      if (!options.append) (s.*member).clear();
      for (Sub& sub : items) (s.*member).push_back(std::move(sub));
    };
    f.write = [member, table, options](const S& s, const std::string& indent) -> std::string {
      const std::vector<Sub>& items = s.*member;
      if (items.empty()) return options.omit_when_empty ? "" : " []";
      std::string out = "\n";
      const std::string inner = indent + "    ";
      for (const Sub& item : items) {
        const std::string text = table.write(item, inner);
        if (text.empty()) {
          out += indent + "  - {}\n";
          continue;
        }
        out += indent + "  - " + text.substr(inner.size());  // "- " in front of the first key
      }
      return out;
    };
    f.check = [member, table](const S& s, const std::string& path) -> std::optional<Problem> {
      for (std::size_t i = 0; i < (s.*member).size(); ++i) {
        if (auto p = table.check((s.*member)[i], path + "[" + std::to_string(i) + "].")) return p;
      }
      return std::nullopt;
    };
    // The list's default, then each item's keys with their defaults, as comments.
    const auto write = f.write;
    f.document = [write, table](const std::string& indent) {
      const std::string value = write(S{}, indent);
      return (value.empty() ? std::string(" []") : value) + "  # a list of mappings, each:\n" +
             table.documented(indent + "  #   ");
    };
    return add(std::move(f));
  }

  /// Marks the field added last as required: a mapping this table reads must give it
  /// ("missing key '<full.key.path>'", on the mapping's line).
  Table& required() {
    if (fields_.empty()) throw std::logic_error("settings table: required() before a field");
    fields_.back().required = true;
    return *this;
  }

  /// A nested mapping `key:` of members of S itself, read and written by `table` (a file
  /// that groups the keys of a flat struct).
  Table& group(const char* key, Table<S> table) {
    Field<S> f = base(key, "", Range{});
    f.is_section = true;
    f.read = [table](const yaml::Node& v, S& s, Reader& r, const std::string& path) {
      table.read(v, s, r, path + ".");
    };
    f.write = [table](const S& s, const std::string& indent) {
      return "\n" + table.write(s, indent + "  ");
    };
    f.check = [table](const S& s, const std::string& path) { return table.check(s, path + "."); };
    f.document = [table](const std::string& indent) {
      return "\n" + table.documented(indent + "  ");
    };
    return add(std::move(f));
  }

  /// A key read and written by functions of its own: `read(value, s, reader, path)`
  /// (null values included when is_section), `write(s, indent)` as Field::write ("": the
  /// key is not written).
  Table& custom(const char* key, decltype(Field<S>::read) read, decltype(Field<S>::write) write,
                bool is_section = false) {
    Field<S> f = base(key, "", Range{});
    f.is_section = is_section;
    f.read = std::move(read);
    f.write = std::move(write);
    f.check = [](const S&, const std::string&) { return std::optional<Problem>(); };
    return add(std::move(f));
  }

  /// Documents the field added last by `document(indent)`: the text after "key:" in
  /// documented() (a custom key whose default is not a written value).
  Table& documentedAs(std::function<std::string(const std::string& indent)> document) {
    if (fields_.empty()) throw std::logic_error("settings table: documentedAs() before a field");
    fields_.back().document = std::move(document);
    return *this;
  }

  const std::vector<Field<S>>& fields() const { return fields_; }
  const Field<S>* find(const std::string& key) const {
    for (const Field<S>& f : fields_) {
      if (f.key == key) return &f;
    }
    return nullptr;
  }

  /// "a, b, c": the keys, for messages.
  std::string keys() const {
    std::string out;
    for (const Field<S>& f : fields_) out += (out.empty() ? "" : ", ") + f.key;
    return out;
  }

  /// Reads the mapping `node` into `s` (a null node: nothing). `prefix` is the path of the
  /// mapping ("" at the top level, "mpc." for a section).
  void read(const yaml::Node& node, S& s, Reader& reader, const std::string& prefix = "") const {
    if (!node.isNull()) {
      if (!node.isMapping()) {
        if (prefix.empty()) reader.fail(node, "expected a mapping of key: value");
        reader.fail(node, sectionName(prefix) + ": expected a mapping, got " + node.kindName());
      }
      for (std::size_t i = 0; i < node.size(); ++i) {
        readEntry(node.key(i), node.value(i), s, reader, prefix);
      }
    }
    for (const Field<S>& f : fields_) {
      if (f.required && reader.seen(prefix + f.key) == nullptr) {
        reader.fail(node, "missing key '" + prefix + f.key + "'");
      }
    }
  }

  /// Reads one entry `key_node: value` of a mapping this table reads (for an owner that
  /// handles some keys itself).
  void readEntry(const yaml::Node& key_node, const yaml::Node& value, S& s, Reader& reader,
                 const std::string& prefix = "") const {
    if (!key_node.isScalar()) {
      reader.fail(key_node, prefix + "<key>: a key is not a plain name (known" + knownIn(prefix) +
                                ": " + keys() + ")");
    }
    const std::string& key = key_node.scalar();
    const Field<S>* f = find(key);
    if (f == nullptr) {
      reader.fail(key_node, "unknown key '" + prefix + key + "' (known" + knownIn(prefix) + ": " +
                                keys() + ")");
    }
    const std::string path = prefix + key;
    reader.note(path, key_node, value);
    if (value.isNull() && !f->is_section) {
      reader.fail(value, path + ": no value");
    }
    f->read(value, s, reader, path);
  }

  /// Every field of `s`, one "key: value" line each (sections nested), `indent` in front.
  std::string write(const S& s, const std::string& indent = "") const {
    std::string out;
    for (const Field<S>& f : fields_) {
      const std::string value = f.write(s, indent);
      if (value.empty()) continue;  // a custom key that is only read
      out += indent + f.key + ":" + value;
      if (out.back() != '\n') out += '\n';
    }
    return out;
  }

  /// The first field of `s` outside its range (sections included), none when all valid.
  std::optional<Problem> check(const S& s, const std::string& prefix = "") const {
    for (const Field<S>& f : fields_) {
      if (auto p = f.check(s, prefix + f.key)) return p;
    }
    return std::nullopt;
  }

  /// The defaults, documented: one line per key, "key: default  # [unit] range" (sections
  /// nested), the values of a default-constructed S.
  std::string documented(const std::string& indent = "") const {
    const S defaults{};
    std::string out;
    for (const Field<S>& f : fields_) {
      if (f.document) {
        out += indent + f.key + ":" + f.document(indent);
        continue;
      }
      const std::string value = f.write(defaults, indent);
      if (value.empty()) continue;
      std::string line = indent + f.key + ":" + value;
      if (f.is_section) {
        out += line;
        if (out.back() != '\n') out += '\n';
        continue;
      }
      std::string note;
      if (!f.unit.empty()) note += "[" + f.unit + "]";
      if (f.range.bounded()) note += (note.empty() ? "" : " ") + f.range.text();
      out += line + (note.empty() ? "" : "  # " + note) + "\n";
    }
    return out;
  }

 private:
  static Field<S> base(const char* key, const char* unit, Range range) {
    Field<S> f;
    f.key = key;
    f.unit = unit;
    f.range = range;
    return f;
  }
  Table& add(Field<S> f) {
    if (find(f.key) != nullptr) throw std::logic_error("settings table: key '" + f.key + "' twice");
    fields_.push_back(std::move(f));
    return *this;
  }
  static std::string sectionName(const std::string& prefix) {
    return prefix.empty() ? prefix : prefix.substr(0, prefix.size() - 1);
  }
  static std::string knownIn(const std::string& prefix) {
    return prefix.empty() ? "" : " in " + sectionName(prefix);
  }

  std::vector<Field<S>> fields_;
};

/// Parses `text` as one YAML document and reads it with `table` over `base`; errors start
/// with `head` (YAML errors: head + "YAML error: ...").
template <typename S>
S readDocument(const std::string& text, const Table<S>& table, const std::string& head,
               const S& base = S{}) {
  const yaml::Document document = yaml::parseDocument(text, head + "YAML error: ");
  S s = base;
  Reader reader(head);
  table.read(document.root(), s, reader);
  return s;
}

}  // namespace rollstep::settings
