// Typed sensor readings, as filters receive them and readings/ logs them. Fields named truth_*
// are the simulator's knowledge for analysis; a filter must never be given them.
#pragma once

#include <cstdint>
#include <string>
#include <variant>
#include <vector>

#include "sim/common/math.hpp"

namespace locsim {

enum class SensorKind { kEncoders, kImu, kPtzCamera, kOmniCamera, kUltrasonic, kLaser };
const char* sensor_name(SensorKind kind);  // "encoders", "imu", "ptz_camera", ...

struct EncoderReading {
  std::int64_t left_ticks = 0;  // cumulative counts since the start
  std::int64_t right_ticks = 0;
  Pose2 odometry;  // the base's dead-reckoned pose from the counts (odom frame = world at t = 0)
};

struct ImuReading {
  double yaw_rate_radps = 0.0;
  Vec2 accel_mps2{0.0, 0.0};  // specific force in the IMU frame (x forward, y left)
};

/// A landmark seen by a camera, relative to the robot frame.
struct Detection {
  std::string color;  // colour name, or "#rrggbb"
  int id = -1;        // landmark id when the camera reports ids, else -1
  double range_m = 0.0;
  double bearing_rad = 0.0;  // counter-clockwise from the robot's x axis
  int truth_id = -1;         // the landmark it really is; -1 for a false detection
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

using ReadingData =
    std::variant<EncoderReading, ImuReading, PtzReading, OmniReading, UltrasonicReading, LaserScan>;

struct Reading {
  double t_s = 0.0;
  int robot = 0;  // index of the robot in the world
  SensorKind kind = SensorKind::kEncoders;
  ReadingData data;
};

}  // namespace locsim
