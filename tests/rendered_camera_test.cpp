// The PTZ camera's own view and its rendered mode: the image has the landmarks' colours where the
// pinhole model puts them, and the colour-segmentation detector finds the landmarks of a known
// scene with the expected distance and bearing, and loses or biases them as a real one does.
#include "render/rendered_camera.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "osmesa_support.hpp"
#include "sim/common/errors.hpp"
#include "sim/producers/simulation.hpp"
#include "sim/run/runner.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;

// A 12 x 8 m hall; the robot at (1, 4) facing +x, its camera 0.1 m ahead at 0.4 m height. Three
// landmarks in view (0.5 m tall, radius 0.1 m), one behind the robot, a pillar that hides half of
// the blue one, and a person far to the side.
const char* kHall = R"(
name: hall
walls:
  - {points: [[0, 0], [12, 0], [12, 8], [0, 8]], closed: true, thickness_m: 0.1}
circles:
  - {center: [4.0, 2.90], radius_m: 0.12}
landmarks:
  - {id: 1, position: [4.0, 4.0], color: red}
  - {id: 2, position: [4.0, 5.2], color: green}
  - {id: 3, position: [7.0, 1.5], color: blue}
  - {id: 4, position: [0.3, 4.0], color: yellow}
movers:
  - {name: walker, kind: person, path: [[9, 7], [10, 7]], moving: false}
robots:
  - name: r
    start: {x: 1.0, y: 4.0, theta_deg: 0}
    footprint: {radius_m: 0.2}
    sensors:
      ptz_camera: {mode: rendered, mount: {x: 0.1, y: 0, theta: 0}}
scenario:
  duration_s: 0.2
  ptz: {policy: fixed, pan_deg: 0}
)";

struct Truth {
  double range_m, bearing_rad;
};

/// Range and bearing from the robot at (1, 4, 0) to a landmark's centre.
Truth truth_of(double x, double y) {
  return {std::hypot(x - 1.0, y - 4.0), std::atan2(y - 4.0, x - 1.0)};
}

using testing::osmesa_imager;

RunInputs hall(const std::string& yaml = kHall) {
  const fs::path dir = testing::temp_dir("hall");
  std::ofstream(dir / "hall.yaml") << yaml;
  return load_run_inputs(dir / "hall.yaml", std::nullopt, std::nullopt);
}

PtzReading first_ptz_reading(Simulation& sim) {
  for (const Reading& r : sim.take_readings()) {
    if (const auto* ptz = std::get_if<PtzReading>(&r.data)) return *ptz;
  }
  ADD_FAILURE() << "no PTZ reading at t = 0";
  return {};
}

const Detection* find_color(const PtzReading& reading, const std::string& color) {
  for (const Detection& d : reading.detections) {
    if (d.color == color) return &d;
  }
  return nullptr;
}

TEST(RenderedCamera, ImageHasTheLandmarkColoursWhereThePinholeModelPutsThem) {
  const RunInputs inputs = hall();
  std::shared_ptr<render::RenderedCamera> camera;
  Simulation sim(inputs.world, inputs.scenario, 1, osmesa_imager(&camera));
  ASSERT_TRUE(camera);
  const cv::Mat image = camera->last_image();
  ASSERT_EQ(image.size(), cv::Size(160, 120));
  cv::imwrite((testing::temp_dir("hall") / "camera.png").string(), image);
  const double f = 0.5 * 160 / std::tan(0.5 * deg_to_rad(65.0));
  // The red landmark dead ahead, 2.9 m from the camera: centre column 80, rows from 0.4 m below
  // to 0.1 m above the optical axis at its near face (2.8 m).
  const auto at = [&](double u, double v) {
    return image.at<cv::Vec3b>(static_cast<int>(v), static_cast<int>(u));
  };
  const double near_m = 2.8;
  const double v_top = 60.0 - f * 0.1 / near_m, v_bottom = 60.0 + f * 0.4 / near_m;
  const cv::Vec3b red = at(80, 0.5 * (v_top + v_bottom));
  EXPECT_GT(red[2], 170) << red;  // BGR; "red" is (230, 25, 25)
  EXPECT_LT(red[1], 40) << red;
  EXPECT_LT(red[0], 40) << red;
  // Just above its top and below its bottom: not red.
  EXPECT_LT(at(80, v_top - 2)[2] - at(80, v_top - 2)[1], 40);
  EXPECT_LT(at(80, v_bottom + 2)[2] - at(80, v_bottom + 2)[1], 40);
  // The green one to the left: column 80 - f tan(bearing from the camera).
  const double green_bearing = std::atan2(1.2, 4.0 - 1.1);
  const cv::Vec3b green = at(80 - f * std::tan(green_bearing), 60 + 2);
  EXPECT_GT(green[1], 120) << green;  // "green" is (20, 170, 40), faces shaded by up to 20 %
  EXPECT_GT(green[1], 2 * std::max(green[0], green[2])) << green;
  // The top row is sky or wall, the bottom row floor: unsaturated.
  for (const cv::Vec3b& p : {at(5, 1), at(155, 118)}) {
    EXPECT_LT(std::max({p[0], p[1], p[2]}) - std::min({p[0], p[1], p[2]}), 30) << p;
  }
}

TEST(RenderedCamera, DetectorFindsTheLandmarksWithTheirDistanceAndBearing) {
  const RunInputs inputs = hall();
  Simulation sim(inputs.world, inputs.scenario, 1, osmesa_imager());
  const PtzReading reading = first_ptz_reading(sim);
  // Red and green in full view; the yellow one is behind the robot.
  EXPECT_EQ(find_color(reading, "yellow"), nullptr);
  const double f = 0.5 * 160 / std::tan(0.5 * deg_to_rad(65.0));
  for (const auto& [color, x, y, id] :
       {std::tuple{"red", 4.0, 4.0, 1}, std::tuple{"green", 4.0, 5.2, 2}}) {
    const Detection* d = find_color(reading, color);
    ASSERT_NE(d, nullptr) << color;
    const Truth truth = truth_of(x, y);
    // Quantisation: a row is r^2 / (f h) of range at distance r (h = 0.5 m); the bearing is the
    // blob's centre column, within a pixel.
    const double row_m = truth.range_m * truth.range_m / (f * 0.5);
    EXPECT_NEAR(d->range_m, truth.range_m, 1.5 * row_m + 0.02) << color;
    EXPECT_NEAR(d->bearing_rad, truth.bearing_rad, 1.0 / f) << color;
    EXPECT_EQ(d->truth_id, id) << color;
  }
}

TEST(RenderedCamera, PartialOcclusionNarrowsTheBlobAndBiasesTheBearingAsOnARealCamera) {
  // The pillar at (4, 2.9) covers the left half of the blue landmark at (7, 1.5): its blob is
  // the visible right half, so the bearing is biased right (more negative) while the range, from
  // the rows, stays (within the one row the rim's curve may take).
  const RunInputs occluded = hall();
  std::string clear_yaml = kHall;
  clear_yaml.replace(clear_yaml.find("[4.0, 2.90]"), 11, "[4.0, 6.90]");
  const RunInputs clear = hall(clear_yaml);
  Simulation with_pillar(occluded.world, occluded.scenario, 1, osmesa_imager());
  Simulation without(clear.world, clear.scenario, 1, osmesa_imager());
  const PtzReading hidden = first_ptz_reading(with_pillar);
  const PtzReading seen = first_ptz_reading(without);
  const Detection* blue_hidden = find_color(hidden, "blue");
  const Detection* blue_seen = find_color(seen, "blue");
  ASSERT_NE(blue_seen, nullptr);
  ASSERT_NE(blue_hidden, nullptr);
  const Truth truth = truth_of(7.0, 1.5);
  EXPECT_NEAR(blue_seen->bearing_rad, truth.bearing_rad, 0.01);
  EXPECT_LT(blue_hidden->bearing_rad, blue_seen->bearing_rad - 0.002);
  const double f = 0.5 * 160 / std::tan(0.5 * deg_to_rad(65.0));
  const double row_m = truth.range_m * truth.range_m / (f * 0.5);
  EXPECT_NEAR(blue_hidden->range_m, blue_seen->range_m, row_m);
}

TEST(RenderedCamera, WithoutTheRendererTheRunStopsWithARenderError) {
  const RunInputs inputs = hall();
  try {
    Simulation sim(inputs.world, inputs.scenario, 1);
    FAIL() << "expected a RenderError";
  } catch (const RenderError& e) {
    EXPECT_NE(std::string(e.what()).find("mode: rendered"), std::string::npos) << e.what();
  }
  std::string bad = kHall;
  bad.replace(bad.find("mode: rendered"), 14, "mode: painted");
  try {
    hall(bad);
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("mode"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("painted"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace locsim
