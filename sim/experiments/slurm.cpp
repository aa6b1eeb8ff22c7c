#include "sim/experiments/slurm.hpp"

#include <algorithm>
#include <cctype>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "sim/common/command.hpp"
#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/experiments/sweep_lock.hpp"

namespace locsim {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

namespace {

/// `text` as one word of sh(1), whatever it holds.
std::string sh_word(const std::string& text) {
  std::string quoted = "'";
  for (const char c : text) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

/// Shards as sbatch's --array takes them: "1-3,5".
std::string array_list(const std::vector<int>& shards) {
  std::string list;
  for (std::size_t i = 0; i < shards.size();) {
    std::size_t j = i;
    while (j + 1 < shards.size() && shards[j + 1] == shards[j] + 1) ++j;
    if (!list.empty()) list += ',';
    list += std::to_string(shards[i]);
    if (j > i) list += '-' + std::to_string(shards[j]);
    i = j + 1;
  }
  return list;
}

std::string trimmed(std::string text) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.pop_back();
  std::size_t start = 0;
  while (start < text.size() && std::isspace(static_cast<unsigned char>(text[start]))) ++start;
  return text.substr(start);
}

/// run_command of one of Slurm's commands, saying where they come from when missing.
CommandOutput slurm_command(const std::vector<std::string>& argv) {
  try {
    return run_command(argv);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(
        std::string(e.what()) +
        " (Slurm's commands: Debian's slurm-client, on a cluster's login node)");
  }
}

/// The states of a job's array tasks still in the queue ("RUNNING", "PENDING", ...), one per task;
/// none once it has ended. Slurm forgets an ended job after MinJobAge: squeue then says the id is
/// invalid, which is the same answer.
std::vector<std::string> queued_tasks(const std::string& job_id) {
  const CommandOutput q =
      slurm_command({"squeue", "--noheader", "--array", "--jobs=" + job_id, "--format=%T"});
  if (q.exit_code != 0) {
    if (q.err.find("Invalid job id") != std::string::npos) return {};
    throw std::runtime_error("squeue could not say how Slurm job " + job_id + " stands (exit " +
                             std::to_string(q.exit_code) + "): " + trimmed(q.err) +
                             "; the job may still run: `locsim sweep --resume` with the same "
                             "--out waits for it");
  }
  std::vector<std::string> states;
  std::istringstream lines(q.out);
  for (std::string line; std::getline(lines, line);) {
    if (!trimmed(line).empty()) states.push_back(trimmed(line));
  }
  return states;
}

/// Waits until the job has left the queue, saying each change of its tasks' states. False when
/// interrupted first.
bool wait_for_job(const std::string& job_id, const SlurmSweepOptions& options,
                  const std::atomic<bool>* interrupt) {
  std::string said;
  for (;;) {
    const std::vector<std::string> states = queued_tasks(job_id);
    std::map<std::string, int> count;
    for (const std::string& s : states) ++count[s];
    std::string now = "slurm job " + job_id + ": ";
    if (states.empty()) {
      now += "ended";
    } else {
      bool first = true;
      for (const auto& [state, n] : count) {
        std::string lower = state;
        std::transform(lower.begin(), lower.end(), lower.begin(),
                       [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
        now += (first ? "" : ", ") + std::to_string(n) + " " + lower;
        first = false;
      }
    }
    if (now != said && options.progress) options.progress(now);
    said = now;
    if (states.empty()) return true;
    const auto until = std::chrono::steady_clock::now() + options.poll_interval;
    while (std::chrono::steady_clock::now() < until) {
      if (interrupt != nullptr && interrupt->load()) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }
}

/// Where a shard's runs stand.
struct ShardState {
  std::size_t runs = 0;      // of the shard
  std::size_t results = 0;   // with a result, error included
  std::size_t standing = 0;  // whose result stands on --resume
  std::size_t errors = 0;
};

ShardState shard_state(const fs::path& dir, std::size_t runs, int k, int n, bool retry_failed) {
  ShardState state;
  for (std::size_t i = static_cast<std::size_t>(k - 1); i < runs; i += static_cast<std::size_t>(n))
    ++state.runs;
  if (!fs::exists(dir / "sweep.json")) return state;
  for (const json& r : read_sweep_results(dir)) {
    ++state.results;
    state.standing += result_stands(r, retry_failed) ? 1 : 0;
    state.errors += r["status"] == "error" ? 1 : 0;
  }
  return state;
}

/// DIR/slurm/job.json, its keys checked.
json read_job_file(const fs::path& file) {
  json job;
  try {
    job = json::parse(read_text(file));
  } catch (const json::parse_error& e) {
    throw InputError(SourceLocation{file.string()}, "", std::string("not valid JSON: ") + e.what());
  }
  const SourceLocation where{file.string()};
  if (!job.is_object()) throw InputError(where, "", "not a JSON object");
  if (!job.contains("tasks") || !job["tasks"].is_number_unsigned() || job["tasks"] == 0)
    throw InputError(where, "tasks", "missing, or not a whole number >= 1");
  if (!job.contains("submissions") || !job["submissions"].is_array())
    throw InputError(where, "submissions", "missing, or not a list");
  for (const json& s : job["submissions"]) {
    if (!s.is_object() || !s.contains("job_id") || !s["job_id"].is_string() ||
        !s.contains("shards") || !s["shards"].is_array())
      throw InputError(where, "submissions", "an entry without job_id and shards");
  }
  return job;
}

/// The log of the last task that ran shard `k`, "" when none did.
fs::path task_log(const json& job, const fs::path& cluster, int k) {
  for (auto s = job["submissions"].rbegin(); s != job["submissions"].rend(); ++s) {
    for (const json& shard : (*s)["shards"]) {
      if (shard == k)
        return cluster / "logs" /
               ((*s)["job_id"].get<std::string>() + "_" + std::to_string(k) + ".log");
    }
  }
  return {};
}

/// The array task's script: shard $SLURM_ARRAY_TASK_ID of `tasks`. A task that Slurm requeues
/// (a node lost), or that --resume submits again, finishes its shard rather than starting over.
std::string job_script(const fs::path& locsim, const fs::path& experiment, const fs::path& cluster,
                       int tasks, int jobs, bool retry_failed) {
  std::ostringstream s;
  s << "#!/bin/sh\n"
    << "# Written by `locsim sweep --slurm`: array task K runs shard K of " << tasks
    << " into shard-K beside this file.\n"
    << "set -eu\n"
    << "k=${SLURM_ARRAY_TASK_ID:?run me with sbatch --array}\n"
    << "out=" << sh_word(cluster.string()) << "/shard-$k\n"
    << "resume=\n"
    << "[ -f \"$out/sweep.json\" ] && resume=\"--resume" << (retry_failed ? " --retry-failed" : "")
    << "\"\n"
    << "exec " << sh_word(locsim.string()) << " sweep " << sh_word(experiment.string())
    << " --shard \"$k/" << tasks << "\" --jobs " << jobs << " --out \"$out\" $resume\n";
  return s.str();
}

SlurmSweepSummary sweep_on_slurm(const SlurmSweepOptions& options, const SweepPlan& plan,
                                 const std::atomic<bool>* interrupt) {
  const SweepOptions& sweep = options.sweep;
  const fs::path out = sweep.out_dir, cluster = out / "slurm", job_file = cluster / "job.json";
  const bool existing = fs::exists(job_file);
  // Held while this locsim submits and waits: a second one on the folder would submit its
  // shards twice.
  const FolderLock lock(cluster, "sweep", "--out");
  json job;
  int tasks = options.tasks;
  if (existing) {
    job = read_job_file(job_file);
    const int before = job["tasks"].get<int>();
    if (tasks != 0 && tasks != before) {
      throw InputError("--slurm: '" + out.string() + "' was submitted as " +
                       std::to_string(before) + " tasks; resume it with --slurm " +
                       std::to_string(before));
    }
    tasks = before;
    for (int k = 1; k <= tasks; ++k) {
      const fs::path shard = cluster / ("shard-" + std::to_string(k));
      if (!fs::exists(shard / "sweep.json")) continue;
      if (const std::string change =
              fingerprint_change(read_sweep_header(shard)["fingerprint"], plan.fingerprint);
          !change.empty()) {
        throw InputError("--resume: '" + shard.string() +
                         "' holds a sweep of other inputs, whose results cannot be joined with "
                         "new ones: " +
                         change);
      }
    }
  } else {
    if (tasks < 1) throw InputError("--slurm: give the number of array tasks (shards), 1 or more");
    if (static_cast<std::size_t>(tasks) > plan.runs) {
      throw InputError("--slurm " + std::to_string(tasks) + ": more tasks than the sweep's " +
                       std::to_string(plan.runs) + " runs; give at most " +
                       std::to_string(plan.runs));
    }
    job = {{"experiment", fs::absolute(sweep.experiment_file).lexically_normal().string()},
           {"tasks", tasks},
           {"submissions", json::array()}};
  }
  SlurmSweepSummary summary;
  summary.runs = plan.runs;
  const auto shard_dir = [&](int k) { return cluster / ("shard-" + std::to_string(k)); };

  // A job of this folder still queued (its locsim interrupted while waiting): waited for, not
  // submitted again beside itself.
  if (!job["submissions"].empty()) {
    const std::string last = job["submissions"].back()["job_id"].get<std::string>();
    if (!queued_tasks(last).empty()) {
      summary.job_id = last;
      if (!wait_for_job(last, options, interrupt)) {
        summary.interrupted = true;
        return summary;
      }
    }
  }

  std::vector<int> todo;
  for (int k = 1; k <= tasks; ++k) {
    const ShardState state = shard_state(shard_dir(k), plan.runs, k, tasks, sweep.retry_failed);
    if (state.standing < state.runs) todo.push_back(k);
  }
  if (!todo.empty()) {
    const fs::path binary = fs::absolute(
        sweep.locsim_binary.empty() ? fs::read_symlink("/proc/self/exe") : sweep.locsim_binary);
    const fs::path script = cluster / "job.sh";
    write_file(script, job_script(binary, fs::absolute(sweep.experiment_file).lexically_normal(),
                                  fs::absolute(cluster), tasks, sweep.jobs, sweep.retry_failed));
    fs::create_directories(cluster / "logs");
    std::vector<std::string> argv = {
        "sbatch",
        "--parsable",
        "--array=" + array_list(todo),
        "--job-name=locsim-" + plan.experiment,
        "--cpus-per-task=" + std::to_string(sweep.jobs),
        "--output=" + (fs::absolute(cluster) / "logs/%A_%a.log").string()};
    argv.insert(argv.end(), options.sbatch_options.begin(), options.sbatch_options.end());
    argv.push_back(script.string());
    const CommandOutput submitted = slurm_command(argv);
    // --parsable prints "ID" or "ID;CLUSTER".
    const std::string id = trimmed(submitted.out.substr(0, submitted.out.find(';')));
    if (submitted.exit_code != 0 || id.empty() ||
        !std::all_of(id.begin(), id.end(), [](unsigned char c) { return std::isdigit(c); })) {
      throw std::runtime_error("sbatch did not take the job (exit " +
                               std::to_string(submitted.exit_code) +
                               "): " + trimmed(submitted.err + submitted.out));
    }
    job["submissions"].push_back({{"job_id", id}, {"shards", todo}});
    write_json_atomically(job_file, job);
    if (options.progress) {
      options.progress("slurm job " + id + ": " + std::to_string(todo.size()) + " of " +
                       std::to_string(tasks) + " shards submitted (array " + array_list(todo) +
                       "), logs in " + (cluster / "logs").string());
    }
    summary.job_id = id;
    summary.submitted = todo.size();
    if (!wait_for_job(id, options, interrupt)) {
      summary.interrupted = true;
      return summary;
    }
  }

  std::vector<fs::path> parts;
  for (int k = 1; k <= tasks; ++k) {
    const ShardState state = shard_state(shard_dir(k), plan.runs, k, tasks, sweep.retry_failed);
    summary.with_result += state.results - state.errors;
    summary.errors += state.errors;
    if (state.results < state.runs) summary.unfinished.emplace_back(k, task_log(job, cluster, k));
    if (fs::exists(shard_dir(k) / "sweep.json")) parts.push_back(shard_dir(k));
  }
  if (!parts.empty()) merge_sweeps(out, parts, "slurm");
  return summary;
}

}  // namespace

SlurmSweepSummary run_sweep_on_slurm(const SlurmSweepOptions& options,
                                     const std::atomic<bool>* interrupt) {
  const SweepOptions& sweep = options.sweep;
  if (sweep.jobs < 1) throw InputError("--jobs: must be >= 1");
  if (sweep.shard) throw InputError("--shard: not with --slurm (each array task runs one shard)");
  if (sweep.retry_failed && !sweep.resume)
    throw InputError("--retry-failed: only with --resume (a new sweep runs every run)");
  // Before the folder is made or anything submitted: a bad plugin or parameter leaves nothing.
  const SweepPlan plan = plan_sweep(sweep.experiment_file);
  const fs::path out = sweep.out_dir;
  check_output_folder(out, "--out");
  const bool existing = fs::exists(out / "slurm/job.json");
  if (existing && !sweep.resume) {
    throw InputError("--out: '" + out.string() +
                     "' already holds a Slurm sweep; pass --resume to finish it, or choose "
                     "another folder");
  }
  if (!existing && holds_files(out))
    throw InputError("--out: folder '" + out.string() + "' is not empty");
  const bool made_out = !fs::exists(out);
  try {
    return sweep_on_slurm(options, plan, interrupt);
  } catch (...) {
    // Nothing submitted yet on a new sweep (sbatch refused it): the folder is left as it was, so
    // that the same command, corrected, can be run again.
    if (!existing) {
      std::error_code ignored;
      if (!fs::exists(out / "slurm/job.json")) {
        fs::remove_all(out / "slurm", ignored);
        if (made_out) fs::remove(out, ignored);
      }
    }
    throw;
  }
}

}  // namespace locsim
