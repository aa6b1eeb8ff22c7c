// `locsim export LOG|RUN --rosbag2 OUT`: a log (or a run folder's) as a ROS 2 bag (docs/ros.md).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "commands.hpp"
#include "common.hpp"
#include "sim/common/errors.hpp"
#include "sim/run/export_bag.hpp"
#include "sim/run/score.hpp"

namespace locsim::cli::export_cmd {

/// What the command line gives; its options write into it, so it lives as long as the command.
struct State {
  std::string log, out, compression = "zstd";
  bool overwrite = false, quiet = false;
};

int execute(const State& s) {
  RosbagRecorderOptions options;
  options.compression = s.compression == "lz4"    ? rosbag::McapCompression::kLz4
                        : s.compression == "none" ? rosbag::McapCompression::kNone
                                                  : rosbag::McapCompression::kZstd;
  // A run folder: the log it kept (run.json's log_file).
  const std::filesystem::path log =
      std::filesystem::is_directory(s.log) ? log_of_run(s.log) : std::filesystem::path(s.log);
  const ExportSummary summary = export_rosbag2(log, s.out, options, s.overwrite);
  if (!s.quiet) {
    std::printf("%s: %llu records -> %s: %llu messages, %.1f MB\n", log.c_str(),
                static_cast<unsigned long long>(summary.records), s.out.c_str(),
                static_cast<unsigned long long>(summary.messages),
                static_cast<double>(summary.bag_bytes) / 1e6);
  }
  return kExitOk;
}

}  // namespace locsim::cli::export_cmd

namespace locsim::cli {

Command add_export(CLI::App& app) {
  const auto state = std::make_shared<export_cmd::State>();
  CLI::App* const command = app.add_subcommand(
      "export", "Write a log as a ROS 2 bag, to play into ROS or open in Foxglove (docs/ros.md)");
  command
      ->add_option("log", state->log,
                   "The log (`locsim run --log`, `locsim import`), or a run folder that kept its "
                   "log (a run with --log, a replay). Its localizers' estimates and particles: "
                   "`run` or `replay` with --rosbag2")
      ->required();
  command
      ->add_option("--rosbag2", state->out,
                   "The bag folder to write (metadata.yaml and NAME_0.mcap; must not exist)")
      ->required();
  command->add_option("--compression", state->compression, "The MCAP chunks': zstd, lz4 or none")
      ->check(CLI::IsMember({"zstd", "lz4", "none"}));
  command->add_flag("--overwrite", state->overwrite,
                    "Replace an existing bag folder (one holding only a bag's files)");
  command->add_flag("-q,--quiet", state->quiet, "No summary line");
  command->footer(
      std::string(
          "Topics (a robot's under /NAME when the world has several): /clock, /tf (odom -> "
          "base_link,\nmap -> base_link_truth), /tf_static (the laser's and IMU's mounts), /odom, "
          "/joint_states\n(wheel encoders), /imu, /scan, /map (the static world as the "
          "localizers see it),\n/ground_truth, /locsim/events. /map and /tf_static are offered "
          "transient local.\n\n") +
      kExitCodes);
  return {command, [state] { return export_cmd::execute(*state); }};
}

}  // namespace locsim::cli
