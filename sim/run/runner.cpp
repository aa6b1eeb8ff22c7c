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
  // What the run reads must survive what it writes: --overwrite keeps it, an output never
  // replaces it.
  std::vector<fs::path> read = inputs.files;
  for (const fs::path& file : session_input_files(options)) read.push_back(file);
  std::vector<std::pair<std::string, fs::path>> named_outputs;
  if (options.log_file) named_outputs.emplace_back("--log", *options.log_file);
  if (options.video != nullptr && options.video_options.video_file)
    named_outputs.emplace_back("--video", *options.video_options.video_file);
  RunFolder::check_outputs(named_outputs, read);
  RunFolder::check(result.out_dir, options.overwrite, read);
  check_run_output(estimate_run_output(inputs.world, inputs.scenario, options.readings,
                                       options.log_file.has_value(), options.localizers.size()),
                   options.max_output_bytes, result.out_dir);
  // The localizers' processes start before the simulation (and any renderer) has threads.
  Session session(options, inputs.world, inputs.scenario, options.seed, interrupt);
  Simulation sim(inputs.world, inputs.scenario, options.seed, options.make_landmark_imager);
  sim.use_threads(options.threads > 0 ? options.threads : default_thread_count());
  // The log and the video are opened before the run folder is made: one that cannot be written
  // (exit 1 for the log, 4 for the video, naming the path and the reason) leaves no folder.
  std::unique_ptr<LogWriter> log;
  if (options.log_file) {
    // Its folder is made when missing, as the run folder is (`--out NEW --log NEW/run.locsimlog`),
    // and removed again when the log cannot be written.
    const fs::path made =
        make_missing_folders(options.log_file->parent_path(),
                             "cannot write the log " + options.log_file->string() + ": ");
    try {
      log = std::make_unique<LogWriter>(*options.log_file, log_header(options, inputs));
    } catch (...) {
      std::error_code ignored;
      if (!made.empty()) fs::remove_all(made, ignored);
      throw;
    }
  }
  std::optional<FrameCapture> capture;
  if (options.video != nullptr) {
    capture.emplace(*options.video, options.video_options, sim, &session.host());
  }
  std::vector<fs::path> keep = read;  // --overwrite empties the folder, but not of these
  for (const auto& file :
       {options.log_file, options.video_options.video_file, options.video_options.frames_dir}) {
    if (file) keep.push_back(*file);
  }
  session.open(result.out_dir, keep);
  SimulationSource source(sim);
  RecordConsumer& input = session.input();
  const auto steps_per_s = std::max<std::int64_t>(1, std::llround(sim.world_def().physics.step_hz));

  const auto wall_start = std::chrono::steady_clock::now();
  auto next_progress = wall_start + std::chrono::seconds(1);
  bool progress_shown = false;
  RunEnd end;
  try {
    if (log) session.input().add(*log);
    if (capture) session.input().add(*capture);
    source.emit(input);
    if (capture) capture->after_step(sim);
    while (!sim.done()) {
      if (interrupt != nullptr && interrupt->load(std::memory_order_relaxed)) {
        end.status = "interrupted";
        break;
      }
      sim.step();
      source.emit(input);
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
  if (options.video != nullptr) {
    // Closed whatever the status: the frames so far make a valid video of a failed run too.
    try {
      options.video->finish();
    } catch (...) {
      end.caught("video: ");
    }
  }
  if (log) {
    try {
      log->flush();
      if (end.completed()) log->finish();  // else it reads as truncated, rightly
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

  json run;
  run["locsim_version"] = locsim_version();
  run["status"] = end.status;
  if (!end.error.empty()) run["error"] = end.error;
  run["seed"] = options.seed;
  run["world_file"] = options.world_file.string();
  run["scenario_file"] = inputs.scenario.source.string();
  if (options.params_file) run["params_file"] = options.params_file->string();
  run["simulated_s"] = result.simulated_s;
  run["steps"] = sim.step_index();
  char hash[24];
  std::snprintf(hash, sizeof(hash), "%016llx", static_cast<unsigned long long>(result.state_hash));
  run["state_hash"] = hash;
  json robots = json::array();
  for (std::size_t i = 0; i < sim.robot_count(); ++i) {
    const RobotStats& stats = sim.stats(i);
    const Pose2 pose = sim.robot(i).pose();
    robots.push_back(
        {{"name", sim.robot(i).name()},
         {"folder", fs::relative(session.folder().robot_dirs[i], result.out_dir).string()},
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
  run["config"] = {{"world", to_json(inputs.world)}, {"scenario", to_json(inputs.scenario)}};
  // Wall-clock figures vary from run to run; they are kept last, in this one block, so that
  // everything else in the run folder is byte-identical for the same inputs and seed.
  run["timing"] = {
      {"wall_s", result.wall_s},
      {"real_time_factor", result.wall_s > 0.0 ? result.simulated_s / result.wall_s : 0.0},
      {"realtime_paced", options.realtime},
      {"peak_memory_mb", peak_memory_json()}};
  write_json_atomically(result.out_dir / "run.json", run);
  if (end.failure) std::rethrow_exception(end.failure);
  return result;
}

}  // namespace locsim
