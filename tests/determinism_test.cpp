// Same inputs and seed: byte-identical run folders (all but run.json's wall-clock "timing").
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "sim/run/runner.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;

RunResult run_demo(const fs::path& out, std::uint64_t seed) {
  RunOptions options;
  options.world_file = fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml";
  options.seed = seed;
  options.duration_s = 45.0;  // past both kidnaps, the second to a random pose
  options.out_dir = out;
  options.localizers = {"odometry", "ekf_landmarks"};
  return run_simulation(options);
}

std::string json_without_timing(const fs::path& file) {
  nlohmann::ordered_json run = nlohmann::ordered_json::parse(testing::read_file(file));
  EXPECT_TRUE(run.contains("timing"));
  run.erase("timing");
  return run.dump();
}

TEST(Determinism, SameSeedGivesByteIdenticalOutputs) {
  const fs::path base = testing::temp_dir("runs");
  const RunResult a = run_demo(base / "a", 7);
  const RunResult b = run_demo(base / "b", 7);
  EXPECT_EQ(a.status, "completed");
  EXPECT_EQ(a.state_hash, b.state_hash);
  for (const char* file :
       {"groundtruth.tum", "events.csv", "readings/encoders.csv", "readings/imu.csv",
        "readings/ptz_camera.csv", "readings/omni_camera.csv", "readings/ultrasonic.csv",
        "readings/laser.csv", "readings/sensors.json", "odometry.tum", "ekf_landmarks.tum"}) {
    const std::string content = testing::read_file(base / "a" / file);
    EXPECT_GT(content.size(), 100u) << file;
    EXPECT_EQ(content, testing::read_file(base / "b" / file)) << file << " differs";
  }
  EXPECT_EQ(json_without_timing(base / "a/run.json"), json_without_timing(base / "b/run.json"));
  EXPECT_EQ(json_without_timing(base / "a/metrics.json"),
            json_without_timing(base / "b/metrics.json"));
}

TEST(Determinism, DifferentSeedsDiffer) {
  const fs::path base = testing::temp_dir("runs");
  const RunResult a = run_demo(base / "a", 7);
  const RunResult b = run_demo(base / "b", 8);
  EXPECT_NE(a.state_hash, b.state_hash);
  EXPECT_NE(testing::read_file(base / "a/groundtruth.tum"),
            testing::read_file(base / "b/groundtruth.tum"));
  EXPECT_NE(testing::read_file(base / "a/events.csv"), testing::read_file(base / "b/events.csv"));
  EXPECT_NE(testing::read_file(base / "a/readings/laser.csv"),
            testing::read_file(base / "b/readings/laser.csv"));
}

TEST(Determinism, BusyWorldHashesEqualAcrossRuns) {
  // Several robots wandering among people: every contact and random turn must replay exactly.
  const std::string world = R"(
walls:
  - points: [[0, 0], [8, 0], [8, 6], [0, 6]]
    closed: true
movers:
  - {name: p1, path: [[1, 1], [7, 5]], speed_mps: 1.2}
  - {name: p2, path: [[7, 1], [1, 5]], speed_mps: 0.8}
robots:
  - {name: a, start: {x: 2, y: 3}}
  - {name: b, start: {x: 4, y: 3}}
  - {name: c, start: {x: 6, y: 3}}
scenario:
  duration_s: 30
  drive:
    - {robot: a, mode: wander, speed_mps: 0.6}
    - {robot: b, mode: wander, speed_mps: 0.6}
    - {robot: c, mode: wander, speed_mps: 0.6}
  events:
    - {at_s: 10, kidnap: {robot: b, to: random}}
)";
  const auto final_hash = [&](std::uint64_t seed) {
    Simulation sim = testing::make_sim(world, seed);
    while (!sim.done()) sim.step();
    return sim.state_hash();
  };
  EXPECT_EQ(final_hash(3), final_hash(3));
  EXPECT_NE(final_hash(3), final_hash(4));
}

TEST(RunFolder, HoldsTumGroundTruthEventsAndResolvedConfig) {
  const fs::path out = testing::temp_dir("run") / "out";
  const RunResult result = run_demo(out, 1);
  const std::string groundtruth = testing::read_file(out / "groundtruth.tum");
  std::istringstream lines(groundtruth);
  std::string line;
  int rows = 0;
  double last_t = -1.0;
  while (std::getline(lines, line)) {
    if (line.starts_with('#')) continue;
    std::istringstream fields(line);
    double t, x, y, z, qx, qy, qz, qw;
    ASSERT_TRUE(fields >> t >> x >> y >> z >> qx >> qy >> qz >> qw) << line;
    EXPECT_GT(t, last_t);
    last_t = t;
    EXPECT_EQ(z, 0.0);
    EXPECT_NEAR(qz * qz + qw * qw, 1.0, 1e-6);
    ++rows;
  }
  // 50 Hz over 45 s, less the 2 s the robot is carried (no floor pose while in the air).
  EXPECT_EQ(rows, 45 * 50 + 1 - 2 * 50);
  const auto run = nlohmann::json::parse(testing::read_file(out / "run.json"));
  EXPECT_EQ(run["status"], "completed");
  EXPECT_EQ(run["seed"], 1);
  EXPECT_DOUBLE_EQ(run["simulated_s"].get<double>(), 45.0);
  EXPECT_EQ(run["config"]["world"]["robots"][0]["wheel_radius_left_m"], 0.0502);
  EXPECT_EQ(run["config"]["scenario"]["events"].size(), 3u);
  EXPECT_GT(run["timing"]["real_time_factor"].get<double>(), 0.0);
  const std::string events = testing::read_file(out / "events.csv");
  EXPECT_TRUE(events.starts_with("t_s,kind,robot,details\n"));
  EXPECT_NE(events.find("20.0000,kidnap,robot,"), std::string::npos);
  EXPECT_NE(events.find("22.0000,put_down,robot,\"to=(1.2000,5.0000,-1.5708)\""),
            std::string::npos);
  EXPECT_NE(events.find("45.0000,end,,"), std::string::npos);
}

}  // namespace
}  // namespace locsim
