// `locsim score LOG --estimate FILE --label NAME`: anyone's estimates (a TUM file, or a topic of a
// ROS 2 bag recorded while a localizer ran on locsim's exported bag) scored as the built-in
// localizers are: the log's records go through the scorer, and at each true pose of the robot
// each external estimate gives its sample (metrics.json: errors, segments at kidnaps, recovery,
// convergence; NEES and the 95 % ellipse when a covariance comes with it). docs/ros.md.
#pragma once

#include <array>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "sim/metrics/error_metrics.hpp"

namespace locsim {

/// One estimate given from outside: a file, and for a bag the topic
/// (geometry_msgs/msg/PoseWithCovarianceStamped, nav_msgs/msg/Odometry or
/// geometry_msgs/msg/PoseStamped).
struct ExternalEstimate {
  std::string label;
  std::filesystem::path file;
  std::string topic;  // for a bag
};

/// An external estimate as times on the log's clock, poses and (when given) covariances.
struct ExternalTrajectory {
  std::vector<double> t_s;
  std::vector<Pose2> poses;
  std::vector<std::optional<std::array<double, 9>>> covariances;  // row-major over x, y, theta
};

/// Reads a TUM file (t x y z qx qy qz qw; its times the log's), or a bag's topic (its stamps
/// put on the log's clock by `epoch_ns`, the Unix time of the log's time 0). Throws InputError
/// naming the file, line or message.
ExternalTrajectory read_external_estimate(const ExternalEstimate& estimate, std::int64_t epoch_ns);

struct ScoreOptions {
  std::filesystem::path log_file;
  std::vector<ExternalEstimate> estimates;
  std::filesystem::path out_dir;
  std::string robot;  // which robot the estimates are of; empty: the log's only robot
  ConvergenceCriterion convergence;
  bool overwrite = false;
};

struct ScoreResult {
  std::size_t true_poses = 0;
  std::vector<std::size_t> samples;  // per estimate: true poses it was scored at
};

/// Writes OUT/metrics.json (the scorer's, one entry per estimate), OUT/LABEL.tum (the estimate
/// at each true pose it was scored at) and OUT/run.json. Throws InputError (a bad log, file or
/// option) before anything is written.
ScoreResult score_estimates(const ScoreOptions& options);

/// The log a run folder's run.json names (log_file: a run with --log, a replay). Throws
/// InputError when it is not a finished run's folder, names no log, or the log is not there.
std::filesystem::path log_of_run(const std::filesystem::path& run_dir);

/// `locsim score RUN`: the estimates scored on the run's log (run.json's log_file: a run with
/// --log, a replay) and added to the run folder beside its own localizers: LABEL.tum in the
/// robot's folder, its entry in metrics.json, in run.json's "localizers" and "scored" (an
/// estimate scored again replaces its entries). `options.log_file` and `out_dir` are set here.
/// Throws InputError before the run's files are touched: not a finished run's folder, no log
/// kept, a label a localizer or a file of the run has.
ScoreResult score_into_run(const std::filesystem::path& run_dir, ScoreOptions options);

}  // namespace locsim
