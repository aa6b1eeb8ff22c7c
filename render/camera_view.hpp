// What a robot's PTZ camera sees: the world extruded to 3D (walls, obstacles and the occupancy
// map's cells with their heights, landmarks as coloured cylinders, people, carts and robots as
// prisms), through the camera's pinhole model at its pose, pan, tilt and zoom.
#pragma once

#include <vector>

#include "render/top_down.hpp"
#include "sim/sensors/camera_image.hpp"
#include "sim/world/world_def.hpp"

namespace locsim::render {

/// Height given to walls and obstacles with no top ("floor to ceiling") [m].
inline constexpr double kCeilingM = 2.5;

class CameraViewRenderer {
 public:
  /// Compiles the static world once (a display list) in the current GL context.
  /// The display list lives as long as the context (its owner frees it with the context: another
  /// context may be current when this is destroyed).
  explicit CameraViewRenderer(const WorldDef& world, Palette palette = {});
  CameraViewRenderer(const CameraViewRenderer&) = delete;
  CameraViewRenderer& operator=(const CameraViewRenderer&) = delete;

  /// Draws the view from `shot` into the current context (shot.width_px x shot.height_px, from
  /// its lower left corner): the static world and `moving` but the one named `self`.
  void draw(const CameraShot& shot, const std::vector<ScenePrism>& moving,
            const std::string& self) const;

 private:
  WorldDef world_;
  Palette palette_;
  unsigned int static_list_ = 0;
};

}  // namespace locsim::render
