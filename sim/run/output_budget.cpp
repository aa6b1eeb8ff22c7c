#include "sim/run/output_budget.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "sim/world/world_budget.hpp"

namespace locsim {

namespace fs = std::filesystem;

namespace {

// Upper estimates of a row's or a record's bytes, per copy: readings/'s CSV text, the log's record.
constexpr double kPoseRowBytes = 80.0;          // a TUM row (ground truth, an estimate), a record
constexpr double kOdometryRowBytes = 100.0;     // CSV row, or log record
constexpr double kImuRowBytes = 70.0;           // CSV row, or log record
constexpr double kDetectionBytes = 90.0;        // per detection: CSV row, or log bytes
constexpr double kBeaconRangeBytes = 60.0;      // per receiver and beacon
constexpr double kLaserBeamCsvBytes = 9.0;      // "12.345 " with room
constexpr double kLaserBeamLogBytes = 4.0;      // a float
constexpr double kReadingOverheadBytes = 40.0;  // a row's time and robot, a record's frame
constexpr double kEventRowBytes = 200.0;        // events.csv row, or log record
// events.csv's collisions: a robot's are at least Simulation::kCollisionQuietS apart per body it
// touches; one a second is counted.
constexpr double kCollisionsPerS = 1.0;
// metrics.json: a localizer's block, and a segment's per kidnap.
constexpr double kMetricsBytes = 16.0 * 1024.0;
constexpr double kMetricsSegmentBytes = 1024.0;
// What run.json holds at the end beyond what it held at the start: per robot its final pose and
// totals, per localizer its summary, the timing.
constexpr double kRunJsonEndBytes = 4096.0;
constexpr double kRunJsonRobotBytes = 1024.0;
constexpr double kRunJsonLocalizerBytes = 256.0;

/// A destination of the run's bytes, with its name for messages.
struct Target {
  std::string name;
  fs::path path;
  double bytes;
};

/// The nearest existing folder or file at or above `path` (absolute).
fs::path nearest_existing(const fs::path& path) {
  std::error_code error;
  fs::path at = fs::absolute(path, error);
  if (error) at = path;
  while (!at.empty() && !fs::exists(at, error) && at != at.parent_path()) at = at.parent_path();
  return at;
}

}  // namespace

double json_text_bytes(const nlohmann::ordered_json& value) {
  using Value = nlohmann::ordered_json;  // not `json`: a unity batch may declare that one
  const auto string_bytes = [](const std::string& text) {
    double bytes = 2.0;  // the quotes
    for (const char c : text) {
      const auto u = static_cast<unsigned char>(c);
      bytes += c == '"' || c == '\\' ? 2.0 : u < 0x20 ? 6.0 : 1.0;
    }
    return bytes;
  };
  switch (value.type()) {
    case Value::value_t::string:
      return string_bytes(value.get_ref<const std::string&>());
    case Value::value_t::array: {
      double bytes = 2.0;
      for (const Value& element : value) bytes += json_text_bytes(element) + 1.0;
      return bytes;
    }
    case Value::value_t::object: {
      double bytes = 2.0;
      for (const auto& [key, element] : value.items())
        bytes += string_bytes(key) + 1.0 + json_text_bytes(element) + 1.0;
      return bytes;
    }
    case Value::value_t::binary:
      return 2.0 * static_cast<double>(value.get_binary().size()) + 64.0;
    default:  // numbers, booleans, null
      return 32.0;
  }
}

OutputEstimate estimate_run_output(const WorldDef& world, const ScenarioDef& scenario,
                                   const OutputPlan& plan) {
  OutputEstimate estimate;
  const double duration_s = scenario.duration_s;
  // A part: bytes into the run folder and into the log, decided by `place` (or by `option`).
  const auto part = [&](const InputPlace& place, const std::string& option, const std::string& what,
                        double folder, double log) {
    estimate.folder_bytes += folder;
    estimate.log_bytes += log;
    estimate.total_bytes += folder + log;
    if (folder + log > estimate.largest_bytes) {
      estimate.largest_bytes = folder + log;
      estimate.largest_place = place;
      estimate.largest_option = option;
      estimate.largest_what = what;
    }
  };
  const double log_copy = plan.log ? 1.0 : 0.0;
  const double csv_copy = plan.readings ? 1.0 : 0.0;
  const auto localizers = static_cast<double>(plan.localizers);
  // What a camera may see at once: every landmark and every other robot.
  const double visible = static_cast<double>(world.landmarks.size() + world.robots.size());
  const double gt_rows = duration_s * scenario.groundtruth_hz;
  for (const RobotDef& robot : world.robots) {
    const std::string name = "robot '" + robot.name + "''s ";
    const auto place = [&](const std::string& key) {
      return InputPlace{robot.where, robot.key_path + key};
    };
    part(place(""), "", name + "ground truth and " + std::to_string(plan.localizers) + " estimates",
         gt_rows * kPoseRowBytes * (1.0 + localizers), gt_rows * kPoseRowBytes * log_copy);
    if (!plan.readings && !plan.log) continue;
    const SensorsDef& s = robot.sensors;
    const auto rows = [&](SensorKind kind) {
      const SensorCommon* common = sensor_common(s, kind);
      return common != nullptr && common->enabled ? common->rate_hz * duration_s : 0.0;
    };
    const double odometry = rows(SensorKind::kEncoders) * kOdometryRowBytes;
    part(place(".sensors.encoders"), "", name + "encoders", odometry * csv_copy,
         odometry * log_copy);
    const double imu = rows(SensorKind::kImu) * kImuRowBytes;
    part(place(".sensors.imu"), "", name + "IMU", imu * csv_copy, imu * log_copy);
    for (const auto& [kind, key] : {std::pair{SensorKind::kPtzCamera, "ptz_camera"},
                                    std::pair{SensorKind::kOmniCamera, "omni_camera"},
                                    std::pair{SensorKind::kRangeBearing, "range_bearing"}}) {
      const double bytes = rows(kind) * (kReadingOverheadBytes + visible * kDetectionBytes);
      part(place(std::string(".sensors.") + key), "", name + key, bytes * csv_copy,
           bytes * log_copy);
    }
    if (s.ultrasonic) {
      const double bytes = rows(SensorKind::kUltrasonic) *
                           (kReadingOverheadBytes +
                            static_cast<double>(s.ultrasonic->receivers.size()) *
                                static_cast<double>(world.beacons.size()) * kBeaconRangeBytes);
      part(place(".sensors.ultrasonic"), "", name + "ultrasonic receivers", bytes * csv_copy,
           bytes * log_copy);
    }
    if (s.laser) {
      const double scans = rows(SensorKind::kLaser);
      const double beams = static_cast<double>(s.laser->beams);
      part(place(".sensors.laser"), "",
           name + std::to_string(s.laser->beams) + "-beam laser at " +
               std::to_string(static_cast<long long>(s.laser->common.rate_hz)) + " Hz",
           scans * (kReadingOverheadBytes + beams * kLaserBeamCsvBytes) * csv_copy,
           scans * (kReadingOverheadBytes + beams * kLaserBeamLogBytes) * log_copy);
    }
  }
  // events.csv (always) and the log's events: the scenario's, and collisions.
  const double kidnaps = static_cast<double>(
      std::count_if(scenario.events.begin(), scenario.events.end(),
                    [](const EventDef& e) { return e.kind == EventDef::Kind::kKidnap; }));
  const double events = (2.0 * static_cast<double>(scenario.events.size()) + 1.0 +
                         kCollisionsPerS * duration_s * static_cast<double>(world.robots.size())) *
                        kEventRowBytes;
  const SourceLocation scenario_file{
      (scenario.source.empty() ? world.source : scenario.source).string()};
  part(InputPlace{scenario_file, scenario.source.empty() ? "scenario.events" : "events"}, "",
       "events.csv (the scenario's events, collisions)", events, events * log_copy);
  // metrics.json: whole or absent, never large; counted, not a part to name.
  const double metrics = localizers * (kMetricsBytes + kidnaps * kMetricsSegmentBytes);
  estimate.folder_bytes += metrics;
  estimate.total_bytes += metrics;
  // run.json: written when the folder is made and rewritten at the end, through a temporary file
  // beside it (both on the disk for a moment). Its size is the world's: movers' paths.
  const double run_json = 2.0 * (plan.run_json_bytes + kRunJsonEndBytes +
                                 static_cast<double>(world.robots.size()) *
                                     (kRunJsonRobotBytes + localizers * kRunJsonLocalizerBytes));
  part(InputPlace{SourceLocation{world.source.string()}, ""}, "",
       "run.json, which holds the world and scenario resolved (twice, for a moment, as it is "
       "rewritten at the end)",
       run_json, 0.0);
  if (plan.log) part(InputPlace{}, "--log", "the log's header", 0.0, plan.log_header_bytes);
  if (plan.video != nullptr) {
    const VideoOptions& video = *plan.video;
    const double frames = std::floor(duration_s * video.fps / video.speed + 1e-9) + 1.0;
    const double pixels = static_cast<double>(video.width_px) * video.height_px;
    const std::string size =
        std::to_string(video.width_px) + "x" + std::to_string(video.height_px) + " frames";
    const auto add = [&](double& into, double bytes, const std::string& option,
                         const std::string& what) {
      into += bytes;
      estimate.total_bytes += bytes;
      if (bytes > estimate.largest_bytes) {
        estimate.largest_bytes = bytes;
        estimate.largest_place = InputPlace{};
        estimate.largest_option = option;
        estimate.largest_what = what;
      }
    };
    const std::string count = std::to_string(static_cast<long long>(frames));
    if (video.video_file) {
      add(estimate.video_bytes,
          (frames * kVideoBitsPerPixel + kVideoFirstFrameBitsPerPixel) * pixels / 8.0, "--video",
          "the video, " + count + " " + size);
    }
    if (video.frames_dir) {
      add(estimate.frames_bytes, frames * kPngBitsPerPixel * pixels / 8.0, "--frames",
          count + " PNG " + size);
    }
  }
  return estimate;
}

void check_run_output(const OutputEstimate& estimate, std::uint64_t max_bytes,
                      const OutputPaths& paths) {
  const std::string largest = "the largest part, " + estimate.largest_what + ", about " +
                              format_bytes(estimate.largest_bytes);
  if (estimate.total_bytes > static_cast<double>(max_bytes)) {
    const bool video =
        estimate.largest_option == "--video" || estimate.largest_option == "--frames";
    const bool run_json = estimate.largest_option.empty() && estimate.largest_place.key.empty();
    const std::string problem =
        "the run would write about " + format_bytes(estimate.total_bytes) + " (" + largest +
        "); a run writes at most " + format_bytes(static_cast<double>(max_bytes)) +
        " unless --max-output-gib allows more (or " +
        (video      ? "pass a smaller --video-size, a lower --video-fps, a higher --video-speed"
         : run_json ? "give the movers fewer path points"
                    : "pass --no-readings, a shorter --duration, a lower rate") +
        ")";
    if (!estimate.largest_place.where.file.empty())
      throw InputError(estimate.largest_place, problem);
    throw InputError(estimate.largest_option + ": " + problem);
  }
  // The free space where each output goes, by disk: its nearest existing ancestor's filesystem.
  // Not enough of it is the machine's state, not the input's fault: exit 1, naming the paths.
  std::vector<Target> targets{{"the run folder", paths.out_dir, estimate.folder_bytes}};
  if (paths.log_file) targets.push_back({"--log", *paths.log_file, estimate.log_bytes});
  if (paths.video_file) targets.push_back({"--video", *paths.video_file, estimate.video_bytes});
  if (paths.frames_dir) targets.push_back({"--frames", *paths.frames_dir, estimate.frames_bytes});
  struct Disk {
    dev_t device;
    fs::path existing;
    double bytes = 0.0;
    std::string parts;
    double freed = 0.0;  // by --overwrite
  };
  std::vector<Disk> disks;
  for (const Target& target : targets) {
    if (target.bytes <= 0.0) continue;
    // A device or a FIFO (--log /dev/null) takes no room on a disk.
    std::error_code error;
    const fs::file_status status = fs::status(target.path, error);
    if (fs::exists(status) && !fs::is_regular_file(status) && !fs::is_directory(status)) continue;
    const fs::path existing = nearest_existing(target.path);
    struct stat info {};
    if (existing.empty() || ::stat(existing.c_str(), &info) != 0) continue;
    auto disk = std::find_if(disks.begin(), disks.end(),
                             [&](const Disk& d) { return d.device == info.st_dev; });
    if (disk == disks.end())
      disk = disks.insert(disks.end(), Disk{info.st_dev, existing, 0.0, "", 0.0});
    disk->bytes += target.bytes;
    if (&target == &targets.front()) disk->freed += paths.out_dir_freed_bytes;
    disk->parts += std::string(disk->parts.empty() ? "" : ", ") + "about " +
                   format_bytes(target.bytes) + " into " + target.name + " '" +
                   target.path.string() + "'";
  }
  for (const Disk& disk : disks) {
    std::error_code error;
    const fs::space_info space = fs::space(disk.existing, error);
    // A filesystem of no size (/proc) holds no files of a run: writing there fails as it will.
    if (error || space.capacity == 0 ||
        disk.bytes <= static_cast<double>(space.available) + disk.freed)
      continue;
    // The largest part is named when every output goes onto this one disk.
    throw std::runtime_error(
        "not enough free disk space: the run would write " + disk.parts +
        (disks.size() == 1 ? " (" + largest + ")" : std::string()) + ", more than the " +
        format_bytes(static_cast<double>(space.available)) + " free on the disk of " +
        disk.existing.string() +
        (disk.freed > 0.0 ? " (and " + format_bytes(disk.freed) + " that --overwrite frees)"
                          : std::string()) +
        "; free some space there or write elsewhere (nothing was written)");
  }
}

}  // namespace locsim
