#pragma once
// Numbers in messages and written files: the shortest decimal text that reads back exactly,
// and printf-style text of any length.
#include <string>

namespace rollstep {

/// The shortest decimal text of v that strtod reads back as exactly v: integers without a
/// fraction ("3", "-0"), others with the fewest significant digits ("0.1", "1e-08");
/// "nan", "inf" and "-inf" for the non-finite values.
std::string shortestNumberText(double v);

/// printf into a std::string of any length.
std::string formatText(const char* fmt, ...) __attribute__((format(printf, 1, 2)));

}  // namespace rollstep
