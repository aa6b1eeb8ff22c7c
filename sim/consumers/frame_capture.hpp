// Frame capture: a consumer of the record stream (it keeps each robot's latest readings) that
// builds a FrameState for a FrameSink whenever a video frame is due: frame k shows the state at
// the first time step at or after k * speed / fps seconds, so a video's frames are locked to the
// stream's time (none dropped or duplicated, whatever the machine's speed). Each localizer's
// belief comes from the host's snapshot (a failed one is drawn as failed; the others go on).
//
// Two producers, one picture: in a run the truth (poses, carried robots, kidnaps, people) comes
// from the simulation after each physics step; in a replay it comes from the stream itself (the
// ground-truth records, kidnap events), since a log holds nothing else: no people, and no pose
// while a robot is carried (it is drawn where it was picked up).
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
  /// A run's frames, the truth from `sim`. `host`: the localizers to draw (none when null).
  FrameCapture(FrameSink& sink, const VideoOptions& options, const Simulation& sim,
               LocalizerHost* host = nullptr);
  /// A replay's frames, the truth from the stream's ground truth and events. The host must be fed
  /// the records before this is (it is snapshot at advance()).
  FrameCapture(FrameSink& sink, const VideoOptions& options, const WorldDef& world,
               LocalizerHost* host = nullptr);

  void consume(const Record& record) override;
  /// A run: after every step's records (and once before the first step).
  void after_step(const Simulation& sim);
  /// A replay: the stream's next record is at `t_s`; the frames due by the records so far are
  /// drawn first (when the time moves on, so a frame holds every record of its time step).
  void advance(double t_s);
  /// A replay: the stream has ended; the frames due by its last records.
  void end_of_stream();
  /// The state now, as a frame (for tests and for a final frame).
  FrameState capture(const Simulation& sim);

 private:
  struct Latest {
    std::optional<Pose2> odometry;
    std::optional<LaserScan> laser;
    std::optional<UltrasonicReading> ultrasonic;
    std::optional<PtzReading> ptz;
    std::optional<RangeBearingReading> range_bearing;
    std::optional<OmniReading> omni;
    double range_bearing_t_s = 0.0, omni_t_s = 0.0;  // when they were read [s]
    Pose2 pose;  // true pose (in a replay: the latest ground truth; where it was picked up)
    bool carried = false;
    int kidnaps = 0;   // kidnaps so far
    Pose2 floor_pose;  // the last pose on the floor, where a kidnap picks it up
  };
  FrameState capture(double t_s, const Simulation* sim);
  /// Every frame due by `t_s` (more than one only when frames are closer than time steps).
  void emit_due(double t_s, const Simulation* sim);
  void consume_truth(const Record& record);

  FrameSink& sink_;
  const WorldDef& world_;
  LocalizerHost* host_;
  bool from_stream_;  // a replay: truth from the records
  double frame_interval_s_;
  long next_frame_ = 0;
  std::optional<double> stream_t_s_;  // a replay: the time of the records so far
  std::vector<Latest> latest_;        // by robot
  std::vector<KidnapMark> kidnaps_;
};

}  // namespace locsim
