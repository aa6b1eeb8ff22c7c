// `locsim score`: estimates made outside locsim, scored on the log they were made on. A built-in
// filter's own TUM file scores as the built-in scorer scored it; a bag's topic with covariances
// gives the consistency figures too.
#include "sim/run/score.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "sim/common/errors.hpp"
#include "sim/producers/text_table.hpp"
#include "sim/rosbag/mcap.hpp"
#include "sim/rosbag/message_definition.hpp"
#include "sim/rosbag/ros_types.hpp"
#include "sim/run/runner.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::expect_contains;

/// 24 s of the demo world (a kidnap at 20 s) with amcl and odometry, logged.
struct DemoRun {
  fs::path log, run;
};
DemoRun demo_run(const fs::path& dir) {
  RunOptions options;
  options.world_file = fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml";
  options.duration_s = 24.0;
  options.out_dir = dir / "run";
  options.log_file = dir / "demo.locsimlog";
  options.localizers = {"amcl", "odometry"};
  options.readings = false;
  run_simulation(options);
  return {*options.log_file, options.out_dir};
}

json entry(const fs::path& metrics, const std::string& label) {
  const json all = json::parse(testing::read_file(metrics));
  for (const json& l : all["localizers"]) {
    if (l["label"] == label) return l;
  }
  ADD_FAILURE() << "no " << label << " in " << metrics;
  return {};
}

TEST(Score, ABuiltInFiltersOwnTumScoresAsTheBuiltInScorerScoredIt) {
  const fs::path dir = testing::temp_dir("score");
  const DemoRun demo = demo_run(dir);
  ScoreOptions options;
  options.log_file = demo.log;
  options.out_dir = dir / "scored";
  options.estimates = {{"amcl_tum", demo.run / "amcl.tum", ""},
                       {"odometry_tum", demo.run / "odometry.tum", ""}};
  const ScoreResult result = score_estimates(options);
  ASSERT_EQ(result.samples.size(), 2u);
  for (const auto& [builtin, external] :
       {std::pair{"amcl", "amcl_tum"}, std::pair{"odometry", "odometry_tum"}}) {
    SCOPED_TRACE(builtin);
    const json a = entry(demo.run / "metrics.json", builtin);
    const json b = entry(dir / "scored" / "metrics.json", external);
    EXPECT_EQ(a["samples"], b["samples"]);
    // The TUM file holds positions to the micrometre and quaternions to 1e-9.
    EXPECT_NEAR(a["position_error_m"]["rms"].get<double>(),
                b["position_error_m"]["rms"].get<double>(), 2e-6);
    EXPECT_NEAR(a["position_error_m"]["max"].get<double>(),
                b["position_error_m"]["max"].get<double>(), 2e-6);
    EXPECT_NEAR(a["heading_error_deg"]["rms"].get<double>(),
                b["heading_error_deg"]["rms"].get<double>(), 1e-5);
    EXPECT_EQ(a["time_lost_s"], b["time_lost_s"]);
    EXPECT_EQ(a["convergence"]["time_s"], b["convergence"]["time_s"]);
    ASSERT_EQ(a["segments"].size(), b["segments"].size());
    ASSERT_EQ(a["segments"].size(), 2u);  // before and after the kidnap
    for (std::size_t s = 0; s < a["segments"].size(); ++s) {
      EXPECT_EQ(a["segments"][s]["from_s"], b["segments"][s]["from_s"]);
      EXPECT_EQ(a["segments"][s]["samples"], b["segments"][s]["samples"]);
      EXPECT_NEAR(a["segments"][s]["position_error_m"]["rms"].get<double>(),
                  b["segments"][s]["position_error_m"]["rms"].get<double>(), 2e-6);
    }
    // A TUM file has no covariance: nothing is said of consistency.
    EXPECT_TRUE(b["consistency"].is_null());
  }
  // The amcl estimate recovers from the kidnap on the laser, as the built-in one did.
  EXPECT_EQ(entry(demo.run / "metrics.json", "amcl")["segments"][1]["recovered_s"],
            entry(dir / "scored" / "metrics.json", "amcl_tum")["segments"][1]["recovered_s"]);
  // The folder is a run folder: the report reads it.
  const auto report =
      testing::run_command(std::string(LOCSIM_PYTHON_EXECUTABLE) + " " + LOCSIM_SOURCE_DIR +
                           "/tools/report.py " + (dir / "scored").string());
  EXPECT_EQ(report.exit_code, 0) << report.output;
  expect_contains(testing::read_file(dir / "scored" / "report.md"), "| amcl_tum | ok |");
}

TEST(Score, IntoARunFolderAnEstimateJoinsTheRunsLocalizersAndItsReport) {
  // `locsim score RUN`: beside the run's own filters, in its metrics.json, run.json and report.
  const fs::path dir = testing::temp_dir("score_run");
  const DemoRun demo = demo_run(dir);
  fs::copy_file(demo.run / "amcl.tum", dir / "nav2_amcl.tum");
  const std::string run = demo.run.string();
  auto o = testing::locsim("score " + run + " --estimate " + (dir / "nav2_amcl.tum").string() +
                           " --label nav2_amcl");
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const json all = json::parse(testing::read_file(demo.run / "metrics.json"));
  ASSERT_EQ(all["localizers"].size(), 3u);
  const json a = entry(demo.run / "metrics.json", "amcl");
  const json b = entry(demo.run / "metrics.json", "nav2_amcl");
  EXPECT_EQ(b["plugin"], "external");
  EXPECT_EQ(a["samples"], b["samples"]);
  EXPECT_NEAR(a["position_error_m"]["rms"].get<double>(),
              b["position_error_m"]["rms"].get<double>(), 2e-6);
  EXPECT_EQ(a["segments"].size(), b["segments"].size());
  EXPECT_EQ(testing::read_file(demo.run / "nav2_amcl.tum").empty(), false);
  const json run_json = json::parse(testing::read_file(demo.run / "run.json"));
  EXPECT_EQ(run_json["localizers"].size(), 3u);
  ASSERT_EQ(run_json["scored"].size(), 1u);
  EXPECT_EQ(run_json["scored"][0]["label"], "nav2_amcl");
  EXPECT_FALSE(fs::exists(demo.run / ".score.partial"));
  const auto report = testing::run_command(std::string(LOCSIM_PYTHON_EXECUTABLE) + " " +
                                           LOCSIM_SOURCE_DIR + "/tools/report.py " + run);
  EXPECT_EQ(report.exit_code, 0) << report.output;
  const std::string markdown = testing::read_file(demo.run / "report.md");
  expect_contains(markdown, "| amcl | ok |");
  expect_contains(markdown, "| nav2_amcl | ok |");

  // Scored again (another file), it replaces its own entries.
  o = testing::locsim("score " + run + " --estimate " + (demo.run / "odometry.tum").string() +
                      " --label nav2_amcl");
  ASSERT_EQ(o.exit_code, 0) << o.output;
  EXPECT_EQ(json::parse(testing::read_file(demo.run / "metrics.json"))["localizers"].size(), 3u);
  EXPECT_NEAR(
      entry(demo.run / "metrics.json", "nav2_amcl")["position_error_m"]["rms"].get<double>(),
      entry(demo.run / "metrics.json", "odometry")["position_error_m"]["rms"].get<double>(), 2e-6);
  // Never over the run's own: a localizer's label, a file of the run; the files stay as they were.
  const std::string metrics = testing::read_file(demo.run / "metrics.json");
  const std::string groundtruth = testing::read_file(demo.run / "groundtruth.tum");
  for (const auto& [label, message] :
       {std::pair{"amcl", "one of the run's own localizers has it"},
        std::pair{"groundtruth", "the run has a file groundtruth.tum of its own"}}) {
    o = testing::locsim("score " + run + " --estimate " + (dir / "nav2_amcl.tum").string() +
                        " --label " + label);
    EXPECT_EQ(o.exit_code, 2) << o.output;
    expect_contains(o.output, message);
  }
  EXPECT_EQ(testing::read_file(demo.run / "metrics.json"), metrics);
  EXPECT_EQ(testing::read_file(demo.run / "groundtruth.tum"), groundtruth);
  // A run that kept no log cannot be scored into: it says what to do.
  o = testing::locsim("run " + std::string(LOCSIM_SOURCE_DIR) +
                      "/worlds/demo/demo.yaml --duration 1 --no-readings --out " +
                      (dir / "nolog").string());
  ASSERT_EQ(o.exit_code, 0) << o.output;
  o = testing::locsim("score " + (dir / "nolog").string() + " --estimate " +
                      (dir / "nav2_amcl.tum").string() + " --label x");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  expect_contains(o.output, "the run kept no log");
  // A log needs --out.
  o = testing::locsim("score " + demo.log.string() + " --estimate " +
                      (dir / "nav2_amcl.tum").string() + " --label x");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  expect_contains(o.output, "--out: give the folder to write");
}

TEST(Score, ABagTopicWithCovariancesIsPutOnTheLogsClockAndJudgedForConsistency) {
  const fs::path dir = testing::temp_dir("bag");
  const DemoRun demo = demo_run(dir);
  // /amcl_pose as a ROS localizer playing locsim's exported bag would publish it: stamps on the
  // bag's clock (the log's time 0 at 1 s), a covariance over (x, y, z, roll, pitch, yaw).
  const std::vector<StampedPose> poses = read_tum(demo.run / "amcl.tum");
  fs::create_directories(dir / "estimate");
  {
    rosbag::McapWriter writer(dir / "estimate" / "estimate_0.mcap");
    const std::string type = "geometry_msgs/msg/PoseWithCovarianceStamped";
    const std::uint16_t channel = writer.add_channel(
        writer.add_schema(type, "ros2msg", rosbag::schema_text(type)), "/amcl_pose", "cdr");
    const rosbag::MessageDefinition definition = rosbag::MessageDefinition::known(type);
    std::vector<double> covariance(36, 0.0);
    covariance[0] = covariance[7] = 0.04;                // 0.2 m on x and y
    covariance[35] = 0.01;                               // 0.1 rad on yaw
    for (std::size_t i = 0; i < poses.size(); i += 5) {  // at a fifth of the rate
      const std::int64_t ns = 1'000'000'000 + std::llround(poses[i].t_s * 1e9);
      const Pose2& p = poses[i].pose;
      writer.write(channel, 0, static_cast<std::uint64_t>(ns), static_cast<std::uint64_t>(ns),
                   definition.encode(
                       {{"header",
                         {{"stamp", {{"sec", ns / 1'000'000'000}, {"nanosec", ns % 1'000'000'000}}},
                          {"frame_id", "map"}}},
                        {"pose",
                         {{"pose",
                           {{"position", {{"x", p.x}, {"y", p.y}, {"z", 0.0}}},
                            {"orientation",
                             {{"x", 0.0},
                              {"y", 0.0},
                              {"z", std::sin(p.theta / 2)},
                              {"w", std::cos(p.theta / 2)}}}}},
                          {"covariance", covariance}}}}));
    }
    writer.finish();
  }
  const fs::path bag = dir / "estimate" / "estimate_0.mcap";
  const auto scored =
      testing::locsim("score " + demo.log.string() + " --estimate " + bag.string() +
                      " --topic /amcl_pose --label ros_amcl --out " + (dir / "scored").string());
  ASSERT_EQ(scored.exit_code, 0) << scored.output;
  const json a = entry(demo.run / "metrics.json", "amcl");
  const json b = entry(dir / "scored" / "metrics.json", "ros_amcl");
  EXPECT_EQ(a["samples"], b["samples"]);  // held between the bag's samples
  // The same estimate at a fifth of the rate: close to the built-in's, not the same.
  EXPECT_NEAR(b["position_error_m"]["rms"].get<double>(),
              a["position_error_m"]["rms"].get<double>(), 0.25);
  ASSERT_FALSE(b["consistency"].is_null());
  EXPECT_EQ(b["consistency"]["samples"], b["samples"]);
  EXPECT_GT(b["consistency"]["inside_95_ellipse"].get<double>(), 0.0);

  // What cannot be scored is refused, naming it.
  const auto refused = [&](const std::string& arguments) {
    const auto outcome = testing::locsim("score " + demo.log.string() + " --out " +
                                         (dir / "refused").string() + " " + arguments);
    EXPECT_EQ(outcome.exit_code, 2) << outcome.output;
    return outcome.output;
  };
  expect_contains(refused("--estimate " + bag.string() + " --label x"),
                  "a bag: name the estimate's topic with --topic");
  expect_contains(refused("--estimate " + bag.string() + " --topic /nothing --label x"),
                  "/nothing: no estimate in it");
  expect_contains(refused("--estimate " + (demo.run / "amcl.tum").string() + " --label 'a b'"),
                  "a label is 1 to 64 ASCII letters, digits, '_' and '-'");
  expect_contains(refused("--estimate " + (demo.run / "amcl.tum").string()), "--label is required");
  EXPECT_FALSE(fs::exists(dir / "refused"));
}

}  // namespace
}  // namespace locsim
