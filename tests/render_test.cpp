// Offscreen rendering: a known scene has the expected colours at the expected pixels; a video
// decodes with the expected frame count and size; a run with a video keeps every other output
// byte-identical; `locsim run --video` works headless and reports bad video options; a replay
// draws a log's frames as its run did, with the detections' rays, from the stream alone.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>

#include "render/gl_context.hpp"
#include "render/top_down.hpp"
#include "render/video_recorder.hpp"
#include "sim/consumers/frame_capture.hpp"
#include "sim/producers/simulation_source.hpp"
#include "sim/run/replay.hpp"
#include "sim/run/runner.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;

// A 4 x 3 m room: walls around, a red landmark at (1, 1), an icy patch in the top right corner,
// the robot at (3, 1.5) facing +y.
const char* kRoom = R"(
name: room
floor:
  friction: 0.8
  regions:
    - {name: ice, friction: 0.1, polygon: [[2.5, 2.0], [4.0, 2.0], [4.0, 3.0], [2.5, 3.0]]}
walls:
  - {points: [[0, 0], [4, 0], [4, 3], [0, 3]], closed: true, thickness_m: 0.1}
landmarks:
  - {id: 1, position: [1.0, 1.0], color: red, radius_m: 0.15}
robots:
  - name: r
    start: {x: 3.0, y: 1.5, theta_deg: 90}
    footprint: {radius_m: 0.2}
)";

cv::Vec3b pixel_at(const cv::Mat& bgr, const render::View& view, double x, double y) {
  const cv::Point2d p = view.to_pixel(x, y);
  return bgr.at<cv::Vec3b>(static_cast<int>(p.y), static_cast<int>(p.x));
}

void expect_color(const cv::Vec3b& got, const render::Rgb& rgb, int tolerance,
                  const std::string& what) {
  const cv::Vec3b want(static_cast<std::uint8_t>(rgb[2] * 255),
                       static_cast<std::uint8_t>(rgb[1] * 255),
                       static_cast<std::uint8_t>(rgb[0] * 255));
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(got[c], want[c], tolerance)
        << what << " channel " << c << ": got " << got << ", want " << want;
  }
}

FrameState room_frame(const WorldDef& world) {
  FrameState frame;
  frame.t_s = 1.0;
  FrameRobot robot;
  robot.name = "r";
  robot.pose = world.robots[0].start;
  robot.footprint = world.robots[0].footprint;
  frame.robots.push_back(robot);
  FrameLocalizer filter;
  filter.label = "pf";
  filter.estimate = Pose2{2.0, 2.0, 0.0};
  filter.covariance.diagonal() << 0.01, 0.01, 0.01;
  // A tight cloud of 50 particles at (0.6, 2.4), and one of weight 0 alone at (1.6, 0.5).
  for (int i = 0; i < 50; ++i) filter.particles.push_back({0.6, 2.4, 0.0});
  filter.weights.assign(50, 1.0);
  filter.particles.push_back({1.6, 0.5, 0.0});
  filter.weights.push_back(0.0);
  frame.localizers.push_back(filter);
  return frame;
}

TEST(Render, KnownSceneHasTheExpectedColoursAtTheExpectedPixels) {
  const WorldDef world = testing::world_from_yaml(kRoom);
  const auto context = render::make_gl_context("osmesa", 320, 240);
  render::TopDownRenderer renderer(world, 320, 240);
  const FrameState frame = room_frame(world);
  renderer.draw(frame);
  cv::Mat bgr;
  renderer.compose(frame, context->finish_frame(), bgr);
  ASSERT_EQ(bgr.cols, 320);
  ASSERT_EQ(bgr.rows, 240);
  const render::View& view = renderer.view();
  const render::Palette& palette = renderer.palette();
  // Too small for the side panel: the map fills the image, world centred, scale preserved.
  EXPECT_EQ(view.map_width_px, 320);
  EXPECT_NEAR(view.to_pixel(2.0, 1.5).x, 160.0, 1.0);
  EXPECT_NEAR(view.to_pixel(2.0, 1.5).y, 120.0, 1.0);
  const auto& red = world.landmarks[0].color;
  expect_color(pixel_at(bgr, view, 1.0, 1.0), {red[0] / 255.0f, red[1] / 255.0f, red[2] / 255.0f},
               2, "landmark centre");
  expect_color(pixel_at(bgr, view, 0.0, 1.5), palette.wall, 3, "west wall");
  expect_color(pixel_at(bgr, view, 1.5, 2.5), palette.floor, 3, "plain floor");
  expect_color(pixel_at(bgr, view, -0.28, 1.5), palette.floor, 3, "margin outside the walls");
  // The icy patch (friction 0.1) is the slippery end's light blue, 55 % over the floor.
  const render::Rgb floor = palette.floor, ice{0.55f, 0.75f, 0.95f};
  const auto mix = [](const render::Rgb& under, const render::Rgb& over, float alpha) {
    return render::Rgb{under[0] + alpha * (over[0] - under[0]),
                       under[1] + alpha * (over[1] - under[1]),
                       under[2] + alpha * (over[2] - under[2])};
  };
  expect_color(pixel_at(bgr, view, 3.5, 2.6), mix(floor, ice, 0.55f), 3, "icy patch");
  // The robot's footprint is white inside a black outline; the estimate's arrow has the first
  // filter's colour; the particles are that colour, half blended with the floor.
  const cv::Vec3b robot = pixel_at(bgr, view, 3.0 - 0.1, 1.5);
  for (int c = 0; c < 3; ++c) EXPECT_GT(robot[c], 230) << "robot footprint " << robot;
  expect_color(pixel_at(bgr, view, 2.02, 2.0), palette.filter(0), 12, "estimate arrow");
  // Fifty dots on one spot saturate to the colour; a lone one of the lowest weight is faint
  // (opacity 0.2 + 0.7 w / w_max).
  expect_color(pixel_at(bgr, view, 0.6, 2.4), palette.filter(0), 3, "particle cloud");
  expect_color(pixel_at(bgr, view, 1.6, 0.5), mix(floor, palette.filter(0), 0.2f), 3,
               "a particle of the lowest weight");
}

TEST(Render, TrailsGrowFrameByFrameBreakAtKidnapsAndTheOdometrysIsDashed) {
  // The trails are painted piece by piece, as frames come, onto a kept image: the robot drives
  // east along y = 1.3 (its odometry along y = 0.6), is kidnapped, and drives on along y = 2.3.
  const WorldDef world = testing::world_from_yaml(kRoom);
  const auto context = render::make_gl_context("osmesa", 640, 480);
  render::TopDownRenderer renderer(world, 640, 480);
  FrameState frame = room_frame(world);
  frame.localizers[0].particles.clear();
  frame.localizers[0].weights.clear();
  cv::Mat bgr;
  const auto draw = [&](double x, double y, int kidnaps) {
    frame.robots[0].pose = {x, y, 0.0};
    frame.robots[0].odometry = Pose2{x, 0.6, 0.0};
    frame.robots[0].kidnaps = kidnaps;
    frame.localizers[0].estimate = Pose2{x, y + 0.3, 0.0};
    renderer.draw(frame);
    renderer.compose(frame, context->finish_frame(), bgr);
  };
  for (int k = 0; k <= 40; ++k) draw(0.5 + 0.03 * k, 1.3, 0);  // to x = 1.7
  for (int k = 0; k <= 40; ++k) draw(0.5 + 0.03 * k, 2.3, 1);  // after the kidnap
  const render::View& view = renderer.view();
  const render::Palette& palette = renderer.palette();
  // The truth: dark where the robot drove, on both sides of the kidnap, and nothing between
  // where it was picked up (1.7, 1.3) and where it landed (0.5, 2.3).
  for (const double x : {0.8, 1.1, 1.4}) {  // the robot covers 1.5-1.9
    for (const double y : {1.3, 2.3}) {
      const cv::Vec3b p = pixel_at(bgr, view, x, y);
      EXPECT_LT(p[0] + p[1] + p[2], 120) << "truth at " << x << ", " << y << ": " << p;
    }
  }
  expect_color(pixel_at(bgr, view, 1.1, 1.8), palette.floor, 3, "between the kidnap's ends");
  // The estimate's path in the filter's colour, 0.3 m above the truth's.
  expect_color(pixel_at(bgr, view, 1.0, 1.6), palette.filter(0), 40, "estimate's path");
  // The odometry, dashed (8 pixels on, 8 off, continued across the frames' 2-pixel pieces):
  // every 16 pixels along its path hold a dash (grey, 140) and a gap (floor, 225-230).
  const cv::Point2d from = view.to_pixel(0.6, 0.6), to = view.to_pixel(1.6, 0.6);
  const int row = static_cast<int>(from.y);
  for (int x = static_cast<int>(from.x); x + 16 <= static_cast<int>(to.x); ++x) {
    int darkest = 255, lightest = 0;
    for (int i = x; i < x + 16; ++i) {
      darkest = std::min<int>(darkest, bgr.at<cv::Vec3b>(row, i)[0]);
      lightest = std::max<int>(lightest, bgr.at<cv::Vec3b>(row, i)[0]);
    }
    EXPECT_LT(darkest, 160) << "no dash in the 16 pixels from " << x;
    EXPECT_GT(lightest, 200) << "no gap in the 16 pixels from " << x;
  }
}

TEST(Render, VideoDecodesWithTheExpectedFrameCountAndSize) {
  const WorldDef world = testing::world_from_yaml(kRoom);
  for (const std::string name : {"room.mp4", "room.avi"}) {
    SCOPED_TRACE(name);
    const fs::path file = testing::temp_dir("video") / name;
    VideoOptions options;
    options.video_file = file;
    options.width_px = 320;
    options.height_px = 240;
    render::VideoRecorder recorder(options);
    recorder.start(world);
    FrameState frame = room_frame(world);
    cv::Mat first;
    for (int k = 0; k < 48; ++k) {
      frame.t_s = k / 30.0;
      frame.robots[0].pose.x = 1.5 + 0.04 * k;  // the robot drives east
      recorder.frame(frame);
      if (k == 0) first = recorder.last_frame().clone();
    }
    recorder.finish();
    EXPECT_EQ(recorder.codec(), name.ends_with(".mp4") ? "H.264" : "MPEG-4");
    EXPECT_EQ(recorder.frames(), 48);

    cv::VideoCapture video(file.string(), cv::CAP_FFMPEG);
    ASSERT_TRUE(video.isOpened());
    EXPECT_EQ(video.get(cv::CAP_PROP_FRAME_WIDTH), 320);
    EXPECT_EQ(video.get(cv::CAP_PROP_FRAME_HEIGHT), 240);
    EXPECT_NEAR(video.get(cv::CAP_PROP_FPS), 30.0, 1e-6);
    int decoded = 0;
    cv::Mat image, decoded_first;
    while (video.read(image)) {
      if (decoded == 0) decoded_first = image.clone();
      ++decoded;
    }
    EXPECT_EQ(decoded, 48);
    // Lossy, but the same picture: mean absolute difference of a few grey levels.
    ASSERT_FALSE(decoded_first.empty());
    EXPECT_LT(cv::norm(decoded_first, first, cv::NORM_L1) / static_cast<double>(first.total() * 3),
              4.0);
  }
}

TEST(Render, RunWithAVideoKeepsEveryOtherOutputAndLocksFramesToSimulatedTime) {
  const fs::path dir = testing::temp_dir("run");
  RunOptions options;
  options.world_file = fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml";
  options.duration_s = 3.0;
  options.seed = 4;
  options.localizers = {"odometry", "ekf_landmarks", "asrl:particles=300"};
  options.out_dir = dir / "plain";
  run_simulation(options);

  VideoOptions video;
  video.video_file = dir / "with_video/run.mp4";
  video.frames_dir = dir / "frames";
  video.width_px = 640;
  video.height_px = 360;
  video.fps = 20.0;
  video.speed = 2.0;  // 2 simulated seconds per video second: a frame every 0.1 s
  render::VideoRecorder recorder(video);
  options.out_dir = dir / "with_video";
  options.video = &recorder;
  options.video_options = video;
  run_simulation(options);

  // Frames at 0, 0.1, ..., 3.0 s: 31, none dropped or doubled whatever the machine's speed.
  EXPECT_EQ(recorder.frames(), 31);
  std::size_t pngs = 0;
  for (const auto& entry : fs::directory_iterator(dir / "frames")) pngs += entry.is_regular_file();
  EXPECT_EQ(pngs, 31u);
  EXPECT_EQ(cv::imread((dir / "frames/frame_000030.png").string()).size(), cv::Size(640, 360));
  // Rendering only looks: the trajectories and readings are byte-identical, and so are the
  // metrics but for the wall-clock cost of each update.
  for (const char* file : {"groundtruth.tum", "asrl.tum", "ekf_landmarks.tum", "events.csv",
                           "readings/ptz_camera.csv"}) {
    EXPECT_EQ(testing::read_file(dir / "plain" / file),
              testing::read_file(dir / "with_video" / file))
        << file;
  }
  const auto without_costs = [](const fs::path& file) {
    nlohmann::json metrics = nlohmann::json::parse(testing::read_file(file));
    metrics.erase("timing");  // wall-clock costs, kept apart for this reason
    return metrics.dump();
  };
  EXPECT_EQ(without_costs(dir / "plain/metrics.json"),
            without_costs(dir / "with_video/metrics.json"));
}

// A robot driving north, carried for 1 s at 1 s, teleported at 2.5 s.
const char* kTwoKidnaps = R"(
scenario:
  duration_s: 3
  drive: {mode: waypoints, path: [[3.0, 2.5]], speed_mps: 0.3}
  events:
    - at_s: 1
      kidnap: {to: {x: 1.0, y: 2.0, theta_deg: 0}, carry_s: 1.0}
    - at_s: 2.5
      kidnap: {to: {x: 2.0, y: 1.0, theta_deg: 180}}
)";

TEST(Render, BothKindsOfKidnapAreMarkedWhereTheyHappen) {
  // One carry (1 s in the air) and one instant teleport, which the robot is never seen carried in:
  // both are marked from where the robot was picked up to where it landed, and the true path
  // breaks at each.
  const fs::path dir = testing::temp_dir("kidnap_marks");
  std::ofstream(dir / "world.yaml") << kRoom << kTwoKidnaps;
  const RunInputs inputs = load_run_inputs(dir / "world.yaml", std::nullopt, std::nullopt);
  Simulation sim(inputs.world, inputs.scenario, 1);
  testing::KeepFrames sink;
  VideoOptions video;
  video.fps = 10.0;
  FrameCapture capture(sink, video, sim);
  SimulationSource source(sim);
  std::vector<Pose2> floor;  // the true pose just before each kidnap
  Pose2 last = sim.robot(0).pose();
  int kidnaps = 0;
  while (!sim.done()) {
    sim.step();
    if (sim.stats(0).kidnaps != kidnaps) floor.push_back(last), kidnaps = sim.stats(0).kidnaps;
    if (!sim.robot(0).carried()) last = sim.robot(0).pose();
    source.emit(capture);
    capture.after_step(sim);
  }
  ASSERT_EQ(floor.size(), 2u);
  ASSERT_EQ(sink.kept.size(), 31u);
  const FrameState& middle = sink.kept[15];  // t = 1.5 s: in the air
  ASSERT_EQ(middle.kidnaps.size(), 1u);
  EXPECT_FALSE(middle.kidnaps[0].landed);
  EXPECT_TRUE(middle.robots[0].carried);
  const FrameState& end = sink.kept.back();
  ASSERT_EQ(end.kidnaps.size(), 2u);
  for (int k = 0; k < 2; ++k) {
    const KidnapMark& mark = end.kidnaps[static_cast<std::size_t>(k)];
    EXPECT_TRUE(mark.landed) << k;
    EXPECT_NEAR(mark.from.x, floor[static_cast<std::size_t>(k)].x, 1e-9) << k;
    EXPECT_NEAR(mark.from.y, floor[static_cast<std::size_t>(k)].y, 1e-9) << k;
  }
  EXPECT_NEAR(end.kidnaps[0].t_s, 1.0, 1e-9);
  EXPECT_NEAR(end.kidnaps[0].to.x, 1.0, 0.05);
  EXPECT_NEAR(end.kidnaps[1].t_s, 2.5, 1e-9);
  EXPECT_NEAR(end.kidnaps[1].to.x, 2.0, 0.05);
  EXPECT_NEAR(end.kidnaps[1].to.y, 1.0, 0.05);
  EXPECT_EQ(end.robots[0].kidnaps, 2);
}

TEST(Render, RangeBearingAndOmniDetectionsAreCapturedWithRobotsTold) {
  const fs::path dir = testing::temp_dir("sightings");
  std::ofstream(dir / "world.yaml") << R"(
walls:
  - {points: [[0, 0], [4, 0], [4, 3], [0, 3]], closed: true, thickness_m: 0.1}
landmarks:
  - {id: 1, position: [2.0, 2.5]}
robots:
  - name: r
    start: {x: 1, y: 1.5, theta: 0}
    sensors:
      range_bearing: {fov_deg: 360, sees_robots: true, sigma_range_m: 0, sigma_bearing: 0}
  - name: s
    start: {x: 3, y: 1.5, theta: 0}
    sensors:
      omni_camera: {sigma_major_m: 0, sigma_minor_m: 0}
scenario: {duration_s: 0.5}
)";
  const RunInputs inputs = load_run_inputs(dir / "world.yaml", std::nullopt, std::nullopt);
  Simulation sim(inputs.world, inputs.scenario, 1);
  testing::KeepFrames sink;
  VideoOptions video;
  video.fps = 10.0;
  FrameCapture capture(sink, video, sim);
  SimulationSource source(sim);
  while (!sim.done()) {
    sim.step();
    source.emit(capture);
    capture.after_step(sim);
  }
  ASSERT_FALSE(sink.kept.empty());
  const FrameState& last = sink.kept.back();
  EXPECT_TRUE(last.robots[0].range_bearing);
  // The omnidirectional camera's detections are drawn alike (it sees landmarks only).
  EXPECT_TRUE(last.robots[1].range_bearing);
  ASSERT_EQ(last.robots[1].sightings.size(), 1u);
  EXPECT_FALSE(last.robots[1].sightings[0].robot);
  EXPECT_NEAR(last.robots[1].sightings[0].at_m.x(), 2.0, 1e-3);
  EXPECT_NEAR(last.robots[1].sightings[0].at_m.y(), 2.5, 1e-3);
  ASSERT_EQ(last.robots[0].sightings.size(), 2u);
  const FrameRobot::Sighting& landmark = last.robots[0].sightings[0];
  const FrameRobot::Sighting& robot = last.robots[0].sightings[1];
  EXPECT_FALSE(landmark.robot);
  EXPECT_NEAR(landmark.at_m.x(), 2.0, 1e-3);
  EXPECT_NEAR(landmark.at_m.y(), 2.5, 1e-3);
  EXPECT_TRUE(robot.robot);
  EXPECT_NEAR(robot.at_m.x(), 3.0, 1e-3);
  EXPECT_NEAR(robot.at_m.y(), 1.5, 1e-3);
}

// The room, its robot driving where the test says, seeing the landmark with a noiseless
// range-bearing sensor; no people (a log has none).
const std::string kRangedRoom = std::string(kRoom) + R"(    sensors:
      encoders: {}
      range_bearing: {rate_hz: 10, fov_deg: 360, sigma_range_m: 0, sigma_bearing: 0}
)";
TEST(Render, ReplayDrawsTheRunsFramesFromItsLogWithDetectionRays) {
  const fs::path dir = testing::temp_dir("replay");
  std::ofstream(dir / "world.yaml") << kRangedRoom << R"(
scenario:
  duration_s: 2
  drive: {mode: waypoints, path: [[3.0, 2.0]], speed_mps: 0.5}
)";
  VideoOptions video;
  video.width_px = 320;
  video.height_px = 240;
  video.fps = 10.0;  // a frame every 0.1 s, on the ground truth's 50 Hz
  const auto frames_into = [&](const std::string& name) {
    VideoOptions options = video;
    options.frames_dir = dir / name;
    return options;
  };
  RunOptions run;
  run.world_file = dir / "world.yaml";
  run.localizers = {"odometry", "ekf_landmarks"};
  run.log_file = dir / "run.locsimlog";
  run.out_dir = dir / "run";
  run.video_options = frames_into("run_frames");
  render::VideoRecorder run_recorder(run.video_options);
  run.video = &run_recorder;
  run_simulation(run);
  ASSERT_EQ(run_recorder.frames(), 21);

  for (const std::string name : {"replay_frames", "replay_frames_again"}) {
    ReplayOptions replay;
    replay.log_file = *run.log_file;
    replay.localizers = run.localizers;
    replay.out_dir = dir / ("replay_of_" + name);
    replay.video_options = frames_into(name);
    render::VideoRecorder recorder(replay.video_options);
    replay.video = &recorder;
    EXPECT_EQ(replay_log(replay).status, "completed");
    EXPECT_EQ(recorder.frames(), 21) << name;
  }
  // Frame k of the replay holds the same records as the run's (truth from the log's ground
  // truth, the same readings, the localizers at the same point of the stream): with no people
  // to leave out, the pictures are the same, byte for byte, and so are two replays'.
  for (int k = 0; k <= 20; ++k) {
    char name[32];
    std::snprintf(name, sizeof(name), "frame_%06d.png", k);
    const std::string run_frame = testing::read_file(dir / "run_frames" / name);
    ASSERT_FALSE(run_frame.empty()) << name;
    EXPECT_EQ(testing::read_file(dir / "replay_frames" / name), run_frame) << name;
    EXPECT_EQ(testing::read_file(dir / "replay_frames_again" / name), run_frame) << name;
  }
  // The last frame: the ray from the robot, where it stopped (the last ground truth), to the
  // landmark it detects at (1, 1) is drawn in the range-bearing colour halfway along, where
  // nothing else is.
  std::istringstream truth(testing::read_file(dir / "replay_of_replay_frames/groundtruth.tum"));
  std::string line, last_line;
  while (std::getline(truth, line)) {
    if (!line.empty() && line[0] != '#') last_line = line;
  }
  double t_s = 0.0, x = 0.0, y = 0.0;
  ASSERT_EQ(std::sscanf(last_line.c_str(), "%lf %lf %lf", &t_s, &x, &y), 3) << last_line;
  EXPECT_NEAR(t_s, 2.0, 1e-9);
  const WorldDef world = testing::world_from_yaml(kRangedRoom);
  const auto context = render::make_gl_context("osmesa", 320, 240);
  const render::TopDownRenderer renderer(world, 320, 240);
  const cv::Mat last = cv::imread((dir / "replay_frames/frame_000020.png").string());
  ASSERT_EQ(last.size(), cv::Size(320, 240));
  const render::Palette& palette = renderer.palette();
  const auto mix = [](const render::Rgb& under, const render::Rgb& over, float alpha) {
    return render::Rgb{under[0] + alpha * (over[0] - under[0]),
                       under[1] + alpha * (over[1] - under[1]),
                       under[2] + alpha * (over[2] - under[2])};
  };
  const render::Rgb ray = mix(palette.floor, palette.sighting, 0.9f);
  const auto distance_to_ray = [&](const cv::Vec3b& got) {
    int worst = 0;
    for (int c = 0; c < 3; ++c) {
      worst = std::max(worst, std::abs(got[c] - static_cast<int>(ray[2 - c] * 255)));
    }
    return worst;
  };
  // The line is 1.5 px wide: the best of the pixel and its neighbours is on it.
  const cv::Point2d on_ray = renderer.view().to_pixel(0.5 * (x + 1.0), 0.5 * (y + 1.0));
  int best = 255;
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      best = std::min(best, distance_to_ray(last.at<cv::Vec3b>(static_cast<int>(on_ray.y) + dy,
                                                               static_cast<int>(on_ray.x) + dx)));
    }
  }
  EXPECT_LE(best, 12) << "no detection ray at " << on_ray;
  // Away from the ray, the floor.
  expect_color(pixel_at(last, renderer.view(), 2.0, 0.5), palette.floor, 3, "floor off the ray");
}

TEST(Render, ReplayTakesTruthAndKidnapsFromTheStream) {
  // A carry and an instant kidnap, replayed: the robot's pose at each frame is the run's (frames
  // fall on ground-truth times), a kidnap is marked from where the robot was picked up to where
  // the ground truth next finds it, and the true path breaks at each.
  const fs::path dir = testing::temp_dir("replay_kidnap");
  std::ofstream(dir / "world.yaml") << kRangedRoom << kTwoKidnaps;
  VideoOptions video;
  video.fps = 10.0;
  testing::KeepFrames run_frames, replay_frames;
  RunOptions run;
  run.world_file = dir / "world.yaml";
  run.log_file = dir / "run.locsimlog";
  run.out_dir = dir / "run";
  run.video = &run_frames;
  run.video_options = video;
  run_simulation(run);
  ReplayOptions replay;
  replay.log_file = *run.log_file;
  replay.out_dir = dir / "replay";
  replay.video = &replay_frames;
  replay.video_options = video;
  replay_log(replay);
  ASSERT_EQ(run_frames.kept.size(), 31u);
  ASSERT_EQ(replay_frames.kept.size(), 31u);
  for (std::size_t k = 0; k < 31; ++k) {
    const FrameRobot& want = run_frames.kept[k].robots[0];
    const FrameRobot& got = replay_frames.kept[k].robots[0];
    EXPECT_NEAR(replay_frames.kept[k].t_s, run_frames.kept[k].t_s, 1e-12) << k;
    EXPECT_EQ(got.carried, want.carried) << k;
    if (!want.carried) {
      EXPECT_NEAR(got.pose.x, want.pose.x, 1e-9) << k;
      EXPECT_NEAR(got.pose.y, want.pose.y, 1e-9) << k;
      EXPECT_NEAR(got.pose.theta, want.pose.theta, 1e-9) << k;
    }
    EXPECT_EQ(got.kidnaps, want.kidnaps) << k;
    ASSERT_TRUE(got.odometry.has_value()) << k;
    EXPECT_NEAR(got.odometry->x, want.odometry->x, 1e-9) << k;
    EXPECT_EQ(got.sightings.size(), want.sightings.size()) << k;
  }
  const std::vector<KidnapMark>& want = run_frames.kept.back().kidnaps;
  const std::vector<KidnapMark>& got = replay_frames.kept.back().kidnaps;
  ASSERT_EQ(got.size(), 2u);
  ASSERT_EQ(want.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_TRUE(got[k].landed) << k;
    EXPECT_NEAR(got[k].t_s, want[k].t_s, 1e-9) << k;
    EXPECT_NEAR(got[k].from.x, want[k].from.x, 0.02) << k;  // ground truth is at 50 Hz
    EXPECT_NEAR(got[k].from.y, want[k].from.y, 0.02) << k;
    EXPECT_NEAR(got[k].to.x, want[k].to.x, 1e-6) << k;
    EXPECT_NEAR(got[k].to.y, want[k].to.y, 1e-6) << k;
  }
}

TEST(Render, AReplayDrawsADetectionUntilTheSensorsNextReadingIsDue) {
  // A dataset's range-bearing readings come only when something was seen: one is drawn for a
  // period of the sensor's rate (10 Hz here), not until the next sighting, seconds later. The
  // robot's pose is the stream's latest ground truth.
  const WorldDef world = testing::world_from_yaml(kRangedRoom);
  testing::KeepFrames sink;
  VideoOptions video;
  video.fps = 20.0;  // a frame every 0.05 s
  FrameCapture capture(sink, video, world);
  const auto feed = [&](const Record& record, double t_s) {
    capture.advance(t_s);
    capture.consume(record);
  };
  Record seen;
  seen.type = Record::Type::kReading;
  seen.reading.robot = 0;
  seen.reading.kind = SensorKind::kRangeBearing;
  Detection landmark;
  landmark.range_m = 2.0;
  seen.reading.data = RangeBearingReading{{landmark}};
  feed(seen, 0.0);
  for (int k = 0; k <= 6; ++k) {
    Record truth;
    truth.type = Record::Type::kGroundTruth;
    truth.t_s = 0.05 * k;
    truth.pose = {3.0, 1.5 + 0.01 * k, 0.5 * std::numbers::pi};
    truth.robot = 0;
    feed(truth, truth.t_s);
  }
  capture.end_of_stream();
  ASSERT_EQ(sink.kept.size(), 7u);
  for (std::size_t k = 0; k < 7; ++k) {
    EXPECT_EQ(sink.kept[k].robots[0].sightings.size(), k <= 2 ? 1u : 0u) << k;
    EXPECT_NEAR(sink.kept[k].robots[0].pose.y, 1.5 + 0.01 * static_cast<double>(k), 1e-12) << k;
  }
  EXPECT_FALSE(sink.kept[0].robots[0].odometry.has_value());  // no odometry reading yet
}

TEST(Render, TheMainJobsVideoShowsThePtzCamerasViewBesideThreeFilters) {
  // The demo with the main job's three localizers: the side panel's legend is long, and the
  // camera view goes under the filters' errors (the key to the symbols gives way to it).
  const fs::path dir = testing::temp_dir("camera_inset");
  const std::string common = "run " + testing::kDemo +
                             " --duration 2 -q --no-readings --video-fps 5 --localizer odometry "
                             "--localizer ekf_landmarks --localizer ultrasonic_amcl";
  const auto with = testing::locsim(common + " --out " + (dir / "a").string() + " --frames " +
                                    (dir / "with").string());
  ASSERT_EQ(with.exit_code, 0) << with.output;
  const auto without = testing::locsim(common + " --no-camera-view --out " + (dir / "b").string() +
                                       " --frames " + (dir / "without").string());
  ASSERT_EQ(without.exit_code, 0) << without.output;
  const auto last_png = [](const fs::path& folder) {
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(folder)) files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    return cv::imread(files.back().string());
  };
  const cv::Mat a = last_png(dir / "with"), b = last_png(dir / "without");
  ASSERT_FALSE(a.empty());
  ASSERT_EQ(a.size(), b.size());
  // The pixels that differ: the camera view (at least 150 x 100 of them, the picture being
  // mostly floor, walls and landmarks, never one flat colour) and the symbols' key it moved,
  // all in the side panel right of the map.
  cv::Mat gray_a, gray_b, changed;
  cv::cvtColor(a, gray_a, cv::COLOR_BGR2GRAY);
  cv::cvtColor(b, gray_b, cv::COLOR_BGR2GRAY);
  cv::compare(gray_a, gray_b, changed, cv::CMP_NE);
  EXPECT_GT(cv::countNonZero(changed), 150 * 100);
  const cv::Rect box = cv::boundingRect(changed);
  EXPECT_GT(box.x, a.cols - 300) << "the view is in the 300-px side panel";
  EXPECT_GE(box.width, 150);
  EXPECT_GE(box.height, 100);
  EXPECT_LE(box.y + box.height, a.rows);
}

TEST(Render, BadBackendAndSizeAreReportedClearly) {
  EXPECT_THROW(render::make_gl_context("egl", 64, 64), RenderError);
  EXPECT_THROW(render::make_gl_context("osmesa", 8, 64), RenderError);
  VideoOptions odd;
  odd.video_file = "x.mp4";
  odd.width_px = 641;
  EXPECT_THROW(render::VideoRecorder{odd}, RenderError);
  VideoOptions text;
  text.video_file = testing::temp_dir("bad") / "run.txt";
  render::VideoRecorder recorder(text);
  try {
    recorder.start(testing::world_from_yaml(kRoom));
    FAIL() << "a .txt video was accepted";
  } catch (const RenderError& e) {
    EXPECT_NE(std::string(e.what()).find("run.txt"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace locsim
