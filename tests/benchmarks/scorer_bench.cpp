// The scorer's share of a run: each record it consumes after a kidnap's landing, where it also
// notes what the sensors show (distinct landmarks and beacons, laser scans) to judge whether the
// kidnap was recoverable. Arguments: a PTZ frame of three detections, an ultrasonic round of two
// receivers by sixteen beacons, a laser scan; a ground-truth record for comparison (nothing to
// note).
#include <benchmark/benchmark.h>

#include <vector>

#include "sim/metrics/scorer.hpp"

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
