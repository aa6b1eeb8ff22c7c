#include "sim/scenario/scenario_loader.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <string_view>
#include <vector>

#include "sim/common/format.hpp"
#include "sim/producers/text_table.hpp"
#include "sim/sensors/sensor_loader.hpp"
#include "sim/world/world_budget.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

namespace {

/// The place of `key` below `node` (a dotted path), or of `node` with the key's path when the key
/// is absent (its default applies).
InputPlace place_of(const YamlNode& node, const std::string& key) {
  std::optional<YamlNode> at = node;
  std::size_t begin = 0;
  while (at && at->is_map() && begin <= key.size()) {
    const std::size_t dot = std::min(key.find('.', begin), key.size());
    std::optional<YamlNode> next = at->find(key.substr(begin, dot - begin));
    if (!next) break;
    at = next;
    begin = dot + 1;
  }
  if (begin > key.size()) return at->place();
  return InputPlace{at->where(), node.path().empty() ? key : node.path() + "." + key};
}

DriveDef parse_drive(const YamlNode& node, const std::filesystem::path& base_dir) {
  // The keys of the modes, in one list: unknown keys are refused, and a key of another mode
  // than the drive's is named as such (only() below).
  static constexpr std::string_view kModeKeys[] = {
      "path",     "loop",        "tolerance_m",        "heading_gain", "after_kidnap",
      "commands", "clearance_m", "clearance_check_hz", "speed_mps",    "max_turn_rate_radps",
      "poses",    "poses_file"};
  std::vector<std::string_view> allowed = {"robot", "mode", "start_after_s"};
  allowed.insert(allowed.end(), std::begin(kModeKeys), std::end(kModeKeys));
  node.allow_keys(allowed);
  DriveDef drive;
  drive.where = node.where();
  drive.key_path = node.path();
  drive.robot = node.get_string("robot", "");
  drive.start_after_s = node.get_double("start_after_s", 0.0, kSimulatedTimeRange);
  const YamlNode mode = node["mode"];
  const std::string mode_name = mode.as_string();
  const auto only = [&](std::initializer_list<std::string_view> keys) {
    for (const std::string_view key : kModeKeys) {
      if (node.has(key) && std::find(keys.begin(), keys.end(), key) == keys.end()) {
        node[key].fail("not used by mode '" + mode_name + "'");
      }
    }
  };
  drive.speed_mps = node.get_double("speed_mps", drive.speed_mps, DriveDef::kSpeedRange);
  drive.max_turn_rate_radps =
      node.get_double("max_turn_rate_radps", drive.max_turn_rate_radps, DriveDef::kTurnRateRange);
  if (mode_name == "idle") {
    drive.mode = DriveDef::Mode::kIdle;
    only({});
  } else if (mode_name == "waypoints") {
    drive.mode = DriveDef::Mode::kWaypoints;
    only({"path", "loop", "speed_mps", "max_turn_rate_radps", "tolerance_m", "heading_gain",
          "after_kidnap"});
    drive.path_m = node["path"].as_points(1, kWorldCoordinateRange);
    drive.loop = node.get_bool("loop", drive.loop);
    drive.tolerance_m =
        node.get_double("tolerance_m", drive.tolerance_m, DriveDef::kToleranceRange);
    drive.heading_gain =
        node.get_double("heading_gain", drive.heading_gain, DriveDef::kHeadingGainRange);
    if (const auto after = node.find("after_kidnap")) {
      const std::string value = after->as_string();
      if (value == "nearest_in_sight") {
        drive.after_kidnap = DriveDef::AfterKidnap::kNearestInSight;
      } else if (value != "continue") {
        after->fail("expected continue or nearest_in_sight, got '" + value + "'");
      }
    }
  } else if (mode_name == "velocity") {
    drive.mode = DriveDef::Mode::kVelocity;
    only({"commands"});
    double previous_t = -1.0;
    for (const YamlNode& item : node["commands"].items()) {
      item.allow_keys({"t_s", "v_mps", "w_radps"});
      VelocityCommand command;
      command.t_s = item["t_s"].as_double(kSimulatedTimeRange);
      if (command.t_s <= previous_t) item["t_s"].fail("command times must increase");
      previous_t = command.t_s;
      command.v_mps = item.get_double("v_mps", 0.0, VelocityCommand::kSpeedRange);
      command.w_radps = item.get_double("w_radps", 0.0, VelocityCommand::kTurnRateRange);
      drive.commands.push_back(command);
    }
  } else if (mode_name == "wander") {
    drive.mode = DriveDef::Mode::kWander;
    only({"speed_mps", "max_turn_rate_radps", "clearance_m", "clearance_check_hz"});
    drive.clearance_m =
        node.get_double("clearance_m", drive.clearance_m, DriveDef::kClearanceRange);
    drive.clearance_check_hz = node.get_double("clearance_check_hz", drive.clearance_check_hz,
                                               DriveDef::kClearanceCheckRange);
  } else if (mode_name == "trajectory") {
    drive.mode = DriveDef::Mode::kTrajectory;
    only({"poses", "poses_file"});
    if (node.has("poses") == node.has("poses_file"))
      node["mode"].fail("a trajectory takes either 'poses' or 'poses_file'");
    if (const auto file = node.find("poses_file")) {
      // A recorded path is long (a robot's 15 minutes at 10 Hz: 9000 poses): a TUM file beside
      // the scenario, as trajectory tools write them, keeps it out of the YAML.
      const std::filesystem::path tum = base_dir / file->as_string();
      drive.trajectory = read_tum(tum, true);
      drive.poses_file = tum;
      for (const StampedPose& sample : drive.trajectory) {
        if (!kSimulatedTimeRange.contains(sample.t_s) ||
            !kWorldCoordinateRange.contains(sample.pose.x) ||
            !kWorldCoordinateRange.contains(sample.pose.y)) {
          file->fail(tum.string() + ": the pose at " + short_number(sample.t_s) +
                     " s is outside the simulated time or world coordinate range");
        }
      }
    } else {
      double previous_t = -1.0;
      for (const YamlNode& item : node["poses"].items()) {
        const std::vector<YamlNode> values = item.items();
        if (values.size() != 4) item.fail("a pose is [t_s, x_m, y_m, theta_rad]");
        StampedPose sample;
        sample.t_s = values[0].as_double(kSimulatedTimeRange);
        if (sample.t_s <= previous_t) values[0].fail("pose times must increase");
        previous_t = sample.t_s;
        sample.pose = {values[1].as_double(kWorldCoordinateRange),
                       values[2].as_double(kWorldCoordinateRange),
                       values[3].as_double(kHeadingRange)};
        drive.trajectory.push_back(sample);
      }
    }
    if (drive.trajectory.empty()) node["mode"].fail("a trajectory needs at least one pose");
  } else {
    mode.fail("unknown mode (known: idle, waypoints, velocity, wander, trajectory)");
  }
  return drive;
}

EventDef parse_event(const YamlNode& node) {
  static constexpr std::array<std::string_view, 6> kKinds = {"kidnap",   "push",         "friction",
                                                             "obstacle", "sensor_fault", "end"};
  node.allow_keys({"at_s", "kidnap", "push", "friction", "obstacle", "sensor_fault", "end"});
  EventDef event;
  event.where = node.where();
  event.at_s = node["at_s"].as_double(kSimulatedTimeRange);
  int kinds_given = 0;
  for (const std::string_view kind : kKinds) kinds_given += node.has(kind) ? 1 : 0;
  if (kinds_given != 1)
    node.fail(
        "an event has 'at_s' and exactly one of: kidnap, push, friction, obstacle, sensor_fault, "
        "end");

  if (const auto kidnap = node.find("kidnap")) {
    event.kind = EventDef::Kind::kKidnap;
    event.key_path = kidnap->path();
    kidnap->allow_keys({"robot", "to", "within", "carry_s"});
    event.robot = kidnap->get_string("robot", "");
    const YamlNode to = (*kidnap)["to"];
    if (to.is_scalar()) {
      if (to.as_string() != "random") to.fail("expected a pose {x, y, theta} or 'random'");
      if (const auto within = kidnap->find("within")) {
        within->allow_keys({"min", "max"});
        event.random_min_m = (*within)["min"].as_vec2(kWorldCoordinateRange);
        event.random_max_m = (*within)["max"].as_vec2(kWorldCoordinateRange);
        if (!(event.random_max_m->x() > event.random_min_m->x() &&
              event.random_max_m->y() > event.random_min_m->y())) {
          within->fail("'max' must exceed 'min' in x and y");
        }
      }
    } else {
      event.to = to.as_pose(kWorldCoordinateRange);
      if (kidnap->has("within")) (*kidnap)["within"].fail("only with 'to: random'");
    }
    event.carry_s = kidnap->get_double("carry_s", 0.0, kSimulatedTimeRange);
  } else if (const auto push = node.find("push")) {
    event.kind = EventDef::Kind::kPush;
    event.key_path = push->path();
    push->allow_keys({"robot", "impulse_ns", "angular_impulse_nms"});
    event.robot = push->get_string("robot", "");
    if (const auto impulse = push->find("impulse_ns"))
      event.impulse_ns = impulse->as_vec2(EventDef::kImpulseRange);
    event.angular_impulse_nms =
        push->get_double("angular_impulse_nms", 0.0, EventDef::kAngularImpulseRange);
  } else if (const auto friction = node.find("friction")) {
    event.kind = EventDef::Kind::kFriction;
    event.key_path = friction->path();
    friction->allow_keys({"region", "friction"});
    event.region = (*friction)["region"].as_string();
    event.friction = (*friction)["friction"].as_double(kFrictionRange);
  } else if (const auto obstacle = node.find("obstacle")) {
    event.kind = EventDef::Kind::kObstacle;
    event.key_path = obstacle->path();
    obstacle->allow_keys({"name", "action"});
    event.obstacle = (*obstacle)["name"].as_string();
    const YamlNode action = (*obstacle)["action"];
    const std::string action_name = action.as_string();
    if (action_name != "start" && action_name != "stop") action.fail("expected 'start' or 'stop'");
    event.start_moving = action_name == "start";
  } else if (const auto fault = node.find("sensor_fault")) {
    event.kind = EventDef::Kind::kSensorFault;
    event.key_path = fault->path();
    fault->allow_keys({"robot", "sensor", "mode", "duration_s", "bias"});
    event.robot = fault->get_string("robot", "");
    const YamlNode sensor = (*fault)["sensor"];
    event.sensor = sensor.as_string();
    if (!sensor_kind(event.sensor)) sensor.fail("unknown sensor (known: " + sensor_names() + ")");
    const YamlNode mode = (*fault)["mode"];
    const std::string mode_name = mode.as_string();
    if (mode_name == "dropout") {
      event.fault.mode = SensorFaultDef::Mode::kDropout;
    } else if (mode_name == "stuck") {
      event.fault.mode = SensorFaultDef::Mode::kStuck;
    } else if (mode_name == "bias") {
      event.fault.mode = SensorFaultDef::Mode::kBias;
      event.fault.bias = (*fault)["bias"].as_double(SensorFaultDef::kBiasRange);
      if (event.sensor == "encoders") mode.fail("encoders take dropout or stuck faults, not bias");
    } else {
      mode.fail("expected dropout, stuck or bias");
    }
    if (event.fault.mode != SensorFaultDef::Mode::kBias && fault->has("bias")) {
      (*fault)["bias"].fail("only with mode: bias");
    }
    event.fault.duration_s = fault->get_double("duration_s", 0.0, kSimulatedTimeRange);
  } else {
    event.kind = EventDef::Kind::kEnd;
    event.key_path = node.path() + ".end";
    const YamlNode end = node["end"];
    if (!end.is_null()) end.allow_keys({});
  }
  return event;
}

PanPolicyDef parse_pan_policy(const YamlNode& node) {
  node.allow_keys({"robot", "policy", "pan", "pan_deg", "sweep_min", "sweep_min_deg", "sweep_max",
                   "sweep_max_deg", "sweep_rate", "sweep_rate_deg"});
  PanPolicyDef policy;
  policy.where = node.where();
  policy.key_path = node.path();
  policy.robot = node.get_string("robot", "");
  const YamlNode mode = node["policy"];
  const std::string name = mode.as_string();
  if (name == "fixed") {
    policy.mode = PanPolicyDef::Mode::kFixed;
  } else if (name == "sweep") {
    policy.mode = PanPolicyDef::Mode::kSweep;
  } else if (name == "nearest_landmark") {
    policy.mode = PanPolicyDef::Mode::kNearestLandmark;
  } else {
    mode.fail("expected fixed, sweep or nearest_landmark");
  }
  policy.pan_rad = node.get_angle("pan", policy.pan_rad, PanPolicyDef::kPanRange);
  policy.sweep_min_rad = node.get_angle("sweep_min", policy.sweep_min_rad, PanPolicyDef::kPanRange);
  policy.sweep_max_rad = node.get_angle("sweep_max", policy.sweep_max_rad, PanPolicyDef::kPanRange);
  if (policy.sweep_min_rad > policy.sweep_max_rad) node.fail("sweep_min exceeds sweep_max");
  policy.sweep_rate_radps =
      node.get_angle("sweep_rate", policy.sweep_rate_radps, PanPolicyDef::kSweepRateRange);
  return policy;
}

}  // namespace

ScenarioDef parse_scenario(const YamlNode& node, const std::filesystem::path& base_dir) {
  node.allow_keys(
      {"name", "duration_s", "groundtruth_hz", "drive", "ptz", "localization", "events"});
  ScenarioDef scenario;
  scenario.name = node.get_string("name", scenario.name);
  scenario.duration_s =
      node.get_double("duration_s", scenario.duration_s, ScenarioDef::kDurationRange);
  scenario.groundtruth_hz = node.get_double("groundtruth_hz", scenario.groundtruth_hz,
                                            ScenarioDef::kGroundTruthRateRange);
  scenario.groundtruth_hz_place = place_of(node, "groundtruth_hz");
  scenario.localization.grid_resolution_place = place_of(node, "localization.grid_resolution_m");
  if (const auto drive = node.find("drive")) {
    if (drive->is_sequence()) {
      for (const YamlNode& item : drive->items())
        scenario.drives.push_back(parse_drive(item, base_dir));
    } else {
      scenario.drives.push_back(parse_drive(*drive, base_dir));
    }
  }
  if (const auto localization = node.find("localization")) {
    localization->allow_keys({"initial_pose", "landmarks_known", "sigma_xy_m", "sigma_theta",
                              "sigma_theta_deg", "grid_resolution_m"});
    LocalizationDef& l = scenario.localization;
    if (const auto initial = localization->find("initial_pose")) {
      const std::string value = initial->as_string();
      if (value != "known" && value != "unknown") initial->fail("expected 'known' or 'unknown'");
      l.initial_pose_known = value == "known";
    }
    l.landmarks_known = localization->get_bool("landmarks_known", l.landmarks_known);
    l.sigma_xy_m =
        localization->get_double("sigma_xy_m", l.sigma_xy_m, LocalizationDef::kSigmaXyRange);
    l.sigma_theta_rad = localization->get_angle("sigma_theta", l.sigma_theta_rad,
                                                LocalizationDef::kSigmaThetaRange);
    l.grid_resolution_m = localization->get_double("grid_resolution_m", l.grid_resolution_m,
                                                   LocalizationDef::kGridResolutionRange);
    l.grid_resolution_place = place_of(*localization, "grid_resolution_m");
  }
  if (const auto ptz = node.find("ptz")) {
    if (ptz->is_sequence()) {
      for (const YamlNode& item : ptz->items())
        scenario.pan_policies.push_back(parse_pan_policy(item));
    } else {
      scenario.pan_policies.push_back(parse_pan_policy(*ptz));
    }
  }
  if (const auto events = node.find("events")) {
    for (const YamlNode& item : events->items()) scenario.events.push_back(parse_event(item));
  }
  std::stable_sort(scenario.events.begin(), scenario.events.end(),
                   [](const EventDef& a, const EventDef& b) { return a.at_s < b.at_s; });
  return scenario;
}

ScenarioDef load_scenario(const std::filesystem::path& file) {
  ScenarioDef scenario = parse_scenario(YamlNode::load_file(file), file.parent_path());
  scenario.source = file;
  return scenario;
}

void bind_scenario(ScenarioDef& scenario, const WorldDef& world) {
  const auto bind_robot = [&](std::string& robot, const SourceLocation& where,
                              const std::string& parent_path, const std::string& what) {
    const std::string key = parent_path + ".robot";
    if (robot.empty()) {
      if (world.robots.size() != 1) {
        throw InputError(where, key,
                         what + " must name its robot: the world has " +
                             std::to_string(world.robots.size()) + " robots");
      }
      robot = world.robots.front().name;
      return;
    }
    const bool known = std::any_of(world.robots.begin(), world.robots.end(),
                                   [&](const RobotDef& r) { return r.name == robot; });
    if (!known) throw InputError(where, key, "no robot called '" + robot + "' in the world");
  };
  std::vector<std::string> driven;
  for (DriveDef& drive : scenario.drives) {
    bind_robot(drive.robot, drive.where, drive.key_path, "a drive");
    if (std::find(driven.begin(), driven.end(), drive.robot) != driven.end()) {
      throw InputError(drive.where, drive.key_path + ".robot",
                       "robot '" + drive.robot + "' has two drives");
    }
    driven.push_back(drive.robot);
  }
  for (PanPolicyDef& policy : scenario.pan_policies) {
    bind_robot(policy.robot, policy.where, policy.key_path, "a ptz policy");
    const auto robot = std::find_if(world.robots.begin(), world.robots.end(),
                                    [&](const RobotDef& r) { return r.name == policy.robot; });
    const auto same_robot = [&](const PanPolicyDef& other) { return other.robot == policy.robot; };
    if (std::count_if(scenario.pan_policies.begin(), scenario.pan_policies.end(), same_robot) > 1) {
      throw InputError(policy.where, policy.key_path,
                       "robot '" + policy.robot + "' has two ptz policies");
    }
    if (!robot->sensors.ptz_camera) {
      throw InputError(policy.where, policy.key_path,
                       "robot '" + policy.robot + "' has no ptz_camera");
    }
  }
  // Checks made before a place is known (a scenario from no file) still name the scenario's file.
  const auto at = [&](InputPlace place) {
    if (place.where.file.empty()) place.where.file = scenario.source.string();
    return place;
  };
  if (const std::string problem =
          divides_physics_rate(scenario.groundtruth_hz, world.physics.step_hz);
      !problem.empty()) {
    throw InputError(at(scenario.groundtruth_hz_place), problem);
  }
  InputPlace grid_place = at(scenario.localization.grid_resolution_place);
  if (grid_place.key.empty()) grid_place.key = "localization.grid_resolution_m";
  check_grid_memory(world, scenario.localization.grid_resolution_m, grid_place);
  for (EventDef& event : scenario.events) {
    switch (event.kind) {
      case EventDef::Kind::kKidnap:
        bind_robot(event.robot, event.where, event.key_path, "a kidnap");
        break;
      case EventDef::Kind::kPush:
        bind_robot(event.robot, event.where, event.key_path, "a push");
        break;
      case EventDef::Kind::kFriction: {
        const bool known =
            event.region == "floor" ||
            std::any_of(world.floor.regions.begin(), world.floor.regions.end(),
                        [&](const FloorRegionDef& r) { return r.name == event.region; });
        if (!known) {
          throw InputError(event.where, event.key_path + ".region",
                           "no floor region called '" + event.region + "' (or use 'floor')");
        }
        break;
      }
      case EventDef::Kind::kObstacle: {
        const bool known = std::any_of(world.movers.begin(), world.movers.end(),
                                       [&](const MoverDef& m) { return m.name == event.obstacle; });
        if (!known) {
          throw InputError(event.where, event.key_path + ".name",
                           "no mover called '" + event.obstacle + "' in the world");
        }
        break;
      }
      case EventDef::Kind::kSensorFault: {
        bind_robot(event.robot, event.where, event.key_path, "a sensor fault");
        const RobotDef& robot =
            *std::find_if(world.robots.begin(), world.robots.end(),
                          [&](const RobotDef& r) { return r.name == event.robot; });
        const std::optional<SensorKind> kind = sensor_kind(event.sensor);
        if (!kind || sensor_common(robot.sensors, *kind) == nullptr) {
          throw InputError(event.where, event.key_path + ".sensor",
                           "robot '" + event.robot + "' has no " + event.sensor);
        }
        break;
      }
      case EventDef::Kind::kEnd:
        break;
    }
  }
}

}  // namespace locsim
