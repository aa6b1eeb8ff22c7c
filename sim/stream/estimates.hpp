// The localizers' side of the stream: what a localizer host emits as the records go through it.
// At every ground-truth record of a robot, each of that robot's localizers gives one
// EstimateSample (its estimate next to the truth it is judged against); a localizer that fails
// gives one LocalizerFailure and nothing after. The scorer (metrics/scorer) and the run folder's
// recorder (consumers/run_recorder) consume these, in the order each localizer produced them.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "locsim/localizer.h"
#include "sim/common/math.hpp"
#include "sim/metrics/error_metrics.hpp"

namespace locsim {

/// Who a localizer is: the host numbers them robot by robot, in the order of the specs.
struct LocalizerInfo {
  std::size_t robot = 0;   // index of the robot in the world
  std::string robot_name;  // its name
  std::string label;       // unique per robot; names its files
  std::string plugin;      // the plugin's name (its table's)
  std::string plugin_file;
  std::string params_json;     // every parameter with defaults filled in, as JSON text
  std::uint32_t readings = 0;  // the kinds it uses, LOCSIM_READING_BIT(kind) or-ed; 0: not said
};

struct EstimateSample {
  std::size_t localizer = 0;  // index into the host's LocalizerInfo list
  double t_s = 0.0;
  Pose2 truth;
  Pose2 pose;
  std::array<double, 9> covariance{};  // row-major over (x, y, theta)
  long perception_updates = 0;         // camera, ultrasonic and laser readings delivered so far
  std::vector<std::pair<std::string, double>> diagnostics;  // sampled at this instant
};

struct LocalizerFailure {
  std::size_t localizer = 0;
  double t_s = 0.0;                 // simulated time of the reading or sample being handled
  std::string call;                 // update, estimate, particles, diagnostics, landmark_map
  std::string message;              // the plugin's own, or what the host saw (a signal, a timeout)
  std::optional<int> signal;        // the signal that killed its process, if one did
  std::optional<double> timeout_s;  // the --plugin-timeout it exceeded, if it did
  bool interrupted = false;         // the run was interrupted (Ctrl-C) while it was in a call
};

/// What a localizer leaves at the end of the stream.
struct LocalizerFinal {
  bool known = false;  // false when its process was lost before it could say
  long updates = 0;    // readings delivered
  long perception_updates = 0;
  CostSummary cost;                                  // of its update calls (wall clock)
  std::vector<locsim_mapped_landmark> landmark_map;  // SLAM filters' final map
};

class EstimateConsumer {
 public:
  virtual ~EstimateConsumer() = default;
  virtual void estimate(const EstimateSample& sample) = 0;
  virtual void failure(const LocalizerFailure& failure) = 0;
};

}  // namespace locsim
