#include "sim/world/world_budget.hpp"

#include <algorithm>
#include <cmath>

#include "sim/common/format.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

std::string format_bytes(double bytes) {
  static constexpr const char* kUnits[] = {"bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  int unit = 0;
  while (bytes >= 1024.0 && unit < 6) bytes /= 1024.0, ++unit;
  return rounded_number(bytes, 3) + " " + kUnits[unit];
}

void WorldMemory::add(InputPlace place, std::string what, std::uint64_t bytes) {
  parts_.push_back(Part{std::move(place), std::move(what), bytes});
}

std::uint64_t WorldMemory::total_bytes() const {
  std::uint64_t total = 0;
  for (const Part& part : parts_) total += part.bytes;
  return total;
}

void WorldMemory::check(std::uint64_t other_bytes) const {
  const std::uint64_t total = other_bytes + total_bytes();
  if (total <= kWorldMemoryBudgetBytes || parts_.empty()) return;
  const Part& largest = *std::max_element(
      parts_.begin(), parts_.end(), [](const Part& a, const Part& b) { return a.bytes < b.bytes; });
  throw InputError(
      largest.place,
      largest.what + " would need about " + format_bytes(static_cast<double>(largest.bytes)) +
          (total > largest.bytes
               ? " (the world " + format_bytes(static_cast<double>(total)) + " in all)"
               : std::string()) +
          "; a world may need at most " +
          format_bytes(static_cast<double>(kWorldMemoryBudgetBytes)) + " (docs/worlds.md, Limits)");
}

Bounds static_bounds(const WorldDef& world) {
  bool any = false;
  Bounds b;
  const auto extend = [&](const Vec2& p) {
    b.min = any ? b.min.cwiseMin(p) : p;
    b.max = any ? b.max.cwiseMax(p) : p;
    any = true;
  };
  for (const WallDef& wall : world.walls) {
    for (const Vec2& p : wall.points_m) extend(p);
  }
  for (const BoxDef& box : world.boxes) {
    const double reach = 0.5 * box.size_m.norm();
    extend(box.center_m - Vec2::Constant(reach));
    extend(box.center_m + Vec2::Constant(reach));
  }
  for (const CircleDef& circle : world.circles) {
    extend(circle.center_m - Vec2::Constant(circle.radius_m));
    extend(circle.center_m + Vec2::Constant(circle.radius_m));
  }
  for (const PolygonDef& polygon : world.polygons) {
    for (const Vec2& p : polygon.points_m) extend(p);
  }
  if (world.map && !world.map->rects.empty()) {
    const OccupancyMapDef& map = *world.map;
    const double w = map.width_px * map.resolution_m, h = map.height_px * map.resolution_m;
    for (const Vec2& corner : {Vec2{0.0, 0.0}, Vec2{w, 0.0}, Vec2{0.0, h}, Vec2{w, h}}) {
      extend(map.origin.transform(corner));
    }
  }
  if (!any) {
    for (const RobotDef& robot : world.robots) extend(robot.start.position());
  }
  return b;
}

void check_grid_memory(const WorldDef& world, double resolution, const InputPlace& place) {
  const Bounds bounds = static_bounds(world);
  // As rasterize_static_world: a margin of two cells around the bounds, and a cell more for the
  // float bounds Box2D reports.
  const Vec2 size = bounds.max - bounds.min + Vec2::Constant(5.0 * resolution);
  const double columns = std::ceil(size.x() / resolution), rows = std::ceil(size.y() / resolution);
  const double bytes = columns * rows * static_cast<double>(kGridCellBytes);
  WorldMemory memory;
  const std::string what = "the localizers' occupancy grid of " + rounded_number(columns, 9) +
                           " x " + rounded_number(rows, 9) + " cells of " +
                           short_number(resolution) + " m";
  if (bytes > static_cast<double>(kWorldMemoryBudgetBytes)) {
    throw InputError(place, what + " would need about " + format_bytes(bytes) +
                                "; a world may need at most " +
                                format_bytes(static_cast<double>(kWorldMemoryBudgetBytes)) +
                                " (docs/worlds.md, Limits): give a coarser resolution");
  }
  memory.add(place, what, static_cast<std::uint64_t>(bytes));
  memory.check(world.memory_bytes);
}

}  // namespace locsim
