// `locsim import mrclam` on generated MRCLAM-format files of one robot and 300 s (odometry at
// 67 Hz, Vicon at 100 Hz, 3 barcode readings a second, as the real dataset): parsing, merging and
// writing the log. Counter: dataset lines read per second. And `locsim calibrate` on the imported
// log: reading it, pairing readings with the truth, and the likelihood fits (counter: log records
// per second). And `locsim twin` of it, with that calibration: reading the log, thinning the true
// path, the landmarks in view along it, writing and loading the world (counter: log records per
// second). And `locsim import generic` of laser scans, the same scans from a ROS 2 bag (`locsim
// import rosbag2`), the demo's log written as a bag (`locsim export`), an external estimate scored
// on it (`locsim score`), and `locsim calibrate` of a laser.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "sim/common/files.hpp"
#include "sim/experiments/twin.hpp"
#include "sim/metrics/calibration.hpp"
#include "sim/producers/generic_import.hpp"
#include "sim/producers/mrclam_import.hpp"
#include "sim/producers/rosbag_import.hpp"
#include "sim/rosbag/mcap.hpp"
#include "sim/rosbag/message_definition.hpp"
#include "sim/rosbag/ros_types.hpp"
#include "sim/run/export_bag.hpp"
#include "sim/run/replay.hpp"
#include "sim/run/runner.hpp"
#include "sim/run/score.hpp"
#include "tests/noisy_world.hpp"

namespace {

namespace fs = std::filesystem;

std::size_t write_dataset(const fs::path& dir) {
  constexpr double kT0 = 1248444000.0, kDurationS = 300.0;
  std::size_t lines = 0;
  char text[160];
  std::ofstream(dir / "Barcodes.dat") << "# subject barcode\n1 5\n6 63\n7 81\n";
  std::ofstream(dir / "Landmark_Groundtruth.dat") << "# subject x y sx sy\n6 4 0 0 0\n7 4 2 0 0\n";
  std::ofstream odometry(dir / "Robot1_Odometry.dat"), truth(dir / "Robot1_Groundtruth.dat"),
      measurements(dir / "Robot1_Measurement.dat");
  for (double t = 0.0; t < kDurationS; t += 0.015, ++lines) {
    std::snprintf(text, sizeof(text), "%.3f \t 0.100 \t -0.050 \n", kT0 + t);
    odometry << text;
  }
  for (double t = 0.0; t < kDurationS; t += 0.01, ++lines) {
    std::snprintf(text, sizeof(text), "%.3f \t %.8f \t %.8f \t %.8f \n", kT0 + t, std::cos(t),
                  std::sin(t), std::fmod(t, 3.0));
    truth << text;
  }
  for (double t = 0.1; t < kDurationS; t += 0.33, ++lines) {
    std::snprintf(text, sizeof(text), "%.3f \t %d \t %.3f \t %.3f \n", kT0 + t,
                  lines % 2 == 0 ? 63 : 81, 2.0 + std::sin(t), 0.3 * std::cos(t));
    measurements << text;
  }
  return lines;
}

void BM_ImportMrclam(benchmark::State& state) {
  const fs::path dir = fs::temp_directory_path() / "locsim_bench_import";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::size_t lines = write_dataset(dir);
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        locsim::write_import(locsim::read_mrclam({dir, {1}}), {}, dir / "out.locsimlog"));
  }
  fs::remove_all(dir);
  state.counters["lines_per_s"] = benchmark::Counter(
      static_cast<double>(lines * state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ImportMrclam)->Unit(benchmark::kMillisecond)->UseRealTime();

/// `locsim import generic` of laser scans: 60 s of a 1081-beam scanner at 40 Hz (a Hokuyo
/// UTM-30LX's), ranges written to the millimetre with a tenth of the beams without a return
/// (`inf`), beside odometry and truth at 50 Hz. Counter: beams read per second.
void BM_ImportGenericScans(benchmark::State& state) {
  constexpr int kBeams = 1081, kScans = 2400;
  const fs::path dir = fs::temp_directory_path() / "locsim_bench_import_scans";
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    std::ofstream odometry(dir / "odometry.csv"), truth(dir / "groundtruth.tum");
    odometry << "t,v,omega\n";
    char text[160];
    for (int i = 0; i <= 3000; ++i) {
      const double t = 0.02 * i;
      std::snprintf(text, sizeof(text), "%.2f,0.5,0.1\n", t);
      odometry << text;
      std::snprintf(text, sizeof(text), "%.2f %.6f %.6f 0 0 0 %.9f %.9f\n", t, std::cos(0.1 * t),
                    std::sin(0.1 * t), std::sin(0.05 * t), std::cos(0.05 * t));
      truth << text;
    }
    std::ofstream(dir / "robot.yaml")
        << "laser: {angle_min_deg: -135, angle_max_deg: 135, min_range_m: 0.1, "
           "max_range_m: 30}\n";
    std::ofstream scans(dir / "scans.csv");
    scans << "t,ranges\n";
    for (int s = 0; s < kScans; ++s) {
      std::string row = std::to_string(0.025 * s) + ",";
      for (int b = 0; b < kBeams; ++b) {
        if ((b + s) % 10 == 0) {
          row += "inf ";
        } else {
          std::snprintf(text, sizeof(text), "%.3f ",
                        2.0 + 5.0 * std::abs(std::sin(0.01 * (b + s))));
          row += text;
        }
      }
      row.back() = '\n';
      scans << row;
    }
  }
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        locsim::write_import(locsim::read_generic(dir), {}, dir / "out.locsimlog"));
  }
  fs::remove_all(dir);
  state.counters["beams_per_s"] = benchmark::Counter(
      static_cast<double>(kBeams) * kScans * static_cast<double>(state.iterations()),
      benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ImportGenericScans)->Unit(benchmark::kMillisecond)->UseRealTime();

/// `locsim import rosbag2` of the same scans as BM_ImportGenericScans (60 s of a 1081-beam
/// scanner at 40 Hz, a tenth of the beams without a return, nav_msgs/Odometry and PoseStamped
/// truth at 50 Hz) in an MCAP bag as `ros2 bag record` writes one: chunks of 768 KiB, compressed
/// with zstd (argument 1), lz4 (2) or not (0). Read, decoded by the bag's definitions, and written
/// as a log. Counter: beams read per second.
void BM_ImportRosbag2Scans(benchmark::State& state) {
  using nlohmann::json;
  namespace rb = locsim::rosbag;
  constexpr int kBeams = 1081, kScans = 2400;
  const fs::path dir = fs::temp_directory_path() / "locsim_bench_import_bag";
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    rb::McapWriterOptions options;
    options.compression = state.range(0) == 1   ? rb::McapCompression::kZstd
                          : state.range(0) == 2 ? rb::McapCompression::kLz4
                                                : rb::McapCompression::kNone;
    rb::McapWriter writer(dir / "bag.mcap", options);
    std::map<std::string, std::pair<std::uint16_t, rb::MessageDefinition>> topics;
    for (const auto& [topic, type] : {std::pair{"/scan", "sensor_msgs/msg/LaserScan"},
                                      {"/odom", "nav_msgs/msg/Odometry"},
                                      {"/ground_truth", "geometry_msgs/msg/PoseStamped"},
                                      {"/tf_static", "tf2_msgs/msg/TFMessage"}}) {
      const std::uint16_t schema = writer.add_schema(type, "ros2msg", rb::schema_text(type));
      topics.emplace(topic, std::pair{writer.add_channel(schema, topic, "cdr"),
                                      rb::MessageDefinition::known(type)});
    }
    const auto write = [&](const std::string& topic, std::int64_t ns, const json& message) {
      const auto& [channel, definition] = topics.at(topic);
      writer.write(channel, 0, static_cast<std::uint64_t>(ns), static_cast<std::uint64_t>(ns),
                   definition.encode(message));
    };
    const auto header = [](std::int64_t ns, const char* frame) {
      return json{{"stamp", {{"sec", ns / 1'000'000'000}, {"nanosec", ns % 1'000'000'000}}},
                  {"frame_id", frame}};
    };
    const auto pose = [](double x, double y, double yaw) {
      return json{{"position", {{"x", x}, {"y", y}, {"z", 0.0}}},
                  {"orientation",
                   {{"x", 0.0}, {"y", 0.0}, {"z", std::sin(yaw / 2)}, {"w", std::cos(yaw / 2)}}}};
    };
    const std::int64_t t0 = 1'700'000'000'000'000'000;
    write("/tf_static", t0,
          {{"transforms",
            {{{"header", header(t0, "base_link")},
              {"child_frame_id", "laser"},
              {"transform",
               {{"translation", {{"x", 0.2}, {"y", 0.0}, {"z", 0.3}}},
                {"rotation", {{"x", 0.0}, {"y", 0.0}, {"z", 0.0}, {"w", 1.0}}}}}}}}});
    const json covariance = std::vector<double>(36, 0.0);
    int scan = 0;
    for (int i = 0; i <= 3000; ++i) {
      const std::int64_t ns = t0 + static_cast<std::int64_t>(i) * 20'000'000;
      const double t = 0.02 * i;
      write("/odom", ns,
            {{"header", header(ns, "odom")},
             {"child_frame_id", "base_link"},
             {"pose", {{"pose", pose(0.5 * t, 0.0, 0.1 * t)}, {"covariance", covariance}}},
             {"twist",
              {{"twist",
                {{"linear", {{"x", 0.5}, {"y", 0.0}, {"z", 0.0}}},
                 {"angular", {{"x", 0.0}, {"y", 0.0}, {"z", 0.1}}}}},
               {"covariance", covariance}}}});
      write("/ground_truth", ns,
            {{"header", header(ns, "map")},
             {"pose", pose(std::cos(0.1 * t), std::sin(0.1 * t), 0.1 * t)}});
      for (; scan < kScans && scan * 25'000'000 <= i * 20'000'000; ++scan) {
        json ranges = json::array();
        for (int b = 0; b < kBeams; ++b) {
          ranges.push_back((b + scan) % 10 == 0
                               ? json("Infinity")
                               : json(2.0 + 5.0 * std::abs(std::sin(0.01 * (b + scan)))));
        }
        const std::int64_t scan_ns = t0 + static_cast<std::int64_t>(scan) * 25'000'000;
        write("/scan", scan_ns,
              {{"header", header(scan_ns, "laser")},
               {"angle_min", -0.75 * std::numbers::pi},
               {"angle_max", 0.75 * std::numbers::pi},
               {"angle_increment", 1.5 * std::numbers::pi / (kBeams - 1)},
               {"time_increment", 0.0},
               {"scan_time", 0.025},
               {"range_min", 0.1},
               {"range_max", 30.0},
               {"ranges", ranges},
               {"intensities", json::array()}});
      }
    }
    writer.finish();
  }
  for (auto _ : state) {
    locsim::RosbagImportOptions options;
    options.bag = dir / "bag.mcap";
    benchmark::DoNotOptimize(
        locsim::write_import(locsim::read_rosbag2(options).dataset, {}, dir / "out.locsimlog"));
  }
  state.counters["bag_mb"] = static_cast<double>(fs::file_size(dir / "bag.mcap")) / 1e6;
  fs::remove_all(dir);
  state.counters["beams_per_s"] = benchmark::Counter(
      static_cast<double>(kBeams) * kScans * static_cast<double>(state.iterations()),
      benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ImportRosbag2Scans)
    ->Arg(0)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

/// `locsim export LOG --rosbag2 OUT` of the demo world's 60 s log (encoders, IMU, laser and
/// truth as ROS messages, the map, zstd chunks). Counter: messages written per second.
/// The demo world's 60 s run in `dir` (run/, with `localizers`), logged as demo.locsimlog.
fs::path demo_log(const fs::path& dir, std::vector<std::string> localizers = {}) {
  fs::remove_all(dir);
  fs::create_directories(dir);
  locsim::RunOptions run;
  run.world_file = fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml";
  run.out_dir = dir / "run";
  run.log_file = dir / "demo.locsimlog";
  run.localizers = std::move(localizers);
  run.readings = false;
  locsim::run_simulation(run);
  return *run.log_file;
}

void BM_ExportRosbag2Demo(benchmark::State& state) {
  const fs::path dir = fs::temp_directory_path() / "locsim_bench_export_bag";
  const fs::path log = demo_log(dir);
  std::uint64_t messages = 0;
  for (auto _ : state) messages = locsim::export_rosbag2(log, dir / "bag", {}, true).messages;
  fs::remove_all(dir);
  state.counters["messages_per_s"] = benchmark::Counter(
      static_cast<double>(messages * state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ExportRosbag2Demo)->Unit(benchmark::kMillisecond)->UseRealTime();

/// `locsim replay` of the demo world's 60 s log with amcl, without (0) and with (1) --rosbag2: the
/// bag's cost beside the replay's own (the stream's topics, amcl's estimate at every true pose and
/// its particle cloud at 10 Hz, zstd chunks). Counter: true poses replayed per second.
void BM_ReplayRosbag2Demo(benchmark::State& state) {
  const fs::path dir = fs::temp_directory_path() / "locsim_bench_replay_bag";
  locsim::ReplayOptions options;
  options.log_file = demo_log(dir);
  options.out_dir = dir / "replay";
  options.localizers = {"amcl"};
  options.readings = false;
  options.overwrite = true;
  if (state.range(0) == 1) options.rosbag2 = dir / "bag";
  std::size_t true_poses = 0;
  for (auto _ : state) true_poses = locsim::replay_log(options).true_poses;
  fs::remove_all(dir);
  state.counters["true_poses_per_s"] = benchmark::Counter(
      static_cast<double>(true_poses * state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ReplayRosbag2Demo)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

/// `locsim score` of an external TUM estimate on the demo world's 60 s log (the run's own
/// odometry.tum, given back as a file): the log through the scorer and the recorder, the estimate
/// at every true pose. Counter: true poses scored per second.
void BM_ScoreExternalTumDemo(benchmark::State& state) {
  const fs::path dir = fs::temp_directory_path() / "locsim_bench_score";
  locsim::ScoreOptions options;
  options.log_file = demo_log(dir, {"odometry"});
  options.out_dir = dir / "scored";
  options.estimates = {{"external", dir / "run" / "odometry.tum", ""}};
  options.overwrite = true;
  std::size_t scored = 0;
  for (auto _ : state) scored = locsim::score_estimates(options).samples[0];
  fs::remove_all(dir);
  state.counters["true_poses_per_s"] = benchmark::Counter(
      static_cast<double>(scored * state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ScoreExternalTumDemo)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_CalibrateMrclam(benchmark::State& state) {
  const fs::path dir = fs::temp_directory_path() / "locsim_bench_calibrate";
  fs::remove_all(dir);
  fs::create_directories(dir);
  write_dataset(dir);
  const locsim::ImportSummary summary =
      locsim::write_import(locsim::read_mrclam({dir, {1}}), {}, dir / "out.locsimlog");
  for (auto _ : state) {
    benchmark::DoNotOptimize(locsim::calibrate({dir / "out.locsimlog"}, {}).to_yaml());
  }
  fs::remove_all(dir);
  state.counters["records_per_s"] = benchmark::Counter(
      static_cast<double>(summary.records * state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_CalibrateMrclam)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_TwinMrclam(benchmark::State& state) {
  const fs::path dir = fs::temp_directory_path() / "locsim_bench_twin";
  fs::remove_all(dir);
  fs::create_directories(dir);
  write_dataset(dir);
  const locsim::ImportSummary summary =
      locsim::write_import(locsim::read_mrclam({dir, {1}}), {}, dir / "out.locsimlog");
  locsim::write_file(dir / "calibration.yaml",
                     locsim::calibrate({dir / "out.locsimlog"}, {}).to_yaml());
  locsim::TwinOptions options;
  options.log = dir / "out.locsimlog";
  options.calibration = dir / "calibration.yaml";
  for (auto _ : state) {
    benchmark::DoNotOptimize(locsim::write_twin(options, dir / "twin" / "twin.yaml", true));
  }
  fs::remove_all(dir);
  state.counters["records_per_s"] = benchmark::Counter(
      static_cast<double>(summary.records * state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_TwinMrclam)->Unit(benchmark::kMillisecond)->UseRealTime();

/// `locsim calibrate` of a laser: 60 s of a robot wandering in the office map with a 181-beam
/// laser at 10 Hz (simulated once): the beams against the map's ranges at the true pose, and the
/// beam model's EM. Counter: beams used per second.
void BM_CalibrateLaser(benchmark::State& state) {
  const fs::path dir = fs::temp_directory_path() / "locsim_bench_calibrate_laser";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path world = locsim::testing::office_world(
      dir,
      "{encoders: {rate_hz: 50}, laser: {rate_hz: 10, fov_deg: 270, beams: 181, max_range_m: 8, "
      "p_short: 0.05}}",
      60);
  locsim::RunOptions run;
  run.world_file = world;
  run.out_dir = dir / "run";
  run.log_file = dir / "laser.locsimlog";
  locsim::run_simulation(run);
  std::size_t beams = 0;
  for (auto _ : state) {
    const locsim::Calibration c = locsim::calibrate({dir / "laser.locsimlog"}, {});
    beams += c.laser ? c.laser->beams : 0;
  }
  fs::remove_all(dir);
  state.counters["beams_per_s"] =
      benchmark::Counter(static_cast<double>(beams), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_CalibrateLaser)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
