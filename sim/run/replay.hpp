// `locsim replay`: a recorded log as the producer of the record stream, wired to the same session
// as `locsim run` (localizer host, scorer, recorder): the folder it writes holds the same
// LABEL.tum, groundtruth.tum, events.csv, readings/ and metrics.json (timing aside) as the run
// with those localizers and options, because the records and their order are the same.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "sim/consumers/frame_state.hpp"
#include "sim/run/session.hpp"

namespace locsim {

struct ReplayOptions : SessionOptions {
  std::filesystem::path log_file;
  std::filesystem::path out_dir;
  FrameSink* video = nullptr;  // frames of the replay (render/), at video_options' frame times
  VideoOptions video_options;
  /// The seed the localizers' random streams (their seeds and the initial guess) derive from;
  /// default: the log's, so that a replay of a run gives that run's estimates byte for byte.
  std::optional<std::uint64_t> seed;
  /// The robots to replay, by name (the log as if it held only them); empty: all.
  std::vector<std::string> robots;
};

struct ReplayResult {
  std::string status;       // completed, interrupted, failed
  double replayed_s = 0.0;  // simulated time covered
  double wall_s = 0.0;
  std::size_t records = 0;
  std::size_t true_poses = 0, unknown_truths = 0;  // ground-truth records, known or not
  std::vector<std::string> failed_localizers;      // labels of localizers that failed (exit code 5)
};

/// Throws InputError (bad log, bad parameters, a bad --out) or PluginError (plugins) before
/// anything is written (and RenderError for a video that cannot be opened, before the folder is
/// made). run.json is the folder's first file ("status": "running"), rewritten at the end, as a
/// run's. A log found corrupt or truncated part-way writes run.json with status "failed" and
/// throws InputError; a write that fails stops the replay, as a run (runner.hpp).
ReplayResult replay_log(const ReplayOptions& options, const std::atomic<bool>* interrupt = nullptr);

}  // namespace locsim
