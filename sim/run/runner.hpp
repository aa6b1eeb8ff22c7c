// `locsim run`: the simulation as the producer of the record stream, wired to the session's
// consumers (localizer host, scorer, run folder recorder), the log writer (--log) and frame
// capture (--video/--frames). A driver only: what the records become is the consumers' business.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "sim/consumers/frame_state.hpp"
#include "sim/run/output_budget.hpp"
#include "sim/run/session.hpp"
#include "sim/scenario/scenario_def.hpp"
#include "sim/sensors/camera_image.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

struct RunOptions : SessionOptions {
  std::filesystem::path world_file;
  std::optional<std::filesystem::path> scenario_file;  // else the world's `scenario:` section
  std::uint64_t seed = 1;
  std::optional<double> duration_s;  // overrides the scenario's duration [s]
  bool no_variation = false;  // the world as declared, whatever its `variation:` (--no-variation)
  std::filesystem::path out_dir;  // empty: a new folder under runs/
  bool realtime = false;          // pace the simulation to the wall clock
  bool progress = false;          // progress line on stderr
  int threads = 0;  // for the sensors of different robots; 0: every core (default_thread_count)
  std::optional<std::filesystem::path> log_file;  // also record the run into one replayable log
  /// The most the run may write (its estimate, output_budget.hpp), --max-output-gib. [bytes]
  std::uint64_t max_output_bytes = kDefaultMaxOutputBytes;
  FrameSink* video = nullptr;  // frames of the run (render/), at video_options' frame times
  VideoOptions video_options;
  LandmarkImagerFactory make_landmark_imager;  // for PTZ cameras in mode: rendered (render/)
};

struct RunResult {
  std::filesystem::path out_dir;
  std::string status;  // completed, interrupted, failed
  double simulated_s = 0.0;
  double wall_s = 0.0;
  std::uint64_t state_hash = 0;
  std::vector<std::string> failed_localizers;  // labels of localizers that failed (exit code 5)
};

/// World and scenario, loaded and checked together. Throws InputError.
struct RunInputs {
  WorldDef world;
  ScenarioDef scenario;
  /// Every file they were read from, as the loaders recorded them: the world, its map's YAML and
  /// image, the scenario file. What a sweep's fingerprint covers.
  std::vector<std::filesystem::path> files;
};
RunInputs load_run_inputs(const std::filesystem::path& world_file,
                          const std::optional<std::filesystem::path>& scenario_file,
                          std::optional<double> duration_s);

/// Runs to the end (or until `*interrupt` turns true). Bad input throws InputError (outputs that
/// cannot all be made, `--out D --log D`, too; and a run estimated past max_output_bytes),
/// plugins that cannot be loaded or created PluginError, too little free disk space for the
/// estimate std::runtime_error, all before any file is written. run.json is the folder's first
/// file ("status": "running"), rewritten at the end. A failure during the run (the first write
/// that fails stops it) removes the files it cut, writes run.json with status "failed", the
/// error and the "removed_files", and rethrows it (naming the file and the system's reason). A
/// localizer that fails does not fail the run: it is in `failed_localizers` and metrics.json.
RunResult run_simulation(const RunOptions& options, const std::atomic<bool>* interrupt = nullptr);

/// The version string recorded in every run.
const char* locsim_version();

}  // namespace locsim
