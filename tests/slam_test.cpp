// Paper 001's pieces in the SDK: the landmark observation and its Jacobians against finite
// differences, the landmark EKF against the closed form, the fish swarm and particle swarm moves
// climbing a toy fitness, directed resampling keeping the board particle and the count, and the
// diversity measure.
#include <gtest/gtest.h>

#include <locsim/slam.hpp>
#include <locsim/swarm.hpp>
#include <random>
#include <set>

namespace {

namespace sdk = locsim::sdk;

TEST(LandmarkObservation, JacobiansMatchFiniteDifferences) {
  std::mt19937 random(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  constexpr double kStep = 1e-6;
  for (int trial = 0; trial < 50; ++trial) {
    const sdk::Pose x(5 * u(random), 5 * u(random), 3 * u(random));
    const Eigen::Vector2d m(x(0) + 2 + 8 * (u(random) + 1), x(1) + 10 * u(random));
    const sdk::RangeBearing h = sdk::observe_landmark(x, m);
    EXPECT_TRUE(h.z.isApprox(sdk::range_bearing(x, m), 1e-12));
    const auto difference = [](Eigen::Vector2d d) {
      d(1) = sdk::wrap(d(1));
      return d / (2 * kStep);
    };
    for (int j = 0; j < 3; ++j) {
      sdk::Pose up = x, down = x;
      up(j) += kStep, down(j) -= kStep;
      const Eigen::Vector2d numeric =
          difference(sdk::observe_landmark(up, m).z - sdk::observe_landmark(down, m).z);
      EXPECT_LT((numeric - h.h_pose.col(j)).norm(), 1e-6) << "pose column " << j;
    }
    for (int j = 0; j < 2; ++j) {
      const Eigen::Vector2d step = Eigen::Vector2d::Unit(j) * kStep;
      const Eigen::Vector2d numeric =
          difference(sdk::observe_landmark(x, m + step).z - sdk::observe_landmark(x, m - step).z);
      EXPECT_LT((numeric - h.h_landmark.col(j)).norm(), 1e-6) << "landmark column " << j;
    }
    // The inverse observation returns the landmark, and its Jacobian the finite differences.
    Eigen::Matrix2d dm_dz;
    EXPECT_TRUE(sdk::landmark_from(x, h.z, &dm_dz).isApprox(m, 1e-9));
    for (int j = 0; j < 2; ++j) {
      const Eigen::Vector2d step = Eigen::Vector2d::Unit(j) * kStep;
      const Eigen::Vector2d numeric =
          (sdk::landmark_from(x, h.z + step) - sdk::landmark_from(x, h.z - step)) / (2 * kStep);
      EXPECT_LT((numeric - dm_dz.col(j)).norm(), 1e-6) << "dm/dz column " << j;
    }
  }
}

TEST(LandmarkEkf, UpdateMatchesTheClosedForm) {
  // Robot at the origin facing +x, landmark believed at (5, 0) with P = p I. There
  // H = d(r, phi)/dm = diag(1, 1/5), so S and K are diagonal and each axis is a scalar Kalman
  // filter: x' = 5 + p / (p + sr^2) (r - 5), P'xx = p sr^2 / (p + sr^2), and across the ray
  // y' = (p / 5) / (p / 25 + sphi^2) phi.
  const double p = 0.04, sr = 0.1, sphi = 0.02;
  sdk::LandmarkEstimate landmark;
  landmark.mean = {5.0, 0.0};
  landmark.covariance = Eigen::Matrix2d::Identity() * p;
  landmark.observations = 1;
  const Eigen::Matrix2d r = Eigen::Vector2d(sr * sr, sphi * sphi).asDiagonal();
  const Eigen::Vector2d z(5.3, 0.01);
  const sdk::LandmarkInnovation innovation =
      sdk::landmark_innovation(landmark, sdk::Pose::Zero(), z, r);
  EXPECT_NEAR(innovation.nu(0), 0.3, 1e-12);
  EXPECT_NEAR(innovation.nu(1), 0.01, 1e-12);
  const double s_r = p + sr * sr, s_phi = p / 25 + sphi * sphi;
  EXPECT_NEAR(innovation.mahalanobis2, 0.09 / s_r + 1e-4 / s_phi, 1e-9);
  EXPECT_NEAR(innovation.log_likelihood(),
              -0.5 * (0.09 / s_r + 1e-4 / s_phi) - std::log(2 * M_PI) - 0.5 * std::log(s_r * s_phi),
              1e-9);
  sdk::update_landmark(landmark, innovation, r);
  EXPECT_NEAR(landmark.mean.x(), 5.0 + p / s_r * 0.3, 1e-9);
  EXPECT_NEAR(landmark.mean.y(), (p / 5) / s_phi * 0.01, 1e-9);
  EXPECT_NEAR(landmark.covariance(0, 0), p * sr * sr / s_r, 1e-12);
  EXPECT_NEAR(landmark.covariance(1, 1), p * (25 * sphi * sphi) / (p + 25 * sphi * sphi), 1e-12);
  EXPECT_NEAR(landmark.covariance(0, 1), 0.0, 1e-12);
  EXPECT_EQ(landmark.observations, 2);
}

/// A toy fitness: one peak at the target pose, exp(-d^2 / 2 (0.3 m)^2) on the scaled distance.
double peak(const sdk::Pose& pose) {
  const sdk::Pose target(1.0, -2.0, 0.5);
  return std::exp(-sdk::pose_difference(pose, target, 1.0).squaredNorm() / (2 * 0.09));
}

std::vector<sdk::Pose> scattered(sdk::Random& random) {
  std::vector<sdk::Pose> poses(10);
  for (sdk::Pose& p : poses)
    p = {1.0 + random.normal(0.3), -2.0 + random.normal(0.3), 0.5 + random.normal(0.3)};
  return poses;
}

double mean_fitness(const std::vector<sdk::Pose>& poses) {
  double sum = 0.0;
  for (const sdk::Pose& p : poses) sum += peak(p);
  return sum / static_cast<double>(poses.size());
}

TEST(FishSwarm, MovesClimbTheFitness) {
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    sdk::Random random(seed);
    std::vector<sdk::Pose> fish = scattered(random);
    const double before = mean_fitness(fish);
    sdk::AfsaDef def;
    def.visual = 0.3, def.step = 0.15, def.iterations = 5;
    const long evaluations = sdk::afsa_move(
        fish, [](std::size_t, const sdk::Pose& p) { return peak(p); }, def, random);
    EXPECT_GT(evaluations, 10 * 5);
    EXPECT_GT(mean_fitness(fish), before + 0.1) << "seed " << seed;
  }
}

TEST(FishSwarm, FishStayWhereNothingIsBetter) {
  // A particle with no associated detection has no fitness gradient: it must not random-walk
  // (the paper's fish always move; in a filter that scatters the particles).
  sdk::Random random(9);
  std::vector<sdk::Pose> fish = scattered(random);
  const std::vector<sdk::Pose> start = fish;
  sdk::afsa_move(
      fish, [](std::size_t, const sdk::Pose&) { return 0.0; }, sdk::AfsaDef{}, random);
  for (std::size_t i = 0; i < fish.size(); ++i) EXPECT_EQ(fish[i], start[i]);
}

TEST(ParticleSwarm, MovesClimbTheFitnessAndNeverEndBelowTheStart) {
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    sdk::Random random(seed);
    std::vector<sdk::Pose> poses = scattered(random);
    const std::vector<sdk::Pose> start = poses;
    sdk::PsoDef def;
    def.iterations = 5;
    sdk::pso_move(
        poses, [](std::size_t, const sdk::Pose& p) { return peak(p); }, def, random);
    for (std::size_t i = 0; i < poses.size(); ++i) EXPECT_GE(peak(poses[i]), peak(start[i]));
    EXPECT_GT(mean_fitness(poses), mean_fitness(start) + 0.1) << "seed " << seed;
  }
}

TEST(DirectedResampling, KeepsTheBoardParticleAndTheCount) {
  // Particles are their own index; 7 and 8 carry most weight.
  for (const std::size_t n : {2u, 9u, 10u}) {
    std::vector<int> particles(n);
    std::vector<double> weights(n, 0.01);
    for (std::size_t i = 0; i < n; ++i) particles[i] = static_cast<int>(i);
    weights[n - 1] = 0.5, weights[n - 2] = 0.3;
    const int board = 100, drawn = 200;
    sdk::Random random(4);
    sdk::directed_resample(
        particles, weights, board, [&](sdk::Random&) { return drawn; }, random);
    ASSERT_EQ(particles.size(), n);
    ASSERT_EQ(weights.size(), n);
    for (const double w : weights) EXPECT_DOUBLE_EQ(w, 1.0 / static_cast<double>(n));
    EXPECT_EQ(std::count(particles.begin(), particles.end(), board), 1);  // the board itself
    EXPECT_EQ(std::count(particles.begin(), particles.end(), drawn), static_cast<long>(n / 2) - 1);
    // The rest are drawn from the heavier half only.
    const std::size_t heavy_from = n / 2;
    for (const int p : particles) {
      if (p == board || p == drawn) continue;
      EXPECT_GE(static_cast<std::size_t>(p), heavy_from) << "a light particle survived";
    }
  }
}

TEST(Diversity, IsTheMeanHammingDistanceOfTheQuantisedPoses) {
  // Three particles: a and b share x and y cells but not heading (1 differs), c differs from
  // both in all three: (1 + 3 + 3) / 3 pairs.
  const std::vector<sdk::Pose> poses = {{0.001, 0.001, 0.0}, {0.002, 0.003, 0.1}, {1.0, 1.0, 1.0}};
  EXPECT_NEAR(sdk::hamming_diversity(poses, 0.01, 0.01), 7.0 / 3.0, 1e-12);
  EXPECT_EQ(sdk::hamming_diversity({poses[0], poses[0]}, 0.01, 0.01), 0.0);
}

}  // namespace
