// `locsim sweep`: every run of an experiment in its own process, N at a time, each result appended
// to results.jsonl as soon as it is known (so a killed sweep loses only the runs in flight), then
// the canonical results.csv and summary (sorted, wall-clock free: identical whatever the number of
// jobs, shards or resumptions). `locsim merge` joins the folders of shards.
#pragma once

#include <atomic>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace locsim {

struct SweepOptions {
  std::filesystem::path experiment_file;
  std::filesystem::path out_dir;
  int jobs = 1;
  bool resume = false;                       // skip runs already in results.jsonl
  std::optional<std::pair<int, int>> shard;  // (K, N): runs whose index % N == K - 1
  bool progress_bar = false;                 // else plain lines
  std::filesystem::path locsim_binary;       // the `locsim` that runs each run (default: this one)
};

struct SweepSummary {
  std::size_t total = 0;    // runs of this sweep (or shard)
  std::size_t skipped = 0;  // already done (resume)
  std::size_t ran = 0;
  std::size_t not_ok = 0;  // failed, crashed, timed out or errored
  bool interrupted = false;
};

/// Throws InputError for a bad experiment or a resume of another experiment.
SweepSummary run_sweep(const SweepOptions& options, const std::atomic<bool>* interrupt = nullptr);

/// Joins shard folders into `out_dir`: results.jsonl, results.csv and the summary.
void merge_sweeps(const std::filesystem::path& out_dir,
                  const std::vector<std::filesystem::path>& parts);

/// Rewrites results.csv, summary.csv and summary.md of a folder from its results.jsonl.
void write_tables(const std::filesystem::path& out_dir);

}  // namespace locsim
