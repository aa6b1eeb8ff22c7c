// Each sensor's noise model against its specification, from many seeded samples; occlusion,
// field of view, pan limits, slip and kidnapping as the sensors see them; faults.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>

#include "sim/sensors/models.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

using testing::drive_for;
using testing::make_sim;

template <class T>
struct Sample {
  double t_s;
  T data;
};

/// Steps `sim` for `seconds` commanding (v, w) and returns the readings of `kind` of robot 0.
template <class T>
std::vector<Sample<T>> collect(Simulation& sim, SensorKind kind, double seconds, double v = 0.0,
                               double w = 0.0) {
  std::vector<Sample<T>> out;
  for (const Reading& r : sim.take_readings()) {
    if (r.kind == kind && r.robot == 0) out.push_back({r.t_s, std::get<T>(r.data)});
  }
  const auto steps = std::llround(seconds / sim.dt_s());
  for (long long i = 0; i < steps; ++i) {
    sim.robot(0).command(v, w);
    sim.step();
    for (const Reading& r : sim.take_readings()) {
      if (r.kind == kind && r.robot == 0) out.push_back({r.t_s, std::get<T>(r.data)});
    }
  }
  return out;
}

struct Stats {
  double mean = 0.0, stddev = 0.0;
  std::size_t n = 0;
};
Stats stats(const std::vector<double>& values) {
  Stats s;
  s.n = values.size();
  if (values.empty()) return s;
  s.mean = std::accumulate(values.begin(), values.end(), 0.0) / static_cast<double>(s.n);
  double sq = 0.0;
  for (const double v : values) sq += (v - s.mean) * (v - s.mean);
  s.stddev = std::sqrt(sq / static_cast<double>(std::max<std::size_t>(s.n - 1, 1)));
  return s;
}

// ----------------------------------------------------------------------------------- encoders
TEST(Encoders, CountRotationAndOdometryMatchesTruthWithoutNoise) {
  Simulation sim = make_sim(R"(
floor: {friction: 1.0}
robots:
  - start: {x: 1, y: 2, theta: 0.5}
    sensors:
      encoders: {k_left: 0, k_right: 0, ticks_per_rev: 4096}
)");
  const auto readings = collect<OdometryReading>(sim, SensorKind::kEncoders, 6.0, 0.4, 0.3);
  ASSERT_EQ(readings.size(), 6u * 50u + 1u);  // 50 Hz including t = 0
  const OdometryReading& last = readings.back().data;
  const double ticks_per_rad = 4096 / (2 * std::numbers::pi);
  EXPECT_NEAR(static_cast<double>(last.left_ticks), sim.robot(0).left().angle_rad * ticks_per_rad,
              1.0);
  EXPECT_NEAR(static_cast<double>(last.right_ticks), sim.robot(0).right().angle_rad * ticks_per_rad,
              1.0);
  const Pose2 truth = sim.robot(0).pose();
  EXPECT_NEAR(last.odometry.x, truth.x, 5e-3);
  EXPECT_NEAR(last.odometry.y, truth.y, 5e-3);
  EXPECT_NEAR(wrap_angle(last.odometry.theta - truth.theta), 0.0, 5e-3);
}

TEST(Encoders, RandomErrorVarianceGrowsAsKSquaredTimesDistance) {
  // Paper 002: after rolling d metres, the counted distance has variance K^2 d.
  const double k = 0.004, distance = 1.0;
  std::vector<double> errors;
  for (std::uint64_t seed = 1; seed <= 300; ++seed) {
    Simulation sim = make_sim(R"(
floor: {friction: 1.0}
robots:
  - start: {x: 0, y: 0}
    sensors:
      encoders: {k_left: 0.004, k_right: 0.004, ticks_per_rev: 1000000}
)",
                              seed);
    const auto readings = collect<OdometryReading>(sim, SensorKind::kEncoders, 3.0, 0.4, 0.0);
    const double radians_per_tick = 2 * std::numbers::pi / 1000000;
    const double counted =
        static_cast<double>(readings.back().data.left_ticks) * radians_per_tick * 0.05;
    const double rolled = sim.robot(0).left().angle_rad * 0.05;
    ASSERT_NEAR(rolled, 1.1, 0.1);
    errors.push_back((counted - rolled) / std::sqrt(rolled / distance));
  }
  const Stats s = stats(errors);
  EXPECT_NEAR(s.mean, 0.0, 4.0 * k / std::sqrt(300.0));
  EXPECT_NEAR(s.stddev, k, 0.15 * k);  // the sample spread of 300 draws is within ~4 %
}

TEST(Encoders, ReportVelocityFromTheirOwnCountsAndOnlyTheFieldsAsked) {
  const auto run = [](const std::string& reports) {
    Simulation sim = make_sim(R"(
floor: {friction: 1.0}
robots:
  - start: {x: 1, y: 2, theta: 0.5}
    sensors:
      encoders: {k_left: 0.01, k_right: 0.01, ticks_per_rev: 2048)" +
                              reports + "}\n");
    return collect<OdometryReading>(sim, SensorKind::kEncoders, 4.0, 0.4, 0.3);
  };
  const auto all = run(", reports: [ticks, pose, velocity]");
  ASSERT_EQ(all.size(), 4u * 50u + 1u);
  // The velocity is the counted travel over the period: integrating it as the base dead-reckons
  // gives its odometry pose back, noise and tick quantisation included.
  Pose2 integrated = all.front().data.odometry;
  for (std::size_t i = 1; i < all.size(); ++i) {
    const OdometryReading& r = all[i].data;
    EXPECT_EQ(r.fields, kOdometryAllFields);
    const double period_s = all[i].t_s - all[i - 1].t_s;
    const double turn = r.omega_radps * period_s;
    const double mid_heading = integrated.theta + 0.5 * turn;
    integrated.x += r.v_mps * period_s * std::cos(mid_heading);
    integrated.y += r.v_mps * period_s * std::sin(mid_heading);
    integrated.theta = wrap_angle(integrated.theta + turn);
    ASSERT_NEAR(integrated.x, r.odometry.x, 1e-9);
    ASSERT_NEAR(integrated.y, r.odometry.y, 1e-9);
  }
  EXPECT_EQ(all.front().data.v_mps, 0.0);  // no period before the first reading
  // Once up to speed, near what was commanded (the noise and ticks make it differ a little).
  double v_sum = 0.0, omega_sum = 0.0;
  for (std::size_t i = 100; i < all.size(); ++i)
    v_sum += all[i].data.v_mps, omega_sum += all[i].data.omega_radps;
  EXPECT_NEAR(v_sum / static_cast<double>(all.size() - 100), 0.4, 0.02);
  EXPECT_NEAR(omega_sum / static_cast<double>(all.size() - 100), 0.3, 0.03);
  EXPECT_NE(all[150].data.v_mps, all[151].data.v_mps);  // measured, not the command

  // Velocity only: the other fields are zeros, the velocities the same draws' (same stream).
  const auto velocity = run(", reports: [velocity]");
  ASSERT_EQ(velocity.size(), all.size());
  for (std::size_t i = 0; i < all.size(); ++i) {
    const OdometryReading& r = velocity[i].data;
    EXPECT_EQ(r.fields, kOdometryVelocity);
    EXPECT_EQ(r.left_ticks, 0);
    EXPECT_EQ(r.odometry.x, 0.0);
    EXPECT_EQ(r.v_mps, all[i].data.v_mps);
    EXPECT_EQ(r.omega_radps, all[i].data.omega_radps);
  }
  // The default: ticks and pose, no velocity.
  const auto plain = run("");
  EXPECT_EQ(plain.back().data.fields, kOdometryTicks | kOdometryPose);
  EXPECT_EQ(plain.back().data.v_mps, 0.0);
  EXPECT_EQ(plain.back().data.left_ticks, all.back().data.left_ticks);
}

TEST(Encoders, MeasuringTheCommandReportItWhileTheRobotLagsAndFallsShort) {
  Simulation sim = make_sim(R"(
floor: {friction: 1.0}
robots:
  - start: {x: 0, y: 0, theta: 0}
    command_response: {dead_time_s: 0.1, time_constant_v_s: 0.2, gain_v: 0.8}
    sensors:
      encoders: {k_left: 0, k_right: 0, measures: command, reports: [pose, velocity]}
)");
  const auto readings = collect<OdometryReading>(sim, SensorKind::kEncoders, 4.0, 0.5, 0.0);
  ASSERT_EQ(readings.size(), 4u * 50u + 1u);
  // The odometry is the command integrated (4 s at 0.5 m/s, to a tick), from the first period
  // on: it leads the motion, which comes 0.1 s late, 0.2 s slow and 20 % short.
  const OdometryReading& last = readings.back().data;
  EXPECT_NEAR(last.odometry.x, 2.0, 0.01);
  EXPECT_NEAR(readings[1].data.v_mps, 0.5, 0.01);
  const double truth_m = sim.robot(0).pose().x;
  EXPECT_NEAR(truth_m, 0.8 * 0.5 * (4.0 - 0.1 - 0.2), 0.05);
}

TEST(Encoders, CountSlipOnIceThatTheGroundNeverSaw) {
  Simulation sim = make_sim(R"(
floor: {friction: 0.05}
robots:
  - start: {x: 0, y: 0}
    sensors: {encoders: {k_left: 0, k_right: 0}}
)");
  const auto readings = collect<OdometryReading>(sim, SensorKind::kEncoders, 2.0, 1.0, 0.0);
  const double odometry_distance = readings.back().data.odometry.x;
  const double ground_distance = sim.robot(0).pose().x;
  EXPECT_GT(odometry_distance, 1.5 * ground_distance);
}

TEST(Encoders, NeverSeeAKidnapAndUnequalRadiiFoolTheOdometry) {
  Simulation sim = make_sim(R"(
floor: {friction: 1.0}
robots:
  - start: {x: 0, y: 0}
    wheel_radius_left_m: 0.0505
    sensors: {encoders: {k_left: 0, k_right: 0}}
scenario:
  events:
    - {at_s: 5, kidnap: {to: {x: 4, y: 4, theta: 2}}}
)");
  auto readings = collect<OdometryReading>(sim, SensorKind::kEncoders, 4.99, 0.3, 0.0);
  const OdometryReading before = readings.back().data;
  EXPECT_NEAR(before.odometry.theta, 0.0, 1e-3);  // the base believes it drove straight
  EXPECT_LT(sim.robot(0).pose().theta, -0.03);    // it veered right
  readings = collect<OdometryReading>(sim, SensorKind::kEncoders, 0.02, 0.0, 0.0);
  ASSERT_FALSE(readings.empty());
  const OdometryReading after = readings.back().data;
  EXPECT_NEAR(sim.robot(0).pose().x, 4.0, 1e-3);
  // 10 ms of driving before the carry (~80 ticks), nothing of the 5.7 m jump.
  EXPECT_LE(std::abs(after.left_ticks - before.left_ticks), 100);
  EXPECT_NEAR(after.odometry.x, before.odometry.x, 0.01);
  EXPECT_NEAR(after.odometry.y, before.odometry.y, 0.01);
}

/// `heading: gyro`: the pose turns as the body does (the veer of unequal wheels that the wheels'
/// heading misses), plus the gyro's bias times the time, and a kidnap's turn is not seen.
TEST(Encoders, AGyroHeadingFollowsTheBodysTurnAndDriftsByItsBiasNotByAKidnap) {
  Simulation sim = make_sim(R"(
floor: {friction: 1.0}
robots:
  - start: {x: 0, y: 0}
    wheel_radius_left_m: 0.0505
    sensors: {encoders: {k_left: 0, k_right: 0, heading: gyro, gyro_bias_radps: 0.01,
                         gyro_noise_density: 0}}
scenario:
  events:
    - {at_s: 5, kidnap: {to: {x: 4, y: 4, theta: 2}}}
)");
  auto readings = collect<OdometryReading>(sim, SensorKind::kEncoders, 4.99, 0.3, 0.0);
  const Sample<OdometryReading> before = readings.back();
  EXPECT_LT(sim.robot(0).pose().theta, -0.03);  // it veered right, and the gyro saw it
  EXPECT_NEAR(before.data.odometry.theta, sim.robot(0).pose().theta + 0.01 * before.t_s, 2e-3);
  readings = collect<OdometryReading>(sim, SensorKind::kEncoders, 1.0, 0.0, 0.0);
  ASSERT_FALSE(readings.empty());
  EXPECT_NEAR(sim.robot(0).pose().theta, 2.0, 0.05);
  // After the kidnap: only the bias turned it (the robot stands still).
  const Sample<OdometryReading> after = readings.back();
  EXPECT_NEAR(after.data.odometry.theta - before.data.odometry.theta,
              0.01 * (after.t_s - before.t_s), 1e-3);
}

// ---------------------------------------------------------------------------------------- imu
TEST(Imu, GyroWhiteNoiseMatchesItsDensity) {
  Simulation sim = make_sim(R"(
robots:
  - start: {x: 0, y: 0}
    sensors:
      imu: {gyro_noise_density: 0.001, gyro_bias_sigma: 0, gyro_bias_random_walk: 0,
            accel_noise_density: 0.01, accel_bias_sigma: 0, accel_bias_random_walk: 0}
)");
  const auto readings = collect<ImuReading>(sim, SensorKind::kImu, 60.0);
  std::vector<double> gyro, accel;
  for (const auto& r : readings) {
    gyro.push_back(r.data.yaw_rate_radps);
    accel.push_back(r.data.accel_mps2.x());
  }
  const Stats g = stats(gyro), a = stats(accel);
  EXPECT_EQ(g.n, 6001u);
  EXPECT_NEAR(g.mean, 0.0, 4.0 * 0.01 / std::sqrt(6001.0));
  EXPECT_NEAR(g.stddev, 0.001 * std::sqrt(100.0), 0.05 * 0.01);  // density * sqrt(rate)
  EXPECT_NEAR(a.stddev, 0.01 * std::sqrt(100.0), 0.05 * 0.1);
}

TEST(Imu, IntegratedGyroFollowsTheTrueHeading) {
  Simulation sim = make_sim(R"(
floor: {friction: 1.0}
robots:
  - start: {x: 0, y: 0}
    sensors: {imu: {gyro_bias_sigma: 0}}
)");
  const auto readings = collect<ImuReading>(sim, SensorKind::kImu, 10.0, 0.2, 0.25);
  double heading = 0.0;
  for (std::size_t i = 1; i < readings.size(); ++i)
    heading += readings[i].data.yaw_rate_radps * 0.01;
  // True heading change: 10 s at 0.25 rad/s less the ramp; wrap-free below pi.
  const double truth = sim.robot(0).pose().theta;
  EXPECT_GT(truth, 2.3);
  EXPECT_NEAR(heading, truth, 0.01);
}

TEST(Imu, SeesAccelerationAndTheCollisionSpikeAndSaturates) {
  const auto run = [](double range) {
    Simulation sim = make_sim(R"(
floor: {friction: 1.0}
walls:
  - points: [[1.5, -3], [1.5, 3]]
robots:
  - start: {x: 0, y: 0}
    sensors:
      imu: {accel_noise_density: 0, accel_bias_sigma: 0, accel_bias_random_walk: 0, accel_range: )" +
                              std::to_string(range) + "}\n");
    return collect<ImuReading>(sim, SensorKind::kImu, 5.0, 0.8, 0.0);
  };
  const auto readings = run(40.0);
  // The wheel ramp (30 rad/s^2 x 0.05 m) accelerates the body at 1.5 m/s^2.
  EXPECT_NEAR(readings[20].data.accel_mps2.x(), 1.5, 0.05);
  double lowest = 0.0;
  for (const auto& r : readings) lowest = std::min(lowest, r.data.accel_mps2.x());
  EXPECT_LT(lowest, -5.0);  // hitting the wall at 0.8 m/s
  for (const auto& r : run(2.0)) EXPECT_LE(std::abs(r.data.accel_mps2.x()), 2.0);
}

// -------------------------------------------------------------------------------- ptz camera
/// A robot at the origin facing +x and one landmark at `landmark` (x, y).
std::string camera_world(const std::string& landmark, const std::string& camera,
                         const std::string& extra = "") {
  return "landmarks:\n  - {id: 7, position: " + landmark + ", color: red, height_m: 0.6}\n" +
         extra + "robots:\n  - start: {x: 0, y: 0}\n    sensors:\n      ptz_camera: " + camera +
         "\n";
}

std::vector<Detection> detections(const std::string& world, double seconds = 0.0,
                                  std::uint64_t seed = 1) {
  Simulation sim = make_sim(world, seed);
  std::vector<Detection> out;
  for (const auto& r : collect<PtzReading>(sim, SensorKind::kPtzCamera, seconds)) {
    out.insert(out.end(), r.data.detections.begin(), r.data.detections.end());
  }
  return out;
}

TEST(PtzCamera, FieldOfViewAndPanDecideWhatIsSeen) {
  const std::string quiet = "{miss_probability: 0, false_detections_per_frame: 0}";
  // hfov 65 deg: 20 deg off-axis is inside, 40 deg is outside.
  EXPECT_EQ(detections(camera_world("[2.819, 1.026]", quiet)).size(), 1u);  // 20 deg
  EXPECT_EQ(detections(camera_world("[2.298, 1.928]", quiet)).size(), 0u);  // 40 deg
  EXPECT_EQ(detections(camera_world("[-2.0, 0.5]", quiet)).size(), 0u);     // behind
  // Panned 30 deg left, the 40 deg landmark is 10 deg off-axis.
  const std::string panned =
      camera_world("[2.298, 1.928]", quiet) + "scenario:\n  ptz: {policy: fixed, pan_deg: 30}\n";
  const auto seen = detections(panned, 1.0);
  ASSERT_FALSE(seen.empty());
  EXPECT_NEAR(seen.back().bearing_rad, deg_to_rad(40.0), deg_to_rad(1.5));
  EXPECT_NEAR(seen.back().range_m, 3.0, 0.3);
}

TEST(PtzCamera, PanStaysWithinItsLimitsAndSweeps) {
  Simulation fixed =
      make_sim(camera_world("[3, 0]", "{}") + "scenario:\n  ptz: {policy: fixed, pan_deg: 150}\n");
  auto frames = collect<PtzReading>(fixed, SensorKind::kPtzCamera, 3.0);
  EXPECT_NEAR(frames.back().data.pan_rad, deg_to_rad(100.0), 1e-9);
  Simulation sweep = make_sim(camera_world("[3, 0]", "{}") +
                              "scenario:\n  ptz: {policy: sweep, sweep_min_deg: -60, "
                              "sweep_max_deg: 60, sweep_rate_deg: 40}\n");
  frames = collect<PtzReading>(sweep, SensorKind::kPtzCamera, 12.0);
  double lo = 1e9, hi = -1e9;
  for (const auto& f : frames) {
    lo = std::min(lo, f.data.pan_rad);
    hi = std::max(hi, f.data.pan_rad);
    EXPECT_LE(std::abs(f.data.pan_rad), deg_to_rad(60.0) + 1e-9);
  }
  EXPECT_NEAR(lo, deg_to_rad(-60.0), 1e-6);
  EXPECT_NEAR(hi, deg_to_rad(60.0), 1e-6);
  EXPECT_NEAR(frames[5].data.pan_rad, deg_to_rad(40.0 * 0.5), 1e-6);  // 0.5 s at 40 deg/s
}

TEST(PtzCamera, ErrorsFollowPixelQuantisationAndGrowWithDistance) {
  const auto errors = [](double distance) {
    std::vector<double> range_errors, bearing_errors;
    const std::string world =
        camera_world("[" + std::to_string(distance) + ", 0.3]",
                     "{miss_probability: 0, false_detections_per_frame: 0, pixel_noise_px: 0.5}");
    for (const Detection& d : detections(world, 30.0)) {
      range_errors.push_back(d.range_m - std::hypot(distance, 0.3));
      bearing_errors.push_back(wrap_angle(d.bearing_rad - std::atan2(0.3, distance)));
    }
    return std::pair{stats(range_errors), stats(bearing_errors)};
  };
  const auto [near_range, near_bearing] = errors(1.5);
  const auto [far_range, far_bearing] = errors(5.0);
  EXPECT_EQ(near_range.n, 301u);
  EXPECT_LT(std::abs(near_range.mean), 0.03);  // unbiased within 2 %
  EXPECT_LT(std::abs(far_range.mean), 0.15);
  EXPECT_GT(far_range.stddev, 3.0 * near_range.stddev);  // height in pixels shrinks as 1/d
  // Bearing: a pixel is 0.5 deg at zoom 1; the blob centre is good to about half a pixel.
  EXPECT_LT(near_bearing.stddev, deg_to_rad(0.5));
  EXPECT_LT(std::abs(near_bearing.mean), deg_to_rad(0.3));
}

TEST(PtzCamera, WallsAndPeopleOcclude) {
  const std::string quiet = "{miss_probability: 0, false_detections_per_frame: 0}";
  EXPECT_EQ(detections(camera_world("[3, 0]", quiet, "walls:\n  - points: [[1.5, -1], [1.5, 1]]\n"))
                .size(),
            0u);
  const std::string person = "movers:\n  - {name: p, path: [[1.5, 0]], speed_mps: 0}\n";
  EXPECT_EQ(detections(camera_world("[3, 0]", quiet, person)).size(), 0u);
  // A person covering part of a wide landmark leaves a narrower blob, still detected.
  const std::string half =
      "movers:\n  - {name: p, path: [[1.5, 0.62]], footprint: {radius_m: 0.1}, speed_mps: 0}\n";
  const auto partial =
      detections(camera_world("[3, 0]", quiet, half)
                     .replace(camera_world("[3, 0]", quiet, half).find("height_m: 0.6"), 13,
                              "height_m: 0.6, radius_m: 0.5"));
  ASSERT_EQ(partial.size(), 1u);
}

TEST(PtzCamera, MissAndFalseDetectionRatesHold) {
  const auto seen = detections(
      camera_world("[3, 0]", "{miss_probability: 0.3, false_detections_per_frame: 0.5}"), 100.0);
  int real = 0, phantom = 0;
  for (const Detection& d : seen) (d.truth_id == 7 ? real : phantom)++;
  EXPECT_NEAR(real / 1001.0, 0.7, 0.05);
  EXPECT_NEAR(phantom / 1001.0, 0.5, 0.07);
  for (const Detection& d : seen) {
    EXPECT_EQ(d.id, -1);  // colours only by default
    EXPECT_EQ(d.color, "red");
  }
}

// ------------------------------------------------------------------------------ omni camera
TEST(OmniCamera, LocalFrameGaussianHasTheGivenPrincipalDeviations) {
  Simulation sim = make_sim(R"(
landmarks:
  - {id: 1, position: [0, 3]}
robots:
  - start: {x: 0, y: 0}
    sensors: {omni_camera: {sigma_major_m: 0.2, sigma_minor_m: 0.05}}
)");
  std::vector<double> along, across;
  for (const auto& r : collect<OmniReading>(sim, SensorKind::kOmniCamera, 200.0)) {
    ASSERT_EQ(r.data.detections.size(), 1u);
    const Detection& d = r.data.detections[0];
    EXPECT_EQ(d.id, 1);
    // The landmark is straight left: along the ray is y, across is -x.
    along.push_back(d.range_m * std::sin(d.bearing_rad) - 3.0);
    across.push_back(-d.range_m * std::cos(d.bearing_rad));
  }
  const Stats a = stats(along), c = stats(across);
  EXPECT_NEAR(a.mean, 0.0, 0.02);
  EXPECT_NEAR(c.mean, 0.0, 0.005);
  EXPECT_NEAR(a.stddev, 0.2, 0.012);
  EXPECT_NEAR(c.stddev, 0.05, 0.003);
}

// ---------------------------------------------------------------------------- range-bearing
/// A robot at the origin facing +x with a range_bearing sensor `sensor`, the landmarks `landmarks`
/// (YAML list items) and `extra` (walls, more robots).
std::string range_bearing_world(const std::string& landmarks, const std::string& sensor,
                                const std::string& extra_robots = "",
                                const std::string& extra = "") {
  return "landmarks:\n" + landmarks + extra +
         "robots:\n  - start: {x: 0, y: 0}\n    sensors:\n      range_bearing: " + sensor + "\n" +
         extra_robots;
}

std::vector<Sample<RangeBearingReading>> range_bearing_readings(const std::string& world,
                                                                double seconds,
                                                                std::uint64_t seed = 1) {
  Simulation sim = make_sim(world, seed);
  return collect<RangeBearingReading>(sim, SensorKind::kRangeBearing, seconds);
}

TEST(RangeBearing, RangeAndBearingErrorsHaveTheGivenBiasesAndSpreads) {
  const auto readings = range_bearing_readings(
      range_bearing_world("  - {id: 4, position: [3, 0]}\n",
                          "{rate_hz: 50, sigma_range_m: 0.05, sigma_range_per_m: 0.02, "
                          "range_bias_m: 0.1, range_bias_per_m: 0.01, sigma_bearing_deg: 2, "
                          "bearing_bias_deg: 1}"),
      60.0);
  ASSERT_EQ(readings.size(), 3001u);
  std::vector<double> ranges, bearings;
  for (const auto& r : readings) {
    ASSERT_EQ(r.data.detections.size(), 1u);
    const Detection& d = r.data.detections[0];
    EXPECT_EQ(d.id, 4);
    EXPECT_EQ(d.truth_id, 4);
    EXPECT_EQ(d.target, DetectionTarget::kLandmark);
    ranges.push_back(d.range_m);
    bearings.push_back(d.bearing_rad);
  }
  // Range: 3 + 0.1 + 0.01 * 3 on average, spread 0.05 + 0.02 * 3. Bearing: 1 deg, spread 2 deg.
  // Tolerances: about 4 standard errors of 3001 samples.
  const Stats range = stats(ranges), bearing = stats(bearings);
  EXPECT_NEAR(range.mean, 3.13, 0.008);
  EXPECT_NEAR(range.stddev, 0.11, 0.006);
  EXPECT_NEAR(bearing.mean, deg_to_rad(1.0), 0.0026);
  EXPECT_NEAR(bearing.stddev, deg_to_rad(2.0), deg_to_rad(2.0) * 0.06);
}

TEST(RangeBearing, DepthModeReportsTheDistanceAlongTheAxisWithItsBiasAndSpread) {
  // Off the axis by 26.6 deg (3.35 m away, 3 m deep) and -45 deg (2.83 m away, 2 m deep).
  const std::string landmarks = "  - {id: 1, position: [3, 1.5]}\n  - {id: 2, position: [2, -2]}\n";
  const auto first = [&](const std::string& sensor) {
    const auto readings = range_bearing_readings(range_bearing_world(landmarks, sensor), 0.0);
    EXPECT_EQ(readings.size(), 1u);
    EXPECT_EQ(readings.at(0).data.detections.size(), 2u);
    return readings.at(0).data.detections;
  };
  const std::string exact = "sigma_range_m: 0, sigma_bearing: 0, fov_deg: 120";
  for (const char* model : {"", ", range_model: distance"}) {
    const auto distance = first("{" + exact + model + "}");
    EXPECT_NEAR(distance[0].range_m, std::hypot(3.0, 1.5), 1e-9) << model;
    EXPECT_NEAR(distance[1].range_m, std::hypot(2.0, 2.0), 1e-9) << model;
  }
  const auto depth = first("{" + exact + ", range_model: depth}");
  EXPECT_NEAR(depth[0].range_m, 3.0, 1e-9);
  EXPECT_NEAR(depth[1].range_m, 2.0, 1e-9);
  // The bearing is the true one still.
  EXPECT_NEAR(depth[0].bearing_rad, std::atan2(1.5, 3.0), 1e-9);
  EXPECT_NEAR(depth[1].bearing_rad, -std::numbers::pi / 4, 1e-9);
  // The bias line applies to the depth: 0.05 + (1 + 0.02) x.
  const auto biased =
      first("{" + exact + ", range_model: depth, range_bias_m: 0.05, range_bias_per_m: 0.02}");
  EXPECT_NEAR(biased[0].range_m, 0.05 + 1.02 * 3.0, 1e-9);
  EXPECT_NEAR(biased[1].range_m, 0.05 + 1.02 * 2.0, 1e-9);

  // So does the spread: 60 deg off the axis, 2 m away and 1 m deep, 0.05 m per metre spreads
  // by 0.05 m (by 0.1 m in distance mode). 3001 samples: a standard error of 1.3 %.
  const auto spread = [](const std::string& model) {
    std::vector<double> ranges;
    for (const auto& r : range_bearing_readings(
             range_bearing_world("  - {id: 1, position: [1, 1.7320508075688772]}\n",
                                 "{rate_hz: 50, fov_deg: 150, sigma_range_m: 0, "
                                 "sigma_range_per_m: 0.05, range_model: " +
                                     model + "}"),
             60.0)) {
      EXPECT_EQ(r.data.detections.size(), 1u);
      if (!r.data.detections.empty()) ranges.push_back(r.data.detections[0].range_m);
    }
    EXPECT_EQ(ranges.size(), 3001u);
    return stats(ranges);
  };
  const Stats in_depth = spread("depth"), in_distance = spread("distance");
  EXPECT_NEAR(in_depth.mean, 1.0, 0.004);
  EXPECT_NEAR(in_depth.stddev, 0.05, 0.003);
  EXPECT_NEAR(in_distance.mean, 2.0, 0.008);
  EXPECT_NEAR(in_distance.stddev, 0.1, 0.006);
}

TEST(RangeBearing, ACameraOffItsBelievedMountSeesFromWhereItIsAndReportsFromWhereItIsBelieved) {
  // The camera 0.1 m ahead and 0.05 m left of the robot's origin, believed at the origin: the
  // landmark at (3, 1) is 2.9 m ahead and 0.95 m left of it, and that is what is reported, as if
  // seen from the origin. Believed where it is, the report is the landmark's true place.
  const std::string landmark = "  - {id: 1, position: [3, 1]}\n";
  const std::string exact = "sigma_range_m: 0, sigma_bearing: 0, mount: {x: 0.1, y: 0.05}";
  const auto detection = [&](const std::string& sensor) {
    const auto readings = range_bearing_readings(range_bearing_world(landmark, sensor), 0.0);
    EXPECT_EQ(readings.size(), 1u);
    EXPECT_EQ(readings.at(0).data.detections.size(), 1u);
    return readings.at(0).data.detections.at(0);
  };
  const Detection off = detection("{" + exact + ", believed_mount: {x: 0, y: 0}}");
  EXPECT_NEAR(off.range_m, std::hypot(2.9, 0.95), 1e-9);
  EXPECT_NEAR(off.bearing_rad, std::atan2(0.95, 2.9), 1e-9);
  const Detection known = detection("{" + exact + "}");
  EXPECT_NEAR(known.range_m, std::hypot(3.0, 1.0), 1e-9);
  EXPECT_NEAR(known.bearing_rad, std::atan2(1.0, 3.0), 1e-9);
  // A believed heading turns the report too: the camera's (2.9, 0.95) turned by 10 degrees.
  const Detection turned =
      detection("{" + exact + ", believed_mount: {x: 0.1, y: 0.05, theta_deg: 10}}");
  const double c = std::cos(deg_to_rad(10.0)), s = std::sin(deg_to_rad(10.0));
  const double x = 0.1 + c * 2.9 - s * 0.95, y = 0.05 + s * 2.9 + c * 0.95;
  EXPECT_NEAR(turned.range_m, std::hypot(x, y), 1e-9);
  EXPECT_NEAR(turned.bearing_rad, std::atan2(y, x), 1e-9);
}

TEST(RangeBearing, SpellsOfTwoKindsKeepTheShareSilentAndGiveTheLongOnesTheirShare) {
  // Silent 0.3 of the time; 0.2 of the spells 5 s long on average, the rest 0.5 s. At 50 Hz the
  // gaps between readings are the spells (a frame each way). 4000 s: about 600 spells, 120 long.
  const auto readings = range_bearing_readings(
      range_bearing_world("  - {id: 1, position: [3, 0]}\n",
                          "{rate_hz: 50, outage_fraction: 0.3, outage_mean_s: 0.5, "
                          "outage_long_share: 0.2, outage_long_mean_s: 5}"),
      4000.0);
  std::vector<double> spells_s;
  for (std::size_t k = 1; k < readings.size(); ++k) {
    const double gap_s = readings[k].t_s - readings[k - 1].t_s;
    if (gap_s > 0.03) spells_s.push_back(gap_s - 0.02);
  }
  const double silent_s = std::accumulate(spells_s.begin(), spells_s.end(), 0.0);
  EXPECT_NEAR(silent_s / 4000.0, 0.3, 0.03);
  // The mean spell (0.8 x 0.5 + 0.2 x 5 = 1.4 s), and the spells beyond 3 s: 0.2 e^(-3/5) of
  // them (0.11; short ones almost never last so long), within about three standard errors.
  const double n = static_cast<double>(spells_s.size());
  EXPECT_NEAR(silent_s / n, 1.4, 0.25);
  const double beyond = static_cast<double>(
      std::count_if(spells_s.begin(), spells_s.end(), [](double s) { return s > 3.0; }));
  EXPECT_NEAR(beyond / n, 0.2 * std::exp(-0.6), 0.04);
}

TEST(RangeBearing, FieldOfViewRangeLimitsAndWallsDecideWhatIsSeen) {
  // fov 60 deg (+-30): 26.6 deg is inside, 33.7 deg and behind outside; range [1, 5].
  const auto readings = range_bearing_world(
      "  - {id: 1, position: [3, 1.5]}\n"     // 26.6 deg, 3.35 m: seen
      "  - {id: 2, position: [3, 2]}\n"       // 33.7 deg: outside the field of view
      "  - {id: 3, position: [-3, 0]}\n"      // behind
      "  - {id: 4, position: [5.5, 0]}\n"     // beyond max_range_m
      "  - {id: 5, position: [0.8, -0.3]}\n"  // closer than min_range_m
      "  - {id: 6, position: [2, -3.4]}\n"    // -59.5 deg: outside
      "  - {id: 7, position: [4, -1]}\n",     // -14 deg, behind the wall
      "{sigma_range_m: 0, sigma_bearing: 0, min_range_m: 1, max_range_m: 5, fov_deg: 60}", "",
      "walls:\n  - points: [[3.5, -2], [3.5, -0.5]]\n");
  for (const auto& r : range_bearing_readings(readings, 1.0)) {
    ASSERT_EQ(r.data.detections.size(), 1u);
    const Detection& d = r.data.detections[0];
    EXPECT_EQ(d.id, 1);
    EXPECT_NEAR(d.range_m, std::hypot(3.0, 1.5), 1e-9);
    EXPECT_NEAR(d.bearing_rad, std::atan2(1.5, 3.0), 1e-9);
  }
  // Without the wall, landmark 7 is seen too; a full circle sees those behind and beside.
  const auto open = range_bearing_readings(
      range_bearing_world("  - {id: 7, position: [4, -1]}\n  - {id: 3, position: [-3, 0]}\n",
                          "{min_range_m: 1, max_range_m: 5, fov_deg: 360}"),
      0.0);
  ASSERT_EQ(open.size(), 1u);
  EXPECT_EQ(open[0].data.detections.size(), 2u);
}

TEST(RangeBearing, MissAndFalseDetectionRatesHold) {
  const auto readings = range_bearing_readings(
      range_bearing_world("  - {id: 7, position: [3, 0]}\n  - {id: 9, position: [-3, 0]}\n",
                          "{miss_probability: 0.3, false_detections: 0.5, min_range_m: 0.5, "
                          "max_range_m: 4, fov_deg: 90}"),
      100.0);
  ASSERT_EQ(readings.size(), 1001u);
  int real = 0, phantom = 0, phantom_ids[2] = {0, 0};
  for (const auto& r : readings) {
    for (const Detection& d : r.data.detections) {
      if (d.truth_id == 7) {
        ++real;
        continue;
      }
      ASSERT_EQ(d.truth_id, -1);
      ++phantom;
      ASSERT_TRUE(d.id == 7 || d.id == 9);
      ++phantom_ids[d.id == 7 ? 0 : 1];
      EXPECT_GE(d.range_m, 0.5);
      EXPECT_LE(d.range_m, 4.0);
      EXPECT_LE(std::abs(d.bearing_rad), deg_to_rad(45.0) + 1e-12);
    }
  }
  // 1001 readings: 700 +- 14.5 seen, 500 +- 22 phantoms (Poisson), each landmark's id half of them.
  EXPECT_NEAR(real / 1001.0, 0.7, 0.05);
  EXPECT_NEAR(phantom / 1001.0, 0.5, 0.07);
  EXPECT_NEAR(phantom_ids[0] / static_cast<double>(phantom), 0.5, 0.1);
  // Without ids, phantoms and real detections alike report -1.
  for (const auto& r :
       range_bearing_readings(range_bearing_world("  - {id: 7, position: [3, 0]}\n",
                                                  "{false_detections: 2, report_ids: false}"),
                              1.0)) {
    for (const Detection& d : r.data.detections) EXPECT_EQ(d.id, -1);
  }
}

TEST(RangeBearing, TheChanceOfADetectionFallsWithRangeAsAsked) {
  // (1 - 0.2) e^(-r / 3): 0.57 at 1 m, 0.15 at 5 m, each drawn per landmark and reading. 2001
  // readings: standard errors 0.011 and 0.008.
  const auto readings = range_bearing_readings(
      range_bearing_world("  - {id: 1, position: [1, 0]}\n  - {id: 2, position: [5, 0.5]}\n",
                          "{rate_hz: 10, miss_probability: 0.2, detection_decay_m: 3, "
                          "max_range_m: 7}"),
      200.0);
  ASSERT_EQ(readings.size(), 2001u);
  double near = 0.0, far = 0.0;
  for (const auto& r : readings) {
    for (const Detection& d : r.data.detections) (d.truth_id == 1 ? near : far) += 1.0;
  }
  const double n = static_cast<double>(readings.size());
  EXPECT_NEAR(near / n, 0.8 * std::exp(-1.0 / 3.0), 0.04);
  EXPECT_NEAR(far / n, 0.8 * std::exp(-std::hypot(5.0, 0.5) / 3.0), 0.03);
}

TEST(RangeBearing, SeesOtherRobotsOnlyWhenAskedAndByTheirIndex) {
  const std::string others =
      "  - {name: b, start: {x: 2, y: 0.5}}\n"
      "  - {name: c, start: {x: -2, y: 0}}\n";  // behind
  const std::string landmark = "  - {id: 3, position: [4, -1]}\n";
  const auto with = range_bearing_readings(
      range_bearing_world(landmark, "{sees_robots: true, sigma_range_m: 0, sigma_bearing: 0}",
                          others),
      1.0);
  ASSERT_FALSE(with.empty());
  for (const auto& r : with) {
    ASSERT_EQ(r.data.detections.size(), 2u);
    const Detection& landmark_seen = r.data.detections[0];
    const Detection& robot_seen = r.data.detections[1];
    EXPECT_EQ(landmark_seen.target, DetectionTarget::kLandmark);
    EXPECT_EQ(landmark_seen.id, 3);
    EXPECT_EQ(robot_seen.target, DetectionTarget::kRobot);
    EXPECT_EQ(robot_seen.id, 1);
    EXPECT_EQ(robot_seen.truth_id, 1);
    EXPECT_NEAR(robot_seen.range_m, std::hypot(2.0, 0.5), 1e-6);
  }
  const auto without = range_bearing_readings(range_bearing_world(landmark, "{}", others), 1.0);
  for (const auto& r : without) {
    for (const Detection& d : r.data.detections) EXPECT_EQ(d.target, DetectionTarget::kLandmark);
  }
}

TEST(RangeBearing, ABiasFaultShiftsTheRanges) {
  const auto readings = range_bearing_readings(
      range_bearing_world("  - {id: 1, position: [3, 0]}\n", "{sigma_range_m: 0}") +
          "scenario:\n  events:\n"
          "    - {at_s: 1, sensor_fault: {sensor: range_bearing, mode: bias, "
          "bias: 0.5}}\n",
      2.0);
  ASSERT_FALSE(readings.empty());
  int before = 0, after = 0;
  for (const auto& r : readings) {
    ASSERT_EQ(r.data.detections.size(), 1u);
    if (std::abs(r.t_s - 1.0) < 1e-9) continue;  // the fault's own instant
    EXPECT_NEAR(r.data.detections[0].range_m, r.t_s < 1.0 ? 3.0 : 3.5, 1e-9) << r.t_s;
    ++(r.t_s < 1.0 ? before : after);
  }
  EXPECT_EQ(before, 10);
  EXPECT_EQ(after, 10);
}

// ------------------------------------------------------------------------------- ultrasonic
std::vector<BeaconRange> ranges(const std::string& world, double seconds, std::uint64_t seed = 1) {
  Simulation sim = make_sim(world, seed);
  std::vector<BeaconRange> out;
  for (const auto& r : collect<UltrasonicReading>(sim, SensorKind::kUltrasonic, seconds)) {
    out.insert(out.end(), r.data.ranges.begin(), r.data.ranges.end());
  }
  return out;
}

const char* kBeaconRobot = R"(
robots:
  - start: {x: 0, y: 0}
    sensors:
      ultrasonic:
        receivers: [{position: [0, 0], height_m: 0.5}]
        sigma_m: 0.03
)";

TEST(Ultrasonic, LineOfSightRangesAreTheThreeDimensionalDistanceWithNoise) {
  const auto all = ranges(
      std::string("beacons:\n  - {id: 4, position: [4, 0], height_m: 3.5}\n") + kBeaconRobot, 50.0);
  std::vector<double> errors;
  int dropped = 0;
  for (const BeaconRange& r : all) {
    if (std::isnan(r.range_m)) {
      ++dropped;
      continue;
    }
    EXPECT_EQ(r.truth_status, RangeStatus::kLineOfSight);
    errors.push_back(r.range_m - 5.0);  // sqrt(4^2 + 3^2)
  }
  const Stats s = stats(errors);
  EXPECT_NEAR(s.mean, 0.0, 0.005);
  EXPECT_NEAR(s.stddev, 0.03, 0.003);
  EXPECT_NEAR(dropped / static_cast<double>(all.size()), 0.01, 0.01);
}

TEST(Ultrasonic, AWallBetweenGivesLongerRangesOrNothing) {
  const auto all = ranges(
      std::string(
          "beacons:\n  - {id: 1, position: [4, 0]}\nwalls:\n  - points: [[2, -1], [2, 1]]\n") +
          kBeaconRobot,
      50.0);
  const double truth = std::hypot(4.0, 2.0);
  int nlos = 0;
  for (const BeaconRange& r : all) {
    ASSERT_NE(r.truth_status, RangeStatus::kLineOfSight);
    if (r.truth_status == RangeStatus::kNonLineOfSight) {
      ++nlos;
      EXPECT_GT(r.range_m, truth + 0.1 - 0.15);  // bias_min less 5 sigma of noise
    } else {
      EXPECT_TRUE(std::isnan(r.range_m));
    }
  }
  EXPECT_NEAR(nlos / static_cast<double>(all.size()), 0.5, 0.06);
}

TEST(Ultrasonic, InjectedErrorsLengthenThatShareOfClearReadings) {
  // Paper 003's MATLAB simulation: no obstacle, yet 20 % of the readings come back long.
  std::string robot = kBeaconRobot;
  robot += "        outlier_probability: 0.2\n";
  const auto all =
      ranges(std::string("beacons:\n  - {id: 4, position: [4, 0], height_m: 3.5}\n") + robot, 50.0);
  int outliers = 0, answered = 0;
  for (const BeaconRange& r : all) {
    if (std::isnan(r.range_m)) continue;
    ++answered;
    if (r.truth_status == RangeStatus::kNonLineOfSight) {
      ++outliers;
      EXPECT_GT(r.range_m, 5.0 + 0.1 - 0.15);  // bias_min less 5 sigma of noise
    } else {
      EXPECT_NEAR(r.range_m, 5.0, 0.15);
    }
  }
  EXPECT_NEAR(outliers / static_cast<double>(answered), 0.2, 0.03);
}

TEST(Ultrasonic, LowObstaclesAreOverlookedAndOutOfRangeIsReported) {
  // A 0.3 m box between a receiver at 0.5 m and a beacon at 2.5 m does not block.
  auto all = ranges(std::string("beacons:\n  - {id: 1, position: [4, 0]}\nboxes:\n  - {center: [2, "
                                "0], size: [0.4, 2], height_m: 0.3}\n") +
                        kBeaconRobot,
                    5.0);
  for (const BeaconRange& r : all) EXPECT_NE(r.truth_status, RangeStatus::kNonLineOfSight);
  all = ranges(std::string("beacons:\n  - {id: 1, position: [40, 0]}\n") + kBeaconRobot, 1.0);
  for (const BeaconRange& r : all) EXPECT_EQ(r.truth_status, RangeStatus::kOutOfRange);
}

TEST(Ultrasonic, APersonWalkingThroughTheBeamCausesABurstOfBadReadings) {
  Simulation sim = make_sim(std::string(R"(
beacons:
  - {id: 1, position: [6, 0], height_m: 1.0}
movers:
  - {name: walker, path: [[3, -4], [3, 4]], speed_mps: 1.0, loop: false}
)") + kBeaconRobot);
  const auto readings = collect<UltrasonicReading>(sim, SensorKind::kUltrasonic, 8.0);
  int bad_before = 0, bad_during = 0, bad_after = 0, during = 0;
  for (const auto& r : readings) {
    const bool bad = r.data.ranges[0].truth_status != RangeStatus::kLineOfSight &&
                     r.data.ranges[0].truth_status != RangeStatus::kDropped;
    const bool blocked = r.data.ranges[0].truth_status == RangeStatus::kNonLineOfSight ||
                         (r.data.ranges[0].truth_status == RangeStatus::kDropped);
    (void)bad;
    // The walker (radius 0.25) crosses the line y = 0 between t = 3.75 s and 4.25 s.
    if (r.t_s < 3.6)
      bad_before += blocked;
    else if (r.t_s > 4.4)
      bad_after += blocked;
    else if (r.t_s > 3.8 && r.t_s < 4.2)
      bad_during += blocked, ++during;
  }
  EXPECT_EQ(bad_during, during);  // every reading while the walker stands in the beam
  EXPECT_LE(bad_before, 3);       // ~1 % random dropouts only
  EXPECT_LE(bad_after, 3);
}

// ------------------------------------------------------------------------------------ laser
TEST(Laser, RangesToAWallAreGaussianAroundTheTruth) {
  Simulation sim = make_sim(R"(
walls:
  - points: [[3, -10], [3, 10]]
robots:
  - start: {x: 0, y: 0}
    sensors:
      laser: {beams: 181, fov_deg: 180, sigma_m: 0.02, p_short: 0, p_max: 0, p_random: 0, max_range_m: 10}
)");
  std::vector<double> centre_errors;
  for (const auto& scan : collect<LaserScan>(sim, SensorKind::kLaser, 50.0)) {
    ASSERT_EQ(scan.data.ranges_m.size(), 181u);
    centre_errors.push_back(scan.data.ranges_m[90] - 3.0);
    // Beam 60 is 30 deg right of the axis: it meets the wall at 3 / cos(30 deg).
    EXPECT_NEAR(scan.data.ranges_m[60], 3.0 / std::cos(deg_to_rad(30.0)), 0.12);
    EXPECT_FLOAT_EQ(scan.data.ranges_m[0], 10.0f);  // parallel to the wall: nothing
  }
  const Stats s = stats(centre_errors);
  EXPECT_NEAR(s.mean, 0.0, 0.004);
  EXPECT_NEAR(s.stddev, 0.02, 0.003);
}

TEST(Laser, MixtureProducesMaxRandomAndShortReadingsAtTheirRates) {
  Simulation sim = make_sim(R"(
walls:
  - points: [[5, -10], [5, 10]]
robots:
  - start: {x: 0, y: 0}
    sensors:
      laser: {beams: 100, fov_deg: 20, sigma_m: 0.0, p_short: 0.1, lambda_short: 1.0, p_max: 0.05, p_random: 0.05, max_range_m: 8}
)");
  int max_readings = 0, short_readings = 0, total = 0;
  for (const auto& scan : collect<LaserScan>(sim, SensorKind::kLaser, 20.0)) {
    for (const float r : scan.data.ranges_m) {
      ++total;
      if (r == 8.0f) ++max_readings;
      if (r < 4.9f) ++short_readings;
    }
  }
  EXPECT_NEAR(max_readings / double(total), 0.05, 0.01);
  // Short: p_short (all phantoms fall below 5 m with prob 1 - e^-5) + p_random x 4.9 / 8.
  EXPECT_NEAR(short_readings / double(total), 0.1 * (1 - std::exp(-4.9)) + 0.05 * 4.9 / 8, 0.015);
}

TEST(Laser, SeesPeopleAndOtherRobotsButNotItself) {
  Simulation sim = make_sim(R"(
movers:
  - {name: p, path: [[2, 0]], speed_mps: 0}
robots:
  - name: a
    start: {x: 0, y: 0}
    sensors: {laser: {beams: 360, fov_deg: 360, sigma_m: 0, p_short: 0, p_max: 0, p_random: 0}}
  - {name: b, start: {x: 0, y: -1.5}}
)");
  const auto scans = collect<LaserScan>(sim, SensorKind::kLaser, 0.0);
  ASSERT_EQ(scans.size(), 1u);
  const auto& ranges_m = scans[0].data.ranges_m;
  // Full circle: beam i at -180 + i deg, so beam 180 looks ahead and beam 90 to the right.
  EXPECT_NEAR(ranges_m[180], 2.0 - 0.25, 1e-3);  // the person's surface
  EXPECT_NEAR(ranges_m[90], 1.5 - 0.2, 1e-3);    // robot b
  EXPECT_FLOAT_EQ(ranges_m[0], 8.0f);            // behind: open space, not its own body
}

TEST(StaticRaycaster, AgreesWithBox2dOnTheOfficeMap) {
  WorldDef world =
      load_world(std::filesystem::path(LOCSIM_SOURCE_DIR) / "worlds/maps/office_world.yaml");
  world.movers.clear();  // static geometry only: Box2D's cast would also see the visitor
  ScenarioDef scenario;
  bind_scenario(scenario, world);
  const Simulation sim(world, scenario, 1);
  const StaticRaycaster grid = StaticRaycaster::from_world(sim.world());
  RandomStream rng = make_stream(1, "rays");
  int compared = 0;
  for (int i = 0; i < 3000; ++i) {
    const Vec2 origin{rng.uniform(0.3, 11.7), rng.uniform(0.3, 8.7)};
    const double angle = rng.uniform(-std::numbers::pi, std::numbers::pi);
    const Vec2 direction{std::cos(angle), std::sin(angle)};
    const double ours = grid.cast(origin, direction, 20.0);
    // Box2D ignores shapes the ray starts inside; skip those origins.
    const b2Body* robot = sim.robot(0).body();  // Box2D would see the robot too
    if (!sim.world().is_free(b2CircleShape(), Pose2{origin.x(), origin.y(), 0}, robot)) continue;
    const auto box2d = sim.world().ray_cast(origin, origin + 20.0 * direction, robot);
    ASSERT_EQ(box2d.has_value(), std::isfinite(ours)) << origin.transpose() << " " << angle;
    if (box2d) {
      EXPECT_NEAR(ours, *box2d, 1e-4);
    }
    ++compared;
  }
  EXPECT_GT(compared, 2000);
}

/// A dynamic body (no fixture yet) at a random place within spread_m of the origin, turned at
/// random.
b2Body* scattered_body(b2World& world, RandomStream& rng, double spread_m) {
  b2BodyDef def;
  def.type = b2_dynamicBody;
  const double x = rng.uniform(-spread_m, spread_m);
  const double y = rng.uniform(-spread_m, spread_m);
  def.position.Set(static_cast<float>(x), static_cast<float>(y));
  def.angle = static_cast<float>(rng.uniform(-3.0, 3.0));
  return world.CreateBody(&def);
}

// A laser's broad phase (SceneRays::fan_candidates) keeps, for every beam, each moving body that
// beam can hit, in order: each beam's range is the same double as when testing every body, for
// fans of every shape, origins inside a body, an ignored body, fans crossing +-180 deg. And it
// culls: a beam is tested against few of a crowd's bodies.
TEST(SceneRays, FanCandidatesGiveTheSameRangesAsTestingEveryBody) {
  b2World world(b2Vec2(0.0f, 0.0f));
  RandomStream rng = make_stream(7, "fan");
  std::vector<DynamicOccluder> occluders;
  for (int i = 0; i < 120; ++i) {
    b2Body* body = scattered_body(world, rng, 20.0);
    double radius_m = 0.0;
    if (i % 2 == 0) {
      b2CircleShape circle;
      circle.m_radius = static_cast<float>(rng.uniform(0.1, 0.6));
      body->CreateFixture(&circle, 1.0f);
      radius_m = circle.m_radius;
    } else {
      b2PolygonShape box;
      const double hx = rng.uniform(0.1, 0.8), hy = rng.uniform(0.1, 0.4);
      box.SetAsBox(static_cast<float>(hx), static_cast<float>(hy));
      body->CreateFixture(&box, 1.0f);
      radius_m = std::hypot(hx, hy);
    }
    occluders.push_back({body, 1.0, radius_m});
  }
  const StaticRaycaster statics({{{-25, -25}, {25, -25}}, {{25, -25}, {25, 25}}}, {});
  const SceneRays rays(statics, occluders);
  FanCandidates candidates;
  std::size_t tested = 0, beams_cast = 0, hits_on_bodies = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const bool inside = trial % 6 == 0;  // the origin at a body's centre, not ignored
    const b2Body* ignore = trial % 3 == 0 ? occluders[trial].body : nullptr;
    const Vec2 origin = inside ? from_b2(occluders[trial + 1].body->GetPosition())
                               : Vec2{rng.uniform(-20.0, 20.0), rng.uniform(-20.0, 20.0)};
    const double heading = rng.uniform(-std::numbers::pi, std::numbers::pi);
    const int beams = std::vector<int>{360, 271, 31, 1}[trial % 4];
    const double fov = std::vector<double>{2.0 * std::numbers::pi, 4.71, 0.3, 0.0}[trial % 4];
    const double max_range_m = trial % 5 == 0 ? 4.0 : 30.0;
    std::vector<double> angles;
    for (int i = 0; i < beams; ++i) angles.push_back(laser_beam_angle(i, beams, fov));
    rays.fan_candidates(origin, heading, angles, max_range_m, ignore, candidates);
    const double c = std::cos(heading), s = std::sin(heading);
    for (int i = 0; i < beams; ++i) {
      const Vec2 local{std::cos(angles[i]), std::sin(angles[i])};
      const Vec2 d{c * local.x() - s * local.y(), s * local.x() + c * local.y()};
      const double all = rays.cast(origin, d, max_range_m, ignore);
      const double culled = rays.cast(origin, d, max_range_m, candidates.of(i));
      ASSERT_EQ(all, culled) << "trial " << trial << " beam " << i;
      hits_on_bodies += all < statics.cast(origin, d, max_range_m);
      tested += candidates.of(i).size();
      ++beams_cast;
    }
  }
  EXPECT_GT(hits_on_bodies, 500u);  // the bodies are seen: the comparison means something
  EXPECT_LT(static_cast<double>(tested), 0.1 * static_cast<double>(beams_cast * occluders.size()));
}

// While the sensors sample, SceneRays files the moving bodies in a grid (SceneRays::Indexed) and
// a ray tests only the bodies in the cells it crosses: every answer (casts past an ignored body,
// lines of sight in 2D and 3D, a laser's fan) is the same as testing every body, for a crowd with
// disabled bodies, rays starting inside bodies and outside the crowd, rays of every length.
TEST(SceneRays, IndexedQueriesGiveTheSameAnswersAsTestingEveryBody) {
  for (const bool stragglers : {false, true}) {
    SCOPED_TRACE(stragglers ? "with stragglers" : "a crowd");
    b2World world(b2Vec2(0.0f, 0.0f));
    RandomStream rng = make_stream(11, "index");
    std::vector<DynamicOccluder> occluders;
    for (int i = 0; i < 150; ++i) {
      // A crowd (cells of about 2.5 m, each body filed in one to four), then with a few stragglers
      // far off (cells of 16 m: coarse, and still the same answers).
      b2Body* body = scattered_body(world, rng, stragglers && i % 50 == 49 ? 200.0 : 15.0);
      b2PolygonShape box;
      const double hx = rng.uniform(0.1, 0.6), hy = rng.uniform(0.1, 0.4);
      box.SetAsBox(static_cast<float>(hx), static_cast<float>(hy));
      body->CreateFixture(&box, 1.0f);
      if (i % 17 == 0) body->SetEnabled(false);  // carried: seen by nothing
      occluders.push_back({body, rng.uniform(0.3, 2.0), std::hypot(hx, hy)});
    }
    const StaticRaycaster statics({{{-18, -18}, {18, -18}}, {{18, -18}, {18, 18}}}, {});
    SceneRays rays(statics, occluders);
    struct Answers {
      std::vector<double> casts;
      std::vector<bool> blocked;
    };
    const auto ask = [&](RandomStream queries) {
      Answers answers;
      FanCandidates fan;
      for (int q = 0; q < 3000; ++q) {
        const bool inside = q % 10 == 0;
        const Vec2 a = inside ? from_b2(occluders[q % occluders.size()].body->GetPosition())
                              : Vec2{queries.uniform(-25.0, 25.0), queries.uniform(-25.0, 25.0)};
        const double length_m = std::vector<double>{0.5, 4.0, 12.0, 60.0}[q % 4];
        const double angle = queries.uniform(-std::numbers::pi, std::numbers::pi);
        const Vec2 d{std::cos(angle), std::sin(angle)};
        const b2Body* ignore = q % 3 == 0 ? occluders[(q * 7) % occluders.size()].body : nullptr;
        answers.casts.push_back(rays.cast(a, d, length_m, ignore));
        answers.blocked.push_back(rays.blocked(a, a + length_m * d, ignore));
        answers.blocked.push_back(rays.blocked(a, queries.uniform(0.0, 2.0), a + length_m * d,
                                               queries.uniform(0.0, 2.5), ignore));
        if (q % 50 == 0) {
          std::vector<double> angles;
          for (int i = 0; i < 181; ++i) angles.push_back(laser_beam_angle(i, 181, 4.0));
          rays.fan_candidates(a, angle, angles, length_m, ignore, fan);
          for (int i = 0; i < 181; ++i) {
            const Vec2 beam{std::cos(angle + angles[i]), std::sin(angle + angles[i])};
            answers.casts.push_back(rays.cast(a, beam, length_m, fan.of(i)));
          }
        }
      }
      return answers;
    };
    ASSERT_FALSE(rays.indexed());
    const Answers every_body = ask(make_stream(3, "queries"));
    Answers through_grid;
    {
      const SceneRays::Indexed indexed(rays);
      ASSERT_TRUE(rays.indexed());
      through_grid = ask(make_stream(3, "queries"));
    }
    EXPECT_FALSE(rays.indexed());  // nothing may use positions the bodies have left
    ASSERT_EQ(every_body.casts.size(), through_grid.casts.size());
    std::size_t on_bodies = 0;
    for (std::size_t i = 0; i < every_body.casts.size(); ++i) {
      ASSERT_EQ(every_body.casts[i], through_grid.casts[i]) << "query " << i;
      on_bodies += every_body.casts[i] < kNoHit;
    }
    EXPECT_EQ(every_body.blocked, through_grid.blocked);
    const auto blocked_count =
        std::count(every_body.blocked.begin(), every_body.blocked.end(), true);
    // Both answers occur often: the comparison means something.
    EXPECT_GT(on_bodies, 2000u);
    EXPECT_GT(blocked_count, 1000);
    EXPECT_LT(blocked_count, static_cast<std::ptrdiff_t>(every_body.blocked.size()) - 1000);
  }
}

// ----------------------------------------------------------------------------------- faults
TEST(SensorFaults, DropoutStuckAndBiasStepApplyForTheirIntervals) {
  Simulation sim = make_sim(R"(
walls:
  - points: [[3, -10], [3, 10]]
robots:
  - start: {x: 0, y: 0}
    sensors:
      laser: {beams: 1, sigma_m: 0.01, p_short: 0, p_max: 0, p_random: 0}
scenario:
  events:
    - {at_s: 1, sensor_fault: {sensor: laser, mode: dropout, duration_s: 1}}
    - {at_s: 3, sensor_fault: {sensor: laser, mode: stuck, duration_s: 1}}
    - {at_s: 5, sensor_fault: {sensor: laser, mode: bias, bias: 0.5}}
)");
  const auto scans = collect<LaserScan>(sim, SensorKind::kLaser, 7.0);
  std::map<int, std::vector<float>> by_second;
  for (const auto& s : scans)
    by_second[static_cast<int>(std::floor(s.t_s + 1e-9))].push_back(s.data.ranges_m[0]);
  EXPECT_EQ(by_second.count(1), 0u);  // dropout [1, 2)
  EXPECT_EQ(by_second[2].size(), 10u);
  for (const float r : by_second[3]) EXPECT_EQ(r, by_second[2].back());  // stuck at the last value
  EXPECT_NE(by_second[4][1], by_second[4][2]);                           // moving again
  for (const float r : by_second[6]) EXPECT_NEAR(r, 3.5, 0.05);          // biased from t = 5 on
}

}  // namespace
}  // namespace locsim
