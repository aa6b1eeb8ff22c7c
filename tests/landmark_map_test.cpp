// SLAM filters' landmark maps: the one-to-one matching to the true landmarks, what a run writes
// for a filter with a map (LABEL_map.csv, metrics.json's landmark_map, results.csv's column),
// `localization: {landmarks_known: false}` giving filters an empty map, plugin errors and NaNs in
// the map failing the filter, and the map in the video's frames.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

#include "render/gl_context.hpp"
#include "render/top_down.hpp"
#include "sim/experiments/sweep.hpp"
#include "sim/metrics/landmark_metrics.hpp"
#include "sim/run/replay.hpp"
#include "sim/run/runner.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;  // keeps the files' key order

// ----------------------------------------------------------------------------------- matching
TEST(LandmarkMatching, IsOneToOneByIncreasingDistance) {
  // Pairs: b-t1 0.1, a-t1 0.2, b-t2 0.6, a-t2 0.9. Greedy takes b-t1, then a-t2 (a-t1 and b-t2
  // have a side taken): a nearest-neighbour rule would have matched both a and b to t1.
  const std::vector<LandmarkPoint> mapped{{10, 0.0, 0.0}, {11, 0.3, 0.0}};
  const std::vector<LandmarkPoint> truth{{1, 0.2, 0.0}, {2, 0.9, 0.0}};
  const std::vector<LandmarkMatch> matches = match_landmarks(mapped, truth);
  ASSERT_EQ(matches.size(), 2u);
  EXPECT_EQ(matches[0].mapped, 1u);
  EXPECT_EQ(matches[0].truth, 0u);
  EXPECT_NEAR(matches[0].distance_m, 0.1, 1e-12);
  EXPECT_EQ(matches[1].mapped, 0u);
  EXPECT_EQ(matches[1].truth, 1u);
  EXPECT_NEAR(matches[1].distance_m, 0.9, 1e-12);
  // Equal distances: the lower mapped index first, whatever the input's other order.
  const std::vector<LandmarkMatch> tie =
      match_landmarks({{10, -0.5, 0.0}, {11, 0.5, 0.0}}, {{1, 0.0, 0.0}});
  ASSERT_EQ(tie.size(), 1u);
  EXPECT_EQ(tie[0].mapped, 0u);
}

TEST(LandmarkMatching, OnlyPairsWithinTheGateMatch) {
  EXPECT_DOUBLE_EQ(kLandmarkMatchGateM, 1.0);
  const std::vector<LandmarkPoint> truth{{1, 0.0, 0.0}};
  EXPECT_EQ(match_landmarks({{10, 1.0, 0.0}}, truth).size(), 1u);  // inclusive
  EXPECT_EQ(match_landmarks({{10, 1.0 + 1e-9, 0.0}}, truth).size(), 0u);
  EXPECT_EQ(match_landmarks({{10, 0.6, 0.8}}, truth).size(), 1u);
  EXPECT_EQ(match_landmarks({{10, 0.6, 0.8}}, truth, 0.5).size(), 0u);
  EXPECT_TRUE(match_landmarks({}, truth).empty());
  EXPECT_TRUE(match_landmarks({{10, 0.0, 0.0}}, {}).empty());
}

TEST(LandmarkMatching, SummaryCountsSpuriousAndMissedOnlyAmongObserved) {
  // True 1..4; the cameras saw 1, 2 and 3. Mapped: near 1 (0.3), near 3 (0.4), one far away.
  const std::vector<LandmarkPoint> truth{{1, 0, 0}, {2, 5, 0}, {3, 0, 5}, {4, 5, 5}};
  const std::vector<LandmarkPoint> mapped{{7, 0.3, 0.0}, {8, 0.0, 5.4}, {9, 20.0, 20.0}};
  const LandmarkMapSummary s = summarize_landmark_map(mapped, truth, {1, 2, 3});
  EXPECT_EQ(s.mapped, 3u);
  EXPECT_EQ(s.matched, 2u);
  EXPECT_EQ(s.spurious, 1u);
  EXPECT_EQ(s.observed, 3u);
  EXPECT_EQ(s.missed, 1u);  // 2; 4 was never seen, so not missed
  ASSERT_TRUE(s.error_rms_m && s.error_mean_m && s.error_max_m);
  EXPECT_NEAR(*s.error_rms_m, std::sqrt((0.09 + 0.16) / 2.0), 1e-12);
  EXPECT_NEAR(*s.error_mean_m, 0.35, 1e-12);
  EXPECT_NEAR(*s.error_max_m, 0.4, 1e-12);
  // Ids the world does not have are ignored; nothing mapped: every observed one missed.
  const LandmarkMapSummary empty = summarize_landmark_map({}, truth, {2, 4, 99});
  EXPECT_EQ(empty.mapped, 0u);
  EXPECT_EQ(empty.matched, 0u);
  EXPECT_EQ(empty.observed, 2u);
  EXPECT_EQ(empty.missed, 2u);
  EXPECT_FALSE(empty.error_rms_m || empty.error_mean_m || empty.error_max_m);
}

TEST(LandmarkMatching, TheAlignedErrorIsTheMapsShapeWithoutItsPlacement) {
  // A map of the right shape in a frame 0.3 m and 2 degrees off (a SLAM filter's start guess):
  // landmarks 0.14-0.35 m off in the world, none once the map is moved onto the truth. Then
  // one landmark mapped 0.2 m out of shape: the aligned error shows it, spread by the fit.
  const std::vector<LandmarkPoint> truth{{1, 0, 0}, {2, 8, 0}, {3, 0, 6}, {4, 8, 6}};
  const double angle = 2.0 * std::numbers::pi / 180.0, c = std::cos(angle), s = std::sin(angle);
  std::vector<LandmarkPoint> mapped;
  for (const LandmarkPoint& t : truth)
    mapped.push_back({t.id + 10, c * t.x_m - s * t.y_m + 0.3, s * t.x_m + c * t.y_m - 0.1});
  const LandmarkMapSummary shifted = summarize_landmark_map(mapped, truth, {1, 2, 3, 4});
  ASSERT_EQ(shifted.matched, 4u);
  EXPECT_GT(*shifted.error_rms_m, 0.2);
  ASSERT_TRUE(shifted.aligned_rms_m && shifted.aligned_mean_m && shifted.aligned_max_m);
  EXPECT_LT(*shifted.aligned_max_m, 1e-9);
  EXPECT_EQ(shifted.aligned_within, 4u);  // all within 0.3 m once aligned (0.14-0.35 m before)
  mapped[3].x_m += 0.2;
  const LandmarkMapSummary bent = summarize_landmark_map(mapped, truth, {1, 2, 3, 4});
  EXPECT_GT(*bent.aligned_max_m, 0.05);
  EXPECT_LT(*bent.aligned_max_m, 0.2);  // the fit shares the bend among the four
  EXPECT_GT(*bent.aligned_rms_m, 0.05);
  EXPECT_EQ(bent.aligned_within, 4u);
  // One landmark mapped 0.6 m out of shape: the fit spreads it (0.12-0.22 m on the others), but
  // it alone stays beyond 0.3 m (0.40).
  mapped[3].x_m += 0.4;
  const LandmarkMapSummary broken = summarize_landmark_map(mapped, truth, {1, 2, 3, 4});
  ASSERT_EQ(broken.matched, 4u);
  EXPECT_GT(*broken.aligned_max_m, kLandmarkAlignedGateM);
  EXPECT_EQ(broken.aligned_within, 3u);
  mapped[3].x_m -= 0.6;
  // Two pairs fix the motion but for their distance: no aligned error below three.
  const LandmarkMapSummary two = summarize_landmark_map({mapped[0], mapped[1]}, truth, {1, 2});
  EXPECT_EQ(two.matched, 2u);
  EXPECT_FALSE(two.aligned_rms_m || two.aligned_mean_m || two.aligned_max_m);
  EXPECT_EQ(two.aligned_within, 0u);  // judged as they are: 0.32 and 0.35 m off
}

// ---------------------------------------------------------------------------------- end to end
// A robot at the origin facing +x with a PTZ camera that misses nothing and invents nothing:
// landmarks 1-3 ahead (seen from the first frame), 4 and 5 behind (never seen).
const char* kWorld = R"(
name: slam_test
landmarks:
  - {id: 1, position: [3.0, 0.0], color: red, height_m: 0.6}
  - {id: 2, position: [3.0, 1.0], color: green, height_m: 0.6}
  - {id: 3, position: [3.0, -1.0], color: blue, height_m: 0.6}
  - {id: 4, position: [-3.0, 0.0], color: yellow, height_m: 0.6}
  - {id: 5, position: [-3.0, 2.0], color: red, height_m: 0.6}
robots:
  - name: r
    start: {x: 0, y: 0}
    sensors:
      ptz_camera: {miss_probability: 0, false_detections_per_frame: 0}
scenario:
  duration_s: 1.0
  ptz: {policy: fixed, pan_deg: 0}
)";

std::string slam_map_plugin() {
  return std::string(LOCSIM_TEST_PLUGIN_DIR) + "/locsim_test_slam_map.so";
}

fs::path write_world(const fs::path& dir, const std::string& scenario_extra = "") {
  const fs::path file = dir / "world.yaml";
  std::ofstream(file) << kWorld << scenario_extra;
  return file;
}

const ojson& entry(const ojson& metrics, const std::string& label) {
  for (const auto& e : metrics["localizers"]) {
    if (e["label"] == label) return e;
  }
  throw std::runtime_error("no localizer " + label);
}

// Landmarks 1, 3, 4 mapped 0.5 m off (0.3, 0.4), landmark 2 left out, one spurious 14 m away.
const char* kExpectedCsv =
    "id,x_m,y_m,cov_xx,cov_xy,cov_yy\n"
    "100,3.300000,0.400000,0.010000000,0.002000000,0.020000000\n"
    "102,3.300000,-0.600000,0.010000000,0.002000000,0.020000000\n"
    "103,-2.700000,0.400000,0.010000000,0.002000000,0.020000000\n"
    "999,13.000000,10.000000,0.010000000,0.000000000,0.010000000\n";

void expect_known_map_metrics(const ojson& l) {
  ASSERT_TRUE(l.contains("landmark_map")) << l.dump(2);
  const ojson& m = l["landmark_map"];
  std::vector<std::string> keys;  // in the file's order
  for (const auto& [key, value] : m.items()) keys.push_back(key);
  EXPECT_EQ(keys, (std::vector<std::string>{"mapped", "matched", "error_m", "error_aligned_m",
                                            "aligned_within", "aligned_gate_m", "spurious",
                                            "missed", "observed", "gate_m"}));
  EXPECT_EQ(m["aligned_within"], 3);  // the three matched, exact once aligned
  EXPECT_EQ(m["aligned_gate_m"], 0.3);
  EXPECT_EQ(m["mapped"], 4);
  EXPECT_EQ(m["matched"], 3);
  EXPECT_EQ(m["spurious"], 1);
  EXPECT_EQ(m["missed"], 1);    // landmark 2
  EXPECT_EQ(m["observed"], 3);  // 1, 2, 3; 4 is matched but was never seen, 5 neither
  EXPECT_EQ(m["gate_m"], 1.0);
  for (const char* stat : {"rms", "mean", "max"}) {
    EXPECT_NEAR(m["error_m"][stat].get<double>(), 0.5, 1e-12) << stat;
    // The three matched are all shifted alike: the map's shape is exact.
    EXPECT_NEAR(m["error_aligned_m"][stat].get<double>(), 0.0, 1e-9) << stat;
  }
}

TEST(LandmarkMapRun, FakeSlamFilterGetsItsMapMatchedAndWritten) {
  const fs::path dir = testing::temp_dir("run");
  RunOptions options;
  options.world_file = write_world(dir);
  options.out_dir = dir / "out";
  options.localizers = {slam_map_plugin() + ":count=4,skip=1,spurious=true@slam",
                        std::string(LOCSIM_TEST_PLUGIN_DIR) + "/locsim_test_probe.so@probe"};
  options.log_file = dir / "run.locsimlog";
  run_simulation(options);
  const ojson metrics = ojson::parse(testing::read_file(options.out_dir / "metrics.json"));
  const ojson& slam = entry(metrics, "slam");
  EXPECT_EQ(slam["status"], "ok");
  expect_known_map_metrics(slam);
  EXPECT_EQ(slam["diagnostics"]["map_landmarks"], 5.0);
  EXPECT_EQ(slam["diagnostics"]["map_landmarks_null"], 0.0);
  EXPECT_EQ(testing::read_file(options.out_dir / "slam_map.csv"), kExpectedCsv);
  // A filter without a map: no file, no block.
  EXPECT_FALSE(entry(metrics, "probe").contains("landmark_map"));
  EXPECT_FALSE(fs::exists(options.out_dir / "probe_map.csv"));
  // The default (landmarks known) leaves the scenario's configuration in run.json as it was.
  const ojson run = ojson::parse(testing::read_file(options.out_dir / "run.json"));
  EXPECT_FALSE(run["config"]["scenario"].contains("localization"));

  // A replay of the log (what sweeps run) knows what the cameras saw from the readings alone.
  ReplayOptions replay;
  replay.log_file = *options.log_file;
  replay.out_dir = dir / "replay";
  replay.localizers = {options.localizers[0]};
  replay_log(replay);
  EXPECT_EQ(testing::read_file(replay.out_dir / "slam_map.csv"), kExpectedCsv);
  const ojson replayed = ojson::parse(testing::read_file(replay.out_dir / "metrics.json"));
  EXPECT_EQ(entry(replayed, "slam")["landmark_map"], slam["landmark_map"]);
}

TEST(LandmarkMapRun, UnknownLandmarksGiveTheFiltersAMapWithoutThem) {
  const fs::path dir = testing::temp_dir("run");
  RunOptions options;
  options.world_file = write_world(dir, "  localization: {landmarks_known: false}\n");
  options.out_dir = dir / "out";
  options.localizers = {slam_map_plugin() + "@slam"};
  run_simulation(options);
  const ojson metrics = ojson::parse(testing::read_file(options.out_dir / "metrics.json"));
  const ojson& slam = entry(metrics, "slam");
  EXPECT_EQ(slam["status"], "ok");
  EXPECT_EQ(slam["diagnostics"]["map_landmarks"], 0.0);
  EXPECT_EQ(slam["diagnostics"]["map_landmarks_null"], 1.0);
  // It mapped nothing (it copies the map it was given): no file, no block.
  EXPECT_FALSE(slam.contains("landmark_map"));
  EXPECT_FALSE(fs::exists(options.out_dir / "slam_map.csv"));
  const ojson run = ojson::parse(testing::read_file(options.out_dir / "run.json"));
  EXPECT_EQ(run["config"]["scenario"]["localization"], ojson({{"landmarks_known", false}}));
  // The world's landmarks are still there for the cameras.
  EXPECT_NE(testing::read_file(options.out_dir / "readings/ptz_camera.csv").find(",red,"),
            std::string::npos);
}

TEST(LandmarkMapRun, ScenarioKeyIsABoolean) {
  const fs::path dir = testing::temp_dir("run");
  std::string message = "accepted";
  try {
    load_run_inputs(write_world(dir, "  localization: {landmarks_known: maybe}\n"), std::nullopt,
                    std::nullopt);
  } catch (const InputError& e) {
    message = e.what();
  }
  EXPECT_NE(message.find("landmarks_known"), std::string::npos) << message;
}

TEST(LandmarkMapRun, ErrorsAndNonFiniteMapsFailTheFilterAlone) {
  const fs::path dir = testing::temp_dir("run");
  RunOptions options;
  options.world_file = write_world(dir);
  options.out_dir = dir / "out";
  options.localizers = {slam_map_plugin() + ":fail=throw@throws",
                        slam_map_plugin() + ":fail=nan@nan", slam_map_plugin() + "@fine"};
  run_simulation(options);
  const ojson metrics = ojson::parse(testing::read_file(options.out_dir / "metrics.json"));
  const ojson& throws = entry(metrics, "throws");
  EXPECT_EQ(throws["status"], "failed");
  EXPECT_EQ(throws["failure"]["call"], "landmark_map");
  EXPECT_EQ(throws["failure"]["message"], "deliberate landmark map failure");
  EXPECT_DOUBLE_EQ(throws["failure"]["t_s"].get<double>(), 1.0);
  const ojson& nan = entry(metrics, "nan");
  EXPECT_EQ(nan["status"], "failed");
  EXPECT_EQ(nan["failure"]["call"], "landmark_map");
  EXPECT_EQ(nan["failure"]["message"],
            "returned a non-finite (NaN or inf) position or covariance for landmark 104");
  for (const char* label : {"throws", "nan"}) {
    EXPECT_FALSE(entry(metrics, label).contains("landmark_map")) << label;
    EXPECT_FALSE(fs::exists(options.out_dir / (std::string(label) + "_map.csv"))) << label;
  }
  // The same plugin without the failure: all five landmarks 0.5 m off, each matched.
  const ojson& fine = entry(metrics, "fine");
  EXPECT_EQ(fine["status"], "ok");
  EXPECT_EQ(fine["landmark_map"]["matched"], 5);
  EXPECT_EQ(fine["landmark_map"]["missed"], 0);
  const ojson run = ojson::parse(testing::read_file(options.out_dir / "run.json"));
  EXPECT_EQ(run["status"], "completed");
}

TEST(LandmarkMapRun, SweepResultsHaveTheLandmarkErrorColumn) {
  const fs::path dir = testing::temp_dir("sweep");
  const fs::path experiment = dir / "experiment.yaml";
  std::ofstream(experiment) << "name: slam\nworld: " << write_world(dir).string()
                            << "\nseeds: [1]\nlocalizers:\n"
                            << "  - plugin: " << slam_map_plugin() << "\n    label: slam\n"
                            << "    params: {count: 4, skip: 1, spurious: true}\n"
                            << "  - plugin: " << LOCSIM_TEST_PLUGIN_DIR
                            << "/locsim_test_probe.so\n    label: probe\n";
  SweepOptions options;
  options.experiment_file = experiment;
  options.out_dir = dir / "out";
  options.jobs = 1;
  options.locsim_binary = LOCSIM_BINARY;
  const SweepSummary summary = run_sweep(options);
  EXPECT_EQ(summary.not_ok, 0u);
  std::istringstream rows(testing::read_file(dir / "out/results.csv"));
  std::string header, slam, probe;
  std::getline(rows, header);
  std::getline(rows, slam);
  std::getline(rows, probe);
  // The column by its name (no field of these rows holds a comma).
  const auto fields = [](const std::string& line) {
    std::vector<std::string> out;
    std::istringstream in(line);
    for (std::string field; std::getline(in, field, ',');) out.push_back(field);
    if (!line.empty() && line.back() == ',') out.emplace_back();
    return out;
  };
  const std::vector<std::string> names = fields(header);
  const auto column = std::find(names.begin(), names.end(), "landmark_error_m");
  ASSERT_NE(column, names.end()) << header;
  const auto at = static_cast<std::size_t>(column - names.begin());
  EXPECT_EQ(slam.substr(0, 7), "0,slam/");
  ASSERT_EQ(fields(slam).size(), names.size()) << slam;
  EXPECT_EQ(fields(slam)[at], "0.500000");
  EXPECT_EQ(probe.substr(0, 8), "1,probe/");
  ASSERT_EQ(fields(probe).size(), names.size()) << probe;
  EXPECT_EQ(fields(probe)[at], "");  // empty: no map
}

// ------------------------------------------------------------------------------------- frames

TEST(LandmarkMapFrames, CaptureCarriesTheMapAndTheRendererDrawsIt) {
  const fs::path dir = testing::temp_dir("run");
  testing::KeepFrames sink;
  RunOptions options;
  options.world_file = write_world(dir);
  options.out_dir = dir / "out";
  options.localizers = {slam_map_plugin() + ":skip=1@slam"};
  options.video = &sink;
  options.video_options.fps = 10.0;
  run_simulation(options);
  ASSERT_FALSE(sink.kept.empty());
  const FrameState& last = sink.kept.back();
  ASSERT_EQ(last.localizers.size(), 1u);
  const auto& map = last.localizers[0].landmark_map;
  ASSERT_EQ(map.size(), 4u);
  EXPECT_NEAR(map[0].position_m.x(), 3.3, 1e-12);
  EXPECT_NEAR(map[0].position_m.y(), 0.4, 1e-12);
  EXPECT_DOUBLE_EQ(map[0].covariance(0, 1), 0.002);
  EXPECT_DOUBLE_EQ(map[0].covariance(1, 1), 0.02);

  // Drawn: a cross in the filter's colour at each mapped landmark, the floor elsewhere.
  const WorldDef world = testing::world_from_yaml(kWorld);
  const auto context = render::make_gl_context("osmesa", 320, 240);
  render::TopDownRenderer renderer(world, 320, 240);
  FrameState frame = last;
  frame.localizers[0].estimate.reset();
  frame.localizers[0].particles.clear();
  renderer.draw(frame);
  cv::Mat bgr;
  renderer.compose(frame, context->finish_frame(), bgr);
  const render::View& view = renderer.view();
  const auto pixel = [&](double x, double y) {
    const cv::Point2d p = view.to_pixel(x, y);
    return bgr.at<cv::Vec3b>(static_cast<int>(p.y), static_cast<int>(p.x));
  };
  const render::Rgb c = renderer.palette().filter(0), floor = renderer.palette().floor;
  const auto near = [](const cv::Vec3b& got, const render::Rgb& rgb, int tolerance) {
    for (int k = 0; k < 3; ++k) {
      if (std::abs(got[k] - static_cast<int>(rgb[2 - k] * 255.0f)) > tolerance) return false;
    }
    return true;
  };
  EXPECT_TRUE(near(pixel(-2.7, 0.4), c, 40)) << pixel(-2.7, 0.4);
  EXPECT_TRUE(near(pixel(0.0, -1.5), floor, 3)) << pixel(0.0, -1.5);
}

}  // namespace
}  // namespace locsim
