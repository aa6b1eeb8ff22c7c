// Rendered PTZ cameras for the tests that draw their landmark detections with OSMesa.
#pragma once

#include <memory>

#include "render/rendered_camera.hpp"
#include "sim/producers/simulation.hpp"

namespace locsim::testing {

/// A factory of OSMesa-rendered cameras; `keep`, when given, receives the last one made.
inline LandmarkImagerFactory osmesa_imager(
    std::shared_ptr<render::RenderedCamera>* keep = nullptr) {
  return [keep](const WorldDef& world, const PtzCameraDef& camera) {
    auto imager = std::make_shared<render::RenderedCamera>(world, camera, "osmesa");
    if (keep != nullptr) *keep = imager;
    return imager;
  };
}

}  // namespace locsim::testing
