// The PTZ camera's rendered mode: its image rendered offscreen (CameraViewRenderer), then the
// landmarks found in it the way the paper's robot found them, by colour segmentation (OpenCV
// connected components on a per-colour mask), leaving distance and bearing to the camera model's
// pinhole back-projection (sim/sensors/models.cpp).
#pragma once

#include <array>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "render/camera_view.hpp"
#include "render/gl_context.hpp"
#include "sim/sensors/camera_image.hpp"

namespace locsim::render {

/// Classifies pixels by the world's landmark colours (hue within a tolerance, enough saturation
/// and brightness) and returns each colour's connected regions.
class LandmarkSegmenter {
 public:
  struct Tolerances {
    double hue_deg = 15.0;        // |hue - the colour's hue| [deg]
    double min_saturation = 0.5;  // times the colour's own saturation [-]
    double min_value = 0.35;      // times the colour's own value (shading darkens faces) [-]
  };
  explicit LandmarkSegmenter(const std::vector<LandmarkDef>& landmarks, Tolerances tolerances);
  explicit LandmarkSegmenter(const std::vector<LandmarkDef>& landmarks)
      : LandmarkSegmenter(landmarks, Tolerances{}) {}

  /// Blobs in an RGBA image (rows from the top), 8-connected, bounding boxes.
  std::vector<ImageBlob> find(const std::uint8_t* rgba, int width_px, int height_px);

  /// Colours too pale to segment (saturation under 0.25): their landmarks are never found.
  const std::vector<std::string>& unsegmentable() const { return unsegmentable_; }

 private:
  static constexpr int kBits = 5;    // the lookup table quantises each channel to 5 bits
  std::vector<std::string> labels_;  // class k + 1 is labels_[k]
  std::vector<std::uint8_t> table_;  // (r, g, b) >> 3 -> class, 0: none
  std::vector<std::string> unsegmentable_;
  cv::Mat classes_, mask_, components_, stats_, centroids_;
};

/// A LandmarkImager on its own offscreen context of the camera's size.
class RenderedCamera final : public LandmarkImager {
 public:
  RenderedCamera(const WorldDef& world, const PtzCameraDef& camera, const std::string& backend);
  std::vector<ImageBlob> look(const CameraShot& shot, const std::vector<ScenePrism>& moving,
                              const std::string& self) override;
  /// The last image looked at (BGR), for tests and pictures.
  cv::Mat last_image() const;

 private:
  std::unique_ptr<GlContext> context_;
  std::unique_ptr<CameraViewRenderer> renderer_;
  LandmarkSegmenter segmenter_;
  const std::uint8_t* last_rgba_ = nullptr;
};

}  // namespace locsim::render
