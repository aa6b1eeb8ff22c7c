#include "sim/run/session.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/resource.h>
#include <unistd.h>

#include <fstream>
#include <string_view>

#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/world/occupancy.hpp"
#include "sim/world/physics_world.hpp"

namespace locsim {

Session::Session(const SessionOptions& options, const WorldDef& world, const ScenarioDef& scenario,
                 std::uint64_t seed, const std::atomic<bool>* interrupt)
    : world_(world), options_(options) {
  std::shared_ptr<const ParamFile> params_file;
  if (options.params_file)
    params_file = std::make_shared<const ParamFile>(load_param_file(*options.params_file));
  std::vector<LocalizerSpec> specs;
  for (const std::string& text : options.localizers) {
    specs.push_back(parse_localizer_spec(text));
    specs.back().params_file = params_file;
  }
  if (!specs.empty() || options.rosbag2) {
    // The static world only, rasterized as the localizers see it (no robot moves in it).
    const PhysicsWorld physics(world);
    grid_ = rasterize_static_world(physics, scenario.localization.grid_resolution_m);
  }
  HostOptions host;
  host.isolate = options.isolate;
  host.plugin_timeout_s = options.plugin_timeout_s;
  host.plugin_memory_bytes = options.plugin_memory_bytes;
  host.interrupt = interrupt;
  host_ = std::make_unique<LocalizerHost>(specs, world, scenario.localization, grid_, seed, host);
  scorer_ = std::make_unique<Scorer>(world, host_->localizers(), options.convergence, &grid_);
}

std::vector<std::filesystem::path> session_input_files(const SessionOptions& options) {
  std::vector<std::filesystem::path> files;
  if (options.params_file) files.push_back(*options.params_file);
  for (const std::string& text : options.localizers) {
    const LocalizerSpec spec = parse_localizer_spec(text);
    // A plugin and a loader's source given as files (one found by name is installed elsewhere).
    for (const std::string& file : {spec.plugin, spec.source}) {
      std::error_code error;
      if (!file.empty() && std::filesystem::is_regular_file(file, error)) files.push_back(file);
    }
  }
  return files;
}

Session::~Session() {
  if (run_json_lock_ >= 0) ::close(run_json_lock_);  // releases the lock
}

void Session::open(const std::filesystem::path& out_dir, const std::string& run_json) {
  folder_ = RunFolder::make(out_dir, world_, run_json);
  // The localizers' processes were forked before: they do not hold it.
  run_json_lock_ = ::open((out_dir / "run.json").c_str(), O_RDONLY | O_CLOEXEC);
  if (run_json_lock_ >= 0) ::flock(run_json_lock_, LOCK_EX | LOCK_NB);
  const std::size_t status = run_json.find("\"status\": \"running\"");
  running_at_ = status == std::string::npos ? status : status + 10;  // past `"status": `
}

void Session::start(const std::vector<std::filesystem::path>& keep, const std::string& log_header) {
  folder_.prepare(options_.overwrite, keep);
  recorder_ =
      std::make_unique<RunRecorder>(folder_, world_, host_->localizers(), options_.readings);
  host_->add_output(*scorer_);
  host_->add_output(*recorder_);
  fanout_.add(*host_);  // first: workers get each record as early as possible
  fanout_.add(*scorer_);
  fanout_.add(*recorder_);
  if (options_.rosbag2) {
    const std::filesystem::path& dir = *options_.rosbag2;
    // The driver checked that it is a bag folder --overwrite may replace.
    if (std::filesystem::exists(dir)) std::filesystem::remove_all(dir);
    RosbagRecorderOptions bag;
    bag.log_header = log_header;
    bag_ = std::make_unique<RosbagRecorder>(dir, world_, grid_, bag);
    bag_->add_localizers(host_->localizers(), host_.get(), options_.rosbag2_particles_hz);
    host_->add_output(*bag_);
    fanout_.add(*bag_);
  }
}

void RunEnd::caught(const std::string& context) {
  try {
    throw;
  } catch (const Interrupted&) {
    if (!failure) status = "interrupted";
  } catch (const std::exception& e) {
    if (failure) return;
    status = "failed";
    error = context + e.what();
    failure = std::current_exception();
  }
}

nlohmann::ordered_json Session::finish(double t_end_s, RunEnd& end) {
  std::vector<LocalizerFinal> finals(host_->localizers().size());
  try {
    // Only Ctrl-C stops the localizers where they are; otherwise (a failed run too) they take in
    // every record sent so far, so that the outputs end at the same instant.
    if (end.status != "interrupted" || !options_.isolate) {
      finals = host_->finish(t_end_s);
    } else {
      host_->abort();
    }
  } catch (...) {
    end.caught();
    host_->abort();
  }
  // Each output on its own: a file that cannot be written costs the others nothing. The
  // recorder's files first: those a failed write cut are removed (on a full disk that frees their
  // room) before metrics.json is written.
  // The bag of a run that failed or was interrupted too: a valid bag up to there, as the video.
  if (bag_) {
    try {
      bag_->finish();
    } catch (...) {
      end.caught();
    }
  }
  nlohmann::ordered_json localizers = nlohmann::ordered_json::array();
  if (!recorder_) return localizers;  // the run failed before its files were opened
  try {
    recorder_->close();
  } catch (...) {
    end.caught();
  }
  for (std::string& file : recorder_->remove_cut()) end.removed.push_back(std::move(file));
  try {
    if (!host_->localizers().empty()) localizers = scorer_->write(folder_.robot_dirs, finals);
  } catch (...) {
    end.caught();
  }
  return localizers;
}

namespace {

/// Turns the "running" at byte `at` of run.json into "failed" (with a space after it, as JSON
/// allows), writing over the same bytes. False when the file does not say "running" there or
/// cannot be written.
bool mark_failed_in_place(const std::filesystem::path& file, std::size_t at) {
  if (at == std::string::npos) return false;
  std::fstream io(file, std::ios::in | std::ios::out | std::ios::binary);
  char was[9] = {};
  io.seekg(static_cast<std::streamoff>(at));
  io.read(was, sizeof was);
  if (!io || std::string_view(was, sizeof was) != "\"running\"") return false;
  io.seekp(static_cast<std::streamoff>(at));
  io.write("\"failed\" ", sizeof was);
  io.flush();
  return static_cast<bool>(io);
}

}  // namespace

void Session::write_run_json(const nlohmann::ordered_json& run, RunEnd& end) {
  const std::filesystem::path file = folder_.root / "run.json";
  try {
    write_json_atomically(file, run);
  } catch (...) {
    end.caught();
    mark_failed_in_place(file, running_at_);
  }
}

void finish_video(FrameSink& sink, const std::optional<std::filesystem::path>& video_file,
                  RunEnd& end) {
  try {
    sink.finish();
  } catch (const std::exception& e) {
    end.caught("video: ");
    std::error_code ignored;
    if (video_file &&
        std::string_view(e.what()).find("video '" + video_file->string() + "'") !=
            std::string_view::npos &&
        std::filesystem::remove(*video_file, ignored)) {
      end.removed.push_back(video_file->string());
    }
  } catch (...) {
    end.caught("video: ");
  }
}

nlohmann::ordered_json peak_memory_json() {
  rusage self{}, children{};
  ::getrusage(RUSAGE_SELF, &self);
  ::getrusage(RUSAGE_CHILDREN, &children);
  // ru_maxrss is in KiB on Linux.
  return {{"locsim", static_cast<double>(self.ru_maxrss) / 1024.0},
          {"largest_localizer", static_cast<double>(children.ru_maxrss) / 1024.0}};
}

nlohmann::ordered_json robots_json(const WorldDef& world) {
  nlohmann::ordered_json robots = nlohmann::ordered_json::array();
  for (std::size_t i = 0; i < world.robots.size(); ++i) {
    robots.push_back(
        {{"name", world.robots[i].name}, {"folder", RunFolder::robot_folder(world, i).string()}});
  }
  return robots;
}

std::string starting_run_json(nlohmann::ordered_json run, const WorldDef& world, Session& session,
                              nlohmann::ordered_json& config) {
  using Json = nlohmann::ordered_json;
  run["robots"] = robots_json(world);
  if (session.has_localizers()) {
    Json localizers = Json::array();
    for (const LocalizerInfo& l : session.host().localizers())
      localizers.push_back({{"robot", l.robot_name}, {"label", l.label}});
    run["localizers"] = std::move(localizers);
  }
  run["config"] = std::move(config);
  std::string text = run.dump(2) + '\n';
  config = std::move(run["config"]);
  return text;
}

}  // namespace locsim
