// `locsim run`: simulate a world and write a run folder.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include "commands.hpp"
#include "common.hpp"
#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/run/runner.hpp"

namespace locsim::cli::run_cmd {

/// What the command line gives; its options write into it, so it lives as long as the command.
struct State {
  CLI::App* command = nullptr;
  RunOptions options;
  std::string world_file;
  std::optional<std::string> scenario_file;
  std::string out_dir;
  bool quiet = false;
  std::string log_file;
  double max_output_gib = static_cast<double>(kDefaultMaxOutputBytes) / (1 << 30);
  VideoCli video;
  SessionCli session;
};

int execute(State& s) {
  RunOptions& options = s.options;
  s.session.apply(options);
  options.world_file = s.world_file;
  if (s.command->count("--log") > 0 && s.log_file.empty())
    throw InputError("--log: the path is empty");
  if (!s.log_file.empty()) {
    // Made by the run when missing (as --out is), after the inputs are checked.
    check_output_folder(std::filesystem::path(s.log_file).parent_path(), "--log");
    options.log_file = s.log_file;
  }
  options.max_output_bytes = static_cast<std::uint64_t>(s.max_output_gib * (1 << 30));
  if (s.scenario_file) options.scenario_file = *s.scenario_file;
  options.out_dir = s.out_dir;
  options.progress = !s.quiet && isatty(STDERR_FILENO);
  options.make_landmark_imager = imager_factory(options.video_options.backend);
  const std::shared_ptr<FrameSink> recorder = video_recorder(s.video, options.video_options);
  options.video = recorder.get();
  const RunResult result = run_simulation(options, catch_sigint());
  if (recorder && !s.quiet) print_video_summary(*recorder, options.video_options);
  if (!s.quiet) {
    std::printf("%s: %s, %.1f s simulated in %.2f s (%.0fx real time) -> %s\n",
                s.world_file.c_str(), result.status.c_str(), result.simulated_s, result.wall_s,
                result.wall_s > 0 ? result.simulated_s / result.wall_s : 0.0,
                result.out_dir.c_str());
  }
  return exit_code(result.status, result.failed_localizers);
}

}  // namespace locsim::cli::run_cmd

namespace locsim::cli {

Command add_run(CLI::App& app) {
  const auto state = std::make_shared<run_cmd::State>();
  RunOptions& options = state->options;
  CLI::App* const run = app.add_subcommand("run", "Simulate a world and write a run folder");
  state->command = run;
  run->add_option("world", state->world_file, "World file (YAML)")->required();
  run->add_option("--scenario", state->scenario_file,
                  "Scenario file (YAML); default: the world's own 'scenario:' section");
  run->add_option("--seed", options.seed, "Run seed; every random stream derives from it")
      ->transform(whole_number_in(0, std::numeric_limits<std::uint64_t>::max()))
      ->capture_default_str();
  // The scenario's own range for duration_s (one place for it: scenario_def.hpp).
  run->add_option("--duration", options.duration_s, "Simulated seconds (overrides the scenario)")
      ->check(number_in(ScenarioDef::kDurationRange.min, ScenarioDef::kDurationRange.max));
  run->add_flag("--no-variation", options.no_variation,
                "Run the world as declared: no per-seed variation, whatever its `variation:` "
                "(docs/worlds.md#variation)");
  run->add_option("--out", state->out_dir, "Output folder (default: a new folder under runs/)");
  run->add_flag("--realtime", options.realtime, "Pace the simulation to the wall clock");
  run->add_option("--threads", options.threads,
                  "Threads for the sensors of different robots; the outputs are the same for "
                  "any count (0: one per core)")
      ->transform(whole_number_in(0, 256))
      ->capture_default_str();
  run->add_flag("-q,--quiet", state->quiet, "No progress line and no summary");
  run->add_option("--log", state->log_file,
                  "Also record the sensor stream, ground truth and events into one log file, for "
                  "`locsim replay` (its folder is made when missing, as --out's is)");
  run->add_option("--max-output-gib", state->max_output_gib,
                  "Refuse (exit 2) a run whose files (readings, log, video, estimates) are "
                  "estimated to exceed this many GiB; one they would not fit on the disk is "
                  "refused too (exit 1). Both before it starts")
      ->check(CLI::Range(0.001, 1e6))
      ->capture_default_str();
  add_video_options(run, state->video, options.video_options);
  run->footer(
      "Writes run.json (resolved configuration, seed, version, timing), groundtruth.tum (true\n"
      "pose, TUM format), events.csv (every scenario event), readings/ (one CSV per sensor), and\n"
      "per localizer LABEL.tum and its part of metrics.json. With several robots each has its own\n"
      "sub-folder.\n\n" +
      std::string(kExitCodes));
  add_session_options(run, state->session, options);
  return {run, [state] { return run_cmd::execute(*state); }};
}

}  // namespace locsim::cli
