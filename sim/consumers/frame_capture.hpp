// Frame capture: a consumer of the record stream (it keeps each robot's latest readings) that,
// after each simulation step, builds a FrameState for a FrameSink when a video frame is due:
// frame k shows the state at the first physics step at or after k * speed / fps simulated
// seconds, so a video's frames are locked to simulated time (none dropped or duplicated,
// whatever the machine's speed). The truth comes from the simulation, each localizer's belief
// from the host's snapshot (a failed one is drawn as failed; the others go on).
#pragma once

#include <memory>
#include <vector>

#include "sim/consumers/frame_state.hpp"
#include "sim/plugin_host/localizer_host.hpp"
#include "sim/producers/simulation.hpp"
#include "sim/stream/record.hpp"

namespace locsim {

class FrameCapture final : public RecordConsumer {
 public:
  /// `host`: the localizers to draw (none when null).
  FrameCapture(FrameSink& sink, const VideoOptions& options, const Simulation& sim,
               LocalizerHost* host = nullptr);

  void consume(const Record& record) override;
  /// After every step's records (and once before the first step).
  void after_step(const Simulation& sim);
  /// The state now, as a frame (for tests and for a final frame).
  FrameState capture(const Simulation& sim);

 private:
  struct Latest {
    std::optional<Pose2> odometry;
    std::optional<LaserScan> laser;
    std::optional<UltrasonicReading> ultrasonic;
    std::optional<PtzReading> ptz;
    std::optional<RangeBearingReading> range_bearing;
    bool carried = false;
    int kidnaps = 0;   // the simulation's count when last seen
    Pose2 floor_pose;  // the last pose on the floor, where a kidnap picks it up
  };
  FrameSink& sink_;
  LocalizerHost* host_;
  double frame_interval_s_;
  long next_frame_ = 0;
  std::vector<Latest> latest_;  // by robot
  std::vector<KidnapMark> kidnaps_;
};

}  // namespace locsim
