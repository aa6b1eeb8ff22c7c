#include "sim/experiments/experiment.hpp"

#include <glob.h>

#include <algorithm>
#include <set>

#include "sim/common/format.hpp"
#include "sim/common/yaml_node.hpp"
#include "sim/producers/log_source.hpp"
#include "sim/run/runner.hpp"

namespace locsim {

namespace fs = std::filesystem;

std::string LocalizerConfig::spec() const {
  std::string out = plugin;
  for (std::size_t i = 0; i < params.size(); ++i) {
    out += (i == 0 ? ":" : ",") + params[i].first + "=" + params[i].second;
  }
  return out + "@" + label;
}

namespace {

std::string scalar_text(const YamlNode& node) {
  if (!node.is_scalar()) node.fail("expected a number, true/false or a string");
  return node.as_string();
}

bool valid_label(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-' || c == '=' ||
           c == '.';
  });
}

bool valid_family(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
  });
}

/// A `seeds:` list or {from, to} range, checked.
void read_seeds(const YamlNode& seeds, std::vector<std::uint64_t>& out) {
  if (seeds.is_sequence()) {
    for (const YamlNode& s : seeds.items())
      out.push_back(static_cast<std::uint64_t>(s.as_int(ExperimentDef::kSeedRange)));
  } else {
    seeds.allow_keys({"from", "to"});
    const long long from = seeds["from"].as_int(ExperimentDef::kSeedRange),
                    to = seeds["to"].as_int(ExperimentDef::kSeedRange);
    if (to < from) seeds["to"].fail("must be >= from");
    if (static_cast<std::size_t>(to - from) >= ExperimentDef::kMaxSeedSpan) {
      seeds.fail("more than " + std::to_string(ExperimentDef::kMaxSeedSpan) + " seeds");
    }
    for (long long s = from; s <= to; ++s) out.push_back(static_cast<std::uint64_t>(s));
  }
  if (out.empty()) seeds.fail("give at least one seed");
  if (std::set<std::uint64_t>(out.begin(), out.end()).size() != out.size()) {
    seeds.fail("a seed is listed twice");
  }
}

/// The files a `worlds:` pattern names, sorted: shell wildcards (`suite/room-*.yaml`) against
/// the experiment's folder; a pattern without wildcards is one file.
std::vector<fs::path> matching_files(const YamlNode& node, const fs::path& base) {
  const std::string pattern = (base / node.as_string()).string();
  glob_t found{};
  const int status = ::glob(pattern.c_str(), GLOB_ERR, nullptr, &found);
  std::vector<fs::path> files;
  for (std::size_t i = 0; status == 0 && i < found.gl_pathc; ++i) {
    std::error_code error;
    if (!fs::is_directory(found.gl_pathv[i], error)) files.emplace_back(found.gl_pathv[i]);
  }
  globfree(&found);
  if (status != 0 && status != GLOB_NOMATCH)
    node.fail("cannot read the folders of '" + pattern + "'");
  if (files.empty()) node.fail("no world file matches '" + pattern + "'");
  std::sort(files.begin(), files.end());  // glob's order is the locale's
  return files;
}

/// `world: FILE` (one world, runs LABEL/seed-N) or `worlds:` (runs LABEL/STEM/seed-N), a list
/// whose items are a world file (its own family, named by its stem) or {family: NAME, files:
/// PATTERN or [PATTERN, ...]}.
template <typename InputFile>
void read_worlds(const YamlNode& root, const fs::path& base, const InputFile& input_file,
                 std::vector<ExperimentWorld>& out) {
  const auto one = root.find("world");
  const auto many = root.find("worlds");
  if (one && many) many->fail("give world (one) or worlds (a list), not both");
  if (!many) {
    out.push_back({input_file(root["world"]), "", "", false, root["world"].place()});
    return;
  }
  if (!many->is_sequence()) many->fail("expected a list of world files or {family, files}");
  std::map<std::string, fs::path> stems;
  const auto add = [&](const YamlNode& at, const fs::path& file, const std::string& family,
                       bool held_back) {
    const std::string stem = file.stem().string();
    if (const auto [it, fresh] = stems.emplace(stem, file); !fresh) {
      at.fail("the file name '" + stem + "' is also that of '" + it->second.string() +
              "'; the runs are named after it: rename one");
    }
    if (stems.size() > ExperimentDef::kMaxWorlds)
      at.fail("more than " + std::to_string(ExperimentDef::kMaxWorlds) + " worlds");
    out.push_back({file, stem, family, held_back, at.place()});
  };
  for (const YamlNode& item : many->items()) {
    if (item.is_scalar()) {
      const fs::path file = input_file(item);
      add(item, file, file.stem().string(), false);
      continue;
    }
    item.allow_keys({"family", "files", "held_back"});
    const bool held_back = item.find("held_back") ? item["held_back"].as_bool() : false;
    const std::string family = item["family"].as_string();
    if (!valid_family(family))
      item["family"].fail("a family name may hold only a-z, A-Z, 0-9, '_', '-', '.'");
    const YamlNode files = item["files"];
    const std::vector<YamlNode> patterns =
        files.is_sequence() ? files.items() : std::vector<YamlNode>{files};
    if (patterns.empty()) files.fail("give at least one file or pattern");
    for (const YamlNode& pattern : patterns) {
      for (const fs::path& file : matching_files(pattern, base))
        add(pattern, file, family, held_back);
    }
  }
  if (out.empty()) many->fail("give at least one world");
}

}  // namespace

ExperimentDef load_experiment(const fs::path& file) {
  const Activity reading("reading the experiment " + file.string());
  const YamlNode root = YamlNode::load_file(file);
  root.allow_keys({"name", "world", "worlds", "scenario", "duration_s", "variation", "logs",
                   "seeds", "localizers", "convergence", "timeout_s", "params_file"});
  ExperimentDef e;
  e.source = file;
  const fs::path base = file.parent_path();
  e.name = root.get_string("name", file.stem().string());
  // A file that is not there is reported where the experiment names it.
  const auto input_file = [&](const YamlNode& node) {
    const fs::path path = base / node.as_string();
    std::error_code error;
    if (!fs::exists(path, error)) node.fail("no such file '" + path.string() + "'");
    if (fs::is_directory(path, error)) node.fail("'" + path.string() + "' is a directory");
    return path;
  };
  const auto logs = root.find("logs");
  if (logs) {
    // A log carries its world, scenario and duration: one given too would be ignored.
    for (const char* key : {"world", "worlds", "scenario", "duration_s", "variation"}) {
      if (const auto node = root.find(key)) {
        node->fail("give either logs (each log holds its world, scenario and duration) or " +
                   std::string("world (or worlds), scenario, duration_s and variation, not both"));
      }
    }
    for (const YamlNode& item : logs->items()) {
      // A log's file, or {file, robots: [names]} for a log of several robots: each robot a log
      // of its own in the runs and results (the log replayed as if it held only that robot).
      std::optional<YamlNode> robots_node;
      YamlNode file_node = item;
      if (item.is_map()) {
        item.allow_keys({"file", "robots"});
        file_node = item["file"];
        robots_node = item["robots"];
      }
      const fs::path path = input_file(file_node);
      std::vector<std::string> names;
      std::uint64_t seed = 0;
      try {
        const LogSource source(path);  // reads the header and the end record only
        for (const RobotDef& r : source.world().robots) names.push_back(r.name);
        seed = source.seed();
      } catch (const InputError& error) {
        file_node.fail(error.what());
      }
      std::vector<std::string> robots;
      if (robots_node) {
        for (const YamlNode& name : robots_node->items()) {
          const std::string robot = name.as_string();
          if (std::find(names.begin(), names.end(), robot) == names.end()) {
            std::string known;
            for (const std::string& n : names) known += (known.empty() ? "" : ", ") + n;
            name.fail("no robot named '" + robot + "' in the log (its robots: " + known + ")");
          }
          robots.push_back(robot);
        }
        if (robots.empty()) robots_node->fail("name at least one robot");
      } else if (names.size() != 1) {
        // Each run's result is one robot's metrics (its run folder's metrics.json).
        item.fail("the log has " + std::to_string(names.size()) +
                  " robots; an experiment scores one robot per run: name them, as {file: " +
                  path.filename().string() +
                  ", robots: [...]} (each robot's runs apart), or import each robot into a log "
                  "of its own (`locsim import mrclam SOURCE --robots N`)");
      }
      if (robots.empty()) robots.push_back("");
      for (const std::string& robot : robots) {
        const std::string stem = path.stem().string() + (robot.empty() ? "" : "-" + robot);
        for (const ExperimentLog& other : e.logs) {
          if (other.stem == stem) {
            item.fail("the file name '" + stem + "' is also that of '" + other.file.string() +
                      "'; the runs are named after it (and the robot): rename one");
          }
        }
        e.logs.push_back({path, stem, seed, robot});
      }
    }
    if (e.logs.empty()) logs->fail("give at least one log");
  } else {
    read_worlds(root, base, input_file, e.worlds);
    if (const auto scenario = root.find("scenario"); scenario && !scenario->is_null()) {
      e.scenario = input_file(*scenario);
    }
    if (const auto duration = root.find("duration_s"))
      e.duration_s = duration->as_double(ScenarioDef::kDurationRange);
    if (const auto variation = root.find("variation")) {
      if (!variation->is_scalar() || variation->as_string() != "none")
        variation->fail("give `none` (the world as declared on every seed), or leave it out");
      e.no_variation = true;
    }
  }
  e.timeout_s = root.get_double("timeout_s", e.timeout_s, ExperimentDef::kTimeoutRange);
  // The parameter file every localizer entry gets unless it names its own.
  std::optional<std::pair<fs::path, InputPlace>> params_file;
  if (const auto node = root.find("params_file"))
    params_file = std::pair{input_file(*node), node->place()};

  // With logs, seeds are optional: each log's own by default.
  if (logs) {
    if (const auto seeds = root.find("seeds")) read_seeds(*seeds, e.seeds);
  } else {
    read_seeds(root["seeds"], e.seeds);
  }

  std::set<std::string> labels;
  const YamlNode localizers = root["localizers"];
  for (const YamlNode& item : localizers.items()) {
    item.allow_keys({"plugin", "label", "params", "params_file", "grid"});
    const YamlNode plugin_node = item["plugin"];
    std::string plugin = plugin_node.as_string();
    // A loader plugin's source (`python:filters/pf.py`, or `filters/pf.py` alone) is relative to
    // the experiment's folder, as every file the experiment names; a bare name (`python:pf`) is
    // looked for in the plugin path when the runs load it.
    const auto colon = plugin.find(':');
    const bool bare_script = colon == std::string::npos && plugin.ends_with(".py");
    const std::string source =
        bare_script ? plugin : (colon == std::string::npos ? "" : plugin.substr(colon + 1));
    if ((source.find('/') != std::string::npos || source.ends_with(".py")) &&
        fs::path(source).is_relative()) {
      const fs::path path = base / source;
      std::error_code error;
      if (!fs::is_regular_file(path, error))
        plugin_node.fail("no such file '" + path.string() + "'");
      plugin = (bare_script ? std::string("python") : plugin.substr(0, colon)) + ":" +
               fs::absolute(path).lexically_normal().string();
    }
    const std::string label =
        item.get_string("label", fs::path(source.empty() ? plugin : source).stem().string());
    const auto place = [](const YamlNode& node) { return InputPlace{node.where(), node.path()}; };
    auto item_params_file = params_file;
    if (const auto node = item.find("params_file"))
      item_params_file = std::pair{input_file(*node), node->place()};
    std::vector<std::pair<std::string, std::string>> fixed;
    std::vector<InputPlace> fixed_places;
    // Grid axes in file order: each value with its place.
    std::vector<std::pair<std::string, std::vector<std::pair<std::string, InputPlace>>>> axes;
    if (const auto params = item.find("params")) {
      if (!params->is_map()) params->fail("expected a map of parameter values");
      for (const auto& [key, value] : params->entries()) {
        fixed.emplace_back(key, scalar_text(value));
        fixed_places.push_back(place(value));
      }
    }
    if (const auto grid = item.find("grid")) {
      if (!grid->is_map()) grid->fail("expected a map from parameter to a list of values");
      for (const auto& [key, values] : grid->entries()) {
        // run keeps one value per parameter: the grid points could all run alike.
        // (A named copy: clang 14 cannot capture a structured binding.)
        const std::string& name = key;
        const bool also_fixed = std::any_of(fixed.begin(), fixed.end(),
                                            [&](const auto& param) { return param.first == name; });
        if (also_fixed) values.fail("also given in params; give it in one of them");
        std::vector<std::pair<std::string, InputPlace>> texts;
        for (const YamlNode& v : values.items()) texts.emplace_back(scalar_text(v), place(v));
        if (texts.empty()) values.fail("give at least one value");
        axes.emplace_back(key, texts);
      }
    }
    // Counted before the expansion is made: a few lists can multiply into billions.
    double configurations = static_cast<double>(e.localizers.size());
    double this_grid = 1.0;
    for (const auto& axis : axes) this_grid *= static_cast<double>(axis.second.size());
    configurations += this_grid;
    if (configurations > static_cast<double>(ExperimentDef::kMaxConfigurations)) {
      item.fail("the grids make " + rounded_number(configurations, 12) +
                " configurations; an experiment has at most " +
                std::to_string(ExperimentDef::kMaxConfigurations) + " (split it)");
    }
    // Runs per configuration: one per seed, on each log (each log's own seed by default).
    const double inputs =
        e.logs.empty()
            ? static_cast<double>(e.worlds.size() * e.seeds.size())
            : static_cast<double>(e.logs.size() * std::max<std::size_t>(e.seeds.size(), 1));
    const std::string inputs_text =
        e.logs.empty() ? (e.worlds.size() > 1 ? std::to_string(e.worlds.size()) + " worlds x "
                                              : std::string()) +
                             std::to_string(e.seeds.size()) + " seeds"
                       : std::to_string(e.logs.size()) + " logs x " +
                             std::to_string(std::max<std::size_t>(e.seeds.size(), 1)) + " seeds";
    if (configurations * inputs > static_cast<double>(ExperimentDef::kMaxRuns)) {
      item.fail(rounded_number(configurations, 12) + " configurations on " + inputs_text +
                " make " + rounded_number(configurations * inputs, 12) +
                " runs; an experiment has at most " + std::to_string(ExperimentDef::kMaxRuns) +
                " (split it, or shard it with --shard)");
    }
    // Cartesian product, the last axis varying fastest.
    std::vector<std::size_t> digit(axes.size(), 0);
    while (true) {
      LocalizerConfig config{
          label,
          plugin,
          fixed,
          place(plugin_node),
          fixed_places,
          item_params_file ? std::optional(item_params_file->first) : std::nullopt,
          item_params_file ? item_params_file->second : InputPlace{}};
      for (std::size_t a = 0; a < axes.size(); ++a) {
        const auto& [text, value_place] = axes[a].second[digit[a]];
        config.params.emplace_back(axes[a].first, text);
        config.param_places.push_back(value_place);
        config.label += "-" + axes[a].first + "=" + text;
      }
      if (!valid_label(config.label)) {
        item.fail("label '" + config.label + "' may hold only a-z, 0-9, '_', '-', '=', '.'");
      }
      if (!labels.insert(config.label).second) item.fail("label '" + config.label + "' used twice");
      e.localizers.push_back(config);
      std::size_t a = axes.size();
      while (a > 0 && ++digit[a - 1] == axes[a - 1].second.size()) digit[--a] = 0;
      if (a == 0) break;
    }
  }
  if (e.localizers.empty()) localizers.fail("give at least one localizer");

  if (const auto convergence = root.find("convergence")) {
    convergence->allow_keys({"position_m", "heading", "heading_deg", "hold_samples"});
    e.convergence.position_m = convergence->get_double("position_m", e.convergence.position_m,
                                                       ConvergenceCriterion::kPositionRange);
    e.convergence.heading_rad = convergence->get_angle("heading", e.convergence.heading_rad,
                                                       ConvergenceCriterion::kHeadingRange);
    e.convergence.hold_samples = static_cast<int>(convergence->get_int(
        "hold_samples", e.convergence.hold_samples, ConvergenceCriterion::kHoldRange));
  }
  // The worlds and scenario must load now, not in every run (a log's were checked above).
  for (const ExperimentWorld& world : e.worlds) {
    const RunInputs inputs = load_run_inputs(world.file, e.scenario, e.duration_s);
    if (inputs.world.robots.size() != 1) {
      // Each run's result is one robot's metrics (its run folder's metrics.json); a run of
      // several robots writes a folder per robot, which no run of a sweep would be scored by.
      throw InputError(
          world.place,
          (world.stem.empty() ? "the world has " : "the world '" + world.file.string() + "' has ") +
              std::to_string(inputs.world.robots.size()) +
              " robots; an experiment scores one robot per run: give it a world with one robot, "
              "or record this one (`locsim run WORLD --seed N --log FILE`) and list the log with "
              "the robots to score as logs: [{file: FILE, robots: [...]}]");
    }
    for (const fs::path& input : inputs.files) {
      if (std::find(e.files.begin(), e.files.end(), input) == e.files.end())
        e.files.push_back(input);
    }
  }
  e.files.insert(e.files.begin(), file);
  // The parameter files too: a resume must see them change like the world.
  for (const LocalizerConfig& config : e.localizers) {
    if (config.params_file &&
        std::find(e.files.begin(), e.files.end(), *config.params_file) == e.files.end()) {
      e.files.push_back(*config.params_file);
    }
  }
  // The logs are inputs like the world: a resume or merge must see one change.
  for (const ExperimentLog& log : e.logs) {
    if (std::find(e.files.begin(), e.files.end(), log.file) == e.files.end())
      e.files.push_back(log.file);
  }
  return e;
}

std::vector<RunUnit> expand_runs(const ExperimentDef& experiment) {
  std::vector<RunUnit> runs;
  for (const LocalizerConfig& config : experiment.localizers) {
    for (const ExperimentWorld& world : experiment.worlds) {
      for (const std::uint64_t seed : experiment.seeds) {
        runs.push_back({runs.size(),
                        config.label + "/" + (world.stem.empty() ? "" : world.stem + "/") +
                            "seed-" + std::to_string(seed),
                        &config, nullptr, &world, seed});
      }
    }
    for (const ExperimentLog& log : experiment.logs) {
      const std::vector<std::uint64_t> seeds =
          experiment.seeds.empty() ? std::vector{log.recorded_seed} : experiment.seeds;
      for (const std::uint64_t seed : seeds) {
        runs.push_back({runs.size(),
                        config.label + "/" + log.stem + "/seed-" + std::to_string(seed), &config,
                        &log, nullptr, seed});
      }
    }
  }
  return runs;
}

}  // namespace locsim
