#pragma once
// YAML configuration text as a small immutable tree, parsed by libyaml.
//
// Why not yaml-cpp: yaml-cpp 0.7 (Debian 12) loops forever, allocating memory, on some
// malformed text that libyaml refuses or reads correctly ("!w ,", ",a: 1", "!w ---\n!w ,";
// found by fuzz/harness_settings), and every pattern check in front of it was one pattern
// short. libyaml is the reference C parser (fuzzed upstream, linear time, bounded
// memory); this tree is built from its event stream, so nothing else parses the text.
//
// What a loader gets: null, scalar, sequence and mapping nodes with their 1-based line
// and column, whether a scalar was plain or quoted (a quoted "null" or "1" is text), and
// mapping entries in file order, repeated keys included (the loader refuses them, naming
// both lines). Aliases (*a) share the anchored node: nothing is copied, so "billion
// laughs" text costs no memory. Flow collections nested deeper than kMaxYamlDepth levels
// are refused before parsing (libyaml is quadratic in the depth), any collections nested
// deeper than 2 kMaxYamlDepth while building.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace rollstep::yaml {

constexpr int kMaxYamlDepth = 64;

/// Malformed text: what() is "line L, column C: <libyaml's problem>" (or another precise
/// reason: several documents, nesting too deep).
class YamlError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class Kind { Null, Scalar, Sequence, Mapping };

class Document;

/// A handle on one node of a Document (valid while the Document lives). Cheap to copy.
class Node {
 public:
  Kind kind() const;
  bool isNull() const { return kind() == Kind::Null; }
  bool isScalar() const { return kind() == Kind::Scalar; }
  bool isSequence() const { return kind() == Kind::Sequence; }
  bool isMapping() const { return kind() == Kind::Mapping; }
  /// "null", "a value", "a list", "a mapping" (for messages).
  const char* kindName() const;

  /// The scalar's text (empty for other kinds).
  const std::string& scalar() const;
  /// True for a plain (unquoted, non-block) scalar: only plain text is a number, a
  /// boolean or null.
  bool plain() const;
  /// The node's explicit tag as libyaml resolved it ("!x", "tag:yaml.org,2002:str"), empty
  /// when there is none.
  const std::string& tag() const;
  int line() const;    ///< 1-based line of the node's first character
  int column() const;  ///< 1-based column

  /// Items of a sequence, entries of a mapping (0 for the other kinds).
  std::size_t size() const;
  Node item(std::size_t i) const;   ///< sequence item i
  Node key(std::size_t i) const;    ///< mapping entry i's key
  Node value(std::size_t i) const;  ///< mapping entry i's value

  /// Conversions of a plain scalar; false (and `out` unchanged) when the text is not one.
  /// Numbers: decimal integers and decimals with an optional exponent, YAML's .inf,
  /// -.inf, .nan (any case); no hexadecimal, octal or trailing text.
  bool toDouble(double& out) const;
  /// Decimal integers within int's range.
  bool toInt(int& out) const;
  /// true / false (also True, TRUE, False, FALSE).
  bool toBool(bool& out) const;

 private:
  friend class Document;
  Node(const Document* doc, std::uint32_t index) : doc_(doc), index_(index) {}
  const Document* doc_;
  std::uint32_t index_;
};

class Document {
 public:
  /// Parses one YAML document (an empty text or comments only: a null root). Throws
  /// YamlError for malformed text, for a second document ("holds more than one YAML
  /// document (the second starts on line L)"), for nesting too deep (see above).
  static Document parse(std::string_view text);

  Node root() const { return Node(this, 0); }

  // Not copyable (nodes point at it), movable.
  Document(const Document&) = delete;
  Document& operator=(const Document&) = delete;
  Document(Document&&) = default;
  Document& operator=(Document&&) = default;

 private:
  friend class Node;
  Document() = default;
  struct Record {
    Kind kind = Kind::Null;
    bool plain = false;
    int line = 0, column = 0;
    std::string text;                     // scalar
    std::string tag;                      // explicit tag, empty when none
    std::vector<std::uint32_t> children;  // sequence items; mapping key, value, key, ...
  };
  std::vector<Record> nodes_;
};

/// Document::parse for a loader: a YamlError comes back as std::runtime_error(prefix +
/// its message), so that every error names the loader's source.
Document parseDocument(std::string_view text, const std::string& prefix);

}  // namespace rollstep::yaml
