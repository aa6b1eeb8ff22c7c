#include "sim/consumers/rosbag_recorder.hpp"

#include <array>
#include <cctype>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string_view>
#include <variant>

#include "sim/common/files.hpp"
#include "sim/plugin_host/localizer_host.hpp"
#include "sim/rosbag/ros_types.hpp"
#include "sim/sensors/models.hpp"

namespace fs = std::filesystem;
using nlohmann::json;

namespace locsim {
namespace {

// rosbag2's QoS profiles (rmw enums: history 1 keep last, reliability 1 reliable, durability 1
// transient local / 2 volatile), as `ros2 bag play` reads them from metadata.yaml: a latched topic
// (/map, /tf_static) is offered transient local, so a node that starts after the bag still gets it.
std::string qos_profile(bool latched) {
  return std::string("- history: 1\n  depth: ") + (latched ? "1" : "100") +
         "\n  reliability: 1\n  durability: " + (latched ? "1" : "2") +
         "\n  deadline:\n    sec: 0\n    nsec: 0\n  lifespan:\n    sec: 0\n    nsec: 0\n"
         "  liveliness: 1\n  liveliness_lease_duration:\n    sec: 0\n    nsec: 0\n"
         "  avoid_ros_namespace_conventions: false";
}

json stamp(std::int64_t ns) {
  return {{"sec", static_cast<std::int32_t>(ns / 1'000'000'000)},
          {"nanosec", static_cast<std::uint32_t>(ns % 1'000'000'000)}};
}
json header(std::int64_t ns, const std::string& frame) {
  return {{"stamp", stamp(ns)}, {"frame_id", frame}};
}
json yaw_quaternion(double yaw) {
  return {{"x", 0.0}, {"y", 0.0}, {"z", std::sin(0.5 * yaw)}, {"w", std::cos(0.5 * yaw)}};
}
json pose(const Pose2& p) {
  return {{"position", {{"x", p.x}, {"y", p.y}, {"z", 0.0}}},
          {"orientation", yaw_quaternion(p.theta)}};
}
json transform(std::int64_t ns, const std::string& parent, const std::string& child,
               const Pose2& p) {
  return {{"header", header(ns, parent)},
          {"child_frame_id", child},
          {"transform",
           {{"translation", {{"x", p.x}, {"y", p.y}, {"z", 0.0}}},
            {"rotation", yaw_quaternion(p.theta)}}}};
}
json vector3(double x, double y, double z) {
  return {{"x", x}, {"y", y}, {"z", z}};
}
/// A number JSON cannot hold, as MessageDefinition::encode reads it.
json number(double value) {
  if (std::isnan(value)) return "NaN";
  if (std::isinf(value)) return value > 0 ? "Infinity" : "-Infinity";
  return value;
}

// The frequent messages, written straight to CDR: through their JSON and the definitions a bag cost
// several times the replay's own time (a particle cloud is thousands of poses ten times a
// second). The same bytes as MessageDefinition::encode of their JSON, which
// RosbagRecorderOptions::through_definitions writes instead (tests/rosbag_export_test.cpp compares
// the two; the independent reader decodes both).
void put_header(rosbag::CdrWriter& cdr, std::int64_t ns, std::string_view frame) {
  cdr.write(static_cast<std::int32_t>(ns / 1'000'000'000));
  cdr.write(static_cast<std::uint32_t>(ns % 1'000'000'000));
  cdr.write_string(frame);
}
void put_pose(rosbag::CdrWriter& cdr, double x, double y, double theta) {
  for (const double v : {x, y, 0.0, 0.0, 0.0, std::sin(0.5 * theta), std::cos(0.5 * theta)})
    cdr.write(v);
}

void put_vector3(rosbag::CdrWriter& cdr, double x, double y, double z) {
  cdr.write(x);
  cdr.write(y);
  cdr.write(z);
}
void put_zeros(rosbag::CdrWriter& cdr, int count) {
  for (int i = 0; i < count; ++i) cdr.write(0.0);
}
/// tf2_msgs/TFMessage of one transform (a Transform is laid out as a Pose).
void put_one_transform(rosbag::CdrWriter& cdr, std::int64_t ns, std::string_view parent,
                       std::string_view child, const Pose2& p) {
  cdr.write_count(1);
  put_header(cdr, ns, parent);
  cdr.write_string(child);
  put_pose(cdr, p.x, p.y, p.theta);
}

json detections_json(std::int64_t ns, const std::string& frame, double pan, double tilt,
                     double zoom, const std::vector<Detection>& detections) {
  json list = json::array();
  for (const Detection& d : detections) {
    list.push_back({{"color", d.color},
                    {"id", d.id},
                    {"range", number(d.range_m)},
                    {"bearing", number(d.bearing_rad)},
                    {"truth_id", d.truth_id},
                    {"target", static_cast<int>(d.target)}});
  }
  return {{"header", header(ns, frame)},
          {"pan", pan},
          {"tilt", tilt},
          {"zoom", zoom},
          {"detections", list}};
}

}  // namespace

RosbagRecorder::RosbagRecorder(const fs::path& folder, const WorldDef& world,
                               const OccupancyGrid& grid, RosbagRecorderOptions options)
    : folder_(folder), world_(world), options_(options) {
  fs::create_directories(folder_);
  const std::string name =
      options_.bag_name.empty() ? folder_.filename().string() : options_.bag_name;
  file_ = folder_ / (name + "_0.mcap");
  rosbag::McapWriterOptions mcap;
  mcap.compression = options_.compression;
  writer_ = std::make_unique<rosbag::McapWriter>(file_, mcap);
  first_ns_ = last_ns_ = options_.epoch_ns;

  // The sensors' mounts, once, latched.
  json transforms = json::array();
  for (std::size_t r = 0; r < world_.robots.size(); ++r) {
    const SensorsDef& sensors = world_.robots[r].sensors;
    const int robot = static_cast<int>(r);
    if (sensors.laser)
      transforms.push_back(transform(options_.epoch_ns, frame(robot, "base_link"),
                                     frame(robot, "laser"), sensors.laser->common.mount));
    if (sensors.imu)
      transforms.push_back(transform(options_.epoch_ns, frame(robot, "base_link"),
                                     frame(robot, "imu_link"), sensors.imu->common.mount));
  }
  if (!options_.log_header.empty()) {
    write(topic("/locsim/log_header", "std_msgs/msg/String", true), options_.epoch_ns,
          {{"data", options_.log_header}});
  }
  if (!transforms.empty()) {
    write(topic("/tf_static", "tf2_msgs/msg/TFMessage", true), options_.epoch_ns,
          {{"transforms", transforms}});
  }
  if (grid.width > 0 && grid.height > 0) {
    json cells = json::array();
    for (const std::uint8_t cell : grid.cells) cells.push_back(cell);
    write(topic("/map", "nav_msgs/msg/OccupancyGrid", true), options_.epoch_ns,
          {{"header", header(options_.epoch_ns, "map")},
           {"info",
            {{"map_load_time", stamp(options_.epoch_ns)},
             {"resolution", grid.resolution_m},
             {"width", grid.width},
             {"height", grid.height},
             {"origin", pose({grid.origin_m.x(), grid.origin_m.y(), 0.0})}}},
           {"data", cells}});
  }
}

RosbagRecorder::~RosbagRecorder() = default;

std::int64_t RosbagRecorder::stamp_ns(double t_s) const {
  return options_.epoch_ns + std::llround(t_s * 1e9);
}

std::string RosbagRecorder::prefix(int robot) const {
  return world_.robots.size() > 1 ? "/" + world_.robots[static_cast<std::size_t>(robot)].name : "";
}

std::string RosbagRecorder::frame(int robot, const std::string& name) const {
  return world_.robots.size() > 1 ? world_.robots[static_cast<std::size_t>(robot)].name + "/" + name
                                  : name;
}

std::size_t RosbagRecorder::topic(const std::string& name, const std::string& type, bool latched) {
  if (const auto found = topic_index_.find(name); found != topic_index_.end()) return found->second;
  Topic t;
  t.name = name;
  t.type = type;
  t.qos = qos_profile(latched);
  t.definition =
      std::make_shared<const rosbag::MessageDefinition>(rosbag::MessageDefinition::known(type));
  const std::uint16_t schema = writer_->add_schema(type, "ros2msg", rosbag::schema_text(type));
  t.channel = writer_->add_channel(schema, name, "cdr", {{"offered_qos_profiles", t.qos}});
  topics_.push_back(std::move(t));
  topic_index_.emplace(name, topics_.size() - 1);
  return topics_.size() - 1;
}

void RosbagRecorder::write(std::size_t index, std::int64_t ns, const json& message) {
  write_cdr(index, ns, topics_[index].definition->encode(message));
}

void RosbagRecorder::write_cdr(std::size_t index, std::int64_t ns, const std::string& cdr) {
  Topic& t = topics_[index];
  writer_->write(t.channel, record_, static_cast<std::uint64_t>(ns), static_cast<std::uint64_t>(ns),
                 cdr);
  ++t.count;
  first_ns_ = std::min(first_ns_, ns);
  last_ns_ = std::max(last_ns_, ns);
}

void RosbagRecorder::consume(const Record& record) {
  ++record_;
  switch (record.type) {
    case Record::Type::kReading: {
      const Reading& reading = record.reading;
      const std::int64_t ns = stamp_ns(reading.t_s);
      const int r = reading.robot;
      const RobotDef& robot = world_.robots[static_cast<std::size_t>(r)];
      if (const auto* odometry = std::get_if<OdometryReading>(&reading.data)) {
        if (odometry->has(kOdometryPose)) {
          const bool velocity = odometry->has(kOdometryVelocity);
          const double v = velocity ? odometry->v_mps : 0.0;
          const double w = velocity ? odometry->omega_radps : 0.0;
          const Pose2& p = odometry->odometry;
          const std::size_t odom = topic(prefix(r) + "/odom", "nav_msgs/msg/Odometry");
          const std::size_t tf = topic("/tf", "tf2_msgs/msg/TFMessage");
          if (options_.through_definitions) {
            const json covariance = std::vector<double>(36, 0.0);
            write(
                odom, ns,
                {{"header", header(ns, frame(r, "odom"))},
                 {"child_frame_id", frame(r, "base_link")},
                 {"pose", {{"pose", pose(p)}, {"covariance", covariance}}},
                 {"twist",
                  {{"twist", {{"linear", vector3(v, 0.0, 0.0)}, {"angular", vector3(0.0, 0.0, w)}}},
                   {"covariance", covariance}}}});
            write(tf, ns,
                  {{"transforms", {transform(ns, frame(r, "odom"), frame(r, "base_link"), p)}}});
          } else {
            cdr_.clear();
            put_header(cdr_, ns, frame(r, "odom"));
            cdr_.write_string(frame(r, "base_link"));
            put_pose(cdr_, p.x, p.y, p.theta);
            put_zeros(cdr_, 36);
            put_vector3(cdr_, v, 0.0, 0.0);
            put_vector3(cdr_, 0.0, 0.0, w);
            put_zeros(cdr_, 36);
            write_cdr(odom, ns, cdr_.bytes());
            cdr_.clear();
            put_one_transform(cdr_, ns, frame(r, "odom"), frame(r, "base_link"), p);
            write_cdr(tf, ns, cdr_.bytes());
          }
        }
        if (odometry->has(kOdometryTicks) && robot.sensors.encoders) {
          // A wheel's angle: its count over the counts a revolution (exact back to the count).
          const double per_tick = 2.0 * std::numbers::pi / robot.sensors.encoders->ticks_per_rev;
          const double left = static_cast<double>(odometry->left_ticks) * per_tick;
          const double right = static_cast<double>(odometry->right_ticks) * per_tick;
          const std::size_t joints =
              topic(prefix(r) + "/joint_states", "sensor_msgs/msg/JointState");
          if (options_.through_definitions) {
            write(joints, ns,
                  {{"header", header(ns, frame(r, "base_link"))},
                   {"name", {"left_wheel_joint", "right_wheel_joint"}},
                   {"position", {left, right}},
                   {"velocity", json::array()},
                   {"effort", json::array()}});
          } else {
            cdr_.clear();
            put_header(cdr_, ns, frame(r, "base_link"));
            cdr_.write_count(2);
            cdr_.write_string("left_wheel_joint");
            cdr_.write_string("right_wheel_joint");
            cdr_.write_count(2);
            cdr_.write(left);
            cdr_.write(right);
            cdr_.write_count(0);
            cdr_.write_count(0);
            write_cdr(joints, ns, cdr_.bytes());
          }
        }
      } else if (const auto* imu = std::get_if<ImuReading>(&reading.data)) {
        // No orientation (covariance[0] = -1, as REP 145 says); gravity on z as an IMU reads it.
        const std::size_t index = topic(prefix(r) + "/imu", "sensor_msgs/msg/Imu");
        constexpr double kGravity_mps2 = 9.80665;
        if (options_.through_definitions) {
          std::vector<double> unknown(9, 0.0);
          unknown[0] = -1.0;
          write(index, ns,
                {{"header", header(ns, frame(r, "imu_link"))},
                 {"orientation", yaw_quaternion(0.0)},
                 {"orientation_covariance", unknown},
                 {"angular_velocity", vector3(0.0, 0.0, imu->yaw_rate_radps)},
                 {"angular_velocity_covariance", std::vector<double>(9, 0.0)},
                 {"linear_acceleration",
                  vector3(imu->accel_mps2.x(), imu->accel_mps2.y(), kGravity_mps2)},
                 {"linear_acceleration_covariance", std::vector<double>(9, 0.0)}});
        } else {
          cdr_.clear();
          put_header(cdr_, ns, frame(r, "imu_link"));
          for (const double q : {0.0, 0.0, std::sin(0.0), std::cos(0.0)}) cdr_.write(q);
          cdr_.write(-1.0);
          put_zeros(cdr_, 8);
          put_vector3(cdr_, 0.0, 0.0, imu->yaw_rate_radps);
          put_zeros(cdr_, 9);
          put_vector3(cdr_, imu->accel_mps2.x(), imu->accel_mps2.y(), kGravity_mps2);
          put_zeros(cdr_, 9);
          write_cdr(index, ns, cdr_.bytes());
        }
      } else if (const auto* ptz = std::get_if<PtzReading>(&reading.data)) {
        write(topic(prefix(r) + "/detections/ptz_camera", "locsim_msgs/msg/Detections"), ns,
              detections_json(ns, frame(r, "base_link"), ptz->pan_rad, ptz->tilt_rad, ptz->zoom,
                              ptz->detections));
      } else if (const auto* omni = std::get_if<OmniReading>(&reading.data)) {
        write(topic(prefix(r) + "/detections/omni_camera", "locsim_msgs/msg/Detections"), ns,
              detections_json(ns, frame(r, "base_link"), 0.0, 0.0, 1.0, omni->detections));
      } else if (const auto* rb = std::get_if<RangeBearingReading>(&reading.data)) {
        write(topic(prefix(r) + "/detections/range_bearing", "locsim_msgs/msg/Detections"), ns,
              detections_json(ns, frame(r, "base_link"), 0.0, 0.0, 1.0, rb->detections));
      } else if (const auto* ultrasonic = std::get_if<UltrasonicReading>(&reading.data)) {
        json ranges = json::array();
        for (const BeaconRange& range : ultrasonic->ranges) {
          ranges.push_back({{"receiver", range.receiver},
                            {"beacon", range.beacon_id},
                            {"range", number(range.range_m)},
                            {"truth_status", static_cast<int>(range.truth_status)}});
        }
        write(topic(prefix(r) + "/beacon_ranges", "locsim_msgs/msg/BeaconRanges"), ns,
              {{"header", header(ns, frame(r, "base_link"))}, {"ranges", ranges}});
      } else if (const auto* scan = std::get_if<LaserScan>(&reading.data);
                 scan != nullptr && robot.sensors.laser) {
        const LaserDef& laser = *robot.sensors.laser;
        const int beams = static_cast<int>(scan->ranges_m.size());
        const double first = laser_beam_angle(0, beams, laser.fov_rad);
        const double step = beams > 1 ? laser_beam_angle(1, beams, laser.fov_rad) - first : 0.0;
        const std::size_t index = topic(prefix(r) + "/scan", "sensor_msgs/msg/LaserScan");
        // locsim's "nothing there" is max_range; ROS's is +inf (REP 117).
        const auto ros_range = [&](float range) {
          return range >= static_cast<float>(laser.max_range_m)
                     ? std::numeric_limits<float>::infinity()
                     : range;
        };
        const double fields[7] = {first,
                                  first + step * (beams - 1),
                                  step,
                                  0.0,
                                  1.0 / laser.common.rate_hz,
                                  laser.min_range_m,
                                  laser.max_range_m};
        if (options_.through_definitions) {
          json ranges = json::array();
          for (const float range : scan->ranges_m) {
            ranges.push_back(number(static_cast<double>(ros_range(range))));
          }
          write(index, ns,
                {{"header", header(ns, frame(r, "laser"))},
                 {"angle_min", fields[0]},
                 {"angle_max", fields[1]},
                 {"angle_increment", fields[2]},
                 {"time_increment", fields[3]},
                 {"scan_time", fields[4]},
                 {"range_min", fields[5]},
                 {"range_max", fields[6]},
                 {"ranges", ranges},
                 {"intensities", json::array()}});
        } else {
          cdr_.clear();
          put_header(cdr_, ns, frame(r, "laser"));
          for (const double field : fields) cdr_.write(static_cast<float>(field));
          cdr_.write_count(scan->ranges_m.size());
          for (const float range : scan->ranges_m) cdr_.write(ros_range(range));
          cdr_.write_count(0);
          write_cdr(index, ns, cdr_.bytes());
        }
      }
      break;
    }
    case Record::Type::kGroundTruth: {
      const std::int64_t ns = stamp_ns(record.t_s);
      if (record.t_s > last_clock_s_) {
        const std::size_t clock = topic("/clock", "rosgraph_msgs/msg/Clock");
        if (options_.through_definitions) {
          write(clock, ns, {{"clock", stamp(ns)}});
        } else {
          cdr_.clear();
          cdr_.write(static_cast<std::int32_t>(ns / 1'000'000'000));
          cdr_.write(static_cast<std::uint32_t>(ns % 1'000'000'000));
          write_cdr(clock, ns, cdr_.bytes());
        }
        last_clock_s_ = record.t_s;
      }
      if (!truth_known(record.pose) || record.robot < 0) break;
      const int r = record.robot;
      const Pose2& p = record.pose;
      const std::size_t truth = topic(prefix(r) + "/ground_truth", "geometry_msgs/msg/PoseStamped");
      const std::size_t tf = topic("/tf", "tf2_msgs/msg/TFMessage");
      if (options_.through_definitions) {
        write(truth, ns, {{"header", header(ns, "map")}, {"pose", pose(p)}});
        write(tf, ns, {{"transforms", {transform(ns, "map", frame(r, "base_link_truth"), p)}}});
      } else {
        cdr_.clear();
        put_header(cdr_, ns, "map");
        put_pose(cdr_, p.x, p.y, p.theta);
        write_cdr(truth, ns, cdr_.bytes());
        cdr_.clear();
        put_one_transform(cdr_, ns, "map", frame(r, "base_link_truth"), p);
        write_cdr(tf, ns, cdr_.bytes());
      }
      break;
    }
    case Record::Type::kEvent: {
      const SimEvent& event = record.event;
      const std::int64_t ns = stamp_ns(event.t_s);
      write(topic("/locsim/events", "locsim_msgs/msg/Event"), ns,
            {{"header", header(ns, "map")},
             {"kind", event.kind},
             {"robot", event.robot},
             {"step", event.step},
             {"details", event.details}});
      break;
    }
    case Record::Type::kEnd:
      break;
  }
}

std::string RosbagRecorder::localizer_topic(std::size_t localizer, const char* what) const {
  const LocalizerInfo& info = localizers_[localizer];
  // A ROS name holds letters, digits and underscores, and no name part starts with a digit
  // (a sweep's labels hold '-', '=' and '.').
  std::string label;
  for (const char c : info.label) label += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  if (label.empty() || std::isdigit(static_cast<unsigned char>(label.front()))) label = "_" + label;
  return prefix(static_cast<int>(info.robot)) + "/localizers/" + label + "/" + what;
}

void RosbagRecorder::add_localizers(const std::vector<LocalizerInfo>& localizers,
                                    LocalizerHost* host, double particles_hz) {
  localizers_ = localizers;
  host_ = host;
  particle_period_s_ = particles_hz > 0.0 ? 1.0 / particles_hz : 0.0;
  next_particles_s_ = 0.0;
}

void RosbagRecorder::estimate(const EstimateSample& sample) {
  if (sample.localizer >= localizers_.size()) return;
  const std::int64_t ns = stamp_ns(sample.t_s);
  // ROS's 6 x 6 over (x, y, z, roll, pitch, yaw), row-major; locsim's 3 x 3 over (x, y, theta).
  std::array<double, 36> covariance{};
  constexpr int kRos[3] = {0, 1, 5};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) covariance[kRos[i] * 6 + kRos[j]] = sample.covariance[i * 3 + j];
  }
  cdr_.clear();
  put_header(cdr_, ns, "map");
  put_pose(cdr_, sample.pose.x, sample.pose.y, sample.pose.theta);
  for (const double c : covariance) cdr_.write(c);  // a fixed array: no count
  write_cdr(topic(localizer_topic(sample.localizer, "pose"),
                  "geometry_msgs/msg/PoseWithCovarianceStamped"),
            ns, cdr_.bytes());
}

void RosbagRecorder::failure(const LocalizerFailure& failure) {
  if (failure.localizer >= localizers_.size()) return;
  const std::int64_t ns = stamp_ns(failure.t_s);
  write(topic(localizer_topic(failure.localizer, "failure"), "std_msgs/msg/String", true), ns,
        {{"data", "failed in its " + failure.call + " call: " + failure.message}});
}

void RosbagRecorder::records_until(double t_s) {
  // A nanosecond's slack: a log's times and the simulation's clock may differ in the last bit.
  if (host_ == nullptr || particle_period_s_ <= 0.0 || t_s + 1e-9 < next_particles_s_) return;
  const std::int64_t ns = stamp_ns(t_s);
  const std::vector<LocalizerSnapshot> snapshots = host_->snapshot(t_s);
  for (std::size_t k = 0; k < snapshots.size() && k < localizers_.size(); ++k) {
    if (snapshots[k].particles.empty()) continue;
    cdr_.clear();
    put_header(cdr_, ns, "map");
    cdr_.write_count(snapshots[k].particles.size());
    for (const locsim_pose2& p : snapshots[k].particles) put_pose(cdr_, p.x, p.y, p.theta);
    write_cdr(topic(localizer_topic(k, "particles"), "geometry_msgs/msg/PoseArray"), ns,
              cdr_.bytes());
  }
  // The next instant on the grid of 1 / particles_hz after t_s (never a burst after a gap).
  next_particles_s_ = (std::floor((t_s + 1e-9) / particle_period_s_) + 1.0) * particle_period_s_;
}

std::uint64_t RosbagRecorder::messages() const {
  return writer_->message_count();
}

void RosbagRecorder::finish() {
  if (finished_) return;
  writer_->finish();
  // metadata.yaml as rosbag2 writes it (version 5: what Humble reads, and Jazzy still does).
  std::string yaml =
      "rosbag2_bagfile_information:\n"
      "  version: 5\n"
      "  storage_identifier: mcap\n"
      "  duration:\n    nanoseconds: " +
      std::to_string(last_ns_ - first_ns_) +
      "\n"
      "  starting_time:\n    nanoseconds_since_epoch: " +
      std::to_string(first_ns_) +
      "\n"
      "  message_count: " +
      std::to_string(writer_->message_count()) +
      "\n"
      "  topics_with_message_count:\n";
  for (const Topic& t : topics_) {
    yaml +=
        "    - topic_metadata:\n        name: " + t.name + "\n        type: " + t.type +
        "\n        serialization_format: cdr\n        offered_qos_profiles: " + json(t.qos).dump() +
        "\n      message_count: " + std::to_string(t.count) + "\n";
  }
  const std::string file = file_.filename().string();
  yaml += "  compression_format: \"\"\n  compression_mode: \"\"\n  relative_file_paths:\n    - " +
          file + "\n  files:\n    - path: " + file +
          "\n      starting_time:\n        nanoseconds_since_epoch: " + std::to_string(first_ns_) +
          "\n      duration:\n        nanoseconds: " + std::to_string(last_ns_ - first_ns_) +
          "\n      message_count: " + std::to_string(writer_->message_count()) + "\n";
  write_file(folder_ / "metadata.yaml", yaml);
  finished_ = true;
}

}  // namespace locsim
