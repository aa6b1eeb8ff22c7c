// `locsim sweep`: every localizer configuration of an experiment on every seed (or log).
#include "sim/experiments/sweep.hpp"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "sim/common/errors.hpp"
#include "sim/experiments/slurm.hpp"

namespace locsim::cli::sweep_cmd {

/// What the command line gives; its options write into it, so it lives as long as the command.
struct State {
  SweepOptions options;
  std::string shard;
  int slurm_tasks = 0;  // --slurm N; 0: a local sweep
  std::vector<std::string> sbatch_options;
};

/// Says that `errors` runs ended in error, and where the reasons are: exit 1.
int runs_in_error(std::size_t errors, const std::filesystem::path& out_dir) {
  std::fflush(stdout);
  std::fprintf(stderr,
               "locsim sweep: %zu run%s ended in error (locsim could not produce a result); the "
               "reasons are in %s (column reason) and each such run's log.txt; fix the cause and "
               "pass --resume to run them again\n",
               errors, errors == 1 ? "" : "s", (out_dir / "results.csv").c_str());
  return kExitFailure;
}

/// `locsim sweep --slurm`: the shards as a Slurm job array, waited for and merged.
int execute_on_slurm(const State& s) {
  SlurmSweepOptions slurm;
  slurm.sweep = s.options;
  slurm.tasks = s.slurm_tasks;
  slurm.sbatch_options = s.sbatch_options;
  slurm.progress = [](const std::string& line) {
    std::fprintf(stderr, "%s\n", line.c_str());
    std::fflush(stderr);
  };
  const SlurmSweepSummary summary = run_sweep_on_slurm(slurm, catch_sigint());
  const std::string& out = s.options.out_dir.string();
  if (summary.interrupted) {
    std::fprintf(stderr,
                 "locsim sweep: interrupted; Slurm job %s still runs (`scancel %s` ends it); "
                 "the same command with --resume waits for it and merges\n",
                 summary.job_id.c_str(), summary.job_id.c_str());
    return kExitInterrupted;
  }
  std::printf("%s: %zu runs, %zu with a result, %zu in error%s -> %s\n",
              s.options.experiment_file.c_str(), summary.runs, summary.with_result, summary.errors,
              summary.job_id.empty() ? " (every shard was done: merged again)" : "", out.c_str());
  if (!summary.unfinished.empty()) {
    std::fflush(stdout);
    for (const auto& [shard, log] : summary.unfinished) {
      std::fprintf(stderr, "locsim sweep: shard %d has runs without a result; its task's log: %s\n",
                   shard, log.empty() ? "(none)" : log.c_str());
    }
    std::fprintf(stderr,
                 "locsim sweep: %zu of %zu runs have no result (a task failed or was "
                 "cancelled); fix the cause and pass --resume: only those shards run again\n",
                 summary.runs - summary.with_result - summary.errors, summary.runs);
    return kExitFailure;
  }
  if (summary.errors > 0) return runs_in_error(summary.errors, s.options.out_dir);
  return kExitOk;
}

int execute(State& s) {
  SweepOptions& options = s.options;
  if (s.slurm_tasks > 0) return execute_on_slurm(s);
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
  if (summary.errors > 0) return runs_in_error(summary.errors, options.out_dir);
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
  CLI::Option* const shard_option =
      sweep->add_option("--shard", state->shard,
                        "K/N: run only the K-th of N deterministic slices (merge them after)");
  CLI::Option* const slurm_option =
      sweep
          ->add_option("--slurm", state->slurm_tasks,
                       "Run the sweep on a Slurm cluster as a job array of N tasks (each one "
                       "shard); wait for it and merge into --out")
          ->transform(whole_number_in(1, 1000000))
          ->excludes(shard_option);
  sweep
      ->add_option("--sbatch", state->sbatch_options,
                   "With --slurm: an option for sbatch, as sbatch takes it "
                   "(--sbatch=--partition=cpu --sbatch=--time=2:00:00); repeatable")
      ->needs(slurm_option)
      ->allow_extra_args(false);
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
      "--slurm N submits the shards as one job array (sbatch, from PATH; the experiment, --out\n"
      "and this locsim must be at the same paths on the nodes), shows the job's state until it\n"
      "ends and merges the shards into --out, which is then the same as a local sweep's; what\n"
      "the cluster wrote stays in DIR/slurm (job.sh, logs/JOB_TASK.log, shard-K/). --jobs is\n"
      "each task's runs at a time and the CPUs it asks for. --resume submits only the shards\n"
      "with a run to do, after waiting for a job of the folder still queued. Ctrl-C leaves the\n"
      "job running (--resume waits for it again).\n\n"
      "Exit codes:\n"
      "  0    every run has a result (ok, failed, crashed or timeout)\n"
      "  1    some run ended in error (the last line says how many; results.csv says why), or a\n"
      "       failure not caused by the input; --slurm: a task left runs without a result (the\n"
      "       message names its log), sbatch refused the job (its message), or squeue failed\n"
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
