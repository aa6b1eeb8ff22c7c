// A consumer of the record stream that writes a ROS 2 bag (rosbag2: a folder with metadata.yaml
// and one MCAP file) a ROS user plays into their stack (`ros2 bag play`) or opens in Foxglove.
// clang-format off
//   /clock             rosgraph_msgs/Clock          at every true-pose instant
//   /tf_static         tf2_msgs/TFMessage           base_link -> laser, imu_link (transient local)
//   /tf                tf2_msgs/TFMessage           odom -> base_link (the wheel odometry, as the
//                                                   robot's driver publishes it), and
//                                                   map -> base_link_truth (the truth)
//   /odom              nav_msgs/Odometry            the odometry's pose and velocity
//   /joint_states      sensor_msgs/JointState       the wheel encoders' angles (ticks)
//   /imu               sensor_msgs/Imu              yaw rate, planar specific force
//   /scan              sensor_msgs/LaserScan        no return: +inf (REP 117)
//   /map               nav_msgs/OccupancyGrid       the static world as the localizers see it
//                                                   (transient local)
//   /ground_truth      geometry_msgs/PoseStamped    the true pose, in map
//   /locsim/events     locsim_msgs/Event            kidnaps, put-downs, pushes, ...
//   /detections/ptz_camera, /detections/omni_camera, /detections/range_bearing
//                      locsim_msgs/Detections       landmarks (and robots) seen: id, colour,
//                                                   range, bearing (no ROS message has them)
//   /beacon_ranges     locsim_msgs/BeaconRanges     the ultrasonic receivers' ranges
//   /locsim/log_header std_msgs/String              the log's header (its world and scenario),
//                                                   so that `import rosbag2` rebuilds the log
// With the localizers of a run or replay (add_localizers), for each LABEL:
//   /localizers/LABEL/pose       geometry_msgs/PoseWithCovarianceStamped  its estimate, in map,
//                                                   at every true-pose instant
//   /localizers/LABEL/particles  geometry_msgs/PoseArray   its particles (a particle filter's),
//                                                   at particles_hz
//   /localizers/LABEL/failure    std_msgs/String   why it failed, when it did (transient local)
// clang-format on
// Every message made of one record carries that record's number (from 1) as its MCAP sequence.
// With several robots each robot's topics and frames are under its name (/robot2/scan,
// robot2/base_link). Times: the record's time from `epoch_ns`. docs/ros.md.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "sim/rosbag/cdr.hpp"
#include "sim/rosbag/mcap.hpp"
#include "sim/rosbag/message_definition.hpp"
#include "sim/stream/estimates.hpp"
#include "sim/stream/record.hpp"
#include "sim/world/occupancy.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

class LocalizerHost;

struct RosbagRecorderOptions {
  rosbag::McapCompression compression = rosbag::McapCompression::kZstd;
  /// The bag's time of the stream's time 0 [ns since the Unix epoch]. 1 s, not 0: ROS takes a
  /// stamp of 0 as "no time" (tf2's latest).
  std::int64_t epoch_ns = 1'000'000'000;
  /// The MCAP file's name is NAME_0.mcap, as rosbag2 names a bag's first file; default: the
  /// folder's name.
  std::string bag_name;
  /// The log's header (JSON text), written on /locsim/log_header; empty: none.
  std::string log_header;
  /// Every message through its JSON and MessageDefinition::encode. The frequent ones are
  /// otherwise written to CDR directly, several times faster; this slower way is the reference
  /// the tests hold the direct one to (the same bytes).
  bool through_definitions = false;
};

class RosbagRecorder final : public RecordConsumer, public EstimateConsumer {
 public:
  /// Creates `folder` (which must not exist) and its MCAP file; writes the static frames and the
  /// map (`grid`, empty: none). Throws as OutputFile does when it cannot.
  RosbagRecorder(const std::filesystem::path& folder, const WorldDef& world,
                 const OccupancyGrid& grid, RosbagRecorderOptions options = {});
  ~RosbagRecorder() override;
  void consume(const Record& record) override;
  /// Writes the estimates of `localizers` (as the host numbers them) and, every 1 / particles_hz
  /// of simulated time (0: never), the particles `host` holds (a snapshot, as a video frame's).
  void add_localizers(const std::vector<LocalizerInfo>& localizers, LocalizerHost* host,
                      double particles_hz);
  void estimate(const EstimateSample& sample) override;
  void failure(const LocalizerFailure& failure) override;
  /// Every record up to `t_s` has been consumed, none later: the particles due by then are
  /// written. The drivers call it as the time moves on, and at the end.
  void records_until(double t_s);
  /// Writes the MCAP file's summary and metadata.yaml. A recorder destroyed without it leaves a
  /// bag without metadata.yaml (readers take it as cut short).
  void finish();
  std::uint64_t messages() const;

 private:
  struct Topic {
    std::uint16_t channel = 0;
    std::string name, type, qos;
    std::uint64_t count = 0;
    std::shared_ptr<const rosbag::MessageDefinition> definition;
  };
  /// The topic's index, made on first use (its schema and channel written then).
  std::size_t topic(const std::string& name, const std::string& type, bool latched = false);
  void write(std::size_t topic, std::int64_t stamp_ns, const nlohmann::json& message);
  void write_cdr(std::size_t topic, std::int64_t stamp_ns, const std::string& cdr);
  std::int64_t stamp_ns(double t_s) const;
  std::string prefix(int robot) const;                          // "" or "/name"
  std::string frame(int robot, const std::string& name) const;  // "base_link", "name/base_link"
  std::string localizer_topic(std::size_t localizer, const char* what) const;

  std::filesystem::path folder_, file_;
  const WorldDef& world_;
  RosbagRecorderOptions options_;
  std::unique_ptr<rosbag::McapWriter> writer_;
  std::vector<Topic> topics_;
  std::map<std::string, std::size_t> topic_index_;
  std::int64_t first_ns_ = 0, last_ns_ = 0;
  std::uint32_t record_ = 0;  // records consumed: the sequence of the messages made of the latest
  double last_clock_s_ = -1.0;
  rosbag::CdrWriter cdr_;  // the localizers' messages, written straight (its memory kept)
  std::vector<LocalizerInfo> localizers_;
  LocalizerHost* host_ = nullptr;
  double particle_period_s_ = 0.0;  // 0: none
  double next_particles_s_ = 0.0;
  bool finished_ = false;
};

}  // namespace locsim
