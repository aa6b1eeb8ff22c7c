// `locsim replay`: run localizers on a recorded log, without simulating.
#include "sim/run/replay.hpp"

#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>

#include "commands.hpp"
#include "common.hpp"

namespace locsim::cli::replay_cmd {

/// What the command line gives; its options write into it, so it lives as long as the command.
struct State {
  ReplayOptions options;
  std::string out;
  bool quiet = false;
  std::string robots = "all";
  SessionCli session;
  VideoCli video;
};

int execute(State& s) {
  ReplayOptions& options = s.options;
  options.out_dir = s.out;
  options.robots = robot_names(s.robots);
  s.session.apply(options);
  const std::shared_ptr<FrameSink> recorder = video_recorder(s.video, options.video_options);
  options.video = recorder.get();
  const ReplayResult r = replay_log(options, catch_sigint());
  if (recorder && !s.quiet) print_video_summary(*recorder, options.video_options);
  if (!s.quiet) {
    std::printf("%s: %s, replayed %.1f s (%zu records) in %.3f s -> %s\n", options.log_file.c_str(),
                r.status.c_str(), r.replayed_s, r.records, r.wall_s, s.out.c_str());
    if (r.true_poses == 0 && r.unknown_truths > 0) {
      std::printf(
          "the log has no ground truth: the estimates are in the .tum files, and "
          "metrics.json scores nothing\n");
    }
  }
  return exit_code(r.status, r.failed_localizers);
}

}  // namespace locsim::cli::replay_cmd

namespace locsim::cli {

Command add_replay(CLI::App& app) {
  const auto state = std::make_shared<replay_cmd::State>();
  ReplayOptions& options = state->options;
  CLI::App* const replay = app.add_subcommand(
      "replay", "Run localizers on a recorded log (run --log), without simulating");
  replay->add_option("log", options.log_file, "Log file written by `locsim run --log`")->required();
  replay->add_option("--out", state->out, "Output folder")->required();
  replay->add_flag("-q,--quiet", state->quiet, "No summary line");
  replay
      ->add_option("--seed", options.seed,
                   "Seed the localizers' random streams (their seeds, the initial guess) derive "
                   "from; default: the log's own, so that a replay of a run repeats its estimates "
                   "exactly. Another seed varies the particle filters, not the deterministic ones")
      ->transform(whole_number_in(0, std::numeric_limits<std::uint64_t>::max()));
  replay->add_option("--robots", state->robots,
                     "Replay only these robots, by name, as robot1,robot3 (the log as if it held "
                     "only them); or all");
  add_session_options(replay, state->session, options);
  add_video_options(replay, state->video, options.video_options);
  return {replay, [state] { return replay_cmd::execute(*state); }};
}

}  // namespace locsim::cli
