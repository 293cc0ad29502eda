#include "rollstep/common/yaml_text.hpp"

#include <yaml.h>

#include <cstddef>

namespace rollstep {

namespace {

bool isBlank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }
bool isFlowIndicator(char c) { return c == ',' || c == '[' || c == ']' || c == '{' || c == '}'; }

/// Is there a document marker ("---" or "...") at `i` (line start), followed by a blank or
/// the end of the text?
bool markerAt(std::string_view t, std::size_t i) {
  if (i + 3 > t.size()) return false;
  const std::string_view m = t.substr(i, 3);
  if (m != "---" && m != "...") return false;
  return i + 3 == t.size() || isBlank(t[i + 3]);
}

/// A document whose first token is ',' (yaml-cpp reads an anchor or tag up to a blank or a
/// flow indicator; libyaml differs, so it passes some of these).
std::string commaStartsDocument(std::string_view t) {
  const std::size_t n = t.size();
  std::size_t i = 0;
  std::size_t line = 1;
  // Scan the start of each document: blanks, comments, directives, document markers and
  // node properties (&anchor, !tag) until the first real token.
  bool at_document_start = true;
  bool line_start = true;
  while (i < n) {
    const char c = t[i];
    if (at_document_start) {
      if (c == '\n') {
        ++line;
        ++i;
        line_start = true;
        continue;
      }
      if (isBlank(c)) {
        ++i;
        continue;
      }
      if (c == '#' || (line_start && c == '%')) {  // comment or directive: skip the line
        while (i < n && t[i] != '\n') ++i;
        continue;
      }
      if (line_start && markerAt(t, i)) {
        i += 3;
        line_start = false;
        continue;
      }
      if (c == '&' || c == '!') {  // a property of the first node
        ++i;
        while (i < n && !isBlank(t[i]) && !isFlowIndicator(t[i])) ++i;
        line_start = false;
        continue;
      }
      if (c == ',') {
        return "line " + std::to_string(line) +
               ": a document starts with ',' (not valid YAML; yaml-cpp would loop forever)";
      }
      at_document_start = false;
    }
    // Inside a document: find the next line that starts with a document marker.
    while (i < n && t[i] != '\n') ++i;
    if (i < n) {
      ++i;
      ++line;
      if (markerAt(t, i)) at_document_start = true;
      line_start = true;
    }
  }
  return "";
}

/// Flow collections ('[', '{') nested deeper than kMaxFlowDepth, outside quoted scalars and
/// comments: libyaml takes time quadratic in the depth on them (100,000 '[': 30 s) and
/// yaml-cpp recurses once per level. No configuration nests more than a few levels.
constexpr int kMaxFlowDepth = 64;
std::string flowTooDeep(std::string_view t) {
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
      if (++depth > kMaxFlowDepth) {
        return "line " + std::to_string(line) + ": flow collections nested deeper than " +
               std::to_string(kMaxFlowDepth) + " levels";
      }
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return "";
}

}  // namespace

std::string yamlTextHazard(std::string_view text) {
  if (std::string comma = commaStartsDocument(text); !comma.empty()) return comma;
  if (std::string deep = flowTooDeep(text); !deep.empty()) return deep;
  yaml_parser_t parser;
  if (yaml_parser_initialize(&parser) == 0) return "cannot initialise the YAML syntax check";
  yaml_parser_set_input_string(&parser, reinterpret_cast<const unsigned char*>(text.data()),
                               text.size());
  std::string error;
  for (bool done = false; !done;) {
    yaml_event_t event;
    if (yaml_parser_parse(&parser, &event) == 0) {
      error = "line " + std::to_string(parser.problem_mark.line + 1) + ", column " +
              std::to_string(parser.problem_mark.column + 1) + ": " +
              (parser.problem != nullptr ? parser.problem : "malformed YAML");
      if (parser.context != nullptr) error += std::string(" ") + parser.context;
      break;
    }
    done = event.type == YAML_STREAM_END_EVENT;
    yaml_event_delete(&event);
  }
  yaml_parser_delete(&parser);
  return error;
}

}  // namespace rollstep
