// `locsim import rosbag2`: a ROS 2 recording (a rosbag2 folder, an .mcap or a .db3 file) as a
// dataset a log is written from (import_log). Each role is a topic of the bag, named on the
// command line or in a small YAML file, or found by its type when the bag has one of it:
//   laser     sensor_msgs/msg/LaserScan, its mount from /tf_static (base frame -> scan frame)
//   odometry  nav_msgs/msg/Odometry (pose and velocity), or "tf": the odom -> base transform
//   imu       sensor_msgs/msg/Imu (yaw rate and planar specific force, in the base's axes)
//   truth     geometry_msgs/msg/PoseStamped, PoseWithCovarianceStamped or nav_msgs/msg/Odometry,
//             or "tf:FRAME": the transform to FRAME (a motion-capture body) from its parent
//   map       nav_msgs/msg/OccupancyGrid (the last one), or a map_server YAML file
// Readings are stamped with their headers' times (the bag's receive times with receive_time), as
// nanoseconds from the earliest: exact to a nanosecond whatever the epoch. docs/ros.md.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "sim/common/math.hpp"
#include "sim/producers/import_log.hpp"

namespace locsim {

/// Which topic plays which role; an empty one is found by its type (the only topic of it, or the
/// conventional name among several: /scan, /odom, /imu, /map, /ground_truth).
struct RosbagTopics {
  std::string laser, odometry, imu, truth, map;
  std::optional<std::filesystem::path> map_yaml;  // a map_server map instead of a map topic
  std::string base_frame;           // default: the odometry's child frame, else base_link
  std::string odom_frame = "odom";  // for odometry from tf
};

/// The topics file (`--topics FILE`): the keys of RosbagTopics (laser, odometry, imu, truth, map,
/// map_yaml, base_frame, odom_frame); map_yaml relative to the file. Throws InputError.
RosbagTopics read_rosbag_topics(const std::filesystem::path& file);

struct RosbagImportOptions {
  std::filesystem::path bag;
  RosbagTopics topics;
  std::string robot = "robot";
  bool receive_time = false;   // stamp readings with the bag's log times, not their headers'
  std::optional<Pose2> start;  // default: the first true pose, else the first odometry pose
};

/// A topic of the bag and what the import made of it.
struct RosbagTopicUse {
  std::string name, type;
  std::uint64_t messages = 0;
  std::string use;  // "laser", "odometry", ...; or why it is not used
};

struct RosbagDataset {
  ImportedDataset dataset;
  std::vector<RosbagTopicUse> topics;
  std::vector<std::string> notes;  // what the import assumed (no truth, an IMU frame not in TF)
};

/// Reads the bag. Throws InputError naming the file and the message's place (byte or row), topic
/// and time for a message of a used topic that cannot be read, and what is missing for a role
/// that cannot be filled (no odometry; a laser whose frame /tf_static does not place).
RosbagDataset read_rosbag2(const RosbagImportOptions& options);

}  // namespace locsim
