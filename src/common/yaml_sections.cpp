#include "rollstep/common/yaml_sections.hpp"

#include <cmath>
#include <cstring>
#include <map>

#include "rollstep/common/number_text.hpp"
#include "rollstep/common/yaml_tree.hpp"

namespace rollstep::yaml {

namespace {

[[noreturn]] void fail(const std::string& source, int line, const std::string& key,
                       const std::string& problem) {
  throw std::runtime_error(source + ": line " + std::to_string(line) + ": " + key + ": " + problem);
}

void readNumber(const Node& value, const NumberField& field, const std::string& source,
                const std::string& name) {
  double x = 0.0;
  if (!value.isScalar() || !value.plain() || !value.toDouble(x)) {
    fail(source, value.line(), name,
         std::string("expected a number, found ") +
             (value.isScalar() ? "'" + value.scalar() + "'" : std::string(value.kindName())));
  }
  if (!std::isfinite(x)) fail(source, value.line(), name, "not finite");
  if (x < field.min || x > field.max) {
    fail(source, value.line(), name,
         shortestNumberText(x) + " is outside [" + shortestNumberText(field.min) + ", " +
             shortestNumberText(field.max) + "]");
  }
  *field.value = x;
}

// Reads a mapping of numbers of one section; `prefix` is "section." or "".
void readMapping(const Node& map, const NumberSection* numbers,
                 const std::vector<NumberSection>& sections, const std::string& source,
                 const std::string& prefix) {
  std::map<std::string, int> seen;
  for (std::size_t i = 0; i < map.size(); ++i) {
    const Node key = map.key(i);
    const Node value = map.value(i);
    const std::string name = key.isScalar() ? key.scalar() : std::string(key.kindName());
    if (!key.isScalar()) fail(source, key.line(), prefix + name, "a key must be text");
    const auto [it, fresh] = seen.emplace(name, key.line());
    if (!fresh) {
      fail(source, key.line(), prefix + name,
           "repeated (first on line " + std::to_string(it->second) + ")");
    }
    bool found = false;
    if (numbers != nullptr) {
      for (const NumberField& f : numbers->fields) {
        if (name == f.key) {
          readNumber(value, f, source, prefix + name);
          found = true;
          break;
        }
      }
    }
    if (!found && prefix.empty()) {
      for (const NumberSection& s : sections) {
        if (s.key[0] != '\0' && name == s.key) {
          if (value.isNull()) {
            found = true;  // an empty section keeps its defaults
            break;
          }
          if (!value.isMapping()) {
            fail(source, value.line(), name,
                 std::string("expected a mapping, found ") + value.kindName());
          }
          readMapping(value, &s, sections, source, name + ".");
          found = true;
          break;
        }
      }
    }
    if (!found) fail(source, key.line(), prefix + name, "unknown key");
  }
}

}  // namespace

void readNumberSections(const std::string& yaml_text, const std::string& source,
                        const std::vector<NumberSection>& sections) {
  Document doc = [&] {
    try {
      return Document::parse(yaml_text);
    } catch (const YamlError& e) {
      throw std::runtime_error(source + ": " + e.what());
    }
  }();
  const Node root = doc.root();
  if (root.isNull()) return;
  if (!root.isMapping()) {
    fail(source, root.line(), "(top level)",
         std::string("expected a mapping, found ") + root.kindName());
  }
  const NumberSection* top = nullptr;
  for (const NumberSection& s : sections) {
    if (s.key[0] == '\0') top = &s;
  }
  readMapping(root, top, sections, source, "");
}

}  // namespace rollstep::yaml
