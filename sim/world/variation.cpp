#include "sim/world/variation.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "sim/common/random.hpp"
#include "sim/world/physics_world.hpp"

namespace locsim {

namespace {

using json = nlohmann::ordered_json;

/// A standard normal draw cut at 3: no tolerance can make a radius negative or a robot start
/// metres away from where the file puts it.
double cut_normal(RandomStream& rng) {
  return std::clamp(rng.normal(), -3.0, 3.0);
}

/// 1 + N(0, rel^2), cut at 3 sigma, from the stream `name`.
double factor(std::uint64_t seed, const std::string& name, double rel) {
  RandomStream rng = make_stream(seed, "variation/" + name);
  return 1.0 + rel * cut_normal(rng);
}

double clamp_to(double value, const Range& range) {
  return std::clamp(value, range.min, range.max);
}

/// Length of a looping path, closing segment included. [m]
double loop_length_m(const std::vector<Vec2>& path_m) {
  double length = 0.0;
  for (std::size_t i = 0; i < path_m.size(); ++i)
    length += (path_m[(i + 1) % path_m.size()] - path_m[i]).norm();
  return length;
}

/// The same loop, starting `phase_m` along it: a point on the segment it falls in, then the
/// waypoints from the segment's end round to its start.
std::vector<Vec2> rotate_loop(const std::vector<Vec2>& path_m, double phase_m) {
  const std::size_t n = path_m.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2 a = path_m[i], b = path_m[(i + 1) % n];
    const double length = (b - a).norm();
    if (phase_m < length || i + 1 == n) {
      std::vector<Vec2> out{a + (b - a) * (length > 0.0 ? std::min(phase_m / length, 1.0) : 0.0)};
      for (std::size_t k = 1; k <= n; ++k) out.push_back(path_m[(i + k) % n]);
      // The start point may fall on a waypoint: keep consecutive points apart, as the loader does.
      if ((out[1] - out[0]).norm() < kMinPointSpacingM) out.erase(out.begin() + 1);
      if (out.size() > 1 && (out.back() - out.front()).norm() < kMinPointSpacingM) out.pop_back();
      return out;
    }
    phase_m -= length;
  }
  return path_m;
}

/// True when a disc of `radius_m` at `at` overlaps none of the robots' start footprints (their
/// bounding circles), the first `drawn_count` at their drawn starts, the rest at their declared
/// ones; `skip` is the robot being placed (or none).
bool clear_of_robots(const Vec2& at, double radius_m, const WorldDef& world,
                     const std::vector<DrawnVariation::Robot>& drawn, std::size_t skip) {
  for (std::size_t r = 0; r < world.robots.size(); ++r) {
    if (r == skip) continue;
    const Vec2 start =
        r < drawn.size() ? drawn[r].start.position() : world.robots[r].start.position();
    if ((at - start).norm() <= radius_m + bounding_radius(world.robots[r].footprint)) return false;
  }
  return true;
}

const DriveDef* drive_of(const ScenarioDef& scenario, const std::string& robot) {
  for (const DriveDef& d : scenario.drives) {
    if (d.robot == robot) return &d;
  }
  return nullptr;
}

}  // namespace

DrawnVariation draw_variation(const WorldDef& world, const ScenarioDef& scenario,
                              std::uint64_t seed) {
  DrawnVariation out;
  const VariationDef& v = world.variation;
  if (!v.enabled) return out;
  out.applied = true;
  out.floor_friction =
      clamp_to(world.floor.friction * factor(seed, "floor", v.friction_rel), kFrictionRange);
  for (std::size_t i = 0; i < world.floor.regions.size(); ++i) {
    const FloorRegionDef& region = world.floor.regions[i];
    const std::string name = region.name.empty() ? std::to_string(i) : region.name;
    out.region_friction.push_back(
        clamp_to(region.friction * factor(seed, "region/" + name, v.friction_rel), kFrictionRange));
  }

  // Free space is judged against the static geometry only: the movers' starts are drawn below,
  // clear of the robots'.
  const PhysicsWorld physics(world);
  for (std::size_t r = 0; r < world.robots.size(); ++r) {
    const RobotDef& robot = world.robots[r];
    const std::string base = "robot/" + robot.name + "/";
    DrawnVariation::Robot drawn;
    drawn.name = robot.name;
    drawn.wheel_radius_left_m = clamp_to(
        robot.wheel_radius_left_m * factor(seed, base + "wheel_radius_left", v.wheel_radius_rel),
        RobotDef::kWheelRadiusRange);
    drawn.wheel_radius_right_m = clamp_to(
        robot.wheel_radius_right_m * factor(seed, base + "wheel_radius_right", v.wheel_radius_rel),
        RobotDef::kWheelRadiusRange);
    drawn.wheel_base_m =
        clamp_to(robot.wheel_base_m * factor(seed, base + "wheel_base", v.wheel_base_rel),
                 RobotDef::kWheelBaseRange);
    drawn.max_wheel_accel_radps2 =
        clamp_to(robot.max_wheel_accel_radps2 * factor(seed, base + "motor_accel", v.motor_rel),
                 RobotDef::kWheelAccelRange);
    drawn.max_wheel_torque_nm =
        clamp_to(robot.max_wheel_torque_nm * factor(seed, base + "motor_torque", v.motor_rel),
                 RobotDef::kWheelTorqueRange);
    drawn.start = robot.start;
    // A robot that follows a recorded trajectory (a twin) starts where the recording does.
    const DriveDef* drive = drive_of(scenario, robot.name);
    if (drive == nullptr || drive->mode != DriveDef::Mode::kTrajectory) {
      b2CircleShape circle;
      b2PolygonShape polygon;
      const b2Shape& shape = make_shape(robot.footprint, circle, polygon);
      const double radius_m = bounding_radius(robot.footprint);
      RandomStream rng = make_stream(seed, "variation/" + base + "start");
      for (int attempt = 0; attempt < kFreeTries; ++attempt) {
        // One draw per statement: the order is the stream's, on every compiler.
        const double dx = v.start_xy_m * cut_normal(rng);
        const double dy = v.start_xy_m * cut_normal(rng);
        const double dtheta = v.start_theta_rad * cut_normal(rng);
        const Pose2 pose{robot.start.x + dx, robot.start.y + dy,
                         wrap_angle(robot.start.theta + dtheta)};
        // Clear of the robots placed before it (drawn) and after it (declared).
        const bool free = physics.is_free_of_static(shape, pose) &&
                          clear_of_robots(pose.position(), radius_m, world, out.robots, r);
        if (free) {
          drawn.start = pose;
          break;
        }
      }
    }
    out.robots.push_back(drawn);
  }

  for (const MoverDef& mover : world.movers) {
    DrawnVariation::Mover drawn;
    drawn.name = mover.name;
    drawn.speed_mps = clamp_to(
        mover.speed_mps * factor(seed, "mover/" + mover.name + "/speed", v.mover_speed_rel),
        MoverDef::kSpeedRange);
    if (v.mover_phase && mover.loop && mover.path_m.size() >= 2) {
      RandomStream rng = make_stream(seed, "variation/mover/" + mover.name + "/phase");
      const double length_m = loop_length_m(mover.path_m);
      const double radius_m = bounding_radius(mover.footprint);
      for (int attempt = 0; attempt < kFreeTries; ++attempt) {
        const double phase_m = rng.uniform(0.0, length_m);
        const Vec2 at = rotate_loop(mover.path_m, phase_m).front();
        const bool free = clear_of_robots(at, radius_m, world, out.robots, world.robots.size());
        if (free) {
          drawn.phase_m = phase_m;
          break;
        }
      }
    }
    out.movers.push_back(drawn);
  }

  for (const DriveDef& drive : scenario.drives) {
    if (drive.mode != DriveDef::Mode::kWaypoints) continue;
    const RobotDef* robot = nullptr;
    for (const RobotDef& r : world.robots) {
      if (r.name == drive.robot) robot = &r;
    }
    if (robot == nullptr) continue;  // bind_scenario names every drive's robot
    b2CircleShape circle;
    circle.m_radius = static_cast<float>(bounding_radius(robot->footprint));
    RandomStream rng = make_stream(seed, "variation/drive/" + drive.robot + "/waypoints");
    DrawnVariation::Drive drawn{drive.robot, drive.path_m};
    for (Vec2& point : drawn.path_m) {
      for (int attempt = 0; attempt < kFreeTries; ++attempt) {
        // Not Vec2(draw, draw): a constructor's arguments are evaluated in an order the compiler
        // picks (gcc right to left, clang left to right), which made the two builds' worlds differ.
        const double dx = v.waypoint_m * cut_normal(rng);
        const double dy = v.waypoint_m * cut_normal(rng);
        const Vec2 moved = point + Vec2(dx, dy);
        if (physics.is_free_of_static(circle, Pose2{moved.x(), moved.y(), 0.0})) {
          point = moved;
          break;
        }
      }
    }
    out.drives.push_back(std::move(drawn));
  }
  return out;
}

void apply_variation(const DrawnVariation& drawn, WorldDef& world, ScenarioDef& scenario) {
  if (!drawn.applied) return;
  const auto mismatch = [&](const std::string& what) {
    throw InputError("the recorded world variation does not fit world '" + world.name +
                     "': " + what);
  };
  if (drawn.robots.size() != world.robots.size()) mismatch("another number of robots");
  if (drawn.movers.size() != world.movers.size()) mismatch("another number of movers");
  if (drawn.region_friction.size() != world.floor.regions.size())
    mismatch("another number of floor regions");
  world.floor.friction = drawn.floor_friction;
  for (std::size_t i = 0; i < drawn.region_friction.size(); ++i)
    world.floor.regions[i].friction = drawn.region_friction[i];
  for (std::size_t r = 0; r < drawn.robots.size(); ++r) {
    const DrawnVariation::Robot& d = drawn.robots[r];
    RobotDef& robot = world.robots[r];
    if (d.name != robot.name) mismatch("robot '" + d.name + "' is not robot '" + robot.name + "'");
    // The encoders (and the localizers) keep the declared geometry: the drawn one is the error.
    if (robot.sensors.encoders && !robot.sensors.encoders->odometry_wheel_base_m)
      robot.sensors.encoders->odometry_wheel_base_m = robot.wheel_base_m;
    robot.wheel_radius_left_m = d.wheel_radius_left_m;
    robot.wheel_radius_right_m = d.wheel_radius_right_m;
    robot.wheel_base_m = d.wheel_base_m;
    robot.max_wheel_accel_radps2 = d.max_wheel_accel_radps2;
    robot.max_wheel_torque_nm = d.max_wheel_torque_nm;
    robot.start = d.start;
  }
  for (std::size_t m = 0; m < drawn.movers.size(); ++m) {
    const DrawnVariation::Mover& d = drawn.movers[m];
    MoverDef& mover = world.movers[m];
    if (d.name != mover.name) mismatch("mover '" + d.name + "' is not mover '" + mover.name + "'");
    mover.speed_mps = d.speed_mps;
    if (d.phase_m > 0.0) mover.path_m = rotate_loop(mover.path_m, d.phase_m);
  }
  std::size_t next = 0;
  for (DriveDef& drive : scenario.drives) {
    if (drive.mode != DriveDef::Mode::kWaypoints) continue;
    if (next >= drawn.drives.size() || drawn.drives[next].robot != drive.robot ||
        drawn.drives[next].path_m.size() != drive.path_m.size()) {
      mismatch("another waypoints drive for robot '" + drive.robot + "'");
    }
    drive.path_m = drawn.drives[next++].path_m;
  }
  if (next != drawn.drives.size()) mismatch("another number of waypoints drives");
  world.drawn = drawn;
}

void vary_world(WorldDef& world, ScenarioDef& scenario, std::uint64_t seed) {
  apply_variation(draw_variation(world, scenario, seed), world, scenario);
}

json to_json(const DrawnVariation& drawn) {
  json robots = json::array(), movers = json::array(), drives = json::array();
  for (const auto& r : drawn.robots) {
    robots.push_back({{"name", r.name},
                      {"wheel_radius_left_m", r.wheel_radius_left_m},
                      {"wheel_radius_right_m", r.wheel_radius_right_m},
                      {"wheel_base_m", r.wheel_base_m},
                      {"max_wheel_accel_radps2", r.max_wheel_accel_radps2},
                      {"max_wheel_torque_nm", r.max_wheel_torque_nm},
                      {"start", {r.start.x, r.start.y, r.start.theta}}});
  }
  for (const auto& m : drawn.movers) {
    movers.push_back({{"name", m.name}, {"speed_mps", m.speed_mps}, {"phase_m", m.phase_m}});
  }
  for (const auto& d : drawn.drives) {
    json path = json::array();
    for (const Vec2& p : d.path_m) path.push_back({p.x(), p.y()});
    drives.push_back({{"robot", d.robot}, {"path", std::move(path)}});
  }
  return {{"floor_friction", drawn.floor_friction},
          {"region_friction", drawn.region_friction},
          {"robots", std::move(robots)},
          {"movers", std::move(movers)},
          {"drives", std::move(drives)}};
}

DrawnVariation drawn_variation_from_json(const nlohmann::json& record) {
  DrawnVariation out;
  try {
    out.applied = true;
    out.floor_friction = record.at("floor_friction").get<double>();
    out.region_friction = record.at("region_friction").get<std::vector<double>>();
    for (const auto& r : record.at("robots")) {
      const auto start = r.at("start").get<std::vector<double>>();
      if (start.size() != 3) throw InputError("a start pose is not [x, y, theta]");
      out.robots.push_back({r.at("name").get<std::string>(),
                            r.at("wheel_radius_left_m").get<double>(),
                            r.at("wheel_radius_right_m").get<double>(),
                            r.at("wheel_base_m").get<double>(),
                            r.at("max_wheel_accel_radps2").get<double>(),
                            r.at("max_wheel_torque_nm").get<double>(),
                            {start[0], start[1], start[2]}});
    }
    for (const auto& m : record.at("movers")) {
      out.movers.push_back({m.at("name").get<std::string>(), m.at("speed_mps").get<double>(),
                            m.at("phase_m").get<double>()});
    }
    for (const auto& d : record.at("drives")) {
      DrawnVariation::Drive drive{d.at("robot").get<std::string>(), {}};
      for (const auto& p : d.at("path")) {
        const auto xy = p.get<std::vector<double>>();
        if (xy.size() != 2) throw InputError("a waypoint is not [x, y]");
        drive.path_m.emplace_back(xy[0], xy[1]);
      }
      out.drives.push_back(std::move(drive));
    }
  } catch (const nlohmann::json::exception& e) {
    throw InputError(std::string("the recorded world variation: ") + e.what());
  }
  return out;
}

}  // namespace locsim
