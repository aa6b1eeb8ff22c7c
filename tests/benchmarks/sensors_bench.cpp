// Sensor costs: each sensor alone on the demo world (real-time factor of the whole step), and the
// static ray caster against Box2D's general ray cast.
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <optional>

#include "sim/producers/simulation.hpp"
#include "sim/scenario/scenario_loader.hpp"
#include "sim/world/world_loader.hpp"

namespace {

namespace fs = std::filesystem;
using namespace locsim;

const fs::path kDemo = fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml";

/// The demo world with only the sensor `kind` on.
void BM_SensorAlone(benchmark::State& state, SensorKind kind) {
  WorldDef world = load_world(kDemo);
  SensorsDef& all = world.robots[0].sensors;
  SensorsDef only;
  switch (kind) {
    case SensorKind::kEncoders:
      only.encoders = all.encoders;
      break;
    case SensorKind::kImu:
      only.imu = all.imu;
      break;
    case SensorKind::kPtzCamera:
      only.ptz_camera = all.ptz_camera;
      break;
    case SensorKind::kOmniCamera:
      only.omni_camera = all.omni_camera;
      break;
    case SensorKind::kUltrasonic:
      only.ultrasonic = all.ultrasonic;
      break;
    case SensorKind::kLaser:
      only.laser = all.laser;
      break;
    case SensorKind::kRangeBearing:
      // The demo robot has none (the MRCLAM twin world will): the defaults, seeing everything.
      only.range_bearing = all.range_bearing.value_or(RangeBearingDef{});
      only.range_bearing->fov_rad = deg_to_rad(360.0);
      only.range_bearing->max_range_m = 20.0;
      only.range_bearing->miss_probability = 0.05;
      only.range_bearing->false_detections = 0.5;
      break;
  }
  all = only;
  ScenarioDef scenario = *world.scenario;
  scenario.duration_s = 1e9;
  scenario.events.clear();
  if (kind != SensorKind::kPtzCamera) scenario.pan_policies.clear();
  bind_scenario(scenario, world);
  Simulation sim(world, scenario, 1);
  std::int64_t steps = 0;
  for (auto _ : state) {
    sim.step();
    benchmark::DoNotOptimize(sim.take_readings());
    ++steps;
  }
  state.counters["real_time_factor"] =
      benchmark::Counter(static_cast<double>(steps) / 200.0, benchmark::Counter::kIsRate);
}
BENCHMARK_CAPTURE(BM_SensorAlone, encoders, SensorKind::kEncoders);
BENCHMARK_CAPTURE(BM_SensorAlone, imu, SensorKind::kImu);
BENCHMARK_CAPTURE(BM_SensorAlone, ptz_camera, SensorKind::kPtzCamera);
BENCHMARK_CAPTURE(BM_SensorAlone, omni_camera, SensorKind::kOmniCamera);
BENCHMARK_CAPTURE(BM_SensorAlone, ultrasonic, SensorKind::kUltrasonic);
BENCHMARK_CAPTURE(BM_SensorAlone, laser, SensorKind::kLaser);
BENCHMARK_CAPTURE(BM_SensorAlone, range_bearing, SensorKind::kRangeBearing);

/// One 360-beam sweep from the middle of a world: the static grid vs Box2D's broad-phase cast.
void BM_RaySweep(benchmark::State& state, const char* world_file, bool box2d) {
  WorldDef world = load_world(fs::path(LOCSIM_SOURCE_DIR) / world_file);
  ScenarioDef scenario;
  bind_scenario(scenario, world);
  const Simulation sim(world, scenario, 1);
  const StaticRaycaster statics = StaticRaycaster::from_world(sim.world());
  const Vec2 origin = world.robots[0].start.position();
  double sum = 0.0;
  std::int64_t rays = 0;
  for (auto _ : state) {
    for (int i = 0; i < 360; ++i) {
      const double angle = deg_to_rad(i);
      const Vec2 direction{std::cos(angle), std::sin(angle)};
      if (box2d) {
        sum += sim.world().ray_cast(origin, origin + 8.0 * direction, nullptr).value_or(8.0);
      } else {
        sum += std::min(statics.cast(origin, direction, 8.0), 8.0);
      }
    }
    rays += 360;
  }
  benchmark::DoNotOptimize(sum);
  state.counters["rays_per_s"] =
      benchmark::Counter(static_cast<double>(rays), benchmark::Counter::kIsRate);
}
BENCHMARK_CAPTURE(BM_RaySweep, demo_grid, "worlds/demo/demo.yaml", false);
BENCHMARK_CAPTURE(BM_RaySweep, demo_box2d, "worlds/demo/demo.yaml", true);
BENCHMARK_CAPTURE(BM_RaySweep, office_map_grid, "worlds/maps/office_world.yaml", false);
BENCHMARK_CAPTURE(BM_RaySweep, office_map_box2d, "worlds/maps/office_world.yaml", true);

/// Lines of sight through a crowd: `bodies` robot-sized boxes scattered over a 30 m room, each
/// query a 3D line from a random point to one of four beacons at the room's corners (what the
/// ultrasonic sensor asks per receiver and beacon), testing every body or through the moving
/// bodies' grid (SceneRays::Indexed, rebuilt once per 100 queries, as the sensors of a 100-robot
/// fleet sample about as many between physics steps). Same answers either way (a test checks).
void BM_CrowdLineOfSight(benchmark::State& state) {
  const auto bodies = static_cast<int>(state.range(0));
  const bool indexed = state.range(1) != 0;
  b2World world(b2Vec2(0.0f, 0.0f));
  RandomStream rng = make_stream(1, "crowd");
  std::vector<DynamicOccluder> occluders;
  for (int i = 0; i < bodies; ++i) {
    b2BodyDef def;
    def.type = b2_dynamicBody;
    def.position.Set(static_cast<float>(rng.uniform(0.5, 29.5)),
                     static_cast<float>(rng.uniform(0.5, 29.5)));
    b2Body* body = world.CreateBody(&def);
    b2PolygonShape box;
    box.SetAsBox(0.2f, 0.15f);
    body->CreateFixture(&box, 1.0f);
    occluders.push_back({body, 0.5, std::hypot(0.2, 0.15)});
  }
  const StaticRaycaster statics(
      {{{0, 0}, {30, 0}}, {{30, 0}, {30, 30}}, {{30, 30}, {0, 30}}, {{0, 30}, {0, 0}}}, {});
  SceneRays rays(statics, occluders);
  const std::array<Vec2, 4> beacons{Vec2{0.1, 0.1}, Vec2{29.9, 0.1}, Vec2{0.1, 29.9},
                                    Vec2{29.9, 29.9}};
  std::int64_t queries = 0, blocked = 0;
  for (auto _ : state) {
    std::optional<SceneRays::Indexed> index;
    if (indexed) index.emplace(rays);
    for (int q = 0; q < 100; ++q) {
      const Vec2 at{rng.uniform(0.5, 29.5), rng.uniform(0.5, 29.5)};
      blocked += rays.blocked(at, 0.3, beacons[q % 4], 2.5, nullptr);
    }
    queries += 100;
  }
  benchmark::DoNotOptimize(blocked);
  state.counters["queries_per_s"] =
      benchmark::Counter(static_cast<double>(queries), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_CrowdLineOfSight)
    ->ArgNames({"bodies", "indexed"})
    ->ArgsProduct({{10, 100, 1000}, {0, 1}});

}  // namespace

// ------------------------------------------------------------------------------------------------
#include "sim/plugin_host/localizer_host.hpp"

namespace {

/// Host overhead per reading delivered to a no-op plugin through the localizer host, as a run
/// feeds it: in locsim's process (translation to the C structs, the call, timing it) or in a
/// worker process (encoding, batching, the socket, decoding and the same in the child; the child
/// runs beside the simulation, so this is the cost per reading the simulation's core sees, with
/// the child keeping up). A true pose every 20 readings asks for an estimate, as a run's 50 Hz
/// ground truth does against about 1000 readings per second. Target: < 1 us.
// `velocity_only`: encoder readings with a velocity and no ticks or pose, which the host
// integrates into odom_pose (real data: MRCLAM).
// `plugin`: the C++ no-op (test_noop) by default; the Python one (tests/python_plugins/py_noop.py,
// plugins/python) measures the embedded interpreter's cost per reading too. Target there: < 5 us.
void BM_StreamToNoopPlugin(benchmark::State& state, SensorKind kind, bool isolate,
                           bool velocity_only = false,
                           const std::string& plugin = LOCSIM_TEST_PLUGIN_DIR
                           "/locsim_test_noop.so") {
  WorldDef world = load_world(kDemo);
  world.robots.resize(1);
  const RobotDef& robot = world.robots[0];
  const OccupancyGrid grid;
  HostOptions options;
  options.isolate = isolate;
  LocalizerHost host({parse_localizer_spec(plugin)}, world, LocalizationDef{}, grid, 1, options);
  Record record;
  record.type = Record::Type::kReading;
  record.robot = 0;
  Reading& reading = record.reading;
  reading.kind = kind;
  if (kind == SensorKind::kLaser) {
    reading.data =
        LaserScan{std::vector<float>(static_cast<std::size_t>(robot.sensors.laser->beams), 3.0f)};
  } else if (kind == SensorKind::kPtzCamera) {
    reading.data =
        PtzReading{0.1, 0.0, 1.0, {{"red", -1, 3.0, 0.2, 1}, {"green", -1, 4.0, -0.3, 2}}};
  } else if (velocity_only) {
    OdometryReading odometry;
    odometry.fields = kOdometryVelocity;
    odometry.v_mps = 0.3;
    odometry.omega_radps = 0.2;
    reading.data = odometry;
  } else {
    reading.data = OdometryReading{100, 120, {1, 2, 0.3}};
  }
  Record truth;
  truth.type = Record::Type::kGroundTruth;
  truth.robot = 0;
  long n = 0;
  for (auto _ : state) {
    reading.t_s += 0.001;
    host.consume(record);
    if (++n % 20 == 0) {
      truth.t_s = reading.t_s;
      host.consume(truth);
    }
  }
  host.finish(reading.t_s);  // every reading taken in by the worker: part of the cost
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK_CAPTURE(BM_StreamToNoopPlugin, in_process_encoders, SensorKind::kEncoders, false);
BENCHMARK_CAPTURE(BM_StreamToNoopPlugin, in_process_velocity_odometry, SensorKind::kEncoders, false,
                  true);
BENCHMARK_CAPTURE(BM_StreamToNoopPlugin, in_process_ptz_camera, SensorKind::kPtzCamera, false);
BENCHMARK_CAPTURE(BM_StreamToNoopPlugin, in_process_laser_271_beams, SensorKind::kLaser, false);
BENCHMARK_CAPTURE(BM_StreamToNoopPlugin, worker_encoders, SensorKind::kEncoders, true)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_StreamToNoopPlugin, worker_ptz_camera, SensorKind::kPtzCamera, true)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_StreamToNoopPlugin, worker_laser_271_beams, SensorKind::kLaser, true)
    ->UseRealTime();
const std::string kPythonNoop =
    "python:" + std::string(LOCSIM_SOURCE_DIR) + "/tests/python_plugins/py_noop.py";
BENCHMARK_CAPTURE(BM_StreamToNoopPlugin, python_in_process_encoders, SensorKind::kEncoders, false,
                  false, kPythonNoop);
BENCHMARK_CAPTURE(BM_StreamToNoopPlugin, python_in_process_ptz_camera, SensorKind::kPtzCamera,
                  false, false, kPythonNoop);
BENCHMARK_CAPTURE(BM_StreamToNoopPlugin, python_in_process_laser_271_beams, SensorKind::kLaser,
                  false, false, kPythonNoop);
BENCHMARK_CAPTURE(BM_StreamToNoopPlugin, python_worker_encoders, SensorKind::kEncoders, true, false,
                  kPythonNoop)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_StreamToNoopPlugin, python_worker_laser_271_beams, SensorKind::kLaser, true,
                  false, kPythonNoop)
    ->UseRealTime();

/// The numpy particle filter (plugins/python/landmark_pf.py) in locsim's process on the demo's map
/// of six landmarks: each iteration one odometry reading (the motion model) and one PTZ frame with
/// two detections (the likelihood over every particle and the landmarks of each detection's
/// colour, then resampling when due). Counter: particle updates per second, one per particle per
/// frame. Target (issue 20): >= 1 M/s at 10 000 particles.
void BM_PythonParticleFilter(benchmark::State& state) {
  WorldDef world = load_world(kDemo);
  world.robots.resize(1);
  const OccupancyGrid grid;
  HostOptions options;
  options.isolate = false;
  const auto particles = state.range(0);
  LocalizerHost host(
      {parse_localizer_spec("python:landmark_pf:particles=" + std::to_string(particles))}, world,
      LocalizationDef{}, grid, 1, options);
  Record odometry, camera;
  odometry.type = camera.type = Record::Type::kReading;
  odometry.reading.kind = SensorKind::kEncoders;
  camera.reading.kind = SensorKind::kPtzCamera;
  camera.reading.data =
      PtzReading{0.1, 0.0, 1.0, {{"red", -1, 3.0, 0.2, 1}, {"green", -1, 4.0, -0.3, 2}}};
  double t_s = 0.0;
  long ticks = 0;
  for (auto _ : state) {
    t_s += 0.1, ticks += 40;
    odometry.reading.t_s = camera.reading.t_s = t_s;
    odometry.reading.data = OdometryReading{ticks, ticks + 4, {1.0 + 0.01 * t_s, 2.0, 0.3}};
    host.consume(odometry);
    host.consume(camera);
  }
  host.finish(t_s);
  state.counters["particle_updates_per_s"] = benchmark::Counter(
      static_cast<double>(state.iterations() * particles), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_PythonParticleFilter)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

}  // namespace
