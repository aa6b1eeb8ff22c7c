#include "sim/run/output_budget.hpp"

#include <algorithm>

#include "sim/world/world_budget.hpp"

namespace locsim {

namespace fs = std::filesystem;

namespace {

// Upper estimates of a row's bytes: readings/'s CSV text and the log's record.
constexpr double kPoseRowBytes = 80.0;          // a TUM row (ground truth, an estimate)
constexpr double kOdometryRowBytes = 120.0;     // CSV row + log record
constexpr double kImuRowBytes = 90.0;           // CSV row + log record
constexpr double kDetectionBytes = 90.0;        // per detection: CSV row + log bytes
constexpr double kBeaconRangeBytes = 60.0;      // per receiver and beacon
constexpr double kLaserBeamCsvBytes = 9.0;      // "12.345 " with room
constexpr double kLaserBeamLogBytes = 4.0;      // a float
constexpr double kReadingOverheadBytes = 40.0;  // a row's time and robot, a record's frame

}  // namespace

OutputEstimate estimate_run_output(const WorldDef& world, const ScenarioDef& scenario,
                                   bool readings, bool log, std::size_t localizers) {
  OutputEstimate estimate;
  const double duration_s = scenario.duration_s;
  const auto part = [&](const RobotDef& robot, const std::string& key, const std::string& what,
                        double bytes) {
    estimate.total_bytes += bytes;
    if (bytes > estimate.largest_bytes) {
      estimate.largest_bytes = bytes;
      estimate.largest_place = InputPlace{robot.where, robot.key_path + key};
      estimate.largest_what = what;
    }
  };
  // What a camera may see at once: every landmark and every other robot.
  const double visible = static_cast<double>(world.landmarks.size() + world.robots.size());
  const double gt_hz = scenario.groundtruth_hz;
  for (const RobotDef& robot : world.robots) {
    const std::string name = "robot '" + robot.name + "''s ";
    part(robot, "", name + "ground truth and " + std::to_string(localizers) + " estimates",
         duration_s * gt_hz * kPoseRowBytes * static_cast<double>(1 + localizers));
    if (!readings && !log) continue;
    const double copies = (readings ? 1.0 : 0.0) + (log ? 1.0 : 0.0);
    const SensorsDef& s = robot.sensors;
    const auto rate = [&](SensorKind kind) {
      const SensorCommon* common = sensor_common(s, kind);
      return common != nullptr && common->enabled ? common->rate_hz * duration_s : 0.0;
    };
    part(robot, ".sensors.encoders", name + "encoders",
         rate(SensorKind::kEncoders) * kOdometryRowBytes);
    part(robot, ".sensors.imu", name + "IMU", rate(SensorKind::kImu) * kImuRowBytes);
    for (const auto& [kind, key] : {std::pair{SensorKind::kPtzCamera, "ptz_camera"},
                                    std::pair{SensorKind::kOmniCamera, "omni_camera"},
                                    std::pair{SensorKind::kRangeBearing, "range_bearing"}}) {
      part(robot, std::string(".sensors.") + key, name + key,
           rate(kind) * (kReadingOverheadBytes + visible * kDetectionBytes) * copies);
    }
    if (s.ultrasonic) {
      part(robot, ".sensors.ultrasonic", name + "ultrasonic receivers",
           rate(SensorKind::kUltrasonic) *
               (kReadingOverheadBytes + static_cast<double>(s.ultrasonic->receivers.size()) *
                                            static_cast<double>(world.beacons.size()) *
                                            kBeaconRangeBytes) *
               copies);
    }
    if (s.laser) {
      const double beam_bytes =
          (readings ? kLaserBeamCsvBytes : 0.0) + (log ? kLaserBeamLogBytes : 0.0);
      part(robot, ".sensors.laser",
           name + std::to_string(s.laser->beams) + "-beam laser at " +
               std::to_string(static_cast<long long>(s.laser->common.rate_hz)) + " Hz",
           rate(SensorKind::kLaser) *
               (kReadingOverheadBytes * copies + static_cast<double>(s.laser->beams) * beam_bytes));
    }
  }
  return estimate;
}

void check_run_output(const OutputEstimate& estimate, std::uint64_t max_bytes,
                      const fs::path& out_dir) {
  const std::string size = "the run would write about " + format_bytes(estimate.total_bytes) +
                           " (the largest part, " + estimate.largest_what + ", about " +
                           format_bytes(estimate.largest_bytes) + ")";
  if (estimate.total_bytes > static_cast<double>(max_bytes)) {
    throw InputError(estimate.largest_place,
                     size + "; a run writes at most " +
                         format_bytes(static_cast<double>(max_bytes)) +
                         " unless --max-output-gib allows more (or pass --no-readings, a shorter "
                         "--duration, a lower rate)");
  }
  // The free space where the folder will be: its nearest existing ancestor's filesystem.
  fs::path existing = fs::absolute(out_dir);
  while (!existing.empty() && !fs::exists(existing) && existing != existing.parent_path())
    existing = existing.parent_path();
  std::error_code error;
  const fs::space_info space = fs::space(existing, error);
  if (!error && estimate.total_bytes > static_cast<double>(space.available)) {
    throw InputError(estimate.largest_place,
                     size + ", more than the " +
                         format_bytes(static_cast<double>(space.available)) +
                         " free on the disk of " + existing.string());
  }
}

}  // namespace locsim
