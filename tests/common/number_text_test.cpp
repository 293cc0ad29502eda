// shortestNumberText: the fewest digits that read back exactly, integers without a fraction.
#include "rollstep/common/number_text.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <random>

namespace rollstep {
namespace {

TEST(ShortestNumberText, FewestDigitsThatReadBackExactly) {
  EXPECT_EQ(shortestNumberText(3.0), "3");
  EXPECT_EQ(shortestNumberText(-250.0), "-250");
  EXPECT_EQ(shortestNumberText(0.1), "0.1");
  EXPECT_EQ(shortestNumberText(1e-8), "1e-08");
  EXPECT_EQ(shortestNumberText(0.995), "0.995");
  EXPECT_EQ(shortestNumberText(std::numeric_limits<double>::quiet_NaN()), "nan");
  EXPECT_EQ(shortestNumberText(std::numeric_limits<double>::infinity()), "inf");
  EXPECT_EQ(shortestNumberText(-std::numeric_limits<double>::infinity()), "-inf");
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> mantissa(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-300, 300);
  for (int i = 0; i < 10000; ++i) {
    const double v = std::ldexp(mantissa(rng), exponent(rng));
    const std::string t = shortestNumberText(v);
    EXPECT_EQ(std::strtod(t.c_str(), nullptr), v) << t;
    EXPECT_LE(t.size(), 24u) << t;
  }
}

}  // namespace
}  // namespace rollstep
