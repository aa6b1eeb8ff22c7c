// The Box2D world built from a WorldDef: static geometry (walls, shapes, map cells), the floor's
// friction field, and the movers (people, carts) walking their paths. Robots live in robot/.
#pragma once

#include <box2d/box2d.h>

#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "sim/world/world_def.hpp"

namespace locsim {

/// What a Box2D body is; stored in b2BodyUserData::pointer as an encoded integer.
enum class BodyKind : std::uint8_t { kStatic = 1, kRobot = 2, kMover = 3 };
struct BodyTag {
  BodyKind kind = BodyKind::kStatic;
  int index = 0;  // into the robots or movers
};
std::uintptr_t encode_tag(BodyTag tag);
BodyTag decode_tag(std::uintptr_t pointer);

/// Friction coefficient of the floor at a point: the last region containing it, else the default.
class FloorFriction {
 public:
  explicit FloorFriction(const FloorDef& floor);
  double at(const Vec2& point_m) const;
  /// Changes a region's coefficient ("floor" is the default). False if there is no such region.
  bool set(const std::string& region, double friction);

 private:
  struct Region {
    std::string name;
    double friction;
    std::vector<Vec2> polygon;
    Vec2 lo, hi;  // bounding box, to skip the polygon test
  };
  double default_friction_;
  std::vector<Region> regions_;
};

/// A mover: a kinematic body walking its waypoints at its speed.
struct Mover {
  MoverDef def;
  b2Body* body = nullptr;  // owned by the b2World
  std::size_t next_waypoint = 0;
  bool moving = true;
  bool finished = false;  // reached the end of a non-looping path
};

/// Begin/end of a touching contact between two bodies, in Box2D's (deterministic) order.
struct ContactChange {
  BodyTag a, b;
  bool begin = true;
};

/// Creates a Box2D shape for a footprint; returns the shape that lives in `storage`.
const b2Shape& make_shape(const FootprintDef& footprint, b2CircleShape& circle_storage,
                          b2PolygonShape& polygon_storage);

class PhysicsWorld {
 public:
  explicit PhysicsWorld(const WorldDef& world);
  ~PhysicsWorld();
  PhysicsWorld(const PhysicsWorld&) = delete;
  PhysicsWorld& operator=(const PhysicsWorld&) = delete;

  b2World& box2d() { return *world_; }
  const b2World& box2d() const { return *world_; }
  FloorFriction& floor() { return floor_; }
  const FloorFriction& floor() const { return floor_; }
  std::vector<Mover>& movers() { return movers_; }
  const std::vector<Mover>& movers() const { return movers_; }
  const PhysicsDef& physics() const { return physics_; }

  /// Sets the movers' velocities for the coming step of `dt_s`.
  void drive_movers(double dt_s);
  /// Advances Box2D by one step and collects contact changes.
  void step(double dt_s);
  /// Contact changes since the last call.
  std::vector<ContactChange> take_contact_changes();

  /// True when `shape` at `pose` overlaps no enabled body other than `ignore`.
  bool is_free(const b2Shape& shape, const Pose2& pose, const b2Body* ignore) const;
  /// True when `shape` at `pose` overlaps no static geometry (walls, shapes, map cells).
  bool is_free_of_static(const b2Shape& shape, const Pose2& pose) const;
  /// Distance to the first fixture hit from `from` towards `to` (not `ignore`), or nullopt.
  std::optional<double> ray_cast(const Vec2& from, const Vec2& to, const b2Body* ignore) const;

  /// Axis-aligned bounds of the static geometry (walls, shapes, map); the robot starts if none.
  Vec2 bounds_min() const { return bounds_min_; }
  Vec2 bounds_max() const { return bounds_max_; }
  /// The one body that holds all static geometry.
  const b2Body* static_body() const { return static_body_; }
  /// Height of a static fixture's obstacle (kFullHeight unless the world gives one). [m]
  double static_height_m(const b2Fixture* fixture) const;
  /// Number of static fixtures (a map turns into merged boxes).
  int static_fixture_count() const;

 private:
  class ContactRecorder;
  void add_static_geometry(const WorldDef& world);
  void add_map(const OccupancyMapDef& map);
  void extend_bounds(const Vec2& point);
  void add_static(const b2FixtureDef& fixture, double height_m);
  bool overlaps_none(const b2Shape& shape, const Pose2& pose, const b2Body* ignore,
                     const b2Body* only) const;

  PhysicsDef physics_;
  std::unique_ptr<b2World> world_;
  std::unique_ptr<ContactRecorder> contacts_;
  b2Body* static_body_ = nullptr;
  std::unordered_map<const b2Fixture*, double> static_heights_;  // only those below the ceiling
  FloorFriction floor_;
  std::vector<Mover> movers_;
  Vec2 bounds_min_{0.0, 0.0}, bounds_max_{0.0, 0.0};
  bool has_bounds_ = false;
};

inline b2Vec2 to_b2(const Vec2& v) {
  return {static_cast<float>(v.x()), static_cast<float>(v.y())};
}
inline Vec2 from_b2(const b2Vec2& v) {
  return {v.x, v.y};
}

}  // namespace locsim
