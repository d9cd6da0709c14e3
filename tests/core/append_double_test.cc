// AppendDouble writes the shortest text that reads back as the same double, exactly as
// std::to_chars does (its fast path for short decimals must not change a single character):
// checked against to_chars on decimals of every length and magnitude, on values at the edges of
// the fast path, and on random doubles; each text is read back too.
#include <gtest/gtest.h>

#include <charconv>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "tether/core/registry.h"

namespace tether {
namespace {

std::string ToChars(double v) {
  char buf[64];
  return std::string(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
}

void ExpectLikeToChars(double v) {
  std::string s;
  AppendDouble(&s, v);
  ASSERT_EQ(s, ToChars(v)) << "value " << ToChars(v);
  double back = 0;
  std::from_chars(s.data(), s.data() + s.size(), back);
  ASSERT_EQ(std::signbit(back), std::signbit(v));
  if (std::isfinite(v)) {
    ASSERT_EQ(back, v) << s;
  }
}

TEST(AppendDouble, ShortDecimalsOfEveryLengthAndMagnitude) {
  std::mt19937_64 rng(7);
  for (int digits = 1; digits <= 16; ++digits) {
    std::uniform_int_distribution<long long> mantissa(1, static_cast<long long>(std::pow(10.0, digits)) - 1);
    for (int exponent = -12; exponent <= 12; ++exponent) {
      for (int i = 0; i < 400; ++i) {
        // The double nearest to the decimal m * 10^exponent, as a file's text gives it.
        const std::string text = std::to_string(mantissa(rng)) + "e" + std::to_string(exponent);
        double v = 0;
        std::from_chars(text.data(), text.data() + text.size(), v);
        ExpectLikeToChars(v);
        ExpectLikeToChars(-v);
      }
    }
  }
}

TEST(AppendDouble, TheEdgesOfTheFastPath) {
  for (double v : {0.0, -0.0, 1.0, -1.0, 10.0, 100.0, 1000.0, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 123456789.0, 999999999.0,
                   999999999.5, 1e9 - 1e-7, 0.001, 0.0011, 0.00123, 0.00099999, 0.01, 0.1, 0.5, 0.12345678, 0.123456789,
                   1.5, 44.72136, 44.721360, 1e15, 1e15 - 1, 123456.78901234, 9.999999999999999, 0.30000000000000004,
                   std::nextafter(1.0, 2.0), std::nextafter(0.001, 0.0), std::nextafter(1e9, 0.0), 5e-324, 1e308,
                   std::numeric_limits<double>::max(), std::numeric_limits<double>::min(),
                   std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()}) {
    ExpectLikeToChars(v);
    ExpectLikeToChars(-v);
  }
  std::string nan;
  AppendDouble(&nan, std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(nan, ToChars(std::numeric_limits<double>::quiet_NaN()));
}

TEST(AppendDouble, IntegersAndPowersOfTen) {
  for (long long i = -20000; i <= 20000; ++i) ExpectLikeToChars(static_cast<double>(i));
  for (int e = -20; e <= 20; ++e) {
    for (int m = 1; m <= 9; ++m) ExpectLikeToChars(m * std::pow(10.0, e));
  }
}

TEST(AppendDouble, RandomDoubles) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-30, 30);
  for (int i = 0; i < 300000; ++i) ExpectLikeToChars(std::ldexp(unit(rng), exponent(rng)));
  // Values a solver writes: poses near a start, sums of short decimals.
  for (int i = 0; i < 100000; ++i) ExpectLikeToChars(0.144012 * i + 0.000001 * (i % 7));
}

}  // namespace
}  // namespace tether
