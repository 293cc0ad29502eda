// Text for XML and HTML documents the project writes (MJCF scenes, the report).
#pragma once

#include <string>

namespace rollstep {

/// `text` with &, <, > and " escaped as entities: safe inside an XML/HTML attribute value
/// in double quotes and inside element text.
std::string escapeMarkup(const std::string& text);

}  // namespace rollstep
