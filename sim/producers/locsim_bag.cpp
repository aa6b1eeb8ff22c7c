#include "sim/producers/locsim_bag.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "sim/common/errors.hpp"
#include "sim/consumers/rosbag_recorder.hpp"
#include "sim/producers/log_source.hpp"
#include "sim/rosbag/bag.hpp"
#include "sim/rosbag/message_definition.hpp"
#include "sim/stream/log_file.hpp"

namespace fs = std::filesystem;

namespace locsim {
namespace {

struct Kept {
  std::uint32_t sequence = 0;
  std::int64_t stamp_ns = 0;
  rosbag::Value value;
};

double bag_yaw(const rosbag::Value& q) {
  const double x = q.number("x"), y = q.number("y"), z = q.number("z"), w = q.number("w");
  return std::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
}

std::vector<Detection> detections_of(const rosbag::Value& message) {
  std::vector<Detection> out;
  for (const rosbag::Value& d : message.at("detections").items()) {
    Detection detection;
    detection.color = d.string("color");
    detection.id = static_cast<int>(d.number("id"));
    detection.range_m = d.number("range");
    detection.bearing_rad = d.number("bearing");
    detection.truth_id = static_cast<int>(d.number("truth_id"));
    detection.target = static_cast<DetectionTarget>(static_cast<int>(d.number("target")));
    out.push_back(std::move(detection));
  }
  return out;
}

}  // namespace

std::optional<std::uint64_t> rebuild_locsim_log(const fs::path& bag_path, const fs::path& out) {
  rosbag::BagReader bag(bag_path);
  std::string header_text;
  std::map<std::string, std::vector<Kept>> topics;
  std::map<std::string, std::shared_ptr<rosbag::MessageDefinition>> definitions;
  // The recorder writes the header first, at the earliest time: a bag whose first message is
  // something else is not one of locsim's, and is left there (an import then reads it as any).
  struct NotLocsim {};
  try {
    bag.read([&](const rosbag::BagTopic& topic, const rosbag::BagMessage& message) {
      if (header_text.empty() && topic.name != "/locsim/log_header") throw NotLocsim{};
      // Frames, the clock and the map are the world's (the header has it), and the localizers'
      // outputs (a run's or replay's --rosbag2) are not records: not decoded.
      const std::string type = rosbag::short_type_name(topic.type);
      if (type == "tf2_msgs/TFMessage" || type == "rosgraph_msgs/Clock" ||
          type == "nav_msgs/OccupancyGrid" ||
          topic.name.find("/localizers/") != std::string::npos) {
        return;
      }
      try {
        auto& definition = definitions[topic.name];
        if (!definition) {
          definition = std::make_shared<rosbag::MessageDefinition>(
              topic.definition_encoding == "ros2msg"
                  ? rosbag::MessageDefinition(topic.type, topic.definition)
                  : rosbag::MessageDefinition::known(topic.type));
        }
        rosbag::Value value = definition->decode(message.data);
        if (topic.name == "/locsim/log_header") {
          header_text = value.string("data");
          return;
        }
        const rosbag::Value* header = value.find("header");
        const std::int64_t stamp =
            header == nullptr
                ? static_cast<std::int64_t>(message.log_time_ns)
                : static_cast<std::int64_t>(header->number("stamp.sec")) * 1'000'000'000 +
                      static_cast<std::int64_t>(header->number("stamp.nanosec"));
        topics[topic.name].push_back({message.sequence, stamp, std::move(value)});
      } catch (const std::exception& e) {
        throw InputError(message.where() + ", topic " + topic.name + ": " + e.what());
      }
    });
  } catch (const NotLocsim&) {
    return std::nullopt;
  }
  if (header_text.empty()) return std::nullopt;

  nlohmann::ordered_json header;
  try {
    header = nlohmann::ordered_json::parse(header_text);
  } catch (const std::exception& e) {
    throw InputError(bag_path.string() + ": /locsim/log_header is not JSON: " + e.what());
  }
  // The world, rebuilt (and checked) as a replay rebuilds it: from a log of the header alone.
  const fs::path partial = out.string() + ".partial";
  std::error_code error;
  WorldDef world;
  try {
    {
      LogWriter empty(partial, header);
      empty.finish();
    }
    LogSource source(partial);
    world = source.world();
  } catch (...) {
    fs::remove(partial, error);
    throw;
  }

  const auto seconds = [](std::int64_t ns) {
    return static_cast<double>(ns - RosbagRecorderOptions{}.epoch_ns) / 1e9;
  };
  std::vector<std::pair<std::uint32_t, Record>> records;
  const auto reading = [&](const Kept& kept, int robot, SensorKind kind, ReadingData data) {
    Record record;
    record.type = Record::Type::kReading;
    record.robot = robot;
    record.reading.t_s = seconds(kept.stamp_ns);
    record.reading.robot = robot;
    record.reading.kind = kind;
    record.reading.data = std::move(data);
    records.emplace_back(kept.sequence, std::move(record));
  };
  const auto kept_of = [&](const std::string& name) -> const std::vector<Kept>& {
    static const std::vector<Kept> none;
    const auto found = topics.find(name);
    return found == topics.end() ? none : found->second;
  };
  for (std::size_t r = 0; r < world.robots.size(); ++r) {
    const RobotDef& robot = world.robots[r];
    const int index = static_cast<int>(r);
    const std::string prefix = world.robots.size() > 1 ? "/" + robot.name : "";
    // Odometry: /odom (pose, velocity) and /joint_states (counts) of one record share its number.
    if (robot.sensors.encoders) {
      const std::uint8_t fields = robot.sensors.encoders->reports;
      const double per_tick = 2.0 * std::numbers::pi / robot.sensors.encoders->ticks_per_rev;
      std::map<std::uint32_t, std::pair<const Kept*, const Kept*>> by_record;
      for (const Kept& k : kept_of(prefix + "/odom")) by_record[k.sequence].first = &k;
      for (const Kept& k : kept_of(prefix + "/joint_states")) by_record[k.sequence].second = &k;
      for (const auto& [sequence, parts] : by_record) {
        const Kept& any = parts.first != nullptr ? *parts.first : *parts.second;
        OdometryReading o;
        o.fields = fields;
        if (parts.first != nullptr) {
          const rosbag::Value& m = parts.first->value;
          o.odometry = {m.number("pose.pose.position.x"), m.number("pose.pose.position.y"),
                        bag_yaw(m.at("pose.pose.orientation"))};
          o.v_mps = m.number("twist.twist.linear.x");
          o.omega_radps = m.number("twist.twist.angular.z");
        }
        if (parts.second != nullptr) {
          const std::vector<double>& position = parts.second->value.numbers("position");
          if (position.size() == 2) {
            o.left_ticks = std::llround(position[0] / per_tick);
            o.right_ticks = std::llround(position[1] / per_tick);
          }
        }
        reading(any, index, SensorKind::kEncoders, o);
      }
    }
    for (const Kept& k : kept_of(prefix + "/imu")) {
      ImuReading imu;
      imu.yaw_rate_radps = k.value.number("angular_velocity.z");
      imu.accel_mps2 = {k.value.number("linear_acceleration.x"),
                        k.value.number("linear_acceleration.y")};
      reading(k, index, SensorKind::kImu, imu);
    }
    if (robot.sensors.laser) {
      const float max_range = static_cast<float>(robot.sensors.laser->max_range_m);
      for (const Kept& k : kept_of(prefix + "/scan")) {
        LaserScan scan;
        for (const double range : k.value.numbers("ranges")) {
          scan.ranges_m.push_back(std::isinf(range) ? max_range : static_cast<float>(range));
        }
        reading(k, index, SensorKind::kLaser, std::move(scan));
      }
    }
    for (const Kept& k : kept_of(prefix + "/detections/ptz_camera")) {
      PtzReading ptz{k.value.number("pan"), k.value.number("tilt"), k.value.number("zoom"),
                     detections_of(k.value)};
      reading(k, index, SensorKind::kPtzCamera, std::move(ptz));
    }
    for (const Kept& k : kept_of(prefix + "/detections/omni_camera")) {
      reading(k, index, SensorKind::kOmniCamera, OmniReading{detections_of(k.value)});
    }
    for (const Kept& k : kept_of(prefix + "/detections/range_bearing")) {
      reading(k, index, SensorKind::kRangeBearing, RangeBearingReading{detections_of(k.value)});
    }
    for (const Kept& k : kept_of(prefix + "/beacon_ranges")) {
      UltrasonicReading ultrasonic;
      for (const rosbag::Value& range : k.value.at("ranges").items()) {
        ultrasonic.ranges.push_back(
            {static_cast<int>(range.number("receiver")), static_cast<int>(range.number("beacon")),
             range.number("range"),
             static_cast<RangeStatus>(static_cast<int>(range.number("truth_status")))});
      }
      reading(k, index, SensorKind::kUltrasonic, std::move(ultrasonic));
    }
    for (const Kept& k : kept_of(prefix + "/ground_truth")) {
      Record record;
      record.type = Record::Type::kGroundTruth;
      record.robot = index;
      record.t_s = seconds(k.stamp_ns);
      record.pose = {k.value.number("pose.position.x"), k.value.number("pose.position.y"),
                     bag_yaw(k.value.at("pose.orientation"))};
      records.emplace_back(k.sequence, record);
    }
  }
  for (const Kept& k : kept_of("/locsim/events")) {
    Record record;
    record.type = Record::Type::kEvent;
    record.event.t_s = seconds(k.stamp_ns);
    record.event.step = static_cast<std::int64_t>(k.value.number("step"));
    record.event.kind = k.value.string("kind");
    record.event.robot = k.value.string("robot");
    record.event.details = k.value.string("details");
    record.robot = -1;
    for (std::size_t r = 0; r < world.robots.size(); ++r) {
      if (world.robots[r].name == record.event.robot) record.robot = static_cast<int>(r);
    }
    records.emplace_back(k.sequence, std::move(record));
  }
  // In the records' order, as they were numbered when exported.
  std::stable_sort(records.begin(), records.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });

  try {
    {
      LogWriter writer(partial, header);
      for (const auto& [sequence, record] : records) writer.consume(record);
      writer.finish();
    }
    // Read back as a replay reads it: a record its world cannot have made is refused here.
    LogSource check(partial);
    Record record;
    while (check.next(record)) {
    }
  } catch (...) {
    fs::remove(partial, error);
    throw;
  }
  fs::rename(partial, out);
  return records.size();
}

}  // namespace locsim
