// A set of localizer instances fed by the record stream: readings go to their robot's filters
// (translated once per robot), and at each true pose of a robot each of its filters gives an
// estimate sample. The localizer host runs one in its own process (--isolation none) or one in
// each worker process (plugin_host/worker_process); the code the plugins see is the same.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "sim/plugin_host/localizer_instance.hpp"
#include "sim/stream/estimates.hpp"
#include "sim/stream/record.hpp"

namespace locsim {

/// Everything needed to create one filter, resolved (and its parameters checked) beforehand.
struct LocalizerDef {
  std::size_t index = 0;  // in the host's list of localizers
  LocalizerInfo info;
  LocalizerSpec spec;
  std::shared_ptr<const PluginLibrary> library;
  const RobotDef* robot = nullptr;
  const LocalizerWorld* world = nullptr;  // the robot's: map, grid, initial guess
  std::uint64_t seed = 0;
};

/// A filter's state at one instant, for a video frame.
struct LocalizerSnapshot {
  bool failed = false;
  std::optional<locsim_estimate> estimate;
  std::vector<locsim_pose2> particles;
  std::vector<double> weights;  // empty: equal weights
  std::vector<locsim_mapped_landmark> landmark_map;
};

class InstanceRunner {
 public:
  /// Creates every instance, in order. Throws PluginError at the first create that fails.
  InstanceRunner(const std::vector<const LocalizerDef*>& defs, CallState* calls = nullptr);

  /// Readings to their robot's filters; at a true pose, a sample from each of its filters.
  /// Failures go to `out` once, when they happen; nothing of a failed filter follows.
  void consume(const Record& record, EstimateConsumer& out);
  /// Each filter's state now, in the order of the defs (failures they cause go to `out`).
  std::vector<LocalizerSnapshot> snapshot(double t_s, EstimateConsumer& out);
  /// The end of the stream at `t_end_s`: each filter's final map and counts, in order.
  std::vector<LocalizerFinal> finish(double t_end_s, EstimateConsumer& out);
  /// The defs' indices, in order.
  const std::vector<std::size_t>& indices() const { return indices_; }

 private:
  struct Robot {
    int robot = 0;
    ReadingTranslator translator;
    std::vector<std::size_t> slots;  // into instances_
  };
  void report_failure(std::size_t slot, EstimateConsumer& out);

  std::vector<std::unique_ptr<LocalizerInstance>> instances_;
  std::vector<std::size_t> indices_;  // host index of each instance
  std::vector<bool> reported_;        // its failure went out already
  std::vector<Robot> robots_;
  std::vector<int> robot_slot_;  // robot index -> index into robots_, -1 when none here
};

}  // namespace locsim
