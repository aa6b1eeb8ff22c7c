// `locsim sweep`: every localizer configuration of an experiment on every seed (or log).
#include "sim/experiments/sweep.hpp"

#include <unistd.h>

#include <cstdio>
#include <memory>
#include <sstream>
#include <string>
#include <utility>

#include "commands.hpp"
#include "common.hpp"
#include "sim/common/errors.hpp"

namespace locsim::cli::sweep_cmd {

/// What the command line gives; its options write into it, so it lives as long as the command.
struct State {
  SweepOptions options;
  std::string shard;
};

int execute(State& s) {
  SweepOptions& options = s.options;
  if (!s.shard.empty()) {
    int k = 0, n = 0;
    char slash = 0;
    std::istringstream text(s.shard);
    if (!(text >> k >> slash >> n) || slash != '/' || !text.eof()) {
      throw InputError("--shard: expected K/N, got '" + s.shard + "'");
    }
    options.shard = std::pair{k, n};
  }
  options.progress_bar = isatty(STDERR_FILENO);
  const SweepSummary summary = run_sweep(options, catch_sigint());
  const std::string retried =
      summary.retried > 0 ? ", " + std::to_string(summary.retried) + " run again" : "";
  std::printf("%s: %zu runs (%zu done before%s), %zu not ok%s -> %s\n",
              options.experiment_file.c_str(), summary.total, summary.skipped, retried.c_str(),
              summary.not_ok, summary.interrupted ? ", interrupted (--resume finishes it)" : "",
              options.out_dir.c_str());
  if (summary.interrupted) return kExitInterrupted;
  if (summary.errors > 0) {
    std::fflush(stdout);
    std::fprintf(stderr,
                 "locsim sweep: %zu run%s ended in error (locsim could not produce a result); "
                 "the reasons are in %s (column reason) and each such run's log.txt; fix the "
                 "cause and pass --resume to run them again\n",
                 summary.errors, summary.errors == 1 ? "" : "s",
                 (options.out_dir / "results.csv").c_str());
    return kExitFailure;
  }
  return kExitOk;
}

}  // namespace locsim::cli::sweep_cmd

namespace locsim::cli {

Command add_sweep(CLI::App& app) {
  const auto state = std::make_shared<sweep_cmd::State>();
  SweepOptions& options = state->options;
  CLI::App* const sweep =
      app.add_subcommand("sweep",
                         "Run an experiment: every localizer configuration on every seed (or on "
                         "every recorded log, once per seed: `logs:`, docs/experiments.md)");
  sweep->add_option("experiment", options.experiment_file, "Experiment file (YAML)")->required();
  sweep->add_option("--out", options.out_dir, "Sweep folder")->required();
  sweep->add_option("-j,--jobs", options.jobs, "Runs at a time, each its own process")
      ->transform(whole_number_in(1, 4096))
      ->capture_default_str();
  CLI::Option* const resume_flag = sweep->add_flag(
      "--resume", options.resume,
      "Finish a sweep in --out: keep its ok and failed runs, run the others (not run "
      "yet, error, crashed, timeout)");
  sweep
      ->add_flag("--retry-failed", options.retry_failed,
                 "With --resume: run the failed runs again too")
      ->needs(resume_flag);
  sweep->add_option("--shard", state->shard,
                    "K/N: run only the K-th of N deterministic slices (merge them after)");
  sweep->footer(
      "Checks first: every plugin is found and loaded and every configuration's parameters are\n"
      "checked as `locsim run` does, before anything is simulated or the folder is made.\n"
      "Writes results.jsonl (a line per finished run, flushed at once), then results.csv and\n"
      "summary.csv/summary.md (sorted and free of wall-clock figures: identical for any --jobs,\n"
      "--shard or --resume). Statuses: ok; failed (the localizer failed: a result); crashed and\n"
      "timeout (its process was killed by a signal or after timeout_s); error (locsim could not\n"
      "produce a result: the reason is the run's whole error output, its log.txt has the rest).\n"
      "--resume runs error, crashed and timeout runs again (and failed ones with --retry-failed);\n"
      "their new result replaces the old one. One sweep at a time writes a folder: it holds\n"
      "DIR/sweep.lock (flock) while it runs; a sweep killed hard holds nothing.\n\n"
      "Exit codes:\n"
      "  0    every run has a result (ok, failed, crashed or timeout)\n"
      "  1    some run ended in error (the last line says how many; results.csv says why), or a\n"
      "       failure not caused by the input\n"
      "  2    bad input: experiment file, world, scenario, command line, or a parameter a plugin\n"
      "       does not declare or accept (the message names the file:line:col and key); --out\n"
      "       in use by another live sweep (the message names its pid); a corrupt sweep.json or\n"
      "       results.jsonl on --resume (file:line)\n"
      "  3    a plugin not found or not loadable (the message names where the experiment gives "
      "it)\n"
      "  130  interrupted (Ctrl-C); --resume finishes it");
  return {sweep, [state] { return sweep_cmd::execute(*state); }};
}

}  // namespace locsim::cli
