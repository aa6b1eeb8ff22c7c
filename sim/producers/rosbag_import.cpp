#include "sim/producers/rosbag_import.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <set>

#include "sim/common/errors.hpp"
#include "sim/common/format.hpp"
#include "sim/common/range.hpp"
#include "sim/common/yaml_node.hpp"
#include "sim/rosbag/bag.hpp"
#include "sim/rosbag/cdr.hpp"
#include "sim/rosbag/message_definition.hpp"
#include "sim/rosbag/ros_types.hpp"
#include "sim/sensors/sensor_defs.hpp"
#include "sim/stream/record.hpp"

namespace fs = std::filesystem;

namespace locsim {
namespace {

using rosbag::BagMessage;
using rosbag::BagReader;
using rosbag::BagTopic;
using rosbag::MessageDefinition;
using rosbag::Value;

constexpr std::string_view kLaserScan = "sensor_msgs/msg/LaserScan";
constexpr std::string_view kOdometry = "nav_msgs/msg/Odometry";
constexpr std::string_view kImu = "sensor_msgs/msg/Imu";
constexpr std::string_view kTf = "tf2_msgs/msg/TFMessage";
constexpr std::string_view kPoseStamped = "geometry_msgs/msg/PoseStamped";
constexpr std::string_view kPoseWithCovariance = "geometry_msgs/msg/PoseWithCovarianceStamped";
constexpr std::string_view kOccupancyGrid = "nav_msgs/msg/OccupancyGrid";

/// The types an import reads; a topic of any other type is listed and skipped.
bool is_read(std::string_view type) {
  for (const std::string_view read :
       {kLaserScan, kOdometry, kImu, kTf, kPoseStamped, kPoseWithCovariance, kOccupancyGrid}) {
    if (rosbag::short_type_name(type) == rosbag::short_type_name(read)) return true;
  }
  return false;
}
bool is_type(const std::string& type, std::string_view wanted) {
  return rosbag::short_type_name(type) == rosbag::short_type_name(wanted);
}

struct Message {
  std::int64_t time_ns = 0;  // the header's stamp, or the log time (receive_time, or no header)
  std::int64_t log_time_ns = 0;
  Value value;
  std::string where;  // the message's place in the bag
};

struct TopicData {
  std::string name, type;
  std::shared_ptr<MessageDefinition> definition;
  std::vector<Message> messages;
  std::uint64_t count = 0, undecoded = 0;
  std::string first_failure;  // where and why the first message that could not be read failed
};

std::int64_t stamp_ns(const Value& header) {
  return static_cast<std::int64_t>(header.number("stamp.sec")) * 1'000'000'000 +
         static_cast<std::int64_t>(header.number("stamp.nanosec"));
}

double yaw_of(const Value& q) {
  const double x = q.number("x"), y = q.number("y"), z = q.number("z"), w = q.number("w");
  return std::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
}

Pose2 pose_of(const Value& pose) {
  return {pose.number("position.x"), pose.number("position.y"), yaw_of(pose.at("orientation"))};
}

Eigen::Isometry3d transform_of(const Value& transform) {
  const Value& t = transform.at("translation");
  const Value& r = transform.at("rotation");
  Eigen::Quaterniond q(r.number("w"), r.number("x"), r.number("y"), r.number("z"));
  if (q.norm() < 1e-9) q = Eigen::Quaterniond::Identity();
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = q.normalized().toRotationMatrix();
  out.translation() = Eigen::Vector3d(t.number("x"), t.number("y"), t.number("z"));
  return out;
}

/// The static transforms (/tf_static), child frame -> (parent frame, parent_T_child).
class StaticFrames {
 public:
  void add(const std::string& parent, const std::string& child, const Eigen::Isometry3d& t) {
    parents_[strip(child)] = {strip(parent), t};
  }
  /// base_T_frame, when the two frames meet in the tree.
  std::optional<Eigen::Isometry3d> find(const std::string& base, const std::string& frame) const {
    const auto chain = [&](std::string at) {
      std::vector<std::pair<std::string, Eigen::Isometry3d>> up{
          {at, Eigen::Isometry3d::Identity()}};
      for (int i = 0; i < 64; ++i) {
        const auto parent = parents_.find(at);
        if (parent == parents_.end()) break;
        up.emplace_back(parent->second.first, parent->second.second * up.back().second);
        at = parent->second.first;
      }
      return up;  // (ancestor, ancestor_T_start), the start itself first
    };
    const auto from_frame = chain(strip(frame));
    const auto from_base = chain(strip(base));
    for (const auto& [ancestor, ancestor_T_frame] : from_frame) {
      for (const auto& [other, ancestor_T_base] : from_base) {
        if (other == ancestor) return ancestor_T_base.inverse() * ancestor_T_frame;
      }
    }
    return std::nullopt;
  }

 private:
  static std::string strip(const std::string& frame) {
    return frame.starts_with('/') ? frame.substr(1) : frame;  // ROS 1 style "/base_link"
  }
  std::map<std::string, std::pair<std::string, Eigen::Isometry3d>> parents_;
};

/// The topic that plays a role: the one named, or the only one of its type, or, among several,
/// the one of the conventional name. Empty when the bag has none.
std::string choose(const std::map<std::string, TopicData>& topics, const std::string& named,
                   std::initializer_list<std::string_view> types, std::string_view conventional,
                   const std::string& role, const std::string& option) {
  if (!named.empty()) {
    const auto topic = topics.find(named);
    if (topic == topics.end()) {
      throw InputError(option + ": the bag has no topic " + quote_input(named) +
                       " that locsim reads (`locsim import rosbag2 BAG --list` lists them)");
    }
    if (std::none_of(types.begin(), types.end(),
                     [&](std::string_view type) { return is_type(topic->second.type, type); })) {
      throw InputError(option + ": " + quote_input(named) + " is a " + topic->second.type +
                       ", not a " + std::string(*types.begin()) + " (the " + role + ")");
    }
    return named;
  }
  std::vector<std::string> candidates;
  for (const auto& entry : topics) {
    const std::string& type = entry.second.type;
    if (std::any_of(types.begin(), types.end(),
                    [&](std::string_view wanted) { return is_type(type, wanted); })) {
      candidates.push_back(entry.first);
    }
  }
  if (candidates.size() == 1) return candidates.front();
  if (std::find(candidates.begin(), candidates.end(), conventional) != candidates.end()) {
    return std::string(conventional);
  }
  if (candidates.empty()) return {};
  std::string list;
  for (const std::string& c : candidates) list += (list.empty() ? "" : ", ") + c;
  throw InputError("the bag has " + std::to_string(candidates.size()) +
                   " topics that could be the " + role + " (" + list + "): name one with " +
                   option);
}

/// The map an OccupancyGrid describes, as a map_server YAML and a PGM image in the log.
ImportedMap map_of_grid(const Message& message, const fs::path& bag) {
  const Value& info = message.value.at("info");
  const double resolution = info.number("resolution");
  const auto width = static_cast<std::size_t>(info.number("width"));
  const auto height = static_cast<std::size_t>(info.number("height"));
  const std::vector<double>& cells = message.value.numbers("data");
  if (width == 0 || height == 0 || cells.size() != width * height) {
    throw InputError(message.where + ": a map of " + std::to_string(width) + " x " +
                     std::to_string(height) + " cells with " + std::to_string(cells.size()) +
                     " values");
  }
  if (!(resolution > 0.0) || !std::isfinite(resolution)) {
    throw InputError(message.where + ": a map whose resolution is " + short_number(resolution));
  }
  ImportedMap map;
  map.yaml_file = fs::absolute(bag).lexically_normal().parent_path() / "map_from_bag.yaml";
  map.image_name = "map_from_bag.pgm";
  // map_server's convention: free 254, occupied 0, unknown 205; the grid's first row is the
  // image's last (the grid grows up from its origin, the image down from its top).
  map.image_bytes = "P5\n" + std::to_string(width) + " " + std::to_string(height) + "\n255\n";
  map.image_bytes.reserve(map.image_bytes.size() + width * height);
  for (std::size_t row = height; row-- > 0;) {
    for (std::size_t col = 0; col < width; ++col) {
      const double v = cells[row * width + col];
      const int grey =
          v < 0.0 ? 205 : static_cast<int>(std::lround(254.0 * (1.0 - std::min(v, 100.0) / 100.0)));
      map.image_bytes.push_back(static_cast<char>(grey));
    }
  }
  const Pose2 origin = pose_of(info.at("origin"));
  // The resolution is a float32: its shortest digits (0.05), not the double's (0.0500000007).
  char digits[32];
  const auto [end, error] =
      std::to_chars(digits, digits + sizeof digits, static_cast<float>(resolution));
  char text[512];
  std::snprintf(text, sizeof text,
                "image: %s\nresolution: %.*s\norigin: [%.17g, %.17g, %.17g]\nnegate: 0\n"
                "occupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n",
                map.image_name.c_str(), static_cast<int>(end - digits), digits, origin.x, origin.y,
                origin.theta);
  map.yaml_text = text;
  check_imported_map(map);
  return map;
}

}  // namespace

RosbagTopics read_rosbag_topics(const fs::path& file) {
  const YamlNode root = YamlNode::load_file(file);
  root.allow_keys(
      {"laser", "odometry", "imu", "truth", "map", "map_yaml", "base_frame", "odom_frame"});
  RosbagTopics topics;
  topics.laser = root.get_string("laser", "");
  topics.odometry = root.get_string("odometry", "");
  topics.imu = root.get_string("imu", "");
  topics.truth = root.get_string("truth", "");
  topics.map = root.get_string("map", "");
  if (const auto yaml = root.find("map_yaml")) {
    topics.map_yaml = file.parent_path() / yaml->as_string();
  }
  topics.base_frame = root.get_string("base_frame", "");
  topics.odom_frame = root.get_string("odom_frame", "odom");
  return topics;
}

RosbagDataset read_rosbag2(const RosbagImportOptions& options) {
  BagReader bag(options.bag);
  RosbagDataset out;
  ImportedDataset& dataset = out.dataset;
  dataset.name = imported_world_name("rosbag2_", options.bag);
  dataset.files = bag.files();
  if (fs::is_directory(options.bag)) dataset.files.push_back(options.bag / "metadata.yaml");

  // One pass: every message of a type an import reads is decoded and kept; the roles are chosen
  // once every topic is known (an MCAP file names its topics as it goes).
  std::map<std::string, TopicData> topics;
  std::map<std::string, std::pair<std::string, std::uint64_t>> other_topics;  // name: type, count
  bag.read([&](const BagTopic& topic, const BagMessage& message) {
    if (!is_read(topic.type)) {
      auto& other = other_topics[topic.name];
      other.first = topic.type;
      ++other.second;
      return;
    }
    TopicData& data = topics[topic.name];
    ++data.count;
    try {
      if (!data.definition) {
        data.name = topic.name;
        data.type = topic.type;
        if (topic.serialization_format != "cdr") {
          throw rosbag::CdrError("serialized as " + quote_input(topic.serialization_format) +
                                 ", not cdr");
        }
        data.definition = std::make_shared<MessageDefinition>(
            topic.definition_encoding == "ros2msg"
                ? MessageDefinition(topic.type, topic.definition)
                : MessageDefinition::known(topic.type));  // none carried, or IDL
      }
      Message m;
      m.value = data.definition->decode(message.data);
      m.log_time_ns = static_cast<std::int64_t>(message.log_time_ns);
      m.time_ns = m.log_time_ns;
      if (const Value* header = m.value.find("header");
          header != nullptr && !options.receive_time) {
        // A driver that leaves its stamps at zero is read by the bag's receive times.
        if (const std::int64_t stamped = stamp_ns(*header); stamped > 0) m.time_ns = stamped;
      }
      m.where = message.where() + ", topic " + topic.name + ", log time " +
                std::to_string(message.log_time_ns) + " ns";
      data.messages.push_back(std::move(m));
    } catch (const std::exception& e) {  // CdrError, DefinitionError, a field missing
      if (data.undecoded++ == 0) {
        data.first_failure = message.where() + ", topic " + topic.name + ", log time " +
                             std::to_string(message.log_time_ns) + " ns: " + e.what();
      }
    }
  });

  // The roles.
  const RosbagTopics& named = options.topics;
  const std::string laser_topic =
      choose(topics, named.laser, {kLaserScan}, "/scan", "laser", "--laser");
  const bool odometry_from_tf = named.odometry == "tf";
  const std::string odometry_topic =
      odometry_from_tf ? std::string()
                       : choose(topics, named.odometry, {kOdometry}, "/odom", "odometry", "--odom");
  const std::string imu_topic = choose(topics, named.imu, {kImu}, "/imu", "imu", "--imu");
  std::string truth_frame;
  std::string truth_topic;
  if (named.truth.starts_with("tf:")) {
    truth_frame = named.truth.substr(3);
  } else if (!named.truth.empty()) {
    truth_topic = choose(topics, named.truth, {kPoseStamped, kPoseWithCovariance, kOdometry}, "",
                         "truth", "--truth");
  } else if (topics.contains("/ground_truth")) {
    truth_topic = choose(topics, "/ground_truth", {kPoseStamped, kPoseWithCovariance, kOdometry},
                         "", "truth", "--truth");
  }
  const std::string map_topic =
      named.map_yaml ? std::string()
                     : choose(topics, named.map, {kOccupancyGrid}, "/map", "map", "--map");
  std::set<std::string> tf_topics;
  for (const auto& [name, topic] : topics) {
    if (is_type(topic.type, kTf)) tf_topics.insert(name);
  }
  for (const std::string& used : {laser_topic, odometry_topic, imu_topic, truth_topic, map_topic}) {
    if (!used.empty() && topics.at(used).undecoded > 0) {
      throw InputError(topics.at(used).first_failure);
    }
  }
  for (const std::string& tf : tf_topics) {
    if (topics.at(tf).undecoded > 0) throw InputError(topics.at(tf).first_failure);
  }

  // The frames: /tf_static's tree (and any transform of /tf a static one names).
  StaticFrames frames;
  for (const std::string& tf : tf_topics) {
    if (tf != "/tf_static" && !tf.ends_with("/tf_static")) continue;
    for (const Message& m : topics.at(tf).messages) {
      for (const Value& t : m.value.at("transforms").items()) {
        frames.add(t.string("header.frame_id"), t.string("child_frame_id"),
                   transform_of(t.at("transform")));
      }
    }
  }
  std::string base_frame = named.base_frame;
  if (base_frame.empty() && !odometry_topic.empty()) {
    const auto& odometry = topics.at(odometry_topic).messages;
    if (!odometry.empty()) base_frame = odometry.front().value.string("child_frame_id");
  }
  if (base_frame.empty()) base_frame = "base_link";

  // The earliest stamp of what is imported is the dataset's time 0.
  std::int64_t t0_ns = std::numeric_limits<std::int64_t>::max();
  const auto consider = [&](const std::string& topic) {
    if (topic.empty()) return;
    for (const Message& m : topics.at(topic).messages) t0_ns = std::min(t0_ns, m.time_ns);
  };
  for (const std::string& used : {laser_topic, odometry_topic, imu_topic, truth_topic})
    consider(used);

  ImportedRobot robot;
  robot.name = options.robot;
  const auto seconds = [&](std::int64_t ns) { return static_cast<double>(ns - t0_ns) / 1e9; };
  const std::string bag_name = options.bag.string();

  // Odometry: nav_msgs/Odometry's pose and velocity, or the odom -> base transform of /tf.
  std::vector<std::pair<std::int64_t, ImportedRobot::Odometry>> odometry;
  if (!odometry_topic.empty()) {
    for (const Message& m : topics.at(odometry_topic).messages) {
      ImportedRobot::Odometry o;
      o.reading.fields = kOdometryPose | kOdometryVelocity;
      o.reading.odometry = pose_of(m.value.at("pose.pose"));
      o.reading.v_mps = m.value.number("twist.twist.linear.x");
      o.reading.omega_radps = m.value.number("twist.twist.angular.z");
      odometry.emplace_back(m.time_ns, o);
    }
    robot.odometry_source = {bag_name + " topic " + odometry_topic, "header.stamp"};
  } else {
    for (const std::string& tf : tf_topics) {
      if (tf == "/tf_static" || tf.ends_with("/tf_static")) continue;
      for (const Message& m : topics.at(tf).messages) {
        for (const Value& t : m.value.at("transforms").items()) {
          if (t.string("header.frame_id") != named.odom_frame ||
              t.string("child_frame_id") != base_frame) {
            continue;
          }
          const Eigen::Isometry3d pose = transform_of(t.at("transform"));
          ImportedRobot::Odometry o;
          o.reading.fields = kOdometryPose;
          o.reading.odometry = {pose.translation().x(), pose.translation().y(),
                                std::atan2(pose.linear()(1, 0), pose.linear()(0, 0))};
          odometry.emplace_back(stamp_ns(t.at("header")) > 0 && !options.receive_time
                                    ? stamp_ns(t.at("header"))
                                    : m.log_time_ns,
                                o);
        }
      }
    }
    robot.odometry_source = {bag_name + " /tf " + named.odom_frame + " -> " + base_frame,
                             "header.stamp"};
    if (odometry.empty() && odometry_from_tf) {
      throw InputError("--odom tf: the bag's /tf has no transform from " +
                       quote_input(named.odom_frame) + " to " + quote_input(base_frame) +
                       " (--odom-frame, --base-frame name others)");
    }
  }
  if (odometry.empty()) {
    throw InputError(bag_name +
                     ": no odometry: name a nav_msgs/msg/Odometry topic (--odom TOPIC) or the "
                     "transform of /tf that carries it (--odom tf, --odom-frame, --base-frame)");
  }

  // Truth: a pose topic, or the transform to a motion-capture frame.
  std::vector<std::pair<std::int64_t, Pose2>> truth;
  const auto add_truth = [&](std::int64_t ns, const Pose2& pose) { truth.emplace_back(ns, pose); };
  if (!truth_topic.empty()) {
    const TopicData& data = topics.at(truth_topic);
    for (const Message& m : data.messages) {
      add_truth(m.time_ns, pose_of(is_type(data.type, kPoseStamped) ? m.value.at("pose")
                                                                    : m.value.at("pose.pose")));
    }
    robot.truth_source = {bag_name + " topic " + truth_topic, "header.stamp"};
  } else if (!truth_frame.empty()) {
    for (const std::string& tf : tf_topics) {
      for (const Message& m : topics.at(tf).messages) {
        for (const Value& t : m.value.at("transforms").items()) {
          if (t.string("child_frame_id") != truth_frame) continue;
          const Eigen::Isometry3d pose = transform_of(t.at("transform"));
          add_truth(stamp_ns(t.at("header")) > 0 && !options.receive_time ? stamp_ns(t.at("header"))
                                                                          : m.log_time_ns,
                    {pose.translation().x(), pose.translation().y(),
                     std::atan2(pose.linear()(1, 0), pose.linear()(0, 0))});
        }
      }
    }
    if (truth.empty()) {
      throw InputError("--truth " + named.truth + ": no transform of the bag's /tf names " +
                       quote_input(truth_frame) + " as its child frame");
    }
    robot.truth_source = {bag_name + " /tf -> " + truth_frame, "header.stamp"};
  }
  // Every stream in seconds from the earliest stamp of all.
  for (const auto& sample : odometry) t0_ns = std::min(t0_ns, sample.first);
  for (const auto& sample : truth) t0_ns = std::min(t0_ns, sample.first);
  const auto by_time = [](const auto& a, const auto& b) { return a.first < b.first; };
  std::stable_sort(odometry.begin(), odometry.end(), by_time);
  std::stable_sort(truth.begin(), truth.end(), by_time);
  for (auto& [ns, o] : odometry) {
    o.t_s = seconds(ns);
    robot.odometry.push_back(o);
  }
  for (const auto& [ns, pose] : truth) robot.truth.emplace_back(seconds(ns), pose);

  // The IMU, turned into the base's axes by /tf_static.
  if (!imu_topic.empty()) {
    const TopicData& data = topics.at(imu_topic);
    const std::string frame = data.messages.empty()
                                  ? std::string()
                                  : data.messages.front().value.string("header.frame_id");
    Eigen::Matrix3d base_R_imu = Eigen::Matrix3d::Identity();
    if (const auto found = frames.find(base_frame, frame)) {
      base_R_imu = found->linear();
    } else if (!frame.empty() && frame != base_frame) {
      out.notes.push_back("the IMU's frame " + quote_input(frame) +
                          " is not in /tf_static: its "
                          "axes are taken as the base's");
    }
    for (const Message& m : data.messages) {
      const Value& w = m.value.at("angular_velocity");
      const Value& a = m.value.at("linear_acceleration");
      const Eigen::Vector3d rate =
          base_R_imu * Eigen::Vector3d(w.number("x"), w.number("y"), w.number("z"));
      const Eigen::Vector3d accel =
          base_R_imu * Eigen::Vector3d(a.number("x"), a.number("y"), a.number("z"));
      ImportedRobot::Imu imu;
      imu.t_s = seconds(m.time_ns);
      imu.reading.yaw_rate_radps = rate.z();
      imu.reading.accel_mps2 = {accel.x(), accel.y()};
      robot.imu.push_back(imu);
    }
    std::stable_sort(robot.imu.begin(), robot.imu.end(),
                     [](const auto& a, const auto& b) { return a.t_s < b.t_s; });
    robot.imu_source = {bag_name + " topic " + imu_topic, "header.stamp"};
  }

  // The laser: the first scan sets the beams; its frame is placed on the base by /tf_static.
  if (!laser_topic.empty() && !topics.at(laser_topic).messages.empty()) {
    const TopicData& data = topics.at(laser_topic);
    const Message& first = data.messages.front();
    const std::string frame = first.value.string("header.frame_id");
    const auto base_T_laser = frame == base_frame
                                  ? std::optional<Eigen::Isometry3d>(Eigen::Isometry3d::Identity())
                                  : frames.find(base_frame, frame);
    if (!base_T_laser) {
      throw InputError(first.where + ": the scan's frame " + quote_input(frame) +
                       " is not placed on the base " + quote_input(base_frame) +
                       " by the bag's /tf_static (--base-frame names the base's frame)");
    }
    const Eigen::Matrix3d& rotation = base_T_laser->linear();
    // A scanner mounted upside down sweeps the other way round.
    const double turn = rotation(2, 2) < 0.0 ? -1.0 : 1.0;
    const double mount_yaw = std::atan2(rotation(1, 0), rotation(0, 0));
    const double angle_min = first.value.number("angle_min");
    const double increment = first.value.number("angle_increment");
    const double range_min = first.value.number("range_min");
    const double range_max = first.value.number("range_max");
    const std::size_t beams = first.value.numbers("ranges").size();
    if (beams == 0 || beams > static_cast<std::size_t>(LaserDef::kBeamsRange.max)) {
      throw InputError(first.where + ": a scan of " + std::to_string(beams) +
                       " beams (locsim "
                       "reads 1 to " +
                       short_number(LaserDef::kBeamsRange.max) + ")");
    }
    if (!(range_max > range_min) || !(range_min >= 0.0) || !std::isfinite(range_max)) {
      throw InputError(first.where + ": range_min " + short_number(range_min) + " and range_max " +
                       short_number(range_max) + " m are not a scanner's ranges");
    }
    // In the base's angles the beams run from `from` by `step`; reversed when that goes down.
    const double from = turn * angle_min;
    const double step = turn * increment;
    const bool reverse = step < 0.0;
    const double lowest = reverse ? from + step * static_cast<double>(beams - 1) : from;
    try {
      robot.laser = laser_spread(
          lowest, lowest + std::abs(step) * static_cast<double>(beams - 1), static_cast<int>(beams),
          range_min, range_max,
          {base_T_laser->translation().x(), base_T_laser->translation().y(), mount_yaw});
    } catch (const std::invalid_argument& e) {
      throw InputError(first.where + ": " + e.what());
    }
    for (const Message& m : data.messages) {
      const std::vector<double>& ranges = m.value.numbers("ranges");
      if (ranges.size() != beams || m.value.number("angle_min") != angle_min ||
          m.value.number("angle_increment") != increment) {
        dataset.dropped.push_back(
            {seconds(m.time_ns), "laser scans unlike the first (beams or angles)"});
        continue;
      }
      ImportedRobot::Scan scan;
      scan.t_s = seconds(m.time_ns);
      scan.scan.ranges_m.resize(beams);
      for (std::size_t i = 0; i < beams; ++i) {
        const double r = ranges[reverse ? beams - 1 - i : i];
        // No return (NaN, inf, outside the scanner's ranges) reads max_range, as in a simulation.
        const bool returned = std::isfinite(r) && r >= range_min && r < range_max;
        scan.scan.ranges_m[i] = static_cast<float>(returned ? r : range_max);
      }
      robot.scans.push_back(std::move(scan));
    }
    std::stable_sort(robot.scans.begin(), robot.scans.end(),
                     [](const auto& a, const auto& b) { return a.t_s < b.t_s; });
    robot.scans_source = {bag_name + " topic " + laser_topic, "header.stamp"};
  }

  // The map.
  if (named.map_yaml) {
    dataset.map = read_map_server_map(*named.map_yaml, dataset.files);
  } else if (!map_topic.empty() && !topics.at(map_topic).messages.empty()) {
    dataset.map = map_of_grid(topics.at(map_topic).messages.back(), options.bag);
  }

  // The start: as asked, else the first true pose (write_import), else the first odometry pose.
  robot.start = options.start;
  if (robot.truth.empty()) {
    // No truth: the localizers are sampled at the odometry's instants, their estimates kept and
    // nothing scored (unknown_truth).
    for (const ImportedRobot::Odometry& o : robot.odometry) {
      if (robot.truth.empty() || robot.truth.back().t_s != o.t_s)
        robot.truth.emplace_back(o.t_s, unknown_truth());
    }
    out.notes.push_back("no truth: the localizers' estimates are kept, nothing is scored");
    if (!robot.start) {
      robot.start = robot.odometry.front().reading.odometry;
      out.notes.push_back(
          "the robot starts at the first odometry pose, in the odometry's frame "
          "(--start x,y,theta puts it on the map)");
    }
  }

  dataset.source = {{"format", "rosbag2"},
                    {"bag", options.bag.string()},
                    {"storage", bag.storage()},
                    {"t0_unix_ns", t0_ns},
                    {"topics",
                     {{"laser", laser_topic},
                      {"odometry", odometry_from_tf ? "tf:" + named.odom_frame + "->" + base_frame
                                                    : odometry_topic},
                      {"imu", imu_topic},
                      {"truth", truth_frame.empty() ? truth_topic : "tf:" + truth_frame},
                      {"map", named.map_yaml ? named.map_yaml->string() : map_topic}}},
                    {"time", options.receive_time ? "receive" : "header"}};
  dataset.robots.push_back(std::move(robot));

  // What became of each topic.
  const std::map<std::string, std::string> uses = {{laser_topic, "laser"},
                                                   {odometry_topic, "odometry"},
                                                   {imu_topic, "imu"},
                                                   {truth_topic, "truth"},
                                                   {map_topic, "map"}};
  for (const auto& [name, data] : topics) {
    RosbagTopicUse use{name, data.type, data.count, ""};
    if (const auto found = uses.find(name); found != uses.end() && !name.empty()) {
      use.use = found->second;
    } else if (tf_topics.contains(name)) {
      use.use = name.ends_with("tf_static")
                    ? "frames (sensor mounts)"
                    : (odometry_from_tf || !truth_frame.empty() ? "frames (odometry or truth)"
                                                                : "not used");
    } else if (data.undecoded > 0) {
      use.use = "not used: " + std::to_string(data.undecoded) + " messages cannot be read";
    } else {
      use.use = "not used (another topic of its type is)";
    }
    out.topics.push_back(use);
  }
  for (const auto& [name, other] : other_topics) {
    out.topics.push_back({name, other.first, other.second, "skipped: a type locsim does not read"});
  }
  std::sort(out.topics.begin(), out.topics.end(),
            [](const auto& a, const auto& b) { return a.name < b.name; });
  return out;
}

}  // namespace locsim
