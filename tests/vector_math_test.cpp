// The SDK's vector maths: every version this processor runs gives the portable version's bits
// (a filter's results must not depend on the processor), and the results are libm's within 1 ulp.
#include "locsim/vector_math.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace locsim::sdk::vector_math {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::vector<Isa> runnable() {
  std::vector<Isa> isas;
  for (const Isa isa : {Isa::kPortable, Isa::kSse2, Isa::kAvx, Isa::kAvx512})
    if (isa <= widest_isa()) isas.push_back(isa);
  return isas;
}

/// The same bits, element by element, or NaN in both (SSE2's sine of an infinity is a NaN of
/// another payload than the portable version's: no output tells NaNs apart).
bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::memcmp(&a[i], &b[i], sizeof(double)) != 0 && !(std::isnan(a[i]) && std::isnan(b[i])))
      return false;
  return true;
}

/// Ordinary and awkward arguments: huge angles, zeros of both signs, infinities, NaN, exp's
/// overflow and underflow, log1p's pole and domain edge.
std::vector<double> arguments(std::size_t count, double lo, double hi, std::uint64_t seed) {
  std::mt19937_64 engine(seed);
  std::uniform_real_distribution<double> uniform(lo, hi);
  std::vector<double> x = {0.0,
                           -0.0,
                           kInf,
                           -kInf,
                           kNaN,
                           1e300,
                           -1e300,
                           710.0,
                           -746.0,
                           -1.0,
                           -2.0,
                           1e-300,
                           3.141592653589793,
                           1.5707963267948966};
  while (x.size() < count) x.push_back(uniform(engine));
  return x;
}

double ulps_apart(double a, double b) {
  if (a == b || (std::isnan(a) && std::isnan(b))) return 0.0;
  return std::abs(a - b) / (std::nextafter(std::abs(b), kInf) - std::abs(b));
}

TEST(VectorMath, EveryVersionGivesThePortableBits) {
  // Lengths that are not a multiple of any width: the padded tail must match too.
  for (const std::size_t n : {0u, 1u, 3u, 7u, 9u, 17u, 1000u, 4099u}) {
    const std::vector<double> angles = arguments(n, -100.0, 100.0, n),
                              powers = arguments(n, -50.0, 50.0, n + 1),
                              small = arguments(n, -0.999, 1e3, n + 2);
    std::vector<double> sin0(angles.size()), cos0(angles.size()), exp0(powers.size()),
        log0(small.size());
    sincos(Isa::kPortable, angles, sin0, cos0);
    exp(Isa::kPortable, powers, exp0);
    log1p(Isa::kPortable, small, log0);
    for (const Isa isa : runnable()) {
      std::vector<double> s(angles.size()), c(angles.size()), e(powers.size()), l(small.size());
      sincos(isa, angles, s, c);
      exp(isa, powers, e);
      log1p(isa, small, l);
      EXPECT_TRUE(same_bits(s, sin0) && same_bits(c, cos0)) << isa_name(isa) << ", n " << n;
      EXPECT_TRUE(same_bits(e, exp0)) << isa_name(isa) << ", n " << n;
      EXPECT_TRUE(same_bits(l, log0)) << isa_name(isa) << ", n " << n;
    }
  }
  // One line says which versions ran here (a machine without AVX-512 tests fewer).
  std::string ran;
  for (const Isa isa : runnable()) ran += std::string(ran.empty() ? "" : ", ") + isa_name(isa);
  RecordProperty("versions", ran);
}

TEST(VectorMath, ResultsAreLibmsWithinOneUlp) {
  const std::vector<double> angles = arguments(20000, -50.0, 50.0, 1),
                            powers = arguments(20000, -700.0, 700.0, 2),
                            small = arguments(20000, -0.999, 1e6, 3);
  std::vector<double> s(angles.size()), c(angles.size()), e(powers.size()), l(small.size());
  sincos(angles, s, c);
  exp(powers, e);
  log1p(small, l);
  for (std::size_t i = 0; i < angles.size(); ++i) {
    if (std::abs(angles[i]) > 1e15) continue;  // libm and SLEEF reduce huge angles differently
    // Below 1 ulp each, so within 2 of each other at worst; the sine's zeros aside (absolute).
    ASSERT_LE(std::min(ulps_apart(s[i], std::sin(angles[i])),
                       1e16 * std::abs(s[i] - std::sin(angles[i]))),
              2.0)
        << angles[i];
    ASSERT_LE(std::min(ulps_apart(c[i], std::cos(angles[i])),
                       1e16 * std::abs(c[i] - std::cos(angles[i]))),
              2.0)
        << angles[i];
  }
  for (std::size_t i = 0; i < powers.size(); ++i)
    ASSERT_LE(ulps_apart(e[i], std::exp(powers[i])), 2.0) << powers[i];
  for (std::size_t i = 0; i < small.size(); ++i)
    ASSERT_LE(ulps_apart(l[i], std::log1p(small[i])), 2.0) << small[i];
  EXPECT_EQ(l[9], -kInf);          // log1p(-1)
  EXPECT_TRUE(std::isnan(l[10]));  // log1p(-2)
  EXPECT_EQ(e[7], kInf);           // exp(710)
  EXPECT_EQ(e[8], 0.0);            // exp(-746)
}

TEST(VectorMath, OutputsMayBeTheInputAndMustMatchItsLength) {
  std::vector<double> x = {0.5, 1.0, -2.0, 3.0, 4.0};
  const std::vector<double> original = x;
  std::vector<double> expected(x.size());
  exp(original, expected);
  exp(x, x);
  EXPECT_TRUE(same_bits(x, expected));
  std::vector<double> shorter(4);
  EXPECT_THROW(exp(original, shorter), std::invalid_argument);
  EXPECT_THROW(sincos(original, x, shorter), std::invalid_argument);
  if (widest_isa() != Isa::kAvx512) {
    EXPECT_THROW(exp(Isa::kAvx512, original, x), std::invalid_argument);
  }
}

}  // namespace
}  // namespace locsim::sdk::vector_math
