#include "sim/run/replay.hpp"

#include <chrono>
#include <optional>

#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/consumers/config_json.hpp"
#include "sim/consumers/frame_capture.hpp"
#include "sim/producers/log_source.hpp"
#include "sim/run/export_bag.hpp"
#include "sim/run/runner.hpp"

namespace locsim {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

ReplayResult replay_log(const ReplayOptions& options, const std::atomic<bool>* interrupt) {
  LogSource source(options.log_file, options.robots);
  const bool video = options.video != nullptr;
  const std::optional<fs::path> video_file =
      video ? options.video_options.video_file : std::optional<fs::path>();
  const std::optional<fs::path> frames_dir =
      video ? options.video_options.frames_dir : std::optional<fs::path>();
  // The log (and the localizers' files) must survive what the replay writes: --overwrite keeps
  // them, an output never replaces them.
  std::vector<fs::path> read = session_input_files(options);
  read.push_back(options.log_file);
  if (video_file) RunFolder::check_outputs({{"--video", *video_file}}, read);
  std::vector<RunFolder::Output> outputs;
  if (video_file) outputs.push_back({"--video", *video_file, false});
  if (frames_dir) outputs.push_back({"--frames", *frames_dir, true});
  if (options.rosbag2) {
    check_bag_folder(*options.rosbag2, options.overwrite, read);
    outputs.push_back({"--rosbag2", *options.rosbag2, true});
  }
  RunFolder::check_apart(options.out_dir, outputs);
  RunFolder::check(options.out_dir, options.overwrite, read);
  const std::uint64_t seed = options.seed.value_or(source.seed());
  Session session(options, source.world(), source.scenario(), seed, interrupt);

  // run.json as known before the replay: written first into the folder (status "running"), and
  // rewritten at the end with how it ended. Its resolved configuration is built once.
  const json& header = source.header();
  json config = {{"world", to_json(source.world())}, {"scenario", to_json(source.scenario())}};
  const auto describe = [&](const RunEnd* end) {
    json run;
    run["locsim_version"] = locsim_version();
    run["status"] = end != nullptr ? end->status : "running";
    if (end != nullptr && !end->error.empty()) run["error"] = end->error;
    if (end != nullptr && !end->removed.empty()) run["removed_files"] = end->removed;
    run["source"] = "replay";
    run["log_file"] = options.log_file.string();
    run["recorded_with"] = header.value("locsim_version", "");
    run["seed"] = seed;  // the localizers' (--seed), by default the log's
    run["recorded_seed"] = source.seed();
    if (!options.robots.empty()) run["replayed_robots"] = options.robots;
    run["world_file"] = header.value("world_file", "");
    run["scenario_file"] = source.scenario().source.string();
    if (options.params_file) run["params_file"] = options.params_file->string();
    return run;
  };
  // Where each robot's files are, as a run says it (tools/report.py reads it).
  std::string run_text = starting_run_json(describe(nullptr), source.world(), session, config);
  // The video is opened before the folder is made, as a run's: one that cannot be written (exit
  // 4) leaves no folder.
  std::optional<FrameCapture> capture;
  if (video)
    capture.emplace(*options.video, options.video_options, source.world(), &session.host());
  std::vector<fs::path> keep = read;  // --overwrite empties the folder, but not of these
  for (const auto& file : {video_file, frames_dir, options.rosbag2}) {
    if (file) keep.push_back(*file);
  }
  try {
    session.open(options.out_dir, run_text);
  } catch (...) {
    std::error_code ignored;  // no replay folder: nor the video begun for it
    if (video_file) fs::remove(*video_file, ignored);
    throw;
  }
  run_text = std::string();  // the folder's run.json has it
  RecordConsumer& input = session.input();

  ReplayResult result;
  RunEnd end;
  const auto start = std::chrono::steady_clock::now();
  try {
    // A bag carries the log's header, as an exported log's does.
    session.start(keep, options.rosbag2 ? header.dump() : std::string());
    // After the localizers (it snapshots them), so the driver, not the fan-out, tells it first
    // when the time moves on: a frame then holds every record of its time and none later.
    if (capture) session.input().add(*capture);
    Record record;
    std::optional<double> stream_t_s;  // the time of the records so far
    std::size_t since_flush = 0;
    while (source.next(record)) {
      ++result.records;
      if (record.type == Record::Type::kGroundTruth) {
        ++(truth_known(record.pose) ? result.true_poses : result.unknown_truths);
      }
      const double t_s = record.type == Record::Type::kReading ? record.reading.t_s
                         : record.type == Record::Type::kEvent ? record.event.t_s
                                                               : record.t_s;
      if (capture) capture->advance(t_s);
      if (stream_t_s && t_s > *stream_t_s) session.records_until(*stream_t_s);
      stream_t_s = t_s;
      input.consume(record);
      result.replayed_s = t_s;
      if (++since_flush == 4096) {
        since_flush = 0;
        session.flush_now_and_then();
        if (interrupt != nullptr && interrupt->load(std::memory_order_relaxed)) {
          end.status = "interrupted";
          break;
        }
      }
    }
    if (stream_t_s && end.completed()) session.records_until(*stream_t_s);
    if (capture && end.completed()) capture->end_of_stream();
  } catch (...) {
    end.caught();
  }
  const json localizers = session.finish(result.replayed_s, end);
  if (video) finish_video(*options.video, video_file, end);
  result.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.failed_localizers = session.failed_localizers();

  json run = describe(&end);
  run["simulated_s"] = result.replayed_s;
  run["records"] = result.records;
  run["robots"] = robots_json(source.world());
  if (session.has_localizers()) run["localizers"] = localizers;
  run["config"] = std::move(config);
  run["timing"] = {{"wall_s", result.wall_s}, {"peak_memory_mb", peak_memory_json()}};
  session.write_run_json(run, end);
  result.status = end.status;
  if (end.failure) std::rethrow_exception(end.failure);
  return result;
}

}  // namespace locsim
