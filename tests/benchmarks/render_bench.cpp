// Offscreen rendering at 1280 x 720 (issue 7), on the demo world 10 s into a run (walls, people,
// laser, ultrasonic lines, the camera's view) with a filter's particle cloud that moves every
// frame, as in a real run's video. Target: >= 100 frames per second rendered and encoded with
// 10 000 particles, so that a video adds little to a run.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <random>

#include "render/gl_context.hpp"
#include "render/rendered_camera.hpp"
#include "render/top_down.hpp"
#include "render/video_recorder.hpp"
#include "sim/consumers/frame_capture.hpp"
#include "sim/producers/log_source.hpp"
#include "sim/producers/simulation_source.hpp"
#include "sim/run/replay.hpp"
#include "sim/run/runner.hpp"

namespace {

namespace fs = std::filesystem;
using namespace locsim;

/// Collects nothing but a count: FrameCapture needs a sink, the benchmark takes its own snapshot.
class NullSink final : public FrameSink {
 public:
  void start(const WorldDef&) override {}
  void frame(const FrameState&) override { ++frames_; }
  void finish() override {}
  long frames() const override { return frames_; }

 private:
  long frames_ = 0;
};

struct Scene {
  WorldDef world;
  FrameState frame;
};

Scene demo_scene(std::size_t particles) {
  const RunInputs inputs =
      load_run_inputs(fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml", std::nullopt, 10.0);
  Simulation sim(inputs.world, inputs.scenario, 1);
  NullSink sink;
  FrameCapture capture(sink, VideoOptions{}, sim);
  SimulationSource source(sim);
  while (!sim.done()) {
    sim.step();
    source.emit(capture);
    capture.after_step(sim);
  }
  Scene scene{inputs.world, capture.capture(sim)};
  FrameLocalizer cloud;
  cloud.label = "particles";
  cloud.estimate = scene.frame.robots[0].pose;
  cloud.covariance.diagonal() << 0.04, 0.04, 0.01;
  cloud.particles.resize(particles);
  cloud.weights.assign(particles, 1.0);
  scene.frame.localizers.push_back(cloud);
  return scene;
}

/// Moves the cloud: every frame of a run has new particles.
void shake(FrameState& frame, std::mt19937_64& random) {
  std::normal_distribution<double> normal(0.0, 0.3);
  const Pose2 centre = frame.robots[0].pose;
  for (Pose2& p : frame.localizers[0].particles) {
    p = {centre.x + normal(random), centre.y + normal(random), centre.theta + normal(random)};
  }
  for (double& w : frame.localizers[0].weights) w = std::abs(normal(random));
  frame.t_s += 1.0 / 30.0;
}

void BM_RenderFrame(benchmark::State& state) {
  Scene scene = demo_scene(static_cast<std::size_t>(state.range(0)));
  const auto context = render::make_gl_context("osmesa", 1280, 720);
  render::TopDownRenderer renderer(scene.world, 1280, 720);
  std::mt19937_64 random(1);
  cv::Mat bgr;
  for (auto _ : state) {
    state.PauseTiming();
    shake(scene.frame, random);
    state.ResumeTiming();
    renderer.draw(scene.frame);
    renderer.compose(scene.frame, context->finish_frame(), bgr);
    renderer.overlay(scene.frame, bgr);
  }
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderFrame)
    ->ArgName("particles")
    ->Arg(0)
    ->Arg(10000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_RenderAndEncodeFrame(benchmark::State& state) {
  Scene scene = demo_scene(static_cast<std::size_t>(state.range(0)));
  const fs::path file = fs::temp_directory_path() / "locsim_bench_render.mp4";
  VideoOptions options;
  options.video_file = file;
  render::VideoRecorder recorder(options);
  recorder.start(scene.world);
  std::mt19937_64 random(1);
  for (auto _ : state) {
    state.PauseTiming();
    shake(scene.frame, random);
    state.ResumeTiming();
    recorder.frame(scene.frame);
  }
  recorder.finish();  // the encoder's delayed frames count too
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  fs::remove(file);
}
BENCHMARK(BM_RenderAndEncodeFrame)
    ->ArgName("particles")
    ->Arg(10000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

/// The demo run with its video, as the README's first command makes it (three localizers, every
/// output, 1280x720 H.264 at 30 frames per second), 20 s of it: everything a video costs a run,
/// the trails growing, the people walking, the camera's view, the localizers' clouds. Issue 21's
/// target: 200 frames per second on 2 cores.
void BM_DemoRunWithVideo(benchmark::State& state) {
  const fs::path dir = fs::temp_directory_path() / "locsim_bench_demo_video";
  RunOptions run;
  run.world_file = fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml";
  run.duration_s = 20.0;
  run.out_dir = dir / "run";
  run.overwrite = true;
  for (const char* name : {"odometry", "ekf_landmarks", "ultrasonic_amcl"})
    run.localizers.push_back(std::string(LOCSIM_BUILD_PLUGIN_DIR "/locsim_") + name + ".so");
  run.video_options.video_file = dir / "demo.mp4";
  long frames = 0;
  for (auto _ : state) {
    render::VideoRecorder recorder(run.video_options);
    run.video = &recorder;
    run_simulation(run);
    frames += recorder.frames();
  }
  fs::remove_all(dir);
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(frames), benchmark::Counter::kIsRate);
  if (frames != 601 * state.iterations()) state.SkipWithError("not 601 frames a run");
}
BENCHMARK(BM_DemoRunWithVideo)->Unit(benchmark::kMillisecond)->UseRealTime();

/// A replay's frames built from a log's records (`locsim replay --video`): the demo world's 10 s,
/// recorded once, read and captured at 30 frames per second with no localizers, into a sink that
/// keeps nothing. What a replay adds to the renderer's cost above; it should be small beside it.
void BM_ReplayFrameCapture(benchmark::State& state) {
  const fs::path dir = fs::temp_directory_path() / "locsim_bench_replay";
  fs::remove_all(dir);
  fs::create_directories(dir);
  RunOptions run;
  run.world_file = fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml";
  run.duration_s = 10.0;
  run.log_file = dir / "demo.locsimlog";
  run.out_dir = dir / "run";
  run.readings = false;
  run_simulation(run);
  long frames = 0;
  for (auto _ : state) {
    LogSource source(*run.log_file);
    NullSink sink;
    FrameCapture capture(sink, VideoOptions{}, source.world());
    Record record;
    while (source.next(record)) {
      capture.advance(record.type == Record::Type::kReading ? record.reading.t_s
                      : record.type == Record::Type::kEvent ? record.event.t_s
                                                            : record.t_s);
      capture.consume(record);
    }
    capture.end_of_stream();
    frames += sink.frames();
  }
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(frames), benchmark::Counter::kIsRate);
  fs::remove_all(dir);
  if (frames != 301 * state.iterations()) state.SkipWithError("not 301 frames a replay");
}
BENCHMARK(BM_ReplayFrameCapture)->Unit(benchmark::kMillisecond)->UseRealTime();

/// The PTZ camera's rendered mode: one 160 x 120 image of the demo world (walls, six landmarks,
/// two people) rendered and segmented, the camera panning 2 degrees per frame so that what is in
/// view changes. Target: >= 2000 frames per second.
void BM_RenderedCameraFrame(benchmark::State& state) {
  const RunInputs inputs =
      load_run_inputs(fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml", std::nullopt, 1.0);
  PtzCameraDef camera;
  render::RenderedCamera imager(inputs.world, camera, "osmesa");
  std::vector<ScenePrism> people;
  for (const MoverDef& m : inputs.world.movers)
    people.push_back(
        {m.name, m.kind, {m.path_m[0].x(), m.path_m[0].y(), 0.0}, m.footprint, m.height_m});
  CameraShot shot;
  shot.pose = inputs.world.robots[0].start;
  shot.focal_px = 0.5 * camera.width_px / std::tan(0.5 * camera.hfov_rad);
  std::size_t blobs = 0;
  for (auto _ : state) {
    shot.pose.theta += deg_to_rad(2.0);
    blobs += imager.look(shot, people, inputs.world.robots[0].name).size();
  }
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["blobs_per_frame"] =
      static_cast<double>(blobs) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_RenderedCameraFrame)->Unit(benchmark::kMicrosecond)->UseRealTime();

}  // namespace
