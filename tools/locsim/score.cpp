// `locsim score LOG|RUN --estimate FILE --label NAME`: anyone's estimates scored as the built-in
// localizers are (docs/ros.md).
#include "sim/run/score.hpp"

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "sim/common/errors.hpp"

namespace locsim::cli::score_cmd {

/// What the command line gives; its options write into it, so it lives as long as the command.
struct State {
  std::string log, out, robot;
  std::vector<std::string> estimates, labels, topics;
  double converged_deg = rad_to_deg(ConvergenceCriterion{}.heading_rad);
  ScoreOptions options;
  bool overwrite = false, quiet = false;
};

int execute(State& s) {
  if (s.labels.size() != s.estimates.size()) {
    throw InputError("--label: give one per --estimate (" + std::to_string(s.estimates.size()) +
                     " estimates, " + std::to_string(s.labels.size()) + " labels)");
  }
  if (s.topics.size() > 1 && s.topics.size() != s.estimates.size()) {
    throw InputError("--topic: give one for every --estimate, or one for all");
  }
  ScoreOptions& options = s.options;
  // A run folder without --out: the estimates join its own localizers there.
  const bool into_run = std::filesystem::is_directory(s.log) && s.out.empty();
  if (!into_run && s.out.empty()) {
    throw InputError(
        "--out: give the folder to write (or score into a run folder: locsim score "
        "RUN)");
  }
  if (std::filesystem::is_directory(s.log) && !into_run) {
    // A run folder with --out: its log, scored into a folder of its own.
    options.log_file = log_of_run(s.log);
  } else {
    options.log_file = s.log;
  }
  options.out_dir = s.out;
  options.robot = s.robot;
  options.overwrite = s.overwrite;
  options.convergence.heading_rad = deg_to_rad(s.converged_deg);
  for (std::size_t i = 0; i < s.estimates.size(); ++i) {
    options.estimates.push_back(
        {s.labels[i], s.estimates[i],
         s.topics.empty() ? std::string() : s.topics[s.topics.size() == 1 ? 0 : i]});
  }
  const ScoreResult result = into_run ? score_into_run(s.log, options) : score_estimates(options);
  if (!s.quiet) {
    for (std::size_t i = 0; i < result.samples.size(); ++i) {
      std::printf("%s: %s scored at %zu of %zu true poses -> %s\n", options.log_file.c_str(),
                  s.labels[i].c_str(), result.samples[i], result.true_poses,
                  (into_run ? s.log : s.out).c_str());
    }
  }
  return kExitOk;
}

}  // namespace locsim::cli::score_cmd

namespace locsim::cli {

Command add_score(CLI::App& app) {
  const auto state = std::make_shared<score_cmd::State>();
  CLI::App* const command = app.add_subcommand(
      "score",
      "Score estimates made outside locsim (a TUM file, a ROS 2 bag's topic) on a log, or into "
      "a run folder beside its own localizers");
  command
      ->add_option("log", state->log,
                   "The log the estimates were made on, or a run folder that kept its log (a "
                   "run with --log, a replay): without --out the estimates join its localizers "
                   "there (metrics.json, LABEL.tum, run.json), for `locsim report`")
      ->required();
  command
      ->add_option("--estimate", state->estimates,
                   "A TUM file (times on the log's clock), or a ROS 2 bag (with --topic); repeat "
                   "for several")
      ->required();
  command->add_option("--label", state->labels, "The estimate's name (one per --estimate)")
      ->required();
  command->add_option("--topic", state->topics,
                      "A bag's PoseWithCovarianceStamped, Odometry or PoseStamped topic (e.g. "
                      "/amcl_pose)");
  command->add_option("--out", state->out,
                      "Output folder (a run folder: metrics.json, LABEL.tum); needed for a log");
  command->add_option("--robot", state->robot, "The robot the estimates are of (a log of several)");
  command
      ->add_option("--converged-within-m", state->options.convergence.position_m,
                   "Convergence: position error at most this [m]")
      ->check(number_above(0.0, 1e4));
  command
      ->add_option("--converged-within-deg", state->converged_deg,
                   "Convergence: heading error at most this [deg]")
      ->check(number_in(1e-6, 180.0));
  command
      ->add_option("--converged-hold", state->options.convergence.hold_samples,
                   "Convergence: for this many consecutive ground-truth samples")
      ->check(CLI::Range(1, 1000000));
  command->add_flag("--overwrite", state->overwrite, "Replace a run folder's contents");
  command->add_flag("-q,--quiet", state->quiet, "No summary line");
  command->footer(
      std::string(
          "At each true pose of the log an estimate is scored by its latest sample at or before "
          "it\n(within 0.1 ms): what the localizer had said by then. A bag's stamps are put on "
          "the log's\nclock by its epoch (a log exported by locsim: 1 s; an imported bag's: "
          "its first stamp).\nCovariances (PoseWithCovarianceStamped, Odometry) give NEES and "
          "the 95 % ellipse.\n\n") +
      kExitCodes);
  return {command, [state] { return score_cmd::execute(*state); }};
}

}  // namespace locsim::cli
