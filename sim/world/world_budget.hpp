// The memory a world needs, estimated from its values before anything is built, and the budget
// it must fit in. A world over budget is refused at load time, at the key of its largest part,
// instead of failing with std::bad_alloc (or swapping the machine) while it is built. The costs
// are upper estimates, measured on Box2D 2.4 and our own structures (docs/worlds.md, Limits).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "sim/common/errors.hpp"
#include "sim/common/math.hpp"

namespace locsim {

struct WorldDef;

/// The most a world may need: its static geometry, map, rendered cameras and the localizers'
/// occupancy grid together. [bytes]
inline constexpr std::uint64_t kWorldMemoryBudgetBytes = std::uint64_t{1} << 30;

/// A static Box2D fixture (a wall segment, a shape, a map's box) with its shape, broad-phase proxy
/// and tree nodes, its segments in the sensors' ray grid and its drawing. [bytes]
inline constexpr std::uint64_t kStaticShapeBytes = 1024;
/// A map pixel: the image, its occupancy and the merge into boxes. [bytes]
inline constexpr std::uint64_t kMapPixelBytes = 4;
/// A rendered camera's pixel: the GL colour and depth buffers, the read-back image and the
/// segmentation's colour planes and labels. [bytes]
inline constexpr std::uint64_t kRenderedPixelBytes = 32;
/// A point of a mover's path: the definition's, the walker's segment table, the YAML list it was
/// read from, and run.json's copy of the world (a JSON tree, then its text: most of it). A path
/// shared by YAML aliases is counted for every mover that names it: each gets its own copy. A
/// run's peak measured ~395 bytes a point, run.json's tree being built at the start and again at
/// the end (Limits.AMoversPathCostsARunNoMoreThanTheBudgetCounts holds it under this). [bytes]
inline constexpr std::uint64_t kPathPointBytes = 512;
/// A beam of a robot's laser: its angle and direction, the moving bodies it may reach, the scan's
/// range, the readings' CSV text, the log's and the localizers' copies of a scan. [bytes]
inline constexpr std::uint64_t kLaserBeamBytes = 256;
/// A cell of the occupancy grid given to localizers: the host's grid, and what a localizer builds
/// from it (its copy, the free cells it samples from, a likelihood field of floats and the
/// distance transform's doubles). [bytes]
inline constexpr std::uint64_t kGridCellBytes = 24;

/// "1.5 GiB", "640 MiB", "12 KiB".
std::string format_bytes(double bytes);

/// The parts of a world's memory, each with the place in the files that decides it.
class WorldMemory {
 public:
  /// Adds a part. Call check() before allocating what grows with the input: a world is refused
  /// before it is built, not after.
  void add(InputPlace place, std::string what, std::uint64_t bytes);
  std::uint64_t total_bytes() const;
  /// Throws InputError at the largest part when `other_bytes` plus the parts exceed the budget.
  void check(std::uint64_t other_bytes = 0) const;

 private:
  struct Part {
    InputPlace place;
    std::string what;
    std::uint64_t bytes = 0;
  };
  std::vector<Part> parts_;
};

/// Axis-aligned bounds of a world's static geometry (walls, shapes, map), or of the robots'
/// starts when it has none: what the localizers' occupancy grid covers. In doubles, from the
/// definitions; Box2D's own (float) bounds lie within a millimetre of these.
struct Bounds {
  Vec2 min{0.0, 0.0}, max{0.0, 0.0};
};
Bounds static_bounds(const WorldDef& world);

/// Checks that the occupancy grid localizers get (cells of `resolution_m` over the world's static
/// bounds) fits in the budget with the rest of the world. Throws InputError at `place` (the
/// scenario's grid_resolution_m).
void check_grid_memory(const WorldDef& world, double resolution_m, const InputPlace& place);

}  // namespace locsim
