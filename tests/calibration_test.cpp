// `locsim calibrate`: on logs whose noise is known (a simulated run with configured sensor noise,
// and a generated dataset whose odometry follows the odometry model with chosen alphas), the
// fitted values come back within 15 %.
#include "sim/metrics/calibration.hpp"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <locsim/models.hpp>
#include <locsim/particles.hpp>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/common/random.hpp"
#include "sim/plugin_host/plugin_library.hpp"
#include "sim/producers/import_log.hpp"
#include "sim/run/runner.hpp"
#include "tests/noisy_world.hpp"
#include "tests/test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;

fs::path record_noisy_run(const fs::path& dir, std::uint64_t seed) {
  const fs::path world = dir / "world.yaml";
  std::ofstream(world) << testing::noisy_world(0.5);
  RunOptions options;
  options.world_file = world;
  options.seed = seed;
  options.out_dir = dir / "run";
  options.readings = false;
  options.log_file = dir / "noisy.locsimlog";
  run_simulation(options);
  return *options.log_file;
}

void expect_within(double fitted, double configured, const char* what) {
  EXPECT_NEAR(fitted, configured, 0.15 * std::abs(configured))
      << what << ": fitted " << fitted << ", configured " << configured;
}

class SimulatedNoise : public ::testing::TestWithParam<std::uint64_t> {};

TEST_P(SimulatedNoise, IsRecoveredWithin15Percent) {
  const fs::path dir = testing::temp_dir("calibrate_sim");
  const Calibration c = calibrate({record_noisy_run(dir, GetParam())}, {});
  ASSERT_TRUE(c.motion);
  expect_within(c.motion->k_left, 0.01, "k_left");
  expect_within(c.motion->k_right, 0.02, "k_right");
  // Below 1 when the wheel model's covariance, with the fitted k, covers the errors it should.
  EXPECT_NEAR(c.motion->k_mean_nees, 3.0, 0.45);
  ASSERT_TRUE(c.motion->heading);
  EXPECT_FALSE(c.motion->heading->gyro) << "the heading is the wheels'";
  ASSERT_EQ(c.cameras.size(), 1u);
  const DetectionCalibration& rb = c.cameras[0];
  EXPECT_EQ(rb.camera, "range_bearing");
  EXPECT_EQ(rb.range_model, "distance");  // the world's sensor reports distances
  expect_within(rb.range_spread_m.at_zero, 0.05, "sigma_range_m");
  expect_within(rb.range_spread_m.per_unit, 0.02, "sigma_range_per_m");
  expect_within(rb.range_bias_m.at_zero, 0.1, "range_bias_m");
  expect_within(rb.range_bias_m.per_unit, -0.05, "range_bias_per_m");
  expect_within(rb.bearing_spread_rad, deg_to_rad(1.5), "sigma_bearing");
  expect_within(rb.bearing_bias_rad, deg_to_rad(2.0), "bearing_bias");
  ASSERT_TRUE(rb.miss_probability);
  expect_within(*rb.miss_probability, 0.2, "miss_probability");
  expect_within(rb.false_per_reading, 0.3, "false_detections");
  ASSERT_TRUE(rb.noise_correlation_s);
  expect_within(*rb.noise_correlation_s, 0.5, "noise_correlation_s");
  // The false ones among all detections (0.3 per reading of ~3), over the measured span.
  ASSERT_TRUE(rb.outlier_likelihood);
  EXPECT_GT(*rb.outlier_likelihood, 0.0);
}

INSTANTIATE_TEST_SUITE_P(Seeds, SimulatedNoise, ::testing::Values(3u, 11u));

/// `world` with `from` replaced by `to` (a test world's key; one that is not there is a mistake
/// in the test).
std::string replaced(std::string world, const std::string& from, const std::string& to) {
  const auto at = world.find(from);
  if (at == std::string::npos) throw std::logic_error("the world has no '" + from + "'");
  return world.replace(at, from.size(), to);
}

/// A run of `world` (YAML) recorded into `dir`: the log's path.
fs::path record(const fs::path& dir, const std::string& world, std::uint64_t seed,
                std::optional<double> duration_s = std::nullopt) {
  std::ofstream(dir / "world.yaml") << world;
  RunOptions options;
  options.world_file = dir / "world.yaml";
  options.seed = seed;
  if (duration_s) options.duration_s = *duration_s;
  options.out_dir = dir / "run";
  options.readings = false;
  options.log_file = dir / "recorded.locsimlog";
  run_simulation(options);
  return *options.log_file;
}

/// The noisy world with its range-bearing sensor's `range_model` given, MRCLAM's order of range
/// bias (5 cm + 2 % of the range) and small independent noise without false detections, so that
/// the fitted lines are tight: 120 s recorded.
fs::path record_range_model_run(const fs::path& dir, const std::string& range_model) {
  std::string world = testing::noisy_world(0.0);
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"sigma_range_m: 0.05", "sigma_range_m: 0.01"},
           {"sigma_range_per_m: 0.02", "sigma_range_per_m: 0.01"},
           {"range_bias_m: 0.1", "range_bias_m: 0.05"},
           {"range_bias_per_m: -0.05",
            "range_bias_per_m: 0.02\n        range_model: " + range_model},
           {"false_detections: 0.3", "false_detections: 0"}}) {
    world = replaced(world, from, to);
  }
  return record(dir, world, 5, 120.0);
}

TEST(Calibrate, ADepthCameraIsFittedAsOneAndItsSensorSettingsSayDepth) {
  const fs::path dir = testing::temp_dir("calibrate_depth");
  const Calibration c = calibrate({record_range_model_run(dir, "depth")}, {});
  ASSERT_EQ(c.cameras.size(), 1u);
  const DetectionCalibration& rb = c.cameras[0];
  ASSERT_TRUE(rb.distance_model && rb.depth_model);
  EXPECT_EQ(rb.range_model, "depth");
  // The depth model's bias line is the configured one: measured = 0.05 + (1 + 0.02) x.
  EXPECT_NEAR(rb.depth_model->bias_m.at_zero, 0.05, 0.02);
  EXPECT_NEAR(rb.depth_model->bias_m.per_unit, 0.02, 0.01);
  // About it only the noise is left (0.01 + 0.01 x, x below 7 m); about the distance line, the
  // cosine too.
  EXPECT_LT(rb.depth_model->residual_rms_m, 0.08);
  EXPECT_LT(rb.depth_model->residual_rms_m, rb.distance_model->residual_rms_m);

  // A world made from the calibration reproduces the errors: depth, with the depth lines.
  const YAML::Node sensor = YAML::Load(c.to_yaml())["sensors"]["range_bearing"];
  EXPECT_EQ(sensor["range_model"].as<std::string>(), "depth");
  EXPECT_NEAR(sensor["range_bias_m"].as<double>(), rb.depth_model->bias_m.at_zero, 1e-3);
  EXPECT_NEAR(sensor["range_bias_per_m"].as<double>(), rb.depth_model->bias_m.per_unit, 1e-3);
  EXPECT_NEAR(sensor["sigma_range_per_m"].as<double>(), rb.depth_model->spread_m.per_unit, 1e-3);
  const nlohmann::json json = nlohmann::json::parse(c.to_json().dump());
  EXPECT_EQ(json.at("cameras").at(0).at("range_models").at("chosen"), "depth");
  testing::expect_contains(describe(c), "range model: depth");
}

TEST(Calibrate, ADistanceCameraKeepsTheDistanceModel) {
  const fs::path dir = testing::temp_dir("calibrate_distance");
  const Calibration c = calibrate({record_range_model_run(dir, "distance")}, {});
  ASSERT_EQ(c.cameras.size(), 1u);
  const DetectionCalibration& rb = c.cameras[0];
  ASSERT_TRUE(rb.distance_model && rb.depth_model);
  EXPECT_EQ(rb.range_model, "distance");
  EXPECT_NEAR(rb.range_bias_m.at_zero, 0.05, 0.02);
  EXPECT_NEAR(rb.range_bias_m.per_unit, 0.02, 0.01);
  EXPECT_LT(rb.distance_model->residual_rms_m, rb.depth_model->residual_rms_m);
  const YAML::Node sensor = YAML::Load(c.to_yaml())["sensors"]["range_bearing"];
  EXPECT_EQ(sensor["range_model"].as<std::string>(), "distance");
  EXPECT_NEAR(sensor["range_bias_m"].as<double>(), rb.range_bias_m.at_zero, 1e-3);
}

TEST(Calibrate, TellsABearingWhoseErrorsPersistOtherwiseThanTheRangesAndWritesBoth) {
  // The range's errors persist over 1 s, the bearing's are independent: one process for both
  // would give the bearing the range's memory (a filter would then trust the bearing too little,
  // and a twin would hold its errors too long).
  const fs::path dir = testing::temp_dir("calibrate_bearing_apart");
  const std::string key = "noise_correlation_s: " + std::to_string(1.0);
  const Calibration c =
      calibrate({record(dir,
                        replaced(testing::noisy_world(1.0), key,
                                 key + "\n        bearing_noise_correlation_s: 0"),
                        7)},
                {});
  ASSERT_EQ(c.cameras.size(), 1u);
  const auto& apart = c.cameras[0].channel_correlations;
  ASSERT_TRUE(apart) << describe(c);
  expect_within(apart->range.fast_s, 1.0, "the range's time constant");
  EXPECT_EQ(apart->range.slow_share, 0.0);
  EXPECT_EQ(apart->bearing.fast_s, 0.0) << "the bearing's errors are independent";
  EXPECT_EQ(apart->bearing.slow_share, 0.0);
  testing::expect_contains(describe(c), "range and bearing apart");
  // Written for the twin's sensor and for the localizers, each channel its own.
  const YAML::Node yaml = YAML::Load(c.to_yaml());
  const YAML::Node sensor = yaml["sensors"]["range_bearing"];
  EXPECT_NEAR(sensor["noise_correlation_s"].as<double>(), apart->range.fast_s, 1e-3);
  EXPECT_EQ(sensor["bearing_noise_correlation_s"].as<double>(), 0.0);
  EXPECT_EQ(sensor["bearing_noise_correlation_slow_share"].as<double>(), 0.0);
  EXPECT_EQ(yaml["localizer_params"]["bearing_noise_correlation_s"].as<double>(), 0.0);
  EXPECT_NEAR(yaml["localizer_params"]["noise_correlation_s"].as<double>(), apart->range.fast_s,
              1e-3);
}

TEST(Calibrate, RecoversWheelsWhoseErrorsMoveTogetherAndGivesTheTwinThem) {
  // Wheels whose errors are correlated 0.7: the robot's travel errs more and its heading less
  // than independent wheels of the same k would make them. The localizers keep the independent
  // fit (what the SDK's wheel model gives them); the twin's encoders take the correlated one.
  const fs::path dir = testing::temp_dir("calibrate_wheels_together");
  const Calibration c = calibrate(
      {record(dir,
              replaced(testing::noisy_world(0.0),
                       "encoders: {rate_hz: 50, k_left: 0.01, k_right: 0.02}",
                       "encoders: {rate_hz: 50, k_left: 0.02, k_right: 0.02, k_correlation: 0.7}"),
              4)},
      {});
  ASSERT_TRUE(c.motion);
  const auto& wheels = c.motion->correlated_wheels;
  ASSERT_TRUE(wheels) << describe(c);
  expect_within(wheels->k_correlation, 0.7, "k_correlation");
  expect_within(wheels->k_left, 0.02, "k_left");
  expect_within(wheels->k_right, 0.02, "k_right");
  testing::expect_contains(describe(c), "the wheels' errors correlated");
  const YAML::Node yaml = YAML::Load(c.to_yaml());
  EXPECT_NEAR(yaml["sensors"]["encoders"]["k_correlation"].as<double>(), wheels->k_correlation,
              1e-3);
  EXPECT_NEAR(yaml["localizer_params"]["k_left"].as<double>(), c.motion->k_left, 1e-4);
  EXPECT_FALSE(yaml["localizer_params"]["k_correlation"]);
}

TEST(Calibrate, FindsACameraOffItsBelievedPlaceAndTheTwinMountsItThere) {
  // Two robots' logs: one whose camera sits 10 cm ahead and 5 cm left of where its detections are
  // given from (MRCLAM robot 4's is 8 cm ahead), one whose camera is where it is believed. The
  // offset errs each bearing by its own amount (more for landmarks near and off the axis), which
  // no bias takes out: calibrate finds it from the bearings, measures the bearings' noise from
  // the camera's place for the twin's sensor, and the twin mounts that robot's camera there.
  const fs::path dir = testing::temp_dir("calibrate_camera_offset");
  fs::create_directories(dir / "shifted");
  fs::create_directories(dir / "placed");
  std::string shifted = replaced(
      replaced(testing::noisy_world(0.0), "        rate_hz: 10\n        fov_deg: 120",
               "        rate_hz: 10\n        fov_deg: 120\n        mount: {x: 0.1, y: 0.05}\n"
               "        believed_mount: {x: 0, y: 0}"),
      "name: robot", "name: shifted");
  shifted = replaced(shifted, "duration_s: 300", "duration_s: 600");
  const std::string placed =
      replaced(testing::noisy_world(0.0), "duration_s: 300", "duration_s: 600");
  const fs::path shifted_log = record(dir / "shifted", shifted, 5);
  const Calibration c = calibrate({shifted_log, record(dir / "placed", placed, 6)}, {});
  ASSERT_EQ(c.cameras.size(), 1u);
  const DetectionCalibration& camera = c.cameras[0];
  ASSERT_EQ(camera.camera_offsets.size(), 2u) << describe(c);
  const CameraOffset* found = nullptr;
  for (const CameraOffset& o : camera.camera_offsets) {
    if (o.robot == "shifted") {
      found = &o;
      EXPECT_TRUE(o.significant) << describe(c);
      expect_within(o.x_m, 0.1, "the camera's forward offset");
      expect_within(o.y_m, 0.05, "the camera's left offset");
      EXPECT_GE(o.blocks, CameraOffset::kMinBlocks);
    } else {
      EXPECT_EQ(o.robot, "robot");
      EXPECT_FALSE(o.significant) << describe(c);
      EXPECT_LT(std::hypot(o.x_m, o.y_m), 0.02) << describe(c);
    }
  }
  ASSERT_NE(found, nullptr);
  const CameraOffset& offset = *found;
  testing::expect_contains(describe(c), "shifted's camera off its believed place");
  // From the believed places the offset passes for bearing noise; from the cameras' places the
  // bearings' noise is the sensors' own: 2 deg bias, 1.5 deg spread.
  ASSERT_TRUE(camera.from_camera_places);
  expect_within(rad_to_deg(camera.from_camera_places->bearing_bias_rad), 2.0, "bearing bias");
  expect_within(rad_to_deg(camera.from_camera_places->bearing_spread_rad), 1.5, "bearing spread");
  EXPECT_GT(camera.bearing_spread_rad, camera.from_camera_places->bearing_spread_rad);

  const fs::path calibration = dir / "calibration.yaml";
  std::ofstream(calibration) << c.to_yaml();
  const YAML::Node yaml = YAML::LoadFile(calibration.string());
  EXPECT_NEAR(yaml["camera_offsets"]["shifted"]["x"].as<double>(), offset.x_m, 1e-4);
  EXPECT_FALSE(yaml["camera_offsets"]["robot"]);
  EXPECT_NEAR(yaml["sensors"]["range_bearing"]["sigma_bearing_deg"].as<double>(),
              rad_to_deg(camera.from_camera_places->bearing_spread_rad), 1e-3);
  // The localizers, which do not know the offset, keep the noise from the believed places.
  EXPECT_NEAR(yaml["localizer_params"]["sigma_bearing_deg"].as<double>(),
              rad_to_deg(camera.bearing_spread_rad), 1e-3);

  const auto twin =
      testing::locsim("twin " + shifted_log.string() + " --calibration " + calibration.string() +
                      " --out " + (dir / "twin" / "world.yaml").string());
  ASSERT_EQ(twin.exit_code, 0) << twin.output;
  testing::expect_contains(twin.output, "range_bearing mounted");
  const YAML::Node sensor = YAML::LoadFile(
      (dir / "twin" / "world.yaml").string())["robots"][0]["sensors"]["range_bearing"];
  EXPECT_NEAR(sensor["mount"]["x"].as<double>(), offset.x_m, 1e-4);
  EXPECT_NEAR(sensor["mount"]["y"].as<double>(), offset.y_m, 1e-4);
  EXPECT_EQ(sensor["believed_mount"]["x"].as<double>(), 0.0);
  // Its ranges as the log's, from the believed place: the camera's depth ahead is added back.
  EXPECT_NEAR(sensor["range_bias_m"].as<double>(),
              yaml["sensors"]["range_bearing"]["range_bias_m"].as<double>() +
                  yaml["camera_offsets"]["shifted"]["x"].as<double>(),
              1e-6);
}

TEST(Calibrate, TellsACameraBlindForSpellsFromOneThatMissesAtRandom) {
  // A camera silent 0.3 of the time in spells of 3 s on average (and missing 0.2 of what it sees
  // besides): calibrate finds the spells from the cells along the path where landmarks were in
  // view and none was detected, and writes them for the twin's sensor. A camera that only misses
  // at random has none; one whose spells are of two kinds (0.2 of them 20 s long, the rest 2 s)
  // has both.
  const fs::path dir = testing::temp_dir("calibrate_camera_silences");
  const std::string key = "noise_correlation_s: " + std::to_string(0.0);
  const auto blind = [&](const std::string& name, const std::string& spells, double duration_s,
                         std::uint64_t seed) {
    fs::create_directories(dir / name);
    // The camera alone: nothing else to calibrate over hours of log.
    const std::string world =
        replaced(replaced(replaced(testing::noisy_world(0.0), key, key + spells), "duration_s: 300",
                          "duration_s: " + std::to_string(duration_s)),
                 "      encoders: {rate_hz: 50, k_left: 0.01, k_right: 0.02}\n", "");
    return calibrate({record(dir / name, world, seed)}, {});
  };
  const Calibration one =
      blind("one", "\n        outage_fraction: 0.3\n        outage_mean_s: 3", 3600.0, 3);
  ASSERT_EQ(one.cameras.size(), 1u);
  const auto& silences = one.cameras[0].silences;
  ASSERT_TRUE(silences);
  EXPECT_TRUE(silences->significant) << describe(one);
  expect_within(silences->fraction, 0.3, "outage_fraction");
  expect_within(silences->mean_s, 3.0, "outage_mean_s");
  EXPECT_EQ(silences->long_share, 0.0) << describe(one);
  testing::expect_contains(describe(one), "blind spells");
  const YAML::Node sensor = YAML::Load(one.to_yaml())["sensors"]["range_bearing"];
  EXPECT_NEAR(sensor["outage_fraction"].as<double>(), silences->fraction, 1e-3);
  EXPECT_NEAR(sensor["outage_mean_s"].as<double>(), silences->mean_s, 1e-3);
  EXPECT_FALSE(sensor["outage_long_share"]);

  const Calibration two = blind("two",
                                "\n        outage_fraction: 0.4\n        outage_mean_s: 2"
                                "\n        outage_long_share: 0.2\n        outage_long_mean_s: 20",
                                7200.0, 3);
  ASSERT_EQ(two.cameras.size(), 1u);
  const auto& kinds = two.cameras[0].silences;
  ASSERT_TRUE(kinds && kinds->significant) << describe(two);
  expect_within(kinds->fraction, 0.4, "outage_fraction");
  expect_within(kinds->mean_s, 2.0, "outage_mean_s");
  expect_within(kinds->long_share, 0.2, "outage_long_share");
  expect_within(kinds->long_mean_s, 20.0, "outage_long_mean_s");
  testing::expect_contains(describe(two), "of two kinds");
  const YAML::Node both = YAML::Load(two.to_yaml())["sensors"]["range_bearing"];
  EXPECT_NEAR(both["outage_long_share"].as<double>(), kinds->long_share, 1e-3);
  EXPECT_NEAR(both["outage_long_mean_s"].as<double>(), kinds->long_mean_s, 1e-2);

  const Calibration seeing = blind("seeing", "", 600.0, 3);
  ASSERT_EQ(seeing.cameras.size(), 1u);
  ASSERT_TRUE(seeing.cameras[0].silences);
  EXPECT_FALSE(seeing.cameras[0].silences->significant) << describe(seeing);
  EXPECT_FALSE(YAML::Load(seeing.to_yaml())["sensors"]["range_bearing"]["outage_fraction"]);
}

/// A robot circling among sixteen landmarks whose camera (120 deg, 0.3-8 m, 10 Hz) detects each
/// landmark in view with the chance (1 - 0.2) e^(-r / 3), exactly where it is; as MRCLAM's logs,
/// only the frames with a detection are kept.
ImportedDataset detections_only_dataset(double seconds) {
  ImportedDataset d;
  d.name = "detections_only";
  d.source = {{"format", "test"}};
  for (int i = 0; i < 16; ++i) {
    const double a = std::numbers::pi / 8.0 * static_cast<double>(i);
    const double r = i % 2 == 0 ? 4.5 : 1.2;
    d.landmarks.push_back({i + 1, {5.0 + r * std::cos(a), 4.0 + r * std::sin(a)}});
  }
  ImportedRobot robot;
  robot.name = "robot";
  robot.fov_rad = deg_to_rad(120.0);
  robot.min_range_m = 0.3;
  robot.max_range_m = 8.0;
  RandomStream rng = make_stream(5, "test/detections_only");
  for (std::size_t k = 0; 0.1 * static_cast<double>(k) <= seconds; ++k) {
    const double t_s = 0.1 * static_cast<double>(k);
    // Around the middle at 0.3 m/s, the radius wandering between 1.5 and 3.5 m.
    const double angle = 0.3 * t_s / 2.5, radius = 2.5 + std::sin(0.05 * t_s);
    const Pose2 pose{5.0 + radius * std::cos(angle), 4.0 + radius * std::sin(angle),
                     wrap_angle(angle + 1.7)};
    robot.truth.push_back({t_s, pose});
    ImportedRobot::Odometry o;
    o.t_s = t_s;
    o.reading.fields = kOdometryPose;
    o.reading.odometry = {pose.x, pose.y, pose.theta};
    robot.odometry.push_back(o);
    ImportedRobot::Detections seen;
    seen.t_s = t_s;
    for (const ImportedLandmark& l : d.landmarks) {
      const Eigen::Vector2d z =
          sdk::range_bearing(sdk::Pose(pose.x, pose.y, pose.theta),
                             Eigen::Vector2d(l.position_m.x(), l.position_m.y()));
      if (z(0) < 0.3 || z(0) > 8.0 || std::abs(z(1)) > deg_to_rad(60.0)) continue;
      if (rng.uniform() >= 0.8 * std::exp(-z(0) / 3.0)) continue;
      Detection detection;
      detection.id = l.id;
      detection.range_m = z(0);
      detection.bearing_rad = z(1);
      seen.detections.push_back(detection);
    }
    if (!seen.detections.empty()) robot.detections.push_back(seen);
  }
  d.robots.push_back(std::move(robot));
  return d;
}

TEST(Calibrate, FindsHowTheChanceOfADetectionFallsWithRange) {
  // A simulated camera missing 0.2 at zero range, its chance falling by e every 3 m, blind 0.3 of
  // the time besides (which, blinding it at every range, must not look like a decay), with 0.05
  // false detections a reading (the noisy world's 0.3, uniform in range, would outnumber the few
  // true ones at 6-7 m, where the range's robust spread, and with it the inlier gate, breaks).
  const fs::path dir = testing::temp_dir("calibrate_detection_decay");
  const std::string key = "noise_correlation_s: " + std::to_string(0.0);
  std::string world = testing::noisy_world(0.0);
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {key, key + "\n        detection_decay_m: 3\n        outage_fraction: 0.3"
                       "\n        outage_mean_s: 3"},
           {"false_detections: 0.3", "false_detections: 0.05"},
           {"duration_s: 300", "duration_s: 1800"},
           {"      encoders: {rate_hz: 50, k_left: 0.01, k_right: 0.02}\n", ""}})
    world = replaced(world, from, to);
  // Both cameras miss 0.2 at zero range, their chance falling by e every 3 m.
  const auto expect_decay = [](const Calibration& c, bool conditioned, const std::string& what) {
    SCOPED_TRACE(what);
    ASSERT_EQ(c.cameras.size(), 1u);
    const auto& decay = c.cameras[0].detection_decay;
    ASSERT_TRUE(decay) << describe(c);
    EXPECT_EQ(decay->conditioned, conditioned);
    expect_within(decay->decay_m, 3.0, "detection_decay_m");
    expect_within(decay->miss_probability_at_zero, 0.2, "miss_probability at zero range");
  };
  fs::create_directories(dir / "simulated");
  const Calibration simulated = calibrate({record(dir / "simulated", world, 3)}, {});
  expect_decay(simulated, false, "every reading logged");
  ASSERT_TRUE(simulated.cameras[0].detection_decay);
  const auto& decay = simulated.cameras[0].detection_decay;
  testing::expect_contains(describe(simulated), "detections fall with range");
  const YAML::Node sensor = YAML::Load(simulated.to_yaml())["sensors"]["range_bearing"];
  EXPECT_NEAR(sensor["detection_decay_m"].as<double>(), decay->decay_m, 1e-3 * decay->decay_m);
  EXPECT_NEAR(sensor["miss_probability"].as<double>(), decay->miss_probability_at_zero, 1e-4);

  // Misses at random whatever the range: no decay (the noisy world misses 0.2).
  const Calibration flat = calibrate({record_noisy_run(dir, 3)}, {});
  ASSERT_EQ(flat.cameras.size(), 1u);
  EXPECT_FALSE(flat.cameras[0].detection_decay) << describe(flat);

  // A log of the frames with a detection only: each is weighed given that one was, else the
  // chance would come out high where one landmark is in view.
  write_import(detections_only_dataset(1800.0), {}, dir / "detections_only.locsimlog");
  expect_decay(calibrate({dir / "detections_only.locsimlog"}, {}), true, "detections only");
}

TEST(Calibrate, AugmentedMclsInjectionLevelStopsInjectionWhileItTracks) {
  // The noisy world's detections (errors correlated over 0.5 s, 0.3 false ones per reading) make
  // the truth's own w_fast / w_slow dip below 1 all the time when a filter counts each detection
  // as independent: with Thrun's rule (level 1) augmented_mcl then injects uniform guesses
  // (Thrun's; not the default) while it tracks, and they cost it the pose. The level `calibrate`
  // writes is where a tracking filter's ratio almost never goes; the correlation it measures
  // (noise_correlation_s) steadies the ratio too.
  const fs::path dir = testing::temp_dir("calibrate_injection");
  const fs::path log = record_noisy_run(dir, 3);
  const auto cal =
      testing::locsim("calibrate " + log.string() + " --out " + (dir / "cal").string());
  ASSERT_EQ(cal.exit_code, 0) << cal.output;
  const YAML::Node yaml = YAML::LoadFile((dir / "cal/calibration.yaml").string());
  const YAML::Node augmented = yaml["localizer_params"]["augmented_mcl"];
  ASSERT_TRUE(augmented["injection_level"]);
  const double level = augmented["injection_level"].as<double>();
  EXPECT_GT(level, 0.0);
  EXPECT_LT(level, 0.9);
  EXPECT_DOUBLE_EQ(augmented["alpha_slow"].as<double>(), kAugmentedAlphaSlow);
  EXPECT_DOUBLE_EQ(augmented["alpha_fast"].as<double>(), kAugmentedAlphaFast);

  const auto replay =
      testing::locsim("replay " + log.string() + " --out " + (dir / "replay").string() +
                      " --params " + (dir / "cal/calibration.yaml").string() +
                      " --localizer augmented_mcl:injection=uniform"
                      " --localizer augmented_mcl:injection=uniform,injection_level=1@thrun"
                      " --localizer augmented_mcl:injection=uniform,injection_level=1,"
                      "noise_correlation_s=0@independent -q");
  ASSERT_EQ(replay.exit_code, 0) << replay.output;
  const auto metrics = nlohmann::json::parse(testing::read_file(dir / "replay/metrics.json"));
  const auto& calibrated = metrics.at("localizers").at(0);
  const auto& thrun = metrics.at("localizers").at(1);
  const auto& independent = metrics.at("localizers").at(2);
  ASSERT_EQ(calibrated.at("status"), "ok");
  ASSERT_EQ(thrun.at("status"), "ok");
  ASSERT_EQ(independent.at("status"), "ok");
  EXPECT_DOUBLE_EQ(calibrated.at("params").at("injection_level").get<double>(), level);
  const auto resets = [](const nlohmann::json& l) {
    return l.at("diagnostics_mean").at("resets").get<double>();  // of 200 particles, per step
  };
  const auto rms = [](const nlohmann::json& l) {
    return l.at("position_error_m").at("rms").get<double>();
  };
  EXPECT_GT(resets(independent), 1.0);
  EXPECT_LT(resets(thrun), 0.5 * resets(independent));
  EXPECT_LE(resets(calibrated), resets(thrun));
  EXPECT_LT(resets(calibrated), 0.25 * resets(independent));
  EXPECT_LT(rms(calibrated), rms(independent));
}

// MRCLAM's robots: a base whose gains wander, a camera blind for seconds at a time. After each
// blind spell a filter that tracks has spread its particles and explains the next detections
// worse than the truth would, so levels measured at the truth (with the averages started at the
// first step's likelihood) made augmented_mcl inject while it tracked: 0.13-0.15 particles a step
// here (level 0.86), where the levels measured along a tracking filter's belief (0.73) inject
// none, and still recover the robot from kidnaps within seconds.
TEST(Calibrate, ResettingLevelsHoldForAFilterThatCoastsThroughBlindSpells) {
  const fs::path dir = testing::temp_dir("calibrate_coasting");
  std::string world = testing::noisy_world(0.5);
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"    wheel_radius_m: 0.05\n",
            "    wheel_radius_m: 0.05\n    max_wheel_accel_radps2: 200\n"
            "    command_response: {dead_time_s: 0.1, time_constant_v_s: 0.25, "
            "time_constant_omega_s: 0.15, gain_v: 0.93, gain_omega: 0.96, gain_wander_v: 0.15, "
            "gain_wander_omega: 0.15, gain_wander_correlation_s: 2}\n"},
           {"encoders: {rate_hz: 50, k_left: 0.01, k_right: 0.02}",
            "encoders: {rate_hz: 50, k_left: 0.01, k_right: 0.02, measures: command, reports: "
            "[velocity]}"},
           {"false_detections: 0.3", "false_detections: 0.1"},
           {"\nscenario:",
            "\n        outage_fraction: 0.4\n        outage_mean_s: 5\n"
            "        noise_correlation_slow_s: 30\n        noise_correlation_slow_share: 0.5"
            "\nscenario:"},
           {"duration_s: 300", "duration_s: 400"}})
    world = replaced(world, from, to);
  fs::create_directories(dir / "tracked");
  const fs::path tracked = record(dir / "tracked", world, 5);
  const auto cal =
      testing::locsim("calibrate " + tracked.string() + " --out " + (dir / "cal").string());
  ASSERT_EQ(cal.exit_code, 0) << cal.output;
  const std::string params = (dir / "cal/calibration.yaml").string();
  const auto replay = [&](const fs::path& log, std::uint64_t seed, const std::string& filters) {
    const fs::path out =
        dir / ("replay_" + log.parent_path().filename().string() + "_" + std::to_string(seed));
    const auto r =
        testing::locsim("replay " + log.string() + " --out " + out.string() + " --params " +
                        params + " --seed " + std::to_string(seed) + filters + " --no-readings -q");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return nlohmann::json::parse(testing::read_file(out / "metrics.json")).at("localizers");
  };
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    SCOPED_TRACE("filter seed " + std::to_string(seed));
    // Uniform guesses (Thrun's), which cost a tracking filter the most.
    const auto l = replay(tracked, seed, " --localizer augmented_mcl:injection=uniform").at(0);
    ASSERT_EQ(l.at("status"), "ok");
    EXPECT_LT(l.at("diagnostics_mean").at("resets").get<double>(), 0.01);  // of 200 per step
  }
  // The same level, and the default guesses from the detections, after two kidnaps.
  fs::create_directories(dir / "kidnapped");
  const fs::path kidnapped =
      record(dir / "kidnapped",
             replaced(world, "  duration_s: 400\n",
                      "  duration_s: 400\n  events:\n"
                      "    - {at_s: 150, kidnap: {to: {x: 8, y: 6, theta_deg: 90}}}\n"
                      "    - {at_s: 280, kidnap: {to: {x: 2, y: 6, theta_deg: -90}}}\n"),
             6);
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    SCOPED_TRACE("filter seed " + std::to_string(seed));
    const auto l = replay(kidnapped, seed, " --localizer augmented_mcl").at(0);
    ASSERT_EQ(l.at("status"), "ok");
    const auto& segments = l.at("segments");
    ASSERT_EQ(segments.size(), 3u);
    for (std::size_t k = 1; k < 3; ++k) {  // measured: 2.0-9.2 s
      ASSERT_TRUE(segments.at(k).at("recovery_s").is_number())
          << "kidnap " << k << " not recovered";
      EXPECT_LT(segments.at(k).at("recovery_s").get<double>(), 20.0) << "kidnap " << k;
    }
  }
}

/// A robot whose odometry reports designed motions (drives, turns on the spot, arcs) while its
/// true path follows them with the odometry model's noise, alphas `noise` (standard-deviation
/// form): what a landmark particle filter assumes. Detections (exact) of every landmark in 6 m
/// make each instant a perception step.
ImportedDataset odometry_model_dataset(const sdk::OdometryNoise& noise, std::size_t steps) {
  ImportedDataset d;
  d.name = "odometry_model";
  d.source = {{"format", "test"}};
  for (int i = 0; i < 4; ++i)
    d.landmarks.push_back({i + 1, {i % 2 == 0 ? -3.0 : 3.0, i < 2 ? -3.0 : 3.0}});
  ImportedRobot robot;
  robot.name = "robot";
  RandomStream rng = make_stream(7, "test/odometry_model");
  sdk::Pose odometry(0, 0, 0), truth(0, 0, 0);
  for (std::size_t k = 0; k <= steps; ++k) {
    const double t_s = 0.2 * static_cast<double>(k);
    ImportedRobot::Odometry o;
    o.t_s = t_s;
    o.reading.fields = kOdometryPose;
    o.reading.odometry = {odometry(0), odometry(1), odometry(2)};
    robot.odometry.push_back(o);
    robot.truth.push_back({t_s, {truth(0), truth(1), truth(2)}});
    ImportedRobot::Detections seen;
    seen.t_s = t_s;
    for (const ImportedLandmark& l : d.landmarks) {
      const Eigen::Vector2d z =
          sdk::range_bearing(truth, Eigen::Vector2d(l.position_m.x(), l.position_m.y()));
      if (z(0) > 6.0) continue;
      Detection detection;
      detection.id = l.id;
      detection.range_m = z(0);
      detection.bearing_rad = z(1);
      seen.detections.push_back(detection);
    }
    robot.detections.push_back(seen);
    // The next commanded motion: straight, on the spot, or an arc; back towards the middle when
    // far out, so that landmarks stay in sight.
    sdk::OdometryDelta step;
    const double pick = rng.uniform();
    if (pick < 0.3) {
      step = {0.0, rng.uniform(0.05, 0.15), 0.0};
    } else if (pick < 0.55) {
      step = {0.0, 0.0, rng.uniform(-0.5, 0.5)};
    } else {
      const double turn = rng.uniform(-0.3, 0.3);
      step = {0.5 * turn, rng.uniform(0.03, 0.1), 0.5 * turn};
    }
    if (std::hypot(odometry(0), odometry(1)) > 2.0) {
      const double home = sdk::wrap(std::atan2(-odometry(1), -odometry(0)) - odometry(2));
      step = {home, 0.05, 0.0};
    }
    const auto apply = [](const sdk::Pose& from, const sdk::OdometryDelta& delta) {
      const double heading = from(2) + delta.rot1;
      return sdk::Pose(from(0) + delta.trans * std::cos(heading),
                       from(1) + delta.trans * std::sin(heading), sdk::wrap(heading + delta.rot2));
    };
    const sdk::OdometryDelta spread = sdk::motion_spread(step, noise);
    const sdk::OdometryDelta actual{step.rot1 + rng.normal(0.0, spread.rot1),
                                    step.trans + rng.normal(0.0, spread.trans),
                                    step.rot2 + rng.normal(0.0, spread.rot2)};
    odometry = apply(odometry, step);
    truth = apply(truth, actual);
  }
  d.robots.push_back(std::move(robot));
  return d;
}

TEST(Calibrate, RecoversTheOdometryModelsAlphasWithin15Percent) {
  const fs::path dir = testing::temp_dir("calibrate_alphas");
  const sdk::OdometryNoise noise{0.1, 0.05, 0.05, 0.03, false};
  write_import(odometry_model_dataset(noise, 4000), {}, dir / "alphas.locsimlog");
  const Calibration c = calibrate({dir / "alphas.locsimlog"}, {});
  ASSERT_TRUE(c.motion);
  EXPECT_FALSE(c.motion->variance_form);  // the form the data were made with explains them better
  expect_within(c.motion->odometry_std.alpha1, noise.alpha1, "alpha1");
  expect_within(c.motion->odometry_std.alpha2, noise.alpha2, "alpha2");
  expect_within(c.motion->odometry_std.alpha3, noise.alpha3, "alpha3");
  expect_within(c.motion->odometry_std.alpha4, noise.alpha4, "alpha4");
  // The detections are exact: no false ones, no bias.
  ASSERT_EQ(c.cameras.size(), 1u);
  EXPECT_EQ(c.cameras[0].false_detections, 0u);
  EXPECT_LT(std::abs(c.cameras[0].range_bias_m.at_zero), 1e-9);
}

TEST(Calibrate, CommandLineWritesAParameterFileAndSensorSettingsAndRefusesBadInput) {
  const fs::path dir = testing::temp_dir("calibrate_cli");
  write_import(odometry_model_dataset({0.1, 0.05, 0.05, 0.03, false}, 300), {},
               dir / "small.locsimlog");
  const auto ok = testing::locsim("calibrate " + (dir / "small.locsimlog").string() + " --out " +
                                  (dir / "cal").string());
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("motion: "), std::string::npos) << ok.output;
  const YAML::Node yaml = YAML::LoadFile((dir / "cal/calibration.yaml").string());
  for (const char* key : {"alpha1", "alpha2", "alpha3", "alpha4", "variance_form", "k_left",
                          "k_right", "sigma_range_m", "sigma_bearing_deg"}) {
    EXPECT_TRUE(yaml["localizer_params"][key]) << key;
  }
  EXPECT_TRUE(yaml["sensors"]["encoders"]["k_left"]);
  const std::string first = testing::read_file(dir / "cal/calibration.yaml");
  const std::string first_json = testing::read_file(dir / "cal/calibration.json");
  EXPECT_NE(first_json.find("\"bins\""), std::string::npos);

  // The same log again: byte-identical files (with --overwrite; refused without).
  const auto again = testing::locsim("calibrate " + (dir / "small.locsimlog").string() + " --out " +
                                     (dir / "cal").string() + " -q");
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_NE(again.output.find("calibration.yaml exists"), std::string::npos) << again.output;
  const auto overwrite = testing::locsim("calibrate " + (dir / "small.locsimlog").string() +
                                         " --out " + (dir / "cal").string() + " -q --overwrite");
  ASSERT_EQ(overwrite.exit_code, 0) << overwrite.output;
  EXPECT_EQ(testing::read_file(dir / "cal/calibration.yaml"), first);
  EXPECT_EQ(testing::read_file(dir / "cal/calibration.json"), first_json);

  // The file is a parameter file every landmark localizer takes (each the keys it declares).
  const auto replay = testing::locsim(
      "replay " + (dir / "small.locsimlog").string() + " --out " + (dir / "replay").string() +
      " --params " + (dir / "cal/calibration.yaml").string() +
      " --localizer ekf_landmarks --localizer mcl --localizer srl --localizer asrl"
      " --localizer augmented_mcl --localizer fastslam -q");
  ASSERT_EQ(replay.exit_code, 0) << replay.output;
  const auto metrics = nlohmann::json::parse(testing::read_file(dir / "replay/metrics.json"));
  for (const auto& localizer : metrics.at("localizers")) {
    const auto& params = localizer.at("params");
    const std::string label = localizer.at("label");
    EXPECT_EQ(localizer.at("status"), "ok") << label;
    if (label == "ekf_landmarks") {
      EXPECT_DOUBLE_EQ(params.at("k_left").get<double>(),
                       yaml["localizer_params"]["k_left"].as<double>());
    } else {
      EXPECT_DOUBLE_EQ(params.at("alpha1").get<double>(),
                       yaml["localizer_params"]["alpha1"].as<double>())
          << label;
    }
    if (label == "fastslam") {
      EXPECT_DOUBLE_EQ(params.at("sigma_range_m").get<double>(),
                       yaml["localizer_params"]["fastslam"]["sigma_range_m"].as<double>());
    }
  }

  const auto nobody = testing::locsim("calibrate " + (dir / "small.locsimlog").string() +
                                      " --out " + (dir / "x").string() + " --robots nobody");
  EXPECT_EQ(nobody.exit_code, 2);
  EXPECT_NE(nobody.output.find("no robot named 'nobody'"), std::string::npos) << nobody.output;
  const auto missing = testing::locsim("calibrate " + (dir / "none.locsimlog").string() +
                                       " --out " + (dir / "y").string());
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.output.find("none.locsimlog"), std::string::npos) << missing.output;
  EXPECT_FALSE(fs::exists(dir / "x/calibration.yaml"));
}

TEST(Calibrate, ItsParameterFileSetsEveryBuiltInFilterPythonOnesIncludedWithoutAWarning) {
  // Range noise that grows with the range and is nothing at zero (MRCLAM's kind): the fit's
  // value at zero range is about nothing, below what a filter declaring a floor above calibrate's
  // would accept, as the Python examples did.
  const fs::path dir = testing::temp_dir("calibrate_every_filter");
  std::string world = testing::noisy_world(0.0);
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"sigma_range_m: 0.05", "sigma_range_m: 0"}, {"range_bias_m: 0.1", "range_bias_m: 0"}}) {
    ASSERT_NE(world.find(from), std::string::npos) << from;
    world.replace(world.find(from), from.size(), to);
  }
  // Beacons too, which the beacon filters need to start (the robot has no receiver: they only
  // have to take the file).
  world +=
      "beacons:\n  - {id: 1, position: [0.1, 0.1], height_m: 2.5}\n"
      "  - {id: 2, position: [9.9, 0.1], height_m: 2.5}\n"
      "  - {id: 3, position: [9.9, 7.9], height_m: 2.5}\n"
      "  - {id: 4, position: [0.1, 7.9], height_m: 2.5}\n";
  std::ofstream(dir / "world.yaml") << world;
  const auto record =
      testing::locsim("run " + (dir / "world.yaml").string() + " --no-readings -q --out " +
                      (dir / "long").string() + " --log " + (dir / "long.locsimlog").string());
  ASSERT_EQ(record.exit_code, 0) << record.output;
  const auto cal = testing::locsim("calibrate " + (dir / "long.locsimlog").string() + " -q --out " +
                                   (dir / "cal").string());
  ASSERT_EQ(cal.exit_code, 0) << cal.output;
  const YAML::Node yaml = YAML::LoadFile((dir / "cal/calibration.yaml").string());
  EXPECT_LT(yaml["localizer_params"]["sigma_range_m"].as<double>(), 0.01);

  // Every plugin of the build and every Python filter shipped, on a short log of the same world.
  const auto shortlog = testing::locsim(
      "run " + (dir / "world.yaml").string() + " --no-readings -q --duration 3 --out " +
      (dir / "short").string() + " --log " + (dir / "short.locsimlog").string());
  ASSERT_EQ(shortlog.exit_code, 0) << shortlog.output;
  const fs::path built_in = fs::path(LOCSIM_BINARY).parent_path() / "plugins";
  std::string localizers;
  std::vector<std::string> labels;
  for (const fs::path& file : list_plugin_files()) {
    if (file.parent_path() != built_in || file.filename() == "locsim_python.so") continue;
    const std::string name = PluginLibrary(file).table().name;
    localizers += " --localizer " + name;
    labels.push_back(name);
  }
  for (const fs::path& script : list_source_files()) {
    localizers += " --localizer python:" + script.stem().string();
    labels.push_back(script.stem().string());
  }
  ASSERT_GE(labels.size(), 15u) << localizers;
  const auto replay = testing::locsim("replay " + (dir / "short.locsimlog").string() + " --out " +
                                      (dir / "replay").string() + " --params " +
                                      (dir / "cal/calibration.yaml").string() + localizers + " -q");
  ASSERT_EQ(replay.exit_code, 0) << replay.output;
  // Each key is some filter's: nothing to warn about, with or without -q.
  EXPECT_EQ(replay.output, "");
  const auto metrics = nlohmann::json::parse(testing::read_file(dir / "replay/metrics.json"));
  ASSERT_EQ(metrics.at("localizers").size(), labels.size());
  const YAML::Node p = yaml["localizer_params"];
  for (const auto& localizer : metrics.at("localizers")) {
    const std::string label = localizer.at("label");
    EXPECT_EQ(localizer.at("status"), "ok") << label;
    if (label == "landmark_pf" || label == "landmark_ekf") {  // the Python filters take it too
      const auto& params = localizer.at("params");
      EXPECT_DOUBLE_EQ(params.at("sigma_range_m").get<double>(), p["sigma_range_m"].as<double>());
      EXPECT_DOUBLE_EQ(params.at("sigma_range_per_m").get<double>(),
                       p["sigma_range_per_m"].as<double>());
      EXPECT_DOUBLE_EQ(params.at("sigma_bearing_deg").get<double>(),
                       p["sigma_bearing_deg"].as<double>());
      EXPECT_DOUBLE_EQ(params.at("k_left").get<double>(), p["k_left"].as<double>());
      if (label == "landmark_pf") {
        EXPECT_EQ(params.at("motion_model"), p["motion_model"].as<std::string>());
        EXPECT_DOUBLE_EQ(params.at("motion_floor_m").get<double>(),
                         p["motion_floor_m"].as<double>());
        EXPECT_DOUBLE_EQ(params.at("alpha1").get<double>(), p["alpha1"].as<double>());
      }
    }
  }
}

/// A UWB-like ranging system in the noisy world: ranges 5 % long plus 0.2 m, 0.1 m of noise, one
/// beacon per reading in turn, 5 % of the ranges lengthened by an echo (0.5 m + exponential, mean
/// 1.5 m). Calibrate recovers each within 15 %, writes them for a world and for the beacon filters,
/// and ultrasonic_ekf, moving by the wheels of this robot without an IMU, is honest with them.
TEST(Calibrate, RecoversARangingSystemsBiasSpreadPollingAndEchoesWithin15Percent) {
  const fs::path dir = testing::temp_dir("calibrate_ranging");
  std::string world = testing::noisy_world(0.0);
  const std::string encoders = "      encoders: {rate_hz: 50, k_left: 0.01, k_right: 0.02}\n";
  ASSERT_NE(world.find(encoders), std::string::npos);
  world.replace(world.find(encoders), encoders.size(),
                encoders +
                    "      ultrasonic: {rate_hz: 10, receivers: [{position: [0.1, 0], height_m: "
                    "0.4}], sigma_m: 0.1, range_bias_m: 0.2, range_bias_per_m: 0.05, "
                    "beacons_per_reading: 1, dropout_probability: 0, outlier_probability: 0.05, "
                    "nlos_bias_min_m: 0.5, nlos_bias_mean_m: 1.5}\n");
  world +=
      "beacons:\n  - {id: 1, position: [0.1, 0.1], height_m: 2.5}\n"
      "  - {id: 2, position: [9.9, 0.1], height_m: 2.5}\n"
      "  - {id: 3, position: [9.9, 7.9], height_m: 2.5}\n"
      "  - {id: 4, position: [0.1, 7.9], height_m: 1.0}\n";
  std::ofstream(dir / "world.yaml") << world;
  const auto record =
      testing::locsim("run " + (dir / "world.yaml").string() + " --no-readings -q --out " +
                      (dir / "run").string() + " --log " + (dir / "ranging.locsimlog").string());
  ASSERT_EQ(record.exit_code, 0) << record.output;
  const Calibration c = calibrate({dir / "ranging.locsimlog"}, {});
  ASSERT_TRUE(c.ranging);
  const RangingCalibration& r = *c.ranging;
  EXPECT_EQ(r.beacons, 4u);
  EXPECT_NEAR(r.ranges_per_reading, 1.0, 1e-9);
  expect_within(r.bias_m.at_zero, 0.2, "range_bias_m");
  expect_within(r.bias_m.per_unit, 0.05, "range_bias_per_m");
  expect_within(r.spread_m, 0.1, "sigma_m");
  expect_within(r.outlier_share, 0.05, "outlier share");
  EXPECT_EQ(r.short_outliers, 0u);
  ASSERT_TRUE(r.excess_mean_m);
  expect_within(*r.excess_mean_m, 1.5, "nlos_bias_mean_m");
  ASSERT_TRUE(r.noise_correlation_s);
  EXPECT_EQ(*r.noise_correlation_s, 0.0);  // independent, as simulated
  for (const auto& beacon : r.by_beacon) EXPECT_LT(std::abs(beacon.mean_residual_m), 0.03);

  const auto cal = testing::locsim("calibrate " + (dir / "ranging.locsimlog").string() +
                                   " -q --out " + (dir / "cal").string());
  ASSERT_EQ(cal.exit_code, 0) << cal.output;
  const YAML::Node yaml = YAML::LoadFile((dir / "cal/calibration.yaml").string());
  const YAML::Node sensor = yaml["sensors"]["ultrasonic"];
  EXPECT_EQ(sensor["beacons_per_reading"].as<int>(), 1);
  EXPECT_DOUBLE_EQ(sensor["range_bias_per_m"].as<double>(),
                   yaml["localizer_params"]["ultrasonic_ekf"]["range_bias_per_m"].as<double>());
  const auto report = testing::locsim("report " + (dir / "cal").string());
  ASSERT_EQ(report.exit_code, 0) << report.output;
  const std::string report_md = testing::read_file(dir / "cal/report.md");
  testing::expect_contains(report_md, "## Ranges to beacons");
  testing::expect_contains(report_md, "| 4 | ");  // beacon 4's row
  EXPECT_TRUE(fs::exists(dir / "cal/report/ranging_errors.png"));
  // The camera's keys stay the camera's: the beacon filters' are in their sections.
  EXPECT_NE(yaml["localizer_params"]["range_bias_per_m"].as<double>(),
            sensor["range_bias_per_m"].as<double>());

  const auto replay = testing::locsim(
      "replay " + (dir / "ranging.locsimlog").string() + " -q --out " + (dir / "replay").string() +
      " --params " + (dir / "cal/calibration.yaml").string() +
      " --localizer ultrasonic_ekf:gate_chi2=16@calibrated" +
      " --localizer ultrasonic_ekf:range_bias_m=0,range_bias_per_m=0,gate_chi2=16@unbiased");
  ASSERT_EQ(replay.exit_code, 0) << replay.output;
  const auto metrics = nlohmann::json::parse(testing::read_file(dir / "replay/metrics.json"));
  const auto& calibrated = metrics["localizers"][0];
  const auto& unbiased = metrics["localizers"][1];
  ASSERT_EQ(calibrated["status"], "ok");
  EXPECT_LT(calibrated["position_error_m"]["rms"].get<double>(), 0.1);
  EXPECT_GT(calibrated["consistency"]["inside_95_ellipse"].get<double>(), 0.8);
  // Taking the bias for noise: the ranges pull the estimate off by decimetres, and the filter
  // does not know it.
  EXPECT_GT(unbiased["position_error_m"]["rms"].get<double>(),
            2.0 * calibrated["position_error_m"]["rms"].get<double>());
  EXPECT_LT(unbiased["consistency"]["inside_95_ellipse"].get<double>(),
            calibrated["consistency"]["inside_95_ellipse"].get<double>());
}

/// A laser in the office map with every branch of its beam model set apart from the defaults:
/// calibrate recovers each, and the twin of the log scans with them.
TEST(Calibrate, RecoversALasersBeamModelWithin15PercentAndTheTwinTakesIt) {
  const fs::path dir = testing::temp_dir("calibrate_laser");
  const fs::path world = testing::office_world(
      dir,
      "{encoders: {rate_hz: 50}, laser: {rate_hz: 10, fov_deg: 270, beams: 181, max_range_m: 8, "
      "sigma_m: 0.03, p_short: 0.06, lambda_short: 0.7, p_max: 0.03, p_random: 0.04}}",
      60);
  const fs::path log = dir / "laser.locsimlog";
  const auto record =
      testing::locsim("run " + (dir / "world.yaml").string() + " --no-readings -q --out " +
                      (dir / "run").string() + " --log " + log.string());
  ASSERT_EQ(record.exit_code, 0) << record.output;
  const Calibration c = calibrate({log}, {});
  ASSERT_TRUE(c.laser);
  const LaserCalibration& l = *c.laser;
  EXPECT_EQ(l.scans, 601u);
  EXPECT_EQ(l.beams, 601u * 61u);  // every third beam
  EXPECT_GT(l.beams_mapped, l.beams / 2);
  expect_within(l.sigma_m, 0.03, "sigma_m");
  expect_within(l.p_short, 0.06, "p_short");
  expect_within(l.lambda_short, 0.7, "lambda_short");
  expect_within(l.p_max, 0.03, "p_max");
  expect_within(l.p_random, 0.04, "p_random");
  EXPECT_LT(std::abs(l.hit_bias_m), 0.005);

  const auto cal =
      testing::locsim("calibrate " + log.string() + " -q --out " + (dir / "cal").string());
  ASSERT_EQ(cal.exit_code, 0) << cal.output;
  const YAML::Node sensor =
      YAML::LoadFile((dir / "cal/calibration.yaml").string())["sensors"]["laser"];
  EXPECT_NEAR(sensor["sigma_m"].as<double>(), l.sigma_m, 1e-3 * l.sigma_m);
  const auto report = testing::locsim("report " + (dir / "cal").string());
  ASSERT_EQ(report.exit_code, 0) << report.output;
  testing::expect_contains(testing::read_file(dir / "cal/report.md"), "| short (unmapped) | 0.0");
  const auto twin = testing::locsim("twin " + log.string() + " --calibration " +
                                    (dir / "cal/calibration.yaml").string() + " --out " +
                                    (dir / "twin/twin.yaml").string());
  ASSERT_EQ(twin.exit_code, 0) << twin.output;
  const YAML::Node twin_laser =
      YAML::LoadFile((dir / "twin/twin.yaml").string())["robots"][0]["sensors"]["laser"];
  for (const char* key : {"sigma_m", "p_short", "lambda_short", "p_max", "p_random"})
    EXPECT_EQ(twin_laser[key].as<std::string>(), sensor[key].as<std::string>()) << key;
  EXPECT_TRUE(fs::exists(dir / "twin" / "office.pgm"));
}

/// A base whose heading is a gyro's (bias and random walk, not the wheels'): calibrate tells it
/// from the wheels by the heading errors' likelihood, recovers the bias, the noise density and
/// the wheels' k from the distances, and writes them as the world's encoders. (On this loop,
/// turning one way, a gyro's scale error is a wheel-base error by another name: the gyro is told
/// by its drift on the straights, and its scale is recovered in the test below, on a plaza.)
TEST(Calibrate, TellsAGyroHeadingFromTheWheelsAndRecoversItsBiasAndNoiseWithin15Percent) {
  const fs::path dir = testing::temp_dir("calibrate_gyro");
  std::string world = testing::noisy_world(0.0);
  const std::string encoders = "      encoders: {rate_hz: 50, k_left: 0.01, k_right: 0.02}\n";
  ASSERT_NE(world.find(encoders), std::string::npos);
  world.replace(world.find(encoders), encoders.size(),
                // The pose only, as such a base reports: a localizer then turns by the gyro.
                "      encoders: {rate_hz: 50, k_left: 0.01, k_right: 0.01, heading: gyro, "
                "gyro_bias_radps: 0.006, gyro_noise_density: 0.002, reports: [pose]}\n");
  std::ofstream(dir / "world.yaml") << world;
  const auto record =
      testing::locsim("run " + (dir / "world.yaml").string() + " --no-readings -q --out " +
                      (dir / "run").string() + " --log " + (dir / "gyro.locsimlog").string());
  ASSERT_EQ(record.exit_code, 0) << record.output;
  const Calibration c = calibrate({dir / "gyro.locsimlog"}, {});
  ASSERT_TRUE(c.motion && c.motion->heading);
  const MotionCalibration::HeadingFit& h = *c.motion->heading;
  EXPECT_TRUE(h.gyro) << "wheels " << h.wheels_log_likelihood << ", gyro " << h.gyro_log_likelihood;
  expect_within(h.bias_radps, 0.006, "gyro_bias_radps");
  expect_within(h.noise_density, 0.002, "gyro_noise_density");
  expect_within(h.distance_k, 0.01, "k from the distances");
  EXPECT_EQ(h.bias_sigma, 0.0);  // one robot
  const YAML::Node sensor = YAML::Load(c.to_yaml())["sensors"]["encoders"];
  EXPECT_EQ(sensor["heading"].as<std::string>(), "gyro");
  EXPECT_NEAR(sensor["gyro_bias_radps"].as<double>(), h.bias_radps, 1e-3 * h.bias_radps);

  // The twin's odometry drifts as the recording's: the heading's bias decides where it ends.
  write_file(dir / "calibration.yaml", c.to_yaml());
  const auto twin = testing::locsim("twin " + (dir / "gyro.locsimlog").string() +
                                    " --calibration " + (dir / "calibration.yaml").string() +
                                    " --out " + (dir / "twin/twin.yaml").string());
  ASSERT_EQ(twin.exit_code, 0) << twin.output;
  const auto odometry_rms = [&](const std::string& command, const fs::path& out) {
    const auto o = testing::locsim(command + " -q --out " + out.string() + " --localizer odometry");
    EXPECT_EQ(o.exit_code, 0) << o.output;
    return nlohmann::json::parse(
               testing::read_file(out / "metrics.json"))["localizers"][0]["position_error_m"]["rms"]
        .get<double>();
  };
  const double real = odometry_rms("replay " + (dir / "gyro.locsimlog").string(), dir / "real");
  const double simulated =
      odometry_rms("run " + (dir / "twin/twin.yaml").string() + " --no-variation", dir / "sim");
  EXPECT_GT(real, 1.0);
  EXPECT_NEAR(simulated / real, 1.0, 0.1) << "twin " << simulated << " m, recording " << real;
}

/// The beacon EKF on a base whose odometry turns by a biased gyro, 2 % short, (a lawnmower ranging
/// to UWB anchors): calibrate writes the gyro's model into ultrasonic_ekf's section, and the EKF,
/// told nothing of the bias's value (prior mean 0), estimates it from the ranges and keeps its
/// heading; holding the bias at 0 instead, its heading drifts with the gyro and the ranges one at
/// a time cannot hold the position. Over seeds 1-3: estimated 0.12-0.14 m and the bias within
/// 3 %; held 0.6-1.9 m.
TEST(Calibrate, GivesTheBeaconEkfTheGyrosModelAndItEstimatesTheBias) {
  const fs::path dir = testing::temp_dir("calibrate_gyro_beacons");
  std::ofstream(dir / "world.yaml") << testing::range_only_world(
      "{rate_hz: 10, k_left: 0.01, k_right: 0.01, heading: gyro, gyro_bias_radps: 0.01, "
      "gyro_noise_density: 0.002, gyro_scale_error: -0.02, reports: [pose]}",
      120.0);
  const fs::path log = dir / "gyro.locsimlog";
  const auto record = testing::locsim("run " + (dir / "world.yaml").string() +
                                      " --no-readings --no-variation -q --seed 2 --out " +
                                      (dir / "run").string() + " --log " + log.string());
  ASSERT_EQ(record.exit_code, 0) << record.output;
  const Calibration c = calibrate({log}, {});
  ASSERT_TRUE(c.motion && c.motion->heading && c.motion->heading->gyro);
  const YAML::Node section = YAML::Load(c.to_yaml())["localizer_params"]["ultrasonic_ekf"];
  EXPECT_EQ(section["odometry_heading"].as<std::string>(), "gyro");
  expect_within(section["heading_rate_bias_radps"].as<double>(), 0.01, "the bias's prior mean");
  expect_within(section["heading_rate_scale_error"].as<double>(), -0.02, "the gyro's scale");
  EXPECT_GE(section["heading_rate_bias_sigma"].as<double>(),
            section["heading_rate_bias_radps"].as<double>());
  EXPECT_EQ(YAML::Load(c.to_yaml())["localizer_params"]["beacon_mcl"]["odometry_heading"]
                .as<std::string>(),
            "gyro");
  write_file(dir / "calibration.yaml", c.to_yaml());

  const auto replay = testing::locsim(
      "replay " + log.string() + " -q --out " + (dir / "replay").string() + " --params " +
      (dir / "calibration.yaml").string() +
      " --localizer ultrasonic_ekf:heading_rate_bias_radps=0@estimated"
      " --localizer ultrasonic_ekf:heading_rate_bias_radps=0,heading_rate_bias_sigma=0@held");
  ASSERT_EQ(replay.exit_code, 0) << replay.output;
  const auto metrics = nlohmann::json::parse(testing::read_file(dir / "replay/metrics.json"));
  const auto& estimated = metrics["localizers"][0];
  const auto& held = metrics["localizers"][1];
  ASSERT_EQ(estimated["label"], "estimated");
  const double estimated_m = estimated["position_error_m"]["rms"].get<double>();
  const double held_m = held["position_error_m"]["rms"].get<double>();
  EXPECT_LT(estimated_m, 0.25);
  EXPECT_GT(held_m, 2.0 * estimated_m);
  expect_within(estimated["diagnostics"]["heading_rate_bias_radps"].get<double>(), 0.01,
                "the EKF's bias at the end");
  EXPECT_GE(estimated["consistency"]["inside_95_ellipse"].get<double>(), 0.8);
  EXPECT_FALSE(held["diagnostics"].contains("heading_rate_bias_radps"));
}

/// A UWB tag silent for spells (out of its anchors' reach: 30 % of the time, 3 s on average):
/// the spells draw from their own stream (every range the tag gives is the one it gives without
/// them), calibrate measures them from the gaps between readings, and the twin has them.
TEST(Calibrate, MeasuresTheRangesSpellsOfSilenceAndTheTwinHasThem) {
  const fs::path dir = testing::temp_dir("calibrate_outages");
  const std::string encoders = "{rate_hz: 10, k_left: 0.01, k_right: 0.01}";
  std::string silent = testing::range_only_world(encoders, 3600.0);
  const std::string always = silent;
  const std::string key = "dropout_probability: 0}";
  ASSERT_NE(silent.find(key), std::string::npos);
  silent.replace(silent.find(key), key.size(),
                 "dropout_probability: 0, outage_fraction: 0.3, outage_mean_s: 3}");
  std::ofstream(dir / "silent.yaml") << silent;
  std::ofstream(dir / "always.yaml") << always;
  for (const char* name : {"silent", "always"}) {
    const auto run =
        testing::locsim("run " + (dir / (std::string(name) + ".yaml")).string() +
                        " --no-variation -q --seed 3 --out " + (dir / name).string() + " --log " +
                        (dir / (std::string(name) + ".locsimlog")).string());
    ASSERT_EQ(run.exit_code, 0) << run.output;
  }
  const auto lines = [](const fs::path& file) {
    std::vector<std::string> out;
    std::istringstream text(testing::read_file(file));
    for (std::string line; std::getline(text, line);) out.push_back(line);
    return out;
  };
  const std::vector<std::string> some = lines(dir / "silent/readings/ultrasonic.csv");
  const std::vector<std::string> all = lines(dir / "always/readings/ultrasonic.csv");
  const std::set<std::string> given(all.begin(), all.end());
  for (const std::string& line : some) ASSERT_TRUE(given.contains(line)) << line;
  EXPECT_NEAR(static_cast<double>(some.size()) / static_cast<double>(all.size()), 0.7, 0.05);

  const Calibration c = calibrate({dir / "silent.locsimlog"}, {});
  ASSERT_TRUE(c.ranging);
  EXPECT_GT(c.ranging->outages.outages, 200u);
  expect_within(c.ranging->outages.fraction, 0.3, "the share of time silent");
  expect_within(c.ranging->outages.mean_s, 3.0, "a spell's mean length");
  const YAML::Node sensor = YAML::Load(c.to_yaml())["sensors"]["ultrasonic"];
  EXPECT_NEAR(sensor["outage_fraction"].as<double>(), c.ranging->outages.fraction, 1e-3);
  EXPECT_NEAR(sensor["outage_mean_s"].as<double>(), c.ranging->outages.mean_s, 1e-2);
  const Calibration none = calibrate({dir / "always.locsimlog"}, {});
  ASSERT_TRUE(none.ranging);
  EXPECT_EQ(none.ranging->outages.outages, 0u);
  EXPECT_FALSE(YAML::Load(none.to_yaml())["sensors"]["ultrasonic"]["outage_fraction"]);

  // The twin takes the log's own silences over the calibration's: where a robot cannot range
  // its anchors depends on where it drives.
  write_file(dir / "calibration.yaml", c.to_yaml());
  for (const char* name : {"silent", "always"}) {
    const fs::path out = dir / "twin" / name / "twin.yaml";
    const auto twin =
        testing::locsim("twin " + (dir / (std::string(name) + ".locsimlog")).string() + " --out " +
                        out.string() + " --calibration " + (dir / "calibration.yaml").string());
    ASSERT_EQ(twin.exit_code, 0) << twin.output;
    const YAML::Node ultrasonic =
        YAML::LoadFile(out.string())["robots"][0]["sensors"]["ultrasonic"];
    if (std::string(name) == "silent") {
      EXPECT_NEAR(ultrasonic["outage_fraction"].as<double>(), c.ranging->outages.fraction, 1e-6);
      EXPECT_NEAR(ultrasonic["outage_mean_s"].as<double>(), c.ranging->outages.mean_s, 1e-6);
      testing::expect_contains(twin.output, "twin: ultrasonic silent 0.");
    } else {
      EXPECT_EQ(ultrasonic["outage_fraction"].as<double>(), 0.0);
      testing::expect_contains(twin.output, "twin: ultrasonic never silent");
    }
  }
}

// A base whose body slides off its heading (docs/worlds.md, side_slip) drives S-shaped loops on
// a plaza for an hour: calibrate finds the crab, the cornering compliance and the wander from the
// truth alone, within 15 %; a base that does not slide gets none worth the name; the twin gives its
// robot the slide, and the twin's log calibrates back to it.
TEST(Calibrate, FindsHowTheBodySlidesOffItsHeadingAndTheTwinSlidesSo) {
  const fs::path dir = testing::temp_dir("calibrate_side_slip");
  std::string commands;
  for (int i = 0; i < 450; ++i) {
    commands += (i > 0 ? ", " : "") + std::string("{t_s: ") + std::to_string(8 * i) +
                ", v_mps: 0.8, w_radps: 0.5}, {t_s: " + std::to_string(8 * i + 4) +
                ", v_mps: 0.8, w_radps: -0.25}";
  }
  const auto world = [&](const std::string& slip) {
    std::string w = testing::range_only_world("{rate_hz: 10, k_left: 0.01, k_right: 0.01}", 3600.0);
    w = replaced(w, "start: {x: 5, y: 4, theta_deg: 0}",
                 slip + "start: {x: 10, y: 3, theta_deg: 0}");
    return replaced(w,
                    "drive: {mode: waypoints, path: [[15, 4], [15, 11], [5, 11], [5, 4]], loop: "
                    "true, speed_mps: 0.8}",
                    "drive: {mode: velocity, commands: [" + commands + "]}");
  };
  fs::create_directories(dir / "slides");
  fs::create_directories(dir / "holds");
  const fs::path slides =
      record(dir / "slides",
             world("side_slip: {crab_angle_deg: 2, cornering_compliance_s: 0.15, wander_k: 0.05, "
                   "wander_correlation_s: 0.8}\n    "),
             3);
  const Calibration c = calibrate({slides}, {});
  ASSERT_TRUE(c.motion && c.motion->side_slip) << describe(c);
  const SideSlipFit& fit = *c.motion->side_slip;
  expect_within(rad_to_deg(fit.crab_angle_rad), 2.0, "crab angle");
  expect_within(fit.cornering_compliance_s, 0.15, "cornering compliance");
  expect_within(fit.wander_k, 0.05, "wander k");
  expect_within(fit.wander_correlation_s, 0.8, "wander time constant");
  testing::expect_contains(describe(c), "the body off its heading");
  const YAML::Node slip = YAML::Load(c.to_yaml())["robot"]["side_slip"];
  EXPECT_NEAR(slip["crab_angle_deg"].as<double>(), rad_to_deg(fit.crab_angle_rad), 1e-3);
  EXPECT_NEAR(slip["cornering_compliance_s"].as<double>(), fit.cornering_compliance_s, 1e-3);
  EXPECT_NEAR(slip["wander_k"].as<double>(), fit.wander_k, 1e-4);
  EXPECT_NEAR(slip["wander_correlation_s"].as<double>(), fit.wander_correlation_s, 1e-3);
  // The beacon filters are told the drift, which their wheels cannot see.
  for (const std::string_view plugin : kBeaconFilters) {
    EXPECT_NEAR(YAML::Load(c.to_yaml())["localizer_params"][std::string(plugin)]["side_slip_k"]
                    .as<double>(),
                fit.wander_k, 1e-4)
        << plugin;
  }
  EXPECT_EQ(parameter_group("side_slip_k", "beacon_mcl"), "side slip");

  // The command line writes it, and `locsim report` of the calibration says it.
  const auto cli =
      testing::locsim("calibrate " + slides.string() + " --out " + (dir / "cal").string());
  ASSERT_EQ(cli.exit_code, 0) << cli.output;
  testing::expect_contains(cli.output, "the body off its heading");
  const auto report = testing::locsim("report " + (dir / "cal").string());
  ASSERT_EQ(report.exit_code, 0) << report.output;
  testing::expect_contains(testing::read_file(dir / "cal" / "report.md"),
                           "the twin's robots get this side slip");

  const Calibration holds = calibrate({record(dir / "holds", world(""), 3, 600.0)}, {});
  ASSERT_TRUE(holds.motion && holds.motion->side_slip) << describe(holds);
  EXPECT_LT(std::abs(rad_to_deg(holds.motion->side_slip->crab_angle_rad)), 0.05) << describe(holds);
  EXPECT_LT(std::abs(holds.motion->side_slip->cornering_compliance_s), 0.01) << describe(holds);
  EXPECT_LT(holds.motion->side_slip->wander_k, 0.005) << describe(holds);

  // The twin: the calibration's slide on its robot, kept on the recorded path by its drive; its
  // own log calibrates back to the slide (a twin that cannot slide would show none: its heading
  // would follow the path).
  write_file(dir / "calibration.yaml", c.to_yaml());
  const auto twin = testing::locsim("twin " + slides.string() + " --out " +
                                    (dir / "twin" / "twin.yaml").string() + " --calibration " +
                                    (dir / "calibration.yaml").string());
  ASSERT_EQ(twin.exit_code, 0) << twin.output;
  const YAML::Node robot = YAML::LoadFile((dir / "twin" / "twin.yaml").string())["robots"][0];
  EXPECT_NEAR(robot["side_slip"]["wander_k"].as<double>(), fit.wander_k, 1e-4);
  const auto run = testing::locsim("run " + (dir / "twin" / "twin.yaml").string() +
                                   " -q --no-variation --seed 5 --no-readings --out " +
                                   (dir / "twin" / "run").string() + " --log " +
                                   (dir / "twin" / "twin.locsimlog").string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  // run.json says what the robot was given.
  const auto config = nlohmann::json::parse(testing::read_file(dir / "twin" / "run" / "run.json"));
  EXPECT_NEAR(config["config"]["world"]["robots"][0]["side_slip"]["wander_k"].get<double>(),
              fit.wander_k, 1e-4);
  const Calibration again = calibrate({dir / "twin" / "twin.locsimlog"}, {});
  ASSERT_TRUE(again.motion && again.motion->side_slip) << describe(again);
  const SideSlipFit& twinned = *again.motion->side_slip;
  expect_within(rad_to_deg(twinned.crab_angle_rad), 2.0, "the twin's crab angle");
  expect_within(twinned.cornering_compliance_s, 0.15, "the twin's cornering compliance");
  expect_within(twinned.wander_k, 0.05, "the twin's wander k");
}

}  // namespace
}  // namespace locsim
