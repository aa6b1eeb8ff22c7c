// `locsim export LOG --rosbag2 OUT`: a log as a ROS 2 bag. An independent reader (npm's
// @mcap/core and @foxglove/rosmsg2-serialization, tests/checkers) decodes every topic of an
// exported demo run, and each value is the log's: poses to 1e-9, scans bit for bit.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "sim/common/errors.hpp"
#include "sim/producers/log_source.hpp"
#include "sim/producers/rosbag_import.hpp"
#include "sim/producers/text_table.hpp"
#include "sim/run/export_bag.hpp"
#include "sim/run/runner.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::expect_contains;

/// A 23 s run of the demo world (encoders, IMU, laser, cameras, beacons; a kidnap at 20 s), logged.
fs::path demo_log(const fs::path& dir) {
  RunOptions options;
  options.world_file = fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml";
  options.duration_s = 23.0;
  options.out_dir = dir / "run";
  options.log_file = dir / "demo.locsimlog";
  options.readings = false;
  run_simulation(options);
  return *options.log_file;
}

std::int64_t stamp_ns(const json& header) {
  return header["stamp"]["sec"].get<std::int64_t>() * 1'000'000'000 +
         header["stamp"]["nanosec"].get<std::int64_t>();
}
double yaw(const json& q) {
  const double x = q["x"], y = q["y"], z = q["z"], w = q["w"];
  return std::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
}
double number(const json& value) {
  return value.is_string() ? std::strtod(value.get<std::string>().c_str(), nullptr)
                           : value.get<double>();
}

/// Every message of an MCAP file as the independent reader (tests/checkers) decodes it: its
/// summary line (the header and channels) into `header`, the messages by topic into `topics`.
void dump_bag(const fs::path& mcap, json& header,
              std::map<std::string, std::vector<json>>& topics) {
  const fs::path checkers = fs::path(LOCSIM_SOURCE_DIR) / "tests" / "checkers";
  ASSERT_TRUE(fs::exists(checkers / "node_modules"))
      << "run tools/setup (npm ci in tests/checkers)";
  const auto dumped =
      testing::run_command("node " + (checkers / "mcap_dump.mjs").string() + " " + mcap.string());
  ASSERT_EQ(dumped.exit_code, 0) << dumped.output;
  std::istringstream lines(dumped.output);
  for (std::string line; std::getline(lines, line);) {
    const json j = json::parse(line);
    if (j.contains("header")) {
      header = j;
    } else {
      topics[j["topic"].get<std::string>()].push_back(j["message"]);
    }
  }
}

TEST(RosbagExport, AnIndependentReaderDecodesEveryTopicToTheLogsValues) {
  const fs::path dir = testing::temp_dir("export");
  const fs::path log = demo_log(dir);
  const auto exported =
      testing::locsim("export " + log.string() + " --rosbag2 " + (dir / "bag").string());
  ASSERT_EQ(exported.exit_code, 0) << exported.output;
  json header;
  std::map<std::string, std::vector<json>> topics;
  ASSERT_NO_FATAL_FAILURE(dump_bag(dir / "bag" / "bag_0.mcap", header, topics));
  EXPECT_EQ(header["header"]["profile"], "ros2");
  // /map, /tf_static and the log's header are offered transient local (durability 1), so a late
  // node gets them.
  for (const json& channel : header["channels"]) {
    const std::string qos = channel["metadata"]["offered_qos_profiles"];
    const bool latched = channel["topic"] == "/map" || channel["topic"] == "/tf_static" ||
                         channel["topic"] == "/locsim/log_header";
    expect_contains(qos, latched ? "durability: 1" : "durability: 2");
  }

  // Every record of the log against the bag's messages, in order.
  LogSource source(log);
  const RobotDef& robot = source.world().robots[0];
  const double per_tick = 2.0 * std::numbers::pi / robot.sensors.encoders->ticks_per_rev;
  const auto ns = [](double t_s) { return 1'000'000'000 + std::llround(t_s * 1e9); };
  std::map<std::string, std::size_t> at;
  std::size_t true_poses = 0, scans = 0, events = 0;
  Record record;
  while (source.next(record)) {
    if (record.type == Record::Type::kReading) {
      const Reading& r = record.reading;
      if (const auto* odometry = std::get_if<OdometryReading>(&r.data)) {
        const json& m = topics["/odom"].at(at["/odom"]++);
        EXPECT_EQ(stamp_ns(m["header"]), ns(r.t_s));
        EXPECT_NEAR(m["pose"]["pose"]["position"]["x"].get<double>(), odometry->odometry.x, 1e-9);
        EXPECT_NEAR(m["pose"]["pose"]["position"]["y"].get<double>(), odometry->odometry.y, 1e-9);
        EXPECT_NEAR(yaw(m["pose"]["pose"]["orientation"]), odometry->odometry.theta, 1e-9);
        const json& joints = topics["/joint_states"].at(at["/joint_states"]++);
        EXPECT_EQ(std::llround(joints["position"][0].get<double>() / per_tick),
                  odometry->left_ticks);
        EXPECT_EQ(std::llround(joints["position"][1].get<double>() / per_tick),
                  odometry->right_ticks);
      } else if (const auto* imu = std::get_if<ImuReading>(&r.data)) {
        const json& m = topics["/imu"].at(at["/imu"]++);
        EXPECT_EQ(m["angular_velocity"]["z"].get<double>(), imu->yaw_rate_radps);
        EXPECT_EQ(m["linear_acceleration"]["x"].get<double>(), imu->accel_mps2.x());
      } else if (const auto* scan = std::get_if<LaserScan>(&r.data)) {
        const json& m = topics["/scan"].at(at["/scan"]++);
        ++scans;
        EXPECT_EQ(stamp_ns(m["header"]), ns(r.t_s));
        ASSERT_EQ(m["ranges"].size(), scan->ranges_m.size());
        for (std::size_t i = 0; i < scan->ranges_m.size(); ++i) {
          const float ours = scan->ranges_m[i];
          const float theirs = static_cast<float>(number(m["ranges"][i]));
          if (ours >= static_cast<float>(robot.sensors.laser->max_range_m)) {
            EXPECT_TRUE(std::isinf(theirs)) << i;  // no return: +inf, REP 117
          } else {
            EXPECT_EQ(std::bit_cast<std::uint32_t>(theirs), std::bit_cast<std::uint32_t>(ours))
                << i;
          }
        }
        // The beams' angles as the laser spreads them.
        EXPECT_NEAR(m["angle_min"].get<double>(), -0.5 * robot.sensors.laser->fov_rad, 1e-6);
      }
    } else if (record.type == Record::Type::kGroundTruth) {
      const json& m = topics["/ground_truth"].at(at["/ground_truth"]++);
      ++true_poses;
      EXPECT_EQ(stamp_ns(m["header"]), ns(record.t_s));
      EXPECT_NEAR(m["pose"]["position"]["x"].get<double>(), record.pose.x, 1e-9);
      EXPECT_NEAR(m["pose"]["position"]["y"].get<double>(), record.pose.y, 1e-9);
      EXPECT_NEAR(yaw(m["pose"]["orientation"]), record.pose.theta, 1e-9);
    } else if (record.type == Record::Type::kEvent) {
      const json& m = topics["/locsim/events"].at(at["/locsim/events"]++);
      ++events;
      EXPECT_EQ(m["kind"], record.event.kind);
      EXPECT_EQ(m["step"].get<std::string>(), std::to_string(record.event.step));
    }
  }
  EXPECT_GT(true_poses, 100u);
  EXPECT_GT(scans, 20u);
  EXPECT_GE(events, 2u);  // the kidnap and its put-down
  for (const auto& [topic, count] : at) EXPECT_EQ(count, topics[topic].size()) << topic;
  // The static frames: the laser's mount as the world has it.
  const json& mounts = topics["/tf_static"].at(0)["transforms"];
  bool laser = false;
  for (const json& t : mounts) {
    if (t["child_frame_id"] != "laser") continue;
    laser = true;
    EXPECT_NEAR(t["transform"]["translation"]["x"].get<double>(),
                robot.sensors.laser->common.mount.x, 1e-12);
    EXPECT_NEAR(yaw(t["transform"]["rotation"]), robot.sensors.laser->common.mount.theta, 1e-12);
  }
  EXPECT_TRUE(laser);
  ASSERT_EQ(topics["/map"].size(), 1u);
  EXPECT_GT(topics["/map"][0]["info"]["width"].get<int>(), 10);

  // And locsim reads its own bag back: the same scans, bit for bit, and the truth.
  RosbagImportOptions options;
  options.bag = dir / "bag";
  const RosbagDataset read = read_rosbag2(options);
  const ImportedRobot& imported = read.dataset.robots[0];
  EXPECT_EQ(imported.scans.size(), scans);
  EXPECT_EQ(imported.truth.size(), true_poses);
}

/// Readings equal: exactly, but an odometry heading (through a quaternion) to 1e-12 rad.
void expect_same_reading(const Reading& a, const Reading& b) {
  ASSERT_EQ(a.kind, b.kind);
  ASSERT_EQ(a.robot, b.robot);
  if (const auto* o = std::get_if<OdometryReading>(&a.data)) {
    const auto& p = std::get<OdometryReading>(b.data);
    EXPECT_EQ(o->fields, p.fields);
    EXPECT_EQ(o->left_ticks, p.left_ticks);
    EXPECT_EQ(o->right_ticks, p.right_ticks);
    EXPECT_EQ(o->odometry.x, p.odometry.x);
    EXPECT_EQ(o->odometry.y, p.odometry.y);
    EXPECT_NEAR(o->odometry.theta, p.odometry.theta, 1e-12);
    EXPECT_EQ(o->v_mps, p.v_mps);
    EXPECT_EQ(o->omega_radps, p.omega_radps);
  } else if (const auto* scan = std::get_if<LaserScan>(&a.data)) {
    EXPECT_EQ(scan->ranges_m, std::get<LaserScan>(b.data).ranges_m);  // bit for bit
  } else if (const auto* imu = std::get_if<ImuReading>(&a.data)) {
    EXPECT_EQ(imu->yaw_rate_radps, std::get<ImuReading>(b.data).yaw_rate_radps);
    EXPECT_EQ(imu->accel_mps2, std::get<ImuReading>(b.data).accel_mps2);
  } else if (const auto* ptz = std::get_if<PtzReading>(&a.data)) {
    const auto& q = std::get<PtzReading>(b.data);
    EXPECT_EQ(ptz->pan_rad, q.pan_rad);
    ASSERT_EQ(ptz->detections.size(), q.detections.size());
    for (std::size_t i = 0; i < q.detections.size(); ++i) {
      EXPECT_EQ(ptz->detections[i].id, q.detections[i].id);
      EXPECT_EQ(ptz->detections[i].color, q.detections[i].color);
      EXPECT_EQ(ptz->detections[i].range_m, q.detections[i].range_m);
      EXPECT_EQ(ptz->detections[i].bearing_rad, q.detections[i].bearing_rad);
      EXPECT_EQ(ptz->detections[i].truth_id, q.detections[i].truth_id);
    }
  } else if (const auto* u = std::get_if<UltrasonicReading>(&a.data)) {
    const auto& v = std::get<UltrasonicReading>(b.data);
    ASSERT_EQ(u->ranges.size(), v.ranges.size());
    for (std::size_t i = 0; i < v.ranges.size(); ++i) {
      EXPECT_EQ(u->ranges[i].beacon_id, v.ranges[i].beacon_id);
      EXPECT_TRUE(u->ranges[i].range_m == v.ranges[i].range_m ||
                  (std::isnan(u->ranges[i].range_m) && std::isnan(v.ranges[i].range_m)));
      EXPECT_EQ(u->ranges[i].truth_status, v.ranges[i].truth_status);
    }
  }
}

TEST(RosbagExport, ExportThenImportGivesTheRunsRecordsAndItsLocalizersTheirEstimates) {
  const fs::path dir = testing::temp_dir("round");
  RunOptions options;
  options.world_file = fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml";
  options.duration_s = 23.0;
  options.out_dir = dir / "run";
  options.log_file = dir / "demo.locsimlog";
  options.localizers = {"ekf_landmarks", "amcl", "ultrasonic_amcl"};
  options.readings = false;
  run_simulation(options);
  const auto exported = testing::locsim("export " + options.log_file->string() + " --rosbag2 " +
                                        (dir / "bag").string());
  ASSERT_EQ(exported.exit_code, 0) << exported.output;
  const auto imported = testing::locsim("import rosbag2 " + (dir / "bag").string() + " --out " +
                                        (dir / "back.locsimlog").string());
  ASSERT_EQ(imported.exit_code, 0) << imported.output;
  expect_contains(imported.output, "a bag locsim exported");

  // Every record, in order: times to the nanosecond, readings as the log has them.
  LogSource original(*options.log_file), back(dir / "back.locsimlog");
  EXPECT_EQ(original.header().dump(), back.header().dump());  // the world, as exported
  Record a, b;
  std::size_t records = 0;
  while (original.next(a)) {
    ASSERT_TRUE(back.next(b)) << "record " << records;
    ASSERT_EQ(a.type, b.type) << "record " << records;
    if (a.type == Record::Type::kReading) {
      EXPECT_NEAR(a.reading.t_s, b.reading.t_s, 1e-9);
      expect_same_reading(a.reading, b.reading);
    } else if (a.type == Record::Type::kGroundTruth) {
      EXPECT_NEAR(a.t_s, b.t_s, 1e-9);
      EXPECT_EQ(a.pose.x, b.pose.x);
      EXPECT_NEAR(a.pose.theta, b.pose.theta, 1e-12);
    } else if (a.type == Record::Type::kEvent) {
      EXPECT_EQ(a.event.kind, b.event.kind);
      EXPECT_EQ(a.event.step, b.event.step);
      EXPECT_EQ(a.event.details, b.event.details);
    }
    ++records;
  }
  EXPECT_FALSE(back.next(b));
  EXPECT_GT(records, 5000u);

  // Replayed, the localizers give the run's estimates (TUM files to 1e-9) and metrics.
  const auto replayed = testing::locsim(
      "replay " + (dir / "back.locsimlog").string() + " --out " + (dir / "replay").string() +
      " --localizer ekf_landmarks --localizer amcl --localizer ultrasonic_amcl");
  ASSERT_EQ(replayed.exit_code, 0) << replayed.output;
  for (const std::string label : {"ekf_landmarks", "amcl", "ultrasonic_amcl"}) {
    SCOPED_TRACE(label);
    const std::vector<StampedPose> ran = read_tum(dir / "run" / (label + ".tum"));
    const std::vector<StampedPose> again = read_tum(dir / "replay" / (label + ".tum"));
    ASSERT_EQ(ran.size(), again.size());
    for (std::size_t i = 0; i < ran.size(); ++i) {
      EXPECT_NEAR(ran[i].t_s, again[i].t_s, 1e-9);
      EXPECT_NEAR(ran[i].pose.x, again[i].pose.x, 1e-9);
      EXPECT_NEAR(ran[i].pose.y, again[i].pose.y, 1e-9);
    }
    const json m = testing::localizer_entry(dir / "run" / "metrics.json", label);
    const json n = testing::localizer_entry(dir / "replay" / "metrics.json", label);
    EXPECT_EQ(m["samples"], n["samples"]);
    EXPECT_NEAR(m["position_error_m"]["rms"].get<double>(),
                n["position_error_m"]["rms"].get<double>(), 1e-9);
  }
}

TEST(RosbagExport, TheDirectEncodersWriteTheBytesTheMessageDefinitionsDo) {
  // The frequent topics are written to CDR directly; through their JSON and the definitions they
  // must give the same file, byte for byte.
  const fs::path dir = testing::temp_dir("direct");
  const fs::path log = demo_log(dir);
  RosbagRecorderOptions reference;
  reference.through_definitions = true;
  reference.bag_name = "bag";
  RosbagRecorderOptions direct;
  direct.bag_name = "bag";
  const ExportSummary a = export_rosbag2(log, dir / "reference", reference);
  const ExportSummary b = export_rosbag2(log, dir / "direct", direct);
  EXPECT_EQ(a.messages, b.messages);
  EXPECT_GT(a.messages, 10000u);
  const std::string reference_bytes = testing::read_file(dir / "reference" / "bag_0.mcap");
  EXPECT_TRUE(reference_bytes == testing::read_file(dir / "direct" / "bag_0.mcap"));
}

TEST(RosbagExport, RefusesToReplaceWhatIsNotABagOrHoldsItsLog) {
  const fs::path dir = testing::temp_dir("refuse");
  const fs::path log = demo_log(dir);
  // A folder of other files is not replaced, even with --overwrite.
  fs::create_directories(dir / "notes");
  std::ofstream(dir / "notes" / "keep.txt") << "mine";
  try {
    export_rosbag2(log, dir / "notes", {}, true);
    FAIL();
  } catch (const InputError& e) {
    expect_contains(e.what(), "is not a bag folder (metadata.yaml and .mcap files only)");
  }
  EXPECT_TRUE(fs::exists(dir / "notes" / "keep.txt"));
  // A bag is replaced only with --overwrite, and never one holding the log it exports.
  export_rosbag2(log, dir / "bag");
  EXPECT_THROW(export_rosbag2(log, dir / "bag"), InputError);
  const ExportSummary again = export_rosbag2(log, dir / "bag", {}, true);
  EXPECT_GT(again.messages, 1000u);
  EXPECT_FALSE(fs::exists(dir / "bag.partial"));
  fs::copy_file(log, dir / "bag" / "inside.db3");  // a log named like a bag's file, in the bag
  try {
    export_rosbag2(dir / "bag" / "inside.db3", dir / "bag", {}, true);
    FAIL();
  } catch (const InputError& e) {
    expect_contains(e.what(), "which locsim reads: not replaced");
  }
  EXPECT_TRUE(fs::exists(dir / "bag" / "inside.db3"));
}

TEST(RosbagRun, ARunsBagHoldsEachLocalizersEstimatesAndParticlesAndAReplayOfItsLogTheSame) {
  // `run --rosbag2`: the estimates (with their covariance) at every true pose, and the particles
  // at --rosbag2-particles-hz, as the independent reader decodes them. The replay of the run's log
  // writes the same localizer messages, bit for bit: the particles are taken at the same instants,
  // after the same records.
  const fs::path dir = testing::temp_dir("run_bag");
  const std::string world = (fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml").string();
  const std::string localizers = " --localizer amcl --localizer ekf_landmarks";
  auto o = testing::locsim("run " + world + " --duration 6 --no-readings --out " +
                           (dir / "run").string() + " --log " + (dir / "run.locsimlog").string() +
                           localizers + " --rosbag2 " + (dir / "run_bag").string() +
                           " --rosbag2-particles-hz 5");
  ASSERT_EQ(o.exit_code, 0) << o.output;
  o = testing::locsim("replay " + (dir / "run.locsimlog").string() + " --no-readings --out " +
                      (dir / "replay").string() + localizers + " --rosbag2 " +
                      (dir / "replay_bag").string() + " --rosbag2-particles-hz 5");
  ASSERT_EQ(o.exit_code, 0) << o.output;
  json header;
  std::map<std::string, std::vector<json>> run, replay;
  ASSERT_NO_FATAL_FAILURE(dump_bag(dir / "run_bag" / "run_bag_0.mcap", header, run));
  ASSERT_NO_FATAL_FAILURE(dump_bag(dir / "replay_bag" / "replay_bag_0.mcap", header, replay));

  for (const std::string label : {"amcl", "ekf_landmarks"}) {
    SCOPED_TRACE(label);
    const std::vector<json>& poses = run["/localizers/" + label + "/pose"];
    const std::vector<StampedPose> tum = read_tum(dir / "run" / (label + ".tum"));
    ASSERT_EQ(poses.size(), tum.size());
    for (std::size_t i = 0; i < tum.size(); ++i) {
      const json& m = poses[i];
      EXPECT_EQ(m["header"]["frame_id"], "map");
      EXPECT_EQ(stamp_ns(m["header"]), 1'000'000'000 + std::llround(tum[i].t_s * 1e9));
      EXPECT_NEAR(m["pose"]["pose"]["position"]["x"].get<double>(), tum[i].pose.x, 1e-6);
      EXPECT_NEAR(m["pose"]["pose"]["position"]["y"].get<double>(), tum[i].pose.y, 1e-6);
      EXPECT_NEAR(std::remainder(yaw(m["pose"]["pose"]["orientation"]) - tum[i].pose.theta,
                                 2.0 * std::numbers::pi),
                  0.0, 1e-6);
      // ROS's 6 x 6 over (x, y, z, roll, pitch, yaw): x, y and yaw filled, symmetric, the rest 0.
      const json& c = m["pose"]["covariance"];
      ASSERT_EQ(c.size(), 36u);
      for (int r = 0; r < 6; ++r) {
        for (int k = 0; k < 6; ++k) {
          const bool planar = (r == 0 || r == 1 || r == 5) && (k == 0 || k == 1 || k == 5);
          if (!planar) {
            EXPECT_EQ(number(c[r * 6 + k]), 0.0) << r << "," << k;
          }
          // as the filter gives it: symmetric to its rounding
          EXPECT_NEAR(number(c[r * 6 + k]), number(c[k * 6 + r]),
                      1e-12 * (std::abs(number(c[0])) + std::abs(number(c[35]))));
        }
      }
      EXPECT_GT(number(c[0]), 0.0);
      EXPECT_GT(number(c[35]), 0.0);
    }
    EXPECT_EQ(run["/localizers/" + label + "/pose"], replay["/localizers/" + label + "/pose"]);
  }
  // amcl's particles at 0, 0.2, ..., 6 s; the EKF has none.
  const std::vector<json>& clouds = run["/localizers/amcl/particles"];
  ASSERT_EQ(clouds.size(), 31u);
  for (std::size_t i = 0; i < clouds.size(); ++i) {
    EXPECT_EQ(stamp_ns(clouds[i]["header"]), 1'000'000'000 + 200'000'000 * static_cast<long>(i));
    EXPECT_GE(clouds[i]["poses"].size(), 500u);  // amcl's default min_particles
  }
  EXPECT_EQ(run.count("/localizers/ekf_landmarks/particles"), 0u);
  EXPECT_EQ(clouds, replay["/localizers/amcl/particles"]);
  // The stream's topics too: the bag of a run is an exported log and more.
  for (const char* topic : {"/scan", "/odom", "/ground_truth", "/tf", "/map"}) {
    EXPECT_FALSE(run[topic].empty()) << topic;
  }

  // `export RUN` exports the log the run kept: the stream's topics as the run's own bag has them.
  o = testing::locsim("export " + (dir / "run").string() + " --rosbag2 " +
                      (dir / "exported").string());
  ASSERT_EQ(o.exit_code, 0) << o.output;
  expect_contains(o.output, (dir / "run.locsimlog").string());
  std::map<std::string, std::vector<json>> exported;
  ASSERT_NO_FATAL_FAILURE(dump_bag(dir / "exported" / "exported_0.mcap", header, exported));
  for (const char* topic : {"/scan", "/odom", "/ground_truth", "/imu", "/locsim/events"}) {
    EXPECT_EQ(exported[topic], run[topic]) << topic;
  }

  // A bag folder is replaced only with --overwrite, and a folder of other files never.
  o = testing::locsim("replay " + (dir / "run.locsimlog").string() + " --no-readings --out " +
                      (dir / "replay2").string() + " --rosbag2 " + (dir / "replay_bag").string());
  EXPECT_EQ(o.exit_code, 2) << o.output;
  expect_contains(o.output, "exists (pass --overwrite to replace a bag)");
  EXPECT_FALSE(fs::exists(dir / "replay2"));
  o = testing::locsim("replay " + (dir / "run.locsimlog").string() + " --no-readings --out " +
                      (dir / "replay2").string() + " --rosbag2 " + (dir / "run").string() +
                      " --overwrite");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  expect_contains(o.output, "is not a bag folder");
  o = testing::locsim("run " + world + " --duration 1 --out " + (dir / "run3").string() +
                      " --rosbag2-particles-hz 5");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  expect_contains(o.output, "--rosbag2-particles-hz requires --rosbag2");
}

}  // namespace
}  // namespace locsim
