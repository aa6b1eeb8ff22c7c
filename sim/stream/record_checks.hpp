// What a record entering the stream from outside (a log, an imported dataset) may hold: the same
// ranges as a world file's numbers (common/range.hpp), and the order the stream promises
// (stream/record.hpp). A simulation's records always pass; a log with valid checksums but a NaN
// time, a pose 1e30 m away or a time that goes back would otherwise reach the localizers and the
// scorer (an RMS of 6e27 m, a `nan` row in groundtruth.tum).
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "sim/common/range.hpp"
#include "sim/stream/record.hpp"

namespace locsim {

/// Speeds a reading may report (odometry's v; an IMU's acceleration). [m/s, m/s^2]
inline constexpr Range kReadingSpeedRange{-1000.0, 1000.0, "m/s"};
inline constexpr Range kReadingAccelRange{-1e4, 1e4, "m/s^2"};
/// Turn rates a reading may report (odometry's omega, an IMU's yaw rate). [rad/s]
inline constexpr Range kReadingTurnRateRange{-1e4, 1e4, "rad/s"};
/// Ranges a sensor may report (detections, beacons, laser beams). [m]
inline constexpr Range kReadingRangeRange{0.0, 1e5, "m"};
/// A PTZ camera's zoom factor. [-]
inline constexpr Range kZoomRange{0.0, 1e4, ""};

/// The longest robot name or details text an event may carry (a simulation's are < 200). [bytes]
inline constexpr std::size_t kMaxEventTextBytes = 4096;

/// The time a record carries (a reading's, an event's, a true pose's). [s]
double record_time_s(const Record& record);

/// What is out of range in the record ("a true pose's x: 1e+30 m is outside [-10000, 10000] m"),
/// or "" when nothing is. NaN is out of every range, except an ultrasonic range's (no echo).
std::string record_value_problem(const Record& record);

/// The order of a stream, record by record: times never go back, and a robot has one true pose
/// per instant (a second, equal one is allowed: it says nothing new).
class StreamOrderCheck {
 public:
  /// The problem with `record` after the ones given before, or "".
  std::string problem(const Record& record);

 private:
  double last_t_s_ = -std::numeric_limits<double>::infinity();
  struct Truth {
    double t_s = -1.0;
    Pose2 pose;
  };
  std::vector<Truth> last_truth_;  // by robot
};

}  // namespace locsim
