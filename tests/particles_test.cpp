// The SDK's particle-filter pieces against their definitions.
#include "locsim/particles.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <optional>
#include <random>
#include <tuple>
#include <vector>

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

TEST(Particles, EachParticleMovesByItsOwnDrawsInTheOrderOneAtATimeWouldDrawThem) {
  // sample_motion draws in blocks and takes the sines and cosines in a vector pass; the draws
  // must still go to the particles in order (rot1, trans, rot2 of particle 0, then 1, ...).
  const OdometryDelta d{0.3, 0.8, -0.2};
  const OdometryNoise noise;
  Random setup(3);
  ParticleSet p;
  p.resize(601);  // two full blocks of 256 and a tail
  for (std::size_t i = 0; i < p.size(); ++i) {
    p.x[i] = setup.uniform(-5, 5), p.y[i] = setup.uniform(-5, 5);
    p.theta[i] = setup.uniform(-std::numbers::pi, std::numbers::pi);
  }
  const ParticleSet before = p;
  Random random(11), one_at_a_time(11);
  sample_motion(p, d, noise, random);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const OdometryDelta s = sample_delta(d, noise, one_at_a_time);
    const double heading = before.theta[i] + s.rot1;
    ASSERT_NEAR(p.x[i], before.x[i] + s.trans * std::cos(heading), 1e-12) << i;
    ASSERT_NEAR(p.y[i], before.y[i] + s.trans * std::sin(heading), 1e-12) << i;
    ASSERT_NEAR(p.theta[i], wrap(heading + s.rot2), 1e-12) << i;
  }
  EXPECT_EQ(random.uniform(0, 1), one_at_a_time.uniform(0, 1));  // as many draws
}

TEST(Particles, WheelMotionSpreadsAsTheEkfPredictsAndTheFloorAddsItsOwn) {
  // Many readings of wheel travel (an arc): the cloud's covariance is the EKF's prediction with
  // the same k (predict_by_wheels), to first order; then the floor adds its variance.
  constexpr std::size_t kParticles = 40000;
  ParticleSet p;
  p.resize(kParticles);
  Random random(11);
  Pose x(0, 0, 0);
  Eigen::Matrix3d P = Eigen::Matrix3d::Zero();
  const double base_m = 0.3, k_left = 0.02, k_right = 0.03;
  for (int step = 0; step < 50; ++step) {
    sample_wheel_motion(p, 0.019, 0.021, base_m, k_left, k_right, random);
    predict_by_wheels(x, P, 0.019, 0.021, base_m, k_left, k_right);
  }
  Pose mean;
  Eigen::Matrix3d covariance;
  mean_and_covariance(p, mean, covariance);
  // The mean lags the noiseless pose a little (the heading spread bends the paths inwards).
  EXPECT_LT((mean - x).head<2>().norm(), 0.01);
  // Across the path and in heading, the first-order prediction holds to sampling noise (0.98-1.02
  // of it over twelve seeds). Along the path (x) the cloud is wider by a second-order term the
  // linearisation drops (a path that wanders in heading ends shorter): 1.03-1.06 of it.
  EXPECT_NEAR(covariance(1, 1), P(1, 1), 0.03 * P(1, 1));
  EXPECT_NEAR(covariance(2, 2), P(2, 2), 0.03 * P(2, 2));
  EXPECT_GT(covariance(0, 0), P(0, 0));
  EXPECT_LT(covariance(0, 0), 1.1 * P(0, 0));
  OdometryNoise floor;
  floor.floor_position_m = 0.05;
  floor.floor_heading_rad = 0.1;
  add_motion_floor(p, floor, random);
  Eigen::Matrix3d widened;
  mean_and_covariance(p, mean, widened);
  EXPECT_NEAR(widened(0, 0) - covariance(0, 0), 0.0025, 0.0002);
  EXPECT_NEAR(widened(1, 1) - covariance(1, 1), 0.0025, 0.0002);
  EXPECT_NEAR(widened(2, 2) - covariance(2, 2), 0.01, 0.0008);
}

TEST(Particles, ReversingIsAsNoisyAsDrivingForwards) {
  // 5 cm straight back decomposes as a half turn, 5 cm, and a half turn back: the noise must be
  // that of 5 cm forwards, not of two half turns (alpha1 pi: 100x the rotation noise).
  const Pose from(1.0, 2.0, 0.3);
  const double step = 0.05, turn = 0.01;
  const Pose ahead(from(0) + step * std::cos(0.3), from(1) + step * std::sin(0.3), 0.3 + turn);
  const Pose behind(from(0) - step * std::cos(0.3), from(1) - step * std::sin(0.3), 0.3 + turn);
  const OdometryDelta forwards = decompose(from, ahead), backwards = decompose(from, behind);
  ASSERT_NEAR(std::abs(backwards.rot1), std::numbers::pi, 1e-9);
  for (const bool variance_form : {false, true}) {
    OdometryNoise noise;
    noise.variance_form = variance_form;
    const OdometryDelta f = motion_spread(forwards, noise), b = motion_spread(backwards, noise);
    EXPECT_NEAR(b.rot1, f.rot1, 1e-12);
    EXPECT_NEAR(b.trans, f.trans, 1e-12);
    EXPECT_NEAR(b.rot2, f.rot2, 1e-12);
  }
  // The geometry stays exact: a noiseless sample lands where the robot went.
  ParticleSet p;
  p.resize(1);
  p.x[0] = from(0), p.y[0] = from(1), p.theta[0] = from(2);
  Random random(3);
  sample_motion(p, backwards, OdometryNoise{0, 0, 0, 0, false}, random);
  EXPECT_NEAR(p.x[0], behind(0), 1e-12);
  EXPECT_NEAR(p.y[0], behind(1), 1e-12);
  EXPECT_NEAR(wrap(p.theta[0] - behind(2)), 0.0, 1e-12);
}

TEST(Particles, LandmarkLikelihoodIsANormalRangeTimesAVonMisesBearing) {
  // Robot at the origin facing +x, landmark at (3, 4): r = 5, phi = atan2(4, 3).
  const double phi = std::atan2(4.0, 3.0);
  EXPECT_NEAR(landmark_log_match(0, 0, 0, 5.0, phi, 3, 4, 0.1, 0.05), 0.0, 1e-12);
  // One sigma of range error: -1/2; a bearing error e: -(1 - cos e) / sigma^2.
  EXPECT_NEAR(landmark_log_match(0, 0, 0, 5.1, phi, 3, 4, 0.1, 0.05), -0.5, 1e-9);
  EXPECT_NEAR(landmark_log_match(0, 0, 0, 5.0, phi + 0.3, 3, 4, 0.1, 0.05),
              -(1.0 - std::cos(0.3)) / (0.05 * 0.05), 1e-9);
  // Near a perfect match the bearing term is the Gaussian's e^2 / (2 sigma^2) (1 % at 14 deg).
  const double e = 14.0 * std::numbers::pi / 180.0;
  EXPECT_NEAR(
      landmark_log_match(0, 0, 0, 5.0, phi + e, 3, 4, 0.1, 0.05) / (-0.5 * e * e / (0.05 * 0.05)),
      1.0, 0.01);
  // A bearing off by 2 pi is the same bearing; the far side of the circle is the worst match.
  EXPECT_NEAR(landmark_log_match(0, 0, 0, 5.0, phi + 2 * std::numbers::pi, 3, 4, 0.1, 0.05), 0.0,
              1e-9);
  EXPECT_NEAR(landmark_log_match(0, 0, 0, 5.0, phi + std::numbers::pi, 3, 4, 0.1, 0.05),
              -2.0 / (0.05 * 0.05), 1e-9);
  // The density integrates to 1 over range and bearing, for narrow and wide bearing noise (the
  // von Mises normaliser by both of its series).
  for (const double sigma_bearing : {0.05, 0.5, 1.5}) {
    double total = 0.0;
    const int steps = 1000;
    const double dr = 2.0 / steps, db = 2.0 * std::numbers::pi / steps;
    for (int i = 0; i < steps; ++i) {
      for (int j = 0; j < steps; ++j) {
        total +=
            landmark_likelihood(0, 0, 0, 4.0 + (i + 0.5) * dr,
                                phi - std::numbers::pi + (j + 0.5) * db, 3, 4, 0.1, sigma_bearing) *
            dr * db;
      }
    }
    EXPECT_NEAR(total, 1.0, 1e-6) << sigma_bearing;
  }
}

TEST(Particles, BatchLandmarkMatchIsTheScalarOneForEveryParticle) {
  Random random(5);
  ParticleSet p;
  p.resize(1001);  // odd: the vector loop's scalar tail too
  for (std::size_t i = 0; i < p.size(); ++i) {
    p.x[i] = random.uniform(-1, 7), p.y[i] = random.uniform(-1, 5);
    p.theta[i] = random.uniform(-std::numbers::pi, std::numbers::pi);
  }
  p.x[7] = 3.0, p.y[7] = 4.0;  // on the landmark itself: finite, no division by zero
  Headings headings;
  headings.compute(p);
  std::vector<double> out;
  landmark_log_match(p, headings, 2.5, -0.7, 3.0, 4.0, 0.2, 0.04, out);
  ASSERT_EQ(out.size(), p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double scalar =
        landmark_log_match(p.x[i], p.y[i], p.theta[i], 2.5, -0.7, 3.0, 4.0, 0.2, 0.04);
    ASSERT_TRUE(std::isfinite(out[i])) << i;
    EXPECT_NEAR(out[i], scalar, 1e-9 * (1.0 + std::abs(scalar))) << i;
  }
}

// Kolmogorov-Smirnov distance of `samples` (sorted here) from the distribution `cdf`.
template <class Cdf>
double ks_distance(std::vector<double>& samples, Cdf cdf) {
  std::sort(samples.begin(), samples.end());
  double d = 0.0;
  const auto n = static_cast<double>(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const double f = cdf(samples[i]);
    d = std::max({d, std::abs(f - static_cast<double>(i) / n),
                  std::abs(f - static_cast<double>(i + 1) / n)});
  }
  return d;
}

TEST(SdkRandom, ZigguratNormalsAndExponentialsHaveTheirDistributions) {
  // The tables close: the last strip reaches the density's peak.
  const auto& zn = detail::normal_ziggurat();
  EXPECT_NEAR(9.91256303526217e-3 / zn.x[127] + zn.fx[127], 1.0, 1e-9);
  const auto& ze = detail::exponential_ziggurat();
  EXPECT_NEAR(3.949659822581572e-3 / ze.x[255] + ze.fx[255], 1.0, 1e-9);

  Random random(2024);
  const std::size_t n = 400000;
  std::vector<double> normals(n), exponentials(n);
  double tail_normal = 0.0, tail_exponential = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    normals[i] = random.normal();
    exponentials[i] = random.exponential();
    tail_normal += std::abs(normals[i]) > 3.5 ? 1.0 : 0.0;  // beyond r: the tail algorithm
    tail_exponential += exponentials[i] > 8.0 ? 1.0 : 0.0;
  }
  // KS at 400 000 samples: the 0.1 % critical distance is 1.95 / sqrt(n) = 0.0031.
  EXPECT_LT(ks_distance(normals, [](double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }),
            0.0031);
  EXPECT_LT(ks_distance(exponentials, [](double x) { return 1.0 - std::exp(-x); }), 0.0031);
  // The tails beyond the base strip, within 5 standard errors of a binomial count.
  const double p_normal = std::erfc(3.5 / std::sqrt(2.0)), p_exponential = std::exp(-8.0);
  EXPECT_NEAR(tail_normal / n, p_normal, 5 * std::sqrt(p_normal / n));
  EXPECT_NEAR(tail_exponential / n, p_exponential, 5 * std::sqrt(p_exponential / n));
  // Seeded: the same seed, the same numbers.
  Random a(9), b(9);
  for (int i = 0; i < 1000; ++i) ASSERT_EQ(a.normal(), b.normal());
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

TEST(Particles, OpenEndedDrawsSpreadEveryPrefixOverAllTheWeights) {
  // Two modes of equal mass, one at each end of the set (the newest guesses are at its end). KLD
  // sampling stops after a count it learns while drawing: whatever the count, each mode gets
  // its share. A comb of max teeth walked in order and stopped at 100 of 1000 drew the head's
  // mode only.
  std::vector<double> w(1000, 0.0);
  for (std::size_t i = 0; i < 50; ++i) w[i] = w[999 - i] = 1.0;
  std::vector<double> cumulative;
  double sum = 0.0;
  for (const double v : w) cumulative.push_back(sum += v);
  for (const double u : {0.0, 0.37, 0.999}) {
    OpenEndedDraws draws(cumulative, u);
    int head = 0, tail = 0;
    for (int k = 1; k <= 512; ++k) {
      const std::size_t i = draws.next();
      ASSERT_GT(w[i], 0.0) << "drew a particle of no weight";
      (i < 500 ? head : tail) += 1;
      if (k == 2 || k == 8 || k == 100 || k == 512) {
        EXPECT_LE(std::abs(head - tail), 2) << "after " << k << " draws, u " << u;
      }
    }
  }
  EXPECT_EQ(OpenEndedDraws::radical_inverse(0), 0.0);
  EXPECT_EQ(OpenEndedDraws::radical_inverse(1), 0.5);
  EXPECT_EQ(OpenEndedDraws::radical_inverse(2), 0.25);
  EXPECT_EQ(OpenEndedDraws::radical_inverse(3), 0.75);
  EXPECT_EQ(OpenEndedDraws::radical_inverse(6), 0.375);
}

TEST(Particles, OpenEndedDrawsFindWhatUpperBoundFinds) {
  // The guide table's search and the six-step bit mirror against the plain forms, on weights with
  // runs of zeros (equal running sums: upper_bound's "first greater" decides) and on large k;
  // one object reset for every set (the table's storage reused).
  const auto radical_inverse = [](std::uint64_t k) {
    std::uint64_t mirrored = 0;
    for (int bit = 0; bit < 64; ++bit, k >>= 1) mirrored = (mirrored << 1) | (k & 1u);
    return static_cast<double>(mirrored >> 11) * 0x1.0p-53;
  };
  std::mt19937_64 engine(11);
  for (int i = 0; i < 10000; ++i) {
    const std::uint64_t k = engine() >> (engine() % 64);
    ASSERT_EQ(OpenEndedDraws::radical_inverse(k), radical_inverse(k)) << k;
  }
  // The guide table's buckets hold one running sum each with even weights, thousands with a
  // few heavy particles among many of almost no weight (a filter after a telling scan), and
  // every one with no weight at all.
  enum class Weights { kSmallIntegers, kFewHeavy, kAllZero };
  OpenEndedDraws draws;
  for (const Weights kind : {Weights::kSmallIntegers, Weights::kFewHeavy, Weights::kAllZero})
    for (const std::size_t n : {1u, 2u, 3u, 7u, 64u, 1000u, 4097u}) {
      std::vector<double> cumulative;
      double sum = 0.0;
      for (std::size_t i = 0; i < n; ++i) {
        const std::uint64_t r = engine();
        const double weight = kind == Weights::kAllZero ? 0.0
                              : kind == Weights::kFewHeavy
                                  ? (r % 97 == 0 ? 1.0 : 1e-12 * static_cast<double>(r % 7))
                                  : (r % 3 == 0 ? 0.0 : static_cast<double>(r % 5));
        cumulative.push_back(sum += weight);
      }
      const double u = static_cast<double>(engine() >> 11) * 0x1.0p-53;
      draws.reset(cumulative, u);
      for (std::uint64_t k = 0; k < 3000; ++k) {
        double v = u + radical_inverse(k);
        if (v >= 1.0) v -= 1.0;
        const auto it = std::upper_bound(cumulative.begin(), cumulative.end(), v * sum);
        const auto expected = std::min(static_cast<std::size_t>(it - cumulative.begin()), n - 1);
        ASSERT_EQ(draws.next(), expected)
            << "n " << n << ", draw " << k << ", weights " << static_cast<int>(kind);
      }
    }
}

TEST(Particles, PoseBinsNumberBinsInTheOrderFirstSeen) {
  // Against std::map over many bins (the table grows several times), then cleared and refilled.
  PoseBins bins(0.5, 10.0 * std::numbers::pi / 180.0);
  std::mt19937_64 engine(5);
  for (int round = 0; round < 2; ++round) {
    std::map<std::tuple<std::int64_t, std::int64_t, std::int64_t>, std::size_t> expected;
    for (int i = 0; i < 20000; ++i) {
      const double x = static_cast<double>(engine() % 4000) * 0.01 - 20.0;
      const double y = static_cast<double>(engine() % 4000) * 0.01 - 20.0;
      const double theta = static_cast<double>(engine() % 6283) * 0.001 - 3.1415;
      const PoseBin bin = bins.bin_of(x, y, theta);
      EXPECT_EQ(bin.x, static_cast<std::int64_t>(std::floor(x / 0.5)));
      const auto [it, added] =
          expected.emplace(std::tuple(bin.x, bin.y, bin.theta), expected.size());
      const auto [index, is_new] = bins.insert(bin);
      ASSERT_EQ(is_new, added) << i;
      ASSERT_EQ(index, it->second) << i;
      ASSERT_EQ(bins.find(bin), it->second);
    }
    EXPECT_EQ(bins.size(), expected.size());
    EXPECT_GT(bins.size(), 1000u);
    for (const auto& [key, index] : expected)
      EXPECT_EQ(bins.bins()[index],
                (PoseBin{std::get<0>(key), std::get<1>(key), std::get<2>(key)}));
    EXPECT_EQ(bins.find({1000000, 0, 0}), PoseBins::kNone);
    bins.clear();
    EXPECT_EQ(bins.size(), 0u);
    EXPECT_EQ(bins.find(bins.bins().empty() ? PoseBin{0, 0, 0} : bins.bins()[0]), PoseBins::kNone);
  }
}

TEST(Particles, RouletteResamplingIsMultinomial) {
  // Each draw independent: a particle of weight w gets n w copies on average with the binomial
  // variance n w (1 - w) (systematic resampling's would be below 1/4).
  const std::vector<double> w = {0.1, 0.2, 0.3, 0.4};
  Random random(11);
  std::vector<std::size_t> chosen;
  std::vector<double> spacings;
  const int trials = 20000;
  std::vector<double> total(4, 0.0), squares(4, 0.0);
  for (int trial = 0; trial < trials; ++trial) {
    roulette_resample(w, random, chosen, spacings);
    ASSERT_EQ(chosen.size(), 4u);
    ASSERT_TRUE(std::is_sorted(chosen.begin(), chosen.end()));
    std::vector<double> copies(4, 0.0);
    for (const std::size_t c : chosen) copies[c] += 1.0;
    for (std::size_t i = 0; i < 4; ++i) total[i] += copies[i], squares[i] += copies[i] * copies[i];
  }
  for (std::size_t i = 0; i < 4; ++i) {
    const double mean = total[i] / trials, variance = squares[i] / trials - mean * mean;
    EXPECT_NEAR(mean, 4 * w[i], 0.03) << i;
    EXPECT_NEAR(variance, 4 * w[i] * (1 - w[i]), 0.05) << i;
  }
  // Zero-weight particles are never chosen, at either end.
  const std::vector<double> ends = {0.0, 1.0, 0.0};
  roulette_resample(ends, random, chosen, spacings);
  for (const std::size_t c : chosen) EXPECT_EQ(c, 1u);
}

TEST(Particles, TheMeanAndCovarianceOfManyParticlesAreTheirWeightedSums) {
  Random random(4);
  ParticleSet p;
  p.resize(700);  // blocks of 256 and a tail
  double sw = 0, sx = 0, sy = 0, ss = 0, sc = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    p.x[i] = random.normal(2.0), p.y[i] = 1.0 + random.normal(0.5);
    p.theta[i] = wrap(3.0 + random.normal(0.3)), p.weight[i] = random.uniform(0.1, 1.0);
    sw += p.weight[i], sx += p.weight[i] * p.x[i], sy += p.weight[i] * p.y[i];
    ss += p.weight[i] * std::sin(p.theta[i]), sc += p.weight[i] * std::cos(p.theta[i]);
  }
  Pose mean;
  Eigen::Matrix3d covariance;
  mean_and_covariance(p, mean, covariance);
  EXPECT_NEAR(mean(0), sx / sw, 1e-12);
  EXPECT_NEAR(mean(1), sy / sw, 1e-12);
  EXPECT_NEAR(mean(2), std::atan2(ss, sc), 1e-12);
  Eigen::Matrix3d expected = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Eigen::Vector3d e(p.x[i] - mean(0), p.y[i] - mean(1), wrap(p.theta[i] - mean(2)));
    expected += p.weight[i] / sw * e * e.transpose();
  }
  // Bit for bit the equation's sums in its order: every particle filter reports this covariance,
  // and a faster summation must not change a run's files.
  for (Eigen::Index r = 0; r < 3; ++r)
    for (Eigen::Index c = 0; c < 3; ++c) EXPECT_EQ(covariance(r, c), expected(r, c)) << r << c;
  // The first 300 only: a count inside the second block.
  mean_and_covariance(p, mean, covariance, 300);
  double sw300 = 0, sx300 = 0;
  for (std::size_t i = 0; i < 300; ++i) sw300 += p.weight[i], sx300 += p.weight[i] * p.x[i];
  EXPECT_NEAR(mean(0), sx300 / sw300, 1e-12);
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

/// `count` particles about (x, y, theta), 0.05 m and 2 degrees apart, each of weight `w`.
void add_group(ParticleSet& p, std::size_t count, double x, double y, double theta, double w) {
  for (std::size_t k = 0; k < count; ++k) {
    const double d = static_cast<double>(k % 5) - 2.0;
    p.x.push_back(x + 0.05 * d), p.y.push_back(y - 0.03 * d);
    p.theta.push_back(wrap(theta + 0.035 * d)), p.weight.push_back(w);
  }
}

TEST(Particles, ClustersJoinNeighbouringBinsAndGiveEachItsWeightAndCentre) {
  // Two groups 5 m apart (one of them across the heading's wrap), a straggler left out.
  ParticleSet p;
  add_group(p, 30, 1.0, 2.0, std::numbers::pi - 0.01, 0.01);
  add_group(p, 70, 6.0, 2.0, 0.5, 0.01);
  add_group(p, 1, 20.0, 20.0, 0.0, 0.5);
  PoseBins bins(0.5, 10.0 * std::numbers::pi / 180.0);
  ParticleClusters clusters;
  clusters.compute(p, 100, bins);  // the last particle not counted
  std::vector<std::size_t> found;
  clusters.for_each([&](std::size_t c) { found.push_back(c); });
  ASSERT_EQ(found.size(), 2u);
  EXPECT_EQ(clusters.heaviest(), found[1]);
  EXPECT_NEAR(clusters.weight(found[0]), 0.30, 1e-12);
  EXPECT_NEAR(clusters.weight(found[1]), 0.70, 1e-12);
  const Pose wrapped = clusters.centre(found[0]);  // headings either side of +-pi
  EXPECT_NEAR(wrapped(0), 1.0, 1e-9);
  EXPECT_NEAR(std::abs(wrap(wrapped(2) - (std::numbers::pi - 0.01))), 0.0, 1e-9);
  Pose mean;
  Eigen::Matrix3d covariance;
  clusters.moments(p, found[1], mean, covariance);
  EXPECT_NEAR(mean(0), 6.0, 1e-9);
  EXPECT_NEAR(mean(2), 0.5, 1e-9);
  EXPECT_GT(covariance(0, 0), 0.0);
  EXPECT_LT(covariance(0, 0), 0.01);
}

TEST(Particles, TheStableModeKeepsItsPlaceUntilARivalSettles) {
  // The belief at (1, 2) and a recovery's guesses at (6, 2): the guesses outweigh it 0.6 to 0.4.
  // The reported mode stays at (1, 2) for switch_updates - 1 updates, and moves on the next.
  const StableMode::Settings settings{3, 0.9};
  StableMode mode(settings);
  PoseBins bins(0.5, 10.0 * std::numbers::pi / 180.0);
  ParticleSet split;
  add_group(split, 40, 1.0, 2.0, 0.0, 0.01);
  add_group(split, 60, 6.0, 2.0, 0.0, 0.01);
  ParticleSet belief;
  add_group(belief, 100, 1.0, 2.0, 0.0, 0.01);
  mode.update(belief, belief.size(), bins, std::nullopt);
  EXPECT_NEAR(mode.mean()(0), 1.0, 1e-9);
  for (int k = 1; k < settings.switch_updates; ++k) {
    mode.update(split, split.size(), bins, mode.mean());
    EXPECT_NEAR(mode.mean()(0), 1.0, 1e-9) << "update " << k;
    // Unsure while the rival stands: its particles widen the covariance about the belief.
    EXPECT_GT(mode.covariance()(0, 0), 0.6 * 25.0 * 0.9);
  }
  mode.update(split, split.size(), bins, mode.mean());
  EXPECT_NEAR(mode.mean()(0), 6.0, 1e-9);
  // A rival with nine tenths of the two's weight wins at once.
  StableMode quick(settings);
  quick.update(belief, belief.size(), bins, std::nullopt);
  ParticleSet overwhelming;
  add_group(overwhelming, 5, 1.0, 2.0, 0.0, 0.01);
  add_group(overwhelming, 95, 6.0, 2.0, 0.0, 0.01);
  quick.update(overwhelming, overwhelming.size(), bins, quick.mean());
  EXPECT_NEAR(quick.mean()(0), 6.0, 1e-9);
  // Nothing left where the belief was: its pose is held (whatever share a rival takes in one
  // update) until a rival has been the heaviest, in one place, for switch_updates updates; a
  // rival that moves starts the count again.
  StableMode held(settings);
  held.update(belief, belief.size(), bins, std::nullopt);
  const auto elsewhere = [](double x) {
    ParticleSet p;
    add_group(p, 90, x, 2.0, 0.0, 0.01);
    add_group(p, 10, x, 8.0, 0.0, 0.01);
    return p;
  };
  held.update(elsewhere(6.0), 100, bins, held.mean());
  EXPECT_NEAR(held.mean()(0), 1.0, 1e-9);
  held.update(elsewhere(11.0), 100, bins, held.mean());  // the rival moved: count from one
  EXPECT_NEAR(held.mean()(0), 1.0, 1e-9);
  held.update(elsewhere(11.0), 100, bins, held.mean());
  EXPECT_NEAR(held.mean()(0), 1.0, 1e-9);
  held.update(elsewhere(11.0), 100, bins, held.mean());
  EXPECT_NEAR(held.mean()(0), 11.0, 1e-9);
  EXPECT_NEAR(held.mean()(1), 2.0, 1e-9);
}

}  // namespace
}  // namespace locsim::sdk
