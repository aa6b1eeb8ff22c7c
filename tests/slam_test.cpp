// Paper 001's pieces in the SDK: the landmark observation and its Jacobians against finite
// differences, the landmark EKF against the closed form, the fish swarm and particle swarm moves
// climbing a toy fitness, directed resampling keeping the board particle and the count, and the
// diversity measure.
#include <gtest/gtest.h>

#include <locsim/numeric_jacobian.hpp>
#include <locsim/slam.hpp>
#include <locsim/swarm.hpp>
#include <random>
#include <set>

namespace {

namespace sdk = locsim::sdk;

TEST(LandmarkObservation, JacobiansMatchFiniteDifferences) {
  std::mt19937 random(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  // Per entry, stricter than the 1e-6 per column these checks had; the differences err by at most
  // 3e-9 here.
  constexpr sdk::JacobianTolerance kTolerance{.abs_tol = 2e-8, .rel_tol = 1e-8};
  const Eigen::Matrix2d r = Eigen::Vector2d(0.01 * 0.01, 0.002 * 0.002).asDiagonal();
  for (int trial = 0; trial < 50; ++trial) {
    const sdk::Pose x(5 * u(random), 5 * u(random), 3 * u(random));
    const Eigen::Vector2d m(x(0) + 2 + 8 * (u(random) + 1), x(1) + 10 * u(random));
    const sdk::RangeBearing h = sdk::observe_landmark(x, m);
    EXPECT_TRUE(h.z.isApprox(sdk::range_bearing(x, m), 1e-12));
    const auto from_pose = [&](const sdk::Pose& p) { return sdk::observe_landmark(p, m).z; };
    const auto from_landmark = [&](const Eigen::Vector2d& l) {
      return sdk::observe_landmark(x, l).z;
    };
    const sdk::JacobianCheck pose =
        sdk::check_jacobian(h.h_pose, from_pose, x, sdk::WrapAngles{1}, kTolerance);
    EXPECT_TRUE(pose.ok) << "h_pose, trial " << trial << ": " << pose.report();
    const sdk::JacobianCheck landmark =
        sdk::check_jacobian(h.h_landmark, from_landmark, m, sdk::WrapAngles{1}, kTolerance);
    EXPECT_TRUE(landmark.ok) << "h_landmark, trial " << trial << ": " << landmark.report();

    // The inverse observation returns the landmark, and its Jacobian the finite differences (a
    // position: nothing to wrap).
    Eigen::Matrix2d dm_dz;
    EXPECT_TRUE(sdk::landmark_from(x, h.z, &dm_dz).isApprox(m, 1e-9));
    const auto seen_at = [&](const Eigen::Vector2d& z) { return sdk::landmark_from(x, z); };
    const sdk::JacobianCheck inverse =
        sdk::check_jacobian(dm_dz, seen_at, h.z, sdk::Subtract{}, kTolerance);
    EXPECT_TRUE(inverse.ok) << "dm/dz, trial " << trial << ": " << inverse.report();

    // The innovation carries the EKF's H = d h / d m: nu = z - h(m), so d nu / d m = -H. A
    // measurement off the prediction, so that nu is not zero (no random draw: the trials above
    // keep their poses and landmarks).
    sdk::LandmarkEstimate estimate;
    estimate.mean = m;
    const Eigen::Vector2d z = h.z + Eigen::Vector2d(0.1, 0.05);
    const auto innovation_at = [&](const Eigen::Vector2d& mean) {
      sdk::LandmarkEstimate moved = estimate;
      moved.mean = mean;
      return sdk::landmark_innovation(moved, x, z, r).nu;
    };
    const sdk::LandmarkInnovation innovation = sdk::landmark_innovation(estimate, x, z, r);
    const sdk::JacobianCheck innovation_h =
        sdk::check_jacobian(-innovation.h, innovation_at, m, sdk::WrapAngles{1}, kTolerance);
    EXPECT_TRUE(innovation_h.ok) << "innovation h, trial " << trial << ": "
                                 << innovation_h.report();
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
