#include "sim/world/occupancy.hpp"

#include <algorithm>
#include <cmath>

#include "sim/common/errors.hpp"
#include "sim/world/physics_world.hpp"

namespace locsim {

OccupancyGrid rasterize_static_world(const PhysicsWorld& world, double resolution_m) {
  const Activity building("building the localizers' occupancy grid");
  OccupancyGrid grid;
  grid.resolution_m = resolution_m;
  const Vec2 margin = Vec2::Constant(2.0 * resolution_m);
  grid.origin_m = world.bounds_min() - margin;
  const Vec2 size = world.bounds_max() + margin - grid.origin_m;
  grid.width = std::max(1, static_cast<int>(std::ceil(size.x() / resolution_m)));
  grid.height = std::max(1, static_cast<int>(std::ceil(size.y() / resolution_m)));
  grid.cells.assign(static_cast<std::size_t>(grid.width) * grid.height, 0);
  const auto mark = [&](const Vec2& p) {
    const int col = static_cast<int>(std::floor((p.x() - grid.origin_m.x()) / resolution_m));
    const int row = static_cast<int>(std::floor((p.y() - grid.origin_m.y()) / resolution_m));
    if (col >= 0 && row >= 0 && col < grid.width && row < grid.height) {
      grid.cells[static_cast<std::size_t>(row) * grid.width + col] = 100;
    }
  };
  const auto mark_segment = [&](const Vec2& a, const Vec2& b) {
    const int steps = std::max(1, static_cast<int>(std::ceil(4.0 * (b - a).norm() / resolution_m)));
    for (int i = 0; i <= steps; ++i) mark(a + (b - a) * (static_cast<double>(i) / steps));
  };
  const b2Body* body = world.static_body();
  for (const b2Fixture* f = body->GetFixtureList(); f != nullptr; f = f->GetNext()) {
    const b2Shape* shape = f->GetShape();
    if (shape->GetType() == b2Shape::e_edge) {
      const auto* edge = static_cast<const b2EdgeShape*>(shape);
      mark_segment(from_b2(b2Mul(body->GetTransform(), edge->m_vertex1)),
                   from_b2(b2Mul(body->GetTransform(), edge->m_vertex2)));
      continue;
    }
    // Solid shapes: every cell whose centre is inside, plus the outline so thin shapes show.
    b2AABB box;
    shape->ComputeAABB(&box, body->GetTransform(), 0);
    const int c0 =
        std::max(0, static_cast<int>((box.lowerBound.x - grid.origin_m.x()) / resolution_m));
    const int r0 =
        std::max(0, static_cast<int>((box.lowerBound.y - grid.origin_m.y()) / resolution_m));
    const int c1 = std::min(
        grid.width - 1, static_cast<int>((box.upperBound.x - grid.origin_m.x()) / resolution_m));
    const int r1 = std::min(
        grid.height - 1, static_cast<int>((box.upperBound.y - grid.origin_m.y()) / resolution_m));
    for (int row = r0; row <= r1; ++row) {
      for (int col = c0; col <= c1; ++col) {
        const Vec2 centre = grid.origin_m + resolution_m * Vec2(col + 0.5, row + 0.5);
        if (f->TestPoint(to_b2(centre)))
          grid.cells[static_cast<std::size_t>(row) * grid.width + col] = 100;
      }
    }
    if (shape->GetType() == b2Shape::e_polygon) {
      const auto* polygon = static_cast<const b2PolygonShape*>(shape);
      for (int i = 0; i < polygon->m_count; ++i) {
        mark_segment(
            from_b2(b2Mul(body->GetTransform(), polygon->m_vertices[i])),
            from_b2(b2Mul(body->GetTransform(), polygon->m_vertices[(i + 1) % polygon->m_count])));
      }
    }
  }
  return grid;
}

std::vector<Vec2> cast_rays(const OccupancyGrid& grid, const Pose2& pose, int beams, double fov_rad,
                            double max_range_m) {
  std::vector<Vec2> points;
  const double step_m = 0.1 * grid.resolution_m;
  for (int i = 0; i < beams; ++i) {
    const double angle = beams == 1 ? 0.0 : -0.5 * fov_rad + fov_rad * i / (beams - 1);
    const Vec2 direction(std::cos(angle), std::sin(angle));
    for (double r = step_m; r < max_range_m; r += step_m) {
      const Vec2 world = pose.transform(r * direction);
      const int col =
          static_cast<int>(std::floor((world.x() - grid.origin_m.x()) / grid.resolution_m));
      const int row =
          static_cast<int>(std::floor((world.y() - grid.origin_m.y()) / grid.resolution_m));
      if (col < 0 || row < 0 || col >= grid.width || row >= grid.height) break;
      if (grid.occupied(col, row)) {
        points.push_back(r * direction);
        break;
      }
    }
  }
  return points;
}

}  // namespace locsim
