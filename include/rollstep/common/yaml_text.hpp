#pragma once
// Syntax check of YAML text before it reaches yaml-cpp (the library the loaders use).
#include <string>
#include <string_view>

namespace rollstep {

/// Empty if `text` is well-formed YAML, else "line L, column C: <problem>". Checked with
/// libyaml's event parser (linear time, bounded memory, no tree, no alias expansion), because
/// yaml-cpp 0.7 (Debian 12) loops forever, allocating memory, on some malformed text: a ','
/// where a document's top-level node or the token after it should be (",a: 1", "'',",
/// ">\n,", "!,"; found by fuzz/harness_settings). Flow collections nested deeper than 64
/// levels are refused too (libyaml is quadratic in the depth, yaml-cpp recursive). Loaders
/// call this first and refuse the text with the message.
std::string yamlTextHazard(std::string_view text);

}  // namespace rollstep
