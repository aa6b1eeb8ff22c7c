// The scorer's share of a run: each record it consumes after a kidnap's landing, where it also
// notes what the sensors show (distinct landmarks and beacons, laser scans) to judge whether the
// kidnap was recoverable. Arguments: a PTZ frame of three detections, an ultrasonic round of two
// receivers by sixteen beacons, a laser scan; a ground-truth record for comparison (nothing to
// note).
#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>
#include <locsim/place_search.hpp>
#include <vector>

#include "sim/metrics/laser_place.hpp"
#include "sim/metrics/scorer.hpp"
#include "sim/world/occupancy.hpp"
#include "sim/world/physics_world.hpp"
#include "sim/world/world_loader.hpp"

namespace {

using namespace locsim;

void BM_ScorerConsume(benchmark::State& state) {
  WorldDef world;
  world.robots.emplace_back().name = "robot";
  for (int id = 1; id <= 8; ++id) world.landmarks.push_back({id, Vec2(id, 0.0)});
  Scorer scorer(world, {{0, "robot", "ekf", "ekf", "", "{}", 0u}}, ConvergenceCriterion{});
  Record event;
  event.type = Record::Type::kEvent;
  event.event = {0, 1.0, "kidnap", "robot", ""};
  scorer.consume(event);
  event.event.kind = "put_down";
  scorer.consume(event);

  Record record;
  record.type = Record::Type::kReading;
  switch (state.range(0)) {
    case 0: {
      PtzReading ptz;
      for (const int id : {2, 5, -1}) {
        Detection d;
        d.truth_id = id;
        ptz.detections.push_back(d);
      }
      record.reading = {2.0, 0, SensorKind::kPtzCamera, ptz};
      break;
    }
    case 1: {
      UltrasonicReading round;
      for (int receiver = 0; receiver < 2; ++receiver) {
        for (int beacon = 1; beacon <= 16; ++beacon) {
          round.ranges.push_back(
              {receiver, beacon, 3.0,
               beacon % 3 == 0 ? RangeStatus::kNonLineOfSight : RangeStatus::kLineOfSight});
        }
      }
      record.reading = {2.0, 0, SensorKind::kUltrasonic, round};
      break;
    }
    case 2:
      record.reading = {2.0, 0, SensorKind::kLaser, LaserScan{std::vector<float>(271, 4.0f)}};
      break;
    default:
      record.type = Record::Type::kGroundTruth;
      record.robot = 0;
      break;
  }
  for (auto _ : state) scorer.consume(record);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ScorerConsume)->Arg(0)->Arg(1)->Arg(2)->Arg(3);

}  // namespace

// The scorer's judgement of whether the laser tells the robot's place apart after a kidnap
// (LaserPlaceJudge), once per kidnap of a filter reading the laser: ten probes a second apart
// (60 end points each, cast in the map from the robot driving straight from the world's start at
// 0.3 m/s) judged against the whole map. Arguments: the suite's room 1, corridor 1, office 1.
void BM_LaserPlaceJudge(benchmark::State& state) {
  const char* worlds[] = {"room_seed1.yaml", "corridor_seed1.yaml", "office_seed1.yaml"};
  const WorldDef world = load_world(std::filesystem::path(LOCSIM_SOURCE_DIR) / "worlds/suite" /
                                    worlds[state.range(0)]);
  const OccupancyGrid grid = rasterize_static_world(PhysicsWorld(world), 0.05);
  const Pose2 start = world.robots.front().start;
  std::vector<LaserProbe> probes;
  for (int k = 0; k < 10; ++k) {
    Pose2 pose = start;
    pose.x += 0.3 * k * std::cos(start.theta);
    pose.y += 0.3 * k * std::sin(start.theta);
    probes.push_back({pose, cast_rays(grid, pose, 60, deg_to_rad(270.0), 8.0)});
  }
  const LaserPlaceJudge judge(grid);
  bool told_apart = false;
  for (auto _ : state) {
    told_apart = judge.judge(probes).told_apart;
    benchmark::DoNotOptimize(told_apart);
  }
  state.counters["told_apart"] = told_apart ? 1.0 : 0.0;
}
BENCHMARK(BM_LaserPlaceJudge)->DenseRange(0, 2)->Unit(benchmark::kMillisecond);

// The SDK's place search (amcl's recovery, the judge's coarse search): the 16 best distinct places
// of the whole map for one scan of 60 end points, each then refined on AMCL's field, as amcl does
// when it searches. Arguments: the suite's room 1, corridor 1, office 1.
void BM_PlaceSearch(benchmark::State& state) {
  const char* worlds[] = {"room_seed1.yaml", "corridor_seed1.yaml", "office_seed1.yaml"};
  const WorldDef world = load_world(std::filesystem::path(LOCSIM_SOURCE_DIR) / "worlds/suite" /
                                    worlds[state.range(0)]);
  const OccupancyGrid grid = rasterize_static_world(PhysicsWorld(world), 0.05);
  const locsim_occupancy_grid view{grid.origin_m.x(), grid.origin_m.y(), grid.resolution_m,
                                   grid.width,        grid.height,       grid.cells.data()};
  const Pose2 start = world.robots.front().start;
  std::vector<double> x, y;
  for (const Vec2& p : cast_rays(grid, start, 60, deg_to_rad(270.0), 8.0))
    x.push_back(p.x()), y.push_back(p.y());
  const sdk::PlaceSearch search(view);
  const sdk::LikelihoodField field(view, sdk::LikelihoodFieldDef{});
  const auto fit = [&](const sdk::Pose& pose) {
    const double c = std::cos(pose(2)), s = std::sin(pose(2));
    double sum = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i)
      sum += field.log_p(pose(0) + c * x[i] - s * y[i], pose(1) + s * x[i] + c * y[i]);
    return sum;
  };
  double best_m = 0.0;
  for (auto _ : state) {
    const std::vector<sdk::ScoredPose> places = search.best(x, y, 16);
    sdk::Pose first = sdk::Pose::Zero();
    for (std::size_t k = 0; k < places.size(); ++k) {
      const sdk::Pose refined =
          sdk::ascend(places[k].pose, fit, search.half_step_m(), search.half_step_rad()).first;
      if (k == 0) first = refined;
    }
    best_m = std::hypot(first(0) - start.x, first(1) - start.y);
    benchmark::DoNotOptimize(best_m);
  }
  state.counters["lattice_positions"] = static_cast<double>(search.positions());
  state.counters["first_place_from_truth_m"] = best_m;
}
BENCHMARK(BM_PlaceSearch)->DenseRange(0, 2)->Unit(benchmark::kMillisecond);
