// The outputs' decimal text: the fast fixed format (integer-scaled) against the exact one
// (std::to_chars), byte for byte, on the values runs write and on the hard cases: exact rounding
// ties, values a hair either side of a tie, negative values that round to zero, the largest
// values the fast path takes, NaN and infinities.
#include "sim/common/format.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "sim/common/random.hpp"

namespace locsim {
namespace {

std::string fast(double value, int decimals) {
  std::string out = "x";  // appends: what is there stays
  append_fixed(out, value, decimals);
  return out;
}

std::string exact(double value, int decimals) {
  std::string out = "x";
  append_fixed_exact(out, value, decimals);
  return out;
}

TEST(Format, FastFixedIsByteIdenticalToTheExactFormat) {
  RandomStream rng = make_stream(11, "format");
  std::size_t compared = 0;
  const auto check = [&](double value, int decimals) {
    ASSERT_EQ(fast(value, decimals), exact(value, decimals)) << value << " to " << decimals;
    ++compared;
  };
  // What runs write: times (4 decimals), positions (6), quaternions and angles (9), ranges.
  for (int i = 0; i < 400000; ++i) {
    check(rng.uniform(0.0, 3600.0), 4);
    check(rng.uniform(-50.0, 50.0), 6);
    check(rng.uniform(-1.0, 1.0), 9);
    check(rng.normal(0.0, 1e-3), 6);
    check(std::ldexp(rng.uniform(-1.0, 1.0), static_cast<int>(rng.uniform(-40.0, 60.0))),
          static_cast<int>(rng.uniform(0.0, 17.99)));
  }
  // Decimal-looking values (k / 10^d), whose binary value lies just off a tie of the next digit.
  for (int d = 0; d <= 9; ++d) {
    for (int k = -20000; k <= 20000; ++k) {
      const double value = (k + 0.5) / std::pow(10.0, d);
      check(value, d);
      check(std::nextafter(value, 1e300), d);
      check(std::nextafter(value, -1e300), d);
      check(k / std::pow(10.0, d + 1), d);
    }
  }
  // Exact binary ties: round half to even, as the exact format does.
  for (const double tie : {0.5, 1.5, 2.5, -0.5, -2.5, 0.125, 0.375, -0.625, 1.0625, 1e15 + 0.5})
    for (int d = 0; d <= 4; ++d) check(tie, d);
  // Zero and negatives rounding to zero ("0.000", never "-0.000"), large and special values.
  for (const double v :
       {0.0, -0.0, -1e-9, -4.9e-4, -5e-4, -5.1e-4, 1e-300, -1e-300, 4.4e15, 4.6e15, 9.2e18, 1e20,
        -1e20, 1e300, std::numeric_limits<double>::quiet_NaN(),
        std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
        std::numeric_limits<double>::denorm_min()})
    for (int d = 0; d <= 17; ++d) check(v, d);
  EXPECT_GT(compared, 2000000u);
  EXPECT_EQ(fast(-0.0004, 3), "x0.000");
  EXPECT_EQ(fast(0.05, 3), "x0.050");
  EXPECT_EQ(fast(-12.3456789, 4), "x-12.3457");
  EXPECT_EQ(fast(2.5, 0), "x2");
}

}  // namespace
}  // namespace locsim
