// The run folder's recorder: a consumer of the record stream and of the localizers' estimates
// that writes groundtruth.tum and readings/ (per robot), events.csv, and each localizer's
// LABEL.tum, flushed as the session says (Session::flush_now_and_then: every 0.2 s of wall-clock
// time), so that a run killed hard keeps all but its last moments.
#pragma once

#include <array>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "sim/common/files.hpp"
#include "sim/stream/estimates.hpp"
#include "sim/stream/record.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

/// A run's folder: the root, and each robot's folder (the root itself with one robot, else a
/// sub-folder named after the robot).
struct RunFolder {
  std::filesystem::path root;
  std::vector<std::filesystem::path> robot_dirs;

  /// Refuses (InputError) a path that is not a folder, and a non-empty folder without
  /// `overwrite`, or with it one that holds no run.json: --overwrite empties a run folder, and a
  /// folder of the user's that only looks like one is never emptied. `inputs` are the files the
  /// command reads (the world, the log it replays, --params, a plugin's source): --overwrite
  /// keeps one that lies in the folder, and refuses one where the run writes a file of its own
  /// (run.json, metrics.json, events.csv, a .tum or _map.csv, readings/), which the run would
  /// overwrite. Writes nothing.
  static void check(const std::filesystem::path& root, bool overwrite,
                    const std::vector<std::filesystem::path>& inputs = {});
  /// Refuses (InputError) an output named on the command line (`outputs`: option and path, e.g.
  /// {"--log", "x.locsimlog"}) that is one of `inputs` (the same file by any name or link):
  /// opening it would destroy what the command is about to read.
  static void check_outputs(
      const std::vector<std::pair<std::string, std::filesystem::path>>& outputs,
      const std::vector<std::filesystem::path>& inputs);
  /// With `overwrite`, first empties the folder (a previous run's LABEL.tum or readings/ must not
  /// stand beside the new ones), except `keep`: files this same command writes into it (--log,
  /// --video, --frames) or reads (its inputs, as for check()). Then makes the folders.
  static RunFolder create(const std::filesystem::path& root, const WorldDef& world,
                          bool overwrite = false,
                          const std::vector<std::filesystem::path>& keep = {});
};

class RunRecorder final : public RecordConsumer, public EstimateConsumer {
 public:
  /// Opens every file. `readings`: also readings/ per robot (one CSV per sensor, sensors.json).
  RunRecorder(const RunFolder& folder, const WorldDef& world,
              const std::vector<LocalizerInfo>& localizers, bool readings);

  void consume(const Record& record) override;
  void flush() override;
  void estimate(const EstimateSample& sample) override;
  void failure(const LocalizerFailure&) override {}
  /// Flushes and closes every file (checked).
  void close();

 private:
  void write_reading(const Reading& reading);
  std::vector<std::unique_ptr<OutputFile>> groundtruth_;  // by robot
  // By robot, SensorKind.
  std::vector<std::array<std::unique_ptr<OutputFile>, kSensorKinds.size()>> readings_;
  std::vector<bool> reports_velocity_;  // by robot: odometry.csv has the velocity columns
  std::vector<std::unique_ptr<OutputFile>> estimates_;  // by localizer
  std::unique_ptr<OutputFile> events_;
  std::string line_;
};

}  // namespace locsim
