// Line-of-sight and range queries for sensors. The static geometry (walls, shapes, map cells) is
// copied once into a uniform grid of segments and circles and traversed cell by cell (Amanatides
// and Woo), far cheaper than Box2D's general ray cast through its broad phase; what moves
// (people, carts, robots) is tested with Box2D's shape ray casts, body by body, the bodies a ray
// can reach found through a grid rebuilt while the sensors sample (crowds) or by testing each.
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

/// A uniform grid's geometry: cell (column, row) covers origin + [column, column + 1) x [row,
/// row + 1) cells of side cell_m. Shared by the static geometry's grid and the moving bodies'.
struct UniformGrid {
  Vec2 origin{0.0, 0.0};  // lower-left corner [m]
  double cell_m = 1.0;    // side of a cell [m]
  int columns = 1, rows = 1;

  std::size_t cell_count() const { return static_cast<std::size_t>(columns) * rows; }
  /// The cells a box covers, clamped to the grid: columns c0..c1, rows r0..r1.
  void cell_range(const Vec2& box_lo, const Vec2& box_hi, int& c0, int& r0, int& c1, int& r1) const;
  /// Visits the cells along the ray up to max_range in order, `visit(cell_index, cell_exit_t)`
  /// returning true to stop. Every cell the ray passes through is visited (up to rounding at the
  /// cells' corners, ~1e-15 of the coordinates).
  template <class Visit>
  void traverse(const Vec2& origin, const Vec2& direction, double max_range, Visit visit) const;
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
  template <class Visit>
  void traverse(const Vec2& origin, const Vec2& direction, double max_range, Visit visit) const;

  std::vector<Segment> segments_;
  std::vector<CircleObstacle> circles_;
  UniformGrid grid_;
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
  SceneRays(const SceneRays&) = delete;
  SceneRays& operator=(const SceneRays&) = delete;

  /// While it lives, the moving bodies' positions are indexed in a grid and the queries below
  /// test only the bodies in the cells a ray crosses (in the body order, so every result is the
  /// same double as testing each body: issue 21, a fleet's line-of-sight tests were O(robots^2)).
  /// The bodies must not move while it lives: a simulation holds one while its sensors sample
  /// (read-only, possibly on several threads) and drops it before the next physics step. Without
  /// one, or with few bodies (where the grid does not pay), every body is tested.
  class Indexed {
   public:
    explicit Indexed(SceneRays& rays) : rays_(rays) { rays_.build_index(); }
    ~Indexed() { rays_.index_valid_ = false; }
    Indexed(const Indexed&) = delete;
    Indexed& operator=(const Indexed&) = delete;

   private:
    SceneRays& rays_;
  };
  /// Bodies from which the grid is built (fewer are tested one by one).
  static constexpr std::size_t kIndexFromBodies = 16;
  /// True while an Indexed lives (and there are enough bodies).
  bool indexed() const { return index_valid_; }

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
  void build_index();
  /// With the index: visit(body index) for each body filed in the cells the segment o + t d,
  /// t in [0, length], crosses, cell after cell (a body filed in several, several times); visit
  /// returns true to stop. A body is filed in every cell its padded bounding box touches, so these
  /// hold every body whose bounding circle the segment meets.
  template <class Visit>
  void visit_filed_along(const Vec2& o, const Vec2& d, double length, Visit visit) const;
  /// With the index: the bodies (indices into dynamics_, ascending, each once) filed in the cells
  /// the segment crosses, or in the cells of a box. The span is a per-thread buffer, valid until
  /// the next call on the thread.
  std::span<const std::uint32_t> indexed_along(const Vec2& o, const Vec2& d, double length) const;
  std::span<const std::uint32_t> indexed_in_box(const Vec2& lo, const Vec2& hi) const;
  /// Calls visit(occluder) for each enabled moving body but `ignore`, in the body order, that
  /// the segment o + t d, t in [0, length], may pass near: all of them without the index, those
  /// in the cells the segment crosses with it. visit returns true to stop.
  template <class Visit>
  void for_each_body_near(const Vec2& o, const Vec2& d, double length, const b2Body* ignore,
                          Visit visit) const;

  const StaticRaycaster& statics_;
  std::vector<DynamicOccluder> dynamics_;
  // The moving bodies' grid (valid only while an Indexed lives): compressed rows of body indices.
  UniformGrid index_grid_;
  std::vector<std::uint32_t> index_first_;   // cells + 1 offsets into index_bodies_
  std::vector<std::uint32_t> index_bodies_;  // ascending within each cell
  std::vector<std::uint32_t> index_fill_;    // building: where each cell's next body goes
  bool index_valid_ = false;
};

}  // namespace locsim
