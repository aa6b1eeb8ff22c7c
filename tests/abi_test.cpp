// Localizer ABI version 2 and what real data needs: the SDK's odometry helpers (velocity
// integration along exact arcs, the wheel travel of a pose increment, OdometryTracker), the
// host's translation of odometry without ticks or pose and of range-bearing detections, and what
// a plugin built for ABI version 1 receives (docs/plugins.md, "ABI versions").
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>
#include <optional>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "locsim/localizer.hpp"
#include "locsim/models.hpp"
#include "sim/plugin_host/localizer_host.hpp"
#include "sim/world/world_loader.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;
using sdk::Pose;

/// The same motion by many small Euler steps: what the closed form must converge to.
Pose euler(Pose x, double v, double omega, double dt, int steps = 100000) {
  const double h = dt / steps;
  for (int i = 0; i < steps; ++i) {
    x(0) += v * h * std::cos(x(2));
    x(1) += v * h * std::sin(x(2));
    x(2) += omega * h;
  }
  x(2) = sdk::wrap(x(2));
  return x;
}

struct Motion {
  double v_mps, omega_radps, dt_s;
};
// Forward and turning, reverse and turning, straight, pure rotation (both ways), a slow creep.
const Motion kMotions[] = {{0.5, 0.3, 0.7},  {-0.4, 0.8, 0.5}, {0.3, 0.0, 1.0},  {0.0, 1.2, 0.6},
                           {0.0, -0.9, 1.1}, {0.2, -2.0, 0.9}, {1e-3, 1e-7, 0.1}};

TEST(SdkOdometry, AdvanceByVelocityIsTheExactArc) {
  const Pose start(1.0, -2.0, 2.9);  // near pi: the heading wraps on the way
  for (const Motion& m : kMotions) {
    const Pose closed = sdk::advance_by_velocity(start, m.v_mps, m.omega_radps, m.dt_s);
    const Pose fine = euler(start, m.v_mps, m.omega_radps, m.dt_s);
    EXPECT_NEAR(closed(0), fine(0), 1e-5) << m.v_mps << " " << m.omega_radps;
    EXPECT_NEAR(closed(1), fine(1), 1e-5) << m.v_mps << " " << m.omega_radps;
    EXPECT_NEAR(sdk::wrap(closed(2) - fine(2)), 0.0, 1e-9);
    if (m.omega_radps != 0.0) {  // the textbook form, with its division by omega
      const double r = m.v_mps / m.omega_radps, t1 = start(2) + m.omega_radps * m.dt_s;
      EXPECT_NEAR(closed(0), start(0) + r * (std::sin(t1) - std::sin(start(2))), 1e-9);
      EXPECT_NEAR(closed(1), start(1) - r * (std::cos(t1) - std::cos(start(2))), 1e-9);
    }
  }
}

/// A velocity reading (the command, as MRCLAM logs it) at its pose.
locsim_odometry command_reading(double v_mps, double omega_radps) {
  locsim_odometry o{};
  o.fields = LOCSIM_ODOMETRY_VELOCITY;
  o.v_mps = v_mps;
  o.omega_radps = omega_radps;
  return o;
}

TEST(SdkOdometry, ACommandFollowerMovesAsTheResponseSays) {
  // Settled at rest, then a step of the command at t = 0: after the dead time d each channel
  // rises as g u (1 - e^(-(t - d) / tau)); straight ahead, the distance is its integral.
  const sdk::CommandResponse response{0.1, 0.3, 0.2, 0.9, 0.95};
  for (const double omega : {0.0, 0.4}) {
    sdk::CommandFollower follower(response);
    follower.follow(-1.0, command_reading(0.0, 0.0));
    for (int k = 0; k <= 60; ++k) {
      const double t_s = 0.05 * k - 0.02;  // readings off the 20 ms arcs' grid
      const locsim_odometry& out = follower.follow(t_s, command_reading(0.5, omega));
      ASSERT_EQ(out.fields, LOCSIM_ODOMETRY_VELOCITY | LOCSIM_ODOMETRY_POSE);
      // The command of the first reading at or after -0.02 s holds from then on.
      const double since = std::max(0.0, t_s - (-0.02) - 0.1);
      const auto level = [&](double gain_u, double tau) {
        return gain_u * (1.0 - std::exp(-since / tau));
      };
      const auto area = [&](double gain_u, double tau) {
        return gain_u * (since - tau * (1.0 - std::exp(-since / tau)));
      };
      EXPECT_NEAR(out.v_mps, level(0.9 * 0.5, 0.3), 1e-12) << t_s;
      EXPECT_NEAR(out.omega_radps, level(0.95 * omega, 0.2), 1e-12) << t_s;
      EXPECT_NEAR(out.odom_pose.theta, area(0.95 * omega, 0.2), 1e-12) << t_s;
      if (omega == 0.0) {
        EXPECT_NEAR(out.odom_pose.x, area(0.9 * 0.5, 0.3), 1e-12) << t_s;
        EXPECT_EQ(out.odom_pose.y, 0.0);
      } else if (since > 0.0) {  // along arcs of at most 20 ms at their mean velocities
        EXPECT_GT(out.odom_pose.y, 0.0);
      }
    }
  }
  // The identity, and a reading without a velocity, pass through untouched.
  sdk::CommandFollower identity;
  const locsim_odometry reading = command_reading(0.3, 0.1);
  EXPECT_EQ(&identity.follow(0.0, reading), &reading);
  sdk::CommandFollower lagging(response);
  locsim_odometry ticks{};
  ticks.fields = LOCSIM_ODOMETRY_TICKS;
  EXPECT_EQ(&lagging.follow(0.0, ticks), &ticks);
}

TEST(SdkDetections, TheBiasIsTakenOutAsTheRangeModelSays) {
  for (const bool depth : {false, true}) {
    const sdk::DetectionBias bias{depth, 0.05, 0.023, 0.01};
    for (const double bearing_rad : {-0.5, 0.0, 0.3}) {
      const double r_m = 3.0;
      const double z_m = 0.05 + 1.023 * r_m * (depth ? std::cos(bearing_rad) : 1.0);
      const auto c = bias.corrected(z_m, bearing_rad + 0.01);
      EXPECT_NEAR(c.range_m, r_m, 1e-12);
      EXPECT_NEAR(c.bearing_rad, bearing_rad, 1e-15);
      EXPECT_NEAR(c.model_x_m, r_m * (depth ? std::cos(bearing_rad) : 1.0), 1e-12);
      const double h = 1e-6;
      const double slope = (bias.corrected(z_m + h, bearing_rad + 0.01).range_m -
                            bias.corrected(z_m - h, bearing_rad + 0.01).range_m) /
                           (2 * h);
      EXPECT_NEAR(c.range_scale, slope, 1e-8);
    }
  }
  const auto none = sdk::DetectionBias{}.corrected(2.5, 0.4);
  EXPECT_EQ(none.range_m, 2.5);
  EXPECT_EQ(none.bearing_rad, 0.4);
  EXPECT_EQ(none.range_scale, 1.0);
}

TEST(SdkDetections, CorrelatedDetectionsOfATargetWeighAsTheirMean) {
  // N detections at a steady interval, errors of correlation rho from one to the next: the
  // information the inflated variances add up to against the exact variance of their mean,
  // sigma^2 / N^2 sum_ij rho^|i - j|: exact for two, within 12 % (never more confident) for any.
  for (const double rho : {0.3, 0.8, 0.95}) {
    const double tau_s = -0.25 / std::log(rho);
    for (const int n : {2, 5, 20, 100}) {
      sdk::CorrelatedDetections seen(tau_s);
      locsim_detection d{};
      d.id = 7;
      double information = 0.0;
      for (int k = 0; k < n; ++k)
        information += 1.0 / seen.inflation(LOCSIM_CAMERA_PTZ, d, 0.25 * k);
      double exact = 0.0;
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) exact += std::pow(rho, std::abs(i - j));
      exact /= n * n;
      const double claimed = 1.0 / information;
      if (n == 2) {
        EXPECT_NEAR(claimed, exact, 1e-12);
      }
      EXPECT_LE(claimed, exact * (1 + 1e-12)) << rho << " " << n;
      EXPECT_GE(claimed, 0.88 * exact) << rho << " " << n;
    }
  }
  // Another target, or another camera, is independent; no correlation is no inflation.
  sdk::CorrelatedDetections seen(1.0);
  locsim_detection a{}, b{};
  a.id = 1, b.id = 2;
  EXPECT_EQ(seen.inflation(LOCSIM_CAMERA_PTZ, a, 0.0), 1.0);
  EXPECT_EQ(seen.inflation(LOCSIM_CAMERA_PTZ, b, 0.1), 1.0);
  EXPECT_EQ(seen.inflation(LOCSIM_CAMERA_RANGE_BEARING, a, 0.1), 1.0);
  EXPECT_GT(seen.inflation(LOCSIM_CAMERA_PTZ, a, 0.1), 10.0);
  sdk::CorrelatedDetections independent(0.0);
  EXPECT_EQ(independent.inflation(LOCSIM_CAMERA_PTZ, a, 0.0), 1.0);
  EXPECT_EQ(independent.inflation(LOCSIM_CAMERA_PTZ, a, 0.1), 1.0);
}

// A range's and a bearing's errors may persist differently: by default (the bearing's keys -1)
// the bearing weighs as the range; given its own, each channel inflates as its own process alone
// would.
TEST(SdkDetections, RangeAndBearingPersistEachAsTheirOwnProcessSays) {
  struct Values {
    std::map<std::string, double, std::less<>> v;
    double number(std::string_view key) const { return v.at(std::string(key)); }
  };
  const Values same{{{"noise_correlation_s", 1.0},
                     {"noise_correlation_slow_s", 20.0},
                     {"noise_correlation_slow_share", 0.5},
                     {"bearing_noise_correlation_s", -1.0},
                     {"bearing_noise_correlation_slow_s", -1.0},
                     {"bearing_noise_correlation_slow_share", -1.0}}};
  Values apart = same;
  apart.v["bearing_noise_correlation_s"] = 0.1;  // slow_s stays the range's, unused without share
  apart.v["bearing_noise_correlation_slow_share"] = 0.0;
  auto both = sdk::CorrelatedRangeBearing::from(same);
  auto own = sdk::CorrelatedRangeBearing::from(apart);
  sdk::CorrelatedDetections range(1.0, 20.0, 0.5), bearing(0.1, 20.0, 0.0);
  locsim_detection d{};
  d.id = 4;
  bool differ = false;
  for (int k = 0; k < 40; ++k) {
    const double t_s = 0.25 * k;
    const auto b = both.inflation(LOCSIM_CAMERA_PTZ, d, t_s);
    const auto o = own.inflation(LOCSIM_CAMERA_PTZ, d, t_s);
    const double expected_range = range.inflation(LOCSIM_CAMERA_PTZ, d, t_s);
    const double expected_bearing = bearing.inflation(LOCSIM_CAMERA_PTZ, d, t_s);
    EXPECT_EQ(b.range, expected_range) << k;
    EXPECT_EQ(b.bearing, expected_range) << k;
    EXPECT_EQ(o.range, expected_range) << k;
    EXPECT_EQ(o.bearing, expected_bearing) << k;
    differ = differ || o.bearing != o.range;
  }
  EXPECT_TRUE(differ);
}

// With a slow part (a share w of the variance persisting over tau_slow), a run of detections of
// a target weighs what generalised least squares gives it: 1^T C^-1 1, C = w R_slow + (1 - w)
// R_fast, R the two processes' correlations, at steady and at irregular intervals; each one at
// most an independent detection's, and a long dense run about (1 + T / (2 tau_slow)) / w.
TEST(SdkDetections, ASlowPartOfTheErrorsBoundsWhatARunOfDetectionsWeighs) {
  std::mt19937_64 engine(3);
  std::exponential_distribution<double> gap(2.0);  // 0.5 s apart on average
  for (const double w : {0.3, 0.6}) {
    for (const double fast_s : {0.0, 0.5}) {
      for (const double slow_s : {5.0, 60.0}) {
        for (const bool steady : {true, false}) {
          SCOPED_TRACE(testing::Message() << "w " << w << ", tau " << fast_s << " s, slow "
                                          << slow_s << " s, " << (steady ? "steady" : "irregular"));
          sdk::CorrelatedDetections seen(fast_s, slow_s, w);
          locsim_detection d{};
          d.id = 3;
          std::vector<double> times;
          double information = 0.0, t_s = 0.0;
          for (int k = 0; k < 200; ++k) {
            t_s += k == 0 ? 0.0 : (steady ? 0.25 : gap(engine));
            times.push_back(t_s);
            const double added = 1.0 / seen.inflation(LOCSIM_CAMERA_RANGE_BEARING, d, t_s);
            EXPECT_LE(added, 1.0);
            information += added;
          }
          const auto n = static_cast<Eigen::Index>(times.size());
          Eigen::MatrixXd C(n, n);
          for (Eigen::Index i = 0; i < n; ++i) {
            for (Eigen::Index j = 0; j < n; ++j) {
              const double dt = std::abs(times[i] - times[j]);
              const double fast = fast_s > 0.0 ? std::exp(-dt / fast_s) : (i == j ? 1.0 : 0.0);
              C(i, j) = w * std::exp(-dt / slow_s) + (1.0 - w) * fast;
            }
          }
          const Eigen::VectorXd ones = Eigen::VectorXd::Ones(n);
          const double exact = ones.dot(C.ldlt().solve(ones));
          EXPECT_NEAR(information, exact, 1e-6 * exact);
          EXPECT_LE(information, (1.0 + t_s / (2.0 * slow_s)) / w * (1.0 + 1e-9));
        }
      }
    }
  }
  // A target reported twice at one instant: the second adds nothing, and what follows is
  // weighed as before.
  {
    sdk::CorrelatedDetections seen(0.3, 5.6, 0.5), once(0.3, 5.6, 0.5);
    locsim_detection d{};
    d.id = 2;
    for (int k = 0; k < 200; ++k) {
      const double t_s = 0.1 * k;
      const double first = seen.inflation(LOCSIM_CAMERA_RANGE_BEARING, d, t_s);
      EXPECT_EQ(first, once.inflation(LOCSIM_CAMERA_RANGE_BEARING, d, t_s)) << k;
      EXPECT_TRUE(std::isfinite(first)) << k;
      if (k > 0) {
        EXPECT_GE(seen.inflation(LOCSIM_CAMERA_RANGE_BEARING, d, t_s), 1e11) << k;
      }
    }
  }
  // The first detection of a target counts in full; without a slow time constant the share
  // means nothing.
  sdk::CorrelatedDetections seen(0.5, 30.0, 0.5);
  locsim_detection a{};
  a.id = 1;
  EXPECT_EQ(seen.inflation(LOCSIM_CAMERA_PTZ, a, 0.0), 1.0);
  EXPECT_GT(seen.inflation(LOCSIM_CAMERA_PTZ, a, 0.1), 2.0);
  sdk::CorrelatedDetections shareless(0.0, 0.0, 0.5);
  EXPECT_EQ(shareless.inflation(LOCSIM_CAMERA_PTZ, a, 0.0), 1.0);
  EXPECT_EQ(shareless.inflation(LOCSIM_CAMERA_PTZ, a, 0.1), 1.0);
}

TEST(SdkOdometry, WheelTravelOfAnIncrementInvertsTheArc) {
  const double b = 0.35;
  for (const Motion& m : kMotions) {
    const Pose start(0.4, 0.2, -1.0);
    const Pose end = sdk::advance_by_velocity(start, m.v_mps, m.omega_radps, m.dt_s);
    const auto [left, right] = sdk::wheel_travel_from_increment(sdk::between(start, end), b);
    // A differential drive at (v, omega) moves its wheels by (v -/+ b omega / 2) dt.
    EXPECT_NEAR(left, (m.v_mps - 0.5 * b * m.omega_radps) * m.dt_s, 1e-9) << m.v_mps;
    EXPECT_NEAR(right, (m.v_mps + 0.5 * b * m.omega_radps) * m.dt_s, 1e-9) << m.v_mps;
  }
  // Pure rotation: the wheels turn opposite ways by b dtheta / 2 each.
  const auto [left, right] = sdk::wheel_travel_from_increment(Pose(0.0, 0.0, 0.5), b);
  EXPECT_NEAR(left, -0.5 * b * 0.5, 1e-12);
  EXPECT_NEAR(right, 0.5 * b * 0.5, 1e-12);
}

locsim_odometry odometry_of(const Pose& pose, std::uint32_t fields) {
  locsim_odometry o{};
  o.odom_pose = {pose(0), pose(1), pose(2)};
  o.fields = fields;
  return o;
}

TEST(SdkOdometry, TrackerTakesTheTicksWhenPresentElseThePose) {
  sdk::OdometryTracker tracker(0.3);
  locsim_odometry first =
      odometry_of(Pose(1.0, 1.0, 0.0), LOCSIM_ODOMETRY_TICKS | LOCSIM_ODOMETRY_POSE);
  first.left_ticks = 100, first.right_ticks = 200, first.meters_per_tick = 1e-3;
  EXPECT_FALSE(tracker.update(0.0, first));
  locsim_odometry second = first;
  second.left_ticks = 150, second.right_ticks = 180;
  second.odom_pose = {1.1, 1.0, 0.0};  // the pose need not agree: the ticks win
  const auto step = tracker.update(0.5, second);
  ASSERT_TRUE(step);
  EXPECT_TRUE(step->travel_from_ticks);
  EXPECT_EQ(step->d_left_m, 50 * 1e-3);
  EXPECT_EQ(step->d_right_m, -20 * 1e-3);
  EXPECT_DOUBLE_EQ(step->dt_s, 0.5);
  EXPECT_NEAR(step->pose_increment(0), 0.1, 1e-12);
  EXPECT_FALSE(tracker.velocity());

  // A source with velocities only (the host integrated the pose): travel from the increment,
  // backwards and turning.
  sdk::OdometryTracker velocity_only(0.3);
  Pose pose(2.0, -1.0, 3.0);
  locsim_odometry o = odometry_of(pose, LOCSIM_ODOMETRY_POSE | LOCSIM_ODOMETRY_VELOCITY);
  o.v_mps = -0.2, o.omega_radps = 0.4;
  EXPECT_FALSE(velocity_only.update(1.0, o));
  pose = sdk::advance_by_velocity(pose, -0.2, 0.4, 0.25);
  o.odom_pose = {pose(0), pose(1), pose(2)};
  const auto back = velocity_only.update(1.25, o);
  ASSERT_TRUE(back);
  EXPECT_FALSE(back->travel_from_ticks);
  EXPECT_NEAR(back->d_left_m, (-0.2 - 0.15 * 0.4) * 0.25, 1e-9);
  EXPECT_NEAR(back->d_right_m, (-0.2 + 0.15 * 0.4) * 0.25, 1e-9);
  ASSERT_TRUE(velocity_only.velocity());
  EXPECT_EQ(velocity_only.velocity()->first, -0.2);
  EXPECT_EQ(velocity_only.velocity()->second, 0.4);
}

TEST(SdkOdometry, TrackerTurnsByTheGyroAndTellsTheSlip) {
  // Ticks of wheels spinning in place against a wall (left back, right forward: 0.2 rad by the
  // wheels) while the gyro reads nothing: no turn, the mean travel kept, the wheels' turn slip.
  locsim_imu still{};
  for (const bool gyro : {true, false}) {
    SCOPED_TRACE(gyro ? "gyro" : "gyro off");
    sdk::OdometryTracker tracker(0.3), wheels_only(0.3);
    tracker.use_gyro(gyro);
    locsim_odometry o =
        odometry_of(Pose(1.0, 1.0, 0.0), LOCSIM_ODOMETRY_TICKS | LOCSIM_ODOMETRY_POSE);
    o.left_ticks = 0, o.right_ticks = 0, o.meters_per_tick = 1e-3;
    tracker.observe_imu(0.0, still);
    EXPECT_FALSE(tracker.update(0.0, o));
    EXPECT_FALSE(wheels_only.update(0.0, o));
    o.left_ticks = -25, o.right_ticks = 35;  // 10 mm forward on average, 0.2 rad of turn
    o.odom_pose = {1.01, 1.0, 0.2};
    tracker.observe_imu(0.01, still);
    tracker.observe_imu(0.02, still);
    const auto step = tracker.update(0.02, o);
    const auto raw = wheels_only.update(0.02, o);
    ASSERT_TRUE(step && raw);
    if (!gyro) {  // the wheels' step, to the bit
      EXPECT_EQ(step->d_left_m, raw->d_left_m);
      EXPECT_EQ(step->d_right_m, raw->d_right_m);
      EXPECT_EQ(step->pose_increment, raw->pose_increment);
      EXPECT_EQ(step->slip_rad, 0.0);
      continue;
    }
    EXPECT_NEAR(step->d_left_m, 0.005, 1e-12);
    EXPECT_NEAR(step->d_right_m, 0.005, 1e-12);
    EXPECT_NEAR(step->slip_rad, 0.2, 1e-12);
    EXPECT_NEAR(step->pose_increment(2), 0.0, 1e-12);
    EXPECT_NEAR(step->pose_increment.head<2>().norm(), raw->pose_increment.head<2>().norm(), 1e-12);
  }
}

TEST(SdkOdometry, TrackerAdvancesToAReadingBetweenOdometryAndTheStepsStillAddUp) {
  // A pose source at 5 Hz driving an arc (1 m/s, 0.5 rad/s), then faster (1.2 m/s): readings
  // of another sensor at 0.3 and 0.35 s meet the pose of their time, extrapolated at the last
  // step's rate; the step to 0.4 s is what is left, and the three add up to the odometry's.
  sdk::OdometryTracker tracker(0.3);
  Pose pose(1.0, 2.0, 0.3);
  locsim_odometry o = odometry_of(pose, LOCSIM_ODOMETRY_POSE);
  EXPECT_FALSE(tracker.update(0.0, o));
  EXPECT_FALSE(tracker.advance_to(0.1));  // no step yet to take the rate from
  pose = sdk::advance_by_velocity(pose, 1.0, 0.5, 0.2);
  o.odom_pose = {pose(0), pose(1), pose(2)};
  const auto first = tracker.update(0.2, o);
  ASSERT_TRUE(first);
  EXPECT_DOUBLE_EQ(first->dt_s, 0.2);
  const auto a = tracker.advance_to(0.3);
  ASSERT_TRUE(a);
  EXPECT_NEAR(a->dt_s, 0.1, 1e-12);
  EXPECT_NEAR(a->d_left_m, 0.5 * first->d_left_m, 1e-12);
  EXPECT_NEAR(a->d_right_m, 0.5 * first->d_right_m, 1e-12);
  EXPECT_LT((a->pose_increment - sdk::advance_by_velocity(Pose::Zero(), 1.0, 0.5, 0.1)).norm(),
            1e-12);
  const auto b = tracker.advance_to(0.35);
  ASSERT_TRUE(b);
  EXPECT_NEAR(b->dt_s, 0.05, 1e-12);
  EXPECT_FALSE(tracker.advance_to(0.35));  // already there
  EXPECT_FALSE(tracker.advance_to(0.32));  // nor back
  const Pose before = pose;
  pose = sdk::advance_by_velocity(pose, 1.2, 0.5, 0.2);
  o.odom_pose = {pose(0), pose(1), pose(2)};
  const auto rest = tracker.update(0.4, o);
  ASSERT_TRUE(rest);
  EXPECT_NEAR(rest->dt_s, 0.05, 1e-12);
  sdk::OdometryTracker whole(0.3);  // the same readings without the advances
  whole.update(0.2, odometry_of(before, LOCSIM_ODOMETRY_POSE));
  const auto full = whole.update(0.4, o);
  ASSERT_TRUE(full);
  EXPECT_NEAR(a->d_left_m + b->d_left_m + rest->d_left_m, full->d_left_m, 1e-12);
  EXPECT_NEAR(a->d_right_m + b->d_right_m + rest->d_right_m, full->d_right_m, 1e-12);
  const Pose summed =
      sdk::compose(sdk::compose(a->pose_increment, b->pose_increment), rest->pose_increment);
  EXPECT_LT((summed - full->pose_increment).norm(), 1e-12);

  // Odometry that stops coming is not driven on: one interval past the last reading at most.
  const auto capped = tracker.advance_to(5.0);
  ASSERT_TRUE(capped);
  EXPECT_NEAR(capped->dt_s, 0.2, 1e-12);
  EXPECT_FALSE(tracker.advance_to(6.0));

  // A source of velocities alone holds each reading's velocity until the next (the host
  // integrates it so): the advance takes the latest velocity, not the last step's.
  sdk::OdometryTracker velocity_only(0.3);
  locsim_odometry v = odometry_of(Pose::Zero(), LOCSIM_ODOMETRY_VELOCITY);
  v.v_mps = 0.2, v.omega_radps = 0.0;
  velocity_only.update(1.0, v);
  const Pose moved = sdk::advance_by_velocity(Pose::Zero(), 0.2, 0.0, 0.25);
  v.odom_pose = {moved(0), moved(1), moved(2)};
  v.v_mps = 0.5, v.omega_radps = -0.1;
  velocity_only.update(1.25, v);
  const auto ahead = velocity_only.advance_to(1.35);
  ASSERT_TRUE(ahead);
  EXPECT_NEAR(ahead->d_left_m, (0.5 + 0.15 * 0.1) * 0.1, 1e-12);
  EXPECT_NEAR(ahead->d_right_m, (0.5 - 0.15 * 0.1) * 0.1, 1e-12);
}

TEST(SdkOdometry, TrackerAdvancesByTheGyrosTurn) {
  // Wheels that report no turn while the gyro turns at 0.5 rad/s: the advance turns by the
  // gyro, the rest of the step by what is left of its turn, and the slip adds up.
  sdk::OdometryTracker tracker(0.3), whole(0.3);
  locsim_imu turning{};
  turning.yaw_rate_radps = 0.5;
  locsim_odometry o = odometry_of(Pose::Zero(), LOCSIM_ODOMETRY_POSE);
  int imu_readings = 0;  // the IMU's readings, every 10 ms, up to t: the gyro's turn is causal
  const auto imu_until = [&](double t_s) {
    for (; 0.01 * imu_readings <= t_s + 1e-9; ++imu_readings) {
      tracker.observe_imu(0.01 * imu_readings, turning);
      whole.observe_imu(0.01 * imu_readings, turning);
    }
  };
  imu_until(0.0);
  tracker.update(0.0, o);
  whole.update(0.0, o);
  imu_until(0.1);
  o.odom_pose = {0.1, 0.0, 0.0};
  tracker.update(0.1, o);
  whole.update(0.1, o);
  imu_until(0.15);
  const auto a = tracker.advance_to(0.15);
  ASSERT_TRUE(a);
  EXPECT_NEAR(a->pose_increment(2), 0.5 * 0.05, 1e-9);
  EXPECT_NEAR(a->d_right_m - a->d_left_m, 0.3 * 0.5 * 0.05, 1e-9);
  imu_until(0.2);
  o.odom_pose = {0.2, 0.0, 0.0};
  const auto rest = tracker.update(0.2, o);
  const auto full = whole.update(0.2, o);
  ASSERT_TRUE(rest && full);
  EXPECT_NEAR(a->pose_increment(2) + rest->pose_increment(2), full->pose_increment(2), 1e-9);
  EXPECT_NEAR(a->slip_rad + rest->slip_rad, full->slip_rad, 1e-9);
  EXPECT_NEAR(full->slip_rad, -0.05, 1e-9);
}

TEST(SdkOdometry, SlipWidensTheKalmanPrediction) {
  Pose x(0.0, 0.0, 0.0), y = x;
  Eigen::Matrix3d p = Eigen::Matrix3d::Identity() * 1e-4, q = p;
  sdk::predict_by_wheels(x, p, 0.1, 0.1, 0.3, 0.001, 0.001);
  sdk::predict_by_wheels(y, q, 0.1, 0.1, 0.3, 0.001, 0.001, 0.02);
  EXPECT_EQ(x, y);
  // Both wheels 0.02 m less sure: the travel by half their variances' sum, the turn by twice
  // over the wheel base squared.
  EXPECT_NEAR(q(0, 0) - p(0, 0), 0.5 * 0.02 * 0.02, 1e-12);
  EXPECT_NEAR(q(2, 2) - p(2, 2), 2.0 * 0.02 * 0.02 / (0.3 * 0.3), 1e-12);
}

// Wheels whose errors move together (k_correlation rho) drive the robot along its heading
// without turning it: straight ahead from a known pose, the travel's variance is
// k^2 d (1 + rho) / 2 and the turn's 2 k^2 d (1 - rho) / b^2.
TEST(SdkOdometry, CorrelatedWheelsMoveTheVarianceFromTheTurnToTheTravel) {
  const double k = 0.03, d = 0.2, b = 0.3;
  for (const double rho : {0.0, 0.7, -0.5}) {
    Pose x(0.0, 0.0, 0.0);
    Eigen::Matrix3d P = Eigen::Matrix3d::Zero();
    sdk::predict_by_wheels(x, P, d, d, b, k, k, 0.0, rho);
    EXPECT_NEAR(P(0, 0), k * k * d * (1.0 + rho) / 2.0, 1e-15) << rho;
    EXPECT_NEAR(P(2, 2), 2.0 * k * k * d * (1.0 - rho) / (b * b), 1e-15) << rho;
  }
}

// ---- the host's translation ------------------------------------------------------------------
Reading odometry_reading(double t_s, const OdometryReading& data) {
  Reading r;
  r.t_s = t_s;
  r.kind = SensorKind::kEncoders;
  r.data = data;
  return r;
}

OdometryReading velocity_only(double v_mps, double omega_radps) {
  OdometryReading o;
  o.fields = kOdometryVelocity;
  o.v_mps = v_mps;
  o.omega_radps = omega_radps;
  return o;
}

// Irregular times, each velocity held until the next reading (as MRCLAM's commands are).
struct Command {
  double t_s, v_mps, omega_radps;
};
const Command kCommands[] = {{0.0, 0.3, 0.0},  {0.1, 0.3, 0.5},  {0.35, -0.2, 0.5},
                             {0.4, 0.0, -1.0}, {0.9, 0.25, 0.1}, {1.6, 0.0, 0.0}};

TEST(HostTranslation, VelocityOnlyOdometryIsIntegratedFromTheStartPose) {
  RobotDef robot;
  robot.start = {1.0, 2.0, 0.3};
  ReadingTranslator translator(robot);
  Pose expected(1.0, 2.0, 0.3);
  double last_t = 0.0, v = 0.0, omega = 0.0;
  for (const Command& c : kCommands) {
    expected = sdk::advance_by_velocity(expected, v, omega, c.t_s - last_t);
    last_t = c.t_s, v = c.v_mps, omega = c.omega_radps;
    const locsim_reading& out =
        translator.translate(odometry_reading(c.t_s, velocity_only(c.v_mps, c.omega_radps)));
    ASSERT_EQ(out.kind, LOCSIM_READING_ODOMETRY);
    const locsim_odometry& o = out.data.odometry;
    EXPECT_EQ(o.fields, static_cast<std::uint32_t>(LOCSIM_ODOMETRY_VELOCITY));
    EXPECT_EQ(o.v_mps, c.v_mps);
    EXPECT_EQ(o.omega_radps, c.omega_radps);
    EXPECT_EQ(o.left_ticks, 0);
    EXPECT_EQ(o.right_ticks, 0);
    EXPECT_EQ(o.meters_per_tick, 0.0);  // no ticks: zero, not the encoder's nominal value
    EXPECT_NEAR(o.odom_pose.x, expected(0), 1e-12) << "t = " << c.t_s;
    EXPECT_NEAR(o.odom_pose.y, expected(1), 1e-12) << "t = " << c.t_s;
    EXPECT_NEAR(o.odom_pose.theta, expected(2), 1e-12) << "t = " << c.t_s;
  }
  // Far from the start: the test would not see a pose left at the start.
  EXPECT_GT(std::hypot(expected(0) - 1.0, expected(1) - 2.0), 0.1);
}

TEST(HostTranslation, TicksAndPoseAndDetectionsPassThrough) {
  RobotDef robot;
  robot.sensors.encoders = EncodersDef{};
  robot.sensors.encoders->ticks_per_rev = 1000;
  robot.wheel_radius_m = 0.05;
  ReadingTranslator translator(robot);
  OdometryReading ticks{120, 130, {0.5, 0.6, 0.7}};
  const locsim_odometry& o = translator.translate(odometry_reading(1.0, ticks)).data.odometry;
  EXPECT_EQ(o.fields, static_cast<std::uint32_t>(LOCSIM_ODOMETRY_TICKS | LOCSIM_ODOMETRY_POSE));
  EXPECT_EQ(o.left_ticks, 120);
  EXPECT_EQ(o.right_ticks, 130);
  EXPECT_DOUBLE_EQ(o.meters_per_tick, 2.0 * std::numbers::pi * 0.05 / 1000);
  EXPECT_EQ(o.odom_pose.x, 0.5);
  EXPECT_EQ(o.odom_pose.theta, 0.7);

  Reading seen;
  seen.t_s = 1.5;
  seen.kind = SensorKind::kRangeBearing;
  RangeBearingReading rb;
  rb.detections.push_back({"", 7, 2.5, 0.25, 7, DetectionTarget::kLandmark});
  rb.detections.push_back({"", 3, 1.5, -0.5, 3, DetectionTarget::kRobot});
  seen.data = rb;
  const locsim_reading& out = translator.translate(seen);
  ASSERT_EQ(out.kind, LOCSIM_READING_LANDMARKS);
  EXPECT_EQ(out.data.landmarks.camera, LOCSIM_CAMERA_RANGE_BEARING);
  ASSERT_EQ(out.data.landmarks.count, 2u);
  EXPECT_EQ(out.data.landmarks.detections[0].target, LOCSIM_TARGET_LANDMARK);
  EXPECT_EQ(out.data.landmarks.detections[0].id, 7);
  EXPECT_EQ(out.data.landmarks.detections[1].target, LOCSIM_TARGET_ROBOT);
  EXPECT_EQ(out.data.landmarks.detections[1].range_m, 1.5);
}

// ---- a plugin built for ABI version 1 --------------------------------------------------------
class Collect final : public EstimateConsumer {
 public:
  void estimate(const EstimateSample& sample) override { samples.push_back(sample); }
  void failure(const LocalizerFailure& failure) override { failures.push_back(failure); }
  std::vector<EstimateSample> samples;
  std::vector<LocalizerFailure> failures;
};

/// Robot 0's range-bearing reading at t_s.
Record range_bearing_at(double t_s, std::vector<Detection> detections) {
  Record record;
  record.type = Record::Type::kReading;
  record.reading.t_s = t_s;
  record.reading.kind = SensorKind::kRangeBearing;
  record.reading.data = RangeBearingReading{std::move(detections)};
  return record;
}

/// Robot 0's true pose at t_s: the instant each filter gives an estimate sample.
Record truth_at(double t_s) {
  Record truth;
  truth.type = Record::Type::kGroundTruth;
  truth.robot = 0;
  truth.t_s = t_s;
  return truth;
}

std::map<std::string, double> named(const EstimateSample& sample) {
  return {sample.diagnostics.begin(), sample.diagnostics.end()};
}

/// What test_abi1 receives, in this process or in a worker process.
void check_abi1_plugin(bool isolate) {
  const std::string plugin = std::string(LOCSIM_TEST_PLUGIN_DIR) + "/locsim_test_abi1.so";
  EXPECT_EQ(PluginLibrary(plugin).abi_version(), 1u);
  EXPECT_EQ(PluginLibrary(plugin).readings(), 0u);  // version 1 could not say

  WorldDef world = load_world(fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml");
  world.robots.resize(1);
  const RobotDef& robot = world.robots[0];
  LocalizationDef localization;
  localization.sigma_xy_m = localization.sigma_theta_rad = 0.0;  // the guess is the start
  HostOptions options;
  options.isolate = isolate;
  LocalizerHost host({parse_localizer_spec(plugin)}, world, localization, OccupancyGrid{}, 1,
                     options);
  Collect out;
  host.add_output(out);

  Record record;
  record.type = Record::Type::kReading;
  record.robot = record.reading.robot = 0;
  Pose expected(robot.start.x, robot.start.y, robot.start.theta);
  double last_t = 0.0, v = 0.0, omega = 0.0;
  for (const Command& c : kCommands) {
    expected = sdk::advance_by_velocity(expected, v, omega, c.t_s - last_t);
    last_t = c.t_s, v = c.v_mps, omega = c.omega_radps;
    record.reading = odometry_reading(c.t_s, velocity_only(c.v_mps, c.omega_radps));
    host.consume(record);
  }
  host.consume(range_bearing_at(1.7, {{"", 1, 2.5, 0.25, 1, DetectionTarget::kLandmark},
                                      {"", 0, 1.5, -0.5, 0, DetectionTarget::kRobot},  // withheld
                                      {"", 2, 4.0, 1.0, 2, DetectionTarget::kLandmark}}));
  host.consume(truth_at(1.7));
  host.finish(1.7);

  ASSERT_TRUE(out.failures.empty()) << out.failures[0].message;
  ASSERT_EQ(out.samples.size(), 1u);
  const EstimateSample& sample = out.samples[0];
  auto d = named(sample);
  EXPECT_EQ(d["struct_size"], 80);  // version 1's locsim_reading
  EXPECT_EQ(d["meters_per_tick"], 1e-4);
  EXPECT_NEAR(d["odom_x"], expected(0), 1e-12);
  EXPECT_NEAR(d["odom_y"], expected(1), 1e-12);
  EXPECT_NEAR(d["odom_theta"], expected(2), 1e-12);
  // Two detections of landmarks at version 1's stride (a wrong stride reads garbage ranges).
  EXPECT_EQ(d["camera"], LOCSIM_CAMERA_RANGE_BEARING);
  EXPECT_EQ(d["detections"], 2);
  EXPECT_EQ(d["detection_ids"], 3);
  EXPECT_EQ(d["detection_ranges"], 6.5);
  // The plugin's own dead reckoning from the synthesised ticks lands where the velocities went
  // (within the rounding to 0.1 mm ticks and the mid-heading approximation).
  EXPECT_NEAR(sample.pose.x, expected(0), 1e-3);
  EXPECT_NEAR(sample.pose.y, expected(1), 1e-3);
  EXPECT_NEAR(sdk::wrap(sample.pose.theta - expected(2)), 0.0, 2e-3);
  EXPECT_NE(d["left_ticks"], d["right_ticks"]);  // it turned
}

// ---- what a filter reads: the C++ layer says it from the handlers a class overrides ----------
struct ReadsLandmarks : sdk::Localizer {
  void on_landmarks(double, const locsim_landmarks&) override {}
  sdk::Estimate estimate() const override { return {}; }
};
struct AndOdometry : ReadsLandmarks {  // a handler a base overrides counts too
  void on_odometry(double, const locsim_odometry&) override {}
};
struct LooksAtEverything : AndOdometry {
  void update(const locsim_reading&) override {}
};
constexpr std::uint32_t bit(int kind) {
  return LOCSIM_READING_BIT(kind);
}
static_assert(sdk::detail::handled_readings<ReadsLandmarks>() == bit(LOCSIM_READING_LANDMARKS));
static_assert(sdk::detail::handled_readings<AndOdometry>() ==
              (bit(LOCSIM_READING_LANDMARKS) | bit(LOCSIM_READING_ODOMETRY)));
static_assert(sdk::detail::handled_readings<LooksAtEverything>() == 0u);

TEST(Readings, EachBuiltInFilterSaysWhatItReads) {
  const auto readings = [](const std::string& name) {
    return PluginLibrary(find_plugin(name)).readings();
  };
  const std::uint32_t odometry = bit(LOCSIM_READING_ODOMETRY);
  EXPECT_EQ(readings("odometry"), odometry);
  // The others turn their odometry by the gyro (OdometryFollower, OdometryTracker).
  const std::uint32_t imu = bit(LOCSIM_READING_IMU);
  for (const char* landmarks : {"omni_kf", "ekf_landmarks", "mcl", "srl", "asrl", "augmented_mcl",
                                "fastslam", "fastslam_afsa", "pso_pf"}) {
    EXPECT_EQ(readings(landmarks), odometry | imu | bit(LOCSIM_READING_LANDMARKS)) << landmarks;
  }
  EXPECT_EQ(readings("amcl"), odometry | imu | bit(LOCSIM_READING_LASER));
  // Without an IMU the ultrasonic EKF and the beacon particle filter move by the wheels.
  EXPECT_EQ(readings("ultrasonic_ekf"), odometry | imu | bit(LOCSIM_READING_BEACON_RANGES));
  EXPECT_EQ(readings("beacon_mcl"), odometry | imu | bit(LOCSIM_READING_BEACON_RANGES));
  EXPECT_EQ(readings("ultrasonic_amcl"), odometry | bit(LOCSIM_READING_IMU) |
                                             bit(LOCSIM_READING_BEACON_RANGES) |
                                             bit(LOCSIM_READING_LASER));
}

TEST(AbiVersion1, PluginGetsVersionOneStructsAndTicksItCanDeadReckonFrom) {
  check_abi1_plugin(false);
}

TEST(AbiVersion1, SoInAWorkerProcessToo) {
  check_abi1_plugin(true);
}

// ---- the landmark filters on the range-bearing sensor -----------------------------------------
/// One filter of `spec` on the demo robot: an odometry reading at the start, then (unless
/// nullopt) a range-bearing reading with `detections`; its estimate and how many landmarks it
/// mapped (SLAM: a first detection moves no estimate, it maps the landmark).
using EstimateOutcome = std::pair<Pose, std::size_t>;
EstimateOutcome estimate_after(const std::string& spec,
                               const std::optional<std::vector<Detection>>& seen) {
  WorldDef world = load_world(fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml");
  world.robots.resize(1);
  HostOptions options;
  options.isolate = false;
  LocalizerHost host({parse_localizer_spec(spec)}, world, LocalizationDef{}, OccupancyGrid{}, 5,
                     options);
  Collect out;
  host.add_output(out);
  Record record;
  record.type = Record::Type::kReading;
  record.reading = odometry_reading(0.0, OdometryReading{0, 0, world.robots[0].start});
  host.consume(record);
  if (seen) host.consume(range_bearing_at(0.1, *seen));
  host.consume(truth_at(0.2));
  const std::vector<LocalizerFinal> finals = host.finish(0.2);
  EXPECT_TRUE(out.failures.empty()) << spec << ": " << out.failures[0].message;
  if (out.samples.size() != 1) {
    ADD_FAILURE() << spec << ": " << out.samples.size() << " samples";
    return {};
  }
  return {Pose(out.samples[0].pose.x, out.samples[0].pose.y, out.samples[0].pose.theta),
          finals.at(0).landmark_map.size()};
}

TEST(LandmarkFilters, TakeRangeBearingDetectionsAndSkipOtherRobots) {
  // The demo robot starts at (1.5, 1.5, 0); landmark 1 (red) is at (0.3, 0.3): seen a little
  // farther and to the left of where it should be, so that a filter using it moves.
  const Detection landmark{"red", 1, 1.75, -2.33, 1, DetectionTarget::kLandmark};
  const Detection robot{"", 1, 1.75, -2.33, 1, DetectionTarget::kRobot};
  // FastSLAM maps a landmark at its first detection (that moves no estimate) when told to. This
  // host gives no occupancy grid: augmented MCL injects from the detections, not uniformly.
  for (const std::string plugin :
       {"ekf_landmarks:", "mcl:", "srl:", "asrl:", "augmented_mcl:injection=sensors,",
        "fastslam:map_min_observations=1,"}) {
    const EstimateOutcome used =
        estimate_after(plugin + "use_range_bearing=true", std::vector{landmark});
    const EstimateOutcome empty =
        estimate_after(plugin + "use_range_bearing=true", std::vector<Detection>{});
    EXPECT_NE(used, empty) << plugin << " did not use the range-bearing detection";
    EXPECT_EQ(estimate_after(plugin + "use_range_bearing=true", std::vector{robot}), empty)
        << plugin << " used a detection of another robot";
    EXPECT_EQ(estimate_after(plugin + "use_range_bearing=false", std::vector{landmark}),
              estimate_after(plugin + "use_range_bearing=true", std::nullopt))
        << plugin << " used the range-bearing sensor with use_range_bearing off";
  }
}

}  // namespace
}  // namespace locsim
