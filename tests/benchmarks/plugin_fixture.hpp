// A built plugin created through its C table as the host does, for plugin-level benchmarks: the
// library, its parameters and the instance, destroyed with the fixture.
#pragma once

#include <benchmark/benchmark.h>

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "sim/plugin_host/localizer_instance.hpp"
#include "sim/plugin_host/plugin_library.hpp"

namespace locsim::bench {

class PluginFixture {
 public:
  /// `plugin` from the build's plugin folder with `params`, on `map`, starting from a Gaussian of
  /// variance `variance_xy` [m^2] and `variance_theta` [rad^2] about `start`; seed 1.
  PluginFixture(const std::string& plugin, std::vector<std::pair<std::string, std::string>> params,
                const locsim_map& map, const locsim_robot_info& robot, locsim_pose2 start,
                double variance_xy, double variance_theta)
      : library_(find_plugin(std::string(LOCSIM_BUILD_PLUGIN_DIR) + "/locsim_" + plugin + ".so")),
        params_(library_.table(), spec(plugin, std::move(params))) {
    locsim_init init{};
    init.struct_size = sizeof(init);
    init.params = params_.values().data();
    init.param_count = params_.values().size();
    init.map = &map;
    init.robot = &robot;
    init.initial_pose_known = 1;
    init.initial_pose = start;
    init.initial_covariance[0] = init.initial_covariance[4] = variance_xy;
    init.initial_covariance[8] = variance_theta;
    init.seed = 1;
    filter_ = library_.table().create(&init, error_, sizeof error_);
    if (filter_ == nullptr) throw std::runtime_error(error_);
  }
  ~PluginFixture() { library_.table().destroy(filter_); }
  PluginFixture(const PluginFixture&) = delete;
  PluginFixture& operator=(const PluginFixture&) = delete;

  /// Passes one reading; false with error() set when the plugin fails.
  bool update(const locsim_reading& reading) {
    return library_.table().update(filter_, &reading, error_, sizeof error_) == 0;
  }
  const char* error() const { return error_; }
  const locsim_localizer& table() const { return library_.table(); }
  void* filter() const { return filter_; }

 private:
  static LocalizerSpec spec(const std::string& plugin,
                            std::vector<std::pair<std::string, std::string>> params) {
    LocalizerSpec s;
    s.plugin = plugin;
    s.params = std::move(params);
    return s;
  }
  PluginLibrary library_;
  ParamSet params_;
  void* filter_ = nullptr;
  char error_[256] = {};
};

/// The timed loop of a plugin benchmark: `warm_up` untimed rounds, then per iteration the
/// simulator's part (`advance`, untimed) and the plugin's (`update`, timed; false stops the
/// benchmark with the fixture's error).
template <class Advance, class Update>
void run_updates(benchmark::State& state, const PluginFixture& fixture, int warm_up,
                 Advance&& advance, Update&& update) {
  for (int i = 0; i < warm_up; ++i) advance(), update();
  for (auto _ : state) {
    state.PauseTiming();
    advance();
    state.ResumeTiming();
    if (!update()) {
      state.SkipWithError(fixture.error());
      break;
    }
  }
}

}  // namespace locsim::bench
