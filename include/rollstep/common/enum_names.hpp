#pragma once
// The names of an enum's values, written once beside the enum and used by its toString,
// by the settings reader and writer, and by anything that parses a name back.
//
// Beside the enum, in its namespace (found by argument-dependent lookup):
//
//   enum class SolverMode { Converging, RealTime };
//   constexpr std::array<EnumName<SolverMode>, 2> enumNames(SolverMode) {
//     return {{{SolverMode::Converging, "converging"}, {SolverMode::RealTime, "realtime"}}};
//   }
#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace rollstep {

template <typename E>
struct EnumName {
  E value;
  const char* name;
};

/// The name of `value`, `fallback` for a value outside the table.
template <typename E>
constexpr const char* enumName(E value, const char* fallback = "unknown") {
  for (const EnumName<E>& entry : enumNames(E{})) {
    if (entry.value == value) return entry.name;
  }
  return fallback;
}

/// The value named `name` (exact spelling), none for another text.
template <typename E>
std::optional<E> enumFromName(std::string_view name) {
  for (const EnumName<E>& entry : enumNames(E{})) {
    if (name == entry.name) return entry.value;
  }
  return std::nullopt;
}

/// The names for a message: "a or b", "a, b or c".
template <typename E>
std::string enumChoices() {
  const auto names = enumNames(E{});
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (i > 0) out += i + 1 == names.size() ? " or " : ", ";
    out += names[i].name;
  }
  return out;
}

}  // namespace rollstep
