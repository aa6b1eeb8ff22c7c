// What `locsim run` and `locsim replay` both wire behind their producer, so that the two give the
// same files and the same metrics for the same records, whatever the options: the localizer host,
// the scorer and the run folder's recorder, fed through one fan-out (the drivers add the log
// writer and frame capture where they apply). docs/architecture.md draws it.
#pragma once

#include <atomic>
#include <chrono>
#include <exception>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "sim/consumers/frame_state.hpp"
#include "sim/consumers/rosbag_recorder.hpp"
#include "sim/consumers/run_recorder.hpp"
#include "sim/metrics/error_metrics.hpp"
#include "sim/metrics/scorer.hpp"
#include "sim/plugin_host/localizer_host.hpp"
#include "sim/scenario/scenario_def.hpp"
#include "sim/stream/record.hpp"

namespace locsim {

/// The options `run` and `replay` share (their command lines share them too).
struct SessionOptions {
  std::vector<std::string> localizers;  // NAME[:key=value,...][@label], each on every robot
  ConvergenceCriterion convergence;     // what "converged" means in metrics.json
  bool isolate = true;                  // each localizer in its own process
  double plugin_timeout_s = 60.0;       // longest one plugin call may take [s]; 0: no limit
  bool readings = true;                 // write readings/ (one CSV per sensor)
  bool overwrite = false;               // allow writing into a non-empty folder
  /// --params: values for every localizer's parameters, below its spec's (plugin_host/param_file)
  std::optional<std::filesystem::path> params_file;
  /// --plugin-memory: what each localizer's process may allocate beyond what it starts with
  /// [bytes]; 0: no limit
  std::uint64_t plugin_memory_bytes = 0;
  /// --rosbag2: also write the stream as a ROS 2 bag into this folder, with every localizer's
  /// estimates and particles (consumers/rosbag_recorder); checked by the driver (check_bag_folder)
  std::optional<std::filesystem::path> rosbag2;
  double rosbag2_particles_hz = 10.0;  // --rosbag2-particles-hz: of simulated time; 0: none [Hz]
};

/// How a run or replay ended: completed, interrupted (Ctrl-C) or failed (with the first error,
/// which the driver rethrows once run.json is written).
struct RunEnd {
  std::string status = "completed";
  std::string error;
  std::exception_ptr failure;
  /// The files a failed write cut, removed (relative to the run folder; an output outside it,
  /// --video, as given): run.json lists them as "removed_files".
  std::vector<std::string> removed;
  bool completed() const { return status == "completed"; }
  /// In a catch block: Interrupted makes it interrupted, anything else failed (the first failure
  /// is the one kept).
  void caught(const std::string& context = "");
};

class Session {
 public:
  /// Parses the specs and the params file, loads the plugins, checks their parameters and creates
  /// every localizer (InputError, PluginError); writes nothing.
  Session(const SessionOptions& options, const WorldDef& world, const ScenarioDef& scenario,
          std::uint64_t seed, const std::atomic<bool>* interrupt);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  /// Makes the run folder (checked beforehand with RunFolder::check) and writes `run_json` into it
  /// first: run.json as known before the run, with "status": "running" (RunFolder::make), held
  /// locked until the session ends (held_by_a_run). Throws when it cannot, leaving nothing of the
  /// folder it made (a previous run's folder as it was).
  void open(const std::filesystem::path& out_dir, const std::string& run_json);
  /// Readies the folder (with overwrite, emptied but for run.json and `keep`, the driver's own
  /// outputs and inputs that lie in it) and opens its files. What fails here fails the run: the
  /// drivers call it where they catch the run's failures, so that run.json says it.
  /// With --rosbag2, also begins the bag (replacing the bag folder --overwrite allows), carrying
  /// `log_header` (the log's header as JSON text, so that `import rosbag2` rebuilds the log).
  void start(const std::vector<std::filesystem::path>& keep = {},
             const std::string& log_header = "");
  /// Every record up to `t_s` has gone into input(), none later: what is due by then from the
  /// localizers' state (the bag's particles) is taken. The drivers call it as the time moves on.
  void records_until(double t_s) {
    if (bag_) bag_->records_until(t_s);
  }
  /// Where the producer's records go: host, scorer, recorder, then what the driver adds.
  RecordFanout& input() { return fanout_; }
  /// Flushes input() (the files' buffers to the system, the records gathered for the localizers'
  /// processes to them) when kFlushEvery of wall-clock time has passed since the last flush: a
  /// run that dies hard (killed, out of memory) keeps all but its last moments, without the
  /// system calls of flushing every simulated second (a 60 s run at 1000x real time flushed 60
  /// times in 0.1 s). The drivers call it between records, at least every simulated second.
  void flush_now_and_then() {
    const auto now = std::chrono::steady_clock::now();
    if (now - flushed_ < kFlushEvery) return;
    fanout_.flush();
    flushed_ = now;
  }
  static constexpr std::chrono::milliseconds kFlushEvery{200};
  LocalizerHost& host() { return *host_; }
  const RunFolder& folder() const { return folder_; }
  bool has_localizers() const { return !host_->localizers().empty(); }

  /// Ends the stream at `t_end_s`. Unless `end` is interrupted, every localizer first takes in
  /// every record (Ctrl-C meanwhile makes it interrupted); else they are stopped where they are.
  /// Closes the files, removes those a failed write cut (into `end.removed`: a cut .tum or CSV
  /// would read as a whole, shorter one), then writes metrics.json (whole or not at all: the
  /// localizers' scores up to the end are kept when the run fails). A failure goes into `end`.
  /// Returns run.json's "localizers" block.
  nlohmann::ordered_json finish(double t_end_s, RunEnd& end);
  /// Rewrites run.json as the run ended (`run`, its status and error from `end`). When that fails
  /// (a full disk has no room for the new file beside the old one), the failure goes into `end`
  /// and the run.json written by open() gets "failed" in place of "running" (the same bytes, so
  /// no more room), so that the folder does not read as a run still going on.
  void write_run_json(const nlohmann::ordered_json& run, RunEnd& end);
  /// Labels of the localizers that failed.
  std::vector<std::string> failed_localizers() const { return scorer_->failed(); }

 private:
  const WorldDef& world_;
  SessionOptions options_;
  std::unique_ptr<LocalizerHost> host_;
  std::unique_ptr<Scorer> scorer_;
  std::unique_ptr<RunRecorder> recorder_;
  OccupancyGrid grid_;  // the static world as the localizers (and the bag's /map) see it
  std::unique_ptr<RosbagRecorder> bag_;
  RunFolder folder_;
  std::size_t running_at_ = std::string::npos;  // where run.json says "running" [byte]
  int run_json_lock_ = -1;                      // run.json as open() wrote it, locked
  RecordFanout fanout_;
  std::chrono::steady_clock::time_point flushed_ = std::chrono::steady_clock::now();
};

/// Closes the video and the frames (FrameSink::finish) whatever the run's status: the frames so
/// far make a valid video of a failed run too. A failure goes into `end`; when it is the video's
/// own (its message names `video_file`: a frame or its index that could not be written), the
/// video may not play (an MP4 without its index) and is removed (into `end.removed`).
void finish_video(FrameSink& sink, const std::optional<std::filesystem::path>& video_file,
                  RunEnd& end);

/// The files a session's localizers read: --params, plugins given by path, their sources (a
/// Python filter's file). The drivers keep them from --overwrite and from being written over.
/// Throws InputError for a malformed --localizer.
std::vector<std::filesystem::path> session_input_files(const SessionOptions& options);

/// Peak resident memory [MB] of this process ("locsim") and of the largest localizer process it
/// has ended ("largest_localizer"), for run.json's wall-clock block.
nlohmann::ordered_json peak_memory_json();

/// run.json's "robots" as known before a run: each robot's name and folder.
nlohmann::ordered_json robots_json(const WorldDef& world);

/// run.json's text as known before a run (Session::open writes it): `run` (the driver's
/// description, "status": "running") with the robots and their folders, the localizers and
/// `config`, which is moved in and back out (a world's configuration can be large).
std::string starting_run_json(nlohmann::ordered_json run, const WorldDef& world, Session& session,
                              nlohmann::ordered_json& config);

}  // namespace locsim
