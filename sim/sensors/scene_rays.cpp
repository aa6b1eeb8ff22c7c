#include "sim/sensors/scene_rays.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>

#include "sim/common/errors.hpp"
#include "sim/world/physics_world.hpp"

namespace locsim {

StaticRaycaster::StaticRaycaster(std::vector<Segment> segments, std::vector<CircleObstacle> circles)
    : segments_(std::move(segments)), circles_(std::move(circles)) {
  const std::size_t item_count = segments_.size() + circles_.size();
  if (item_count == 0) {
    cells_.resize(1);
    return;
  }
  Vec2 lo = Vec2::Constant(std::numeric_limits<double>::max());
  Vec2 hi = -lo;
  const auto item_box = [&](std::size_t item, Vec2& box_lo, Vec2& box_hi) {
    if (item < segments_.size()) {
      box_lo = segments_[item].a.cwiseMin(segments_[item].b);
      box_hi = segments_[item].a.cwiseMax(segments_[item].b);
    } else {
      const CircleObstacle& c = circles_[item - segments_.size()];
      box_lo = c.center - Vec2::Constant(c.radius_m);
      box_hi = c.center + Vec2::Constant(c.radius_m);
    }
  };
  for (std::size_t i = 0; i < item_count; ++i) {
    Vec2 box_lo, box_hi;
    item_box(i, box_lo, box_hi);
    lo = lo.cwiseMin(box_lo);
    hi = hi.cwiseMax(box_hi);
  }
  lo -= Vec2::Constant(0.01);
  hi += Vec2::Constant(0.01);
  // About one item per cell, within limits that keep the grid small and the cells useful.
  const Vec2 size = hi - lo;
  double cell_m =
      std::clamp(std::sqrt(size.x() * size.y() / static_cast<double>(item_count)), 0.2, 2.0);
  // A large world (kilometres of walls, long diagonal walls whose boxes cover many cells) gets
  // coarser cells until the grid fits: it stays an acceleration, never a memory hazard. Counted
  // in doubles before anything is allocated.
  for (;;) {
    const double columns = std::max(1.0, std::ceil(size.x() / cell_m));
    const double rows = std::max(1.0, std::ceil(size.y() / cell_m));
    double entries = 0.0;
    for (std::size_t i = 0; i < item_count; ++i) {
      Vec2 box_lo, box_hi;
      item_box(i, box_lo, box_hi);
      entries += (std::floor((box_hi.x() - lo.x()) / cell_m) -
                  std::floor((box_lo.x() - lo.x()) / cell_m) + 1.0) *
                 (std::floor((box_hi.y() - lo.y()) / cell_m) -
                  std::floor((box_lo.y() - lo.y()) / cell_m) + 1.0);
    }
    if ((columns * rows <= kMaxCells && entries <= kMaxEntries) || columns * rows == 1.0) {
      grid_ = UniformGrid{lo, cell_m, static_cast<int>(columns), static_cast<int>(rows)};
      break;
    }
    cell_m *= 2.0;
  }
  cells_.assign(grid_.cell_count(), Cell{});

  // Two passes: count the items of each cell, then fill (compressed rows).
  const auto cell_range = [&](std::size_t item, int& c0, int& r0, int& c1, int& r1) {
    Vec2 box_lo, box_hi;
    item_box(item, box_lo, box_hi);
    grid_.cell_range(box_lo, box_hi, c0, r0, c1, r1);
  };
  const auto columns = static_cast<std::size_t>(grid_.columns);
  for (std::size_t i = 0; i < item_count; ++i) {
    int c0, r0, c1, r1;
    cell_range(i, c0, r0, c1, r1);
    for (int r = r0; r <= r1; ++r) {
      for (int c = c0; c <= c1; ++c) ++cells_[r * columns + c].count;
    }
  }
  std::uint32_t offset = 0;
  for (Cell& cell : cells_) {
    cell.first = offset;
    offset += cell.count;
    cell.count = 0;
  }
  items_.resize(offset);
  for (std::size_t i = 0; i < item_count; ++i) {
    int c0, r0, c1, r1;
    cell_range(i, c0, r0, c1, r1);
    for (int r = r0; r <= r1; ++r) {
      for (int c = c0; c <= c1; ++c) {
        Cell& cell = cells_[r * columns + c];
        items_[cell.first + cell.count++] = static_cast<std::uint32_t>(i);
      }
    }
  }
}

StaticRaycaster StaticRaycaster::from_world(const PhysicsWorld& world) {
  const Activity building("building the sensors' ray grid");
  std::vector<Segment> segments;
  std::vector<CircleObstacle> circles;
  const b2Body* body = world.static_body();
  const b2Transform& xf = body->GetTransform();
  const auto to_world = [&](const b2Vec2& local) { return from_b2(b2Mul(xf, local)); };
  for (const b2Fixture* f = body->GetFixtureList(); f != nullptr; f = f->GetNext()) {
    const double height = world.static_height_m(f);
    switch (f->GetType()) {
      case b2Shape::e_edge: {
        const auto* edge = static_cast<const b2EdgeShape*>(f->GetShape());
        segments.push_back({to_world(edge->m_vertex1), to_world(edge->m_vertex2), height});
        break;
      }
      case b2Shape::e_polygon: {
        const auto* polygon = static_cast<const b2PolygonShape*>(f->GetShape());
        for (int i = 0; i < polygon->m_count; ++i) {
          segments.push_back({to_world(polygon->m_vertices[i]),
                              to_world(polygon->m_vertices[(i + 1) % polygon->m_count]), height});
        }
        break;
      }
      case b2Shape::e_circle: {
        const auto* circle = static_cast<const b2CircleShape*>(f->GetShape());
        circles.push_back({to_world(circle->m_p), circle->m_radius, height});
        break;
      }
      case b2Shape::e_chain: {
        const auto* chain = static_cast<const b2ChainShape*>(f->GetShape());
        for (int i = 0; i + 1 < chain->m_count; ++i) {
          segments.push_back(
              {to_world(chain->m_vertices[i]), to_world(chain->m_vertices[i + 1]), height});
        }
        break;
      }
      default:
        break;
    }
  }
  return StaticRaycaster(std::move(segments), std::move(circles));
}

double StaticRaycaster::hit(std::uint32_t item, const Vec2& o, const Vec2& d) const {
  if (item < segments_.size()) {
    const Segment& s = segments_[item];
    const Vec2 e = s.b - s.a;
    const double denominator = cross(d, e);
    if (std::abs(denominator) < 1e-12) return kNoHit;  // parallel
    const Vec2 ao = s.a - o;
    const double t = cross(ao, e) / denominator;
    const double u = cross(ao, d) / denominator;
    return (t >= 0.0 && u >= 0.0 && u <= 1.0) ? t : kNoHit;
  }
  const CircleObstacle& c = circles_[item - segments_.size()];
  const Vec2 oc = o - c.center;
  const double b = oc.dot(d);
  const double q = oc.squaredNorm() - c.radius_m * c.radius_m;
  if (q <= 0.0) return 0.0;  // starts inside
  const double discriminant = b * b - q;
  if (discriminant < 0.0) return kNoHit;
  const double t = -b - std::sqrt(discriminant);
  return t >= 0.0 ? t : kNoHit;
}

double StaticRaycaster::height(std::uint32_t item) const {
  return item < segments_.size() ? segments_[item].height_m
                                 : circles_[item - segments_.size()].height_m;
}

void UniformGrid::cell_range(const Vec2& box_lo, const Vec2& box_hi, int& c0, int& r0, int& c1,
                             int& r1) const {
  c0 = std::clamp(static_cast<int>((box_lo.x() - origin.x()) / cell_m), 0, columns - 1);
  c1 = std::clamp(static_cast<int>((box_hi.x() - origin.x()) / cell_m), 0, columns - 1);
  r0 = std::clamp(static_cast<int>((box_lo.y() - origin.y()) / cell_m), 0, rows - 1);
  r1 = std::clamp(static_cast<int>((box_hi.y() - origin.y()) / cell_m), 0, rows - 1);
}

template <class Visit>
void UniformGrid::traverse(const Vec2& o, const Vec2& d, double max_range, Visit visit) const {
  // Clip the ray to the grid (slabs).
  double t_enter = 0.0, t_exit = max_range;
  const Vec2 grid_hi = origin + Vec2(columns * cell_m, rows * cell_m);
  for (int axis = 0; axis < 2; ++axis) {
    if (std::abs(d[axis]) < 1e-15) {
      if (o[axis] < origin[axis] || o[axis] > grid_hi[axis]) return;
      continue;
    }
    double t0 = (origin[axis] - o[axis]) / d[axis];
    double t1 = (grid_hi[axis] - o[axis]) / d[axis];
    if (t0 > t1) std::swap(t0, t1);
    t_enter = std::max(t_enter, t0);
    t_exit = std::min(t_exit, t1);
  }
  if (t_enter > t_exit) return;

  const Vec2 start = o + t_enter * d - origin;
  int column = std::clamp(static_cast<int>(start.x() / cell_m), 0, columns - 1);
  int row = std::clamp(static_cast<int>(start.y() / cell_m), 0, rows - 1);
  const int step_column = d.x() > 0 ? 1 : -1;
  const int step_row = d.y() > 0 ? 1 : -1;
  const bool moves_x = std::abs(d.x()) > 1e-15, moves_y = std::abs(d.y()) > 1e-15;
  const double delta_x = moves_x ? cell_m / std::abs(d.x()) : kNoHit;
  const double delta_y = moves_y ? cell_m / std::abs(d.y()) : kNoHit;
  double next_x =
      moves_x ? (origin.x() + (column + (step_column > 0)) * cell_m - o.x()) / d.x() : kNoHit;
  double next_y = moves_y ? (origin.y() + (row + (step_row > 0)) * cell_m - o.y()) / d.y() : kNoHit;
  while (true) {
    const double cell_exit = std::min(next_x, next_y);
    if (visit(static_cast<std::size_t>(row) * columns + column, cell_exit)) return;
    if (cell_exit > t_exit) return;
    if (next_x < next_y) {
      column += step_column;
      next_x += delta_x;
      if (column < 0 || column >= columns) return;
    } else {
      row += step_row;
      next_y += delta_y;
      if (row < 0 || row >= rows) return;
    }
  }
}

template <class Visit>
void StaticRaycaster::traverse(const Vec2& o, const Vec2& d, double max_range, Visit visit) const {
  if (items_.empty()) return;
  grid_.traverse(o, d, max_range, [&](std::size_t cell, double cell_exit) {
    return visit(cells_[cell], cell_exit);
  });
}

double StaticRaycaster::cast(const Vec2& o, const Vec2& d, double max_range) const {
  double best = kNoHit;
  traverse(o, d, max_range, [&](const Cell& cell, double cell_exit) {
    for (std::uint32_t k = 0; k < cell.count; ++k) {
      best = std::min(best, hit(items_[cell.first + k], o, d));
    }
    // A hit before this cell's exit cannot be beaten by items of cells further along.
    return best <= cell_exit;
  });
  return best <= max_range ? best : kNoHit;
}

bool StaticRaycaster::blocked(const Vec2& a, double za_m, const Vec2& b, double zb_m) const {
  const double length = (b - a).norm();
  if (length < 1e-9) return false;
  const Vec2 d = (b - a) / length;
  bool found = false;
  traverse(a, d, length, [&](const Cell& cell, double) {
    for (std::uint32_t k = 0; k < cell.count && !found; ++k) {
      const std::uint32_t item = items_[cell.first + k];
      const double t = hit(item, a, d);
      found = t < length - 1e-9 && za_m + (zb_m - za_m) * t / length < height(item);
    }
    return found;
  });
  return found;
}

namespace {
/// First entry of the ray into `body` within max_range, or kNoHit.
double cast_body(const b2Body* body, const Vec2& o, const Vec2& d, double max_range) {
  b2RayCastInput input;
  input.p1 = to_b2(o);
  input.p2 = to_b2(o + max_range * d);
  input.maxFraction = 1.0f;
  double best = kNoHit;
  for (const b2Fixture* f = body->GetFixtureList(); f != nullptr; f = f->GetNext()) {
    b2RayCastOutput output;
    if (f->RayCast(&output, input, 0)) best = std::min(best, output.fraction * max_range);
  }
  return best;
}

bool near_ray(const DynamicOccluder& occluder, const Vec2& o, const Vec2& d, double max_range) {
  const Vec2 to_body = from_b2(occluder.body->GetPosition()) - o;
  const double along = std::clamp(to_body.dot(d), 0.0, max_range);
  return (to_body - along * d).squaredNorm() <= occluder.radius_m * occluder.radius_m;
}
}  // namespace

namespace {
/// A bounding circle's radius as filed in the moving bodies' grid: wider than near_ray's test by
/// more than any rounding in it or in the grid's traversal, so that no body near_ray would pass
/// is missing from the cells a ray crosses.
double filed_radius_m(const DynamicOccluder& occluder) {
  return occluder.radius_m * (1.0 + 1e-9) + 1e-6;
}

/// A thread's scratch for gathering candidates: a bit per body (all clear between queries), and
/// the list the set bits are read into, in ascending order, each once (no sort).
struct CandidateScratch {
  std::vector<std::uint64_t> bits;
  std::vector<std::uint32_t> bodies;
};
CandidateScratch& scratch(std::size_t body_count) {
  thread_local CandidateScratch s;
  if (s.bits.size() < (body_count + 63) / 64) s.bits.resize((body_count + 63) / 64, 0);
  return s;
}
/// Reads the set bits of words [lo, hi] into s.bodies in order, clearing them.
std::span<const std::uint32_t> drain(CandidateScratch& s, std::size_t lo, std::size_t hi) {
  s.bodies.clear();
  for (std::size_t w = lo; w <= hi && w < s.bits.size(); ++w) {
    for (std::uint64_t word = s.bits[w]; word != 0; word &= word - 1)
      s.bodies.push_back(static_cast<std::uint32_t>(64 * w + std::countr_zero(word)));
    s.bits[w] = 0;
  }
  return s.bodies;
}
}  // namespace

void SceneRays::build_index() {
  index_valid_ = false;
  if (dynamics_.size() < kIndexFromBodies) return;
  // The enabled bodies' padded boxes; the grid spans them, cells about one body each (but no
  // smaller than a body, which would file it in many cells).
  Vec2 lo = Vec2::Constant(std::numeric_limits<double>::max()), hi = -lo;
  double largest_m = 0.0;
  std::size_t enabled = 0;
  for (const DynamicOccluder& occluder : dynamics_) {
    if (!occluder.body->IsEnabled()) continue;
    const double r = filed_radius_m(occluder);
    const Vec2 center = from_b2(occluder.body->GetPosition());
    lo = lo.cwiseMin(center - Vec2::Constant(r));
    hi = hi.cwiseMax(center + Vec2::Constant(r));
    largest_m = std::max(largest_m, r);
    ++enabled;
  }
  index_first_.clear();
  index_bodies_.clear();
  if (enabled == 0) {
    index_grid_ = UniformGrid{};
    index_first_.assign(2, 0);
    index_valid_ = true;
    return;
  }
  const Vec2 size = hi - lo;
  // At most 4 cells a body whatever their spread (one far-off body makes the cells coarse: the
  // grid is then no help, but also no harm).
  const double max_cells = 4.0 * static_cast<double>(enabled);
  double cell_m = std::max(
      {std::sqrt(size.x() * size.y() / static_cast<double>(enabled)), 2.0 * largest_m, 1e-3});
  while (std::ceil(size.x() / cell_m) * std::ceil(size.y() / cell_m) > max_cells) cell_m *= 2.0;
  index_grid_ = UniformGrid{lo, cell_m, std::max(1, static_cast<int>(std::ceil(size.x() / cell_m))),
                            std::max(1, static_cast<int>(std::ceil(size.y() / cell_m)))};
  // Compressed rows, bodies in ascending order within each cell: count, then fill.
  const auto columns = static_cast<std::size_t>(index_grid_.columns);
  index_first_.assign(index_grid_.cell_count() + 1, 0);
  const auto for_each_filing = [&](auto file) {
    for (std::uint32_t i = 0; i < dynamics_.size(); ++i) {
      const DynamicOccluder& occluder = dynamics_[i];
      if (!occluder.body->IsEnabled()) continue;
      const double r = filed_radius_m(occluder);
      const Vec2 center = from_b2(occluder.body->GetPosition());
      int c0, r0, c1, r1;
      index_grid_.cell_range(center - Vec2::Constant(r), center + Vec2::Constant(r), c0, r0, c1,
                             r1);
      for (int row = r0; row <= r1; ++row) {
        for (int column = c0; column <= c1; ++column) file(row * columns + column, i);
      }
    }
  };
  for_each_filing([&](std::size_t cell, std::uint32_t) { ++index_first_[cell + 1]; });
  for (std::size_t c = 0; c + 1 < index_first_.size(); ++c) index_first_[c + 1] += index_first_[c];
  index_bodies_.resize(index_first_.back());
  std::vector<std::uint32_t>& next = index_fill_;
  next.assign(index_first_.begin(), index_first_.end() - 1);
  for_each_filing(
      [&](std::size_t cell, std::uint32_t body) { index_bodies_[next[cell]++] = body; });
  index_valid_ = true;
}

template <class Visit>
void SceneRays::visit_filed_along(const Vec2& o, const Vec2& d, double length, Visit visit) const {
  index_grid_.traverse(o, d, length, [&](std::size_t cell, double) {
    for (std::uint32_t k = index_first_[cell]; k < index_first_[cell + 1]; ++k) {
      if (visit(index_bodies_[k])) return true;
    }
    return false;
  });
}

std::span<const std::uint32_t> SceneRays::indexed_along(const Vec2& o, const Vec2& d,
                                                        double length) const {
  CandidateScratch& s = scratch(dynamics_.size());
  std::size_t lo = s.bits.size(), hi = 0;
  visit_filed_along(o, d, length, [&](std::uint32_t body) {
    s.bits[body / 64] |= std::uint64_t{1} << (body % 64);
    lo = std::min<std::size_t>(lo, body / 64);
    hi = std::max<std::size_t>(hi, body / 64);
    return false;
  });
  return drain(s, lo, hi);
}

std::span<const std::uint32_t> SceneRays::indexed_in_box(const Vec2& lo, const Vec2& hi) const {
  CandidateScratch& s = scratch(dynamics_.size());
  // Boxes off the grid: cell_range clamps to the grid's border cells, which only adds bodies.
  int c0, r0, c1, r1;
  index_grid_.cell_range(lo, hi, c0, r0, c1, r1);
  const auto columns = static_cast<std::size_t>(index_grid_.columns);
  std::size_t word_lo = s.bits.size(), word_hi = 0;
  for (int row = r0; row <= r1; ++row) {
    for (std::uint32_t k = index_first_[row * columns + c0];
         k < index_first_[row * columns + c1 + 1]; ++k) {
      const std::uint32_t body = index_bodies_[k];
      s.bits[body / 64] |= std::uint64_t{1} << (body % 64);
      word_lo = std::min<std::size_t>(word_lo, body / 64);
      word_hi = std::max<std::size_t>(word_hi, body / 64);
    }
  }
  return drain(s, word_lo, word_hi);
}

template <class Visit>
void SceneRays::for_each_body_near(const Vec2& o, const Vec2& d, double length,
                                   const b2Body* ignore, Visit visit) const {
  const auto consider = [&](const DynamicOccluder& occluder) {
    return occluder.body != ignore && occluder.body->IsEnabled() && visit(occluder);
  };
  if (!index_valid_) {
    for (const DynamicOccluder& occluder : dynamics_) {
      if (consider(occluder)) return;
    }
    return;
  }
  for (const std::uint32_t i : indexed_along(o, d, length)) {
    if (consider(dynamics_[i])) return;
  }
}

double SceneRays::cast(const Vec2& o, const Vec2& d, double max_range, const b2Body* ignore) const {
  double best = statics_.cast(o, d, max_range);
  for_each_body_near(o, d, std::min(best, max_range), ignore, [&](const DynamicOccluder& occluder) {
    if (near_ray(occluder, o, d, std::min(best, max_range)))
      best = std::min(best, cast_body(occluder.body, o, d, std::min(best, max_range)));
    return false;
  });
  return best;
}

double SceneRays::cast(const Vec2& o, const Vec2& d, double max_range,
                       std::span<const std::uint32_t> candidates) const {
  // The loop above over a subset that holds every body near_ray can pass, in the same order.
  double best = statics_.cast(o, d, max_range);
  for (const std::uint32_t index : candidates) {
    const DynamicOccluder& occluder = dynamics_[index];
    if (!near_ray(occluder, o, d, std::min(best, max_range))) continue;
    best = std::min(best, cast_body(occluder.body, o, d, std::min(best, max_range)));
  }
  return best;
}

void SceneRays::fan_candidates(const Vec2& o, double heading_rad,
                               std::span<const double> angles_rad, double max_range,
                               const b2Body* ignore, FanCandidates& out) const {
  const std::size_t rays = angles_rad.size();
  out.spans_.clear();
  const auto add = [&](std::uint32_t body, double lo_rad, double hi_rad) {
    const auto lo = std::lower_bound(angles_rad.begin(), angles_rad.end(), lo_rad);
    const auto hi = std::upper_bound(lo, angles_rad.end(), hi_rad);
    if (lo != hi) {
      out.spans_.push_back({body, static_cast<std::uint32_t>(lo - angles_rad.begin()),
                            static_cast<std::uint32_t>(hi - angles_rad.begin())});
    }
  };
  // Wider than the exact tangent angle: rounding in the beams' directions (1e-15) and in near_ray
  // must never drop a body that near_ray would pass.
  constexpr double kPadRad = 1e-6;
  const auto consider = [&](std::uint32_t i) {
    const DynamicOccluder& occluder = dynamics_[i];
    if (occluder.body == ignore || !occluder.body->IsEnabled()) return;
    const Vec2 to_body = from_b2(occluder.body->GetPosition()) - o;
    const double distance = to_body.norm();
    const double radius = occluder.radius_m * (1.0 + 1e-9) + 1e-9;
    if (distance <= radius) {  // the origin is within its bounding circle: any ray may hit it
      add(i, -kNoHit, kNoHit);
      return;
    }
    if (distance - radius > max_range) return;  // out of reach of every ray
    const double half_width = std::asin(radius / distance) + kPadRad;
    const double bearing =
        std::remainder(std::atan2(to_body.y(), to_body.x()) - heading_rad, 2.0 * std::numbers::pi);
    // The angle window, and its copies a turn either way (a fan crossing +-pi).
    for (const double turn : {0.0, -2.0 * std::numbers::pi, 2.0 * std::numbers::pi})
      add(i, bearing + turn - half_width, bearing + turn + half_width);
  };
  // In the body order either way: with the index, only the bodies filed in the cells within
  // reach (their filed radius covers the test above's).
  if (index_valid_) {
    const Vec2 reach = Vec2::Constant(max_range);
    for (const std::uint32_t i : indexed_in_box(o - reach, o + reach)) consider(i);
  } else {
    for (std::uint32_t i = 0; i < dynamics_.size(); ++i) consider(i);
  }
  // Compressed rows, filled body by body: each ray's list is in the body order.
  out.first_.assign(rays + 1, 0);
  for (const FanCandidates::Span& span : out.spans_) {
    for (std::uint32_t r = span.ray_lo; r < span.ray_hi; ++r) ++out.first_[r + 1];
  }
  for (std::size_t r = 0; r < rays; ++r) out.first_[r + 1] += out.first_[r];
  out.bodies_.resize(out.first_[rays]);
  std::vector<std::uint32_t>& next = out.fill_;
  next.assign(out.first_.begin(), out.first_.end() - 1);
  for (const FanCandidates::Span& span : out.spans_) {
    for (std::uint32_t r = span.ray_lo; r < span.ray_hi; ++r) out.bodies_[next[r]++] = span.body;
  }
}

bool SceneRays::blocked(const Vec2& a, double za_m, const Vec2& b, double zb_m,
                        const b2Body* ignore) const {
  const double length = (b - a).norm();
  if (length < 1e-9) return false;
  const Vec2 d = (b - a) / length;
  if (statics_.blocked(a, za_m, b, zb_m)) return true;
  // Whether any body blocks does not depend on the order they are tested in: through the grid,
  // straight from the cells (a body filed in two cells the line crosses is tested twice).
  const auto blocks = [&](const DynamicOccluder& occluder) {
    if (occluder.body == ignore || !occluder.body->IsEnabled()) return false;
    if (!near_ray(occluder, a, d, length)) return false;
    const double t = cast_body(occluder.body, a, d, length);
    return t < length && za_m + (zb_m - za_m) * t / length < occluder.height_m;
  };
  if (index_valid_) {
    bool found = false;
    visit_filed_along(a, d, length, [&](std::uint32_t i) { return found = blocks(dynamics_[i]); });
    return found;
  }
  return std::any_of(dynamics_.begin(), dynamics_.end(), blocks);
}

bool SceneRays::blocked(const Vec2& a, const Vec2& b, const b2Body* ignore) const {
  const double length = (b - a).norm();
  return length > 1e-9 && cast(a, (b - a) / length, length, ignore) < length - 1e-9;
}

}  // namespace locsim
