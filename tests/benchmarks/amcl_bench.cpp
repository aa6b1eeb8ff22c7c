// AMCL on the laser as a run drives it, through the plugin's C table: each iteration is one
// odometry reading (0.3 m of travel, past update_min_d) and one scan of 271 beams of which 60
// are used, so one filter update: motion, the likelihood field, KLD resampling, the estimate.
// The set-up of issue 8's target: a 20 m map at 5 cm; min = max particles so that the count is
// the argument. Target: >= 2 million particle updates per second per core (nav2 AMCL's core
// 0.2-0.27 M, MRPT 2.5 about 0.36 M on this machine, as the issue measured).
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "plugin_fixture.hpp"

namespace {

using namespace locsim;

/// 20 x 20 m at 5 cm: outer walls, a cross of inner walls with doorways, and pillars, so that the
/// likelihood field is not trivially flat.
struct Building {
  static constexpr int kCells = 400;
  static constexpr double kResolution = 0.05;
  std::vector<std::uint8_t> cells = std::vector<std::uint8_t>(kCells * kCells, 0);
  locsim_map map{};
  locsim_robot_info robot{0.33, 0.05, 0.2};

  Building() {
    const auto wall = [&](int c0, int r0, int c1, int r1) {
      for (int r = r0; r <= r1; ++r)
        for (int c = c0; c <= c1; ++c) cells[static_cast<std::size_t>(r) * kCells + c] = 100;
    };
    wall(0, 0, kCells - 1, 1), wall(0, kCells - 2, kCells - 1, kCells - 1);
    wall(0, 0, 1, kCells - 1), wall(kCells - 2, 0, kCells - 1, kCells - 1);
    wall(199, 0, 201, 150), wall(199, 190, 201, 399);  // a doorway at rows 151-189
    wall(0, 199, 150, 201), wall(190, 199, 399, 201);
    for (int p = 50; p < kCells; p += 100) wall(p, p, p + 6, p + 6);
    map.grid = {0.0, 0.0, kResolution, kCells, kCells, cells.data()};
  }

  /// Distance from (x, y) along `angle` to the first occupied cell, up to max_range.
  float cast(double x, double y, double angle, double max_range) const {
    const double step = 0.5 * kResolution;
    for (double r = 0.0; r < max_range; r += step) {
      const auto c = static_cast<int>((x + r * std::cos(angle)) / kResolution);
      const auto w = static_cast<int>((y + r * std::sin(angle)) / kResolution);
      if (c < 0 || w < 0 || c >= kCells || w >= kCells ||
          cells[static_cast<std::size_t>(w) * kCells + c] != 0)
        return static_cast<float>(r);
    }
    return static_cast<float>(max_range);
  }
};

/// The robot driving a 3 m circle about (5, 5) in the first room, 0.3 m per update, and its
/// 270-degree scan of 271 beams, 8 m, cast in the map from the pose moved by `offset` (x, y,
/// heading; none: the true pose). advance() is the simulator's work, not timed.
struct CircleDrive {
  static constexpr int kBeams = 271;
  const Building& building;
  std::vector<float> angles = std::vector<float>(kBeams), ranges = std::vector<float>(kBeams);
  locsim_reading odometry{}, scan{};
  double a = 0.0;
  std::array<double, 3> offset{0.0, 0.0, 0.0};

  explicit CircleDrive(const Building& b) : building(b) {
    for (int k = 0; k < kBeams; ++k) angles[k] = static_cast<float>((-135.0 + k) * M_PI / 180.0);
    odometry.struct_size = scan.struct_size = sizeof(locsim_reading);
    odometry.kind = LOCSIM_READING_ODOMETRY;
    scan.kind = LOCSIM_READING_LASER;
    scan.data.laser = {ranges.data(), angles.data(), kBeams, {0.1, 0.0, 0.0}, 0.05, 8.0};
  }
  void advance() {
    a += 0.1;
    const double x = 5.0 + 3.0 * std::cos(a), y = 5.0 + 3.0 * std::sin(a), theta = a + M_PI / 2;
    odometry.data.odometry.odom_pose = {x, y, theta};
    odometry.t_s = scan.t_s = a;
    const double sx = x + offset[0] + 0.1 * std::cos(theta);
    const double sy = y + offset[1] + 0.1 * std::sin(theta);
    for (int k = 0; k < kBeams; ++k)
      ranges[k] = building.cast(sx, sy, theta + offset[2] + angles[k], 8.0);
  }
  bool update(bench::PluginFixture& f) const { return f.update(odometry) && f.update(scan); }
};

void BM_AmclUpdate(benchmark::State& state) {
  const Building building;
  const std::string n = std::to_string(state.range(0));
  bench::PluginFixture f("amcl",
                         {{"min_particles", n}, {"max_particles", n}, {"laser_max_beams", "60"}},
                         building.map, building.robot, {5.0, 5.0, 0.0}, 0.04, 0.01);
  CircleDrive drive(building);
  const auto advance = [&] { drive.advance(); };
  const auto update = [&] { return drive.update(f); };
  bench::run_updates(state, f, 5, advance, update);
  state.counters["particle_updates_per_s"] = benchmark::Counter(
      static_cast<double>(state.range(0)) * static_cast<double>(state.iterations()),
      benchmark::Counter::kIsRate);
}
BENCHMARK(BM_AmclUpdate)->Arg(1000)->Arg(5000)->Arg(20000)->Unit(benchmark::kMicrosecond);

// What recovery costs while the filter is lost: AMCL's defaults (500-5000 particles, random
// injection on), 30 updates tracking the circle, then the 200 timed updates with the scan of each
// cast from a pose moved off the circle by one of four offsets in turn (the rooms are alike, a
// move to another would not be noticed), so that the scans never agree with the belief and w_fast
// stays below w_slow. The argument is recovery_candidates: 1 injects uniform poses (AMCL's), 10 the
// best fit of ten draws (the default), each draw one more scan weighing.
void BM_AmclLost(benchmark::State& state) {
  const Building building;
  bench::PluginFixture f("amcl",
                         {{"recovery_candidates", std::to_string(state.range(0))},
                          {"recovery_search_updates", std::to_string(state.range(1))},
                          {"laser_max_beams", "60"}},
                         building.map, building.robot, {5.0, 5.0, 0.0}, 0.04, 0.01);
  CircleDrive drive(building);
  int turn = 0;
  const auto advance = [&] {
    constexpr std::array<std::array<double, 3>, 4> kOffsets = {
        {{0.0, 0.0, 0.0}, {1.5, -1.0, 1.0}, {-1.0, 1.5, 2.0}, {1.0, 1.0, -1.5}}};
    drive.offset = kOffsets[turn++ % 4];
    drive.advance();
  };
  const auto update = [&] { return drive.update(f); };
  for (int i = 0; i < 30; ++i) drive.advance(), update();  // tracking
  double injected = 0.0;  // the recovery's guesses, summed over the timed updates
  const auto update_and_count = [&] {
    const bool ok = update();
    state.PauseTiming();
    locsim_diagnostic diagnostics[16];
    std::size_t count = 0;
    char error[128];
    if (f.table().diagnostics(f.filter(), diagnostics, 16, &count, error, sizeof error) == 0)
      for (std::size_t d = 0; d < count; ++d)
        if (std::string(diagnostics[d].name) == "injected") injected += diagnostics[d].value;
    state.ResumeTiming();
    return ok;
  };
  bench::run_updates(state, f, 0, advance, update_and_count);
  state.counters["injected_per_update"] = injected / static_cast<double>(state.iterations());
}
// Arguments: recovery_candidates, recovery_search_updates (AMCL's one uniform draw; best of ten
// uniform and near; the default, best of ten about the searched places, searching every fifth).
BENCHMARK(BM_AmclLost)
    ->Args({1, 0})
    ->Args({10, 0})
    ->Args({10, 5})
    ->Iterations(200)
    ->Unit(benchmark::kMicrosecond);

}  // namespace
