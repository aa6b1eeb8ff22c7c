// Paper 003's ultrasonic + IMU EKF through the plugin's C table, as a run drives it: each
// iteration is 50 ms of readings, five IMU samples (100 Hz) and one ultrasonic round (20 Hz) of
// two receivers to four ceiling beacons, one of the eight ranges lengthened by a person in the
// beam. Argument 0: the paper's trilateration; 1: gated raw ranges; 2: gated raw ranges in an
// office, where twelve beacons answer each receiver and nine of them by an echo off a wall: most
// of every round is gated out, so the filter counts itself lost round after round and tries the
// echo-robust restart each time (every three of a receiver's twelve ranges trilaterated), which
// the estimate, explaining the direct ranges, keeps from taking over. The readings are computed
// from a robot driving a 3 m circle outside the timed region.
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "plugin_fixture.hpp"

namespace {

using namespace locsim;

void BM_UltrasonicEkfRound(benchmark::State& state) {
  const bool office = state.range(0) == 2;
  std::vector<locsim_beacon> beacons = {
      {1, 0.2, 0.2, 2.8}, {2, 11.8, 0.2, 2.8}, {3, 11.8, 7.8, 2.8}, {4, 0.2, 7.8, 2.8}};
  if (office) {  // eight more, beyond the room's walls: they answer by echoes
    for (int i = 0; i < 8; ++i)
      beacons.push_back({5 + i, -6.0 + 4.0 * i, i % 2 == 0 ? -4.0 : 12.0, 2.8});
  }
  constexpr int kDirectInOffice = 3;  // beacons 1-3; 4 too is behind a partition there
  locsim_map map{};
  map.beacons = beacons.data();
  map.beacon_count = beacons.size();
  const locsim_robot_info robot{0.33, 0.05, 0.2};
  const std::string mode = state.range(0) == 0 ? "trilateration" : "ranges";
  bench::PluginFixture f("ultrasonic_ekf", {{"mode", mode}}, map, robot, {9.0, 4.0, M_PI / 2}, 1e-4,
                         1e-4);

  constexpr double kRadius = 3.0, kSpeed = 0.3, kOmega = kSpeed / kRadius;
  std::vector<locsim_beacon_range> ranges(2 * beacons.size());
  locsim_reading imu{}, round{};
  imu.struct_size = round.struct_size = sizeof(locsim_reading);
  imu.kind = LOCSIM_READING_IMU;
  round.kind = LOCSIM_READING_BEACON_RANGES;
  round.data.beacon_ranges = {ranges.data(), ranges.size()};
  double t = 0.0;
  int person = 0;
  const auto advance = [&] {  // the next round's ranges: the simulator's work, not timed
    t += 0.05;
    const double a = kOmega * t, x = 6.0 + kRadius * std::cos(a), y = 4.0 + kRadius * std::sin(a);
    const double theta = a + M_PI / 2;
    std::size_t k = 0;
    for (int receiver = 0; receiver < 2; ++receiver) {
      const double side = receiver == 0 ? 0.15 : -0.15;
      const double rx = x - side * std::sin(theta), ry = y + side * std::cos(theta);
      for (std::size_t i = 0; i < beacons.size(); ++i) {
        const locsim_beacon& b = beacons[i];
        const double d = std::sqrt((b.x - rx) * (b.x - rx) + (b.y - ry) * (b.y - ry) +
                                   (b.height_m - 0.4) * (b.height_m - 0.4));
        // An echo's extra path, 0.1 m and more, different per beacon and round.
        const double echo = office && static_cast<int>(i) >= kDirectInOffice
                                ? 0.1 + std::fmod(0.37 * static_cast<double>(k) + 3.1 * t, 2.0)
                                : (!office && static_cast<int>(k) == person ? 0.6 : 0.0);
        ranges[k] = {receiver, b.id, d + echo, 0.0, side, 0.4};
        ++k;
      }
    }
    person = (person + 1) % 8;
  };
  const auto update = [&] {
    for (int i = 0; i < 5; ++i) {
      imu.t_s = t - 0.05 + 0.01 * (i + 1);
      imu.data.imu = {kOmega, 0.0, kSpeed * kOmega, 0.0};  // centripetal, to the left
      if (!f.update(imu)) return false;
    }
    round.t_s = t;
    return f.update(round);
  };
  bench::run_updates(state, f, 20, advance, update);
  // What the rounds made of the filter: lost rounds and restarts show in its diagnostics.
  std::array<locsim_diagnostic, 32> diagnostics{};
  std::size_t count = 0;
  char error[256] = {};
  if (f.table().diagnostics(f.filter(), diagnostics.data(), diagnostics.size(), &count, error,
                            sizeof error) == 0) {
    for (std::size_t i = 0; i < count; ++i) {
      const std::string name = diagnostics[i].name;
      if (name == "restarts" || name == "echo_restarts" || name == "ranges_gated")
        state.counters[name] = diagnostics[i].value;
    }
  }
  state.counters["rounds_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_UltrasonicEkfRound)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

/// Range-only localization as a lawnmower ranging to UWB anchors does it (real_data.md, CMU
/// Plaza): each iteration is 0.25 s of readings, one odometry reading (wheel travel, no IMU) and
/// one range to the next of four anchors 30-60 m away, with 0.5 m of noise. Argument 0:
/// ultrasonic_ekf predicting by the wheels; 1: beacon_mcl with its default 1000 particles; 2:
/// ultrasonic_ekf on an odometry that turns by a gyro, estimating its bias (the sixth state in
/// use). The robot drives a 20 m circle.
void BM_RangeOnlyRound(benchmark::State& state) {
  std::vector<locsim_beacon> beacons = {
      {0, -30.0, 0.0, 0.0}, {1, 30.0, -10.0, 0.0}, {5, 20.0, 40.0, 0.0}, {6, -20.0, 50.0, 0.0}};
  locsim_map map{};
  map.beacons = beacons.data();
  map.beacon_count = beacons.size();
  const locsim_robot_info robot{0.5, 0.1, 0.5};
  constexpr double kRadius = 20.0, kSpeed = 1.0, kOmega = kSpeed / kRadius, kDt = 0.25;
  const bool particles = state.range(0) == 1;
  std::vector<std::pair<std::string, std::string>> params = {
      {"sigma_range_m", "0.5"}, {"k_left", "0.01"}, {"k_right", "0.01"}};
  if (state.range(0) == 2) {
    params.insert(params.end(), {{"odometry_heading", "gyro"},
                                 {"heading_noise_density", "0.001"},
                                 {"heading_rate_bias_sigma", "0.005"},
                                 {"heading_rate_scale_error", "-0.01"}});
  }
  bench::PluginFixture f(particles ? "beacon_mcl" : "ultrasonic_ekf", params, map, robot,
                         {kRadius, 0.0, M_PI / 2}, 1e-4, 1e-4);
  locsim_beacon_range range{};
  locsim_reading odometry{}, round{};
  odometry.struct_size = round.struct_size = sizeof(locsim_reading);
  odometry.kind = LOCSIM_READING_ODOMETRY;
  round.kind = LOCSIM_READING_BEACON_RANGES;
  round.data.beacon_ranges = {&range, 1};
  double t = 0.0;
  std::size_t next = 0;
  const auto advance = [&] {  // the next readings: the simulator's work, not timed
    t += kDt;
    const double a = kOmega * t;
    odometry.t_s = round.t_s = t;
    odometry.data.odometry = {};
    odometry.data.odometry.fields = LOCSIM_ODOMETRY_POSE;
    // The odometry frame is the world's here: the pose on the circle.
    odometry.data.odometry.odom_pose = {kRadius * std::cos(a), kRadius * std::sin(a), a + M_PI / 2};
    const locsim_beacon& b = beacons[next];
    next = (next + 1) % beacons.size();
    const double d = std::hypot(b.x - kRadius * std::cos(a), b.y - kRadius * std::sin(a));
    range = {0, b.id, d + 0.5 * std::sin(7.3 * t), 0.0, 0.0, 0.0};  // a bounded, varying error
  };
  const auto update = [&] { return f.update(odometry) && f.update(round); };
  bench::run_updates(state, f, 20, advance, update);
  state.counters["rounds_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RangeOnlyRound)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

}  // namespace
