// `locsim twin`: write a simulated twin of a log.
#include "sim/experiments/twin.hpp"

#include <cstdio>
#include <memory>
#include <string>

#include "commands.hpp"
#include "common.hpp"
#include "sim/common/errors.hpp"

namespace locsim::cli::twin_cmd {

/// What the command line gives; its options write into it, so it lives as long as the command.
struct State {
  TwinOptions options;
  std::string log, out, calibration, robots = "all";
  bool overwrite = false, quiet = false, keep_camera_rate = false;
};

int execute(State& s) {
  TwinOptions& options = s.options;
  options.log = s.log;
  if (!s.calibration.empty()) options.calibration = s.calibration;
  options.robots = robot_names(s.robots);
  options.match_detections = !s.keep_camera_rate;
  const Twin twin = write_twin(options, s.out, s.overwrite);
  if (!s.quiet) std::printf("%s", describe(twin).c_str());
  return kExitOk;
}

}  // namespace locsim::cli::twin_cmd

namespace locsim::cli {

Command add_twin(CLI::App& app) {
  const auto state = std::make_shared<twin_cmd::State>();
  CLI::App* const twin = app.add_subcommand(
      "twin",
      "Write a simulated twin of a log: its world, each robot driven along its true path, the "
      "calibrated sensor noise (docs/real_data.md)");
  twin->add_option("log", state->log, "A log with ground truth (locsim import, run --log)")
      ->required();
  twin->add_option("--out", state->out,
                   "The world file to write (WORLD.yaml; the paths go beside it as "
                   "WORLD_ROBOT.tum)")
      ->required();
  twin->add_option("--calibration", state->calibration,
                   "A calibration.yaml (locsim calibrate): its sensors: for every robot");
  twin->add_option("--robots", state->robots,
                   "The robots to keep, by name, as robot1,robot3; or all");
  twin->add_option("--pose-rate-hz", state->options.pose_rate_hz,
                   "Samples of each true path per second [Hz]")
      ->check(number_in(TwinOptions::kPoseRateRange.min, TwinOptions::kPoseRateRange.max))
      ->capture_default_str();
  twin->add_flag("--keep-camera-rate", state->keep_camera_rate,
                 "Keep the range_bearing camera's rate and misses (do not match the log's "
                 "detections per second)");
  twin->add_flag("--overwrite", state->overwrite, "Replace the world and path files");
  twin->add_flag("-q,--quiet", state->quiet, "No summary");
  return {twin, [state] { return twin_cmd::execute(*state); }};
}

}  // namespace locsim::cli
