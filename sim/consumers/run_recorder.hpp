// The run folder's recorder: a consumer of the record stream and of the localizers' estimates
// that writes groundtruth.tum and readings/ (per robot), events.csv, and each localizer's
// LABEL.tum, flushed as the session says (Session::flush_now_and_then: every 0.2 s of wall-clock
// time), so that a run killed hard keeps all but its last moments (whole rows: what goes to the
// system is whole rows). A file whose write fails (a full disk, a file-size limit) may end
// mid-row: it is marked cut, and removed when the run ends (RunRecorder::remove_cut), so that no
// later reader takes it for a whole, shorter file; run.json lists it.
#pragma once

#include <array>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "sim/common/files.hpp"
#include "sim/stream/estimates.hpp"
#include "sim/stream/record.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

/// A run's folder: the root, and each robot's folder (the root itself with one robot, else a
/// sub-folder named after the robot).
///
/// A run folder is recognisable as one from the moment it is made: its run.json is the first file
/// written into it, saying "status": "running", and is rewritten when the run ends (completed,
/// interrupted, failed). A folder left by a run that was killed, or that failed, holds a run.json
/// and so is emptied by --overwrite like any run's; a folder without one never is, nor one whose
/// run is still going on (held_by_a_run).
struct RunFolder {
  std::filesystem::path root;
  std::vector<std::filesystem::path> robot_dirs;

  /// An output named on the command line, as check_apart() takes it: option, path, and whether
  /// it is a folder (--frames) or a file (--log, --video).
  struct Output {
    std::string option;
    std::filesystem::path path;
    bool folder = false;
  };

  /// Refuses (InputError) a path that is not a folder, and a non-empty folder without
  /// `overwrite`, or with it one that holds no run.json of locsim's (a JSON object that begins
  /// with "locsim_version"), or whose run is still going on (held_by_a_run): --overwrite empties
  /// a run folder, and a folder of the user's that only looks like one is never emptied. `inputs`
  /// are the files the command reads (the world, the log it replays, --params, a plugin's source):
  /// --overwrite keeps one that lies in the folder, and refuses one where the run writes a file of
  /// its own (run.json, metrics.json, events.csv, a .tum or _map.csv, readings/), which the run
  /// would overwrite. Writes nothing.
  static void check(const std::filesystem::path& root, bool overwrite,
                    const std::vector<std::filesystem::path>& inputs = {});
  /// Refuses (InputError) an output named on the command line (`outputs`: option and path, e.g.
  /// {"--log", "x.locsimlog"}) that is one of `inputs` (the same file by any name or link):
  /// opening it would destroy what the command is about to read.
  static void check_outputs(
      const std::vector<std::pair<std::string, std::filesystem::path>>& outputs,
      const std::vector<std::filesystem::path>& inputs);
  /// Refuses (InputError) outputs that cannot all be made: a file output that is the run folder
  /// `root`, another output, or a folder that exists, or that lies above one of them (a file
  /// cannot hold a folder: `--out D --log D`, `--out D/run --log D`), or that lies in the run
  /// folder where the run writes a file of its own (`--log D/run.json`). Writes nothing.
  static void check_apart(const std::filesystem::path& root, const std::vector<Output>& outputs);

  /// A robot's folder, relative to the run folder: "." with one robot, else its name.
  static std::filesystem::path robot_folder(const WorldDef& world, std::size_t robot);

  /// Makes the folder (and its missing parents) and writes `run_json` (the run's description as
  /// known before it starts, "status": "running") into it before anything else, replacing a
  /// previous run's (checked beforehand with check()). Throws, naming run.json and the system's
  /// reason, when it cannot: what it made is removed again, and a previous run's folder is left
  /// as it was. Makes no other folder.
  static RunFolder make(const std::filesystem::path& root, const WorldDef& world,
                        std::string_view run_json);
  /// With `overwrite`, empties the folder but for run.json and `keep` (a previous run's LABEL.tum
  /// or readings/ must not stand beside the new ones): files this same command writes into it
  /// (--log, --video, --frames) or reads (its inputs, as for check()). Then makes the robots'
  /// folders.
  void prepare(bool overwrite, const std::vector<std::filesystem::path>& keep = {}) const;
};

/// Whether a run still going on holds `run_json`: from RunFolder::make to its end a run keeps its
/// run.json locked (flock, released by the system however the process ends: a run killed with
/// SIGKILL holds nothing), so that --overwrite never empties the folder of a live run.
bool held_by_a_run(const std::filesystem::path& run_json);

class RunRecorder final : public RecordConsumer, public EstimateConsumer {
 public:
  /// Opens every file. `readings`: also readings/ per robot (one CSV per sensor, sensors.json).
  /// When one cannot be written, those it had made are removed and it throws (as OutputFile).
  RunRecorder(const RunFolder& folder, const WorldDef& world,
              const std::vector<LocalizerInfo>& localizers, bool readings);

  /// The first write that fails throws (as OutputFile: the path and the system's reason), and
  /// marks its file cut: what follows for it is dropped.
  void consume(const Record& record) override;
  void flush() override;
  void estimate(const EstimateSample& sample) override;
  void failure(const LocalizerFailure&) override {}
  /// Flushes and closes every file, each on its own (one that cannot be written costs the others
  /// nothing); then throws the first failure, if any.
  void close();
  /// Removes the files a failed write cut (they may end mid-row: no later reader must take one
  /// for a whole file); returns their paths relative to the run folder.
  std::vector<std::string> remove_cut();

 private:
  /// An OutputFile that remembers whether a write to it failed.
  class File {
   public:
    explicit File(std::filesystem::path path);
    void write(std::string_view text) {
      if (cut_) return;
      try {
        out_.write(text);
      } catch (...) {
        cut_ = true;
        throw;
      }
    }
    void flush();
    void close();
    bool cut() const { return cut_; }
    const std::filesystem::path& path() const { return path_; }

   private:
    std::filesystem::path path_;
    OutputFile out_;
    bool cut_ = false;
  };
  /// Every file, for flush(), close() and remove_cut().
  template <typename Visit>
  void for_each_file(Visit visit);
  void write_reading(const Reading& reading);
  std::filesystem::path root_;
  std::vector<std::unique_ptr<File>> groundtruth_;  // by robot
  // By robot, SensorKind.
  std::vector<std::array<std::unique_ptr<File>, kSensorKinds.size()>> readings_;
  std::vector<bool> reports_velocity_;            // by robot: odometry.csv has the velocity columns
  std::vector<std::unique_ptr<File>> estimates_;  // by localizer
  std::unique_ptr<File> events_;
  std::string line_;
};

}  // namespace locsim
