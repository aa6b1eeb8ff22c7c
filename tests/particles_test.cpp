// The SDK's particle-filter pieces against their definitions.
#include "locsim/particles.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace locsim::sdk {
namespace {

TEST(Particles, DecomposedOdometryRecomposesTheMotion) {
  const Pose from(1.0, 2.0, 0.5), to(1.8, 2.6, -0.4);
  const OdometryDelta d = decompose(from, to);
  const double heading = from(2) + d.rot1;
  EXPECT_NEAR(from(0) + d.trans * std::cos(heading), to(0), 1e-12);
  EXPECT_NEAR(from(1) + d.trans * std::sin(heading), to(1), 1e-12);
  EXPECT_NEAR(wrap(heading + d.rot2 - to(2)), 0.0, 1e-12);
  const OdometryDelta turn = decompose(from, Pose(1.0, 2.0, 1.5));  // turning on the spot
  EXPECT_EQ(turn.rot1, 0.0);
  EXPECT_NEAR(turn.rot2, 1.0, 1e-12);
}

double stddev(const std::vector<double>& v, double mean) {
  double s = 0;
  for (const double x : v) s += (x - mean) * (x - mean);
  return std::sqrt(s / static_cast<double>(v.size() - 1));
}

TEST(Particles, MotionNoiseHasThePapersSpreadAndThrunsVarianceForm) {
  const OdometryDelta d{0.3, 1.0, -0.2};
  for (const bool variance_form : {false, true}) {
    OdometryNoise noise;
    noise.variance_form = variance_form;
    Random random(7);
    std::vector<double> rot1, trans, rot2;
    for (int i = 0; i < 200000; ++i) {
      const OdometryDelta s = sample_delta(d, noise, random);
      rot1.push_back(s.rot1), trans.push_back(s.trans), rot2.push_back(s.rot2);
    }
    // Paper: std = a|u| + b|v|; Thrun: variance = a u^2 + b v^2.
    const auto spread = [&](double a, double u, double b, double v) {
      return variance_form ? std::sqrt(a * u * u + b * v * v) : a * std::abs(u) + b * std::abs(v);
    };
    EXPECT_NEAR(stddev(rot1, 0.3), spread(0.0014, 0.3, 0.000125, 1.0),
                0.01 * spread(0.0014, 0.3, 0.000125, 1.0));
    EXPECT_NEAR(stddev(trans, 1.0), spread(0.26, 0.1, 0.01, 1.0),
                0.01 * spread(0.26, 0.1, 0.01, 1.0));
    EXPECT_NEAR(stddev(rot2, -0.2), spread(0.0014, -0.2, 0.000125, 1.0),
                0.01 * spread(0.0014, -0.2, 0.000125, 1.0));
  }
}

TEST(Particles, LandmarkLikelihoodIsTheProductOfTheComponentDensities) {
  // Robot at the origin facing +x, landmark at (3, 4): r = 5, phi = atan2(4, 3).
  const double peak = landmark_likelihood(0, 0, 0, 5.0, std::atan2(4.0, 3.0), 3, 4, 0.1, 0.05);
  EXPECT_NEAR(peak, 1.0 / (2 * std::numbers::pi * 0.1 * 0.05), 1e-9);
  EXPECT_NEAR(landmark_likelihood(0, 0, 0, 5.1, std::atan2(4.0, 3.0), 3, 4, 0.1, 0.05),
              peak * std::exp(-0.5), 1e-9);
  // A bearing off by 2 pi is the same bearing.
  EXPECT_NEAR(landmark_likelihood(0, 0, 0, 5.0, std::atan2(4.0, 3.0) + 2 * std::numbers::pi, 3, 4,
                                  0.1, 0.05),
              peak, 1e-9);
}

TEST(Particles, EffectiveSampleSizeAndNormalisation) {
  std::vector<double> w(100, 3.0);
  EXPECT_DOUBLE_EQ(normalize(w), 300.0);
  EXPECT_NEAR(effective_sample_size(w), 100.0, 1e-9);
  std::vector<double> one(100, 0.0);
  one[5] = 2.0;
  normalize(one);
  EXPECT_DOUBLE_EQ(effective_sample_size(one), 1.0);
  std::vector<double> zero(4, 0.0);
  EXPECT_EQ(normalize(zero), 0.0);
  EXPECT_DOUBLE_EQ(zero[0], 0.25);  // all zero: fall back to equal weights
}

TEST(Particles, LowVarianceResamplingCopiesInProportionToWeight) {
  std::vector<double> w = {0.1, 0.2, 0.3, 0.4};
  std::vector<double> many;
  for (int i = 0; i < 1000; ++i) many.push_back(w[static_cast<std::size_t>(i % 4)]);
  normalize(many);
  Random random(3);
  std::vector<std::size_t> chosen;
  low_variance_resample(many, random, chosen);
  ASSERT_EQ(chosen.size(), 1000u);
  std::vector<int> copies(1000, 0);
  for (const std::size_t c : chosen) ++copies[c];
  for (std::size_t i = 0; i < 1000; ++i) {
    const double expected = 1000 * many[i];
    EXPECT_LE(std::abs(copies[i] - expected), 1.0) << i;  // systematic: within one copy
  }
}

TEST(Particles, RouletteResamplingIsUnbiased) {
  const std::vector<double> w = {0.1, 0.2, 0.3, 0.4};
  Random random(11);
  std::vector<std::size_t> chosen;
  std::vector<double> cumulative;
  std::vector<double> total(4, 0.0);
  for (int trial = 0; trial < 20000; ++trial) {
    roulette_resample(w, random, chosen, cumulative);
    for (const std::size_t c : chosen) total[c] += 1.0;
  }
  for (std::size_t i = 0; i < 4; ++i) EXPECT_NEAR(total[i] / (20000 * 4), w[i], 0.005);
}

TEST(Particles, MeanHeadingIsCircularAndResamplingKeepsTheCount) {
  ParticleSet p;
  p.resize(2);
  p.x = {1.0, 3.0}, p.y = {0.0, 0.0}, p.theta = {std::numbers::pi - 0.1, -std::numbers::pi + 0.1};
  Pose mean;
  Eigen::Matrix3d covariance;
  mean_and_covariance(p, mean, covariance);
  EXPECT_NEAR(std::abs(mean(2)), std::numbers::pi, 1e-9);  // not 0, the arithmetic mean
  EXPECT_NEAR(mean(0), 2.0, 1e-12);
  EXPECT_NEAR(covariance(2, 2), 0.01, 1e-9);
  EXPECT_NEAR(covariance(0, 0), 1.0, 1e-12);
  ParticleSet scratch;
  apply_resample(p, {1, 1}, scratch);
  EXPECT_EQ(p.size(), 2u);
  EXPECT_EQ(p.x[0], 3.0);
  EXPECT_EQ(p.weight[1], 0.5);
}

}  // namespace
}  // namespace locsim::sdk
