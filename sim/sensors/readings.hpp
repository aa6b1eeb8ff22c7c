// Typed sensor readings, as filters receive them and readings/ logs them. Fields named truth_*
// are the simulator's knowledge for analysis; a filter must never be given them.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "sim/common/math.hpp"

namespace locsim {

// The values are those of the log format (docs/log_format.md): append, never renumber.
enum class SensorKind {
  kEncoders,
  kImu,
  kPtzCamera,
  kOmniCamera,
  kUltrasonic,
  kLaser,
  kRangeBearing
};
inline constexpr std::array kSensorKinds = {
    SensorKind::kEncoders,   SensorKind::kImu,   SensorKind::kPtzCamera,   SensorKind::kOmniCamera,
    SensorKind::kUltrasonic, SensorKind::kLaser, SensorKind::kRangeBearing};
const char* sensor_name(SensorKind kind);  // "encoders", "imu", "ptz_camera", ...
/// The kind of the sensor called `name` (its YAML key), if there is one.
std::optional<SensorKind> sensor_kind(std::string_view name);
/// Every sensor's name, comma-separated, for messages.
std::string sensor_names();

/// What an odometry reading carries: a simulated base reports its wheel ticks and the pose it
/// dead-reckons from them; a real dataset reports what its robot logged (MRCLAM: commanded
/// forward and angular velocity only; others an odometry pose). Bit values of the log format and
/// of the plugin ABI's LOCSIM_ODOMETRY_* (plugins/sdk/include/locsim/localizer.h).
enum OdometryField : std::uint8_t {
  kOdometryTicks = 1u << 0,
  kOdometryPose = 1u << 1,
  kOdometryVelocity = 1u << 2,
};
inline constexpr std::uint8_t kOdometryAllFields =
    kOdometryTicks | kOdometryPose | kOdometryVelocity;
inline constexpr std::array kOdometryFields = {kOdometryTicks, kOdometryPose, kOdometryVelocity};
const char* odometry_field_name(OdometryField field);  // "ticks", "pose", "velocity"
/// The names of the bits set in `fields`, comma-separated ("ticks, pose"), for messages.
std::string odometry_fields_text(std::uint8_t fields);

/// The `encoders` sensor's reading: the fields `fields` names hold values, the others zeros.
struct OdometryReading {
  std::int64_t left_ticks = 0;  // cumulative counts since the start
  std::int64_t right_ticks = 0;
  Pose2 odometry;  // the base's dead-reckoned pose (odom frame = world at t = 0)
  // The base's velocity from this reading's time on (a commanded velocity holds until the next
  // reading; a measured one is the latest measurement) [m/s, rad/s].
  double v_mps = 0.0;
  double omega_radps = 0.0;
  std::uint8_t fields = kOdometryTicks | kOdometryPose;
  bool has(OdometryField field) const { return (fields & field) != 0; }
};

struct ImuReading {
  double yaw_rate_radps = 0.0;
  Vec2 accel_mps2{0.0, 0.0};  // specific force in the IMU frame (x forward, y left)
};

/// What a detection is of. Values of the log format and of the ABI's LOCSIM_TARGET_*.
enum class DetectionTarget : std::uint8_t { kLandmark = 0, kRobot = 1 };
const char* detection_target_name(DetectionTarget target);  // "landmark", "robot"

/// A landmark (or another robot) seen by a camera, relative to the robot frame.
struct Detection {
  std::string color;  // colour name, or "#rrggbb"
  int id = -1;        // landmark id (a robot: its index in the world) when reported, else -1
  double range_m = 0.0;
  double bearing_rad = 0.0;  // counter-clockwise from the robot's x axis
  int truth_id = -1;         // the landmark (robot) it really is; -1 for a false detection
  DetectionTarget target = DetectionTarget::kLandmark;
};

struct PtzReading {
  double pan_rad = 0.0;  // counter-clockwise positive (the paper's panpos is -pan)
  double tilt_rad = 0.0;
  double zoom = 1.0;
  std::vector<Detection> detections;
};

struct OmniReading {
  std::vector<Detection> detections;
};

/// A range-bearing landmark sensor (a camera reading barcodes, as MRCLAM's robots carry).
struct RangeBearingReading {
  std::vector<Detection> detections;
};

enum class RangeStatus { kLineOfSight, kNonLineOfSight, kDropped, kOutOfRange };
const char* range_status_name(RangeStatus status);

struct BeaconRange {
  int receiver = 0;  // index into the sensor's receivers
  int beacon_id = 0;
  double range_m = 0.0;  // NaN when no reading came back
  RangeStatus truth_status = RangeStatus::kLineOfSight;
};

struct UltrasonicReading {
  std::vector<BeaconRange> ranges;
};

struct LaserScan {
  std::vector<float> ranges_m;  // beam i at laser_beam_angle(i, beams, fov) in the mount frame
};

using ReadingData = std::variant<OdometryReading, ImuReading, PtzReading, OmniReading,
                                 UltrasonicReading, LaserScan, RangeBearingReading>;

struct Reading {
  double t_s = 0.0;
  int robot = 0;  // index of the robot in the world
  SensorKind kind = SensorKind::kEncoders;
  ReadingData data;
};

}  // namespace locsim
