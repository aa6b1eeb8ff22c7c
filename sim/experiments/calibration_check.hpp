// Whether a calibration describes the robot or the recording (`locsim calibrate` with several
// logs; docs/real_data.md): each log, a recording, is calibrated alone beside the pooled
// calibration of them all; each parameter's spread over the recordings is reported; and each
// localizer checked replays every recording with every recording's parameters (one sweep). Where
// a recording's parameters move a localizer's position RMS on another recording by more than
// `flag_above` of what that recording's own give (or the pooled ones do), the cell is flagged,
// and the parameters are swapped a group at a time (calibration.hpp's parameter_group) to say
// which group moves it.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "sim/common/range.hpp"
#include "sim/metrics/calibration.hpp"

namespace locsim {

struct CalibrationCheckOptions {
  std::vector<std::filesystem::path> logs;  // the recordings, two or more
  CalibrationOptions calibration;           // as for the pooled calibration
  std::filesystem::path pooled_file;        // the pooled calibration.yaml, already written
  std::filesystem::path out_dir;            // recordings/ and transfer/ are made in it
  std::vector<std::string> localizers;      // plugins (by name) that replay; empty: none
  std::vector<std::uint64_t> seeds;         // the localizers' seeds; empty: each log's own
  int jobs = 1;                             // replays at a time
  double flag_above = 0.25;                 // an RMS that moves by more than this is flagged [-]
  static constexpr Range kFlagRange{0.01, 10.0, ""};
  std::filesystem::path locsim_binary;  // runs the replays (default: this process's)
};

/// One log, calibrated alone.
struct CheckedRecording {
  std::string name;  // names its parameters in the sweeps: the log's file stem, as a label
  std::filesystem::path log;
  std::vector<std::string> robots;         // those calibrated and replayed
  std::filesystem::path calibration_file;  // recordings/NAME/calibration.yaml
};

/// One number calibrate writes, over the recordings.
struct ParameterSpread {
  std::string plugin;  // its section's plugin; empty: a value for every localizer
  std::string key, group;
  std::vector<std::optional<double>> values;  // per recording; unset where it wrote none
  std::optional<double> pooled;
  double min = 0.0, max = 0.0;
  double relative = 0.0;  // (max - min) over |pooled| (else the largest |value|) [-]
};

/// A localizer replaying recording `on` with the parameters of recording `from` (unset: the
/// pooled calibration's).
struct TransferCell {
  std::string localizer;
  std::optional<std::size_t> from;
  std::size_t on = 0;
  std::optional<double> rms_m;      // over the recording's robots and the seeds; unset: no result
  std::optional<double> own_rms_m;  // `on` replayed with its own parameters
  std::optional<double> change;     // rms_m / own_rms_m - 1
  // Half-width of the change's 95 % interval over the seeds (the change seed by seed, Student's
  // t); unset with fewer than two seeds. 0 for a filter whose estimates do not depend on its seed.
  std::optional<double> change_ci95;
  std::string problem;  // a run that did not end ok: its status and reason
  // |change| > flag_above, the interval (if any) leaving out zero; or no result where its own has
  // one. Uncertain: beyond flag_above, but the interval holds zero.
  bool flagged = false, uncertain = false;
  struct GroupChange {
    std::string group;
    std::optional<double> change;  // `on`'s own parameters with this group's from `from`
  };
  std::vector<GroupChange> groups;  // flagged cells only; largest |change| first
};

struct CalibrationCheck {
  std::vector<CheckedRecording> recordings;
  std::vector<ParameterSpread> spread;  // the numbers calibrate wrote, in the pooled file's order
  std::vector<std::string> localizers;
  std::vector<std::uint64_t> seeds;
  double flag_above = 0.25;
  std::vector<TransferCell> cells;  // localizer, then from (recordings, then pooled), then on
  bool interrupted = false;         // Ctrl-C during the replays: the cells so far
  std::size_t errors = 0;           // replays locsim could not produce a result for
  /// For calibration.json: "recordings", "spread" and "transfer".
  nlohmann::ordered_json to_json() const;
  /// One line per flagged cell, what moved it included.
  std::vector<std::string> flags() const;
  /// The tables `locsim calibrate` prints.
  std::string describe() const;
};

/// The recordings of `options.logs`, checked as check_calibration does first (so that a driver
/// can refuse bad input before it writes anything): the throws below but the calibrations'.
std::vector<CheckedRecording> checked_recordings(const CalibrationCheckOptions& options);

/// Calibrates each log alone (recordings/NAME/calibration.{yaml,json} in out_dir), then with
/// localizers replays (transfer/: the experiments and their sweeps, which `locsim sweep` and
/// `locsim report` take). out_dir/recordings and out_dir/transfer must not exist. Throws
/// InputError for fewer than two logs, two logs of one file name, a log that holds none of the
/// robots, or a localizer name that cannot label a configuration; PluginError for a plugin that
/// is not found; all before anything is written.
CalibrationCheck check_calibration(const CalibrationCheckOptions& options,
                                   const std::atomic<bool>* interrupt = nullptr);

}  // namespace locsim
