// `locsim import rosbag2`: bags written here (MCAP and SQLite, as rosbag2 writes them) of a robot
// driving a loop in a room, its scans cast in the room, its odometry drifting; imported, the
// laser's mount, the times, the map and the truth are the bag's, and amcl localizes on them.
#include "sim/producers/locsim_bag.hpp"
#include "sim/producers/rosbag_import.hpp"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "sim/common/errors.hpp"
#include "sim/rosbag/mcap.hpp"
#include "sim/rosbag/message_definition.hpp"
#include "sim/rosbag/ros_types.hpp"
#include "sim/stream/record.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using rosbag::MessageDefinition;
using testing::expect_contains;

void write_text(const fs::path& file, const std::string& text) {
  std::ofstream(file) << text;
}

std::size_t line_count(const fs::path& file) {
  const std::string text = testing::read_file(file);
  return static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n'));
}

constexpr double kPi = std::numbers::pi;
constexpr std::int64_t kEpochNs = 1'700'000'000'123'456'789;  // any epoch: times stay exact

// ---- the room, the robot's loop, its scans ------------------------------------------------------

struct Segment {
  Vec2 a, b;
};
/// A 10 x 8 m room with a box and a wall stub, so that no two places look alike.
const std::vector<Segment>& room() {
  static const std::vector<Segment> walls = {
      {{0, 0}, {10, 0}},  {{10, 0}, {10, 8}}, {{10, 8}, {0, 8}},    {{0, 8}, {0, 0}},
      {{6, 2}, {7, 2}},   {{7, 2}, {7, 3.5}}, {{7, 3.5}, {6, 3.5}}, {{6, 3.5}, {6, 2}},
      {{2, 8}, {2, 6.5}}, {{0, 3}, {1.2, 3}}};
  return walls;
}

/// The range along a ray from `from` in direction `angle` to the nearest wall, or +inf.
double cast(const Vec2& from, double angle) {
  const Vec2 d(std::cos(angle), std::sin(angle));
  double best = std::numeric_limits<double>::infinity();
  for (const Segment& s : room()) {
    const Vec2 e = s.b - s.a;
    const double denom = d.x() * e.y() - d.y() * e.x();
    if (std::abs(denom) < 1e-12) continue;
    const Vec2 w = s.a - from;
    const double t = (w.x() * e.y() - w.y() * e.x()) / denom;
    const double u = (w.x() * d.y() - w.y() * d.x()) / denom;
    if (t > 0.0 && u >= 0.0 && u <= 1.0) best = std::min(best, t);
  }
  return best;
}

/// The true pose at time t: an ellipse around the room's middle, heading along it.
Pose2 truth_at(double t_s) {
  const double w = 2.0 * kPi / 40.0;  // a lap in 40 s
  const double a = w * t_s;
  const Vec2 p(4.0 + 2.5 * std::cos(a), 4.5 + 2.0 * std::sin(a));
  const Vec2 v(-2.5 * w * std::sin(a), 2.0 * w * std::cos(a));
  return {p.x(), p.y(), std::atan2(v.y(), v.x())};
}

json stamp(std::int64_t ns) {
  return {{"sec", ns / 1'000'000'000}, {"nanosec", ns % 1'000'000'000}};
}
json header(std::int64_t ns, const std::string& frame) {
  return {{"stamp", stamp(ns)}, {"frame_id", frame}};
}
json quaternion(double roll, double yaw) {
  const double cr = std::cos(roll / 2), sr = std::sin(roll / 2);
  const double cy = std::cos(yaw / 2), sy = std::sin(yaw / 2);
  // Rz(yaw) Rx(roll): a yaw, then a roll about the turned x axis.
  return {{"x", sr * cy}, {"y", sr * sy}, {"z", cr * sy}, {"w", cr * cy}};
}
json pose(const Pose2& p) {
  return {{"position", {{"x", p.x}, {"y", p.y}, {"z", 0.0}}},
          {"orientation", quaternion(0, p.theta)}};
}
json transform(const std::string& parent, const std::string& child, std::int64_t ns, double x,
               double y, double z, double roll, double yaw) {
  return {{"header", header(ns, parent)},
          {"child_frame_id", child},
          {"transform",
           {{"translation", {{"x", x}, {"y", y}, {"z", z}}}, {"rotation", quaternion(roll, yaw)}}}};
}

/// The room as an OccupancyGrid message (5 cm cells, the walls marked along their length).
json occupancy_grid(std::int64_t ns) {
  const double resolution = 0.05;
  const int width = 220, height = 180;  // from (-0.5, -0.5)
  std::vector<int> cells(static_cast<std::size_t>(width * height), 0);
  for (const Segment& s : room()) {
    const double length = (s.b - s.a).norm();
    for (double u = 0.0; u <= length; u += resolution / 4) {
      const Vec2 p = s.a + (s.b - s.a) * (u / length);
      const int col = static_cast<int>(std::floor((p.x() + 0.5) / resolution));
      const int row = static_cast<int>(std::floor((p.y() + 0.5) / resolution));
      cells[static_cast<std::size_t>(row * width + col)] = 100;
    }
  }
  cells[0] = -1;  // an unknown cell
  return {{"header", header(ns, "map")},
          {"info",
           {{"map_load_time", stamp(ns)},
            {"resolution", resolution},
            {"width", width},
            {"height", height},
            {"origin", pose({-0.5, -0.5, 0.0})}}},
          {"data", cells}};
}

struct BagMessage {
  std::string topic, type;
  std::int64_t log_ns;
  json message;
};

struct LoopOptions {
  bool upside_down_laser = false;  // the scanner hangs under the base (roll pi)
  bool truth = true;
  bool odometry_as_tf = false;  // odom -> base_footprint on /tf, no /odom topic
  bool truth_as_tf = false;     // world -> mocap_body on /tf
  double seconds = 30.0;
};

/// A robot driving its loop: odometry at 20 Hz drifting (3 % long, 2 deg/m to the left), scans
/// at 10 Hz from a scanner at (0.10, 0.05) m turned +90 deg on base_link (itself 0.1 m above
/// base_footprint), an IMU, the truth, the room's map, and a topic an import skips.
std::vector<BagMessage> loop_bag(const LoopOptions& o) {
  std::vector<BagMessage> out;
  const double mount_x = 0.10, mount_y = 0.05, mount_yaw = kPi / 2;
  out.push_back({"/tf_static",
                 "tf2_msgs/msg/TFMessage",
                 kEpochNs,
                 {{"transforms",
                   {transform("base_footprint", "base_link", kEpochNs, 0, 0, 0.1, 0, 0),
                    transform("base_link", "laser", kEpochNs, mount_x, mount_y, 0.2,
                              o.upside_down_laser ? kPi : 0.0, mount_yaw),
                    transform("base_link", "imu_link", kEpochNs, 0, 0, 0.05, 0, 0)}}}});
  out.push_back({"/map", "nav_msgs/msg/OccupancyGrid", kEpochNs, occupancy_grid(kEpochNs)});
  out.push_back({"/chatter", "std_msgs/msg/String", kEpochNs, {{"data", "not a sensor"}}});
  Pose2 odom{0.0, 0.0, 0.0};
  Pose2 last = truth_at(0.0);
  const int steps = static_cast<int>(o.seconds * 20.0);
  for (int k = 0; k <= steps; ++k) {
    const double t = k / 20.0;
    const std::int64_t ns = kEpochNs + static_cast<std::int64_t>(k) * 50'000'000;
    const Pose2 truth = truth_at(t);
    // Odometry: the true motion in the base's frame, 3 % long, turning 2 deg a metre extra.
    const double dx = truth.x - last.x, dy = truth.y - last.y;
    const double forward = std::cos(last.theta) * dx + std::sin(last.theta) * dy;
    const double side = -std::sin(last.theta) * dx + std::cos(last.theta) * dy;
    const double turn = wrap_angle(truth.theta - last.theta);
    odom.x += 1.03 * (std::cos(odom.theta) * forward - std::sin(odom.theta) * side);
    odom.y += 1.03 * (std::sin(odom.theta) * forward + std::cos(odom.theta) * side);
    odom.theta = wrap_angle(odom.theta + turn + 2.0 * kPi / 180.0 * std::hypot(dx, dy));
    last = truth;
    const double v = std::hypot(dx, dy) * 20.0, w = turn * 20.0;
    if (o.odometry_as_tf) {
      out.push_back(
          {"/tf",
           "tf2_msgs/msg/TFMessage",
           ns + 1'000'000,
           {{"transforms",
             {transform("odom", "base_footprint", ns, odom.x, odom.y, 0, 0, odom.theta)}}}});
    } else {
      json covariance = json::array();
      for (int i = 0; i < 36; ++i) covariance.push_back(i % 7 == 0 ? 0.01 : 0.0);
      out.push_back({"/odom",
                     "nav_msgs/msg/Odometry",
                     ns + 1'000'000,
                     {{"header", header(ns, "odom")},
                      {"child_frame_id", "base_footprint"},
                      {"pose", {{"pose", pose(odom)}, {"covariance", covariance}}},
                      {"twist",
                       {{"twist",
                         {{"linear", {{"x", v}, {"y", 0.0}, {"z", 0.0}}},
                          {"angular", {{"x", 0.0}, {"y", 0.0}, {"z", w}}}}},
                        {"covariance", covariance}}}}});
    }
    out.push_back({"/imu",
                   "sensor_msgs/msg/Imu",
                   ns + 2'000'000,
                   {{"header", header(ns, "imu_link")},
                    {"orientation", quaternion(0, 0)},
                    {"orientation_covariance", std::vector<double>(9, 0.0)},
                    {"angular_velocity", {{"x", 0.0}, {"y", 0.0}, {"z", w}}},
                    {"angular_velocity_covariance", std::vector<double>(9, 0.0)},
                    {"linear_acceleration", {{"x", 0.25}, {"y", -0.5}, {"z", 9.81}}},
                    {"linear_acceleration_covariance", std::vector<double>(9, 0.0)}}});
    if (o.truth && o.truth_as_tf) {
      out.push_back(
          {"/tf",
           "tf2_msgs/msg/TFMessage",
           ns + 3'000'000,
           {{"transforms",
             {transform("world", "mocap_body", ns, truth.x, truth.y, 0.3, 0, truth.theta)}}}});
    } else if (o.truth) {
      out.push_back({"/ground_truth",
                     "geometry_msgs/msg/PoseStamped",
                     ns + 3'000'000,
                     {{"header", header(ns, "map")}, {"pose", pose(truth)}}});
    }
    if (k % 2 == 0) {
      // The scan, stamped 7 ms after the odometry: 360 beams from -pi, counter-clockwise in the
      // scanner's frame (clockwise in the base's when it hangs upside down).
      const std::int64_t scan_ns = ns + 7'000'000;
      const Pose2 at = truth_at(t + 0.007);
      const Vec2 origin(at.x + std::cos(at.theta) * mount_x - std::sin(at.theta) * mount_y,
                        at.y + std::sin(at.theta) * mount_x + std::cos(at.theta) * mount_y);
      json ranges = json::array();
      for (int i = 0; i < 360; ++i) {
        const double a = -kPi + i * (2.0 * kPi / 360.0);
        const double in_base = mount_yaw + (o.upside_down_laser ? -a : a);
        const double r = cast(origin, at.theta + in_base);
        ranges.push_back(r > 12.0 ? json("Infinity") : json(r));
      }
      ranges[7] = "NaN";  // a beam without a return
      out.push_back({"/scan",
                     "sensor_msgs/msg/LaserScan",
                     scan_ns + 1'000'000,
                     {{"header", header(scan_ns, "laser")},
                      {"angle_min", -kPi},
                      {"angle_max", kPi - 2.0 * kPi / 360.0},
                      {"angle_increment", 2.0 * kPi / 360.0},
                      {"time_increment", 0.0},
                      {"scan_time", 0.1},
                      {"range_min", 0.12},
                      {"range_max", 12.0},
                      {"ranges", ranges},
                      {"intensities", json::array()}}});
    }
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const BagMessage& a, const BagMessage& b) { return a.log_ns < b.log_ns; });
  return out;
}

/// rosbag2's MCAP: a folder with metadata.yaml and one file.
fs::path write_mcap_bag(const fs::path& folder, const std::vector<BagMessage>& messages) {
  fs::create_directories(folder);
  const std::string file = folder.filename().string() + "_0.mcap";
  rosbag::McapWriter writer(folder / file);
  std::map<std::string, std::uint16_t> channels;
  std::map<std::string, MessageDefinition> definitions;
  for (const BagMessage& m : messages) {
    if (!channels.contains(m.topic)) {
      const std::uint16_t schema =
          writer.add_schema(m.type, "ros2msg", rosbag::schema_text(m.type));
      channels[m.topic] =
          writer.add_channel(schema, m.topic, "cdr", {{"offered_qos_profiles", ""}});
      definitions.emplace(m.topic, MessageDefinition::known(m.type));
    }
    writer.write(channels.at(m.topic), 0, static_cast<std::uint64_t>(m.log_ns),
                 static_cast<std::uint64_t>(m.log_ns), definitions.at(m.topic).encode(m.message));
  }
  writer.finish();
  write_text(folder / "metadata.yaml",
             "rosbag2_bagfile_information:\n  version: 8\n  storage_identifier: mcap\n"
             "  relative_file_paths:\n    - " +
                 file + "\n");
  return folder;
}

/// rosbag2's SQLite file as Humble writes it: no definitions in it.
fs::path write_sqlite_bag(const fs::path& file, const std::vector<BagMessage>& messages) {
  fs::create_directories(file.parent_path());
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
  sqlite3_exec(db,
               "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT "
               "NULL, serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);"
               "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, "
               "timestamp INTEGER NOT NULL, data BLOB NOT NULL);",
               nullptr, nullptr, nullptr);
  std::map<std::string, int> ids;
  sqlite3_stmt* topic = nullptr;
  sqlite3_stmt* message = nullptr;
  sqlite3_prepare_v2(db, "INSERT INTO topics VALUES (?, ?, ?, 'cdr', '')", -1, &topic, nullptr);
  sqlite3_prepare_v2(db, "INSERT INTO messages(topic_id, timestamp, data) VALUES (?, ?, ?)", -1,
                     &message, nullptr);
  sqlite3_exec(db, "BEGIN", nullptr, nullptr, nullptr);
  for (const BagMessage& m : messages) {
    if (!ids.contains(m.topic)) {
      const int id = static_cast<int>(ids.size()) + 1;
      ids[m.topic] = id;
      sqlite3_bind_int(topic, 1, id);
      sqlite3_bind_text(topic, 2, m.topic.c_str(), -1, SQLITE_TRANSIENT);
      sqlite3_bind_text(topic, 3, m.type.c_str(), -1, SQLITE_TRANSIENT);
      sqlite3_step(topic);
      sqlite3_reset(topic);
    }
    const std::string bytes = MessageDefinition::known(m.type).encode(m.message);
    sqlite3_bind_int(message, 1, ids.at(m.topic));
    sqlite3_bind_int64(message, 2, m.log_ns);
    sqlite3_bind_blob(message, 3, bytes.data(), static_cast<int>(bytes.size()), SQLITE_TRANSIENT);
    sqlite3_step(message);
    sqlite3_reset(message);
  }
  sqlite3_exec(db, "COMMIT", nullptr, nullptr, nullptr);
  sqlite3_finalize(topic);
  sqlite3_finalize(message);
  sqlite3_close(db);
  return file;
}

RosbagDataset import_bag(const fs::path& bag, RosbagTopics topics = {}) {
  RosbagImportOptions options;
  options.bag = bag;
  options.topics = std::move(topics);
  return read_rosbag2(options);
}

// ---- what an import reads ----------------------------------------------------------------------

TEST(RosbagImport, ReadsTheLaserItsMountTheOdometryImuTruthAndMapAsTheBagHasThem) {
  const fs::path bag = write_mcap_bag(testing::temp_dir("bag") / "loop", loop_bag({}));
  const RosbagDataset read = import_bag(bag);
  const ImportedDataset& dataset = read.dataset;
  ASSERT_EQ(dataset.robots.size(), 1u);
  const ImportedRobot& robot = dataset.robots[0];

  // Times: nanoseconds from the earliest stamp (the first odometry's), exact whatever the epoch.
  EXPECT_EQ(dataset.source["t0_unix_ns"].get<std::int64_t>(), kEpochNs);
  ASSERT_EQ(robot.odometry.size(), 601u);
  EXPECT_EQ(robot.odometry[0].t_s, 0.0);
  EXPECT_EQ(robot.odometry[37].t_s, 37 * 50'000'000 / 1e9);
  ASSERT_EQ(robot.scans.size(), 301u);
  EXPECT_EQ(robot.scans[3].t_s, (6 * 50'000'000 + 7'000'000) / 1e9);
  ASSERT_EQ(robot.truth.size(), 601u);
  EXPECT_NEAR(robot.truth[100].pose.x, truth_at(5.0).x, 1e-12);
  EXPECT_NEAR(robot.truth[100].pose.theta, truth_at(5.0).theta, 1e-12);
  ASSERT_EQ(robot.imu.size(), 601u);
  EXPECT_DOUBLE_EQ(robot.imu[5].reading.accel_mps2.y(), -0.5);
  EXPECT_TRUE(robot.odometry[5].reading.has(kOdometryPose));
  EXPECT_TRUE(robot.odometry[5].reading.has(kOdometryVelocity));

  // The laser: base_footprint -> base_link -> laser composed; 360 beams over a turn, centred.
  ASSERT_TRUE(robot.laser.has_value());
  EXPECT_EQ(robot.laser->beams, 360);
  EXPECT_NEAR(robot.laser->common.mount.x, 0.10, 1e-12);
  EXPECT_NEAR(robot.laser->common.mount.y, 0.05, 1e-12);
  // Beams from -pi to pi - 1 deg on a mount turned +90 deg: centred on 90 - 0.5 deg (the
  // message's angles are float32s).
  EXPECT_NEAR(robot.laser->common.mount.theta, kPi / 2 - 0.5 * kPi / 180.0, 1e-6);
  EXPECT_NEAR(robot.laser->fov_rad, 2.0 * kPi * 359.0 / 360.0, 1e-6);
  EXPECT_FLOAT_EQ(static_cast<float>(robot.laser->max_range_m), 12.0f);
  EXPECT_EQ(robot.scans[0].scan.ranges_m[7], 12.0f);  // NaN: no return, read as max range

  // The map: the grid as a map_server map, its rows the right way up.
  ASSERT_TRUE(dataset.map.has_value());
  expect_contains(dataset.map->yaml_text, "resolution: 0.05\n");  // the float32's digits
  expect_contains(dataset.map->yaml_text, "origin: [-0.5, -0.5, 0]");
  const std::string& image = dataset.map->image_bytes;
  ASSERT_TRUE(image.starts_with("P5\n220 180\n255\n"));
  const std::size_t pixels = image.size() - (220 * 180);
  // The grid's first cell (unknown) is the image's bottom-left pixel.
  EXPECT_EQ(static_cast<unsigned char>(image[pixels + 179 * 220]), 205);
  // The wall y = 0 is grid row 10, image row 169: occupied (0); the room's middle free (254).
  EXPECT_EQ(static_cast<unsigned char>(image[pixels + 169 * 220 + 100]), 0);
  EXPECT_EQ(static_cast<unsigned char>(image[pixels + 90 * 220 + 100]), 254);

  std::map<std::string, std::string> uses;
  for (const RosbagTopicUse& topic : read.topics) uses[topic.name] = topic.use;
  EXPECT_EQ(uses["/scan"], "laser");
  EXPECT_EQ(uses["/odom"], "odometry");
  EXPECT_EQ(uses["/imu"], "imu");
  EXPECT_EQ(uses["/ground_truth"], "truth");
  EXPECT_EQ(uses["/map"], "map");
  EXPECT_EQ(uses["/tf_static"], "frames (sensor mounts)");
  EXPECT_EQ(uses["/chatter"], "skipped: a type locsim does not read");
}

TEST(RosbagImport, AScannerHangingUpsideDownGivesTheSameBeamsInTheBasesAngles) {
  const fs::path dir = testing::temp_dir("bags");
  const RosbagDataset upright = import_bag(write_mcap_bag(dir / "upright", loop_bag({})));
  LoopOptions hanging;
  hanging.upside_down_laser = true;
  const RosbagDataset flipped = import_bag(write_mcap_bag(dir / "hanging", loop_bag(hanging)));
  const ImportedRobot& a = upright.dataset.robots[0];
  const ImportedRobot& b = flipped.dataset.robots[0];
  ASSERT_EQ(a.scans.size(), b.scans.size());
  // The flipped scanner's beams run clockwise in the base: reversed, they are the upright one's
  // shifted by one beam (its first beam, -pi, is the other's last, +pi - 1 deg, mirrored).
  EXPECT_NEAR(b.laser->common.mount.theta, kPi / 2 + 0.5 * kPi / 180.0, 1e-6);
  for (std::size_t i = 1; i < 359; ++i) {
    if (i == 7 || i == 352 || i == 353) continue;  // the NaN beam, on either side
    EXPECT_NEAR(b.scans[10].scan.ranges_m[i - 1], a.scans[10].scan.ranges_m[i], 1e-5) << i;
  }
}

TEST(RosbagImport, AmclLocalizesOnTheBagsMapWithItsScansAndOdometry) {
  const fs::path dir = testing::temp_dir("amcl");
  for (const std::string storage : {"mcap", "sqlite3"}) {
    SCOPED_TRACE(storage);
    LoopOptions hanging;
    hanging.upside_down_laser = storage == "sqlite3";  // and hanging, read from SQLite
    const std::vector<BagMessage> messages = loop_bag(hanging);
    const fs::path bag = storage == "mcap" ? write_mcap_bag(dir / "loop_mcap", messages)
                                           : write_sqlite_bag(dir / "loop.db3", messages);
    const fs::path log = dir / (storage + ".locsimlog");
    const auto imported =
        testing::locsim("import rosbag2 " + bag.string() + " --out " + log.string());
    ASSERT_EQ(imported.exit_code, 0) << imported.output;
    expect_contains(imported.output, "601 odometry, 601 IMU, 301 laser scans");
    const fs::path run = dir / ("run_" + storage);
    const auto replayed = testing::locsim("replay " + log.string() + " --out " + run.string() +
                                          " --localizer amcl --localizer odometry");
    ASSERT_EQ(replayed.exit_code, 0) << replayed.output;
    const json metrics = json::parse(testing::read_file(run / "metrics.json"));
    const json& amcl = metrics["localizers"][0];
    const json& odometry = metrics["localizers"][1];
    EXPECT_EQ(amcl["samples"], 601);
    // Dead reckoning drifts off (3 % long, a turn of 2 deg a metre); amcl holds the room.
    EXPECT_GT(odometry["position_error_m"]["max"].get<double>(), 0.6);
    EXPECT_LT(amcl["position_error_m"]["rms"].get<double>(), 0.15);
    EXPECT_LT(amcl["heading_error_deg"]["rms"].get<double>(), 3.0);
  }
}

TEST(RosbagImport, OdometryFromTfAndTruthFromAMotionCaptureFrame) {
  LoopOptions o;
  o.odometry_as_tf = true;
  o.truth_as_tf = true;
  const fs::path bag = write_mcap_bag(testing::temp_dir("bag") / "tf", loop_bag(o));
  RosbagTopics topics;
  topics.odometry = "tf";
  topics.base_frame = "base_footprint";
  topics.truth = "tf:mocap_body";
  const RosbagDataset read = import_bag(bag, topics);
  const ImportedRobot& robot = read.dataset.robots[0];
  ASSERT_EQ(robot.odometry.size(), 601u);
  EXPECT_TRUE(robot.odometry[3].reading.has(kOdometryPose));
  EXPECT_FALSE(robot.odometry[3].reading.has(kOdometryVelocity));
  ASSERT_EQ(robot.truth.size(), 601u);
  EXPECT_NEAR(robot.truth[200].pose.y, truth_at(10.0).y, 1e-12);
  EXPECT_EQ(read.dataset.source["topics"]["truth"], "tf:mocap_body");

  // Without --base-frame, tf odometry looks for base_link, which this bag's /tf does not move.
  topics.base_frame.clear();
  try {
    import_bag(bag, topics);
    FAIL();
  } catch (const InputError& e) {
    expect_contains(e.what(),
                    "--odom tf: the bag's /tf has no transform from 'odom' to "
                    "'base_link'");
  }
}

TEST(RosbagImport, WithoutTruthTheEstimatesAreKeptAndNothingIsScoredAndTheReportSaysSo) {
  const fs::path dir = testing::temp_dir("notruth");
  LoopOptions o;
  o.truth = false;
  o.seconds = 10.0;
  const fs::path bag = write_mcap_bag(dir / "bag", loop_bag(o));
  const RosbagDataset read = import_bag(bag);
  const ImportedRobot& robot = read.dataset.robots[0];
  ASSERT_EQ(robot.truth.size(), robot.odometry.size());  // sampling instants at the odometry's
  EXPECT_FALSE(truth_known(robot.truth[0].pose));
  ASSERT_TRUE(robot.start.has_value());  // the first odometry pose
  EXPECT_EQ(robot.start->x, 0.0);

  const fs::path log = dir / "log.locsimlog";
  const auto imported = testing::locsim("import rosbag2 " + bag.string() + " --out " +
                                        log.string() + " --start 6.5,4.5,1.5707963");
  ASSERT_EQ(imported.exit_code, 0) << imported.output;
  expect_contains(imported.output, "0 true poses, 201 sampling instants without truth");
  expect_contains(imported.output, "note: no truth: the localizers' estimates are kept");
  const auto replayed = testing::locsim("replay " + log.string() + " --out " +
                                        (dir / "run").string() + " --localizer amcl");
  ASSERT_EQ(replayed.exit_code, 0) << replayed.output;
  expect_contains(replayed.output,
                  "the log has no ground truth: the estimates are in the .tum "
                  "files, and metrics.json scores nothing");
  const json metrics = json::parse(testing::read_file(dir / "run" / "metrics.json"));
  const json& amcl = metrics["localizers"][0];
  EXPECT_EQ(amcl["samples"], 0);
  EXPECT_EQ(amcl["unscored_samples"], 201);
  EXPECT_TRUE(amcl["position_error_m"]["rms"].is_null());  // not a perfect 0
  // The estimates are there, and no true pose was made up.
  EXPECT_EQ(line_count(dir / "run" / "amcl.tum"), 202u);  // a header and 201
  EXPECT_EQ(line_count(dir / "run" / "groundtruth.tum"), 1u);
}

TEST(RosbagImport, RefusesWhatItCannotUseNamingTheMessagesPlaceTopicAndTime) {
  const fs::path dir = testing::temp_dir("bad");
  const auto refusal = [](const fs::path& bag, RosbagTopics topics = {}) -> std::string {
    try {
      import_bag(bag, std::move(topics));
    } catch (const InputError& e) {
      return e.what();
    }
    return "(imported)";
  };
  LoopOptions short_loop;
  short_loop.seconds = 2.0;
  std::vector<BagMessage> messages = loop_bag(short_loop);

  // A scan that is cut short: its file, byte, topic and log time.
  {
    const fs::path folder = dir / "cut";
    fs::create_directories(folder);
    rosbag::McapWriter writer(folder / "cut.mcap");
    const std::uint16_t odom =
        writer.add_channel(writer.add_schema("nav_msgs/msg/Odometry", "ros2msg",
                                             rosbag::schema_text("nav_msgs/msg/Odometry")),
                           "/odom", "cdr");
    const std::uint16_t scan =
        writer.add_channel(writer.add_schema("sensor_msgs/msg/LaserScan", "ros2msg",
                                             rosbag::schema_text("sensor_msgs/msg/LaserScan")),
                           "/scan", "cdr");
    for (const BagMessage& m : messages) {
      if (m.topic == "/odom") {
        writer.write(odom, 0, static_cast<std::uint64_t>(m.log_ns), 0,
                     MessageDefinition::known(m.type).encode(m.message));
      } else if (m.topic == "/scan") {
        const std::string bytes = MessageDefinition::known(m.type).encode(m.message);
        writer.write(scan, 0, static_cast<std::uint64_t>(m.log_ns), 0,
                     std::string_view(bytes).substr(0, bytes.size() / 2));
      }
    }
    writer.finish();
    const std::string error = refusal(folder / "cut.mcap");
    expect_contains(error, (folder / "cut.mcap").string() + ": byte ");
    expect_contains(error, "topic /scan, log time " + std::to_string(kEpochNs + 8'000'000) + " ns");
    expect_contains(error, "byte 52: a sequence of 360 elements cannot fit");
  }
  // Two scanners and none named: the import asks which.
  std::vector<BagMessage> two = messages;
  for (const BagMessage& m : messages) {
    if (m.topic == "/scan") two.push_back({"/scan_rear", m.type, m.log_ns, m.message});
  }
  for (BagMessage& m : two) {
    if (m.topic == "/scan") m.topic = "/scan_front";
  }
  const fs::path two_bag = write_mcap_bag(dir / "two", two);
  expect_contains(refusal(two_bag),
                  "the bag has 2 topics that could be the laser (/scan_front, /scan_rear): name "
                  "one with --laser");
  RosbagTopics front;
  front.laser = "/scan_front";
  EXPECT_EQ(import_bag(two_bag, front).dataset.robots[0].scans.size(), 21u);
  front.laser = "/odom";
  expect_contains(refusal(two_bag, front),
                  "--laser: '/odom' is a nav_msgs/msg/Odometry, not a sensor_msgs/msg/LaserScan");
  front.laser = "/nothing";
  expect_contains(refusal(two_bag, front), "--laser: the bag has no topic '/nothing'");

  // No odometry; a scanner whose frame /tf_static does not place.
  std::vector<BagMessage> no_odometry, no_frames;
  for (const BagMessage& m : messages) {
    if (m.topic != "/odom") no_odometry.push_back(m);
    if (m.topic != "/tf_static") no_frames.push_back(m);
  }
  expect_contains(refusal(write_mcap_bag(dir / "no_odometry", no_odometry)),
                  "no odometry: name a nav_msgs/msg/Odometry topic (--odom TOPIC)");
  expect_contains(refusal(write_mcap_bag(dir / "no_frames", no_frames)),
                  "the scan's frame 'laser' is not placed on the base 'base_footprint' by the "
                  "bag's /tf_static");
}

TEST(RosbagImport, ListsTheTopicsAndWhatBecomesOfThemWritingNothing) {
  const fs::path dir = testing::temp_dir("list");
  LoopOptions o;
  o.seconds = 1.0;
  const fs::path bag = write_mcap_bag(dir / "bag", loop_bag(o));
  const auto listed = testing::locsim("import rosbag2 " + bag.string() + " --list");
  ASSERT_EQ(listed.exit_code, 0) << listed.output;
  expect_contains(listed.output,
                  "/scan          sensor_msgs/msg/LaserScan             11  laser\n");
  expect_contains(listed.output,
                  "/chatter       std_msgs/msg/String                    1  skipped: a type "
                  "locsim does not read\n");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
  // A bag locsim did not write is not taken for one (and nothing is written for it).
  EXPECT_FALSE(rebuild_locsim_log(bag, dir / "not_ours.locsimlog").has_value());
  EXPECT_FALSE(fs::exists(dir / "not_ours.locsimlog.partial"));
  const auto other = testing::locsim("import generic " + dir.string() + " --list");
  EXPECT_EQ(other.exit_code, 2);
  expect_contains(other.output, "--list: for rosbag2 only");
  const auto no_out = testing::locsim("import rosbag2 " + bag.string());
  EXPECT_EQ(no_out.exit_code, 2);
  expect_contains(no_out.output, "--out: the log file to write is required");
}

}  // namespace
}  // namespace locsim
