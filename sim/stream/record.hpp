// The record stream: the one time-ordered sequence of sensor readings, true poses and events that
// every producer emits (a simulation, a recorded log, an imported dataset) and every consumer
// takes (a localizer host, the scorer, the run folder's recorder, the log writer, frame capture).
// `locsim run` and `locsim replay` differ only in their producer; docs/architecture.md.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "sim/common/math.hpp"
#include "sim/sensors/readings.hpp"

namespace locsim {

/// Something that happened, for events.csv.
struct SimEvent {
  std::int64_t step = 0;
  double t_s = 0.0;
  std::string kind;     // kidnap, put_down, push, friction, obstacle_start/stop, end, collision
  std::string robot;    // empty when not about one robot
  std::string details;  // key=value pairs separated by spaces
};

/// One element of the stream. Within a time step a producer emits the readings, then the
/// events, then (at the ground-truth rate) each robot's true pose: a consumer that scores a
/// localizer on a true pose has seen every reading up to that instant. The type values are those
/// of the log format (docs/log_format.md).
struct Record {
  enum class Type : std::uint8_t { kReading = 1, kGroundTruth = 2, kEvent = 3, kEnd = 255 };
  Type type = Type::kEnd;
  Reading reading;   // kReading
  double t_s = 0.0;  // kGroundTruth
  int robot = -1;    // kGroundTruth, kEvent (the index of the robot; -1: not about one robot)
  Pose2 pose;        // kGroundTruth: the robot's true pose (never while it is carried)
  SimEvent event;    // kEvent
};

/// The pose of a ground-truth record when the truth is not known (a recording without it, e.g. a
/// ROS bag): the record still marks an instant the localizers are sampled at, so their estimates
/// are kept, and nothing is scored against it. docs/log_format.md.
inline Pose2 unknown_truth() {
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  return {nan, nan, nan};
}
/// Whether a true pose is known (unknown_truth() is not).
inline bool truth_known(const Pose2& pose) {
  return !std::isnan(pose.x);
}

/// Takes the records of a stream, in order.
class RecordConsumer {
 public:
  virtual ~RecordConsumer() = default;
  virtual void consume(const Record& record) = 0;
  /// Called every few simulated seconds: push buffered output to the files, so that a crash or
  /// a kill loses little.
  virtual void flush() {}
};

/// Hands each record to several consumers, in the order they were added.
class RecordFanout final : public RecordConsumer {
 public:
  void add(RecordConsumer& consumer) { consumers_.push_back(&consumer); }
  void consume(const Record& record) override {
    for (RecordConsumer* consumer : consumers_) consumer->consume(record);
  }
  void flush() override {
    for (RecordConsumer* consumer : consumers_) consumer->flush();
  }

 private:
  std::vector<RecordConsumer*> consumers_;
};

}  // namespace locsim
