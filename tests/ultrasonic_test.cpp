// Paper 003's ultrasonic geometry in the SDK: trilateration from three or more beacons recovers
// exact positions (least squares with more), and two receivers give the robot's pose.
#include <gtest/gtest.h>

#include <locsim/models.hpp>
#include <random>

#include "run_support.hpp"

namespace locsim {
namespace {

TEST(Trilateration, RecoversExactPositionsFromThreeOrMoreBeacons) {
  // Paper 003's simulation beacons, and a fourth.
  const std::vector<Eigen::Vector2d> beacons = {
      {5.0, 41.0}, {35.0, 10.0}, {53.0, 30.0}, {20.0, 20.0}};
  std::mt19937 random(5);
  std::uniform_real_distribution<double> coordinate(0.0, 60.0);
  for (int trial = 0; trial < 100; ++trial) {
    const Eigen::Vector2d truth(coordinate(random), coordinate(random));
    for (const std::size_t used : {3u, 4u}) {
      std::vector<Eigen::Vector2d> anchors(beacons.begin(), beacons.begin() + used);
      std::vector<double> ranges;
      for (const auto& a : anchors) ranges.push_back((truth - a).norm());
      const auto p = sdk::trilaterate(anchors, ranges);
      ASSERT_TRUE(p.has_value());
      EXPECT_NEAR((*p - truth).norm(), 0.0, 1e-8) << truth.transpose() << " with " << used;
    }
  }
  // Noisy ranges, four beacons: least squares lands within the noise.
  std::normal_distribution<double> noise(0.0, 0.05);
  const Eigen::Vector2d truth(30.0, 30.0);
  std::vector<double> ranges;
  for (const auto& a : beacons) ranges.push_back((truth - a).norm() + noise(random));
  EXPECT_LT((*sdk::trilaterate(beacons, ranges) - truth).norm(), 0.15);
  // Too few or collinear beacons: no answer.
  EXPECT_FALSE(sdk::trilaterate({{0, 0}, {1, 0}}, {1.0, 1.0}).has_value());
  EXPECT_FALSE(sdk::trilaterate({{0, 0}, {1, 0}, {2, 0}}, {1.0, 1.0, 1.0}).has_value());
}

TEST(Trilateration, TwoReceiversGiveThePose) {
  // Receivers A1 (left) and A2 (right) at (0, +-0.15) in the robot frame, found in the world.
  std::mt19937 random(9);
  std::uniform_real_distribution<double> coordinate(-10.0, 10.0), heading(-3.14, 3.14);
  const Eigen::Vector2d a1(0.0, 0.15), a2(0.0, -0.15);
  for (int trial = 0; trial < 100; ++trial) {
    const sdk::Pose truth(coordinate(random), coordinate(random), heading(random));
    const auto world = [&](const Eigen::Vector2d& r) {
      const sdk::Pose p = sdk::compose(truth, sdk::Pose(r.x(), r.y(), 0.0));
      return Eigen::Vector2d(p(0), p(1));
    };
    const sdk::Pose pose = sdk::align_two_points(world(a1), world(a2), a1, a2);
    EXPECT_NEAR(pose(0), truth(0), 1e-12);
    EXPECT_NEAR(pose(1), truth(1), 1e-12);
    EXPECT_NEAR(sdk::wrap(pose(2) - truth(2)), 0.0, 1e-12);
    // The paper's formula for receivers on the robot's y axis: yaw = atan((x_A2 - x_A1) /
    // (y_A1 - y_A2)), read with atan2 so that it holds in every quadrant.
    const Eigen::Vector2d w1 = world(a1), w2 = world(a2);
    EXPECT_NEAR(sdk::wrap(std::atan2(w2.x() - w1.x(), w1.y() - w2.y()) - truth(2)), 0.0, 1e-12);
  }
  // Receivers off the robot's origin: the pose is still the robot's.
  const Eigen::Vector2d b1(0.1, 0.2), b2(0.1, -0.1);
  const sdk::Pose truth(2.0, -1.0, 0.7);
  const auto w = [&](const Eigen::Vector2d& r) {
    const sdk::Pose p = sdk::compose(truth, sdk::Pose(r.x(), r.y(), 0.0));
    return Eigen::Vector2d(p(0), p(1));
  };
  EXPECT_TRUE(sdk::align_two_points(w(b1), w(b2), b1, b2).isApprox(truth, 1e-12));
}

TEST(ImuMotion, JacobiansMatchFiniteDifferences) {
  std::mt19937 random(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  constexpr double kStep = 1e-6;
  for (int trial = 0; trial < 50; ++trial) {
    sdk::ImuState s;
    s << 5 * u(random), 5 * u(random), u(random), u(random), 3 * u(random);
    const double a = 2 * u(random), omega = u(random), dt = 0.01 + 0.05 * (u(random) + 1);
    const Eigen::Matrix<double, 5, 5> f = sdk::imu_motion_jacobian(s, a, dt);
    const Eigen::Matrix<double, 5, 2> g = sdk::imu_noise_jacobian(s, dt);
    const auto difference = [](sdk::ImuState d) {
      d(4) = sdk::wrap(d(4));
      return d / (2 * kStep);
    };
    for (int j = 0; j < 5; ++j) {
      sdk::ImuState up = s, down = s;
      up(j) += kStep, down(j) -= kStep;
      const sdk::ImuState numeric =
          difference(sdk::imu_motion(up, a, omega, dt) - sdk::imu_motion(down, a, omega, dt));
      EXPECT_LT((numeric - f.col(j)).norm(), 1e-7) << "F column " << j;
    }
    const sdk::ImuState by_a = difference(sdk::imu_motion(s, a + kStep, omega, dt) -
                                          sdk::imu_motion(s, a - kStep, omega, dt));
    const sdk::ImuState by_omega = difference(sdk::imu_motion(s, a, omega + kStep, dt) -
                                              sdk::imu_motion(s, a, omega - kStep, dt));
    EXPECT_LT((by_a - g.col(0)).norm(), 1e-7);
    EXPECT_LT((by_omega - g.col(1)).norm(), 1e-7);
  }
}

TEST(UltrasonicEkf, TracksWithTheBeaconsAndTheImuWhilePeopleWalkThroughTheBeams) {
  // The demo world's four beacons, two receivers on the robot, people crossing the beams: the
  // paper's trilateration + IMU EKF holds the pose to about 10 cm, absolute: no drift.
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    RunOptions options;
    options.world_file = std::filesystem::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml";
    options.duration_s = 20.0;
    options.seed = seed;
    options.out_dir = testing::temp_dir("ultrasonic") / std::to_string(seed);
    options.localizers = {"ultrasonic_ekf"};
    const auto metrics = testing::run_metrics(options);
    const auto& ekf = metrics["localizers"][0];
    ASSERT_EQ(ekf["status"], "ok");
    EXPECT_LT(ekf["position_error_m"]["rms"].get<double>(), 0.15) << "seed " << seed;
    EXPECT_LT(ekf["heading_error_deg"]["rms"].get<double>(), 6.0) << "seed " << seed;
    // A person in a beam lengthens a range and the ungated trilateration follows it: peaks to
    // 0.9 m (the weakness the raw-range, gated variant is for).
    EXPECT_LT(ekf["position_error_m"]["max"].get<double>(), 1.0) << "seed " << seed;
    EXPECT_GT(ekf["diagnostics"]["fixes"].get<double>(), 380.0);  // 20 Hz, few rounds lost
  }
}

}  // namespace
}  // namespace locsim
