// A world as read from YAML: static geometry, floor friction, landmarks, beacons, moving
// obstacles and robots. Plain values with defaults; beside each number its unit and the range the
// loader holds it to (sim/common/range.hpp).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "sim/common/errors.hpp"
#include "sim/common/math.hpp"
#include "sim/common/range.hpp"
#include "sim/robot/robot_def.hpp"
#include "sim/scenario/scenario_def.hpp"

namespace locsim {

/// Height of static geometry that reaches the ceiling (the default): blocks every line of sight.
inline constexpr double kFullHeight = std::numeric_limits<double>::infinity();

struct PhysicsDef {
  double step_hz = 200.0;  // fixed physics rate [Hz]
  static constexpr Range kStepRange{10.0, 10000.0, "Hz"};
  int velocity_iterations = 8;  // Box2D velocity solver iterations [-]
  int position_iterations = 3;  // Box2D position solver iterations [-]
  static constexpr Range kIterationsRange{1.0, 100.0, ""};
  double gravity_mps2 = 9.81;  // sets the wheels' normal loads; the world is horizontal [m/s²]
  static constexpr Range kGravityRange{0.1, 100.0, "m/s^2"};
};

/// A wall: a segment (2 points) or a polyline; `closed` joins the last point to the first.
struct WallDef {
  std::vector<Vec2> points_m;  // kWorldCoordinateRange, kMinPointSpacingM apart
  bool closed = false;
  double thickness_m = 0.05;  // drawn thickness; collisions use the centre line [m]
  static constexpr Range kThicknessRange{0.001, 100.0, "m"};
  double height_m = kFullHeight;  // top above the floor, for ultrasound line of sight [m]
  static constexpr Range kHeightRange = kBodyHeightRange;
};

struct BoxDef {
  Vec2 center_m{0.0, 0.0};  // kWorldCoordinateRange
  Vec2 size_m{1.0, 1.0};    // full extents along the box's own x and y [m]
  static constexpr Range kSizeRange{0.01, 20000.0, "m"};
  double angle_rad = 0.0;         // any heading (kHeadingRange), wrapped [rad]
  double height_m = kFullHeight;  // kBodyHeightRange [m]
};

struct CircleDef {
  Vec2 center_m{0.0, 0.0};  // kWorldCoordinateRange
  double radius_m = 0.5;    // [m]
  static constexpr Range kRadiusRange{0.005, 10000.0, "m"};
  double height_m = kFullHeight;  // kBodyHeightRange [m]
};

struct PolygonDef {
  // Convex, <= 8 vertices (Box2D's limit), kMinPointSpacingM apart, kWorldCoordinateRange.
  std::vector<Vec2> points_m;
  double height_m = kFullHeight;  // kBodyHeightRange [m]
};

/// A floor area with its own friction coefficient: carpet, tiles, ice. Later regions win where
/// regions overlap; outside every region the floor's default applies.
struct FloorRegionDef {
  std::string name;
  double friction = 0.8;  // Coulomb coefficient between wheel and floor, kFrictionRange [-]
  // Simple polygon, kWorldCoordinateRange, at most kMaxVertices (tested at every step).
  std::vector<Vec2> polygon_m;
  static constexpr std::size_t kMaxVertices = 1000;
};

struct FloorDef {
  double friction = 0.8;  // default coefficient outside all regions, kFrictionRange [-]
  std::vector<FloorRegionDef> regions;
};

using Rgb = std::array<unsigned char, 3>;

/// Ids of landmarks and beacons. [-]
inline constexpr Range kIdRange{0.0, 1e6, ""};
/// A colour channel. [-]
inline constexpr Range kColorChannelRange{0.0, 255.0, ""};

struct LandmarkDef {
  int id = 0;                      // kIdRange
  Vec2 position_m{0.0, 0.0};       // kWorldCoordinateRange
  Rgb color{255, 0, 0};            // kColorChannelRange each
  std::string color_name = "red";  // as written; "" when given as [r, g, b]
  double radius_m = 0.1;           // cylinder radius [m]
  static constexpr Range kRadiusRange{0.001, 100.0, "m"};
  double height_m = 0.5;  // cylinder height, kBodyHeightRange [m]
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
  int id = 0;                 // kIdRange
  Vec2 position_m{0.0, 0.0};  // kWorldCoordinateRange
  double height_m = 2.5;      // mounting height above the floor, kHeightRange [m]
};

/// A person or cart walking a waypoint path at a set speed. Movers are kinematic bodies: they
/// push robots out of their way and are not pushed back, as a walking person mostly is not.
struct MoverDef {
  std::string name;
  std::string kind = "person";  // "person" or "cart"; decides the default footprint and drawing
  FootprintDef footprint;       // default: circle of 0.25 m (person), box 0.8 x 0.5 m (cart)
  // Waypoints, kWorldCoordinateRange, consecutive ones kMinPointSpacingM apart; the mover
  // starts at the first one.
  std::vector<Vec2> path_m;
  double speed_mps = 1.0;  // walking speed [m/s]
  static constexpr Range kSpeedRange{0.0, 50.0, "m/s"};
  bool loop = true;       // after the last waypoint go back to the first; else stop there
  bool moving = true;     // false: stands still until an `obstacle: start` event
  double height_m = 1.7;  // blocks ultrasound below it; 1.7 (person), 1.0 (cart); kBodyHeightRange
};

/// A ROS map_server map: `map.yaml` plus image. Occupied cells become static boxes.
struct OccupancyMapDef {
  std::filesystem::path yaml_file;
  std::filesystem::path image_file;
  double resolution_m = 0.05;  // cell size [m]
  static constexpr Range kResolutionRange{0.001, 100.0, "m"};
  Pose2 origin;                   // pose of the lower-left pixel's corner, kWorldCoordinateRange
  double occupied_thresh = 0.65;  // kProbabilityRange [-]
  double free_thresh = 0.196;     // kProbabilityRange [-]
  bool negate = false;            // given as 0 or 1
  static constexpr Range kNegateRange{0.0, 1.0, ""};
  int width_px = 0;
  int height_px = 0;
  std::vector<unsigned char> occupied;  // row-major from the top row; 1 = occupied
  /// Occupied pixels merged into rectangles (runs along a row, grown down while the rows below
  /// repeat the run), in pixels from the top-left; each becomes one static Box2D box.
  struct Rect {
    int col = 0, row = 0, end_col = 0, end_row = 0;
  };
  std::vector<Rect> rects;
};

/// How much a seed varies the world around what the file declares (docs/worlds.md#variation):
/// the true values a real robot and room would have on another day. A relative tolerance is the
/// standard deviation of a factor 1 + N(0, sigma^2); every draw is cut at 3 sigma. Each quantity
/// is drawn from its own named stream of the run's seed (sim/world/variation.hpp).
struct VariationDef {
  bool enabled = true;              // `variation: none` turns every draw off
  double wheel_radius_rel = 0.001;  // each true wheel radius, relative [-]
  double wheel_base_rel = 0.005;    // the true wheel base (the encoders keep the declared) [-]
  double motor_rel = 0.05;       // each robot's wheel acceleration and torque limits, relative [-]
  double friction_rel = 0.1;     // the floor's and each region's friction, relative [-]
  double mover_speed_rel = 0.1;  // each mover's walking speed, relative [-]
  static constexpr Range kRelativeRange{0.0, 0.3, ""};
  double start_xy_m = 0.05;  // the start position, per axis; kept free of obstacles [m]
  static constexpr Range kStartXyRange{0.0, 10.0, "m"};
  double start_theta_rad = deg_to_rad(2.0);  // the start heading [rad]
  static constexpr Range kStartThetaRange{0.0, deg_to_rad(180.0), "rad"};
  double waypoint_m = 0.1;  // each waypoint of a `waypoints` drive, per axis; kept free [m]
  static constexpr Range kWaypointRange{0.0, 10.0, "m"};
  bool mover_phase = true;  // each looping mover starts anywhere along its path
};

/// What one seed drew (VariationDef), in absolute values: written to run.json and to logs so
/// that a replay rebuilds the same world. Empty when the world has `variation: none`.
struct DrawnVariation {
  struct Robot {
    std::string name;
    double wheel_radius_left_m = 0.0, wheel_radius_right_m = 0.0;  // true radii [m]
    double wheel_base_m = 0.0;                                     // true wheel base [m]
    double max_wheel_accel_radps2 = 0.0;                           // [rad/s^2]
    double max_wheel_torque_nm = 0.0;                              // [N m]
    Pose2 start;                                                   // true start pose
  };
  struct Mover {
    std::string name;
    double speed_mps = 0.0;  // [m/s]
    double phase_m = 0.0;    // where along its (looping) path it starts [m]
  };
  struct Drive {
    std::string robot;
    std::vector<Vec2> path_m;  // the waypoints this seed drives through
  };
  bool applied = false;
  double floor_friction = 0.0;          // [-]
  std::vector<double> region_friction;  // per floor region, in order [-]
  std::vector<Robot> robots;            // in the world's order
  std::vector<Mover> movers;            // in the world's order
  std::vector<Drive> drives;            // the waypoints drives, in the scenario's order
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
  VariationDef variation;               // what each seed may vary
  DrawnVariation drawn;                 // what this run's seed drew (once applied)
  std::uint64_t memory_bytes = 0;  // what its geometry, map and cameras need (world_budget.hpp)
};

}  // namespace locsim
