// The landmark particle filters as a run drives them: each iteration is one odometry reading and
// one camera frame with 6 detections through the plugin's C table (motion, weighting,
// resampling and, for srl/asrl, sensor resetting). Target (issue 6): >= 10 million particle
// updates per second per core, so 10 000 particles take well under a millisecond.
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "plugin_fixture.hpp"

namespace {

using namespace locsim;

// Paper 004's field: 6 x 4 m, six coloured posts at its edges.
struct Field {
  std::array<const char*, 6> colors = {"red", "green", "blue", "yellow", "magenta", "cyan"};
  std::array<std::array<double, 2>, 6> posts = {
      {{0.15, 0.15}, {3.0, 0.15}, {5.85, 0.15}, {5.85, 3.85}, {3.0, 3.85}, {0.15, 3.85}}};
  std::vector<locsim_landmark> landmarks;
  std::vector<std::uint8_t> cells = std::vector<std::uint8_t>(60 * 40, 0);  // 10 cm, all free
  locsim_map map{};
  locsim_robot_info robot{0.3, 0.05, 0.2};

  Field() {
    for (int i = 0; i < 6; ++i)
      landmarks.push_back({i + 1, posts[i][0], posts[i][1], 0.05, 0.5, colors[i]});
    map.landmarks = landmarks.data();
    map.landmark_count = landmarks.size();
    map.grid = {0.0, 0.0, 0.1, 60, 40, cells.data()};
  }
};

void BM_LandmarkPluginUpdate(benchmark::State& state, const char* plugin) {
  const Field field;
  bench::PluginFixture plugin_fixture(plugin, {{"particles", std::to_string(state.range(0))}},
                                      field.map, field.robot, {3.0, 2.0, 0.0}, 0.01, 0.01);
  bench::PluginFixture& f = plugin_fixture;

  // The robot drives a 1 m circle about the field's centre at 0.3 m/s; a frame every 0.2 s.
  double t_s = 0.0;
  std::vector<locsim_detection> detections(6);
  locsim_reading odometry{}, frame{};
  odometry.struct_size = frame.struct_size = sizeof(locsim_reading);
  odometry.kind = LOCSIM_READING_ODOMETRY;
  frame.kind = LOCSIM_READING_LANDMARKS;
  frame.data.landmarks = {LOCSIM_CAMERA_PTZ, 0.0, detections.data(), detections.size()};
  const auto step = [&] {
    t_s += 0.2;
    const double a = 0.3 * t_s;  // angle on the circle [rad]
    const double x = 3.0 + std::cos(a), y = 2.0 + std::sin(a), theta = a + M_PI / 2;
    odometry.t_s = frame.t_s = t_s;
    odometry.data.odometry.odom_pose = {x, y, theta};
    for (int i = 0; i < 6; ++i) {
      const double dx = field.posts[i][0] - x, dy = field.posts[i][1] - y;
      detections[i] = {field.colors[i], -1, std::hypot(dx, dy), std::atan2(dy, dx) - theta,
                       LOCSIM_TARGET_LANDMARK};
    }
    return f.update(odometry) && f.update(frame);
  };
  // Steady-state tracking: the first steps, in which sensor resetting still replaces particles
  // drawn about the initial guess, are left out of the timing.
  for (int warm_up = 0; warm_up < 25; ++warm_up) {
    if (!step()) {
      state.SkipWithError(f.error());
      return;
    }
  }
  for (auto _ : state) {
    if (!step()) {
      state.SkipWithError(f.error());
      break;
    }
  }
  // How many particles sensor resetting replaced per step (its share of the time).
  std::array<locsim_diagnostic, 16> diagnostics{};
  std::size_t count = 0;
  char error[256] = {};
  if (f.table().diagnostics != nullptr &&
      f.table().diagnostics(f.filter(), diagnostics.data(), diagnostics.size(), &count, error,
                            sizeof error) == 0) {
    for (std::size_t i = 0; i < count; ++i)
      if (std::string(diagnostics[i].name) == "resets")
        state.counters["resets"] = diagnostics[i].value;
  }
  state.counters["particle_updates_per_s"] = benchmark::Counter(
      static_cast<double>(state.range(0)) * static_cast<double>(state.iterations()),
      benchmark::Counter::kIsRate);
}
BENCHMARK_CAPTURE(BM_LandmarkPluginUpdate, mcl, "mcl")
    ->Arg(400)
    ->Arg(10000)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_LandmarkPluginUpdate, asrl, "asrl")
    ->Arg(400)
    ->Arg(10000)
    ->Unit(benchmark::kMicrosecond);

}  // namespace
