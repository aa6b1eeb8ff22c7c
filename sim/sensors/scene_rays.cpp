#include "sim/sensors/scene_rays.hpp"

#include <algorithm>
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
  cell_m_ = std::clamp(std::sqrt(size.x() * size.y() / static_cast<double>(item_count)), 0.2, 2.0);
  origin_ = lo;
  // A large world (kilometres of walls, long diagonal walls whose boxes cover many cells) gets
  // coarser cells until the grid fits: it stays an acceleration, never a memory hazard. Counted
  // in doubles before anything is allocated.
  for (;;) {
    const double columns = std::max(1.0, std::ceil(size.x() / cell_m_));
    const double rows = std::max(1.0, std::ceil(size.y() / cell_m_));
    double entries = 0.0;
    for (std::size_t i = 0; i < item_count; ++i) {
      Vec2 box_lo, box_hi;
      item_box(i, box_lo, box_hi);
      entries += (std::floor((box_hi.x() - lo.x()) / cell_m_) -
                  std::floor((box_lo.x() - lo.x()) / cell_m_) + 1.0) *
                 (std::floor((box_hi.y() - lo.y()) / cell_m_) -
                  std::floor((box_lo.y() - lo.y()) / cell_m_) + 1.0);
    }
    if ((columns * rows <= kMaxCells && entries <= kMaxEntries) || columns * rows == 1.0) {
      columns_ = static_cast<int>(columns);
      rows_ = static_cast<int>(rows);
      break;
    }
    cell_m_ *= 2.0;
  }
  cells_.assign(static_cast<std::size_t>(columns_) * rows_, Cell{});

  // Two passes: count the items of each cell, then fill (compressed rows).
  const auto cell_range = [&](std::size_t item, int& c0, int& r0, int& c1, int& r1) {
    Vec2 box_lo, box_hi;
    item_box(item, box_lo, box_hi);
    c0 = std::clamp(static_cast<int>((box_lo.x() - origin_.x()) / cell_m_), 0, columns_ - 1);
    c1 = std::clamp(static_cast<int>((box_hi.x() - origin_.x()) / cell_m_), 0, columns_ - 1);
    r0 = std::clamp(static_cast<int>((box_lo.y() - origin_.y()) / cell_m_), 0, rows_ - 1);
    r1 = std::clamp(static_cast<int>((box_hi.y() - origin_.y()) / cell_m_), 0, rows_ - 1);
  };
  for (std::size_t i = 0; i < item_count; ++i) {
    int c0, r0, c1, r1;
    cell_range(i, c0, r0, c1, r1);
    for (int r = r0; r <= r1; ++r) {
      for (int c = c0; c <= c1; ++c) ++cells_[static_cast<std::size_t>(r) * columns_ + c].count;
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
        Cell& cell = cells_[static_cast<std::size_t>(r) * columns_ + c];
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

template <class Visit>
void StaticRaycaster::traverse(const Vec2& o, const Vec2& d, double max_range, Visit visit) const {
  if (items_.empty()) return;
  // Clip the ray to the grid (slabs).
  double t_enter = 0.0, t_exit = max_range;
  const Vec2 grid_hi = origin_ + Vec2(columns_ * cell_m_, rows_ * cell_m_);
  for (int axis = 0; axis < 2; ++axis) {
    if (std::abs(d[axis]) < 1e-15) {
      if (o[axis] < origin_[axis] || o[axis] > grid_hi[axis]) return;
      continue;
    }
    double t0 = (origin_[axis] - o[axis]) / d[axis];
    double t1 = (grid_hi[axis] - o[axis]) / d[axis];
    if (t0 > t1) std::swap(t0, t1);
    t_enter = std::max(t_enter, t0);
    t_exit = std::min(t_exit, t1);
  }
  if (t_enter > t_exit) return;

  const Vec2 start = o + t_enter * d - origin_;
  int column = std::clamp(static_cast<int>(start.x() / cell_m_), 0, columns_ - 1);
  int row = std::clamp(static_cast<int>(start.y() / cell_m_), 0, rows_ - 1);
  const int step_column = d.x() > 0 ? 1 : -1;
  const int step_row = d.y() > 0 ? 1 : -1;
  const bool moves_x = std::abs(d.x()) > 1e-15, moves_y = std::abs(d.y()) > 1e-15;
  const double delta_x = moves_x ? cell_m_ / std::abs(d.x()) : kNoHit;
  const double delta_y = moves_y ? cell_m_ / std::abs(d.y()) : kNoHit;
  double next_x =
      moves_x ? (origin_.x() + (column + (step_column > 0)) * cell_m_ - o.x()) / d.x() : kNoHit;
  double next_y =
      moves_y ? (origin_.y() + (row + (step_row > 0)) * cell_m_ - o.y()) / d.y() : kNoHit;
  while (true) {
    const double cell_exit = std::min(next_x, next_y);
    if (visit(cells_[static_cast<std::size_t>(row) * columns_ + column], cell_exit)) return;
    if (cell_exit > t_exit) return;
    if (next_x < next_y) {
      column += step_column;
      next_x += delta_x;
      if (column < 0 || column >= columns_) return;
    } else {
      row += step_row;
      next_y += delta_y;
      if (row < 0 || row >= rows_) return;
    }
  }
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

double SceneRays::cast(const Vec2& o, const Vec2& d, double max_range, const b2Body* ignore) const {
  double best = statics_.cast(o, d, max_range);
  for (const DynamicOccluder& occluder : dynamics_) {
    if (occluder.body == ignore || !occluder.body->IsEnabled()) continue;
    if (!near_ray(occluder, o, d, std::min(best, max_range))) continue;
    best = std::min(best, cast_body(occluder.body, o, d, std::min(best, max_range)));
  }
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
  for (std::uint32_t i = 0; i < dynamics_.size(); ++i) {
    const DynamicOccluder& occluder = dynamics_[i];
    if (occluder.body == ignore || !occluder.body->IsEnabled()) continue;
    const Vec2 to_body = from_b2(occluder.body->GetPosition()) - o;
    const double distance = to_body.norm();
    const double radius = occluder.radius_m * (1.0 + 1e-9) + 1e-9;
    if (distance <= radius) {  // the origin is within its bounding circle: any ray may hit it
      add(i, -kNoHit, kNoHit);
      continue;
    }
    if (distance - radius > max_range) continue;  // out of reach of every ray
    const double half_width = std::asin(radius / distance) + kPadRad;
    const double bearing =
        std::remainder(std::atan2(to_body.y(), to_body.x()) - heading_rad, 2.0 * std::numbers::pi);
    // The angle window, and its copies a turn either way (a fan crossing +-pi).
    for (const double turn : {0.0, -2.0 * std::numbers::pi, 2.0 * std::numbers::pi})
      add(i, bearing + turn - half_width, bearing + turn + half_width);
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
  for (const DynamicOccluder& occluder : dynamics_) {
    if (occluder.body == ignore || !occluder.body->IsEnabled()) continue;
    if (!near_ray(occluder, a, d, length)) continue;
    const double t = cast_body(occluder.body, a, d, length);
    if (t < length && za_m + (zb_m - za_m) * t / length < occluder.height_m) return true;
  }
  return false;
}

bool SceneRays::blocked(const Vec2& a, const Vec2& b, const b2Body* ignore) const {
  const double length = (b - a).norm();
  return length > 1e-9 && cast(a, (b - a) / length, length, ignore) < length - 1e-9;
}

}  // namespace locsim
