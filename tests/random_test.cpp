#include "sim/common/random.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace locsim {
namespace {

TEST(Random, StreamsAreReproducibleAndIndependentByName) {
  RandomStream a1 = make_stream(7, "sensor/imu"), a2 = make_stream(7, "sensor/imu");
  RandomStream b = make_stream(7, "sensor/laser"), c = make_stream(8, "sensor/imu");
  int equal_b = 0, equal_c = 0;
  for (int i = 0; i < 100; ++i) {
    const std::uint64_t x = a1.next_u64();
    EXPECT_EQ(x, a2.next_u64());
    equal_b += x == b.next_u64();
    equal_c += x == c.next_u64();
  }
  EXPECT_EQ(equal_b, 0);
  EXPECT_EQ(equal_c, 0);
}

TEST(Random, NormalHasUnitMomentsAndUniformStaysInRange) {
  RandomStream rng = make_stream(1, "moments");
  const int n = 200000;
  double sum = 0, sum_sq = 0;
  for (int i = 0; i < n; ++i) {
    const double x = rng.normal();
    sum += x;
    sum_sq += x * x;
    const double u = rng.uniform();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
  }
  EXPECT_NEAR(sum / n, 0.0, 0.01);  // 4.5 standard errors
  EXPECT_NEAR(sum_sq / n, 1.0, 0.015);
}

}  // namespace
}  // namespace locsim
