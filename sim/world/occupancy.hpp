// The static world rasterised into an occupancy grid: the map localizers are allowed to know.
#pragma once

#include <cstdint>
#include <vector>

#include "sim/common/math.hpp"

namespace locsim {

class PhysicsWorld;

struct OccupancyGrid {
  Vec2 origin_m{0.0, 0.0};  // lower-left corner of cell (0, 0)
  double resolution_m = 0.05;
  int width = 0, height = 0;
  std::vector<std::uint8_t> cells;  // row-major from the bottom row; 0 free, 100 occupied
  bool occupied(int col, int row) const {
    return cells[static_cast<std::size_t>(row) * width + col] != 0;
  }
};

/// Cells touched by a wall or inside a shape are occupied; people, carts and robots are not in it.
OccupancyGrid rasterize_static_world(const PhysicsWorld& world, double resolution_m);

/// The end points, in the frame of `pose`, of `beams` rays evenly spread over `fov_rad` (centred on
/// its x axis) that reach an occupied cell within `max_range_m`, marched a tenth of a cell at a
/// time: what a noiseless laser at `pose` would hit in the grid (tests, benchmarks).
std::vector<Vec2> cast_rays(const OccupancyGrid& grid, const Pose2& pose, int beams, double fov_rad,
                            double max_range_m);

}  // namespace locsim
