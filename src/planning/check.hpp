#pragma once
// Argument checks shared by the planning sources: each throws std::invalid_argument
// naming the function, the parameter and its value.
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "rollstep/planning/gait.hpp"

namespace rollstep::planning::detail {

template <class T>
[[noreturn]] void fail(const char* where, const char* name, const T& value, const char* need) {
  std::ostringstream os;
  os << where << ": " << name << " = " << value << " (" << need << ")";
  throw std::invalid_argument(os.str());
}

inline void checkFinite(const char* where, const char* name, double v) {
  if (!std::isfinite(v)) fail(where, name, v, "must be finite");
}
inline void checkPositive(const char* where, const char* name, double v) {
  if (!std::isfinite(v) || v <= 0.0) fail(where, name, v, "must be finite and > 0");
}
inline void checkNonNegative(const char* where, const char* name, double v) {
  if (!std::isfinite(v) || v < 0.0) fail(where, name, v, "must be finite and >= 0");
}
inline void checkOpenUnit(const char* where, const char* name, double v) {
  if (!std::isfinite(v) || v <= 0.0 || v >= 1.0) fail(where, name, v, "must be in (0, 1)");
}
inline void checkNumFeet(const char* where, int n) {
  if (n < 1 || n > kMaxFeet) fail(where, "num_feet", n, "must be in [1, 16]");
}

}  // namespace rollstep::planning::detail
