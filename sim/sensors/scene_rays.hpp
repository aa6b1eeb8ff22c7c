// Line-of-sight and range queries for sensors. The static geometry (walls, shapes, map cells) is
// copied once into a uniform grid of segments and circles and traversed cell by cell (Amanatides
// and Woo), far cheaper than Box2D's general ray cast through its broad phase; only what moves
// (people, carts, robots) is tested with Box2D's shape ray casts, body by body.
#pragma once

#include <box2d/box2d.h>

#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "sim/common/math.hpp"

namespace locsim {

class PhysicsWorld;

inline constexpr double kNoHit = std::numeric_limits<double>::infinity();

struct Segment {
  Vec2 a, b;
  double height_m = kNoHit;  // top above the floor; infinite: floor to ceiling [m]
};
struct CircleObstacle {
  Vec2 center;
  double radius_m = 0.0;
  double height_m = kNoHit;
};

class StaticRaycaster {
 public:
  // The grid's size limits: 32 MiB of cells, 64 MiB of item entries (cells get coarser until the
  // world fits).
  static constexpr double kMaxCells = 4194304.0;
  static constexpr double kMaxEntries = 16777216.0;

  StaticRaycaster(std::vector<Segment> segments, std::vector<CircleObstacle> circles);
  /// The static fixtures of a world (edges, polygons' edges, circles).
  static StaticRaycaster from_world(const PhysicsWorld& world);

  /// Distance along `unit_direction` to the first hit, or infinity when none within `max_range`.
  /// Heights are ignored: planar sensors see every obstacle.
  double cast(const Vec2& origin, const Vec2& unit_direction, double max_range) const;
  /// True when the line from (a, za) to (b, zb) passes through an obstacle below its top.
  bool blocked(const Vec2& a, double za_m, const Vec2& b, double zb_m) const;
  std::size_t segment_count() const { return segments_.size(); }
  /// Cells of the grid: at most kMaxCells, whatever the world.
  std::size_t cell_count() const { return cells_.size(); }

 private:
  struct Cell {
    std::uint32_t first = 0, count = 0;  // into items_
  };
  // Items: index < segments_.size() is a segment, else a circle.
  double hit(std::uint32_t item, const Vec2& origin, const Vec2& direction) const;
  double height(std::uint32_t item) const;
  /// Visits the cells along the ray up to max_range in order; `visit(cell, cell_exit_t)` returns
  /// true to stop.
  template <class Visit>
  void traverse(const Vec2& origin, const Vec2& direction, double max_range, Visit visit) const;

  std::vector<Segment> segments_;
  std::vector<CircleObstacle> circles_;
  Vec2 origin_{0.0, 0.0};  // lower-left corner of the grid [m]
  double cell_m_ = 1.0;
  int columns_ = 1, rows_ = 1;
  std::vector<Cell> cells_;
  std::vector<std::uint32_t> items_;
};

/// A moving body that blocks sensors: its Box2D body and its height.
struct DynamicOccluder {
  const b2Body* body = nullptr;
  double height_m = 1.0;
  double radius_m = 0.0;  // bounding radius about the body origin, to skip far bodies
};

/// A scan's broad phase over the moving bodies: for each ray of a fan from one origin, the moving
/// bodies it can reach (their bounding circles within its angle), so a scan costs O(bodies +
/// rays + what each ray can hit) instead of O(bodies x rays) (issue 21: 100 robots, each laser
/// testing every robot with every beam, was most of a fleet's time). Reused scan to scan.
class FanCandidates {
 public:
  /// Each ray's candidates, in the order of the body list (so a ray's min over them is computed in
  /// the same order as over all bodies, and gives the same bits).
  std::span<const std::uint32_t> of(std::size_t ray) const {
    return {bodies_.data() + first_[ray], first_[ray + 1] - first_[ray]};
  }

 private:
  friend class SceneRays;
  std::vector<std::uint32_t> first_;   // rays + 1 offsets into bodies_
  std::vector<std::uint32_t> bodies_;  // indices into the dynamic occluders
  struct Span {
    std::uint32_t body, ray_lo, ray_hi;  // rays [ray_lo, ray_hi)
  };
  std::vector<Span> spans_;
  std::vector<std::uint32_t> fill_;  // per ray: where its next body goes
};

/// Rays against everything: the static grid plus the moving bodies.
class SceneRays {
 public:
  SceneRays(const StaticRaycaster& statics, std::vector<DynamicOccluder> dynamics)
      : statics_(statics), dynamics_(std::move(dynamics)) {}

  /// First hit along the ray (static or moving, skipping `ignore`), or infinity.
  double cast(const Vec2& origin, const Vec2& unit_direction, double max_range,
              const b2Body* ignore) const;
  /// Fills `out` with the moving bodies (not `ignore`, enabled) that each ray of a fan from
  /// `origin` can hit within `max_range`: ray i points at heading_rad + angles_rad[i], the angles
  /// increasing within (-pi - step, pi]. Conservative: a body a ray passes near is always a
  /// candidate of that ray.
  void fan_candidates(const Vec2& origin, double heading_rad, std::span<const double> angles_rad,
                      double max_range, const b2Body* ignore, FanCandidates& out) const;
  /// cast() over the ray's candidates only: the same result, bit for bit.
  double cast(const Vec2& origin, const Vec2& unit_direction, double max_range,
              std::span<const std::uint32_t> candidates) const;
  /// True when the segment a-b (at heights za, zb above the floor) is blocked: by static
  /// geometry always (walls reach the ceiling), by a moving body where the line passes below
  /// the body's height.
  bool blocked(const Vec2& a, double za_m, const Vec2& b, double zb_m, const b2Body* ignore) const;
  /// 2D version: blocked by anything.
  bool blocked(const Vec2& a, const Vec2& b, const b2Body* ignore) const;

 private:
  const StaticRaycaster& statics_;
  std::vector<DynamicOccluder> dynamics_;
};

}  // namespace locsim
