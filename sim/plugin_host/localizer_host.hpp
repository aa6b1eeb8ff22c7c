// Running localizer plugins on a robot's readings: parameters checked against the plugin's
// declarations, readings translated once and delivered in time order to every filter, each call
// timed, and every failure (an error return, an exception caught by the SDK, a NaN) confined to
// the filter that caused it.
#pragma once

#include <deque>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "locsim/localizer.h"
#include "sim/common/random.hpp"
#include "sim/metrics/error_metrics.hpp"
#include "sim/metrics/landmark_metrics.hpp"
#include "sim/plugin_host/plugin_library.hpp"
#include "sim/robot/robot_def.hpp"
#include "sim/scenario/scenario_def.hpp"
#include "sim/sensors/readings.hpp"
#include "sim/world/occupancy.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

/// `NAME[:key=value,...][@label]` from the command line.
struct LocalizerSpec {
  std::string plugin;  // name or .so path
  std::vector<std::pair<std::string, std::string>> params;
  std::string label;  // default: the plugin's name
};
LocalizerSpec parse_localizer_spec(const std::string& text);  // throws InputError

/// Parameter values checked against a plugin's declarations, defaults filled in.
class ParamSet {
 public:
  ParamSet(const locsim_localizer& table, const LocalizerSpec& spec);  // throws InputError
  const std::vector<locsim_param_value>& values() const { return values_; }
  nlohmann::ordered_json to_json() const;

 private:
  std::deque<std::string> strings_;  // stable storage for string values
  std::vector<locsim_param_value> values_;
};

/// Everything a plugin is told at creation (owns the storage the C structs point into). With
/// `localization.landmarks_known` false the map's landmarks are NULL with count 0 (SLAM).
struct LocalizerWorld {
  LocalizerWorld(const WorldDef& world, const RobotDef& robot, OccupancyGrid grid,
                 const LocalizationDef& localization, RandomStream& initial_rng);
  std::deque<std::string> colors;
  std::vector<locsim_landmark> landmarks;
  std::vector<locsim_beacon> beacons;
  OccupancyGrid grid;
  locsim_map map{};
  locsim_robot_info robot{};
  bool initial_pose_known = true;
  locsim_pose2 initial_pose{};
  double initial_covariance[9] = {};
};

/// Converts the simulator's readings of one robot to the ABI's structs (no truth_* fields).
class ReadingTranslator {
 public:
  explicit ReadingTranslator(const RobotDef& robot);
  /// The C view of `reading`; valid until the next call.
  const locsim_reading& translate(const Reading& reading);

 private:
  const RobotDef* robot_;
  double meters_per_tick_ = 0.0;
  std::vector<float> laser_angles_;
  std::vector<locsim_detection> detections_;
  std::vector<locsim_beacon_range> ranges_;
  locsim_reading out_{};
};

class LocalizerInstance {
 public:
  LocalizerInstance(std::shared_ptr<const PluginLibrary> library, std::string label,
                    ParamSet params, const LocalizerWorld& world,
                    std::uint64_t seed);  // throws PluginError
  ~LocalizerInstance();
  LocalizerInstance(const LocalizerInstance&) = delete;
  LocalizerInstance& operator=(const LocalizerInstance&) = delete;

  const std::string& label() const { return label_; }
  const locsim_localizer& table() const { return library_->table(); }
  bool failed() const { return failure_.has_value(); }

  /// One reading; a failure ends this filter's run.
  void deliver(const locsim_reading& reading);
  /// The current estimate, or nullopt after a failure (which this call may cause).
  std::optional<locsim_estimate> estimate(double t_s);
  /// The particles, and their weights when the plugin gives them (else `weights` is left empty).
  std::vector<locsim_pose2> particles(double t_s, std::vector<double>* weights = nullptr);
  /// The plugin's diagnostics, named.
  std::vector<std::pair<std::string, double>> diagnostics(double t_s);
  /// The plugin's landmark map (SLAM filters), copied; empty when the plugin has no
  /// `landmark_map` entry, maps nothing, or has failed. An error return or a non-finite position
  /// or covariance fails the filter like any other call.
  std::vector<locsim_mapped_landmark> landmark_map(double t_s);

  void add_error(ErrorSample sample) {
    sample.steps = perception_updates_;
    errors_.push_back(sample);
  }
  void set_criterion(const ConvergenceCriterion& criterion) { criterion_ = criterion; }
  /// Its part of metrics.json; `kidnap_times_s` split the run into segments, each with its own
  /// errors and its recovery time (convergence measured from the segment's start).
  nlohmann::ordered_json metrics(const std::vector<double>& kidnap_times_s = {}) const;
  const std::vector<float>& update_seconds() const { return update_seconds_; }

 private:
  void fail(double t_s, const std::string& call, const std::string& message);

  std::shared_ptr<const PluginLibrary> library_;
  std::string label_;
  ParamSet params_;
  void* instance_ = nullptr;
  struct Failure {
    double t_s;
    std::string call, message;
  };
  std::optional<Failure> failure_;
  std::vector<float> update_seconds_;
  std::vector<ErrorSample> errors_;
  ConvergenceCriterion criterion_;
  std::vector<std::pair<std::string, double>> last_diagnostics_;
  std::map<std::string, std::pair<double, long>> diagnostic_sums_;  // sum, samples
  long perception_updates_ = 0;
  char error_[1024] = {};
};

/// The localizers of one robot, all fed the same readings.
class LocalizerHost {
 public:
  /// Loads (or reuses from `libraries`) each spec's plugin and creates its instance. Throws
  /// PluginError (exit 3) or InputError (bad parameters, exit 2).
  LocalizerHost(const std::vector<LocalizerSpec>& specs, const WorldDef& world,
                const RobotDef& robot, const LocalizationDef& localization,
                const OccupancyGrid& grid, std::uint64_t run_seed,
                const ConvergenceCriterion& criterion = {});

  void deliver(const Reading& reading);
  std::vector<std::unique_ptr<LocalizerInstance>>& instances() { return instances_; }

  /// The world's landmarks, true positions (for metrics; whatever the plugins were given).
  const std::vector<LandmarkPoint>& true_landmarks() const { return true_landmarks_; }
  /// Ids of the true landmarks this robot's cameras have detected so far (the readings' truth_id;
  /// false detections aside).
  const std::set<int>& observed_landmarks() const { return observed_landmarks_; }

 private:
  std::unique_ptr<LocalizerWorld> world_;
  std::vector<LandmarkPoint> true_landmarks_;
  std::set<int> observed_landmarks_;
  ReadingTranslator translator_;
  std::vector<std::unique_ptr<LocalizerInstance>> instances_;
};

}  // namespace locsim
