// `locsim sweep`: every run of an experiment in its own process, N at a time, each result appended
// to results.jsonl as soon as it is known (so a killed sweep loses only the runs in flight), then
// the canonical results.csv and summary (sorted, wall-clock free: identical whatever the number of
// jobs, shards or resumptions). `locsim merge` joins the folders of shards.
#pragma once

#include <atomic>
#include <cstddef>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace locsim {

struct SweepOptions {
  std::filesystem::path experiment_file;
  std::filesystem::path out_dir;
  int jobs = 1;
  // Skip the runs whose result in results.jsonl stands: ok and failed (a localizer's own,
  // deterministic failure is a result); error, crashed and timeout are run again.
  bool resume = false;
  bool retry_failed = false;                 // with resume: run `failed` ones again too
  std::optional<std::pair<int, int>> shard;  // (K, N): runs whose index % N == K - 1
  bool progress_bar = false;                 // else plain lines
  bool progress_lines = true;                // without the bar, a line per run (else nothing)
  std::filesystem::path locsim_binary;       // the `locsim` that runs each run (default: this one)
};

struct SweepSummary {
  std::size_t total = 0;    // runs of this sweep (or shard)
  std::size_t skipped = 0;  // already done (resume)
  std::size_t retried = 0;  // of those ran, how many had a result that did not stand (resume)
  std::size_t ran = 0;
  std::size_t not_ok = 0;  // of those ran: failed, crashed, timed out or errored
  std::size_t errors = 0;  // of those ran: error, locsim could not produce a result
  bool interrupted = false;
};

/// Throws InputError for a bad experiment, a parameter a plugin rejects, a resume of another
/// experiment, a corrupt sweep.json or results.jsonl (naming the file and line), or a folder
/// another live sweep holds (DIR/sweep.lock, flock(2); naming its pid), and PluginError for a
/// plugin that cannot be found or loaded: all before anything is simulated or written.
SweepSummary run_sweep(const SweepOptions& options, const std::atomic<bool>* interrupt = nullptr);

/// What a sweep of an experiment runs, checked as run_sweep checks it before it writes anything.
struct SweepPlan {
  std::string experiment;              // its name
  std::size_t runs = 0;                // localizer configurations x seeds (or logs)
  nlohmann::ordered_json fingerprint;  // of its inputs, as sweep.json holds it
};

/// Throws as run_sweep does, before writing anything (InputError, PluginError).
SweepPlan plan_sweep(const std::filesystem::path& experiment_file);

/// How fingerprint `now` differs from `before`, input by input ("" when it does not).
std::string fingerprint_change(const nlohmann::ordered_json& before,
                               const nlohmann::ordered_json& now);

/// A sweep folder's sweep.json. Throws InputError naming the file (its line, or the key) when it
/// is not a sweep's.
nlohmann::ordered_json read_sweep_header(const std::filesystem::path& dir);

/// Whether a result stands on --resume: ok, and failed unless `retry_failed`.
bool result_stands(const nlohmann::ordered_json& result, bool retry_failed);

/// Joins shard folders into `out_dir`: results.jsonl, results.csv and the summary. Throws
/// InputError, before `out_dir` is made, for a folder that is not a sweep's, a corrupt sweep.json
/// or results.jsonl, shards of other inputs, a folder given twice or a run in two shards, and a
/// shard a live sweep still writes. `kept`, when not empty, is an entry of `out_dir` that is not
/// the merge's (the shards of a Slurm sweep, sim/experiments/slurm.hpp): it does not make the
/// folder "not empty", and what an earlier merge wrote beside it is replaced.
void merge_sweeps(const std::filesystem::path& out_dir,
                  const std::vector<std::filesystem::path>& parts, const std::string& kept = "");

/// A sweep folder's results (results.jsonl: each run's newest line, as the tables take them), in
/// run order. Throws InputError for a corrupt results.jsonl, naming the file and line.
std::vector<nlohmann::ordered_json> read_sweep_results(const std::filesystem::path& out_dir);

/// Rewrites results.csv, summary.csv and summary.md of a folder from its results.jsonl.
void write_tables(const std::filesystem::path& out_dir);

}  // namespace locsim
