// Paper 001's filters through their plugins' C tables, as a run drives them: each iteration is one
// odometry reading (3 cm of travel) and one camera frame with 30 landmarks in view (range and
// bearing, no ids: every particle associates every detection by nearest neighbour, updates
// their EKFs, and the swarm variants move the particles first). The landmarks were mapped during
// a warm-up while the robot drove a 1 m circle. Arguments: the plugin (0 fastslam, 1 fastslam_afsa,
// 2 pso_pf) and the particle count.
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "plugin_fixture.hpp"

namespace {

using namespace locsim;

void BM_FastSlamUpdate(benchmark::State& state) {
  static const std::array<const char*, 3> kPlugins = {"fastslam", "fastslam_afsa", "pso_pf"};
  const char* plugin = kPlugins[static_cast<std::size_t>(state.range(0))];
  const std::string n = std::to_string(state.range(1));
  const locsim_map map{};  // SLAM: no landmarks given
  const locsim_robot_info robot{0.33, 0.05, 0.2};
  bench::PluginFixture f(plugin, {{"particles", n}}, map, robot, {1.0, 0.0, M_PI / 2}, 0.0, 0.0);

  // 30 landmarks on a 6 x 5 grid 2 m apart around the robot's circle.
  std::vector<std::array<double, 2>> landmarks;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 5; ++j) landmarks.push_back({-5.0 + 2.0 * i, -4.0 + 2.0 * j + 0.5});
  std::vector<locsim_detection> detections(landmarks.size());
  locsim_reading odometry{}, frame{};
  odometry.struct_size = frame.struct_size = sizeof(locsim_reading);
  odometry.kind = LOCSIM_READING_ODOMETRY;
  frame.kind = LOCSIM_READING_LANDMARKS;
  frame.data.landmarks = {LOCSIM_CAMERA_OMNI, 0.0, detections.data(), detections.size()};
  double t = 0.0, a = 0.0;
  const auto advance = [&] {  // the next pose and what it sees: the simulator's work, not timed
    // Forward on a 1 m circle about the origin, 3 cm per step.
    t += 0.1;
    a += 0.03;
    const double x = std::cos(a), y = std::sin(a), theta = a + M_PI / 2;
    odometry.t_s = frame.t_s = t;
    odometry.data.odometry.odom_pose = {x, y, theta};
    for (std::size_t k = 0; k < landmarks.size(); ++k) {
      const double dx = landmarks[k][0] - x, dy = landmarks[k][1] - y;
      detections[k] = {"red", -1, std::hypot(dx, dy),
                       std::remainder(std::atan2(dy, dx) - theta, 2 * M_PI),
                       LOCSIM_TARGET_LANDMARK};
    }
  };
  const auto update = [&] { return f.update(odometry) && f.update(frame); };
  bench::run_updates(state, f, 20, advance, update);
  state.SetLabel(plugin);
  state.counters["updates_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_FastSlamUpdate)
    ->ArgsProduct({{0, 1, 2}, {10, 100, 1000}})
    ->Unit(benchmark::kMicrosecond);

}  // namespace
