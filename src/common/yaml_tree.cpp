#include "rollstep/common/yaml_tree.hpp"

#include <yaml.h>

#include <cctype>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <memory>

namespace rollstep::yaml {

namespace {

bool isBlank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

/// Flow collections ('[', '{') nested deeper than kMaxYamlDepth, outside quoted scalars and
/// comments: libyaml takes time quadratic in the depth on them (100,000 '[': 30 s), so they
/// are refused before libyaml sees the text. Block nesting is bounded while building.
void refuseDeepFlow(std::string_view t) {
  int depth = 0;
  std::size_t line = 1;
  char quote = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const char c = t[i];
    if (c == '\n') {
      ++line;
      if (quote == 0) continue;
    }
    if (quote != 0) {
      if (c == quote) quote = 0;  // '' inside single quotes re-enters at once: harmless
      if (quote == '"' && c == '\\') ++i;
      continue;
    }
    if (c == '\'' || c == '"') {
      quote = c;
    } else if (c == '#' && (i == 0 || isBlank(t[i - 1]))) {
      while (i + 1 < t.size() && t[i + 1] != '\n') ++i;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxYamlDepth) {
        throw YamlError("line " + std::to_string(line) + ": flow collections nested deeper than " +
                        std::to_string(kMaxYamlDepth) + " levels");
      }
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
}

std::string at(const yaml_mark_t& mark) {
  return "line " + std::to_string(mark.line + 1) + ", column " + std::to_string(mark.column + 1);
}

/// A plain scalar YAML reads as null.
bool nullText(const std::string& s) {
  return s.empty() || s == "~" || s == "null" || s == "Null" || s == "NULL";
}

/// Owns a libyaml parser (deleted on every exit path) and an event.
struct Parser {
  yaml_parser_t parser;
  explicit Parser(std::string_view text) {
    if (yaml_parser_initialize(&parser) == 0) throw YamlError("cannot initialise libyaml");
    yaml_parser_set_input_string(&parser, reinterpret_cast<const unsigned char*>(text.data()),
                                 text.size());
  }
  ~Parser() { yaml_parser_delete(&parser); }
  Parser(const Parser&) = delete;
  Parser& operator=(const Parser&) = delete;
};
struct Event {
  yaml_event_t event{};
  bool valid = false;
  ~Event() {
    if (valid) yaml_event_delete(&event);
  }
};

}  // namespace

Document Document::parse(std::string_view text) {
  refuseDeepFlow(text);
  Document doc;
  Parser p(text);
  std::vector<std::uint32_t> open;  // containers being filled
  std::map<std::string, std::uint32_t> anchors;
  int documents = 0;
  bool root_set = false;
  doc.nodes_.emplace_back();  // the root: null until a node arrives
  doc.nodes_[0].line = 1;
  doc.nodes_[0].column = 1;

  // Attaches node `index` to the container being filled (or makes it the root).
  const auto attach = [&](std::uint32_t index) {
    if (open.empty()) {
      root_set = true;
      return;
    }
    doc.nodes_[open.back()].children.push_back(index);
  };
  // A new record for a node starting at `mark` (index 0 for the root).
  const auto record = [&](const yaml_mark_t& mark, Kind kind) -> std::uint32_t {
    std::uint32_t index = 0;
    if (!open.empty() || root_set) {
      index = static_cast<std::uint32_t>(doc.nodes_.size());
      doc.nodes_.emplace_back();
    }
    Record& r = doc.nodes_[index];
    r.kind = kind;
    r.line = static_cast<int>(mark.line) + 1;
    r.column = static_cast<int>(mark.column) + 1;
    return index;
  };
  const auto remember = [&](const yaml_char_t* anchor, std::uint32_t index) {
    if (anchor != nullptr) anchors[reinterpret_cast<const char*>(anchor)] = index;
  };

  for (bool done = false; !done;) {
    Event e;
    if (yaml_parser_parse(&p.parser, &e.event) == 0) {
      std::string message = at(p.parser.problem_mark) + ": " +
                            (p.parser.problem != nullptr ? p.parser.problem : "malformed YAML");
      if (p.parser.context != nullptr) message += std::string(" ") + p.parser.context;
      throw YamlError(message);
    }
    e.valid = true;
    const yaml_event_t& ev = e.event;
    switch (ev.type) {
      case YAML_STREAM_END_EVENT:
        done = true;
        break;
      case YAML_DOCUMENT_START_EVENT:
        if (++documents > 1) {
          throw YamlError("holds more than one YAML document (the second starts on line " +
                          std::to_string(ev.start_mark.line + 1) + ")");
        }
        break;
      case YAML_SCALAR_EVENT: {
        const std::string value(reinterpret_cast<const char*>(ev.data.scalar.value),
                                ev.data.scalar.length);
        const bool untagged = ev.data.scalar.tag == nullptr;
        const bool plain = ev.data.scalar.style == YAML_PLAIN_SCALAR_STYLE && untagged;
        const std::uint32_t index =
            record(ev.start_mark, plain && nullText(value) ? Kind::Null : Kind::Scalar);
        doc.nodes_[index].text = value;
        doc.nodes_[index].plain = plain;
        if (!untagged) doc.nodes_[index].tag = reinterpret_cast<const char*>(ev.data.scalar.tag);
        remember(ev.data.scalar.anchor, index);
        attach(index);
        break;
      }
      case YAML_ALIAS_EVENT: {
        const auto it = anchors.find(reinterpret_cast<const char*>(ev.data.alias.anchor));
        if (it == anchors.end()) {
          throw YamlError(at(ev.start_mark) + ": unknown alias *" +
                          reinterpret_cast<const char*>(ev.data.alias.anchor));
        }
        attach(it->second);
        break;
      }
      case YAML_SEQUENCE_START_EVENT:
      case YAML_MAPPING_START_EVENT: {
        const bool sequence = ev.type == YAML_SEQUENCE_START_EVENT;
        // Flow nesting is bounded by refuseDeepFlow; block nesting costs libyaml nothing
        // special, but no configuration needs more and the loaders recurse on the tree.
        if (static_cast<int>(open.size()) >= 2 * kMaxYamlDepth) {
          throw YamlError(at(ev.start_mark) + ": collections nested deeper than " +
                          std::to_string(2 * kMaxYamlDepth) + " levels");
        }
        const std::uint32_t index =
            record(ev.start_mark, sequence ? Kind::Sequence : Kind::Mapping);
        remember(sequence ? ev.data.sequence_start.anchor : ev.data.mapping_start.anchor, index);
        attach(index);
        open.push_back(index);
        break;
      }
      case YAML_SEQUENCE_END_EVENT:
      case YAML_MAPPING_END_EVENT:
        open.pop_back();
        break;
      default:  // stream start, document end: nothing to build
        break;
    }
  }
  return doc;
}

// --- Node ------------------------------------------------------------------------------

Kind Node::kind() const { return doc_->nodes_[index_].kind; }

const char* Node::kindName() const {
  switch (kind()) {
    case Kind::Null:
      return "null";
    case Kind::Scalar:
      return "a value";
    case Kind::Sequence:
      return "a list";
    case Kind::Mapping:
      return "a mapping";
  }
  return "?";
}

const std::string& Node::scalar() const { return doc_->nodes_[index_].text; }
bool Node::plain() const { return doc_->nodes_[index_].plain; }
const std::string& Node::tag() const { return doc_->nodes_[index_].tag; }
int Node::line() const { return doc_->nodes_[index_].line; }
int Node::column() const { return doc_->nodes_[index_].column; }

std::size_t Node::size() const {
  const auto& r = doc_->nodes_[index_];
  if (r.kind == Kind::Sequence) return r.children.size();
  if (r.kind == Kind::Mapping) return r.children.size() / 2;
  return 0;
}
Node Node::item(std::size_t i) const { return Node(doc_, doc_->nodes_[index_].children.at(i)); }
Node Node::key(std::size_t i) const { return Node(doc_, doc_->nodes_[index_].children.at(2 * i)); }
Node Node::value(std::size_t i) const {
  return Node(doc_, doc_->nodes_[index_].children.at(2 * i + 1));
}

bool Node::toDouble(double& out) const {
  if (!isScalar() || !plain()) return false;
  std::string s = scalar();
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  std::size_t i = 0;
  const bool negative = !s.empty() && s[0] == '-';
  if (!s.empty() && (s[0] == '+' || s[0] == '-')) i = 1;
  const std::string body = s.substr(i);
  if (body == ".inf") {
    out = negative ? -std::numeric_limits<double>::infinity()
                   : std::numeric_limits<double>::infinity();
    return true;
  }
  if (body == ".nan" && i == 0) {
    out = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  // [+-] digits [. digits] [e [+-] digits], or [+-] . digits [...]
  const auto digits = [&]() {
    const std::size_t start = i;
    while (i < s.size() && std::isdigit(static_cast<unsigned char>(s[i]))) ++i;
    return i - start;
  };
  std::size_t mantissa = digits();
  if (i < s.size() && s[i] == '.') {
    ++i;
    mantissa += digits();
  }
  if (mantissa == 0) return false;
  if (i < s.size() && s[i] == 'e') {
    ++i;
    if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
    if (digits() == 0) return false;
  }
  if (i != s.size()) return false;
  out = std::strtod(s.c_str(), nullptr);  // overflow gives +-inf: refused by the callers' checks
  return true;
}

bool Node::toInt(int& out) const {
  if (!isScalar() || !plain()) return false;
  const std::string& s = scalar();
  std::size_t i = (!s.empty() && (s[0] == '+' || s[0] == '-')) ? 1 : 0;
  if (i == s.size()) return false;
  for (std::size_t j = i; j < s.size(); ++j) {
    if (!std::isdigit(static_cast<unsigned char>(s[j]))) return false;
  }
  errno = 0;
  const long long v = std::strtoll(s.c_str(), nullptr, 10);
  if (errno == ERANGE || v < INT_MIN || v > INT_MAX) return false;
  out = static_cast<int>(v);
  return true;
}

bool Node::toBool(bool& out) const {
  if (!isScalar() || !plain()) return false;
  const std::string& s = scalar();
  if (s == "true" || s == "True" || s == "TRUE") {
    out = true;
    return true;
  }
  if (s == "false" || s == "False" || s == "FALSE") {
    out = false;
    return true;
  }
  return false;
}

Document parseDocument(std::string_view text, const std::string& prefix) {
  try {
    return Document::parse(text);
  } catch (const YamlError& e) {
    throw std::runtime_error(prefix + e.what());
  }
}

}  // namespace rollstep::yaml
