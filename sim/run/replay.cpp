#include "sim/run/replay.hpp"

#include <chrono>

#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/consumers/config_json.hpp"
#include "sim/consumers/frame_capture.hpp"
#include "sim/producers/log_source.hpp"
#include "sim/run/runner.hpp"

namespace locsim {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

ReplayResult replay_log(const ReplayOptions& options, const std::atomic<bool>* interrupt) {
  LogSource source(options.log_file, options.robots);
  // The log (and the localizers' files) must survive what the replay writes: --overwrite keeps
  // them, an output never replaces them.
  std::vector<fs::path> read = session_input_files(options);
  read.push_back(options.log_file);
  if (options.video != nullptr && options.video_options.video_file)
    RunFolder::check_outputs({{"--video", *options.video_options.video_file}}, read);
  RunFolder::check(options.out_dir, options.overwrite, read);
  const std::uint64_t seed = options.seed.value_or(source.seed());
  Session session(options, source.world(), source.scenario(), seed, interrupt);
  // The video is opened before the folder is made, as a run's: one that cannot be written (exit
  // 4) leaves no folder.
  std::optional<FrameCapture> capture;
  if (options.video != nullptr) {
    capture.emplace(*options.video, options.video_options, source.world(), &session.host());
  }
  std::vector<fs::path> keep = read;  // --overwrite empties the folder, but not of these
  for (const auto& file : {options.video_options.video_file, options.video_options.frames_dir}) {
    if (file && options.video != nullptr) keep.push_back(*file);
  }
  session.open(options.out_dir, keep);
  RecordConsumer& input = session.input();

  ReplayResult result;
  RunEnd end;
  const auto start = std::chrono::steady_clock::now();
  try {
    // After the localizers (it snapshots them), so the driver, not the fan-out, tells it first
    // when the time moves on: a frame then holds every record of its time and none later.
    if (capture) session.input().add(*capture);
    Record record;
    std::size_t since_flush = 0;
    while (source.next(record)) {
      ++result.records;
      const double t_s = record.type == Record::Type::kReading ? record.reading.t_s
                         : record.type == Record::Type::kEvent ? record.event.t_s
                                                               : record.t_s;
      if (capture) capture->advance(t_s);
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
    if (capture && end.completed()) capture->end_of_stream();
  } catch (...) {
    end.caught();
  }
  const json localizers = session.finish(result.replayed_s, end);
  if (options.video != nullptr) {
    // Closed whatever the status: the frames so far make a valid video of a failed replay too.
    try {
      options.video->finish();
    } catch (...) {
      end.caught("video: ");
    }
  }
  result.status = end.status;
  result.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.failed_localizers = session.failed_localizers();

  const json& header = source.header();
  json run;
  run["locsim_version"] = locsim_version();
  run["status"] = end.status;
  if (!end.error.empty()) run["error"] = end.error;
  run["source"] = "replay";
  run["log_file"] = options.log_file.string();
  run["recorded_with"] = header.value("locsim_version", "");
  run["seed"] = seed;  // the localizers' (--seed), by default the log's
  run["recorded_seed"] = source.seed();
  if (!options.robots.empty()) run["replayed_robots"] = options.robots;
  run["world_file"] = header.value("world_file", "");
  run["scenario_file"] = source.scenario().source.string();
  if (options.params_file) run["params_file"] = options.params_file->string();
  run["simulated_s"] = result.replayed_s;
  run["records"] = result.records;
  // Where each robot's files are, as a run says it (tools/report.py reads it).
  json robots = json::array();
  for (std::size_t i = 0; i < source.world().robots.size(); ++i) {
    robots.push_back(
        {{"name", source.world().robots[i].name},
         {"folder", fs::relative(session.folder().robot_dirs[i], options.out_dir).string()}});
  }
  run["robots"] = robots;
  if (session.has_localizers()) run["localizers"] = localizers;
  run["config"] = {{"world", to_json(source.world())}, {"scenario", to_json(source.scenario())}};
  run["timing"] = {{"wall_s", result.wall_s}, {"peak_memory_mb", peak_memory_json()}};
  write_json_atomically(options.out_dir / "run.json", run);
  if (end.failure) std::rethrow_exception(end.failure);
  return result;
}

}  // namespace locsim
