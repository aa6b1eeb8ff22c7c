// A world as read from YAML: static geometry, floor friction, landmarks, beacons, moving
// obstacles and robots. Plain values with defaults; units in every field's comment.
#pragma once

#include <array>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "sim/common/errors.hpp"
#include "sim/common/math.hpp"
#include "sim/robot/robot_def.hpp"
#include "sim/scenario/scenario_def.hpp"

namespace locsim {

/// Height of static geometry that reaches the ceiling (the default): blocks every line of sight.
inline constexpr double kFullHeight = std::numeric_limits<double>::infinity();

struct PhysicsDef {
  double step_hz = 200.0;       // fixed physics rate [Hz]
  int velocity_iterations = 8;  // Box2D velocity solver iterations [-]
  int position_iterations = 3;  // Box2D position solver iterations [-]
  double gravity_mps2 = 9.81;   // sets the wheels' normal loads; the world is horizontal [m/s²]
};

/// A wall: a segment (2 points) or a polyline; `closed` joins the last point to the first.
struct WallDef {
  std::vector<Vec2> points_m;
  bool closed = false;
  double thickness_m = 0.05;      // drawn thickness; collisions use the centre line [m]
  double height_m = kFullHeight;  // top above the floor, for ultrasound line of sight [m]
};

struct BoxDef {
  Vec2 center_m{0.0, 0.0};
  Vec2 size_m{1.0, 1.0};  // full extents along the box's own x and y [m]
  double angle_rad = 0.0;
  double height_m = kFullHeight;  // [m]
};

struct CircleDef {
  Vec2 center_m{0.0, 0.0};
  double radius_m = 0.5;
  double height_m = kFullHeight;  // [m]
};

struct PolygonDef {
  std::vector<Vec2> points_m;     // convex, <= 8 vertices (Box2D's limit)
  double height_m = kFullHeight;  // [m]
};

/// A floor area with its own friction coefficient: carpet, tiles, ice. Later regions win where
/// regions overlap; outside every region the floor's default applies.
struct FloorRegionDef {
  std::string name;
  double friction = 0.8;        // Coulomb coefficient between wheel and floor [-]
  std::vector<Vec2> polygon_m;  // simple polygon, any number of vertices
};

struct FloorDef {
  double friction = 0.8;  // default coefficient outside all regions [-]
  std::vector<FloorRegionDef> regions;
};

using Rgb = std::array<unsigned char, 3>;

struct LandmarkDef {
  int id = 0;
  Vec2 position_m{0.0, 0.0};
  Rgb color{255, 0, 0};
  std::string color_name = "red";  // as written; "" when given as [r, g, b]
  double radius_m = 0.1;           // cylinder radius [m]
  double height_m = 0.5;           // cylinder height [m]
};

/// What a camera reports of a landmark's colour: its name, or "#rrggbb" when given as numbers.
inline std::string color_label(const LandmarkDef& landmark) {
  if (!landmark.color_name.empty()) return landmark.color_name;
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out = "#";
  for (const unsigned char c : landmark.color) {
    out += kHex[c >> 4];
    out += kHex[c & 15];
  }
  return out;
}

struct BeaconDef {
  int id = 0;
  Vec2 position_m{0.0, 0.0};
  double height_m = 2.5;  // mounting height above the floor [m]
};

/// A person or cart walking a waypoint path at a set speed. Movers are kinematic bodies: they
/// push robots out of their way and are not pushed back, as a walking person mostly is not.
struct MoverDef {
  std::string name;
  std::string kind = "person";  // "person" or "cart"; decides the default footprint and drawing
  FootprintDef footprint;       // default: circle of 0.25 m (person), box 0.8 x 0.5 m (cart)
  std::vector<Vec2> path_m;     // waypoints; the mover starts at the first one
  double speed_mps = 1.0;       // walking speed [m/s]
  bool loop = true;             // after the last waypoint go back to the first; else stop there
  bool moving = true;           // false: stands still until an `obstacle: start` event
  double height_m = 1.7;        // blocks ultrasound below it; default 1.7 (person), 1.0 (cart)
};

/// A ROS map_server map: `map.yaml` plus image. Occupied cells become static boxes.
struct OccupancyMapDef {
  std::filesystem::path yaml_file;
  std::filesystem::path image_file;
  double resolution_m = 0.05;  // cell size [m]
  Pose2 origin;                // pose of the lower-left pixel's corner
  double occupied_thresh = 0.65;
  double free_thresh = 0.196;
  bool negate = false;
  int width_px = 0;
  int height_px = 0;
  std::vector<unsigned char> occupied;  // row-major from the top row; 1 = occupied
};

struct WorldDef {
  std::string name = "world";
  std::filesystem::path source;  // the YAML file it came from
  PhysicsDef physics;
  FloorDef floor;
  std::vector<WallDef> walls;
  std::vector<BoxDef> boxes;
  std::vector<CircleDef> circles;
  std::vector<PolygonDef> polygons;
  std::optional<OccupancyMapDef> map;
  std::vector<LandmarkDef> landmarks;
  std::vector<BeaconDef> beacons;
  std::vector<MoverDef> movers;
  std::vector<RobotDef> robots;
  std::optional<ScenarioDef> scenario;  // a `scenario:` section, if the world file has one
};

}  // namespace locsim
