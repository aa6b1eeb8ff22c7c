#include "sim/experiments/sweep.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstring>
#include <deque>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "sim/common/capped_text.hpp"
#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/common/parallel.hpp"
#include "sim/common/process_tree.hpp"
#include "sim/experiments/experiment.hpp"
#include "sim/experiments/statistics.hpp"
#include "sim/experiments/suite_tables.hpp"
#include "sim/experiments/sweep_lock.hpp"
#include "sim/plugin_host/localizer_instance.hpp"
#include "sim/plugin_host/plugin_library.hpp"
#include "sim/producers/simulation.hpp"
#include "sim/run/runner.hpp"

namespace locsim {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

namespace {

/// FNV-1a of a file's bytes: whether it is the same file as before. Streamed: a recorded log of
/// tens of MB costs a read of it, not its size in memory.
std::string content_hash(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError("cannot read '" + file.string() + "'");
  std::uint64_t hash = 0xcbf29ce484222325ULL;
  std::vector<char> chunk(1 << 16);
  while (in.read(chunk.data(), static_cast<std::streamsize>(chunk.size())) || in.gcount() > 0) {
    const auto* bytes = reinterpret_cast<const unsigned char*>(chunk.data());
    for (std::streamsize i = 0; i < in.gcount(); ++i) {
      hash ^= bytes[i];
      hash *= 0x100000001b3ULL;
    }
  }
  if (in.bad()) throw std::runtime_error("cannot read '" + file.string() + "'");
  char text[24];
  std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(hash));
  return text;
}

/// What the results of a sweep depend on, each input on its own so that a resume or merge can
/// say which changed: the locsim version, every file the experiment was read from (itself, the
/// world, its map's YAML and image, the scenario) and every plugin (`plugins`, from
/// check_localizers: its declared name, ABI version and its file's hash; not the file's path,
/// which differs between machines).
json input_fingerprint(const ExperimentDef& experiment, const json& plugins) {
  // Named relative to the experiment file's folder: the same on resume from another working
  // folder, and for shards run on other machines.
  const fs::path base = fs::absolute(experiment.files.front()).parent_path();
  json files = json::object();
  for (const fs::path& file : experiment.files) {
    const std::string name =
        fs::absolute(file).lexically_normal().lexically_relative(base).generic_string();
    files[name] = content_hash(file);
  }
  return {
      {"format", 2}, {"locsim_version", locsim_version()}, {"files", files}, {"plugins", plugins}};
}

}  // namespace

/// How fingerprint `now` differs from `before` ("" when it does not), input by input.
std::string fingerprint_change(const json& before, const json& now) {
  if (!before.is_object() || before.value("format", 0) != 2) {
    return "it was made by an older locsim, whose fingerprint covers the experiment file only "
           "(not the world, scenario, map or plugins), so it cannot be told whether its inputs "
           "changed; finish it with that locsim, or run the sweep again into a new folder";
  }
  std::vector<std::string> changes;
  const json version_before = before.value("locsim_version", json()),
             version_now = now.value("locsim_version", json());
  if (version_before != version_now) {
    changes.push_back("locsim version " + version_before.dump() + " -> " + version_now.dump());
  }
  for (const char* kind : {"files", "plugins"}) {
    const std::string what = std::string(kind) == "files" ? "file" : "plugin";
    const json was = before.value(kind, json::object()), is = now.value(kind, json::object());
    for (const auto& [name, value] : was.items()) {
      if (!is.contains(name)) {
        changes.push_back(what + " " + name + " is no longer used");
      } else if (is.at(name) != value) {
        changes.push_back(what + " " + name + " changed");
      }
    }
    for (const auto& [name, value] : is.items()) {
      if (!was.contains(name)) changes.push_back(what + " " + name + " is new");
    }
  }
  std::string out;
  for (const std::string& change : changes) out += (out.empty() ? "" : "; ") + change;
  return out;
}

namespace {

/// `text` from an input file for a message: quoted, control characters shown as '?', and cut
/// after `max_bytes` (at a UTF-8 boundary) saying how long it was: a line of megabytes is not
/// a message of megabytes.
std::string quoted_excerpt(std::string_view text, std::size_t max_bytes = 60) {
  std::size_t cut = std::min(text.size(), max_bytes);
  while (cut > 0 && cut < text.size() && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80)
    --cut;
  std::string out = "'";
  for (const char c : text.substr(0, cut))
    out += static_cast<unsigned char>(c) < 0x20 || c == 0x7f ? '?' : c;
  out += "'";
  if (cut < text.size()) out += "... (" + std::to_string(text.size()) + " bytes)";
  return out;
}

/// What nlohmann's parse error says, without its prefix and with the text it last read quoted and
/// cut ("syntax error while parsing value - invalid literal; last read: 'x'").
std::string json_problem(const json::parse_error& error) {
  std::string message = error.what();
  if (const std::size_t column = message.find("column "); column != std::string::npos) {
    if (const std::size_t colon = message.find(": ", column); colon != std::string::npos)
      message.erase(0, colon + 2);
  }
  const std::string last_read = "; last read: '";
  if (const std::size_t at = message.find(last_read); at != std::string::npos) {
    std::string read = message.substr(at + last_read.size());
    if (!read.empty() && read.back() == '\'') read.pop_back();
    message = message.substr(0, at) + "; last read: " + quoted_excerpt(read, 40);
  }
  return message;
}

/// A JSON file of a sweep folder, parsed. Throws InputError naming the file, and the line and
/// column where it is not JSON.
json read_json_file(const fs::path& file) {
  const std::string text = read_text(file);
  try {
    return json::parse(text);
  } catch (const json::parse_error& error) {
    // error.byte: 1-based, of the character it failed at.
    const std::size_t at = std::min<std::size_t>(error.byte > 0 ? error.byte - 1 : 0, text.size());
    const std::size_t line_start = text.rfind('\n', at == 0 ? 0 : at - 1);
    SourceLocation where{file.string()};
    where.line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + at, '\n'));
    where.column =
        static_cast<int>(line_start == std::string::npos || at == 0 ? at + 1 : at - line_start);
    throw InputError(where, "", "not valid JSON: " + json_problem(error));
  }
}

}  // namespace

/// A sweep folder's sweep.json, with the keys resume and merge rely on checked. Throws
/// InputError naming the file (its line, or the key) when it is not a sweep's.
json read_sweep_header(const fs::path& dir) {
  const fs::path file = dir / "sweep.json";
  const json header = read_json_file(file);
  const SourceLocation where{file.string()};
  if (!header.is_object())
    throw InputError(where, "", "not a JSON object: not a sweep's sweep.json");
  if (!header.contains("fingerprint")) throw InputError(where, "fingerprint", "missing");
  if (!header.contains("runs") || !header["runs"].is_number_unsigned())
    throw InputError(where, "runs", "missing, or not a whole number");
  const json shard = header.value("shard", json());
  if (!shard.is_null() && !(shard.is_array() && shard.size() == 2 &&
                            shard[0].is_number_unsigned() && shard[1].is_number_unsigned()))
    throw InputError(where, "shard", "expected null or [K, N]");
  return header;
}

namespace {

/// Every run's newest result in results.jsonl, in file order: a resume appends a retried run's
/// new result after its old one. Each result goes in one write of its whole line, so a sweep
/// killed while writing leaves at most its last line cut short, without its line break: that
/// line is dropped (its run has no result; --resume runs it again). Any other line that is not a
/// result is corruption: InputError naming the file and line (every later result would be lost).
std::vector<json> read_results(const fs::path& file) {
  std::vector<json> lines;
  if (!fs::exists(file)) return lines;
  const std::string text = read_text(file);
  int number = 0;
  for (std::size_t start = 0; start < text.size();) {
    const std::size_t end = std::min(text.find('\n', start), text.size());
    const std::string_view line = std::string_view(text).substr(start, end - start);
    const bool cut_short = end == text.size();  // the last line, without its line break
    start = end + 1;
    ++number;
    if (line.empty()) continue;
    const SourceLocation where{file.string(), number};
    json result;
    try {
      result = json::parse(line);
    } catch (const json::parse_error&) {
      if (cut_short) break;  // a write cut short by a kill
      throw InputError(where, "",
                       "not a run's result (not JSON: a line cut short or edited; only the last "
                       "line may be, by a sweep killed while writing it): " +
                           quoted_excerpt(line));
    }
    const auto problem = [&](const char* key, const char* expected) {
      return InputError(where, key,
                        "missing, or not " + std::string(expected) + ": " + quoted_excerpt(line) +
                            " is not a run's result");
    };
    if (!result.is_object())
      throw InputError(where, "",
                       "not a run's result (not a JSON object): " + quoted_excerpt(line));
    if (!result.contains("index") || !result["index"].is_number_unsigned())
      throw problem("index", "a whole number");
    if (!result.contains("seed") || !result["seed"].is_number_unsigned())
      throw problem("seed", "a whole number");
    for (const char* key : {"id", "config", "status"}) {
      if (!result.contains(key) || !result[key].is_string()) throw problem(key, "a string");
    }
    lines.push_back(std::move(result));
  }
  std::map<std::size_t, std::size_t> newest;  // run index -> its last line
  for (std::size_t i = 0; i < lines.size(); ++i) newest[lines[i]["index"].get<std::size_t>()] = i;
  std::vector<json> out;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (newest[lines[i]["index"].get<std::size_t>()] == i) out.push_back(std::move(lines[i]));
  }
  return out;
}

/// A result as one line of results.jsonl. Invalid UTF-8 (a plugin's output in a reason) is
/// replaced rather than thrown on.
std::string jsonl_line(const json& result) {
  return result.dump(-1, ' ', false, json::error_handler_t::replace) + '\n';
}

/// Writes `results` as the whole of `file`, atomically: a kill leaves the old file or the new one.
void rewrite_results(const fs::path& file, const std::vector<json>& results) {
  std::string text;
  for (const json& r : results) text += jsonl_line(r);
  write_file(file, text);
}

}  // namespace

/// Whether a result stands on --resume. ok, and failed (the localizer's own failure: replaying
/// the same log gives it again) do; error (locsim could not produce a result), crashed and
/// timeout (may be the machine's doing) are worth running again.
bool result_stands(const json& result, bool retry_failed) {
  const std::string status = result.value("status", "");
  return status == "ok" || (status == "failed" && !retry_failed);
}

namespace {

constexpr std::size_t kMaxReasonBytes = 4096;
// A run's log.txt keeps this much of what its process printed first and last.
constexpr std::size_t kLogHeadBytes = 2 << 20, kLogTailBytes = 256 << 10;

/// What a process that could not produce a result said: its log from the first `locsim: ` line
/// on (the error, with a message's continuation lines, e.g. where a plugin was looked for),
/// or the whole log when it has none (the loader's or the shell's words). Capped: a plugin may
/// print without end.
std::string error_output(const fs::path& log) {
  const std::string text = fs::exists(log) ? read_text(log) : std::string();
  std::size_t start = 0;
  if (!text.starts_with("locsim: ")) {
    const std::size_t at = text.find("\nlocsim: ");
    start = at == std::string::npos ? text.find_first_not_of(" \t\r\n") : at + 1;
  }
  const std::size_t end = text.find_last_not_of(" \t\r\n");
  if (start == std::string::npos || end == std::string::npos) {
    return "no output (" + log.filename().string() + " is empty)";
  }
  std::string out = text.substr(start, end + 1 - start);
  if (out.size() > kMaxReasonBytes) {
    std::size_t cut = kMaxReasonBytes;
    while (cut > 0 && (static_cast<unsigned char>(out[cut]) & 0xC0) == 0x80) --cut;  // UTF-8
    const std::size_t left = out.size() - cut;
    out = out.substr(0, cut) + "\n[" + std::to_string(left) + " more bytes cut; all in " +
          log.filename().string() + "]";
  }
  return out;
}

/// Whether a run's process completed: its metrics.json holds the result (exit 5: completed, but
/// the localizer failed, crash, timeout, NaN or error, and metrics.json says which and why).
bool completed(int wait_status) {
  return WIFEXITED(wait_status) &&
         (WEXITSTATUS(wait_status) == 0 || WEXITSTATUS(wait_status) == kExitLocalizerFailed);
}

/// The result of a finished run, from its exit and its metrics.json. `log` is the process's
/// log.txt, relative to the sweep folder.
json result_of(const RunUnit& run, const fs::path& out, const fs::path& log, int wait_status,
               bool timed_out, double wall_s) {
  const fs::path run_dir = (out / log).parent_path();
  json r;
  r["index"] = run.index;
  r["id"] = run.id;
  r["config"] = run.config->label;
  r["plugin"] = run.config->plugin;
  json params = json::object();
  for (const auto& [k, v] : run.config->params) params[k] = v;
  r["params"] = params;
  if (run.log != nullptr) r["source_log"] = run.log->stem;  // the recorded log it replayed
  if (run.world != nullptr && !run.world->stem.empty()) {   // one of the experiment's worlds
    r["world"] = run.world->stem;
    r["family"] = run.world->family;
    // Only when held back: the results of an experiment without such worlds are as they were.
    if (run.world->held_back) r["held_back"] = true;
  }
  r["seed"] = run.seed;
  r["log"] = log.generic_string();
  json metrics;
  if (timed_out) {
    r["status"] = "timeout";
    r["reason"] = "killed after the experiment's timeout_s";
  } else if (WIFSIGNALED(wait_status)) {
    const int signal = WTERMSIG(wait_status);
    r["status"] = "crashed";
    r["reason"] = "signal " + std::to_string(signal) + " (" + strsignal(signal) + ")";
  } else if (!completed(wait_status)) {
    r["status"] = "error";
    r["reason"] =
        "exit code " + std::to_string(WEXITSTATUS(wait_status)) + ": " + error_output(out / log);
  } else {
    try {
      const json file = json::parse(read_text(run_dir / "metrics.json"));
      metrics = file["localizers"].at(0);
      r["status"] = metrics["status"] == "ok" ? "ok" : "failed";
      std::string reason;
      if (const auto failure = metrics.find("failure"); failure != metrics.end()) {
        // "CALL at t = T s: MESSAGE", with whichever of its parts metrics.json gives.
        const std::string call = failure->value("call", "");
        const json t_s = failure->value("t_s", json());
        reason = call + (t_s.is_number() ? " at t = " + fixed(t_s.get<double>(), 3) + " s" : "");
        const std::string message = failure->value("message", "");
        reason += (reason.empty() || message.empty() ? "" : ": ") + message;
      }
      r["reason"] = reason;
      // Costs are null for a localizer whose process was lost before it could report them.
      const json cost = file["timing"].at(run.config->label).value("cost_per_update_us", json());
      r["timing"] = {{"wall_s", wall_s},
                     {"cost_mean_us", cost.is_object() ? cost["mean"] : json()},
                     {"cost_p99_us", cost.is_object() ? cost["p99"] : json()}};
    } catch (const std::exception& e) {
      r["status"] = "error";
      r["reason"] = std::string("no readable metrics.json: ") + e.what();
    }
  }
  if (!r.contains("timing")) r["timing"] = {{"wall_s", wall_s}};
  if (!metrics.is_null()) {
    metrics.erase("label");
    metrics.erase("plugin");
    metrics.erase("params");
    metrics.erase("status");
    metrics.erase("failure");
    r["metrics"] = metrics;
  }
  // Keep "timing" last: everything before it is deterministic.
  json t = r["timing"];
  r.erase("timing");
  r["timing"] = t;
  return r;
}

/// segments.csv: one row per run and segment between kidnaps (segment 0 runs from the start to
/// the first kidnap), with the scorer's per-segment figures as columns: what a researcher
/// compares before and after a kidnap, tidy (docs/experiments.md).
std::string segments_csv(const std::vector<json>& results) {
  std::ostringstream csv;
  csv << "index,id,config,seed,world,segment,from_s,to_s,samples,carried_m,turned_deg,"
         "recoverable,recovery_s,recovery_steps,position_rms_m,heading_rms_deg,"
         "tracking_position_rms_m,nees_mean,nees_median,inside_95_ellipse,"
         "tracking_inside_95_ellipse,jumps\n";
  for (const json& r : results) {
    const json m = r.value("metrics", json::object());
    const json segments = m.is_object() ? m.value("segments", json::array()) : json::array();
    for (std::size_t k = 0; k < segments.size(); ++k) {
      const json& s = segments[k];
      const json consistency = s.value("consistency", json());
      const auto from_consistency = [&](const char* key) {
        return consistency.is_object() ? csv_number(consistency.value(key, json()), 4)
                                       : std::string();
      };
      const json recoverable = s.value("recoverable", json());
      const json steps = s.value("recovery_steps", json());
      csv << r["index"].get<std::size_t>() << ',' << csv_field(r["id"]) << ','
          << csv_field(r["config"]) << ',' << r["seed"].get<std::uint64_t>() << ','
          << csv_field(r.value("world", "")) << ',' << k << ','
          << csv_number(s.value("from_s", json()), 4) << ','
          << csv_number(s.value("to_s", json()), 4) << ',' << s.value("samples", std::size_t{0})
          << ',' << csv_number(s.value("carried_m", json())) << ','
          << csv_number(s.value("turned_deg", json()), 4) << ','
          << (recoverable.is_boolean() ? (recoverable.get<bool>() ? "true" : "false") : "") << ','
          << csv_number(s.value("recovery_s", json()), 4) << ','
          << (steps.is_number() ? std::to_string(steps.get<long>()) : std::string()) << ','
          << csv_number(s.value("position_error_m", json::object()).value("rms", json())) << ','
          << csv_number(s.value("heading_error_deg", json::object()).value("rms", json()), 4) << ','
          << csv_number(s.value("tracking", json::object()).value("position_rms_m", json())) << ','
          << from_consistency("nees_mean") << ',' << from_consistency("nees_median") << ','
          << from_consistency("inside_95_ellipse") << ','
          << csv_number(s.value("tracking", json::object()).value("inside_95_ellipse", json()), 4)
          << ',' << csv_number(s.value("jumps", json::object()).value("count", json()), 0) << '\n';
    }
  }
  return csv.str();
}

}  // namespace

std::vector<json> read_sweep_results(const fs::path& out_dir) {
  std::vector<json> results = read_results(out_dir / "results.jsonl");
  std::sort(results.begin(), results.end(), [](const json& a, const json& b) {
    return a["index"].get<std::size_t>() < b["index"].get<std::size_t>();
  });
  return results;
}

void write_tables(const fs::path& out_dir) {
  std::vector<json> results = read_sweep_results(out_dir);
  // Each table whole or not at all (write_file): a full disk leaves no table cut mid-row.
  {
    std::ostringstream csv;
    csv << "index,id,config,log,seed,status,reason,position_rms_m,position_mean_m,position_max_m,"
           "x_rms_m,y_rms_m,heading_rms_deg,heading_mean_deg,heading_max_deg,converged_s,"
           "converged_steps,time_lost_s,recovery_s,recovery_steps,landmark_error_m,nees_mean,"
           "nees_median,inside_95_ellipse,world,family,kidnaps,kidnaps_recoverable,"
           "kidnaps_recovered,"
           "tracking_position_rms_m,first_segment_position_rms_m,first_segment_nees_median,"
           "first_segment_inside_95_ellipse,tracking_inside_95_ellipse,jumps,held_back\n";
    for (const json& r : results) {
      const json m = r.value("metrics", json::object());
      std::string recoveries, recovery_steps;  // one per kidnap: the segments after the first
      const json segments = m.value("segments", json::array());
      for (std::size_t k = 1; k < segments.size(); ++k) {
        const bool never = segments[k]["recovery_s"].is_null();
        recoveries += (k == 1 ? "" : ";") +
                      (never ? std::string("never") : csv_number(segments[k]["recovery_s"], 4));
        recovery_steps +=
            (k == 1 ? "" : ";") +
            (never ? std::string("never")
                   : std::to_string(segments[k].value("recovery_steps", json(0)).get<long>()));
      }
      const json p = m.value("position_error_m", json::object());
      const json h = m.value("heading_error_deg", json::object());
      const json c = m.value("convergence", json::object());
      // SLAM filters only: the RMS distance of their mapped landmarks to the true ones matched.
      const json landmark_error =
          m.value("landmark_map", json::object()).value("error_m", json::object());
      // Empty when the localizer gave no positive definite covariance (metrics.json: null).
      const json consistency = m.value("consistency", json());
      const json nees =
          consistency.is_object() ? consistency.value("nees_mean", json()) : json(nullptr);
      const json nees_median =
          consistency.is_object() ? consistency.value("nees_median", json()) : json(nullptr);
      const json inside =
          consistency.is_object() ? consistency.value("inside_95_ellipse", json()) : json(nullptr);
      csv << r["index"].get<std::size_t>() << ',' << csv_field(r["id"]) << ','
          << csv_field(r["config"]) << ',' << csv_field(r.value("source_log", "")) << ','
          << r["seed"].get<std::uint64_t>() << ',' << r["status"].get<std::string>() << ','
          << csv_field(r.value("reason", "")) << ',' << csv_number(p.value("rms", json())) << ','
          << csv_number(p.value("mean", json())) << ',' << csv_number(p.value("max", json())) << ','
          << csv_number(p.value("rms_x", json())) << ',' << csv_number(p.value("rms_y", json()))
          << ',' << csv_number(h.value("rms", json())) << ',' << csv_number(h.value("mean", json()))
          << ',' << csv_number(h.value("max", json())) << ','
          << csv_number(c.value("time_s", json()), 4) << ','
          << (c.value("steps", json()).is_number() ? std::to_string(c["steps"].get<long>())
                                                   : std::string())
          << ',' << csv_number(m.value("time_lost_s", json()), 4) << ',' << recoveries << ','
          << recovery_steps << ',' << csv_number(landmark_error.value("rms", json())) << ','
          << csv_number(nees, 4) << ',' << csv_number(nees_median, 4) << ','
          << csv_number(inside, 4) << ',';
      const RunRecovery recovery = recovery_of(m);
      const std::optional<double> tracking = recovery.tracking_rms_m();
      const std::optional<double> tracking_inside = recovery.tracking_inside_95();
      csv << csv_field(r.value("world", "")) << ',' << csv_field(r.value("family", "")) << ','
          << (m.is_object() && !m.empty()
                  ? std::to_string(recovery.kidnaps) + ',' + std::to_string(recovery.recoverable) +
                        ',' + std::to_string(recovery.recovered)
                  : std::string(",,"))
          << ',' << (tracking ? fixed(*tracking, 6) : std::string());
      // Before the first kidnap (the whole run without one): where a tracker is judged; a
      // filter lost after a kidnap has a whole-run NEES that says only that (segments.csv).
      const json first = segments.empty() ? json::object() : segments[0];
      const json first_consistency = first.value("consistency", json());
      csv << ',' << csv_number(first.value("position_error_m", json::object()).value("rms", json()))
          << ','
          << (first_consistency.is_object()
                  ? csv_number(first_consistency.value("nees_median", json()), 4) + ',' +
                        csv_number(first_consistency.value("inside_95_ellipse", json()), 4)
                  : std::string(","))
          << ',' << (tracking_inside ? fixed(*tracking_inside, 4) : std::string()) << ','
          << (m.is_object() && !m.empty() ? std::to_string(recovery.jumps) : std::string()) << ','
          << (r.value("held_back", false) ? "true" : "false") << '\n';
    }
    write_file(out_dir / "results.csv", csv.str());
  }
  write_file(out_dir / "segments.csv", segments_csv(results));
  // Per configuration: success and the metrics over seeds (mean +- 95 % CI, median).
  std::vector<std::string> order;
  std::map<std::string, std::vector<const json*>> by_config;
  for (const json& r : results) {
    const std::string config = r["config"];
    if (!by_config.count(config)) order.push_back(config);
    by_config[config].push_back(&r);
  }
  std::ostringstream csv, md;
  csv << "config,runs,ok,converged,recovered_every_kidnap,first_segment_position_rms_m_mean,"
         "first_segment_position_rms_m_ci95,position_rms_m_mean,position_rms_m_ci95,position_rms_m_"
         "median,heading_rms_deg_mean,heading_rms_deg_ci95,heading_rms_deg_median,"
         "converged_s_mean,converged_s_ci95,converged_s_median,inside_95_ellipse_mean,"
         "inside_95_ellipse_ci95,nees_median,first_segment_inside_95_ellipse_mean,"
         "first_segment_inside_95_ellipse_ci95,first_segment_nees_median,kidnaps_recoverable,"
         "kidnaps_recovered\n";
  md << "Figures: mean ± 95 % confidence interval over the runs that finished (ok); median after "
        "';'.\n\n"
        "'Recovered every kidnap' counts the runs that recovered from every kidnap their "
        "sensors made recoverable (a kidnap too short, or that moved the robot within the "
        "convergence criterion, tests nothing); the truth in the 95 % ellipse and the median "
        "NEES are before the first kidnap, where a tracker is judged (after a kidnap a lost "
        "filter's NEES says only that it is lost; segments.csv has each segment's).\n\n"
        "| config | runs | ok | converged | recovered every kidnap | position RMS before the first "
        "kidnap [m] "
        "| position RMS [m] | heading RMS [deg] | convergence [s] | truth in the 95 % ellipse "
        "(0.95: honest) | median NEES (2.37: honest) |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const std::string& config : order) {
    std::vector<double> position, heading, converged, first_segment, inside, nees, first_inside,
        first_nees;
    std::size_t ok = 0, recovered_all = 0, recoverable = 0, recovered = 0;
    for (const json* r : by_config[config]) {
      if ((*r)["status"] != "ok") continue;
      ++ok;
      const json& m = (*r)["metrics"];
      position.push_back(m["position_error_m"]["rms"]);
      if (!m["segments"].empty()) {
        const json& first = m["segments"][0];
        first_segment.push_back(first["position_error_m"]["rms"]);
        if (const json c = first.value("consistency", json()); c.is_object()) {
          first_inside.push_back(c["inside_95_ellipse"]);
          first_nees.push_back(c["nees_median"]);
        }
      }
      heading.push_back(m["heading_error_deg"]["rms"]);
      if (!m["convergence"]["time_s"].is_null()) converged.push_back(m["convergence"]["time_s"]);
      if (const json c = m.value("consistency", json()); c.is_object()) {
        inside.push_back(c["inside_95_ellipse"]);
        nees.push_back(c["nees_median"]);
      }
      const RunRecovery recovery = recovery_of(m);
      recoverable += recovery.recoverable;
      recovered += recovery.recovered;
      recovered_all += recovery.recovered == recovery.recoverable ? 1 : 0;
    }
    const Aggregate p = aggregate(position), h = aggregate(heading), c = aggregate(converged),
                    f = aggregate(first_segment), in = aggregate(inside), ne = aggregate(nees),
                    fin = aggregate(first_inside), fne = aggregate(first_nees);
    const std::size_t runs = by_config[config].size();
    csv << csv_field(config) << ',' << runs << ',' << ok << ',' << c.n << ',' << recovered_all
        << ',' << fixed(f.mean, 6) << ',' << fixed(f.ci95, 6) << ',' << fixed(p.mean, 6) << ','
        << fixed(p.ci95, 6) << ',' << fixed(p.median, 6) << ',' << fixed(h.mean, 4) << ','
        << fixed(h.ci95, 4) << ',' << fixed(h.median, 4) << ',' << fixed(c.mean, 4) << ','
        << fixed(c.ci95, 4) << ',' << fixed(c.median, 4) << ','
        << (in.n > 0 ? fixed(in.mean, 4) + ',' + fixed(in.ci95, 4) + ',' + fixed(ne.median, 4)
                     : std::string(",,"))
        << ','
        << (fin.n > 0 ? fixed(fin.mean, 4) + ',' + fixed(fin.ci95, 4) + ',' + fixed(fne.median, 4)
                      : std::string(",,"))
        << ',' << recoverable << ',' << recovered << '\n';
    md << "| " << config << " | " << runs << " | " << ok << " | " << c.n << " | " << recovered_all
       << (recoverable > 0 ? " (" + std::to_string(recovered) + " of " +
                                 std::to_string(recoverable) + " kidnaps)"
                           : std::string())
       << " | " << fixed(f.mean, 3) << " ± " << fixed(f.ci95, 3) << " | " << fixed(p.mean, 3)
       << " ± " << fixed(p.ci95, 3) << "; " << fixed(p.median, 3) << " | " << fixed(h.mean, 2)
       << " ± " << fixed(h.ci95, 2) << "; " << fixed(h.median, 2) << " | "
       << (c.n > 0 ? fixed(c.mean, 2) + " ± " + fixed(c.ci95, 2) + "; " + fixed(c.median, 2)
                   : std::string("—"))
       << " | " << (fin.n > 0 ? fixed(fin.mean, 2) + " ± " + fixed(fin.ci95, 2) : std::string("—"))
       << " | " << (fne.n > 0 ? fixed(fne.median, 1) : std::string("—")) << " |\n";
  }
  write_family_tables(out_dir, results, order, md);
  write_part_tables(out_dir, results, order, md);
  write_file(out_dir / "summary.csv", csv.str());
  write_file(out_dir / "summary.md", md.str());
}

namespace {

/// Finds and loads every configuration's plugin (each file once) and checks its parameters, with
/// its params file, exactly as `locsim run` does (parse_localizer_spec, find_plugin,
/// PluginLibrary, load_param_file, ParamSet), so that a misspelt plugin or parameter fails the
/// sweep at once, with run's own message prefixed by where the experiment file gives it (a
/// problem in a params file: where that file has it), rather than every run of it after the
/// simulation.
/// Creating the filters needs the world's simulation; a plugin whose create call fails is still
/// found by its runs.
json check_localizers(const ExperimentDef& experiment) {
  json stamps = json::object();  // by plugin, as the experiment names it: for the fingerprint
  const auto at = [](const InputPlace& place, const std::string& message) {
    return place.where.str() + ": '" + place.key + "': " + message;
  };
  PluginCache libraries;
  std::map<std::string, std::shared_ptr<const ParamFile>> files;  // by path
  // Each params file, in the order of first use, with the plugins given it.
  std::vector<std::pair<const ParamFile*, std::vector<const locsim_localizer*>>> users;
  for (const LocalizerConfig& config : experiment.localizers) {
    LocalizerSpec spec;
    try {
      spec = parse_localizer_spec(config.spec());
    } catch (const InputError& e) {
      throw InputError(at(config.plugin_place, e.what()));
    }
    if (spec.params != config.params) {
      // A value holding ',' reads as more than one parameter on replay's command line.
      throw InputError(at(config.plugin_place,
                          "a parameter value of configuration '" + config.label + "' holds a ','"));
    }
    std::shared_ptr<const PluginLibrary> library;
    try {
      library = libraries.load(spec.plugin, spec.source);
      // A script's fingerprint is its own and its loader's: either edited, the results differ.
      json stamp = {{"name", library->table().name},
                    {"abi_version", library->table().abi_version},
                    {"hash", content_hash(library->path())}};
      if (!library->source().empty()) stamp["source_hash"] = content_hash(library->source());
      stamps[spec.source.empty() ? spec.plugin : spec.plugin + ":" + spec.source] = stamp;
      const ParamSet params(library->table(), spec);
    } catch (const PluginError& e) {
      throw PluginError(at(config.plugin_place, e.what()));
    } catch (const InputError& e) {
      // ParamSet checks each parameter on its own: the one that fails alone is the one to name.
      InputPlace place = config.plugin_place;
      for (std::size_t i = 0; i < spec.params.size(); ++i) {
        LocalizerSpec alone = spec;
        alone.params = {spec.params[i]};
        try {
          const ParamSet single(library->table(), alone);
        } catch (const std::exception& single_error) {
          if (std::string(single_error.what()) == e.what()) {
            place = config.param_places.at(i);
            break;
          }
        }
      }
      throw InputError(at(place, e.what()));
    }
    if (config.params_file) {
      // As `replay --params` reads it; a problem in the file is named where the file has it.
      auto& file = files[config.params_file->string()];
      if (!file) {
        file = std::make_shared<const ParamFile>(load_param_file(*config.params_file));
        users.emplace_back(file.get(), std::vector<const locsim_localizer*>{});
      }
      spec.params_file = file;
      const ParamSet params(library->table(), spec);
      std::find_if(users.begin(), users.end(), [&](const auto& u) {
        return u.first == file.get();
      })->second.push_back(&library->table());
    }
  }
  // Once for the sweep (each run's log.txt has them again, for its one localizer).
  for (const auto& [file, tables] : users) {
    for (const std::string& warning : param_file_warnings(*file, tables))
      std::fprintf(stderr, "locsim sweep: warning: %s\n", warning.c_str());
  }
  return stamps;
}

}  // namespace

SweepPlan plan_sweep(const fs::path& experiment_file) {
  const ExperimentDef experiment = load_experiment(experiment_file);
  const json plugins = check_localizers(experiment);
  return {experiment.name, expand_runs(experiment).size(), input_fingerprint(experiment, plugins)};
}

SweepSummary run_sweep(const SweepOptions& options, const std::atomic<bool>* interrupt) {
  const ExperimentDef experiment = load_experiment(options.experiment_file);
  if (options.jobs < 1) throw InputError("--jobs: must be >= 1");
  if (options.shard && (options.shard->second < 1 || options.shard->first < 1 ||
                        options.shard->first > options.shard->second)) {
    throw InputError("--shard: expected K/N with 1 <= K <= N");
  }
  if (options.retry_failed && !options.resume) {
    throw InputError("--retry-failed: only with --resume (a new sweep runs every run)");
  }
  // Before the folder is made or touched: a bad plugin or parameter leaves nothing behind.
  const json plugins = check_localizers(experiment);
  const std::vector<RunUnit> all = expand_runs(experiment);
  std::vector<const RunUnit*> mine;
  for (const RunUnit& run : all) {
    if (!options.shard ||
        static_cast<int>(run.index % static_cast<std::size_t>(options.shard->second)) ==
            options.shard->first - 1) {
      mine.push_back(&run);
    }
  }

  const fs::path out = options.out_dir;
  const json header = {
      {"experiment", experiment.name},
      {"file", options.experiment_file.string()},
      {"fingerprint", input_fingerprint(experiment, plugins)},
      {"runs", all.size()},
      {"shard",
       options.shard ? json::array({options.shard->first, options.shard->second}) : json(nullptr)}};
  std::set<std::string> done, retry;  // runs whose result stands; runs to run again
  check_output_folder(out, "--out");
  // A folder of other files is refused before anything is written into it, the lock file too.
  if (!fs::exists(out / "sweep.json") && holds_files(out))
    throw InputError("--out: folder '" + out.string() + "' is not empty");
  // Held until the sweep ends: a second sweep or --resume into the folder is refused at once.
  const FolderLock lock(out, "sweep", "--out");
  if (fs::exists(out / "sweep.json")) {
    if (!options.resume) {
      throw InputError(
          "--out: '" + out.string() +
          "' already holds a sweep; pass --resume to finish it, or choose another folder");
    }
    const json previous = read_sweep_header(out);
    if (const std::string change =
            fingerprint_change(previous["fingerprint"], header["fingerprint"]);
        !change.empty()) {
      throw InputError("--resume: '" + out.string() +
                       "' holds a sweep of other inputs, whose results cannot be joined with new "
                       "ones: " +
                       change);
    }
    if (previous.value("shard", json()) != header["shard"]) {
      throw InputError("--resume: '" + out.string() + "' holds another shard of this sweep");
    }
    const std::vector<json> results = read_results(out / "results.jsonl");
    // One line per run and no torn last line before appending. A retried run's old result stays
    // until its new one is appended: a resume killed before then retries it again.
    rewrite_results(out / "results.jsonl", results);
    for (const json& r : results) {
      (result_stands(r, options.retry_failed) ? done : retry).insert(r["id"].get<std::string>());
    }
  } else {
    // Again, under the lock: another sweep may have written into it since.
    if (holds_files(out)) throw InputError("--out: folder '" + out.string() + "' is not empty");
    write_json_atomically(out / "sweep.json", header);
  }

  SweepSummary summary;
  summary.total = mine.size();
  std::vector<const RunUnit*> pending;
  for (const RunUnit* run : mine) {
    if (done.count(run->id)) {
      ++summary.skipped;
    } else {
      summary.retried += retry.count(run->id);
      pending.push_back(run);
    }
  }
  const fs::path binary =
      options.locsim_binary.empty() ? fs::read_symlink("/proc/self/exe") : options.locsim_binary;
  const int results_fd =
      ::open((out / "results.jsonl").c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  if (results_fd < 0) throw std::runtime_error("cannot write " + (out / "results.jsonl").string());

  const auto sweep_start = std::chrono::steady_clock::now();
  const auto report = [&](const RunUnit& run, const json& result) {
    const std::size_t finished = summary.skipped + summary.ran;
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - sweep_start).count();
    const double left = summary.ran > 0 ? elapsed / static_cast<double>(summary.ran) *
                                              static_cast<double>(summary.total - finished)
                                        : 0.0;
    if (options.progress_bar) {
      const int width = 30;
      const int filled =
          static_cast<int>(width * finished / std::max<std::size_t>(summary.total, 1));
      std::fprintf(stderr, "\r  [%s%s] %zu/%zu runs, %zu not ok, %.0f s left   ",
                   std::string(static_cast<std::size_t>(filled), '#').c_str(),
                   std::string(static_cast<std::size_t>(width - filled), '.').c_str(), finished,
                   summary.total, summary.not_ok, left);
    } else if (options.progress_lines) {
      // A glance at the reason (its first line, 200 bytes at most): the rest is in results.csv
      // and the run's log.
      const std::string reason = result.value("reason", "");
      std::string glance = reason.substr(0, std::min<std::size_t>(reason.find('\n'), 200));
      if (glance.size() < reason.size()) glance += " [...]";
      std::fprintf(stderr, "[%zu/%zu] %s %s%s%s (%.0f s left)\n", finished, summary.total,
                   result["status"].get<std::string>().c_str(), run.id.c_str(),
                   reason.empty() ? "" : ": ", glance.c_str(), left);
    }
  };
  const auto append_result = [&](const RunUnit& run, const json& result) {
    const std::string line = jsonl_line(result);
    // One write per line, flushed to the disk: a kill loses at most the runs in flight.
    if (::write(results_fd, line.data(), line.size()) != static_cast<ssize_t>(line.size())) {
      throw std::runtime_error("cannot append to results.jsonl");
    }
    fsync(results_fd);
    ++summary.ran;
    if (result["status"] != "ok") ++summary.not_ok;
    if (result["status"] == "error") ++summary.errors;
    report(run, result);
  };

  // Phase 1: simulate each seed once, recording its log. Phase 2: replay the log to every
  // localizer configuration, each in its own process. Both phases share one pool of processes.
  struct Task {
    std::vector<std::string> args;
    fs::path log;
    std::string recording;  // of a world's seed, "[WORLDSTEM/]seed-N"; empty: a replay
    const RunUnit* run = nullptr;
  };
  struct Active {
    Task task;
    std::chrono::steady_clock::time_point start;
    bool timed_out = false;
    int output_fd = -1;  // the read end of the pipe its stdout and stderr go to
    CappedText output{kLogHeadBytes, kLogTailBytes};
  };
  // What a process printed goes to its log.txt when it ends, capped: a plugin that prints without
  // end costs neither the disk nor the memory. Written at the end (not as it comes) because the
  // run empties its folder first.
  const auto drain = [](Active& a) {
    char chunk[1 << 16];
    while (a.output_fd >= 0) {
      const ssize_t n = ::read(a.output_fd, chunk, sizeof(chunk));
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
      if (n <= 0) {
        ::close(a.output_fd);
        a.output_fd = -1;
        return;
      }
      a.output.add(std::string_view(chunk, static_cast<std::size_t>(n)));
    }
  };
  std::map<pid_t, Active> active;
  std::deque<Task> queue;
  // A world's seed is simulated once, recorded as logs/[WORLDSTEM/]seed-N.locsimlog, with its
  // run's files in the folder of that name.
  const auto recording_of = [](const RunUnit& run) {
    return (run.world->stem.empty() ? "" : run.world->stem + "/") + "seed-" +
           std::to_string(run.seed);
  };
  const auto log_of = [&](const std::string& recording) {
    return out / "logs" / (recording + ".locsimlog");
  };
  const auto recording_dir = [&](const std::string& recording) { return out / "logs" / recording; };
  const auto run_dir_of = [&](const RunUnit& run) { return out / "runs" / run.id; };
  const auto recorded = [&](const std::string& recording) {
    try {
      return fs::exists(log_of(recording)) &&
             json::parse(read_text(recording_dir(recording) / "run.json"))["status"] == "completed";
    } catch (const std::exception&) {
      return false;
    }
  };
  std::map<std::string, std::vector<const RunUnit*>> waiting;  // runs whose log is being recorded
  const auto replay_task = [&](const RunUnit& run) {
    Task task;
    task.run = &run;
    task.log = run_dir_of(run) / "log.txt";
    task.args = {binary.string(), "replay",
                 run.log != nullptr ? run.log->file.string() : log_of(recording_of(run)).string(),
                 "--localizer", run.config->spec(), "--out", run_dir_of(run).string(),
                 // The seed's recording folder has the readings already; a recorded log is
                 // its own readings (`locsim replay` of it writes them as CSV).
                 "--no-readings", "--converged-within-m",
                 fixed(experiment.convergence.position_m, 9), "--converged-within-deg",
                 fixed(rad_to_deg(experiment.convergence.heading_rad), 9), "--converged-hold",
                 std::to_string(experiment.convergence.hold_samples)};
    if (run.config->params_file)
      task.args.insert(task.args.end(), {"--params", run.config->params_file->string()});
    // A simulated seed's log was recorded with that seed; a recorded log gets the run's.
    if (run.log != nullptr) task.args.insert(task.args.end(), {"--seed", std::to_string(run.seed)});
    if (run.log != nullptr && !run.log->robot.empty())
      task.args.insert(task.args.end(), {"--robots", run.log->robot});
    return task;
  };
  // The jobs share the cores: each recording gets its share for its robots' sensors (what it
  // writes does not depend on it).
  const int run_threads = std::max(1, default_thread_count() / options.jobs);
  for (const RunUnit* run : pending) {
    if (run->log != nullptr) {
      queue.push_back(replay_task(*run));
      continue;
    }
    const std::string recording = recording_of(*run);
    if (recorded(recording)) {
      queue.push_back(replay_task(*run));
      continue;
    }
    if (!waiting.count(recording)) {
      Task task;
      task.recording = recording;
      task.log = recording_dir(recording) / "log.txt";
      task.args = {binary.string(),
                   "run",
                   run->world->file.string(),
                   "--seed",
                   std::to_string(run->seed),
                   "--out",
                   recording_dir(recording).string(),
                   "-q",
                   "--threads",
                   std::to_string(run_threads),
                   "--log",
                   log_of(recording).string()};
      if (experiment.scenario)
        task.args.insert(task.args.end(), {"--scenario", experiment.scenario->string()});
      if (experiment.duration_s)
        task.args.insert(task.args.end(), {"--duration", fixed(*experiment.duration_s, 9)});
      if (experiment.no_variation) task.args.push_back("--no-variation");
      // Recordings first: the replays of a seed wait for its log.
      queue.push_front(task);
    }
    waiting[recording].push_back(run);
  }

  // Wake the moment a child ends (SIGCHLD, blocked and waited for) rather than polling: with
  // short runs, a poll interval shows up directly in the parallel efficiency.
  sigset_t child_signal, previous_mask;
  sigemptyset(&child_signal);
  sigaddset(&child_signal, SIGCHLD);
  sigprocmask(SIG_BLOCK, &child_signal, &previous_mask);
  // SIGCHLD, blocked but for the wait in ppoll, interrupts it: a handler that does nothing (the
  // default disposition would discard the signal without waking anyone).
  struct sigaction wake_on_child {
  }, previous_child_action{};
  wake_on_child.sa_handler = [](int) {};
  sigemptyset(&wake_on_child.sa_mask);
  sigaction(SIGCHLD, &wake_on_child, &previous_child_action);
  sigset_t wait_mask = previous_mask;
  sigdelset(&wait_mask, SIGCHLD);
  // Whatever a run leaves behind is the sweep's to end: as the subreaper of its runs' trees it
  // gets every process whose run (or the run's keeper of a localizer, see
  // plugin_host/worker_process) died, however the run ended (a timeout's SIGKILL, a crash) and
  // whatever the process did (setsid too), and ends them when the run is reaped. Any child that
  // is not a run in flight is such a process: the sweep starts nothing else meanwhile.
  int was_subreaper = 0;
  prctl(PR_GET_CHILD_SUBREAPER, &was_subreaper);
  prctl(PR_SET_CHILD_SUBREAPER, 1);
  std::vector<pid_t> running;
  const auto end_strays = [&] {
    running.clear();
    for (const auto& [pid, a] : active) running.push_back(pid);
    end_children(running);
  };
  std::vector<pollfd> outputs;
  while (!queue.empty() || !active.empty()) {
    if (interrupt != nullptr && interrupt->load()) {
      for (const auto& [pid, a] : active) kill(-pid, SIGKILL);
      for (auto& [pid, a] : active) {
        waitpid(pid, nullptr, 0);
        drain(a);  // what it printed until then, for whoever wonders what it was doing
        write_file(a.task.log, a.output.kept());
      }
      summary.interrupted = true;
      break;
    }
    while (!queue.empty() && static_cast<int>(active.size()) < options.jobs) {
      Task task = std::move(queue.front());
      queue.pop_front();
      const fs::path dir = task.log.parent_path();
      fs::remove_all(dir);  // a task in flight when a previous sweep died
      fs::create_directories(dir);
      std::vector<char*> argv;
      for (std::string& a : task.args) argv.push_back(a.data());
      argv.push_back(nullptr);
      int output[2];
      if (::pipe2(output, O_CLOEXEC) != 0)
        throw std::runtime_error(std::string("pipe failed: ") + std::strerror(errno));
      const pid_t pid = fork();
      if (pid < 0) throw std::runtime_error(std::string("fork failed: ") + std::strerror(errno));
      if (pid == 0) {
        setpgid(0, 0);  // its own group: a timeout kills it and anything it started
        // A sweep killed hard takes its runs with it, so a --resume never races a survivor.
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        if (getppid() == 1) _exit(127);  // the sweep died before prctl took effect
        sigaction(SIGCHLD, &previous_child_action, nullptr);
        sigprocmask(SIG_SETMASK, &previous_mask, nullptr);
        dup2(output[1], STDOUT_FILENO);  // dup2 clears close-on-exec on the copies
        dup2(output[1], STDERR_FILENO);
        execv(argv[0], argv.data());
        _exit(127);
      }
      ::close(output[1]);
      ::fcntl(output[0], F_SETFL, O_NONBLOCK);
      setpgid(pid, pid);
      Active& started = active[pid];
      started.task = std::move(task);
      started.start = std::chrono::steady_clock::now();
      started.output_fd = output[0];
    }
    for (auto& [child, a] : active) drain(a);
    int status = 0;
    const pid_t pid = waitpid(-1, &status, WNOHANG);
    if (pid > 0 && active.count(pid)) {
      Active a = std::move(active[pid]);
      active.erase(pid);
      end_strays();  // what it left, before its pipe is read for the last time
      drain(a);      // what it wrote before it ended (nothing it started is left to hold the pipe)
      if (a.output_fd >= 0) ::close(a.output_fd);
      fs::create_directories(a.task.log.parent_path());
      write_file(a.task.log, a.output.kept());
      const double wall =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - a.start).count();
      if (!a.task.recording.empty()) {
        const bool ok = !a.timed_out && completed(status);
        for (const RunUnit* run : waiting[a.task.recording]) {
          if (ok) {
            queue.push_back(replay_task(*run));
            continue;
          }
          // Without its recording no run of this seed can go on: each gets the reason.
          json result =
              result_of(*run, out, a.task.log.lexically_relative(out), status, a.timed_out, wall);
          if (result["status"] != "ok") {
            result["reason"] =
                "simulating " +
                (run->world->stem.empty() ? std::string() : "world " + run->world->stem + ", ") +
                "seed " + std::to_string(run->seed) +
                " failed: " + result["status"].get<std::string>() + ", " +
                result.value("reason", "");
            result["status"] = "error";
          }
          append_result(*run, result);
        }
        continue;
      }
      append_result(*a.task.run, result_of(*a.task.run, out, a.task.log.lexically_relative(out),
                                           status, a.timed_out, wall));
      continue;
    }
    const auto now = std::chrono::steady_clock::now();
    for (auto& [child, a] : active) {
      if (!a.timed_out &&
          std::chrono::duration<double>(now - a.start).count() > experiment.timeout_s) {
        a.timed_out = true;
        kill(-child, SIGKILL);
      }
    }
    // 50 ms: timeouts and Ctrl-C are checked that often. Output to read or a child that ended
    // (SIGCHLD) wakes it at once.
    const timespec wait_at_most{0, 50'000'000};
    outputs.clear();
    for (const auto& [child, a] : active) {
      if (a.output_fd >= 0) outputs.push_back({a.output_fd, POLLIN, 0});
    }
    ppoll(outputs.data(), outputs.size(), &wait_at_most, &wait_mask);
  }
  for (auto& [child, a] : active) {
    if (a.output_fd >= 0) ::close(a.output_fd);
  }
  active.clear();
  end_strays();  // nothing of a run outlives the sweep (Ctrl-C included)
  prctl(PR_SET_CHILD_SUBREAPER, was_subreaper);
  sigaction(SIGCHLD, &previous_child_action, nullptr);
  sigprocmask(SIG_SETMASK, &previous_mask, nullptr);
  ::close(results_fd);
  if (options.progress_bar) std::fprintf(stderr, "\n");
  // One line per run, the newest, as in results.csv: the retried runs' old lines go.
  rewrite_results(out / "results.jsonl", read_results(out / "results.jsonl"));
  write_tables(out);
  return summary;
}

namespace {

/// Copies the files of `from` into `to` (made as needed), keeping a file `to` already has (a
/// seed's log in two shards is the same file). Throws std::runtime_error naming the file that
/// could not be written and the system's reason.
void copy_tree(const fs::path& from, const fs::path& to) {
  fs::create_directories(to);
  for (const fs::directory_entry& entry : fs::recursive_directory_iterator(from)) {
    const fs::path target = to / entry.path().lexically_relative(from);
    std::error_code error;
    if (entry.is_directory()) {
      fs::create_directories(target, error);
    } else if (entry.is_regular_file() && !fs::exists(target)) {
      fs::copy_file(entry.path(), target, error);
    }
    if (error) throw std::runtime_error("cannot write " + target.string() + ": " + error.message());
  }
}

}  // namespace

void merge_sweeps(const fs::path& out_dir, const std::vector<fs::path>& parts,
                  const std::string& kept) {
  if (parts.empty()) throw InputError("merge: give the shard folders to join");
  std::map<std::size_t, std::pair<json, const fs::path*>> by_index;  // with the part it is from
  json header, first;
  for (std::size_t p = 0; p < parts.size(); ++p) {
    const fs::path& part = parts[p];
    if (!fs::exists(part / "sweep.json"))
      throw InputError("merge: '" + part.string() + "' is not a sweep folder");
    for (std::size_t q = 0; q < p; ++q) {
      std::error_code error;
      if (fs::equivalent(parts[q], part, error))
        throw InputError("merge: '" + parts[q].string() + "' and '" + part.string() +
                         "' are the same folder: each shard once");
    }
    // A sweep still writing it would leave its runs in flight out.
    if (const std::string holder = lock_holder(part); !holder.empty())
      throw InputError("merge: '" + part.string() + "' is in use by " + holder +
                       ": merge it once that has ended");
    header = read_sweep_header(part);
    if (first.is_null()) first = header;
    // Against itself first: a folder of an older locsim is refused even alone.
    for (const json* other : {&header, &first}) {
      if (const std::string change =
              fingerprint_change(header["fingerprint"], (*other)["fingerprint"]);
          !change.empty()) {
        throw InputError("merge: '" + part.string() + "' is a sweep of other inputs than '" +
                         parts.front().string() + "': " + change);
      }
    }
    for (json& r : read_results(part / "results.jsonl")) {
      const auto index = r["index"].get<std::size_t>();
      if (const auto found = by_index.find(index); found != by_index.end()) {
        throw InputError("merge: run " + quoted_excerpt(r["id"].get<std::string>(), 200) +
                         " is in both '" + found->second.second->string() + "' and '" +
                         part.string() + "': each run must come from one shard");
      }
      by_index.emplace(index, std::pair{std::move(r), &part});
    }
  }
  check_output_folder(out_dir, "merge: out");
  if (const std::string holder = lock_holder(out_dir); !holder.empty())
    throw InputError("merge: folder '" + out_dir.string() + "' is in use by " + holder);
  // What an earlier merge wrote beside `kept`: the same shards joined again replace it.
  const auto clear_beside_kept = [&] {
    std::error_code ignored;
    for (const fs::directory_entry& entry : fs::directory_iterator(out_dir, ignored)) {
      const fs::path name = entry.path().filename();
      if (name != "sweep.lock" && name != kept) fs::remove_all(entry.path(), ignored);
    }
  };
  if (kept.empty() && holds_files(out_dir))
    throw InputError("merge: folder '" + out_dir.string() + "' is not empty");
  const FolderLock lock(out_dir, "merge", "merge: out");
  if (kept.empty() && holds_files(out_dir))  // again, under the lock
    throw InputError("merge: folder '" + out_dir.string() + "' is not empty");
  if (!kept.empty()) clear_beside_kept();
  header["shard"] = nullptr;
  header["merged_from"] = json::array();
  for (const fs::path& part : parts) header["merged_from"].push_back(part.string());
  // The folder was empty: a merge that fails (a full disk) empties it again, so that nothing half
  // copied is taken for a sweep and the same command can be run again.
  try {
    write_json_atomically(out_dir / "sweep.json", header);
    // The runs' folders and the seeds' logs too, so that the joined folder is a sweep like any
    // (`locsim report` draws from the runs' files). A run is in one shard only; a seed's log may
    // be in several, the same file (a seed is simulated the same wherever).
    for (const fs::path& part : parts) {
      for (const char* sub : {"runs", "logs"}) {
        if (fs::exists(part / sub)) copy_tree(part / sub, out_dir / sub);
      }
    }
    std::string results;
    for (const auto& [index, r] : by_index) results += jsonl_line(r.first);
    write_file(out_dir / "results.jsonl", results);
    write_tables(out_dir);
  } catch (...) {
    clear_beside_kept();
    throw;
  }
  if (by_index.size() != header["runs"].get<std::size_t>()) {
    std::fprintf(stderr,
                 "locsim merge: warning: %zu of %zu runs present (a shard not given, or not "
                 "finished: `locsim sweep --resume` finishes it)\n",
                 by_index.size(), header["runs"].get<std::size_t>());
  }
}

}  // namespace locsim
