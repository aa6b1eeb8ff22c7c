// `locsim sweep --slurm N`: a sweep as a Slurm job array. Each array task runs one deterministic
// shard (`locsim sweep --shard K/N`) on whichever node Slurm gives it; locsim waits for the job,
// then merges the shards into the sweep folder, which is then the same as a local sweep's (every
// file but the wall-clock timings). A task that failed is run again, alone, by --resume.
//
// The sweep folder DIR holds the merged sweep, and DIR/slurm what the cluster wrote:
//   job.json        the experiment, the number of tasks, the job ids submitted
//   job.sh          the array task's script (sbatch runs it once per task)
//   logs/J_K.log    what task K of job J printed
//   shard-K/        shard K's sweep folder
// DIR/slurm/sweep.lock is held (flock) while a locsim waits on the folder's jobs.
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "sim/experiments/sweep.hpp"

namespace locsim {

struct SlurmSweepOptions {
  // experiment_file, out_dir (the merged sweep), jobs (each task's runs at a time, and the CPUs
  // it asks Slurm for), resume, retry_failed, locsim_binary (the `locsim` the tasks run: it must
  // be at the same path on every node, as the experiment and DIR must be).
  SweepOptions sweep;
  int tasks = 0;                            // array tasks = shards; 0 on --resume: as before
  std::vector<std::string> sbatch_options;  // handed to sbatch as given: --partition=, --time=
  std::chrono::milliseconds poll_interval{2000};     // between two looks at the job's state
  std::function<void(const std::string&)> progress;  // a line at each change of the job's state
};

struct SlurmSweepSummary {
  std::string job_id;           // the job waited for ("" when every shard was already done)
  std::size_t submitted = 0;    // array tasks submitted by this call
  std::size_t runs = 0;         // of the sweep
  std::size_t with_result = 0;  // runs with a result (ok, failed, crashed, timeout)
  std::size_t errors = 0;       // runs in error: locsim could not produce a result
  /// Shards with a run without a result (their task failed, or was cancelled), each with the
  /// log of the last task that ran it.
  std::vector<std::pair<int, std::filesystem::path>> unfinished;
  bool interrupted = false;  // Ctrl-C while waiting: the job still runs
};

/// Submits the shards that have a run to do (all of them on a new sweep; with resume, those with
/// a run without a result that stands, after waiting for a job of the folder still in the queue),
/// waits for the job, and merges every shard into out_dir. Throws InputError / PluginError as
/// run_sweep does, before anything is submitted or written (also: a folder of another sweep, a
/// task count other than the folder's); std::runtime_error when sbatch refuses the job (its
/// message) or cannot be run.
SlurmSweepSummary run_sweep_on_slurm(const SlurmSweepOptions& options,
                                     const std::atomic<bool>* interrupt = nullptr);

}  // namespace locsim
