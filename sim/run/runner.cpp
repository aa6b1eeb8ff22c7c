#include "sim/run/runner.hpp"

#include <chrono>
#include <cstdio>
#include <ctime>
#include <nlohmann/json.hpp>
#include <thread>

#include "sim/common/base64.hpp"
#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/consumers/config_json.hpp"
#include "sim/consumers/frame_capture.hpp"
#include "sim/producers/simulation_source.hpp"
#include "sim/run/export_bag.hpp"
#include "sim/scenario/scenario_loader.hpp"
#include "sim/stream/log_file.hpp"
#include "sim/world/variation.hpp"
#include "sim/world/world_loader.hpp"

namespace locsim {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

RunInputs load_run_inputs(const fs::path& world_file, const std::optional<fs::path>& scenario_file,
                          std::optional<double> duration_s) {
  const Activity reading("reading " + world_file.string() +
                         (scenario_file ? " and " + scenario_file->string() : std::string()));
  RunInputs inputs{load_world(world_file), ScenarioDef{}, {}};
  if (scenario_file) {
    inputs.scenario = load_scenario(*scenario_file);
  } else if (inputs.world.scenario) {
    inputs.scenario = *inputs.world.scenario;
    inputs.scenario.source = world_file;
  } else {
    inputs.scenario.source = world_file;  // defaults: idle robots for 60 s
  }
  if (duration_s) {
    if (const std::string problem = out_of_range(*duration_s, ScenarioDef::kDurationRange);
        !problem.empty()) {
      throw InputError("--duration: " + problem);
    }
    inputs.scenario.duration_s = *duration_s;
  }
  bind_scenario(inputs.scenario, inputs.world);
  inputs.files.push_back(inputs.world.source);
  if (inputs.world.map) {
    inputs.files.push_back(inputs.world.map->yaml_file);
    inputs.files.push_back(inputs.world.map->image_file);
  }
  if (scenario_file) inputs.files.push_back(inputs.scenario.source);
  for (const DriveDef& drive : inputs.scenario.drives) {
    if (!drive.poses_file.empty()) inputs.files.push_back(drive.poses_file);
  }
  return inputs;
}

namespace {

fs::path default_out_dir(const RunInputs& inputs, std::uint64_t seed) {
  const std::time_t now = std::time(nullptr);
  char stamp[32];
  std::strftime(stamp, sizeof(stamp), "%Y%m%d-%H%M%S", std::localtime(&now));
  const std::string base =
      inputs.world.name + "-" + inputs.scenario.name + "-seed" + std::to_string(seed) + "-" + stamp;
  fs::path dir = fs::path("runs") / base;
  for (int suffix = 2; fs::exists(dir); ++suffix) {
    dir = fs::path("runs") / (base + "-" + std::to_string(suffix));
  }
  return dir;
}

/// Everything replay needs to rebuild the world and its localizer inputs: the world's and the
/// scenario's text, and every other file they name (a map's YAML and image, a trajectory's TUM
/// file), so that a replay reads nothing but the log (producers/log_source).
json log_header(const RunOptions& options, const RunInputs& inputs) {
  json header = {{"format", "locsim-log"},
                 {"locsim_version", locsim_version()},
                 {"seed", options.seed},
                 {"world_file", options.world_file.string()},
                 {"world_dir", fs::absolute(options.world_file).parent_path().string()},
                 {"world_yaml", read_text(options.world_file)},
                 {"scenario_file",
                  options.scenario_file ? json(options.scenario_file->string()) : json(nullptr)},
                 {"scenario_dir", options.scenario_file
                                      ? json(fs::absolute(*options.scenario_file).parent_path())
                                      : json(nullptr)},
                 {"scenario_yaml",
                  options.scenario_file ? json(read_text(*options.scenario_file)) : json(nullptr)},
                 {"duration_s", inputs.scenario.duration_s}};
  json files = json::object();
  for (const fs::path& file : inputs.files) {
    if (file == options.world_file || (options.scenario_file && file == *options.scenario_file))
      continue;
    files[InputSandbox::key(fs::absolute(file))] = base64_encode(read_text(file));
  }
  header["files"] = files;
  if (inputs.world.drawn.applied) header["variation"] = to_json(inputs.world.drawn);
  return header;
}

}  // namespace

RunResult run_simulation(const RunOptions& options, const std::atomic<bool>* interrupt) {
  // Everything that can be wrong with the input is found before the folder is made.
  RunInputs inputs = load_run_inputs(options.world_file, options.scenario_file, options.duration_s);
  // This seed's world: everything downstream (the localizers' start guesses, the log) sees it.
  if (options.no_variation) inputs.world.variation.enabled = false;
  vary_world(inputs.world, inputs.scenario, options.seed);
  RunResult result;
  result.out_dir =
      options.out_dir.empty() ? default_out_dir(inputs, options.seed) : options.out_dir;
  const bool video = options.video != nullptr;
  const std::optional<fs::path> video_file =
      video ? options.video_options.video_file : std::optional<fs::path>();
  const std::optional<fs::path> frames_dir =
      video ? options.video_options.frames_dir : std::optional<fs::path>();
  // What the run reads must survive what it writes: --overwrite keeps it, an output never
  // replaces it.
  std::vector<fs::path> read = inputs.files;
  for (const fs::path& file : session_input_files(options)) read.push_back(file);
  std::vector<std::pair<std::string, fs::path>> named_outputs;
  if (options.log_file) named_outputs.emplace_back("--log", *options.log_file);
  if (video_file) named_outputs.emplace_back("--video", *video_file);
  RunFolder::check_outputs(named_outputs, read);
  // The outputs must fit together: `--out D --log D` would make D a file, then fail to make the
  // folder (exit 1, a 4 KiB log left behind).
  std::vector<RunFolder::Output> outputs;
  if (options.log_file) outputs.push_back({"--log", *options.log_file, false});
  if (video_file) outputs.push_back({"--video", *video_file, false});
  if (frames_dir) outputs.push_back({"--frames", *frames_dir, true});
  if (options.rosbag2) {
    check_bag_folder(*options.rosbag2, options.overwrite, read);
    outputs.push_back({"--rosbag2", *options.rosbag2, true});
  }
  RunFolder::check_apart(result.out_dir, outputs);
  RunFolder::check(result.out_dir, options.overwrite, read);
  // The localizers' processes start before the simulation (and any renderer) has threads.
  Session session(options, inputs.world, inputs.scenario, options.seed, interrupt);

  // run.json as known before the run: written first into the folder (status "running"), and
  // rewritten at the end with how it ended. Its resolved configuration is built once.
  json config = {{"world", to_json(inputs.world)}, {"scenario", to_json(inputs.scenario)}};
  const auto describe = [&](const RunEnd* end) {
    json run;
    run["locsim_version"] = locsim_version();
    run["status"] = end != nullptr ? end->status : "running";
    if (end != nullptr && !end->error.empty()) run["error"] = end->error;
    if (end != nullptr && !end->removed.empty()) run["removed_files"] = end->removed;
    run["seed"] = options.seed;
    if (options.log_file) run["log_file"] = options.log_file->string();  // what `score RUN` reads
    run["world_file"] = options.world_file.string();
    run["scenario_file"] = inputs.scenario.source.string();
    if (options.params_file) run["params_file"] = options.params_file->string();
    return run;
  };
  std::string run_text = starting_run_json(describe(nullptr), inputs.world, session, config);
  std::optional<json> header;
  if (options.log_file) header = log_header(options, inputs);
  OutputPlan plan;
  plan.readings = options.readings;
  plan.localizers = options.localizers.size();
  plan.log = header.has_value();
  plan.log_header_bytes = header ? json_text_bytes(*header) : 0.0;
  plan.run_json_bytes = static_cast<double>(run_text.size());
  plan.video = video ? &options.video_options : nullptr;
  OutputPaths paths{result.out_dir, options.log_file, video_file, frames_dir};
  if (options.overwrite) {
    // The previous run's files, which --overwrite removes: their room is the new run's.
    std::error_code error;
    for (auto entry = fs::recursive_directory_iterator(result.out_dir, error);
         !error && entry != fs::recursive_directory_iterator(); entry.increment(error)) {
      std::error_code ignored;
      if (entry->is_symlink(ignored) || !entry->is_regular_file(ignored)) continue;
      const std::uintmax_t size = entry->file_size(ignored);
      if (!ignored) paths.out_dir_freed_bytes += static_cast<double>(size);
    }
  }
  check_run_output(estimate_run_output(inputs.world, inputs.scenario, plan),
                   options.max_output_bytes, paths);

  Simulation sim(inputs.world, inputs.scenario, options.seed, options.make_landmark_imager);
  sim.use_threads(options.threads);  // 0: one per core, shared out when that is faster
  // The log and the video are opened before the run folder is made: one that cannot be written
  // (exit 1 for the log, 4 for the video, naming the path and the reason) leaves no folder.
  std::unique_ptr<LogWriter> log;
  fs::path log_made;  // the folders made for the log
  if (options.log_file) {
    // Its folder is made when missing, as the run folder is (`--out NEW --log NEW/run.locsimlog`),
    // and removed again when the log cannot be written.
    log_made = make_missing_folders(options.log_file->parent_path(),
                                    "cannot write the log " + options.log_file->string() + ": ");
    try {
      log = std::make_unique<LogWriter>(*options.log_file, *header);
    } catch (...) {
      std::error_code ignored;
      if (!log_made.empty()) fs::remove_all(log_made, ignored);
      throw;
    }
    header.reset();
  }
  // When the run cannot start after all, the log begun for it goes too.
  const auto discard_log = [&] {
    if (!log) return;
    log.reset();
    std::error_code ignored;
    fs::remove(*options.log_file, ignored);
    if (!log_made.empty()) fs::remove_all(log_made, ignored);
  };
  std::optional<FrameCapture> capture;
  try {
    if (video) capture.emplace(*options.video, options.video_options, sim, &session.host());
  } catch (...) {
    discard_log();
    throw;
  }
  std::vector<fs::path> keep = read;  // --overwrite empties the folder, but not of these
  for (const auto& file : {options.log_file, video_file, frames_dir, options.rosbag2}) {
    if (file) keep.push_back(*file);
  }
  try {
    session.open(result.out_dir, run_text);
  } catch (...) {
    // No run folder: nor the log and the video begun for it.
    discard_log();
    std::error_code ignored;
    if (video_file) fs::remove(*video_file, ignored);
    throw;
  }
  run_text = std::string();  // the folder's run.json has it
  SimulationSource source(sim);
  RecordConsumer& input = session.input();
  const auto steps_per_s = std::max<std::int64_t>(1, std::llround(sim.world_def().physics.step_hz));

  const auto wall_start = std::chrono::steady_clock::now();
  auto next_progress = wall_start + std::chrono::seconds(1);
  bool progress_shown = false;
  RunEnd end;
  try {
    // A bag carries the log's header, as an exported log's does.
    session.start(keep, options.rosbag2 ? log_header(options, inputs).dump() : std::string());
    if (log) session.input().add(*log);
    if (capture) session.input().add(*capture);
    source.emit(input);
    session.records_until(sim.time_s());
    if (capture) capture->after_step(sim);
    while (!sim.done()) {
      if (interrupt != nullptr && interrupt->load(std::memory_order_relaxed)) {
        end.status = "interrupted";
        break;
      }
      sim.step();
      source.emit(input);
      session.records_until(sim.time_s());
      if (capture) capture->after_step(sim);
      if (sim.step_index() % steps_per_s == 0) session.flush_now_and_then();
      if (options.realtime) {
        std::this_thread::sleep_until(wall_start + std::chrono::duration<double>(sim.time_s()));
      }
      if (options.progress && (sim.step_index() & 255) == 0) {
        const auto now = std::chrono::steady_clock::now();
        if (now >= next_progress) {
          const double wall = std::chrono::duration<double>(now - wall_start).count();
          std::fprintf(
              stderr, "\r  t = %.1f / %.1f s (%3.0f%%), %.0fx real time   ", sim.time_s(),
              inputs.scenario.duration_s,
              100.0 * static_cast<double>(sim.step_index()) / static_cast<double>(sim.end_step()),
              sim.time_s() / wall);
          next_progress = now + std::chrono::milliseconds(500);
          progress_shown = true;
        }
      }
    }
  } catch (...) {
    end.caught();
  }
  if (progress_shown) std::fprintf(stderr, "\n");
  const json localizers = session.finish(sim.time_s(), end);
  if (video) finish_video(*options.video, video_file, end);
  if (log) {
    // A log without its end record reads as truncated (replay refuses it), rightly: it is kept.
    try {
      log->flush();
      if (end.completed()) log->finish();
    } catch (...) {
      end.caught();
    }
  }
  result.status = end.status;
  result.wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  result.simulated_s = sim.time_s();
  result.state_hash = sim.state_hash();
  result.failed_localizers = session.failed_localizers();

  json run = describe(&end);
  run["simulated_s"] = result.simulated_s;
  run["steps"] = sim.step_index();
  char hash[24];
  std::snprintf(hash, sizeof(hash), "%016llx", static_cast<unsigned long long>(result.state_hash));
  run["state_hash"] = hash;
  json robots = json::array();
  for (std::size_t i = 0; i < sim.robot_count(); ++i) {
    const RobotStats& stats = sim.stats(i);
    const Pose2 pose = sim.robot(i).pose();
    robots.push_back({{"name", sim.robot(i).name()},
                      {"folder", RunFolder::robot_folder(inputs.world, i).string()},
                      {"final_pose", {{"x", pose.x}, {"y", pose.y}, {"theta", pose.theta}}},
                      {"ground_distance_m", stats.ground_distance_m},
                      {"wheel_distance_left_m", stats.wheel_distance_left_m},
                      {"wheel_distance_right_m", stats.wheel_distance_right_m},
                      {"slip_time_s", stats.slip_time_s},
                      {"collisions", stats.collisions},
                      {"kidnaps", stats.kidnaps}});
  }
  run["robots"] = robots;
  if (session.has_localizers()) run["localizers"] = localizers;
  run["config"] = std::move(config);
  // Wall-clock figures vary from run to run; they are kept last, in this one block, so that
  // everything else in the run folder is byte-identical for the same inputs and seed.
  run["timing"] = {
      {"wall_s", result.wall_s},
      {"real_time_factor", result.wall_s > 0.0 ? result.simulated_s / result.wall_s : 0.0},
      {"realtime_paced", options.realtime},
      {"peak_memory_mb", peak_memory_json()}};
  session.write_run_json(run, end);
  result.status = end.status;
  if (end.failure) std::rethrow_exception(end.failure);
  return result;
}

}  // namespace locsim
