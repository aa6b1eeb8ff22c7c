// World and scenario files: what they accept, and a clear message at file:line:col with the key
// for everything they do not.
#include <gtest/gtest.h>

#include "sim/world/pgm.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

using testing::make_sim;

struct Malformed {
  const char* name;
  const char* yaml;
  const char* expected;  // a substring of the message
};

void PrintTo(const Malformed& c, std::ostream* os) {
  *os << c.name;
}

class MalformedWorld : public ::testing::TestWithParam<Malformed> {};

TEST_P(MalformedWorld, IsRejectedWithFileLineColumnAndKey) {
  const Malformed& c = GetParam();
  try {
    const Simulation sim = make_sim(c.yaml);
    FAIL() << "accepted:\n" << c.yaml;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(c.expected), std::string::npos)
        << "message: " << e.what() << "\nexpected to contain: " << c.expected;
  }
}

// Each world below is wrong in one way; line and column are 1-based.
const Malformed kMalformedWorlds[] = {
    {"syntax", "robots: [\n", "test.yaml:2:1: YAML syntax error"},
    {"unknown_top_key", "robotz: []\n",
     "test.yaml:1:1: 'robotz': unknown key; did you mean 'robots'?"},
    {"no_robots_key", "name: x\n", "test.yaml:1:1: missing required key 'robots'"},
    {"no_robots", "robots: []\n", "test.yaml:1:9: 'robots': a world needs at least one robot"},
    {"unknown_robot_key", "robots:\n  - start: {x: 0, y: 0}\n    wheel_bas_m: 0.3\n",
     "test.yaml:3:5: 'robots[0].wheel_bas_m': unknown key; did you mean 'wheel_base_m'?"},
    {"negative_radius", "robots:\n  - start: {x: 0, y: 0}\n    wheel_radius_m: -0.05\n",
     "test.yaml:3:21: 'robots[0].wheel_radius_m': -0.05 m is outside [0.001, 10] m"},
    {"wrong_type", "robots:\n  - start: {x: 0, y: 0}\n    mass_kg: heavy\n",
     "test.yaml:3:14: 'robots[0].mass_kg': expected a number, got 'heavy'"},
    {"nan", "robots:\n  - start: {x: .nan, y: 0}\n",
     "'robots[0].start.x': expected a finite number"},
    {"missing_start", "robots:\n  - name: r\n", "'robots[0]': missing required key 'start'"},
    {"response_key", "robots:\n  - start: {x: 0, y: 0}\n    command_response: {dead_time: 0.1}\n",
     "test.yaml:3:24: 'robots[0].command_response.dead_time': unknown key; did you mean "
     "'dead_time_s'?"},
    {"response_gain", "robots:\n  - start: {x: 0, y: 0}\n    command_response: {gain_v: 0}\n",
     "'robots[0].command_response.gain_v': 0 is outside [0.01, 100]"},
    {"encoders_measure",
     "robots:\n  - start: {x: 0, y: 0}\n    sensors:\n      encoders: {measures: motors}\n",
     "'robots[0].sensors.encoders.measures': must be wheels or command, not 'motors'"},
    {"encoders_heading",
     "robots:\n  - start: {x: 0, y: 0}\n    sensors:\n      encoders: {heading: compass}\n",
     "'robots[0].sensors.encoders.heading': must be wheels or gyro, not 'compass'"},
    {"encoders_gyro_without_one",
     "robots:\n  - start: {x: 0, y: 0}\n    sensors:\n      encoders: {gyro_bias_radps: 0.01}\n",
     "'robots[0].sensors.encoders.gyro_bias_radps': describes the gyro of `heading: gyro`, which "
     "this base has not"},
    {"theta_twice", "robots:\n  - start: {x: 0, y: 0, theta: 1, theta_deg: 5}\n",
     "'robots[0].start.theta_deg': give either 'theta' [rad] or 'theta_deg' [deg], not both"},
    {"point_not_pair", "walls:\n  - points: [[0, 0], [1]]\nrobots:\n  - start: {x: 5, y: 5}\n",
     "test.yaml:2:22: 'walls[0].points[1]': expected a point [x, y]"},
    {"wall_one_point", "walls:\n  - points: [[0, 0]]\nrobots:\n  - start: {x: 5, y: 5}\n",
     "'walls[0].points': expected at least 2 points"},
    {"concave_polygon",
     "polygons:\n  - points: [[0, 0], [2, 0], [1, 0.2], [1, 2]]\nrobots:\n  - start: {x: 5, y: "
     "5}\n",
     "'polygons[0].points': polygon must be convex"},
    {"negative_friction", "floor: {friction: -1}\nrobots:\n  - start: {x: 0, y: 0}\n",
     "test.yaml:1:19: 'floor.friction': -1 is outside [0, 10]"},
    {"region_two_shapes",
     "floor:\n  regions:\n    - {name: a, friction: 1, box: {min: [0, 0], max: [1, 1]}, polygon: "
     "[[0, 0], [1, 0], [0, 1]]}\n"
     "robots:\n  - start: {x: 5, y: 5}\n",
     "'floor.regions[0]': give exactly one of 'polygon' or 'box'"},
    {"duplicate_landmark",
     "landmarks:\n  - {id: 1, position: [0, 0]}\n  - {id: 1, position: [1, 0]}\nrobots:\n  - "
     "start: {x: 5, y: 5}\n",
     "test.yaml:3:10: 'landmarks[1].id': landmark id used twice"},
    {"unknown_color",
     "landmarks:\n  - {id: 1, position: [0, 0], color: chartreuse}\nrobots:\n  - start: {x: 5, y: "
     "5}\n",
     "'landmarks[0].color': unknown colour 'chartreuse'"},
    {"bad_mover_kind",
     "movers:\n  - {name: m, kind: dog, path: [[0, 0]]}\nrobots:\n  - start: {x: 5, y: 5}\n",
     "'movers[0].kind': expected 'person' or 'cart'"},
    {"duplicate_key", "robots:\n  - start: {x: 0, y: 0}\n    mass_kg: 1\n    mass_kg: 2\n",
     "'robots[0].mass_kg': key given twice"},
    {"step_rate", "physics: {step_hz: 5}\nrobots:\n  - start: {x: 0, y: 0}\n",
     "'physics.step_hz': 5 Hz is outside [10, 10000] Hz"},
    {"bad_robot_name", "robots:\n  - {name: my robot, start: {x: 0, y: 0}}\n",
     "'robots[0].name': a robot name names its output folder"},
    {"missing_map", "map: nowhere/map.yaml\nrobots:\n  - start: {x: 0, y: 0}\n",
     "test.yaml:1:6: 'map': no such map file"},
    // A name the system cannot look up (the fuzzer's: a quote left open swallowed the file).
    {"map_name_too_long",
     "map: "
     "mmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmm"
     "mmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmm"
     "mmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmm"
     "mmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmm"
     "mmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmmm"
     ".yaml\nrobots:\n  - start: {x: 0, y: 0}\n",
     "test.yaml:1:6: 'map': cannot look up the map file"},
    // Sensors.
    {"unknown_sensor", "robots:\n  - start: {x: 0, y: 0}\n    sensors: {lidar: {}}\n",
     "'robots[0].sensors.lidar': unknown key; did you mean 'laser'?"},
    {"unknown_sensor_key", "robots:\n  - start: {x: 0, y: 0}\n    sensors: {laser: {beems: 10}}\n",
     "'robots[0].sensors.laser.beems': unknown key; did you mean 'beams'?"},
    {"sensor_rate", "robots:\n  - start: {x: 0, y: 0}\n    sensors: {imu: {rate_hz: 30}}\n",
     "test.yaml:3:30: 'robots[0].sensors.imu.rate_hz': rate 30 Hz must divide the physics rate "
     "(200 Hz)"},
    {"range_model_unknown",
     "robots:\n  - start: {x: 0, y: 0}\n    sensors:\n      range_bearing: {range_model: "
     "sideways}\n",
     "test.yaml:4:36: 'robots[0].sensors.range_bearing.range_model': must be distance or depth, "
     "not 'sideways'"},
    {"range_model_depth_all_round",
     "robots:\n  - start: {x: 0, y: 0}\n    sensors:\n      range_bearing: {fov_deg: 270, "
     "range_model: depth}\n",
     "'robots[0].sensors.range_bearing.range_model': depth needs a field of view below 180 deg, "
     "not 270 deg"},
    {"laser_mixture",
     "robots:\n  - start: {x: 0, y: 0}\n    sensors: {laser: {p_max: 0.7, p_random: 0.5}}\n",
     "p_short + p_max + p_random exceeds 1"},
    {"fault_unknown_sensor",
     "robots:\n  - start: {x: 0, y: 0}\nscenario:\n  events:\n    - {at_s: 1, sensor_fault: "
     "{sensor: gps, mode: dropout}}\n",
     "'scenario.events[0].sensor_fault.sensor': unknown sensor"},
    {"fault_encoder_bias",
     "robots:\n  - start: {x: 0, y: 0}\n    sensors: {encoders: {}}\nscenario:\n  events:\n"
     "    - {at_s: 1, sensor_fault: {sensor: encoders, mode: bias, bias: 1}}\n",
     "encoders take dropout or stuck faults, not bias"},
    // Scenario problems, in the world's scenario section.
    {"unknown_drive_mode", "robots:\n  - start: {x: 0, y: 0}\nscenario:\n  drive: {mode: fly}\n",
     "test.yaml:4:17: 'scenario.drive.mode': unknown mode"},
    {"key_of_other_mode",
     "robots:\n  - start: {x: 0, y: 0}\nscenario:\n  drive: {mode: velocity, commands: [], path: "
     "[[1, 1]]}\n",
     "'scenario.drive.path': not used by mode 'velocity'"},
    {"event_two_kinds",
     "robots:\n  - start: {x: 0, y: 0}\nscenario:\n  events:\n    - {at_s: 1, end: {}, push: "
     "{impulse_ns: [1, 0]}}\n",
     "test.yaml:5:7: 'scenario.events[0]': an event has 'at_s' and exactly one of"},
    {"kidnap_bad_to",
     "robots:\n  - start: {x: 0, y: 0}\nscenario:\n  events:\n    - {at_s: 1, kidnap: {to: "
     "anywhere}}\n",
     "'scenario.events[0].kidnap.to': expected a pose {x, y, theta} or 'random'"},
    {"commands_not_increasing",
     "robots:\n  - start: {x: 0, y: 0}\nscenario:\n  drive:\n    mode: velocity\n    commands:\n"
     "      - {t_s: 1, v_mps: 0.1}\n      - {t_s: 1, v_mps: 0.2}\n",
     "test.yaml:8:15: 'scenario.drive.commands[1].t_s': command times must increase"},
};

INSTANTIATE_TEST_SUITE_P(Syntax, MalformedWorld, ::testing::ValuesIn(kMalformedWorlds),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

// Well-formed numbers outside their declared ranges (issue 22): before, each of these crashed
// Box2D (SIGABRT), overflowed a step count, hung, produced NaN poses or allocated gigabytes.
const Malformed kOutOfRange[] = {
    {"mass_huge", "robots:\n  - start: {x: 0, y: 0}\n    mass_kg: 1.0e38\n",
     "test.yaml:3:14: 'robots[0].mass_kg': 1e+38 kg is outside [0.01, 100000] kg"},
    {"mass_tiny", "robots:\n  - start: {x: 0, y: 0}\n    mass_kg: 1.0e-40\n",
     "test.yaml:3:14: 'robots[0].mass_kg': 1e-40 kg is outside [0.01, 100000] kg"},
    {"start_far", "robots:\n  - start: {x: 1.0e300, y: 0}\n",
     "test.yaml:2:16: 'robots[0].start.x': 1e+300 m is outside [-10000, 10000] m"},
    {"heading_huge", "robots:\n  - start: {x: 0, y: 0, theta: 1.0e300}\n",
     "test.yaml:2:32: 'robots[0].start.theta': 1e+300 rad is outside [-1000000, 1000000] rad"},
    {"heading_huge_deg", "robots:\n  - start: {x: 0, y: 0, theta_deg: -1.0e9}\n",
     "'robots[0].start.theta_deg': -1e+09 deg is outside [-5.72958e+07, 5.72958e+07] deg"},
    {"wanderer_far", "robots:\n  - start: {x: 1.0e10, y: 0}\nscenario:\n  drive: {mode: wander}\n",
     "test.yaml:2:16: 'robots[0].start.x': 1e+10 m is outside [-10000, 10000] m"},
    {"groundtruth_rate_tiny",
     "robots:\n  - start: {x: 0, y: 0}\nscenario:\n  groundtruth_hz: 1.0e-300\n",
     "test.yaml:4:19: 'scenario.groundtruth_hz': 1e-300 Hz is outside [0.01, 10000] Hz"},
    {"groundtruth_rate_not_dividing",
     "robots:\n  - start: {x: 0, y: 0}\nscenario:\n  groundtruth_hz: 30\n",
     "test.yaml:4:19: 'scenario.groundtruth_hz': rate 30 Hz must divide the physics rate (200 Hz)"},
    {"mover_speed_huge",
     "movers:\n  - {name: m, path: [[3, 3], [4, 3]], speed_mps: 1.0e300}\nrobots:\n  - start: {x: "
     "0, "
     "y: 0}\n",
     "test.yaml:2:50: 'movers[0].speed_mps': 1e+300 m/s is outside [0, 50] m/s"},
    {"mover_path_standing",
     "movers:\n  - {name: m, path: [[3, 3], [3, 3.001]]}\nrobots:\n  - start: {x: 0, y: 0}\n",
     "test.yaml:2:21: 'movers[0].path': points 0 and 1 are closer than 1 cm"},
    {"footprint_tiny", "robots:\n  - start: {x: 0, y: 0}\n    footprint: {radius_m: 1.0e-300}\n",
     "test.yaml:3:27: 'robots[0].footprint.radius_m': 1e-300 m is outside [0.01, 50] m"},
    {"footprint_polygon_tiny",
     "robots:\n  - start: {x: 0, y: 0}\n    footprint: {polygon: [[0.001, 0], [0, 0.001], [-0.001, "
     "0]]}\n",
     "'robots[0].footprint.polygon': points 0 and 1 are closer than 1 cm"},
    {"footprint_polygon_sliver",
     "robots:\n  - start: {x: 0, y: 0}\n    footprint: {polygon: [[0.3, 0], [0, 0.0001], [-0.3, "
     "0]]}\n",
     "'robots[0].footprint.polygon': polygon's area 3e-05 m² is below 0.0001 m²"},
    {"duration_huge", "robots:\n  - start: {x: 0, y: 0}\nscenario:\n  duration_s: 1.0e300\n",
     "test.yaml:4:15: 'scenario.duration_s': 1e+300 s is outside [0.001, 10000000] s"},
    {"wall_long", "walls:\n  - points: [[0, 0], [2.1e9, 0]]\nrobots:\n  - start: {x: 2, y: 2}\n",
     "test.yaml:2:23: 'walls[0].points[1][0]': 2.1e+09 m is outside [-10000, 10000] m"},
    {"room_30km",
     "walls:\n  - points: [[0, 0], [30000, 0], [30000, 30000], [0, 30000]]\n    closed: true\n"
     "robots:\n  - start: {x: 2, y: 2}\n",
     "test.yaml:2:23: 'walls[0].points[1][0]': 30000 m is outside [-10000, 10000] m"},
    {"grid_resolution_tiny",
     "robots:\n  - start: {x: 0, y: 0}\nscenario:\n  localization: {grid_resolution_m: 1.0e-5}\n",
     "test.yaml:4:37: 'scenario.localization.grid_resolution_m': 1e-05 m is outside [0.001, 100] "
     "m"},
    {"grid_over_budget",
     "walls:\n  - points: [[0, 0], [2000, 0], [2000, 2000], [0, 2000]]\n    closed: true\n"
     "robots:\n  - start: {x: 2, y: 2}\nscenario:\n  localization: {grid_resolution_m: 0.05}\n",
     "test.yaml:7:37: 'scenario.localization.grid_resolution_m': the localizers' occupancy grid of "
     "40005 x 40005 cells of 0.05 m would need about 35.8 GiB; a world may need at most 1 GiB"},
    {"rendered_camera_over_budget",
     "robots:\n  - start: {x: 0, y: 0}\n    sensors:\n      ptz_camera: {mode: rendered, width_px: "
     "8192, height_px: 8192}\n",
     "test.yaml:4:19: 'robots[0].sensors.ptz_camera': a rendered 8192 x 8192 px camera would need "
     "about "
     "2 "
     "GiB; a world may need at most 1 GiB"},
    {"sweep_rate_zero",
     "robots:\n  - start: {x: 0, y: 0}\n    sensors: {ptz_camera: {}}\nscenario:\n  ptz: {policy: "
     "sweep, sweep_rate_deg: 0}\n",
     "'scenario.ptz.sweep_rate_deg': 0 deg/s is outside [0.01, 10000] deg/s"},
};

INSTANTIATE_TEST_SUITE_P(Ranges, MalformedWorld, ::testing::ValuesIn(kOutOfRange),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

// Problems only the assembled world or the scenario's names reveal.
const Malformed kInconsistentWorlds[] = {
    {"start_in_wall", "walls:\n  - points: [[1, -1], [1, 1]]\nrobots:\n  - start: {x: 1.1, y: 0}\n",
     "test.yaml:4:5: 'robots[0].start': robot 'robot0' starts in collision"},
    {"start_in_box",
     "boxes:\n  - {center: [0, 0], size: [1, 1]}\nrobots:\n  - start: {x: 0, y: 0}\n",
     "starts in collision"},
    {"robots_overlap",
     "robots:\n  - {name: a, start: {x: 0, y: 0}}\n  - {name: b, start: {x: 0.3, y: 0}}\n",
     "robot 'b' starts in collision"},
    {"unknown_region",
     "robots:\n  - start: {x: 0, y: 0}\nscenario:\n  events:\n    - {at_s: 1, friction: {region: "
     "mud, friction: 0.1}}\n",
     "test.yaml:5:7: 'scenario.events[0].friction.region': no floor region called 'mud'"},
    {"unknown_robot",
     "robots:\n  - start: {x: 0, y: 0}\nscenario:\n  events:\n    - {at_s: 1, kidnap: {robot: r9, "
     "to: random}}\n",
     "'scenario.events[0].kidnap.robot': no robot called 'r9'"},
    {"unnamed_robot_with_two",
     "robots:\n  - {name: a, start: {x: 0, y: 0}}\n  - {name: b, start: {x: 2, y: 0}}\n"
     "scenario:\n  drive: {mode: wander}\n",
     "'scenario.drive.robot': a drive must name its robot: the world has 2 robots"},
    {"fault_on_absent_sensor",
     "robots:\n  - start: {x: 0, y: 0}\nscenario:\n  events:\n    - {at_s: 1, sensor_fault: "
     "{sensor: laser, mode: dropout}}\n",
     "'scenario.events[0].sensor_fault.sensor': robot 'robot0' has no laser"},
    {"ptz_without_camera", "robots:\n  - start: {x: 0, y: 0}\nscenario:\n  ptz: {policy: sweep}\n",
     "'scenario.ptz': robot 'robot0' has no ptz_camera"},
    // A kidnap that would put its robot inside a wall: Box2D would push it out to either side,
    // outside the room as likely as in.
    {"kidnap_into_wall",
     "walls:\n  - points: [[0, 0], [10, 0], [10, 8], [0, 8]]\n    closed: true\nrobots:\n  - "
     "start: {x: 2, y: 2}\nscenario:\n  events:\n    - {at_s: 1, kidnap: {to: {x: 10, y: 4}}}\n",
     "test.yaml:8:7: 'scenario.events[0].kidnap.to': robot 'robot0' would be put down at "
     "(10.0000,4.0000,0.0000) overlapping a wall, shape or map cell"},
    // A random kidnap into a region filled by a box: found now, not half-way through the run.
    {"kidnap_random_nowhere",
     "boxes:\n  - {center: [5, 4], size: [2, 2]}\nrobots:\n  - start: {x: 2, y: 2}\nscenario:\n"
     "  events:\n    - {at_s: 1, kidnap: {to: random, within: {min: [4.5, 3.5], max: [5.5, "
     "4.5]}}}\n",
     "test.yaml:7:7: 'scenario.events[0].kidnap.within': robot 'robot0' fits nowhere in x 4.5..5.5 "
     "m, y 3.5..4.5 m"},
    {"unknown_obstacle",
     "robots:\n  - start: {x: 0, y: 0}\nscenario:\n  events:\n    - {at_s: 1, obstacle: {name: "
     "carol, action: stop}}\n",
     "no mover called 'carol'"},
};

INSTANTIATE_TEST_SUITE_P(Consistency, MalformedWorld, ::testing::ValuesIn(kInconsistentWorlds),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

TEST(WorldLoader, ReadsEveryKindOfEntityWithDefaults) {
  const WorldDef world = testing::world_from_yaml(R"(
name: lab
floor:
  friction: 0.7
  regions:
    - {name: ice, friction: 0.05, polygon: [[0, 0], [1, 0], [1, 1]]}
walls:
  - {points: [[0, 0], [4, 0], [4, 3]], closed: true}
boxes:
  - {center: [2, 2], size: [0.5, 0.25], angle_deg: 90}
circles:
  - {center: [1, 2], radius_m: 0.1}
landmarks:
  - {id: 3, position: [1, 1], color: [10, 20, 30], height_m: 1.0}
beacons:
  - {id: 1, position: [0, 3]}
movers:
  - {name: cart1, kind: cart, path: [[1, 1], [2, 1]]}
robots:
  - name: r
    start: {x: 3, y: 1, theta_deg: 90}
)");
  EXPECT_EQ(world.name, "lab");
  EXPECT_DOUBLE_EQ(world.floor.friction, 0.7);
  ASSERT_EQ(world.floor.regions.size(), 1u);
  EXPECT_EQ(world.walls[0].points_m.size(), 3u);
  EXPECT_TRUE(world.walls[0].closed);
  EXPECT_DOUBLE_EQ(world.boxes[0].angle_rad, std::numbers::pi / 2);
  EXPECT_EQ(world.landmarks[0].color, (Rgb{10, 20, 30}));
  EXPECT_DOUBLE_EQ(world.landmarks[0].radius_m, 0.1);
  EXPECT_DOUBLE_EQ(world.beacons[0].height_m, 2.5);
  EXPECT_EQ(world.movers[0].footprint.kind, FootprintDef::Kind::kBox);
  EXPECT_DOUBLE_EQ(world.robots[0].start.theta, std::numbers::pi / 2);
  EXPECT_DOUBLE_EQ(world.robots[0].wheel_radius_left_m, world.robots[0].wheel_radius_m);
}

TEST(WorldLoader, ARangeBearingSensorReportsDistanceUnlessToldDepth) {
  const auto model = [](const std::string& sensor) {
    const WorldDef world = testing::world_from_yaml(
        "robots:\n  - start: {x: 0, y: 0}\n    sensors:\n      range_bearing: " + sensor + "\n");
    return world.robots.at(0).sensors.range_bearing.value().range_model;
  };
  using Model = RangeBearingDef::RangeModel;
  EXPECT_EQ(model("{}"), Model::kDistance);
  EXPECT_EQ(model("{range_model: distance}"), Model::kDistance);
  EXPECT_EQ(model("{range_model: depth}"), Model::kDepth);
  EXPECT_EQ(model("{range_model: depth, fov_deg: 179}"), Model::kDepth);
}

TEST(WorldLoader, DemoWorldLoadsAndValidates) {
  const std::filesystem::path demo =
      std::filesystem::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml";
  WorldDef world = load_world(demo);
  ASSERT_TRUE(world.scenario.has_value());
  ScenarioDef scenario = *world.scenario;
  bind_scenario(scenario, world);
  const Simulation sim(world, scenario, 1);
  EXPECT_EQ(world.landmarks.size(), 6u);
  EXPECT_GE(scenario.events.size(), 2u);
}

/// A ROS map_server map: an 8 x 6 px image at 0.5 m per px, origin (-1, -2), with a 2 px thick
/// wall along its top row pair and one occupied pixel.
std::filesystem::path write_map(const std::filesystem::path& dir, bool negate) {
  const unsigned char free_value = negate ? 0 : 254, occupied = negate ? 255 : 0;
  std::vector<unsigned char> pixels(6 * 8, free_value);
  for (int col = 0; col < 8; ++col) pixels[col] = pixels[8 + col] = occupied;
  pixels[4 * 8 + 2] = occupied;
  std::ofstream image(dir / "lab.pgm", std::ios::binary);
  image << "P5\n# written by the test\n8 6\n255\n";
  image.write(reinterpret_cast<const char*>(pixels.data()),
              static_cast<std::streamsize>(pixels.size()));
  image.close();
  std::ofstream yaml(dir / "lab.yaml");
  yaml << "image: lab.pgm\nresolution: 0.5\norigin: [-1.0, -2.0, 0.0]\n"
       << "occupied_thresh: 0.65\nfree_thresh: 0.196\nnegate: " << (negate ? 1 : 0) << "\n";
  return dir / "lab.yaml";
}

TEST(OccupancyMap, CellsBecomeStaticGeometryWhereMapServerPutsThem) {
  for (const bool negate : {false, true}) {
    const auto dir = testing::temp_dir(negate ? "negated" : "plain");
    write_map(dir, negate);
    std::ofstream(dir / "world.yaml") << "map: lab.yaml\nrobots:\n  - start: {x: 2, y: -0.7}\n";
    WorldDef world = load_world(dir / "world.yaml");
    ASSERT_TRUE(world.map.has_value());
    EXPECT_EQ(world.map->width_px, 8);
    ScenarioDef scenario;
    bind_scenario(scenario, world);
    const Simulation sim(world, scenario, 1);
    // Two full rows merge into one box; the lone pixel is another.
    EXPECT_EQ(sim.world().static_fixture_count(), 2);
    // The image's top two rows span y in [-2 + 4 * 0.5, -2 + 6 * 0.5] = [0, 1].
    const auto up = sim.world().ray_cast({1.0, -0.5}, {1.0, 5.0}, nullptr);
    ASSERT_TRUE(up.has_value());
    EXPECT_NEAR(*up, 0.5, 1e-4);
    // Pixel (row 4, col 2) covers x in [0, 0.5], y in [-1.5, -1].
    const auto right = sim.world().ray_cast({-0.9, -1.25}, {3.0, -1.25}, nullptr);
    ASSERT_TRUE(right.has_value());
    EXPECT_NEAR(*right, 0.9, 1e-4);
  }
}

TEST(OccupancyMap, MissingImageIsReportedAtTheImageKey) {
  const auto dir = testing::temp_dir("map");
  std::ofstream(dir / "lab.yaml") << "image: gone.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n";
  try {
    load_occupancy_map(dir / "lab.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("lab.yaml:1:8: 'image': no such map image"),
              std::string::npos)
        << e.what();
  }
}

TEST(OccupancyMap, AnImageOverTheLimitIsReportedAtTheImageKey) {
  // 19 bytes announcing 50 000 x 50 000 pixels: before, 2.5 GB were allocated to read them.
  const auto dir = testing::temp_dir("map");
  std::ofstream(dir / "huge.pgm") << "P5\n50000 50000\n255\n";
  std::ofstream(dir / "lab.yaml") << "image: huge.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n";
  try {
    load_occupancy_map(dir / "lab.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("lab.yaml:1:8: 'image': " + (dir / "huge.pgm").string() +
                                         ": not a readable PGM image: 50000 x 50000 pixels; a "
                                         "map has at most 33554432"),
              std::string::npos)
        << e.what();
  }
}

TEST(Pgm, ReadsTextAndSixteenBitImagesScaledTo255) {
  const auto dir = testing::temp_dir("pgm");
  std::ofstream(dir / "text.pgm") << "P2\n# comment\n3 2\n15\n0 15 5\n15 0 10\n";
  const GrayImage text = read_pgm(dir / "text.pgm");
  EXPECT_EQ(text.width, 3);
  EXPECT_EQ(text.pixels, (std::vector<unsigned char>{0, 255, 85, 255, 0, 170}));
  std::ofstream wide(dir / "wide.pgm", std::ios::binary);
  wide << "P5 2 1 65535\n";
  wide.write("\xff\xff\x80\x00", 4);
  wide.close();
  EXPECT_EQ(read_pgm(dir / "wide.pgm").pixels, (std::vector<unsigned char>{255, 128}));
}

TEST(Pgm, RejectsOtherFormatsAndTruncatedFiles) {
  const auto dir = testing::temp_dir("pgm");
  std::ofstream(dir / "map.png") << "\x89PNG\r\n";
  std::ofstream(dir / "short.pgm") << "P5\n4 4\n255\n\x01\x02";
  std::ofstream(dir / "big.pgm") << "P2\n1 1\n10\n11\n";
  const auto message = [](const std::filesystem::path& file) {
    try {
      read_pgm(file);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(
      message(dir / "map.png").find("map.png: not a readable PGM image: expected the magic number"),
      std::string::npos);
  EXPECT_NE(message(dir / "short.pgm").find("truncated pixel data"), std::string::npos);
  EXPECT_NE(message(dir / "big.pgm").find("pixel value above the maximum value"),
            std::string::npos);
  // A 19-byte header announcing 50 000 x 50 000 pixels is refused before a pixel is allocated:
  // over the documented maximum, or more than the file holds.
  std::ofstream(dir / "huge.pgm") << "P5\n50000 50000\n255\n";
  EXPECT_NE(message(dir / "huge.pgm")
                .find("huge.pgm: not a readable PGM image: 50000 x 50000 pixels; a map has at most "
                      "33554432"),
            std::string::npos)
      << message(dir / "huge.pgm");
  std::ofstream(dir / "liar.pgm") << "P2\n4000 4000\n255\n0 0 0\n";
  EXPECT_NE(message(dir / "liar.pgm")
                .find("truncated pixel data: the header announces 4000 x 4000 pixels (at least "
                      "31999999 bytes) and 7 bytes follow it"),
            std::string::npos)
      << message(dir / "liar.pgm");
  std::filesystem::create_directories(dir / "folder.pgm");
  EXPECT_NE(message(dir / "folder.pgm").find("folder.pgm: is a directory, not a file"),
            std::string::npos);
}

TEST(ScenarioLoader, MissingScenarioFileIsAnInputError) {
  EXPECT_THROW(load_scenario("/nonexistent/scenario.yaml"), InputError);
}

}  // namespace
}  // namespace locsim
