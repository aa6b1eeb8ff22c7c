// The PTZ camera's rendered mode (`ptz_camera: {mode: rendered}`): instead of projecting each
// landmark analytically, the camera's image is rendered (render/, OpenGL) and the landmarks are
// found in it by colour segmentation. This header is the contract between the camera model here
// and the renderer, which `locsim` loads at run time: the core library has no GL or OpenCV.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "sim/common/math.hpp"
#include "sim/robot/robot_def.hpp"
#include "sim/sensors/sensor_defs.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

/// Where a pinhole camera is and how it projects. Pixel columns run left to right, rows top to
/// bottom, with the principal point at the image centre: a point at bearing b (left positive)
/// and elevation e lands at u = width/2 - f tan b, v = height/2 - f tan(e - tilt) (tilt small).
struct CameraShot {
  Pose2 pose;               // optical centre over the floor, viewing direction (pan included)
  double height_m = 0.4;    // optical centre above the floor [m]
  double tilt_rad = 0.0;    // up positive [rad]
  double focal_px = 125.6;  // focal length, zoom included [px]
  int width_px = 160;
  int height_px = 120;
};

/// Something that moves and has height: a person, a cart, a robot.
struct ScenePrism {
  std::string name;
  std::string kind;  // "person", "cart" or "robot"
  Pose2 pose;
  FootprintDef footprint;
  double height_m = 1.7;  // [m]
};

/// A connected region of one landmark colour in an image.
struct ImageBlob {
  std::string color;     // the landmark colour label it matched (LandmarkDef's colour name)
  int first_column = 0;  // bounding box: columns [first, end), rows [top, bottom) [px]
  int end_column = 0;
  int top_row = 0;
  int bottom_row = 0;
  int pixels = 0;  // pixels of the region itself [px]
};

/// Renders what a camera sees and finds the landmark-coloured blobs in it.
class LandmarkImager {
 public:
  virtual ~LandmarkImager() = default;
  /// The blobs in the image taken from `shot`, with the static world and `moving` (the robot
  /// carrying the camera is left out by name: `self`).
  virtual std::vector<ImageBlob> look(const CameraShot& shot, const std::vector<ScenePrism>& moving,
                                      const std::string& self) = 0;
};

/// Makes the imager of one robot's camera; set by whoever can load the renderer (the CLI).
using LandmarkImagerFactory =
    std::function<std::shared_ptr<LandmarkImager>(const WorldDef&, const PtzCameraDef&)>;

}  // namespace locsim
