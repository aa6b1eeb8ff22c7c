#include "sim/world/physics_world.hpp"

#include <algorithm>

namespace locsim {

std::uintptr_t encode_tag(BodyTag tag) {
  return (static_cast<std::uintptr_t>(tag.index) << 8) | static_cast<std::uintptr_t>(tag.kind);
}

BodyTag decode_tag(std::uintptr_t pointer) {
  return BodyTag{static_cast<BodyKind>(pointer & 0xff), static_cast<int>(pointer >> 8)};
}

// ---------------------------------------------------------------------------------------------
FloorFriction::FloorFriction(const FloorDef& floor) : default_friction_(floor.friction) {
  for (const FloorRegionDef& def : floor.regions) {
    Region region{def.name, def.friction, def.polygon_m, def.polygon_m.front(),
                  def.polygon_m.front()};
    for (const Vec2& p : def.polygon_m) {
      region.lo = region.lo.cwiseMin(p);
      region.hi = region.hi.cwiseMax(p);
    }
    regions_.push_back(std::move(region));
  }
}

namespace {
/// Even-odd rule point-in-polygon test.
bool contains(const std::vector<Vec2>& polygon, const Vec2& p) {
  bool inside = false;
  for (std::size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++) {
    const Vec2& a = polygon[i];
    const Vec2& b = polygon[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x()) {
      inside = !inside;
    }
  }
  return inside;
}
}  // namespace

double FloorFriction::at(const Vec2& point) const {
  for (auto it = regions_.rbegin(); it != regions_.rend(); ++it) {
    if (point.x() < it->lo.x() || point.y() < it->lo.y() || point.x() > it->hi.x() ||
        point.y() > it->hi.y()) {
      continue;
    }
    if (contains(it->polygon, point)) return it->friction;
  }
  return default_friction_;
}

bool FloorFriction::set(const std::string& region, double friction) {
  if (region == "floor") {
    default_friction_ = friction;
    return true;
  }
  for (Region& r : regions_) {
    if (r.name == region) {
      r.friction = friction;
      return true;
    }
  }
  return false;
}

// ---------------------------------------------------------------------------------------------
const b2Shape& make_shape(const FootprintDef& footprint, b2CircleShape& circle_storage,
                          b2PolygonShape& polygon_storage) {
  switch (footprint.kind) {
    case FootprintDef::Kind::kCircle:
      circle_storage.m_radius = static_cast<float>(footprint.radius_m);
      circle_storage.m_p.SetZero();
      return circle_storage;
    case FootprintDef::Kind::kBox:
      polygon_storage.SetAsBox(static_cast<float>(footprint.size_m.x() / 2),
                               static_cast<float>(footprint.size_m.y() / 2));
      return polygon_storage;
    case FootprintDef::Kind::kPolygon: {
      std::vector<b2Vec2> points;
      for (const Vec2& p : footprint.points_m) points.push_back(to_b2(p));
      polygon_storage.Set(points.data(), static_cast<int32>(points.size()));
      return polygon_storage;
    }
  }
  return circle_storage;
}

class PhysicsWorld::ContactRecorder : public b2ContactListener {
 public:
  void BeginContact(b2Contact* contact) override { record(contact, true); }
  void EndContact(b2Contact* contact) override { record(contact, false); }
  std::vector<ContactChange> changes;

 private:
  void record(b2Contact* contact, bool begin) {
    changes.push_back(
        ContactChange{decode_tag(contact->GetFixtureA()->GetBody()->GetUserData().pointer),
                      decode_tag(contact->GetFixtureB()->GetBody()->GetUserData().pointer), begin});
  }
};

PhysicsWorld::PhysicsWorld(const WorldDef& world)
    : physics_(world.physics),
      world_(std::make_unique<b2World>(b2Vec2(0.0f, 0.0f))),
      contacts_(std::make_unique<ContactRecorder>()),
      floor_(world.floor) {
  const Activity building("building the world's Box2D bodies");
  world_->SetContactListener(contacts_.get());
  b2BodyDef static_def;
  static_def.type = b2_staticBody;
  static_def.userData.pointer = encode_tag({BodyKind::kStatic, 0});
  static_body_ = world_->CreateBody(&static_def);
  add_static_geometry(world);
  if (world.map) add_map(*world.map);

  for (std::size_t i = 0; i < world.movers.size(); ++i) {
    const MoverDef& def = world.movers[i];
    b2BodyDef body_def;
    body_def.type = b2_kinematicBody;
    body_def.position = to_b2(def.path_m.front());
    if (def.path_m.size() > 1) {
      const Vec2 d = def.path_m[1] - def.path_m[0];
      body_def.angle = static_cast<float>(std::atan2(d.y(), d.x()));
    }
    body_def.userData.pointer = encode_tag({BodyKind::kMover, static_cast<int>(i)});
    Mover mover{def, world_->CreateBody(&body_def), def.path_m.size() > 1 ? 1u : 0u, def.moving};
    b2CircleShape circle;
    b2PolygonShape polygon;
    b2FixtureDef fixture;
    fixture.shape = &make_shape(def.footprint, circle, polygon);
    fixture.friction = 0.5f;
    mover.body->CreateFixture(&fixture);
    movers_.push_back(std::move(mover));
  }
  if (!has_bounds_) {
    for (const RobotDef& robot : world.robots) extend_bounds(robot.start.position());
  }
}

PhysicsWorld::~PhysicsWorld() = default;

void PhysicsWorld::extend_bounds(const Vec2& point) {
  if (!has_bounds_) {
    bounds_min_ = bounds_max_ = point;
    has_bounds_ = true;
    return;
  }
  bounds_min_ = bounds_min_.cwiseMin(point);
  bounds_max_ = bounds_max_.cwiseMax(point);
}

void PhysicsWorld::add_static_geometry(const WorldDef& world) {
  b2FixtureDef fixture;
  fixture.friction = 0.3f;
  for (const WallDef& wall : world.walls) {
    // Two-sided edges, one per segment: Box2D 2.4's chain shapes collide from one side only,
    // and a wall must stop a robot from either side.
    const std::size_t n = wall.points_m.size();
    for (const Vec2& p : wall.points_m) extend_bounds(p);
    for (std::size_t i = 0; i + 1 < n + (wall.closed ? 1 : 0); ++i) {
      b2EdgeShape edge;
      edge.SetTwoSided(to_b2(wall.points_m[i]), to_b2(wall.points_m[(i + 1) % n]));
      fixture.shape = &edge;
      add_static(fixture, wall.height_m);
    }
  }
  for (const BoxDef& box : world.boxes) {
    b2PolygonShape shape;
    shape.SetAsBox(static_cast<float>(box.size_m.x() / 2), static_cast<float>(box.size_m.y() / 2),
                   to_b2(box.center_m), static_cast<float>(box.angle_rad));
    for (int i = 0; i < shape.m_count; ++i) extend_bounds(from_b2(shape.m_vertices[i]));
    fixture.shape = &shape;
    add_static(fixture, box.height_m);
  }
  for (const CircleDef& circle : world.circles) {
    b2CircleShape shape;
    shape.m_p = to_b2(circle.center_m);
    shape.m_radius = static_cast<float>(circle.radius_m);
    extend_bounds(circle.center_m - Vec2::Constant(circle.radius_m));
    extend_bounds(circle.center_m + Vec2::Constant(circle.radius_m));
    fixture.shape = &shape;
    add_static(fixture, circle.height_m);
  }
  for (const PolygonDef& polygon : world.polygons) {
    std::vector<b2Vec2> points;
    for (const Vec2& p : polygon.points_m) {
      points.push_back(to_b2(p));
      extend_bounds(p);
    }
    b2PolygonShape shape;
    shape.Set(points.data(), static_cast<int32>(points.size()));
    fixture.shape = &shape;
    add_static(fixture, polygon.height_m);
  }
}

void PhysicsWorld::add_map(const OccupancyMapDef& map) {
  b2FixtureDef fixture;
  fixture.friction = 0.3f;
  const double res = map.resolution_m;
  const int height = map.height_px;
  for (const OccupancyMapDef::Rect& rect : map.rects) {
    // Map frame: x right, y up, origin at the lower-left corner of the bottom-left pixel.
    const Vec2 lo{rect.col * res, (height - rect.end_row) * res};
    const Vec2 hi{rect.end_col * res, (height - rect.row) * res};
    const Vec2 center = map.origin.transform(0.5 * (lo + hi));
    const Vec2 half = 0.5 * (hi - lo);
    b2PolygonShape shape;
    shape.SetAsBox(static_cast<float>(half.x()), static_cast<float>(half.y()), to_b2(center),
                   static_cast<float>(map.origin.theta));
    for (int i = 0; i < shape.m_count; ++i) extend_bounds(from_b2(shape.m_vertices[i]));
    fixture.shape = &shape;
    static_body_->CreateFixture(&fixture);
  }
}

void PhysicsWorld::add_static(const b2FixtureDef& fixture, double height_m) {
  const b2Fixture* created = static_body_->CreateFixture(&fixture);
  if (height_m != kFullHeight) static_heights_[created] = height_m;
}

double PhysicsWorld::static_height_m(const b2Fixture* fixture) const {
  const auto it = static_heights_.find(fixture);
  return it == static_heights_.end() ? kFullHeight : it->second;
}

int PhysicsWorld::static_fixture_count() const {
  int count = 0;
  for (const b2Fixture* f = static_body_->GetFixtureList(); f != nullptr; f = f->GetNext()) ++count;
  return count;
}

void PhysicsWorld::drive_movers(double dt_s) {
  for (Mover& mover : movers_) {
    if (!mover.moving || mover.finished || mover.def.path_m.size() < 2) {
      mover.body->SetLinearVelocity(b2Vec2_zero);
      mover.body->SetAngularVelocity(0.0f);
      continue;
    }
    Vec2 position = from_b2(mover.body->GetPosition());
    double budget_m = mover.def.speed_mps * dt_s;  // distance to cover this step
    Vec2 target_position = position;
    // Walk along the path for this step's distance, passing waypoints as needed, and set the
    // velocity that lands the body exactly there: movers never overshoot their corners.
    while (budget_m > 1e-12) {
      const Vec2 waypoint = mover.def.path_m[mover.next_waypoint];
      const double remaining = (waypoint - target_position).norm();
      if (remaining > budget_m) {
        target_position += (waypoint - target_position) * (budget_m / remaining);
        break;
      }
      target_position = waypoint;
      budget_m -= remaining;
      if (mover.next_waypoint + 1 < mover.def.path_m.size()) {
        ++mover.next_waypoint;
      } else if (mover.def.loop) {
        mover.next_waypoint = 0;
      } else {
        mover.finished = true;
        break;
      }
    }
    const Vec2 velocity = (target_position - position) / dt_s;
    mover.body->SetLinearVelocity(to_b2(velocity));
    if (velocity.norm() > 1e-6) {
      const double heading = std::atan2(velocity.y(), velocity.x());
      const double turn = wrap_angle(heading - mover.body->GetAngle());
      mover.body->SetAngularVelocity(static_cast<float>(turn / dt_s));
    } else {
      mover.body->SetAngularVelocity(0.0f);
    }
  }
}

void PhysicsWorld::step(double dt_s) {
  world_->Step(static_cast<float>(dt_s), physics_.velocity_iterations,
               physics_.position_iterations);
}

std::vector<ContactChange> PhysicsWorld::take_contact_changes() {
  std::vector<ContactChange> out;
  out.swap(contacts_->changes);
  return out;
}

bool PhysicsWorld::is_free(const b2Shape& shape, const Pose2& pose, const b2Body* ignore) const {
  return overlaps_none(shape, pose, ignore, nullptr);
}

bool PhysicsWorld::is_free_of_static(const b2Shape& shape, const Pose2& pose) const {
  return overlaps_none(shape, pose, nullptr, static_body_);
}

bool PhysicsWorld::overlaps_none(const b2Shape& shape, const Pose2& pose, const b2Body* ignore,
                                 const b2Body* only) const {
  b2Transform transform;
  transform.Set(to_b2(pose.position()), static_cast<float>(pose.theta));
  b2AABB box;
  shape.ComputeAABB(&box, transform, 0);
  struct Query : b2QueryCallback {
    const b2Shape* shape;
    b2Transform transform;
    const b2Body* ignore;
    const b2Body* only;
    bool hit = false;
    bool ReportFixture(b2Fixture* fixture) override {
      if (fixture->GetBody() == ignore) return true;
      if (only != nullptr && fixture->GetBody() != only) return true;
      const b2Transform& other = fixture->GetBody()->GetTransform();
      if (b2TestOverlap(shape, 0, fixture->GetShape(), 0, transform, other)) {
        hit = true;
        return false;
      }
      return true;
    }
  } query;
  query.shape = &shape;
  query.transform = transform;
  query.ignore = ignore;
  query.only = only;
  world_->QueryAABB(&query, box);
  return !query.hit;
}

std::optional<double> PhysicsWorld::ray_cast(const Vec2& from, const Vec2& to,
                                             const b2Body* ignore) const {
  struct Closest : b2RayCastCallback {
    const b2Body* ignore;
    float fraction = 2.0f;
    float ReportFixture(b2Fixture* fixture, const b2Vec2&, const b2Vec2&, float f) override {
      if (fixture->GetBody() == ignore) return -1.0f;  // skip, continue
      fraction = f;
      return f;  // clip the ray to the closest hit so far
    }
  } closest;
  closest.ignore = ignore;
  // Box2D asserts on a ray of zero length in float: far from the origin (a robot driven out of
  // its world) a short ray is one.
  const b2Vec2 from_f = to_b2(from), to_f = to_b2(to);
  if ((to - from).squaredNorm() < 1e-12 || !((to_f - from_f).LengthSquared() > 0.0f)) {
    return std::nullopt;
  }
  world_->RayCast(&closest, from_f, to_f);
  if (closest.fraction > 1.0f) return std::nullopt;
  return closest.fraction * (to - from).norm();
}

}  // namespace locsim

// ---------------------------------------------------------------------------------------------
// Box2D 2.4's profiling timer, made free. b2World::Step times itself and each phase (b2Profile)
// with about ten b2Timer calls per step, each a gettimeofday: on the 2-core VM about half of the
// demo's physics-only time. locsim never reads b2Profile. These definitions take the place of
// libbox2d's own (which calls them through its PLT, so the program's definitions win: ELF symbol
// interposition), keeping Debian's package as the dependency. Nothing simulated depends on them:
// the state hash is the same with either (tests/physics_test.cpp checks they are the ones used).
b2Timer::b2Timer() = default;
void b2Timer::Reset() {}
float b2Timer::GetMilliseconds() const {
  return 0.0f;
}
