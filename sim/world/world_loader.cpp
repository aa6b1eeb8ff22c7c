#include "sim/world/world_loader.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "sim/common/files.hpp"
#include "sim/common/format.hpp"
#include "sim/scenario/scenario_loader.hpp"
#include "sim/sensors/sensor_loader.hpp"
#include "sim/world/pgm.hpp"
#include "sim/world/world_budget.hpp"

namespace locsim {

const std::map<std::string, Rgb>& named_colors() {
  static const std::map<std::string, Rgb> kNamed = {
      {"red", {230, 25, 25}},     {"green", {20, 170, 40}},   {"blue", {30, 80, 230}},
      {"yellow", {240, 210, 20}}, {"cyan", {20, 200, 220}},   {"magenta", {220, 40, 200}},
      {"orange", {255, 130, 0}},  {"purple", {120, 40, 170}}, {"white", {245, 245, 245}},
      {"black", {20, 20, 20}},    {"pink", {255, 140, 180}},  {"brown", {130, 80, 30}},
  };
  return kNamed;
}

namespace {

/// Fails at `node` unless `file` exists. A path the system cannot even look up (a name too long,
/// a component that is not a folder) is bad input too, said as such, not an exception escaping.
void require_file(const YamlNode& node, const std::filesystem::path& file,
                  const std::string& what) {
  std::error_code error;
  const bool found = input_file_exists(file, error);
  if (error)
    node.fail("cannot look up the " + what + " '" + file.string() + "': " + error.message());
  if (!found) node.fail(missing_input_file(file, what));
}

bool is_convex_ccw(const std::vector<Vec2>& points) {
  const std::size_t n = points.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2& a = points[i];
    const Vec2& b = points[(i + 1) % n];
    const Vec2& c = points[(i + 2) % n];
    if (cross(b - a, c - b) <= 1e-12) return false;
  }
  return true;
}

double signed_area(const std::vector<Vec2>& points) {
  double area = 0.0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    area += cross(points[i], points[(i + 1) % points.size()]);
  }
  return 0.5 * area;
}

/// Fails unless consecutive points (and the last and the first, when `closed`) are at least
/// kMinPointSpacingM apart.
void check_spacing(const YamlNode& node, const std::vector<Vec2>& points, bool closed) {
  const std::size_t n = points.size();
  for (std::size_t i = 0; i + 1 < n + (closed ? 1 : 0); ++i) {
    if ((points[(i + 1) % n] - points[i]).norm() < kMinPointSpacingM) {
      node.fail("points " + std::to_string(i) + " and " + std::to_string((i + 1) % n) +
                " are closer than " + rounded_number(kMinPointSpacingM * 100.0) + " cm");
    }
  }
}

/// Box2D polygons: convex, 3..8 vertices, edges of at least kMinPointSpacingM, an area of at least
/// `min_area_m2`. Accepts either winding and stores counter-clockwise.
std::vector<Vec2> convex_polygon(const YamlNode& node, const Range& range, double min_area_m2) {
  std::vector<Vec2> points = node.as_points(3, range);
  if (points.size() > 8)
    node.fail(
        "a polygon has at most 8 vertices (Box2D's limit); split it "
        "or use walls");
  if (signed_area(points) < 0.0) std::reverse(points.begin(), points.end());
  if (!is_convex_ccw(points)) node.fail("polygon must be convex with no repeated points");
  check_spacing(node, points, true);
  if (signed_area(points) < min_area_m2) {
    node.fail("polygon's area " + short_number(signed_area(points)) + " m² is below " +
              rounded_number(min_area_m2) + " m²");
  }
  return points;
}

/// Static shapes have no mass: Box2D only needs their area above its epsilon (1.2e-7 m²).
constexpr double kMinStaticPolygonAreaM2 = 1e-6;

Rgb parse_color(const YamlNode& node, std::string& name_out) {
  const std::map<std::string, Rgb>& kNamed = named_colors();
  if (node.is_scalar()) {
    name_out = node.as_string();
    const auto it = kNamed.find(name_out);
    if (it == kNamed.end()) {
      std::string known;
      for (const auto& [n, rgb] : kNamed) known += (known.empty() ? "" : ", ") + n;
      node.fail("unknown colour '" + name_out + "' (known: " + known + "; or give [r, g, b])");
    }
    return it->second;
  }
  const auto channels = node.items();
  if (channels.size() != 3) node.fail("expected a colour name or [r, g, b] with 0..255 each");
  name_out.clear();
  Rgb rgb{};
  for (std::size_t i = 0; i < 3; ++i)
    rgb[i] = static_cast<unsigned char>(channels[i].as_int(kColorChannelRange));
  return rgb;
}

PhysicsDef parse_physics(const YamlNode& node) {
  node.allow_keys({"step_hz", "velocity_iterations", "position_iterations", "gravity_mps2"});
  PhysicsDef physics;
  physics.step_hz = node.get_double("step_hz", physics.step_hz, PhysicsDef::kStepRange);
  physics.velocity_iterations = static_cast<int>(node.get_int(
      "velocity_iterations", physics.velocity_iterations, PhysicsDef::kIterationsRange));
  physics.position_iterations = static_cast<int>(node.get_int(
      "position_iterations", physics.position_iterations, PhysicsDef::kIterationsRange));
  physics.gravity_mps2 =
      node.get_double("gravity_mps2", physics.gravity_mps2, PhysicsDef::kGravityRange);
  return physics;
}

VariationDef parse_variation(const YamlNode& node) {
  VariationDef v;
  if (node.is_scalar()) {
    if (node.as_string() != "none") node.fail("give `none` or a map of tolerances");
    v.enabled = false;
    return v;
  }
  node.allow_keys({"wheel_radius_rel", "wheel_base_rel", "motor_rel", "friction_rel",
                   "mover_speed_rel", "start_xy_m", "start_theta", "start_theta_deg", "waypoint_m",
                   "mover_phase"});
  const Range& rel = VariationDef::kRelativeRange;
  v.wheel_radius_rel = node.get_double("wheel_radius_rel", v.wheel_radius_rel, rel);
  v.wheel_base_rel = node.get_double("wheel_base_rel", v.wheel_base_rel, rel);
  v.motor_rel = node.get_double("motor_rel", v.motor_rel, rel);
  v.friction_rel = node.get_double("friction_rel", v.friction_rel, rel);
  v.mover_speed_rel = node.get_double("mover_speed_rel", v.mover_speed_rel, rel);
  v.start_xy_m = node.get_double("start_xy_m", v.start_xy_m, VariationDef::kStartXyRange);
  v.start_theta_rad =
      node.get_angle("start_theta", v.start_theta_rad, VariationDef::kStartThetaRange);
  v.waypoint_m = node.get_double("waypoint_m", v.waypoint_m, VariationDef::kWaypointRange);
  v.mover_phase = node.get_bool("mover_phase", v.mover_phase);
  return v;
}

FloorDef parse_floor(const YamlNode& node) {
  node.allow_keys({"friction", "regions"});
  FloorDef floor;
  floor.friction = node.get_double("friction", floor.friction, kFrictionRange);
  std::set<std::string> names;
  if (const auto regions = node.find("regions")) {
    for (const YamlNode& item : regions->items()) {
      item.allow_keys({"name", "friction", "polygon", "box"});
      FloorRegionDef region;
      region.name = item["name"].as_string();
      if (region.name == "floor") item["name"].fail("'floor' is reserved for the default floor");
      if (!names.insert(region.name).second) item["name"].fail("region name used twice");
      region.friction = item["friction"].as_double(kFrictionRange);
      const auto polygon = item.find("polygon");
      const auto box = item.find("box");
      if (polygon.has_value() == box.has_value())
        item.fail("give exactly one of 'polygon' or 'box'");
      if (polygon) {
        region.polygon_m = polygon->as_points(3, kWorldCoordinateRange);
        // Every wheel tests its point against the polygon at every step.
        if (region.polygon_m.size() > FloorRegionDef::kMaxVertices) {
          polygon->fail("a region has at most " + std::to_string(FloorRegionDef::kMaxVertices) +
                        " vertices");
        }
        if (std::abs(signed_area(region.polygon_m)) < 1e-9) polygon->fail("polygon has no area");
      } else {
        box->allow_keys({"min", "max"});
        const Vec2 lo = (*box)["min"].as_vec2(kWorldCoordinateRange),
                   hi = (*box)["max"].as_vec2(kWorldCoordinateRange);
        if (!(hi.x() > lo.x() && hi.y() > lo.y())) box->fail("'max' must exceed 'min' in x and y");
        region.polygon_m = {lo, {hi.x(), lo.y()}, hi, {lo.x(), hi.y()}};
      }
      floor.regions.push_back(std::move(region));
    }
  }
  return floor;
}

}  // namespace

FootprintDef parse_footprint(const YamlNode& node) {
  node.allow_keys({"radius_m", "box_m", "polygon"});
  FootprintDef footprint;
  const auto radius = node.find("radius_m");
  const auto box = node.find("box_m");
  const auto polygon = node.find("polygon");
  if (int(radius.has_value()) + int(box.has_value()) + int(polygon.has_value()) != 1) {
    node.fail("give exactly one of 'radius_m', 'box_m' [length, width] or 'polygon'");
  }
  if (radius) {
    footprint.kind = FootprintDef::Kind::kCircle;
    footprint.radius_m = radius->as_double(FootprintDef::kRadiusRange);
  } else if (box) {
    footprint.kind = FootprintDef::Kind::kBox;
    footprint.size_m = box->as_vec2(FootprintDef::kSizeRange);
  } else {
    footprint.kind = FootprintDef::Kind::kPolygon;
    footprint.points_m = convex_polygon(*polygon, kBodyFrameRange, FootprintDef::kMinPolygonAreaM2);
  }
  return footprint;
}

CommandResponseDef parse_command_response(const YamlNode& node) {
  using D = CommandResponseDef;
  node.allow_keys({"dead_time_s", "time_constant_v_s", "time_constant_omega_s", "gain_v",
                   "gain_omega", "gain_wander_v", "gain_wander_omega",
                   "gain_wander_correlation_s"});
  D d;
  d.dead_time_s = node.get_double("dead_time_s", d.dead_time_s, D::kDeadTimeRange);
  d.time_constant_v_s =
      node.get_double("time_constant_v_s", d.time_constant_v_s, D::kTimeConstantRange);
  d.time_constant_omega_s =
      node.get_double("time_constant_omega_s", d.time_constant_omega_s, D::kTimeConstantRange);
  d.gain_v = node.get_double("gain_v", d.gain_v, D::kGainRange);
  d.gain_omega = node.get_double("gain_omega", d.gain_omega, D::kGainRange);
  d.gain_wander_v = node.get_double("gain_wander_v", d.gain_wander_v, D::kGainWanderRange);
  d.gain_wander_omega =
      node.get_double("gain_wander_omega", d.gain_wander_omega, D::kGainWanderRange);
  d.gain_wander_correlation_s = node.get_double(
      "gain_wander_correlation_s", d.gain_wander_correlation_s, D::kGainWanderCorrelationRange);
  return d;
}

SideSlipDef parse_side_slip(const YamlNode& node) {
  using D = SideSlipDef;
  node.allow_keys({"crab_angle", "crab_angle_deg", "cornering_compliance_s", "wander_k",
                   "wander_correlation_s"});
  D d;
  d.crab_angle_rad = node.get_angle("crab_angle", d.crab_angle_rad, D::kCrabAngleRange);
  d.cornering_compliance_s = node.get_double("cornering_compliance_s", d.cornering_compliance_s,
                                             D::kCorneringComplianceRange);
  d.wander_k = node.get_double("wander_k", d.wander_k, D::kWanderKRange);
  d.wander_correlation_s =
      node.get_double("wander_correlation_s", d.wander_correlation_s, D::kWanderCorrelationRange);
  return d;
}

namespace {

/// Occupied pixels merged greedily into rectangles: runs along a row, grown down while the rows
/// below repeat the run, so that a map becomes a few hundred boxes, not one per pixel.
std::vector<OccupancyMapDef::Rect> merge_occupied(const OccupancyMapDef& map) {
  const int width = map.width_px, height = map.height_px;
  std::vector<unsigned char> covered(map.occupied.size(), 0);
  const auto occupied_free = [&](int row, int col) {
    const std::size_t i = static_cast<std::size_t>(row) * width + col;
    return map.occupied[i] != 0 && covered[i] == 0;
  };
  std::vector<OccupancyMapDef::Rect> rects;
  for (int row = 0; row < height; ++row) {
    for (int col = 0; col < width;) {
      if (!occupied_free(row, col)) {
        ++col;
        continue;
      }
      int end_col = col;
      while (end_col < width && occupied_free(row, end_col)) ++end_col;
      int end_row = row + 1;
      while (end_row < height) {
        bool full = true;
        for (int c = col; c < end_col && full; ++c) full = occupied_free(end_row, c);
        if (!full) break;
        ++end_row;
      }
      for (int r = row; r < end_row; ++r) {
        for (int c = col; c < end_col; ++c) covered[static_cast<std::size_t>(r) * width + c] = 1;
      }
      rects.push_back({col, row, end_col, end_row});
      col = end_col;
    }
  }
  return rects;
}

}  // namespace

OccupancyMapDef load_occupancy_map(const std::filesystem::path& map_yaml) {
  const YamlNode root = YamlNode::load_file(map_yaml);
  root.allow_keys(
      {"image", "resolution", "origin", "occupied_thresh", "free_thresh", "negate", "mode"});
  OccupancyMapDef map;
  map.yaml_file = map_yaml;
  map.image_file = map_yaml.parent_path() / root["image"].as_string();
  map.resolution_m = root["resolution"].as_double(OccupancyMapDef::kResolutionRange);
  const auto origin = root["origin"].items();
  if (origin.size() != 3) root["origin"].fail("expected [x, y, yaw]");
  map.origin =
      Pose2{origin[0].as_double(kWorldCoordinateRange), origin[1].as_double(kWorldCoordinateRange),
            wrap_angle(origin[2].as_double(kHeadingRange))};
  map.occupied_thresh = root.get_double("occupied_thresh", map.occupied_thresh, kProbabilityRange);
  map.free_thresh = root.get_double("free_thresh", map.free_thresh, kProbabilityRange);
  if (map.free_thresh > map.occupied_thresh) {
    root["free_thresh"].fail("must not exceed occupied_thresh");
  }
  if (const auto negate = root.find("negate"))
    map.negate = negate->as_int(OccupancyMapDef::kNegateRange) != 0;
  if (const auto mode = root.find("mode")) {
    const std::string m = mode->as_string();
    if (m != "trinary" && m != "scale") mode->fail("only 'trinary' and 'scale' maps are supported");
  }
  require_file(root["image"], map.image_file, "map image");
  // A bad image is reported at the key that names it, after the image's own message.
  GrayImage image;
  try {
    image = read_pgm(map.image_file);
  } catch (const InputError& e) {
    root["image"].fail(e.what());
  }
  map.width_px = image.width;
  map.height_px = image.height;
  // The map's extent must lie within the world's coordinates, as everything else does.
  const double extent_m = std::max(image.width, image.height) * map.resolution_m * std::sqrt(2.0);
  if (std::abs(map.origin.x) + extent_m > kWorldCoordinateRange.max ||
      std::abs(map.origin.y) + extent_m > kWorldCoordinateRange.max) {
    root["resolution"].fail(std::to_string(image.width) + " x " + std::to_string(image.height) +
                            " px of " + short_number(map.resolution_m) +
                            " m from the origin reach beyond the world's coordinates " +
                            describe(kWorldCoordinateRange));
  }
  map.occupied.resize(image.pixels.size());
  for (std::size_t i = 0; i < image.pixels.size(); ++i) {
    const double value = image.pixels[i] / 255.0;
    // map_server: occupancy p = (255 - value) / 255, or value / 255 when negated.
    const double occupancy = map.negate ? value : 1.0 - value;
    map.occupied[i] = occupancy > map.occupied_thresh ? 1 : 0;
  }
  map.rects = merge_occupied(map);
  return map;
}

WorldDef parse_world(const YamlNode& root, const std::filesystem::path& base_dir) {
  root.allow_keys({"name", "physics", "floor", "walls", "boxes", "circles", "polygons", "map",
                   "landmarks", "beacons", "movers", "robots", "scenario", "variation"});
  WorldDef world;
  world.name = root.get_string("name", world.name);
  if (const auto physics = root.find("physics")) world.physics = parse_physics(*physics);
  if (const auto floor = root.find("floor")) world.floor = parse_floor(*floor);
  if (const auto variation = root.find("variation")) world.variation = parse_variation(*variation);
  WorldMemory memory;

  if (const auto walls = root.find("walls")) {
    std::size_t segments = 0;
    for (const YamlNode& item : walls->items()) {
      item.allow_keys({"points", "closed", "thickness_m", "height_m"});
      WallDef wall;
      wall.points_m = item["points"].as_points(2, kWorldCoordinateRange);
      wall.closed = item.get_bool("closed", false);
      if (wall.closed && wall.points_m.size() < 3)
        item["closed"].fail("a closed wall needs 3 points");
      wall.thickness_m = item.get_double("thickness_m", wall.thickness_m, WallDef::kThicknessRange);
      wall.height_m = item.get_double("height_m", wall.height_m, WallDef::kHeightRange);
      check_spacing(item["points"], wall.points_m, wall.closed);
      segments += wall.points_m.size() - (wall.closed ? 0 : 1);
      // Checked as the walls come: YAML aliases can repeat one long wall many times over.
      if (segments * kStaticShapeBytes > kWorldMemoryBudgetBytes) {
        item.fail("the walls so far have " + std::to_string(segments) +
                  " segments, more than fit in a world's memory budget of " +
                  format_bytes(static_cast<double>(kWorldMemoryBudgetBytes)) +
                  " (docs/worlds.md, Limits)");
      }
      world.walls.push_back(std::move(wall));
    }
    memory.add(walls->place(), "walls' segments", segments * kStaticShapeBytes);
  }
  if (const auto boxes = root.find("boxes")) {
    for (const YamlNode& item : boxes->items()) {
      item.allow_keys({"center", "size", "angle", "angle_deg", "height_m"});
      BoxDef box;
      box.center_m = item["center"].as_vec2(kWorldCoordinateRange);
      box.size_m = item["size"].as_vec2(BoxDef::kSizeRange);
      box.angle_rad = item.get_heading("angle", 0.0);
      box.height_m = item.get_double("height_m", box.height_m, kBodyHeightRange);
      world.boxes.push_back(box);
    }
    memory.add(boxes->place(), "boxes", world.boxes.size() * kStaticShapeBytes);
  }
  if (const auto circles = root.find("circles")) {
    for (const YamlNode& item : circles->items()) {
      item.allow_keys({"center", "radius_m", "height_m"});
      world.circles.push_back(
          CircleDef{item["center"].as_vec2(kWorldCoordinateRange),
                    item["radius_m"].as_double(CircleDef::kRadiusRange),
                    item.get_double("height_m", kFullHeight, kBodyHeightRange)});
    }
    memory.add(circles->place(), "circles", world.circles.size() * kStaticShapeBytes);
  }
  if (const auto polygons = root.find("polygons")) {
    for (const YamlNode& item : polygons->items()) {
      item.allow_keys({"points", "height_m"});
      world.polygons.push_back(
          PolygonDef{convex_polygon(item["points"], kWorldCoordinateRange, kMinStaticPolygonAreaM2),
                     item.get_double("height_m", kFullHeight, kBodyHeightRange)});
    }
    memory.add(polygons->place(), "polygons", world.polygons.size() * kStaticShapeBytes);
  }
  if (const auto map = root.find("map")) {
    const std::filesystem::path map_file = base_dir / map->as_string();
    require_file(*map, map_file, "map file");
    world.map = load_occupancy_map(map_file);
    memory.add(
        map->place(),
        "the map's " + std::to_string(world.map->rects.size()) + " boxes of occupied pixels",
        world.map->rects.size() * kStaticShapeBytes + world.map->occupied.size() * kMapPixelBytes);
  }

  if (const auto landmarks = root.find("landmarks")) {
    std::set<int> ids;
    for (const YamlNode& item : landmarks->items()) {
      item.allow_keys({"id", "position", "color", "radius_m", "height_m"});
      LandmarkDef landmark;
      landmark.id = static_cast<int>(item["id"].as_int(kIdRange));
      if (!ids.insert(landmark.id).second) item["id"].fail("landmark id used twice");
      landmark.position_m = item["position"].as_vec2(kWorldCoordinateRange);
      if (const auto color = item.find("color"))
        landmark.color = parse_color(*color, landmark.color_name);
      landmark.radius_m = item.get_double("radius_m", landmark.radius_m, LandmarkDef::kRadiusRange);
      landmark.height_m = item.get_double("height_m", landmark.height_m, kBodyHeightRange);
      world.landmarks.push_back(landmark);
    }
  }
  if (const auto beacons = root.find("beacons")) {
    std::set<int> ids;
    for (const YamlNode& item : beacons->items()) {
      item.allow_keys({"id", "position", "height_m"});
      BeaconDef beacon;
      beacon.id = static_cast<int>(item["id"].as_int(kIdRange));
      if (!ids.insert(beacon.id).second) item["id"].fail("beacon id used twice");
      beacon.position_m = item["position"].as_vec2(kWorldCoordinateRange);
      beacon.height_m = item.get_double("height_m", beacon.height_m, kHeightRange);
      world.beacons.push_back(beacon);
    }
  }
  std::set<std::string> body_names;
  if (const auto movers = root.find("movers")) {
    // Every path's points counted before any is read: paths shared through YAML aliases are
    // copied for each mover, so a small file can name gigabytes of them.
    std::uint64_t points = 0;
    for (const YamlNode& item : movers->items()) {
      if (const auto path = item.find("path")) points += path->size();
    }
    memory.add(movers->place(), "the movers' paths (" + std::to_string(points) + " points)",
               points * kPathPointBytes);
    memory.check();
    for (const YamlNode& item : movers->items()) {
      item.allow_keys(
          {"name", "kind", "footprint", "path", "speed_mps", "loop", "moving", "height_m"});
      MoverDef mover;
      mover.name = item["name"].as_string();
      if (!body_names.insert(mover.name).second) item["name"].fail("name used twice");
      mover.kind = item.get_string("kind", mover.kind);
      if (mover.kind == "person") {
        mover.footprint.kind = FootprintDef::Kind::kCircle;
        mover.footprint.radius_m = 0.25;
      } else if (mover.kind == "cart") {
        mover.footprint.kind = FootprintDef::Kind::kBox;
        mover.footprint.size_m = {0.8, 0.5};
        mover.height_m = 1.0;
      } else {
        item["kind"].fail("expected 'person' or 'cart'");
      }
      if (const auto footprint = item.find("footprint"))
        mover.footprint = parse_footprint(*footprint);
      mover.path_m = item["path"].as_points(1, kWorldCoordinateRange);
      // A path whose points coincide would have a mover walk it forever within one step.
      check_spacing(item["path"], mover.path_m, false);
      mover.speed_mps = item.get_double("speed_mps", mover.speed_mps, MoverDef::kSpeedRange);
      mover.loop = item.get_bool("loop", mover.loop);
      mover.moving = item.get_bool("moving", mover.moving);
      mover.height_m = item.get_double("height_m", mover.height_m, kBodyHeightRange);
      world.movers.push_back(std::move(mover));
    }
  }

  const auto robots = root["robots"];
  for (const YamlNode& item : robots.items()) {
    item.allow_keys({"name", "footprint", "mass_kg", "wheel_base_m", "wheel_radius_m",
                     "wheel_radius_left_m", "wheel_radius_right_m", "wheel_inertia_kgm2",
                     "max_wheel_speed_radps", "max_wheel_accel_radps2", "max_wheel_torque_nm",
                     "drive_load_fraction", "height_m", "command_response", "side_slip", "start",
                     "sensors"});
    RobotDef robot;
    robot.where = item.where();
    robot.key_path = item.path();
    robot.name = item.get_string("name", "robot" + std::to_string(world.robots.size()));
    if (robot.name.empty() || robot.name.find_first_of("/\\ .") != std::string::npos) {
      item["name"].fail("a robot name names its output folder: no spaces, dots or slashes");
    }
    if (!body_names.insert(robot.name).second) item.fail("name '" + robot.name + "' used twice");
    if (const auto footprint = item.find("footprint"))
      robot.footprint = parse_footprint(*footprint);
    robot.mass_kg = item.get_double("mass_kg", robot.mass_kg, RobotDef::kMassRange);
    robot.wheel_base_m =
        item.get_double("wheel_base_m", robot.wheel_base_m, RobotDef::kWheelBaseRange);
    robot.wheel_radius_m =
        item.get_double("wheel_radius_m", robot.wheel_radius_m, RobotDef::kWheelRadiusRange);
    robot.wheel_radius_left_m =
        item.get_double("wheel_radius_left_m", robot.wheel_radius_m, RobotDef::kWheelRadiusRange);
    robot.wheel_radius_right_m =
        item.get_double("wheel_radius_right_m", robot.wheel_radius_m, RobotDef::kWheelRadiusRange);
    robot.wheel_inertia_kgm2 = item.get_double("wheel_inertia_kgm2", robot.wheel_inertia_kgm2,
                                               RobotDef::kWheelInertiaRange);
    robot.max_wheel_speed_radps = item.get_double(
        "max_wheel_speed_radps", robot.max_wheel_speed_radps, RobotDef::kWheelSpeedRange);
    robot.max_wheel_accel_radps2 = item.get_double(
        "max_wheel_accel_radps2", robot.max_wheel_accel_radps2, RobotDef::kWheelAccelRange);
    robot.max_wheel_torque_nm = item.get_double("max_wheel_torque_nm", robot.max_wheel_torque_nm,
                                                RobotDef::kWheelTorqueRange);
    robot.drive_load_fraction = item.get_double("drive_load_fraction", robot.drive_load_fraction,
                                                RobotDef::kDriveLoadRange);
    robot.height_m = item.get_double("height_m", robot.height_m, RobotDef::kHeightRange);
    if (const auto response = item.find("command_response"))
      robot.command_response = parse_command_response(*response);
    if (const auto slip = item.find("side_slip")) robot.side_slip = parse_side_slip(*slip);
    robot.start = item["start"].as_pose(kWorldCoordinateRange);
    if (const auto sensors = item.find("sensors")) {
      robot.sensors = parse_sensors(*sensors, world.physics.step_hz);
      if (const auto& laser = robot.sensors.laser) {
        // What a robot's laser allocates is built with the simulation: counted (and refused)
        // here, before it is.
        memory.add((*sensors)["laser"].place(),
                   "robot '" + robot.name + "''s " + std::to_string(laser->beams) + "-beam laser",
                   static_cast<std::uint64_t>(laser->beams) * kLaserBeamBytes);
        memory.check();
      }
      if (const auto& ptz = robot.sensors.ptz_camera;
          ptz && ptz->mode == PtzCameraDef::Mode::kRendered) {
        memory.add(
            (*sensors)["ptz_camera"].place(),
            "a rendered " + std::to_string(ptz->width_px) + " x " + std::to_string(ptz->height_px) +
                " px camera",
            static_cast<std::uint64_t>(ptz->width_px) * ptz->height_px * kRenderedPixelBytes);
      }
    }
    world.robots.push_back(std::move(robot));
  }
  if (world.robots.empty()) robots.fail("a world needs at least one robot");
  memory.check();
  world.memory_bytes = memory.total_bytes();

  if (const auto scenario = root.find("scenario"))
    world.scenario = parse_scenario(*scenario, base_dir);
  return world;
}

WorldDef load_world(const std::filesystem::path& file) {
  WorldDef world = parse_world(YamlNode::load_file(file), file.parent_path());
  world.source = file;
  return world;
}

}  // namespace locsim
