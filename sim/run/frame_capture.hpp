// Builds FrameStates from a running simulation for a FrameSink, at the video's frame times:
// frame k shows the state at the first physics step at or after k * speed / fps simulated
// seconds, so a video's frames are locked to simulated time (none dropped or duplicated,
// whatever the machine's speed). Between frames it only keeps the latest readings and notes
// kidnaps, cheaply, every step.
#pragma once

#include <memory>
#include <vector>

#include "sim/plugin_host/localizer_host.hpp"
#include "sim/run/frame_state.hpp"
#include "sim/run/simulation.hpp"

namespace locsim {

class FrameCapture {
 public:
  FrameCapture(FrameSink& sink, const VideoOptions& options, const Simulation& sim);

  /// After every step (and once before the first), with the step's readings.
  void step(const Simulation& sim, const std::vector<Reading>& readings,
            std::vector<std::unique_ptr<LocalizerHost>>& hosts);
  /// The state now, as a frame (for tests and for a final frame).
  FrameState capture(const Simulation& sim, std::vector<std::unique_ptr<LocalizerHost>>& hosts);

 private:
  struct Latest {
    std::optional<Pose2> odometry;
    std::optional<LaserScan> laser;
    std::optional<UltrasonicReading> ultrasonic;
    std::optional<PtzReading> ptz;
    bool carried = false;
    int kidnaps = 0;   // the simulation's count when last seen
    Pose2 floor_pose;  // the last pose on the floor, where a kidnap picks it up
  };
  FrameSink& sink_;
  double frame_interval_s_;
  long next_frame_ = 0;
  std::vector<Latest> latest_;  // by robot
  std::vector<KidnapMark> kidnaps_;
};

}  // namespace locsim
