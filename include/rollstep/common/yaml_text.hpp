#pragma once
// Text checks for YAML inputs that the YAML library itself gets wrong (no YAML dependency:
// run them on the text before handing it to yaml-cpp).
#include <string>
#include <string_view>

namespace rollstep {

/// Empty if `text` is safe to give to yaml-cpp 0.7 (Debian 12), else why it is not. Today:
/// a document whose first token is ',' (e.g. ",a: 1", "--- ,"), on which yaml-cpp 0.7's
/// parser loops forever allocating memory (found by fuzz/harness_settings). Such text is
/// not valid YAML anyway, so refusing it loses nothing. Linear in the text size.
std::string yamlTextHazard(std::string_view text);

}  // namespace rollstep
