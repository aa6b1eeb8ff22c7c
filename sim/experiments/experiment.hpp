// Experiments: one YAML file naming a world and a scenario (or recorded logs), localizers with
// parameter grids, seeds and what "converged" means; expanded into runs, each one `locsim replay`
// of one localizer configuration on one seed's simulated log, or on one recorded log with one seed
// for the localizers' random streams.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "sim/common/errors.hpp"
#include "sim/common/range.hpp"
#include "sim/metrics/error_metrics.hpp"

namespace locsim {

/// One localizer configuration of the grid.
struct LocalizerConfig {
  std::string label;   // unique, names its folder and its rows: "ekf_landmarks-sigma_bearing_deg=1"
  std::string plugin;  // name or .so path
  std::vector<std::pair<std::string, std::string>> params;  // as given on the command line
  std::string spec() const;                                 // NAME:key=value,...@label
  InputPlace plugin_place;                                  // of the `plugin:` value
  std::vector<InputPlace> param_places;  // of each parameter's value, parallel to `params`
  /// The parameter file its runs get (`--params`): the entry's `params_file`, else the
  /// experiment's; resolved against the experiment file. Its values rank below `params`.
  std::optional<std::filesystem::path> params_file;
  InputPlace params_file_place;  // of the `params_file:` value that gives it
};

/// A recorded log an experiment replays (`logs:`), e.g. one `locsim import` wrote.
struct ExperimentLog {
  std::filesystem::path file;  // resolved against the experiment file
  // Its file name without extension, and "-ROBOT" with `robot`: names its runs, unique.
  std::string stem;
  std::uint64_t recorded_seed = 0;  // the log's own seed: the default of `seeds:`
  std::string robot;  // of a log of several robots, the one replayed (`replay --robots`)
};

/// A world an experiment simulates: its `world:`, or one of its `worlds:` (a suite of worlds,
/// e.g. ones `locsim generate` drew, whose results are also grouped by family).
struct ExperimentWorld {
  std::filesystem::path file;  // resolved against the experiment file
  // Its file name without extension: names its runs ("LABEL/STEM/seed-N") and recordings
  // ("logs/STEM/seed-N"). Empty for the one world of `world:` ("LABEL/seed-N", "logs/seed-N").
  std::string stem;
  std::string family;  // the group its results are tabled in; empty for `world:`
  // Held back from choosing the defaults (`held_back: true`): tabled apart from the rest,
  // side by side (summary.md, "Chosen on and held back").
  bool held_back = false;
  InputPlace place;  // of the entry that names it
};

struct ExperimentDef {
  std::string name = "experiment";
  std::filesystem::path source;
  /// The worlds simulated: the one of `world:`, or those of `worlds:`, in file order; empty
  /// with `logs:`.
  std::vector<ExperimentWorld> worlds;
  static constexpr std::size_t kMaxWorlds = 100000;
  std::optional<std::filesystem::path> scenario;  // for every world
  std::optional<double> duration_s;               // ScenarioDef::kDurationRange [s]
  bool no_variation = false;  // `variation: none`: every seed runs the world as declared
  /// With `logs:`: the logs replayed instead of simulating worlds (`worlds` is then empty).
  std::vector<ExperimentLog> logs;
  /// Without logs: the seeds simulated. With logs: the localizers' seeds each log is replayed
  /// with (`replay --seed`); empty when not given: each log once, with its own seed.
  std::vector<std::uint64_t> seeds;
  static constexpr Range kSeedRange{0.0, 4611686018427387904.0, ""};  // 0..2^62
  static constexpr std::size_t kMaxSeedSpan = 100000;  // seeds {from, to} lists at most this many
  std::vector<LocalizerConfig> localizers;
  // Configurations of all the localizers' grids together, and runs (configurations x seeds):
  // each run is a folder and a line of results, and the expansion is made before anything runs.
  static constexpr std::size_t kMaxConfigurations = 100000;
  static constexpr std::size_t kMaxRuns = 1000000;
  ConvergenceCriterion convergence;
  double timeout_s = 600.0;  // per run, wall clock [s]
  static constexpr Range kTimeoutRange{0.01, kSimulatedTimeRange.max, "s"};
  /// Every file the experiment was read from: this one, then its world's and scenario's
  /// (RunInputs::files), then its parameter files, then its logs.
  std::vector<std::filesystem::path> files;
};

/// Reads and checks an experiment file (including that the world and scenario load).
ExperimentDef load_experiment(const std::filesystem::path& file);  // throws InputError

struct RunUnit {
  // In the full expansion: localizers outer, then worlds (or logs), seeds inner.
  std::size_t index = 0;
  // "LABEL/seed-N", "LABEL/WORLDSTEM/seed-N" or "LABEL/LOGSTEM/seed-N": also its folder in runs/.
  std::string id;
  const LocalizerConfig* config = nullptr;
  const ExperimentLog* log = nullptr;      // the recorded log it replays; null: a simulation
  const ExperimentWorld* world = nullptr;  // the world simulated, with this seed; null: a log
  std::uint64_t seed = 0;
};

/// Every run of the experiment, in a fixed order.
std::vector<RunUnit> expand_runs(const ExperimentDef& experiment);

}  // namespace locsim
