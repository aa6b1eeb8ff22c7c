// One localizer plugin's instance as the host sees it: the command-line spec, parameters checked
// against the plugin's declarations, what the plugin is told at creation, readings translated to
// the ABI's structs, and every call into the plugin checked and timed.
#pragma once

#include <atomic>
#include <chrono>
#include <deque>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "locsim/localizer.h"
#include "locsim/models.hpp"
#include "sim/common/random.hpp"
#include "sim/metrics/error_metrics.hpp"
#include "sim/plugin_host/param_file.hpp"
#include "sim/plugin_host/plugin_library.hpp"
#include "sim/robot/robot_def.hpp"
#include "sim/scenario/scenario_def.hpp"
#include "sim/sensors/readings.hpp"
#include "sim/world/occupancy.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

/// `NAME[:SOURCE][:key=value,...][@label]` from the command line. A key given twice is refused.
/// SOURCE is what a loader plugin runs: after `python:` a script's path or name
/// (`python:my_filter.py`, `python:landmark_pf` for landmark_pf.py in the plugin path), after
/// another plugin a file's path; a bare `my_filter.py` is short for `python:my_filter.py`.
struct LocalizerSpec {
  std::string plugin;  // name or .so path
  std::string source;  // name or path of the source a loader plugin runs; empty for most
  std::vector<std::pair<std::string, std::string>> params;
  std::string label;  // default: the plugin's name
  /// `--params FILE`: values for the parameters the spec does not give (may be null).
  std::shared_ptr<const ParamFile> params_file;
};
LocalizerSpec parse_localizer_spec(const std::string& text);  // throws InputError

/// Parameter values checked against a plugin's declarations, defaults filled in. Each value from,
/// in order of precedence: the spec, its params file's section of this plugin, the file's common
/// values, the plugin's default. A value from the file is checked like one from the command line
/// and a problem with it names the file's line and key; a key of the file's section of this
/// plugin that the plugin does not declare is an error, a common one is left to others.
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
/// Odometry's odom_pose is always valid: the source's pose when it has one, else dead-reckoned
/// from the start pose with its velocities (each held until the next reading, SDK
/// VelocityOdometry) or, failing those, its ticks. Fields the source lacks are zero.
class ReadingTranslator {
 public:
  explicit ReadingTranslator(const RobotDef& robot);
  /// The C view of `reading`; valid until the next call. Readings come in time order.
  const locsim_reading& translate(const Reading& reading);

 private:
  locsim_pose2 odometry_pose(double t_s, const OdometryReading& odometry);

  const RobotDef* robot_;
  double meters_per_tick_ = 0.0;
  sdk::VelocityOdometry velocity_odometry_;
  sdk::Pose tick_odometry_;  // dead-reckoned from ticks alone
  std::optional<std::pair<std::int64_t, std::int64_t>> last_ticks_;
  std::vector<float> laser_angles_;
  std::vector<locsim_detection> detections_;
  std::vector<locsim_beacon_range> ranges_;
  locsim_reading out_{};
};

/// What the host is doing inside a plugin right now. A worker process shares it with its parent
/// (shared memory), whose watchdog reads it: which call, since when, on which reading's time.
enum class PluginCall : int {
  kNone = 0,
  kCreate,
  kUpdate,
  kEstimate,
  kParticles,
  kDiagnostics,
  kLandmarkMap,
  kDestroy
};
const char* plugin_call_name(PluginCall call);

struct CallState {
  std::atomic<int> call{0};                 // PluginCall
  std::atomic<std::int64_t> started_ns{0};  // steady clock; 0 when no call is in progress
  std::atomic<double> t_s{0.0};             // the reading's or sample's time
  std::atomic<int> localizer{-1};           // the host's index of the instance in the call
};

/// One filter: its plugin's instance and every call into it, each checked (an error return, an
/// exception caught by the SDK, a NaN) and timed. The first failure ends the filter's run.
class LocalizerInstance {
 public:
  struct Failure {
    double t_s = 0.0;
    std::string call, message;
  };

  /// Creates the plugin's instance. Throws PluginError (the plugin's message). `calls`, when
  /// given, is kept up to date around every call; `index` is what it records as the localizer.
  LocalizerInstance(std::shared_ptr<const PluginLibrary> library, std::string label,
                    ParamSet params, const LocalizerWorld& world, std::uint64_t seed,
                    CallState* calls = nullptr, int index = -1);
  ~LocalizerInstance();
  LocalizerInstance(const LocalizerInstance&) = delete;
  LocalizerInstance& operator=(const LocalizerInstance&) = delete;

  const std::string& label() const { return label_; }
  const locsim_localizer& table() const { return library_->table(); }
  const PluginLibrary& library() const { return *library_; }
  const ParamSet& params() const { return params_; }
  bool failed() const { return failure_.has_value(); }
  const std::optional<Failure>& failure() const { return failure_; }

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

  /// Readings delivered (update calls made) and, of them, perception updates (camera,
  /// ultrasonic, laser: what the papers' "steps" count).
  long updates() const { return updates_; }
  long perception_updates() const { return perception_updates_; }
  /// Wall-clock cost of the update calls.
  CostSummary cost() const { return cost_.summary(); }

 private:
  void fail(double t_s, const std::string& call, const std::string& message);
  /// Marks the start of a call in `calls_` (when shared); returns the clock reading.
  std::chrono::steady_clock::time_point begin(PluginCall call, double t_s);
  void end();

  /// For a plugin built for ABI version 1: the reading in version 1's structs (docs/plugins.md,
  /// "ABI versions"). Null for current plugins.
  class Abi1Adapter;
  std::unique_ptr<Abi1Adapter> abi1_;

  std::shared_ptr<const PluginLibrary> library_;
  std::string label_;
  ParamSet params_;
  CallState* calls_ = nullptr;
  int index_ = -1;
  void* instance_ = nullptr;
  std::optional<Failure> failure_;
  CostAccumulator cost_;
  long updates_ = 0;
  long perception_updates_ = 0;
  char error_[1024] = {};
};

}  // namespace locsim
