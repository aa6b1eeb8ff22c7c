// World variation per seed (sim/world/variation.hpp): what each seed draws, that the same seed
// draws the same, that draws stay free of obstacles and inside their tolerances, that the
// encoders keep the declared geometry, and that a replay rebuilds the recorded world.
#include "sim/world/variation.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "sim/run/replay.hpp"
#include "sim/run/runner.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;

// A room with a pillar right next to the robot's start, two people and a floor region.
constexpr const char* kRoom = R"(
name: room
floor:
  friction: 0.8
  regions:
    - {name: rug, friction: 0.5, box: {min: [1, 1], max: [2, 2]}}
walls:
  - points: [[0, 0], [6, 0], [6, 4], [0, 4]]
    closed: true
circles:
  - {center: [1.0, 2.52], radius_m: 0.3}
movers:
  - {name: alice, path: [[4, 1], [5, 1], [5, 3], [4, 3]], speed_mps: 1.0}
  - {name: bob, path: [[1, 3.5], [3, 3.5]], speed_mps: 0.5, loop: false}
robots:
  - name: r
    footprint: {radius_m: 0.2}
    start: {x: 1.0, y: 2.0, theta: 0.0}
    sensors:
      encoders: {}
scenario:
  duration_s: 3
  drive: {mode: waypoints, path: [[3, 2], [3, 1.0], [1, 1]], speed_mps: 0.3}
)";

RunInputs room(const std::string& extra = "") {
  const fs::path dir = testing::temp_dir("room");
  std::ofstream(dir / "room.yaml") << kRoom << extra;
  return load_run_inputs(dir / "room.yaml", std::nullopt, std::nullopt);
}

TEST(Variation, SameSeedSameWorldOtherSeedOtherWorld) {
  const RunInputs inputs = room();
  const auto a = to_json(draw_variation(inputs.world, inputs.scenario, 1));
  EXPECT_EQ(a, to_json(draw_variation(inputs.world, inputs.scenario, 1)));
  const auto b = to_json(draw_variation(inputs.world, inputs.scenario, 2));
  EXPECT_NE(a["robots"][0]["wheel_radius_left_m"], b["robots"][0]["wheel_radius_left_m"]);
  EXPECT_NE(a["robots"][0]["start"], b["robots"][0]["start"]);
  EXPECT_NE(a["movers"][0]["phase_m"], b["movers"][0]["phase_m"]);
  EXPECT_NE(a["floor_friction"], b["floor_friction"]);
  EXPECT_NE(a["drives"][0]["path"], b["drives"][0]["path"]);
}

TEST(Variation, DrawsStayWithinTheirTolerancesAndFreeSpace) {
  const RunInputs inputs = room();
  const RobotDef& declared = inputs.world.robots[0];
  b2CircleShape circle;
  b2PolygonShape polygon;
  const b2Shape& shape = make_shape(declared.footprint, circle, polygon);
  const PhysicsWorld physics(inputs.world);
  int moved_start = 0, left_radius_above = 0;
  for (std::uint64_t seed = 1; seed <= 200; ++seed) {
    const DrawnVariation d = draw_variation(inputs.world, inputs.scenario, seed);
    const DrawnVariation::Robot& r = d.robots[0];
    // Cut at 3 sigma of the defaults (0.1 % radius, 0.5 % base, 5 % motor, 10 % friction).
    EXPECT_LE(std::abs(r.wheel_radius_left_m / declared.wheel_radius_left_m - 1.0), 0.003 + 1e-12);
    EXPECT_LE(std::abs(r.wheel_base_m / declared.wheel_base_m - 1.0), 0.015 + 1e-12);
    EXPECT_LE(std::abs(r.max_wheel_torque_nm / declared.max_wheel_torque_nm - 1.0), 0.15 + 1e-12);
    EXPECT_LE(std::abs(d.floor_friction / 0.8 - 1.0), 0.3 + 1e-12);
    EXPECT_LE(std::abs(d.region_friction[0] / 0.5 - 1.0), 0.3 + 1e-12);
    EXPECT_LE((r.start.position() - declared.start.position()).norm(), 0.15 * std::sqrt(2.0));
    // The pillar is 0.02 m from the robot's footprint: half the draws would touch it.
    EXPECT_TRUE(physics.is_free_of_static(shape, r.start)) << "seed " << seed;
    moved_start += r.start.x != declared.start.x ? 1 : 0;
    left_radius_above += r.wheel_radius_left_m > declared.wheel_radius_left_m ? 1 : 0;
    // Alice loops and starts anywhere on her 6 m path; Bob walks once and starts at his start.
    EXPECT_GE(d.movers[0].phase_m, 0.0);
    EXPECT_LT(d.movers[0].phase_m, 6.0);
    EXPECT_EQ(d.movers[1].phase_m, 0.0);
    for (const Vec2& p : d.drives[0].path_m) {
      b2CircleShape disc;
      disc.m_radius = 0.2f;
      EXPECT_TRUE(physics.is_free_of_static(disc, Pose2{p.x(), p.y(), 0.0}));
    }
  }
  EXPECT_EQ(moved_start, 200);  // a free draw was always found within kFreeTries
  EXPECT_GT(left_radius_above, 70);
  EXPECT_LT(left_radius_above, 130);
}

TEST(Variation, EachQuantityHasItsOwnStream) {
  // Another mover added: every other draw stays as it was.
  const RunInputs a = room();
  WorldDef with_carol = a.world;
  MoverDef carol = with_carol.movers[0];
  carol.name = "carol";
  with_carol.movers.push_back(carol);
  const auto one = to_json(draw_variation(a.world, a.scenario, 5));
  const auto two = to_json(draw_variation(with_carol, a.scenario, 5));
  EXPECT_EQ(one["robots"], two["robots"]);
  EXPECT_EQ(one["drives"], two["drives"]);
  EXPECT_EQ(one["movers"][0], two["movers"][0]);
  EXPECT_EQ(one["movers"][1], two["movers"][1]);
  EXPECT_EQ(two["movers"].size(), 3u);
}

TEST(Variation, NoneAndZeroTolerancesKeepTheDeclaredWorld) {
  RunInputs none = room("variation: none\n");
  EXPECT_FALSE(none.world.variation.enabled);
  const WorldDef before = none.world;
  vary_world(none.world, none.scenario, 3);
  EXPECT_FALSE(none.world.drawn.applied);
  EXPECT_EQ(nlohmann::json(to_json(none.world.drawn))["robots"].size(), 0u);
  EXPECT_EQ(none.world.robots[0].start.x, before.robots[0].start.x);
  EXPECT_FALSE(none.world.robots[0].sensors.encoders->odometry_wheel_base_m.has_value());

  RunInputs zero = room(R"(variation:
  wheel_radius_rel: 0
  wheel_base_rel: 0
  motor_rel: 0
  friction_rel: 0
  mover_speed_rel: 0
  start_xy_m: 0
  start_theta_deg: 0
  waypoint_m: 0
  mover_phase: false
)");
  const WorldDef declared = zero.world;
  const ScenarioDef declared_scenario = zero.scenario;
  vary_world(zero.world, zero.scenario, 3);
  EXPECT_TRUE(zero.world.drawn.applied);
  const RobotDef& r = zero.world.robots[0];
  EXPECT_EQ(r.wheel_radius_left_m, declared.robots[0].wheel_radius_left_m);
  EXPECT_EQ(r.wheel_base_m, declared.robots[0].wheel_base_m);
  EXPECT_EQ(r.start.x, declared.robots[0].start.x);
  EXPECT_EQ(r.start.theta, declared.robots[0].start.theta);
  EXPECT_EQ(zero.world.movers[0].path_m, declared.movers[0].path_m);
  EXPECT_EQ(zero.world.floor.friction, declared.floor.friction);
  EXPECT_EQ(zero.scenario.drives[0].path_m, declared_scenario.drives[0].path_m);
}

TEST(Variation, TheEncodersKeepTheDeclaredGeometry) {
  RunInputs inputs = room();
  const double declared_base = inputs.world.robots[0].wheel_base_m;
  vary_world(inputs.world, inputs.scenario, 11);
  const RobotDef& r = inputs.world.robots[0];
  EXPECT_NE(r.wheel_base_m, declared_base);
  EXPECT_EQ(believed_wheel_base_m(r), declared_base);
  EXPECT_EQ(r.wheel_radius_m, 0.05);  // nominal: what ticks are converted with
  EXPECT_NE(r.wheel_radius_left_m, 0.05);
}

TEST(Variation, AMoverStartsAnywhereOnItsLoopAndWalksTheSamePath) {
  RunInputs inputs = room();
  const std::vector<Vec2> declared = inputs.world.movers[0].path_m;
  vary_world(inputs.world, inputs.scenario, 4);
  const std::vector<Vec2>& path = inputs.world.movers[0].path_m;
  const double phase_m = inputs.world.drawn.movers[0].phase_m;
  ASSERT_GT(phase_m, 0.0);
  // The first point lies on the declared loop, `phase_m` along it; the rest are its corners.
  double along = 0.0;
  bool found = false;
  for (std::size_t i = 0; i < declared.size() && !found; ++i) {
    const Vec2 a = declared[i], b = declared[(i + 1) % declared.size()];
    const double length = (b - a).norm();
    if (phase_m <= along + length) {
      EXPECT_NEAR((path[0] - (a + (b - a) * ((phase_m - along) / length))).norm(), 0.0, 1e-12);
      found = true;
    }
    along += length;
  }
  EXPECT_TRUE(found);
  for (std::size_t k = 1; k < path.size(); ++k) {
    EXPECT_NE(std::find(declared.begin(), declared.end(), path[k]), declared.end());
  }
}

TEST(Variation, TwoSeedsOfAShippedWorldGiveOtherGroundTruthAndAReplayRebuildsIt) {
  const fs::path dir = testing::temp_dir("runs");
  const auto run = [&](std::uint64_t seed, const std::string& name) {
    RunOptions options;
    options.world_file = fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml";
    options.seed = seed;
    options.duration_s = 4.0;  // before the demo's first kidnap
    options.out_dir = dir / name;
    options.localizers = {"odometry"};
    options.log_file = dir / (name + ".locsimlog");
    return run_simulation(options);
  };
  run(1, "a");
  run(1, "a2");
  run(2, "b");
  const std::string a = testing::read_file(dir / "a/groundtruth.tum");
  EXPECT_EQ(a, testing::read_file(dir / "a2/groundtruth.tum"));
  EXPECT_NE(a, testing::read_file(dir / "b/groundtruth.tum"));
  // The very first pose (after the header line) differs: the start is drawn.
  const auto first_pose = [](const std::string& tum) {
    const std::size_t start = tum.find('\n') + 1;
    return tum.substr(start, tum.find('\n', start) - start);
  };
  EXPECT_NE(first_pose(a), first_pose(testing::read_file(dir / "b/groundtruth.tum")));
  const auto config = nlohmann::json::parse(testing::read_file(dir / "a/run.json"))["config"];
  EXPECT_TRUE(config["world"]["variation"]["drawn"].is_object());

  ReplayOptions replay;
  replay.log_file = dir / "a.locsimlog";
  replay.out_dir = dir / "replay";
  replay.localizers = {"odometry"};
  replay_log(replay);
  EXPECT_EQ(testing::json_without_timing(dir / "a/metrics.json"),
            testing::json_without_timing(dir / "replay/metrics.json"));
  const auto replayed = nlohmann::json::parse(testing::read_file(dir / "replay/run.json"));
  EXPECT_EQ(replayed["config"]["world"]["variation"]["drawn"],
            config["world"]["variation"]["drawn"]);
}

TEST(Variation, BadToleranceNamesFileLineAndKey) {
  const auto error = [](const std::string& extra) {
    try {
      room(extra);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  testing::expect_contains(error("variation: sometimes\n"), "variation");
  testing::expect_contains(error("variation: sometimes\n"), "none");
  testing::expect_contains(error("variation: {wheel_radius_rel: 0.5}\n"), "wheel_radius_rel");
  testing::expect_contains(error("variation: {wheel_radius_rel: 0.5}\n"), "0.3");
  testing::expect_contains(error("variation: {wheels: 0.1}\n"), "wheels");
  testing::expect_contains(error("variation: {start_xy_m: -1}\n"), "room.yaml:");
}

TEST(Variation, ARecordThatDoesNotFitTheWorldIsRefused) {
  RunInputs inputs = room();
  DrawnVariation drawn = draw_variation(inputs.world, inputs.scenario, 1);
  drawn.robots[0].name = "someone";
  try {
    apply_variation(drawn, inputs.world, inputs.scenario);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    testing::expect_contains(e.what(), "robot 'someone' is not robot 'r'");
  }
  EXPECT_THROW(drawn_variation_from_json(nlohmann::json{{"robots", 3}}), InputError);
  const DrawnVariation back = drawn_variation_from_json(
      nlohmann::json::parse(to_json(draw_variation(inputs.world, inputs.scenario, 1)).dump()));
  EXPECT_EQ(to_json(back), to_json(draw_variation(inputs.world, inputs.scenario, 1)));
}

}  // namespace
}  // namespace locsim
