#include "sim/experiments/calibration_check.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <map>
#include <set>
#include <system_error>
#include <tuple>
#include <utility>

#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/common/format.hpp"
#include "sim/experiments/statistics.hpp"
#include "sim/experiments/sweep.hpp"
#include "sim/plugin_host/param_file.hpp"
#include "sim/plugin_host/plugin_library.hpp"
#include "sim/producers/log_source.hpp"

namespace locsim {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;
using ojson = nlohmann::ordered_json;

std::optional<double> number_of(const std::string& text) {
  double value = 0.0;
  const char* const end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(text.data(), end, value);
  if (error != std::errc() || stop != end || !std::isfinite(value)) return std::nullopt;
  return value;
}

/// A file stem as a part of a configuration's label (a-z, 0-9, '_', '-', '.').
std::string label_part(const std::string& stem) {
  std::string out;
  for (const char c : stem) {
    const char lower = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    const bool kept = (lower >= 'a' && lower <= 'z') || (lower >= '0' && lower <= '9') ||
                      lower == '_' || lower == '-' || lower == '.';
    out += kept ? lower : '_';
  }
  return out;
}

std::string quoted(const std::string& text) {
  return json(text).dump();
}

/// "+12 %", "-3 %", "0 %": a change in whole per cent.
std::string percent(double change) {
  const double rounded = std::round(100.0 * change);
  if (rounded == 0.0) return "0 %";
  return (rounded > 0.0 ? "+" : "") + fixed(rounded, 0) + " %";
}

/// One configuration of a check's experiment.
struct Config {
  std::string plugin, label;
  fs::path params_file;
};

/// The experiment replaying `recordings` with `configs`: an experiment file as `locsim sweep`
/// takes it, so that the user can run it again (--resume) and report it.
std::string experiment_text(const std::string& name, const std::string& what,
                            const std::vector<const CheckedRecording*>& recordings,
                            const std::vector<std::uint64_t>& seeds,
                            const std::vector<Config>& configs) {
  std::string text = "# Written by `locsim calibrate`: " + what + "\nname: " + name + "\nlogs:\n";
  for (const CheckedRecording* r : recordings) {
    text += "  - {file: " + quoted(fs::absolute(r->log).string()) + ", robots: [";
    for (std::size_t i = 0; i < r->robots.size(); ++i)
      text += (i == 0 ? "" : ", ") + quoted(r->robots[i]);
    text += "]}\n";
  }
  if (!seeds.empty()) {
    text += "seeds: [";
    for (std::size_t i = 0; i < seeds.size(); ++i)
      text += (i == 0 ? "" : ", ") + std::to_string(seeds[i]);
    text += "]\n";
  }
  text += "timeout_s: 3600\nlocalizers:\n";
  for (const Config& c : configs) {
    text += "  - {plugin: " + quoted(c.plugin) + ", label: " + c.label +
            ", params_file: " + quoted(fs::absolute(c.params_file).string()) + "}\n";
  }
  return text;
}

/// A localizer's position RMS on a recording over its robots and the seeds (each run's RMS
/// weighted by its samples), and per seed, or why a run gave none.
struct RmsSum {
  struct Sum {
    double weighted_square_m2 = 0.0, samples = 0.0;
    double rms_m() const { return std::sqrt(weighted_square_m2 / samples); }
  };
  Sum all;
  std::map<std::uint64_t, Sum> by_seed;
  std::string problem;
  std::optional<double> rms_m() const {
    if (!problem.empty() || all.samples <= 0.0) return std::nullopt;
    return all.rms_m();
  }
};

using RmsSums = std::map<std::pair<std::string, std::size_t>, RmsSum>;  // (label, on)

/// The sweep's results by configuration and recording; `recording_of` maps a result's
/// source_log (STEM-ROBOT) to its recording.
RmsSums rms_sums(const std::vector<json>& results,
                 const std::map<std::string, std::size_t>& recording_of) {
  RmsSums out;
  for (const json& r : results) {
    const auto on = recording_of.find(r.value("source_log", ""));
    if (on == recording_of.end()) continue;
    RmsSum& a = out[{r["config"].get<std::string>(), on->second}];
    const std::string status = r["status"].get<std::string>();
    const json metrics = r.value("metrics", json::object());
    const json rms = metrics.value("position_error_m", json::object()).value("rms", json());
    const json samples = metrics.value("samples", json());
    if (status != "ok" || !rms.is_number() || !samples.is_number()) {
      if (a.problem.empty()) {
        a.problem = status + (r.value("reason", "").empty() ? "" : ": " + r.value("reason", ""));
        if (a.problem == "ok") a.problem = "ok, but no position error";
      }
      continue;
    }
    const double n = samples.get<double>(), e = rms.get<double>();
    for (RmsSum::Sum* sum : {&a.all, &a.by_seed[r["seed"].get<std::uint64_t>()]}) {
      sum->weighted_square_m2 += n * e * e;
      sum->samples += n;
    }
  }
  return out;
}

/// The 95 % interval's half-width of the change of `from` against `own`, from the change seed
/// by seed (both replayed with the same seeds: the seed's luck on the log largely cancels), and
/// whether that interval leaves out zero. Unset with fewer than two seeds.
std::optional<std::pair<double, bool>> change_interval(const RmsSum& from, const RmsSum& own) {
  std::vector<double> changes;
  for (const auto& [seed, sum] : from.by_seed) {
    const auto it = own.by_seed.find(seed);
    if (it == own.by_seed.end() || sum.samples <= 0.0 || it->second.samples <= 0.0) continue;
    const double own_m = it->second.rms_m();
    if (own_m > 0.0) changes.push_back(sum.rms_m() / own_m - 1.0);
  }
  if (changes.size() < 2) return std::nullopt;
  const Aggregate a = aggregate(changes);
  return std::pair{a.ci95, std::abs(a.mean) > a.ci95};
}

SweepSummary sweep(const fs::path& experiment, const fs::path& out,
                   const CalibrationCheckOptions& options, const std::atomic<bool>* interrupt) {
  SweepOptions s;
  s.experiment_file = experiment;
  s.out_dir = out;
  s.jobs = options.jobs;
  s.progress_bar = isatty(STDERR_FILENO) != 0;
  s.progress_lines = false;
  s.locsim_binary = options.locsim_binary;
  return run_sweep(s, interrupt);
}

/// The parameters a localizer declares, as a replay's metrics.json lists them (with their
/// values): read from a run of `label` in a sweep's results. Empty when no run has them.
std::set<std::string> declared_params(const std::vector<json>& results, const fs::path& sweep_dir,
                                      const std::string& label) {
  std::set<std::string> keys;
  for (const json& r : results) {
    if (r["config"] != label || r["status"] != "ok") continue;
    try {
      const fs::path run_dir = (sweep_dir / r["log"].get<std::string>()).parent_path();
      const json metrics = json::parse(read_text(run_dir / "metrics.json"));
      for (const auto& [key, value] : metrics["localizers"].at(0)["params"].items())
        keys.insert(key);
      return keys;
    } catch (const std::exception&) {
      // A run folder that cannot be read names nothing: try another run.
    }
  }
  return keys;
}

/// (key, text) of the values `plugin` takes from `file`, restricted to `declared`.
std::vector<std::pair<std::string, std::string>> values_taken(
    const fs::path& file, const std::string& plugin, const std::set<std::string>& declared) {
  std::vector<std::pair<std::string, std::string>> out;
  for (const ParamFileValue& v : values_for(load_param_file(file), plugin)) {
    if (declared.count(v.key) > 0) out.emplace_back(v.key, v.text);
  }
  return out;
}

std::string group_of(const std::string& key, const std::string& plugin) {
  const std::string_view group = parameter_group(key, plugin);
  return group.empty() ? key : std::string(group);
}

std::string slug(const std::string& group) {
  std::string out = group;
  std::replace(out.begin(), out.end(), ' ', '_');
  return label_part(out);
}

std::string whose(const CalibrationCheck& check, const std::optional<std::size_t>& from) {
  return from ? check.recordings[*from].name + "'s" : "the pooled";
}

}  // namespace

std::vector<CheckedRecording> checked_recordings(const CalibrationCheckOptions& options) {
  if (options.logs.size() < 2) {
    throw InputError("calibrate: checking a calibration across recordings needs two logs or more");
  }
  for (const std::string& plugin : options.localizers) {
    if (plugin.empty() || label_part(plugin) != plugin) {
      throw InputError("--check: '" + plugin +
                       "' is not a plugin's name (a-z, 0-9, '_', '-', '.'): give names, as "
                       "`locsim plugins` lists them");
    }
    find_plugin(plugin);  // PluginError: not found, saying where it looked
  }
  // The recordings, each with the robots the pooled calibration uses from it.
  std::vector<CheckedRecording> recordings;
  std::set<std::string> stems, names;
  for (const fs::path& log : options.logs) {
    CheckedRecording r;
    r.log = log;
    const std::string stem = log.stem().string();
    if (!stems.insert(stem).second) {
      throw InputError(log.string() + ": another log is named '" + stem +
                       "' too; a recording is named by its file: rename one");
    }
    r.name = label_part(stem);
    while (!names.insert(r.name).second) r.name += "_";
    const LogSource source(log);
    const std::vector<std::string>& wanted = options.calibration.robots;
    for (const RobotDef& robot : source.world().robots) {
      if (wanted.empty() || std::find(wanted.begin(), wanted.end(), robot.name) != wanted.end())
        r.robots.push_back(robot.name);
    }
    if (r.robots.empty()) {
      throw InputError(log.string() +
                       ": holds none of the robots --robots names; a recording needs one");
    }
    recordings.push_back(std::move(r));
  }
  return recordings;
}

CalibrationCheck check_calibration(const CalibrationCheckOptions& options,
                                   const std::atomic<bool>* interrupt) {
  CalibrationCheck check;
  check.recordings = checked_recordings(options);
  check.localizers = options.localizers;
  check.seeds = options.seeds;
  check.flag_above = options.flag_above;
  // Each recording alone.
  for (CheckedRecording& r : check.recordings) {
    CalibrationOptions alone = options.calibration;
    alone.robots = r.robots;
    const Calibration calibration = calibrate({r.log}, alone);
    const fs::path dir = options.out_dir / "recordings" / r.name;
    make_missing_folders(dir, "calibrate");
    r.calibration_file = dir / "calibration.yaml";
    const std::string json_text = calibration.to_json().dump(2) + '\n',
                      yaml_text = calibration.to_yaml();
    write_files({{dir / "calibration.json", json_text}, {r.calibration_file, yaml_text}});
  }
  // The spread of every number written, in the pooled file's order (then keys only the
  // recordings have).
  {
    std::vector<ParamFile> files;
    for (const CheckedRecording& r : check.recordings)
      files.push_back(load_param_file(r.calibration_file));
    const ParamFile pooled = load_param_file(options.pooled_file);
    std::vector<std::pair<std::string, std::string>> keys;  // (plugin, key)
    const auto add_keys = [&](const ParamFile& file) {
      const auto add = [&](const std::string& plugin, const ParamFileValue& v) {
        if (std::find(keys.begin(), keys.end(), std::pair{plugin, v.key}) == keys.end())
          keys.emplace_back(plugin, v.key);
      };
      for (const ParamFileValue& v : file.common) add("", v);
      for (const ParamFileSection& s : file.sections) {
        for (const ParamFileValue& v : s.values) add(s.plugin, v);
      }
    };
    add_keys(pooled);
    for (const ParamFile& file : files) add_keys(file);
    const auto value_in = [](const ParamFile& file, const std::string& plugin,
                             const std::string& key) -> std::optional<double> {
      const std::vector<ParamFileValue>* values = &file.common;
      if (!plugin.empty()) {
        const ParamFileSection* section = file.section(plugin);
        if (section == nullptr) return std::nullopt;
        values = &section->values;
      }
      for (const ParamFileValue& v : *values) {
        if (v.key == key) return number_of(v.text);
      }
      return std::nullopt;
    };
    for (const auto& [plugin, key] : keys) {
      ParameterSpread p;
      p.plugin = plugin;
      p.key = key;
      p.group = std::string(parameter_group(key, plugin));
      p.pooled = value_in(pooled, plugin, key);
      bool any = false;
      double largest = 0.0;
      for (const ParamFile& file : files) {
        p.values.push_back(value_in(file, plugin, key));
        if (const auto v = p.values.back()) {
          p.min = any ? std::min(p.min, *v) : *v;
          p.max = any ? std::max(p.max, *v) : *v;
          largest = std::max(largest, std::abs(*v));
          any = true;
        }
      }
      if (!any) continue;  // a word (range_model, motion_model): no spread
      const double scale = p.pooled && *p.pooled != 0.0 ? std::abs(*p.pooled) : largest;
      p.relative = scale > 0.0 ? (p.max - p.min) / scale : 0.0;
      check.spread.push_back(std::move(p));
    }
  }
  if (options.localizers.empty()) return check;

  // Every recording with every recording's parameters, and the pooled ones.
  const fs::path transfer = options.out_dir / "transfer";
  make_missing_folders(transfer, "calibrate");
  std::map<std::string, std::size_t> recording_of;  // a result's source_log -> recording
  std::vector<const CheckedRecording*> all;
  for (std::size_t k = 0; k < check.recordings.size(); ++k) {
    const CheckedRecording& r = check.recordings[k];
    all.push_back(&r);
    for (const std::string& robot : r.robots) recording_of[r.log.stem().string() + "-" + robot] = k;
  }
  const auto label_of = [&](const std::string& plugin, const std::optional<std::size_t>& from) {
    return plugin + (from ? ".from." + check.recordings[*from].name : std::string(".pooled"));
  };
  std::vector<Config> configs;
  for (const std::string& plugin : options.localizers) {
    for (std::size_t k = 0; k < check.recordings.size(); ++k)
      configs.push_back({plugin, label_of(plugin, k), check.recordings[k].calibration_file});
    configs.push_back({plugin, label_of(plugin, std::nullopt), options.pooled_file});
  }
  write_file(transfer / "experiment.yaml",
             experiment_text("calibration_transfer",
                             "every recording replayed with every recording's calibration", all,
                             options.seeds, configs));
  const fs::path runs = transfer / "runs";
  const SweepSummary summary = sweep(transfer / "experiment.yaml", runs, options, interrupt);
  check.errors += summary.errors;
  const std::vector<json> results = read_sweep_results(runs);
  const RmsSums measured = rms_sums(results, recording_of);
  const auto rms_of = [](const RmsSums& a, const std::string& label,
                         std::size_t on) -> std::pair<std::optional<double>, std::string> {
    const auto it = a.find({label, on});
    if (it == a.end()) return {std::nullopt, "not run"};
    return {it->second.rms_m(), it->second.problem};
  };
  for (const std::string& plugin : options.localizers) {
    std::vector<std::optional<std::size_t>> sources;
    for (std::size_t k = 0; k < check.recordings.size(); ++k) sources.emplace_back(k);
    sources.emplace_back(std::nullopt);
    for (const std::optional<std::size_t>& from : sources) {
      for (std::size_t on = 0; on < check.recordings.size(); ++on) {
        TransferCell cell;
        cell.localizer = plugin;
        cell.from = from;
        cell.on = on;
        std::tie(cell.rms_m, cell.problem) = rms_of(measured, label_of(plugin, from), on);
        cell.own_rms_m = rms_of(measured, label_of(plugin, on), on).first;
        bool significant = true;
        if (cell.rms_m && cell.own_rms_m && *cell.own_rms_m > 0.0) {
          cell.change = *cell.rms_m / *cell.own_rms_m - 1.0;
          const auto interval = change_interval(measured.at({label_of(plugin, from), on}),
                                                measured.at({label_of(plugin, on), on}));
          if (interval) {
            cell.change_ci95 = interval->first;
            significant = interval->second;
          }
        }
        const bool own = from && *from == on;
        const bool beyond = cell.change && std::abs(*cell.change) > options.flag_above;
        cell.uncertain = !own && beyond && !significant;
        cell.flagged = !own && !summary.interrupted &&
                       ((beyond && significant) || (!cell.rms_m && cell.own_rms_m));
        check.cells.push_back(std::move(cell));
      }
    }
  }
  if (summary.interrupted) {
    check.interrupted = true;
    return check;
  }

  // What moves a flagged cell: its recording's own parameters with one group from the other's.
  for (std::size_t on = 0; on < check.recordings.size(); ++on) {
    const CheckedRecording& target = check.recordings[on];
    const fs::path dir = transfer / "groups" / target.name;
    std::vector<Config> swaps;
    std::vector<std::tuple<TransferCell*, std::string, std::string>> asked;  // cell, group, label
    for (TransferCell& cell : check.cells) {
      if (!cell.flagged || cell.on != on || !cell.rms_m) continue;
      const std::set<std::string> declared =
          declared_params(results, runs, label_of(cell.localizer, on));
      if (declared.empty()) continue;
      const fs::path from_file =
          cell.from ? check.recordings[*cell.from].calibration_file : options.pooled_file;
      const auto own = values_taken(target.calibration_file, cell.localizer, declared);
      const auto other = values_taken(from_file, cell.localizer, declared);
      std::vector<std::string> groups;  // those whose values differ, in the own file's order
      const auto differs = [&](const std::string& key) {
        const auto find = [&](const auto& values) {
          const auto it = std::find_if(values.begin(), values.end(),
                                       [&](const auto& kv) { return kv.first == key; });
          return it == values.end() ? std::optional<std::string>() : it->second;
        };
        return find(own) != find(other);
      };
      for (const auto* values : {&own, &other}) {
        for (const auto& [key, text] : *values) {
          const std::string group = group_of(key, cell.localizer);
          if (differs(key) && std::find(groups.begin(), groups.end(), group) == groups.end())
            groups.push_back(group);
        }
      }
      for (const std::string& group : groups) {
        std::vector<std::pair<std::string, std::string>> mixed;
        for (const auto& kv : own) {
          if (group_of(kv.first, cell.localizer) != group) mixed.push_back(kv);
        }
        for (const auto& kv : other) {
          if (group_of(kv.first, cell.localizer) == group) mixed.push_back(kv);
        }
        const std::string label = label_of(cell.localizer, cell.from) + "." + slug(group);
        const fs::path file = dir / "params" / (label + ".yaml");
        make_missing_folders(file.parent_path(), "calibrate");
        write_file(file, param_file_text(mixed, {"Written by `locsim calibrate`: " + target.name +
                                                 "'s calibration for " + cell.localizer + ", its " +
                                                 group + " from " + whose(check, cell.from)}));
        swaps.push_back({cell.localizer, label, file});
        asked.emplace_back(&cell, group, label);
      }
    }
    if (swaps.empty()) continue;
    write_file(dir / "experiment.yaml",
               experiment_text("calibration_groups_" + target.name,
                               target.name + " replayed with its own calibration but for one "
                                             "group of parameters, from another's",
                               {&target}, options.seeds, swaps));
    const SweepSummary groups_summary =
        sweep(dir / "experiment.yaml", dir / "runs", options, interrupt);
    check.errors += groups_summary.errors;
    const RmsSums swapped = rms_sums(read_sweep_results(dir / "runs"), recording_of);
    for (const auto& [cell, group, label] : asked) {
      TransferCell::GroupChange g{group, std::nullopt};
      const std::optional<double> rms = rms_of(swapped, label, on).first;
      if (rms && cell->own_rms_m && *cell->own_rms_m > 0.0)
        g.change = *rms / *cell->own_rms_m - 1.0;
      cell->groups.push_back(g);
    }
    if (groups_summary.interrupted) {
      check.interrupted = true;
      break;
    }
  }
  for (TransferCell& cell : check.cells) {
    std::stable_sort(cell.groups.begin(), cell.groups.end(),
                     [](const TransferCell::GroupChange& a, const TransferCell::GroupChange& b) {
                       const double x = a.change ? std::abs(*a.change) : -1.0;
                       const double y = b.change ? std::abs(*b.change) : -1.0;
                       return x > y;
                     });
  }
  return check;
}

ojson CalibrationCheck::to_json() const {
  ojson out;
  ojson recordings_json = ojson::array();
  for (const CheckedRecording& r : recordings) {
    recordings_json.push_back({{"name", r.name},
                               {"log", r.log.string()},
                               {"robots", r.robots},
                               {"calibration", r.calibration_file.string()}});
  }
  out["recordings"] = recordings_json;
  const auto number = [](const std::optional<double>& v) { return v ? ojson(*v) : ojson(); };
  ojson spread_json = ojson::array();
  for (const ParameterSpread& p : spread) {
    ojson values = ojson::array();
    for (const auto& v : p.values) values.push_back(number(v));
    spread_json.push_back({{"plugin", p.plugin.empty() ? ojson() : ojson(p.plugin)},
                           {"key", p.key},
                           {"group", p.group},
                           {"values", values},
                           {"pooled", number(p.pooled)},
                           {"min", p.min},
                           {"max", p.max},
                           {"relative_spread", p.relative}});
  }
  out["spread"] = spread_json;
  if (localizers.empty()) return out;
  ojson cells_json = ojson::array();
  for (const TransferCell& c : cells) {
    ojson groups = ojson::array();
    for (const TransferCell::GroupChange& g : c.groups)
      groups.push_back({{"group", g.group}, {"change", number(g.change)}});
    cells_json.push_back({{"localizer", c.localizer},
                          {"from", c.from ? ojson(recordings[*c.from].name) : ojson("pooled")},
                          {"on", recordings[c.on].name},
                          {"position_rms_m", number(c.rms_m)},
                          {"own_position_rms_m", number(c.own_rms_m)},
                          {"change", number(c.change)},
                          {"change_ci95", number(c.change_ci95)},
                          {"flagged", c.flagged},
                          {"uncertain", c.uncertain},
                          {"problem", c.problem},
                          {"groups", groups}});
  }
  out["transfer"] = {
      {"localizers", localizers}, {"seeds", seeds.empty() ? ojson("each log's own") : ojson(seeds)},
      {"flag_above", flag_above}, {"interrupted", interrupted},
      {"cells", cells_json},      {"flags", flags()}};
  return out;
}

std::vector<std::string> CalibrationCheck::flags() const {
  std::vector<std::string> lines;
  for (const TransferCell& c : cells) {
    if (!c.flagged) continue;
    std::string line = c.localizer + " on " + recordings[c.on].name + " with " +
                       whose(*this, c.from) + " calibration: ";
    if (!c.rms_m) {
      line += "no result (" + c.problem + ")";
    } else {
      line += "RMS " + fixed(*c.rms_m, 3) + " m against " + fixed(*c.own_rms_m, 3) +
              " m with its own (" + percent(*c.change) + ")";
    }
    std::string alone;
    for (const TransferCell::GroupChange& g : c.groups) {
      if (!g.change) continue;
      alone += (alone.empty() ? "" : ", ") + g.group + " " + percent(*g.change);
    }
    if (!alone.empty()) line += "; each group alone: " + alone;
    lines.push_back(line);
  }
  return lines;
}

std::string CalibrationCheck::describe() const {
  std::string text = "recordings, each calibrated alone:";
  for (const CheckedRecording& r : recordings) {
    text += " " + r.name + " (";
    for (std::size_t i = 0; i < r.robots.size(); ++i) text += (i == 0 ? "" : ", ") + r.robots[i];
    text += ")";
  }
  text += "\n";
  std::vector<const ParameterSpread*> wide;
  for (const ParameterSpread& p : spread) {
    if (p.relative > flag_above) wide.push_back(&p);
  }
  std::stable_sort(
      wide.begin(), wide.end(),
      [](const ParameterSpread* a, const ParameterSpread* b) { return a->relative > b->relative; });
  if (wide.empty()) {
    text += "  every value within " + percent(flag_above).substr(1) +
            " of the pooled one over the recordings\n";
  } else {
    text += "  spread over the recordings beyond " + percent(flag_above).substr(1) +
            " of the pooled value:";
    for (std::size_t i = 0; i < std::min<std::size_t>(wide.size(), 8); ++i) {
      const ParameterSpread& p = *wide[i];
      text += std::string(i == 0 ? " " : ", ") + (p.plugin.empty() ? "" : p.plugin + ".") + p.key +
              " " + rounded_number(p.min, 3) + " to " + rounded_number(p.max, 3) + " (" +
              percent(p.relative).substr(1) + ")";
    }
    if (wide.size() > 8) text += ", " + std::to_string(wide.size() - 8) + " more";
    text += " (calibration.json \"spread\")\n";
  }
  if (localizers.empty()) return text;
  std::size_t width = 8;
  for (const CheckedRecording& r : recordings) width = std::max(width, r.name.size() + 2);
  const auto pad = [](std::string s, std::size_t n) {
    if (s.size() < n) s += std::string(n - s.size(), ' ');
    return s;
  };
  for (const std::string& plugin : localizers) {
    text += plugin +
            ": position RMS [m] on each recording (columns) with each calibration (rows), and "
            "its change against the recording's own\n  " +
            pad("", width);
    for (const CheckedRecording& r : recordings) text += pad(r.name, width + 8);
    text += "\n";
    std::optional<std::optional<std::size_t>> row;
    for (const TransferCell& c : cells) {
      if (c.localizer != plugin) continue;
      if (!row || *row != c.from) {
        if (row) text += "\n";
        row = c.from;
        text += "  " + pad(c.from ? recordings[*c.from].name : "pooled", width);
      }
      std::string entry = c.rms_m ? fixed(*c.rms_m, 3) : "-";
      if (c.change && !(c.from && *c.from == c.on)) entry += " " + percent(*c.change);
      if (c.flagged) entry += "!";
      if (c.uncertain) entry += "?";
      text += pad(entry, width + 8);
    }
    text += "\n";
  }
  const std::size_t uncertain = static_cast<std::size_t>(
      std::count_if(cells.begin(), cells.end(), [](const TransferCell& c) { return c.uncertain; }));
  if (uncertain > 0) {
    text += "?: " + std::to_string(uncertain) + " change" + (uncertain == 1 ? "" : "s") +
            " beyond " + percent(flag_above).substr(1) +
            " whose 95 % interval over the seeds holds zero: not flagged (more --check-seeds "
            "tell)\n";
  }
  const std::vector<std::string> flagged = flags();
  if (flagged.empty()) {
    text += "no calibration moves a localizer's RMS on another recording by more than " +
            percent(flag_above).substr(1) + "\n";
  } else {
    text += "flagged (RMS moved by more than " + percent(flag_above).substr(1) + "):\n";
    for (const std::string& line : flagged) text += "  " + line + "\n";
  }
  if (interrupted) text += "interrupted: the replays so far\n";
  return text;
}

}  // namespace locsim
