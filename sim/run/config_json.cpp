#include "sim/run/config_json.hpp"

namespace locsim {

using json = nlohmann::ordered_json;

namespace {
json point(const Vec2& p) {
  return json::array({p.x(), p.y()});
}
json points(const std::vector<Vec2>& ps) {
  json out = json::array();
  for (const Vec2& p : ps) out.push_back(point(p));
  return out;
}
json pose(const Pose2& p) {
  return json{{"x", p.x}, {"y", p.y}, {"theta", p.theta}};
}
json footprint(const FootprintDef& f) {
  switch (f.kind) {
    case FootprintDef::Kind::kCircle:
      return json{{"radius_m", f.radius_m}};
    case FootprintDef::Kind::kBox:
      return json{{"box_m", point(f.size_m)}};
    case FootprintDef::Kind::kPolygon:
      return json{{"polygon", points(f.points_m)}};
  }
  return json{};
}
const char* mode_name(DriveDef::Mode mode) {
  switch (mode) {
    case DriveDef::Mode::kIdle:
      return "idle";
    case DriveDef::Mode::kWaypoints:
      return "waypoints";
    case DriveDef::Mode::kVelocity:
      return "velocity";
    case DriveDef::Mode::kWander:
      return "wander";
  }
  return "?";
}
}  // namespace

json to_json(const WorldDef& w) {
  json out;
  out["name"] = w.name;
  out["source"] = w.source.string();
  out["physics"] = {{"step_hz", w.physics.step_hz},
                    {"velocity_iterations", w.physics.velocity_iterations},
                    {"position_iterations", w.physics.position_iterations},
                    {"gravity_mps2", w.physics.gravity_mps2}};
  json regions = json::array();
  for (const FloorRegionDef& r : w.floor.regions) {
    regions.push_back(
        {{"name", r.name}, {"friction", r.friction}, {"polygon", points(r.polygon_m)}});
  }
  out["floor"] = {{"friction", w.floor.friction}, {"regions", regions}};
  json walls = json::array();
  for (const WallDef& wall : w.walls) {
    walls.push_back({{"points", points(wall.points_m)},
                     {"closed", wall.closed},
                     {"thickness_m", wall.thickness_m}});
  }
  out["walls"] = walls;
  json boxes = json::array();
  for (const BoxDef& b : w.boxes) {
    boxes.push_back(
        {{"center", point(b.center_m)}, {"size", point(b.size_m)}, {"angle", b.angle_rad}});
  }
  out["boxes"] = boxes;
  json circles = json::array();
  for (const CircleDef& c : w.circles) {
    circles.push_back({{"center", point(c.center_m)}, {"radius_m", c.radius_m}});
  }
  out["circles"] = circles;
  json polygons = json::array();
  for (const PolygonDef& p : w.polygons) polygons.push_back({{"points", points(p.points_m)}});
  out["polygons"] = polygons;
  if (w.map) {
    out["map"] = {{"yaml", w.map->yaml_file.string()},
                  {"image", w.map->image_file.string()},
                  {"resolution", w.map->resolution_m},
                  {"origin", json::array({w.map->origin.x, w.map->origin.y, w.map->origin.theta})},
                  {"occupied_thresh", w.map->occupied_thresh},
                  {"free_thresh", w.map->free_thresh},
                  {"negate", w.map->negate},
                  {"size_px", json::array({w.map->width_px, w.map->height_px})}};
  }
  json landmarks = json::array();
  for (const LandmarkDef& l : w.landmarks) {
    json color = l.color_name.empty() ? json::array({l.color[0], l.color[1], l.color[2]})
                                      : json(l.color_name);
    landmarks.push_back({{"id", l.id},
                         {"position", point(l.position_m)},
                         {"color", color},
                         {"radius_m", l.radius_m},
                         {"height_m", l.height_m}});
  }
  out["landmarks"] = landmarks;
  json beacons = json::array();
  for (const BeaconDef& b : w.beacons) {
    beacons.push_back({{"id", b.id}, {"position", point(b.position_m)}, {"height_m", b.height_m}});
  }
  out["beacons"] = beacons;
  json movers = json::array();
  for (const MoverDef& m : w.movers) {
    movers.push_back({{"name", m.name},
                      {"kind", m.kind},
                      {"footprint", footprint(m.footprint)},
                      {"path", points(m.path_m)},
                      {"speed_mps", m.speed_mps},
                      {"loop", m.loop},
                      {"moving", m.moving}});
  }
  out["movers"] = movers;
  json robots = json::array();
  for (const RobotDef& r : w.robots) {
    robots.push_back({{"name", r.name},
                      {"footprint", footprint(r.footprint)},
                      {"mass_kg", r.mass_kg},
                      {"wheel_base_m", r.wheel_base_m},
                      {"wheel_radius_m", r.wheel_radius_m},
                      {"wheel_radius_left_m", r.wheel_radius_left_m},
                      {"wheel_radius_right_m", r.wheel_radius_right_m},
                      {"wheel_inertia_kgm2", r.wheel_inertia_kgm2},
                      {"max_wheel_speed_radps", r.max_wheel_speed_radps},
                      {"max_wheel_accel_radps2", r.max_wheel_accel_radps2},
                      {"max_wheel_torque_nm", r.max_wheel_torque_nm},
                      {"drive_load_fraction", r.drive_load_fraction},
                      {"start", pose(r.start)}});
  }
  out["robots"] = robots;
  return out;
}

json to_json(const ScenarioDef& s) {
  json out;
  out["name"] = s.name;
  out["source"] = s.source.string();
  out["duration_s"] = s.duration_s;
  out["groundtruth_hz"] = s.groundtruth_hz;
  json drives = json::array();
  for (const DriveDef& d : s.drives) {
    json drive = {{"robot", d.robot}, {"mode", mode_name(d.mode)}};
    switch (d.mode) {
      case DriveDef::Mode::kIdle:
        break;
      case DriveDef::Mode::kWaypoints:
        drive["path"] = points(d.path_m);
        drive["loop"] = d.loop;
        drive["speed_mps"] = d.speed_mps;
        drive["max_turn_rate_radps"] = d.max_turn_rate_radps;
        drive["tolerance_m"] = d.tolerance_m;
        drive["heading_gain"] = d.heading_gain;
        break;
      case DriveDef::Mode::kVelocity: {
        json commands = json::array();
        for (const VelocityCommand& c : d.commands) {
          commands.push_back({{"t_s", c.t_s}, {"v_mps", c.v_mps}, {"w_radps", c.w_radps}});
        }
        drive["commands"] = commands;
        break;
      }
      case DriveDef::Mode::kWander:
        drive["speed_mps"] = d.speed_mps;
        drive["max_turn_rate_radps"] = d.max_turn_rate_radps;
        drive["clearance_m"] = d.clearance_m;
        break;
    }
    drives.push_back(drive);
  }
  out["drive"] = drives;
  json events = json::array();
  for (const EventDef& e : s.events) {
    json event = {{"at_s", e.at_s}};
    switch (e.kind) {
      case EventDef::Kind::kKidnap: {
        json kidnap = {{"robot", e.robot}, {"carry_s", e.carry_s}};
        if (e.to) {
          kidnap["to"] = pose(*e.to);
        } else {
          kidnap["to"] = "random";
          if (e.random_min_m) {
            kidnap["within"] = {{"min", point(*e.random_min_m)}, {"max", point(*e.random_max_m)}};
          }
        }
        event["kidnap"] = kidnap;
        break;
      }
      case EventDef::Kind::kPush:
        event["push"] = {{"robot", e.robot},
                         {"impulse_ns", point(e.impulse_ns)},
                         {"angular_impulse_nms", e.angular_impulse_nms}};
        break;
      case EventDef::Kind::kFriction:
        event["friction"] = {{"region", e.region}, {"friction", e.friction}};
        break;
      case EventDef::Kind::kObstacle:
        event["obstacle"] = {{"name", e.obstacle}, {"action", e.start_moving ? "start" : "stop"}};
        break;
      case EventDef::Kind::kEnd:
        event["end"] = json::object();
        break;
    }
    events.push_back(event);
  }
  out["events"] = events;
  return out;
}

}  // namespace locsim
