// The scorer: a consumer of the record stream (kidnaps split a run into segments; the cameras'
// detections say which landmarks a robot was shown) and of the localizers' estimates, which it
// judges against the truth they came with as they arrive, in memory that does not grow with the
// run. At the end it writes each robot's metrics.json (and SLAM filters' LABEL_map.csv).
#pragma once

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "sim/metrics/error_metrics.hpp"
#include "sim/metrics/landmark_metrics.hpp"
#include "sim/metrics/laser_place.hpp"
#include "sim/stream/estimates.hpp"
#include "sim/stream/record.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

class Scorer final : public RecordConsumer, public EstimateConsumer {
 public:
  /// `grid`, the static map the localizers were given, lets the scorer judge whether a robot's
  /// laser tells its place apart after a kidnap (LaserPlaceJudge); without it any scan does.
  Scorer(const WorldDef& world, std::vector<LocalizerInfo> localizers,
         const ConvergenceCriterion& criterion, const OccupancyGrid* grid = nullptr);

  void consume(const Record& record) override;
  void estimate(const EstimateSample& sample) override;
  void failure(const LocalizerFailure& failure) override;

  /// Writes `robot_dirs[r]`/metrics.json for each robot with localizers (their wall-clock costs
  /// in the last block, "timing", so that the rest is byte-identical for the same inputs) and
  /// LABEL_map.csv for each localizer that left a map; warns on stderr of failed localizers.
  /// `ends` in the order of the localizers. Returns their one-line summaries for run.json.
  nlohmann::ordered_json write(const std::vector<std::filesystem::path>& robot_dirs,
                               const std::vector<LocalizerFinal>& ends) const;
  /// The labels of the localizers that failed, "robot/label" when several robots have them.
  std::vector<std::string> failed() const;

 private:
  struct Track {
    LocalizerInfo info;
    ErrorAccumulator all;
    ErrorAccumulator segment;
    nlohmann::ordered_json closed_segments = nlohmann::ordered_json::array();
    std::size_t kidnaps_passed = 0;      // kidnaps of its robot before the current segment
    std::optional<Pose2> last_truth;     // at its latest sample
    std::optional<Pose2> before_kidnap;  // at its last sample before the current segment's kidnap
    // How far the current segment's kidnap moved the robot, from before_kidnap to the truth at
    // the first sample after the put-down: a carry within the convergence criterion tests no
    // recovery (the generator's landings may be a short carry).
    std::optional<double> carried_m, turned_rad;
    std::optional<LocalizerFailure> failure;
    std::vector<std::pair<std::string, double>> last_diagnostics;
    std::map<std::string, std::pair<double, long>> diagnostic_sums;  // sum, samples
    long unscored = 0;  // samples at instants whose truth the log does not know
  };
  /// What a robot's sensors showed between a kidnap's put-down and the next kidnap (or the end):
  /// a kidnap is recoverable for a localizer when a kind of reading it uses showed enough.
  struct Sensed {
    std::set<int> landmarks;  // true landmarks detected (any camera; false detections aside)
    std::set<int> beacons;    // beacons ranged in line of sight
    long laser_scans = 0;
    // Scans kept for the laser's judgement, one a second (the first kLaserProbes), each with the
    // true pose of the ground-truth record that follows it in the stream.
    std::vector<LaserProbe> laser_probes;
    std::optional<std::vector<Vec2>> pending_probe;
    double next_probe_s = -1e300;
  };
  nlohmann::ordered_json segment_json(const Track& track) const;
  /// Whether the kidnap that opened the track's current segment is one its localizer's kinds of
  /// reading (all kinds when it does not say) showed enough to recover from; nullopt before any.
  std::optional<bool> recoverable(const Track& track) const;
  const Sensed& sensed_since_kidnap(const Track& track) const;
  /// The laser's verdict on the track's current kidnap; nullopt without a judge or a probe.
  const LaserPlaceVerdict* laser_verdict(const Track& track) const;
  nlohmann::ordered_json metrics_json(const Track& track, const LocalizerFinal& end) const;

  ConvergenceCriterion criterion_;
  std::vector<LandmarkPoint> true_landmarks_;
  std::vector<std::string> robot_names_;
  std::vector<std::vector<double>> kidnaps_;    // by robot: kidnap times [s]
  std::vector<std::vector<double>> put_downs_;  // by robot: when each kidnap landed [s]
  std::vector<std::set<int>> observed_;         // by robot: true landmarks its cameras detected
  std::vector<std::vector<Sensed>> sensed_;     // by robot, by kidnap: after its put-down
  // The map the laser's verdicts are judged on: with a grid, a laser and a filter reading it.
  std::optional<OccupancyGrid> judged_map_;
  // Built from it at the first verdict asked for: its distance transforms cost a run without a
  // kidnap (most of a sweep's) several milliseconds for nothing.
  mutable std::optional<LaserPlaceJudge> laser_judge_;
  std::vector<std::optional<LaserDef>> lasers_;  // by robot
  // Judged once per robot and kidnap, whichever localizer's segment asks first.
  mutable std::map<std::pair<std::size_t, std::size_t>, LaserPlaceVerdict> laser_verdicts_;
  std::vector<Track> tracks_;
};

}  // namespace locsim
