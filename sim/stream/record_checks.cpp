#include "sim/stream/record_checks.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string_view>
#include <type_traits>
#include <variant>

#include "sim/common/errors.hpp"
#include "sim/common/format.hpp"

namespace locsim {

namespace {

/// "WHAT: PROBLEM" when `value` is outside `range`, else "".
std::string check(const std::string& what, double value, const Range& range) {
  const std::string problem = out_of_range(value, range);
  return problem.empty() ? problem : what + ": " + problem;
}

std::string check_pose(const std::string& what, const Pose2& pose) {
  for (std::string problem : {check(what + "'s x", pose.x, kWorldCoordinateRange),
                              check(what + "'s y", pose.y, kWorldCoordinateRange),
                              check(what + "'s heading", pose.theta, kHeadingRange)}) {
    if (!problem.empty()) return problem;
  }
  return "";
}

std::string check_detections(const std::vector<Detection>& detections) {
  for (const Detection& d : detections) {
    for (std::string problem : {check("a detection's range", d.range_m, kReadingRangeRange),
                                check("a detection's bearing", d.bearing_rad, kHeadingRange)}) {
      if (!problem.empty()) return problem;
    }
  }
  return "";
}

/// An event as a simulation writes one (Simulation::log): a kind it knows, and a robot and
/// details that are one short line of text (events.csv holds them; a terminal may show them).
std::string check_event(const SimEvent& event) {
  static constexpr std::array<std::string_view, 9> kKinds{
      "collision", "end",          "friction",       "kidnap",       "push",
      "put_down",  "sensor_fault", "obstacle_start", "obstacle_stop"};
  if (std::find(kKinds.begin(), kKinds.end(), event.kind) == kKinds.end())
    return "an event of unknown kind " + quote_input(event.kind, 40);
  for (const auto& [what, text] : {std::pair{"robot", &event.robot}, {"details", &event.details}}) {
    if (text->size() > kMaxEventTextBytes) {
      return std::string("an event's ") + what + " of " + std::to_string(text->size()) +
             " bytes (at most " + std::to_string(kMaxEventTextBytes) + ")";
    }
    const bool control = std::any_of(text->begin(), text->end(), [](char c) {
      return static_cast<unsigned char>(c) < 0x20 || c == 0x7f;
    });
    if (control)
      return std::string("an event's ") + what + " " + quote_input(*text, 40) +
             " holds control characters";
  }
  return "";
}

std::string check_reading(const Reading& reading) {
  return std::visit(
      [](const auto& data) -> std::string {
        using T = std::decay_t<decltype(data)>;
        if constexpr (std::is_same_v<T, OdometryReading>) {
          for (std::string problem :
               {check_pose("an odometry pose", data.odometry),
                check("an odometry velocity", data.v_mps, kReadingSpeedRange),
                check("an odometry turn rate", data.omega_radps, kReadingTurnRateRange)}) {
            if (!problem.empty()) return problem;
          }
          return "";
        } else if constexpr (std::is_same_v<T, ImuReading>) {
          for (std::string problem :
               {check("an IMU's yaw rate", data.yaw_rate_radps, kReadingTurnRateRange),
                check("an IMU's acceleration x", data.accel_mps2.x(), kReadingAccelRange),
                check("an IMU's acceleration y", data.accel_mps2.y(), kReadingAccelRange)}) {
            if (!problem.empty()) return problem;
          }
          return "";
        } else if constexpr (std::is_same_v<T, PtzReading>) {
          for (std::string problem : {check("a PTZ camera's pan", data.pan_rad, kHeadingRange),
                                      check("a PTZ camera's tilt", data.tilt_rad, kHeadingRange),
                                      check("a PTZ camera's zoom", data.zoom, kZoomRange)}) {
            if (!problem.empty()) return problem;
          }
          return check_detections(data.detections);
        } else if constexpr (std::is_same_v<T, OmniReading> ||
                             std::is_same_v<T, RangeBearingReading>) {
          return check_detections(data.detections);
        } else if constexpr (std::is_same_v<T, UltrasonicReading>) {
          for (const BeaconRange& range : data.ranges) {
            if (std::isnan(range.range_m)) continue;  // no echo came back
            if (std::string problem =
                    check("an ultrasonic range", range.range_m, kReadingRangeRange);
                !problem.empty())
              return problem;
          }
          return "";
        } else if constexpr (std::is_same_v<T, LaserScan>) {
          for (std::size_t i = 0; i < data.ranges_m.size(); ++i) {
            if (std::string problem = check("laser beam " + std::to_string(i) + "'s range",
                                            data.ranges_m[i], kReadingRangeRange);
                !problem.empty())
              return problem;
          }
          return "";
        }
      },
      reading.data);
}

}  // namespace

double record_time_s(const Record& record) {
  switch (record.type) {
    case Record::Type::kReading:
      return record.reading.t_s;
    case Record::Type::kEvent:
      return record.event.t_s;
    case Record::Type::kGroundTruth:
    case Record::Type::kEnd:
      break;
  }
  return record.t_s;
}

std::string record_value_problem(const Record& record) {
  if (record.type == Record::Type::kEnd) return "";
  if (std::string problem = check("its time", record_time_s(record), kSimulatedTimeRange);
      !problem.empty())
    return problem;
  switch (record.type) {
    case Record::Type::kReading:
      return check_reading(record.reading);
    case Record::Type::kGroundTruth:
      // All three NaN: a sampling instant without truth (unknown_truth); one NaN is a bad pose.
      if (std::isnan(record.pose.x) && std::isnan(record.pose.y) && std::isnan(record.pose.theta))
        return "";
      return check_pose("a true pose", record.pose);
    case Record::Type::kEvent:
      return check_event(record.event);
    case Record::Type::kEnd:
      break;
  }
  return "";
}

std::string StreamOrderCheck::problem(const Record& record) {
  if (record.type == Record::Type::kEnd) return "";
  const double t_s = record_time_s(record);
  if (t_s < last_t_s_) {
    return "its time " + short_number(t_s) + " s is before the previous record's " +
           short_number(last_t_s_) + " s (a stream's times never go back)";
  }
  last_t_s_ = t_s;
  if (record.type != Record::Type::kGroundTruth || record.robot < 0) return "";
  const auto robot = static_cast<std::size_t>(record.robot);
  if (last_truth_.size() <= robot) last_truth_.resize(robot + 1);
  Truth& last = last_truth_[robot];
  if (last.t_s == t_s && !(last.pose == record.pose) &&
      (truth_known(last.pose) || truth_known(record.pose))) {
    return "a second true pose of robot " + std::to_string(record.robot) + " at " +
           short_number(t_s) + " s, not the first's (" + short_number(last.pose.x) + ", " +
           short_number(last.pose.y) + ", " + short_number(last.pose.theta) + ")";
  }
  last = {t_s, record.pose};
  return "";
}

}  // namespace locsim
