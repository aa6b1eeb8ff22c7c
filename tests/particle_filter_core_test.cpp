// The SDK's particle-filter skeleton (locsim/particle_filter.hpp) against its definitions: what
// every particle filter of locsim (and a plugin author's) relies on.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <vector>

#include "locsim/particle_filter.hpp"
#include "locsim/swarm.hpp"

namespace locsim::sdk {
namespace {

/// A 10 x 6 grid of 0.5 m cells whose left half and one cell of the right half are walls.
struct HalfWalledGrid {
  std::vector<std::uint8_t> cells = std::vector<std::uint8_t>(60, 0);
  locsim_occupancy_grid grid{-1.0, 2.0, 0.5, 10, 6, nullptr};
  HalfWalledGrid() {
    for (int row = 0; row < 6; ++row)
      for (int col = 0; col < 5; ++col) cells[static_cast<std::size_t>(row * 10 + col)] = 100;
    cells[3 * 10 + 7] = 100;
    grid.cells = cells.data();
  }
};

TEST(ParticleFilterCore, FreeSpaceSamplesEveryFreeCellAlikeAndNoWall) {
  const HalfWalledGrid g;
  const FreeSpace free(g.grid);
  ASSERT_EQ(free.free_cells(), 29u);
  Random random(3);
  std::vector<int> hits(60, 0);
  constexpr int kDraws = 290000;
  double heading_sum = 0.0;
  for (int k = 0; k < kDraws; ++k) {
    const Pose p = free.sample(random);
    const int col = static_cast<int>(std::floor((p(0) - g.grid.origin_x) / 0.5));
    const int row = static_cast<int>(std::floor((p(1) - g.grid.origin_y) / 0.5));
    ASSERT_TRUE(col >= 0 && col < 10 && row >= 0 && row < 6) << p.transpose();
    ASSERT_EQ(g.cells[static_cast<std::size_t>(row * 10 + col)], 0) << "a wall: " << p.transpose();
    ++hits[static_cast<std::size_t>(row * 10 + col)];
    ASSERT_GE(p(2), -std::numbers::pi);
    ASSERT_LT(p(2), std::numbers::pi);
    heading_sum += p(2);
  }
  // 10000 expected per free cell: 5 sigma is 500.
  for (std::size_t c = 0; c < hits.size(); ++c) {
    if (g.cells[c] == 0) {
      EXPECT_NEAR(hits[c], 10000, 500) << "cell " << c;
    }
  }
  EXPECT_NEAR(heading_sum / kDraws, 0.0, 0.02);
  EXPECT_TRUE(FreeSpace().empty());
  EXPECT_TRUE(FreeSpace(locsim_occupancy_grid{}).empty());
}

TEST(ParticleFilterCore, FreeSpaceSaysWhereTheRobotCanBe) {
  // Open: the half-walled grid's free cells all reach its edge (no wall closes them in), so the
  // grid's extent is the geometry's, not the robot's: anywhere free, or off the grid.
  const HalfWalledGrid g;  // x in [-1, 4), y in [2, 5); walls: x < 1.5, and the cell (7, 3)
  const FreeSpace open(g.grid);
  EXPECT_FALSE(open.enclosed());
  EXPECT_TRUE(open.possible(1.6, 2.1));
  EXPECT_TRUE(open.possible(3.99, 4.99));
  EXPECT_FALSE(open.possible(1.4, 3.0));    // the left half's wall
  EXPECT_FALSE(open.possible(2.75, 3.75));  // the lone wall cell: col 7, row 3
  EXPECT_TRUE(open.possible(2.75, 3.45));   // the cell below it
  EXPECT_TRUE(open.possible(40.0, 3.0));    // off the grid
  EXPECT_FALSE(open.possible(std::nan(""), 3.0));
  EXPECT_TRUE(FreeSpace().possible(1e9, -1e9));  // no grid: nothing is known

  // Enclosed: a room whose walls are one cell in from the grid's edge (the rasterizer's margin).
  // Only the inside is possible: not the margin beyond the walls, nor off the grid.
  std::vector<std::uint8_t> cells(8 * 6, 0);
  for (int row = 0; row < 6; ++row)
    for (int col = 0; col < 8; ++col)
      if ((row == 1 || row == 4) && col >= 1 && col <= 6)
        cells[static_cast<std::size_t>(row * 8 + col)] = 100;
      else if ((col == 1 || col == 6) && row >= 1 && row <= 4)
        cells[static_cast<std::size_t>(row * 8 + col)] = 100;
  const locsim_occupancy_grid room{0.0, 0.0, 1.0, 8, 6, cells.data()};
  const FreeSpace inside(room);
  EXPECT_TRUE(inside.enclosed());
  EXPECT_EQ(inside.free_cells(), 24u + 8u);  // the margin's 24 and the room's 4 x 2
  EXPECT_TRUE(inside.possible(2.5, 2.5));
  EXPECT_TRUE(inside.possible(5.5, 3.5));
  EXPECT_FALSE(inside.possible(1.5, 2.5));   // the wall
  EXPECT_FALSE(inside.possible(0.5, 2.5));   // the margin outside the wall
  EXPECT_FALSE(inside.possible(-3.0, 2.5));  // off the grid
}

locsim_init known_start(double x, double y, double theta, double sigma_xy, double sigma_theta) {
  locsim_init init{};
  init.initial_pose_known = 1;
  init.initial_pose = {x, y, theta};
  init.initial_covariance[0] = init.initial_covariance[4] = sigma_xy * sigma_xy;
  init.initial_covariance[8] = sigma_theta * sigma_theta;
  return init;
}

TEST(ParticleFilterCore, StartsAboutAKnownPoseOrUniformOverTheFreeSpace) {
  ParticleFilter pf(20000, 11);
  pf.initialise(known_start(1.0, -2.0, 3.0, 0.2, 0.1), FreeSpace());
  const Estimate known = pf.estimate();
  EXPECT_NEAR(known.pose.x, 1.0, 0.01);
  EXPECT_NEAR(known.pose.y, -2.0, 0.01);
  EXPECT_NEAR(wrap(known.pose.theta - 3.0), 0.0, 0.005);  // the circular mean across +-pi
  EXPECT_NEAR(std::sqrt(known.covariance(0, 0)), 0.2, 0.005);
  EXPECT_NEAR(std::sqrt(known.covariance(2, 2)), 0.1, 0.0025);
  for (const double w : pf.particles().weight) ASSERT_EQ(w, 1.0 / 20000);

  const HalfWalledGrid g;
  locsim_init global{};
  pf.initialise(global, FreeSpace(g.grid));
  for (std::size_t i = 0; i < pf.size(); ++i) ASSERT_GE(pf.particles().x[i], 1.5);  // right half
  try {
    pf.initialise(global, FreeSpace());
    FAIL() << "a global start without free space was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("occupancy grid"), std::string::npos) << e.what();
  }
}

TEST(ParticleFilterCore, ScatterDrawsTheGivenCovariance) {
  ParticleFilter pf(1, 5);
  Eigen::Matrix3d covariance;
  covariance << 0.04, 0.01, 0.0, 0.01, 0.09, 0.002, 0.0, 0.002, 0.01;
  pf.scatter(Pose(2.0, 1.0, 0.5), covariance, 50000);
  pf.equalise_weights();
  ASSERT_EQ(pf.size(), 50000u);
  const Estimate e = pf.estimate();
  EXPECT_NEAR(e.pose.x, 2.0, 0.005);
  EXPECT_NEAR(e.pose.y, 1.0, 0.005);
  EXPECT_NEAR(e.pose.theta, 0.5, 0.002);
  EXPECT_LT((e.covariance - covariance).cwiseAbs().maxCoeff(), 0.003) << e.covariance;
}

TEST(ParticleFilterCore, WeighingMultipliesThePriorAndReportsTheMeasurementsLikelihood) {
  ParticleFilter pf(4, 1);
  pf.place_all(Pose::Zero());
  // Equal prior: the likelihood under the belief is the mean likelihood, whatever its scale (a
  // thousand detections' worth of log likelihood does not underflow).
  const std::vector<double> log_p = {-1000.0, -1001.0, -1002.0, -1000.5};
  const Evidence equal = pf.weigh(log_p, 2);
  double mean = 0.0, mean_head = 0.0;
  for (std::size_t i = 0; i < 4; ++i) mean += std::exp(log_p[i] + 1000.0) / 4.0;
  for (std::size_t i = 0; i < 2; ++i) mean_head += std::exp(log_p[i] + 1000.0) / 2.0;
  EXPECT_NEAR(equal.log_likelihood, std::log(mean) - 1000.0, 1e-12);
  EXPECT_NEAR(equal.log_likelihood_head, std::log(mean_head) - 1000.0, 1e-12);
  const std::vector<double>& w = pf.particles().weight;
  for (std::size_t i = 0; i < 4; ++i)
    EXPECT_NEAR(w[i], std::exp(log_p[i] + 1000.0) / 4.0 / mean, 1e-12);
  double sum_sq = 0.0;
  for (const double v : w) sum_sq += v * v;
  EXPECT_NEAR(equal.n_eff, 1.0 / sum_sq, 1e-12);

  // Unequal prior (no resampling in between): p(z) = sum_i w_i p_i, the posterior w_i p_i / p(z).
  const std::vector<double> prior = w;
  const std::vector<double> log_q = {-2.0, -0.5, -1.0, -3.0};
  const Evidence carried = pf.weigh(log_q);
  double evidence = 0.0;
  for (std::size_t i = 0; i < 4; ++i) evidence += prior[i] * std::exp(log_q[i]);
  EXPECT_NEAR(carried.log_likelihood, std::log(evidence), 1e-12);
  for (std::size_t i = 0; i < 4; ++i)
    EXPECT_NEAR(w[i], prior[i] * std::exp(log_q[i]) / evidence, 1e-12);
  EXPECT_THROW(pf.weigh({0.0}), std::invalid_argument);
}

TEST(ParticleFilterCore, ResamplingCarriesTheFiltersOwnDataWithItsParticles) {
  for (const Resampler resampler : {Resampler::kLowVariance, Resampler::kRoulette}) {
    ParticleFilter pf(1000, 9, resampler);
    std::vector<int> tag(1000);
    std::vector<std::string> name(1000);
    for (std::size_t i = 0; i < 1000; ++i) {
      pf.set(i, Pose(static_cast<double>(i), 0.0, 0.0));
      tag[i] = static_cast<int>(i);
      name[i] = std::to_string(i);
    }
    // Only the particles 100..199 have weight.
    std::vector<double> log_p(1000, -1e9);
    for (std::size_t i = 100; i < 200; ++i) log_p[i] = 0.0;
    pf.weigh(log_p);
    pf.resample(tag, name);
    ASSERT_EQ(pf.size(), 1000u);
    for (std::size_t i = 0; i < 1000; ++i) {
      ASSERT_EQ(pf.particles().x[i], static_cast<double>(tag[i])) << i;
      ASSERT_EQ(name[i], std::to_string(tag[i]));
      ASSERT_GE(tag[i], 100);
      ASSERT_LT(tag[i], 200);
      ASSERT_EQ(pf.particles().weight[i], 1.0 / 1000);
    }
  }
  EXPECT_THROW(resampler_from("systematic"), std::invalid_argument);
  EXPECT_EQ(resampler_from("roulette"), Resampler::kRoulette);
}

TEST(ParticleFilterCore, TheEstimateFollowsTheOdometrySinceTheMarkAndCanLeaveOutTheTail) {
  ParticleFilter pf(4, 2);
  pf.place_all(Pose(1.0, 1.0, std::numbers::pi / 2));
  pf.set(3, Pose(50.0, 50.0, 0.0));  // a fresh guess at the tail
  locsim_odometry odometry{};
  odometry.odom_pose = {10.0, 0.0, 0.0};
  pf.odometry().observe(odometry);  // the first sets the mark
  EXPECT_EQ(pf.odometry().mark(), Pose(10.0, 0.0, 0.0));
  odometry.odom_pose = {11.0, 0.0, 0.5};  // 1 m forward and a turn, in the odometry's frame
  pf.odometry().observe(odometry);
  const OdometryDelta d = pf.odometry().since_mark();
  EXPECT_NEAR(d.trans, 1.0, 1e-12);
  const Estimate e = pf.estimate(3);  // the particles at (1, 1) facing +y moved 1 m along +y
  EXPECT_NEAR(e.pose.x, 1.0, 1e-12);
  EXPECT_NEAR(e.pose.y, 2.0, 1e-12);
  EXPECT_NEAR(e.pose.theta, std::numbers::pi / 2 + 0.5, 1e-12);
  EXPECT_GT(pf.estimate().pose.x, 10.0);  // with the tail
  pf.odometry().mark_now();
  EXPECT_NEAR(pf.estimate(3).pose.y, 1.0, 1e-12);
  std::vector<locsim_pose2> poses;
  std::vector<double> weights;
  pf.export_particles(poses, weights);
  ASSERT_EQ(poses.size(), 4u);
  EXPECT_EQ(poses[3].x, 50.0);
  EXPECT_EQ(weights[0], 0.25);
}

/// Feeds `follower` `seconds` of a robot whose wheels report `wheels` (v [m/s], omega [rad/s])
/// while its gyro reads `gyro_radps` (nullopt: no IMU): odometry at 50 Hz, the IMU at 100 Hz,
/// from t0_s on; the wheels' odometry pose starts at `odom` and is left where they end.
void drive(OdometryFollower& follower, Pose& odom, double t0_s, double seconds, double v_mps,
           double omega_radps, std::optional<double> gyro_radps) {
  const int steps = static_cast<int>(std::lround(seconds * 100.0));
  for (int k = 0; k <= steps; ++k) {
    const double t_s = t0_s + k * 0.01;
    if (gyro_radps) {
      locsim_imu imu{};
      imu.yaw_rate_radps = *gyro_radps;
      follower.observe_imu(t_s, imu);
    }
    if (k % 2 != 0) continue;
    if (k > 0) odom = compose(odom, Pose(v_mps * 0.02, 0.0, omega_radps * 0.02));
    locsim_odometry reading{};
    reading.odom_pose = {odom(0), odom(1), odom(2)};
    follower.observe(t_s, reading);
  }
}

TEST(ParticleFilterCore, TheGyroTurnsTheOdometryAndTheWheelsExtraTurnIsSlip) {
  // Wheels spinning in place against a wall (they say 1 rad/s, the gyro nothing): no turn, and
  // the two seconds' 2 rad are slip.
  OdometryFollower stuck;
  Pose odom(3.0, 4.0, 0.5);
  drive(stuck, odom, 0.0, 2.0, 0.0, 1.0, 0.0);
  EXPECT_NEAR(stuck.now()(2), 0.5, 1e-12);
  EXPECT_NEAR(odom(2), 2.5, 1e-9);
  const OdometryDelta d = stuck.since_mark();
  EXPECT_NEAR(d.trans, 0.0, 1e-12);
  EXPECT_NEAR(d.rot1 + d.rot2, 0.0, 1e-12);
  EXPECT_NEAR(d.slip_rad, 2.0, 1e-9);
  stuck.mark_now();
  EXPECT_EQ(stuck.since_mark().slip_rad, 0.0);

  // A push turns the robot at 0.2 rad/s while its wheels drive straight at 0.5 m/s: the
  // wheels' metre-long second bends into the gyro's arc.
  OdometryFollower pushed;
  odom = Pose::Zero();
  drive(pushed, odom, 0.0, 1.0, 0.5, 0.0, 0.2);
  EXPECT_NEAR(pushed.now()(2), 0.2, 1e-9);
  EXPECT_NEAR(pushed.now()(0), 0.5 * std::sin(0.2) / 0.2, 1e-6);
  EXPECT_NEAR(pushed.now()(1), 0.5 * (1.0 - std::cos(0.2)) / 0.2, 1e-6);
  EXPECT_NEAR(pushed.since_mark().slip_rad, 0.2, 1e-9);

  // A slip widens the translation's noise as alpha4 does a turn of that size.
  const OdometryNoise noise;
  OdometryDelta straight{0.0, 1.0, 0.0}, slipped = straight;
  slipped.slip_rad = 0.5;
  EXPECT_NEAR(motion_spread(slipped, noise).trans - motion_spread(straight, noise).trans,
              noise.alpha4 * 0.5, 1e-12);
  EXPECT_EQ(motion_spread(slipped, noise).rot1, motion_spread(straight, noise).rot1);
}

TEST(ParticleFilterCore, WithoutAGyroTheOdometryIsTheWheelsExactly) {
  // No IMU, the gyro turned off, or an IMU that fell silent: the wheels' own odometry poses, to
  // the bit (a filter without a gyro keeps its results).
  for (const bool imu : {false, true}) {
    OdometryFollower follower;
    if (imu) follower.use_gyro(false);
    Pose odom(1.0, 2.0, 0.3);
    drive(follower, odom, 0.0, 3.0, 0.4, 0.7, imu ? std::optional<double>(0.0) : std::nullopt);
    EXPECT_EQ(follower.now(), odom) << (imu ? "gyro off" : "no IMU");
    EXPECT_EQ(follower.since_mark().slip_rad, 0.0);
  }
  OdometryFollower silent;
  Pose odom = Pose::Zero();
  drive(silent, odom, 0.0, 1.0, 0.0, 1.0, 0.0);  // the gyro holds the heading
  const double heading = silent.now()(2);
  EXPECT_NEAR(heading, 0.0, 1e-12);
  drive(silent, odom, 1.5, 1.0, 0.0, 1.0, std::nullopt);  // then the IMU stops: the wheels turn
  EXPECT_NEAR(silent.now()(2), 1.0, 1e-9);
}

TEST(ParticleFilterCore, LikelihoodAveragesSayWhenTheBeliefStoppedExplainingTheMeasurements) {
  LikelihoodAverages averages{0.001, 0.1};
  averages.update(0.5);
  EXPECT_EQ(averages.w_slow, 0.5);
  EXPECT_EQ(averages.w_fast, 0.5);
  EXPECT_EQ(averages.deficit(), 0.0);
  for (int k = 0; k < 20; ++k) averages.update(0.05);  // a kidnapping: the fit collapses
  EXPECT_GT(averages.deficit(), 0.5);
  EXPECT_LT(averages.deficit(0.1), 0.0);  // a lower level waits for a deeper fall
  averages.reset();
  averages.update(0.05);
  EXPECT_EQ(averages.deficit(), 0.0);
}

TEST(ParticleFilterCore, DirectedResamplingKeepsTheHeavierHalfAndLeavesTheRestToTheBoard) {
  Random random(4);
  const std::vector<double> weights = {0.01, 0.3, 0.02, 0.25, 0.03, 0.2, 0.04, 0.15};
  std::vector<std::size_t> chosen;
  directed_resample_indices(weights, random, chosen);
  ASSERT_EQ(chosen.size(), 4u);
  for (const std::size_t k : chosen) EXPECT_TRUE(k == 1 || k == 3 || k == 5 || k == 7) << k;
}

TEST(ParticleFilterCore, TheOdometryIsBroughtOnToAScansTimeAndStillAddsUp) {
  // Odometry once a second on an arc (0.8 m/s, 0.3 rad/s), a scan half a second after a
  // reading: now() is the arc's pose at the scan, marked there; the next reading's motion since
  // the mark is the rest of the arc, so the two add up to the odometry's second.
  OdometryFollower follower;
  Pose odom(1.0, 2.0, 0.3);
  locsim_odometry reading{};
  const auto observe = [&](double t_s) {
    reading.odom_pose = {odom(0), odom(1), odom(2)};
    follower.observe(t_s, reading);
  };
  observe(0.0);
  follower.advance_to(0.5);  // no step yet: nothing to extrapolate
  EXPECT_EQ(follower.now(), odom);
  odom = advance_by_velocity(odom, 0.8, 0.3, 1.0);
  observe(1.0);
  const Pose at_reading = odom;
  follower.advance_to(1.5);
  EXPECT_LT((follower.now() - advance_by_velocity(at_reading, 0.8, 0.3, 0.5)).norm(), 1e-12);
  follower.advance_to(1.2);  // never back
  EXPECT_LT((follower.now() - advance_by_velocity(at_reading, 0.8, 0.3, 0.5)).norm(), 1e-12);
  const Pose at_scan = follower.now();
  follower.mark_now();
  odom = advance_by_velocity(odom, 0.8, 0.3, 1.0);
  observe(2.0);
  EXPECT_EQ(follower.now(), odom);  // the odometry's own pose again
  EXPECT_LT((compose(at_scan, between(follower.mark(), follower.now())) - odom).norm(), 1e-12);
  EXPECT_NEAR(follower.since_mark().trans, 0.8 * 0.5 * sinc(0.075), 1e-12);
  // Odometry that stops coming is not driven on: one interval past the last reading at most.
  follower.advance_to(10.0);
  EXPECT_LT((follower.now() - advance_by_velocity(odom, 0.8, 0.3, 1.0)).norm(), 1e-12);
}

}  // namespace
}  // namespace locsim::sdk
