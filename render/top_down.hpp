// The top-down view of a run: the world (floor friction tinted, walls, obstacles, landmarks,
// beacons, people), the robot's true footprint, every localizer's estimate with its covariance
// ellipse and particles, the trajectories, the sensors' rays and field of view, and the kidnaps.
// Drawn with OpenGL into the current context; the text (time, errors, legend) is drawn on the
// read-back image with OpenCV (GL has no text).
#pragma once

#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "sim/consumers/frame_state.hpp"

namespace locsim::render {

using Rgb = std::array<float, 3>;  // [0, 1]

/// Colours of the drawing, also what tests look for.
struct Palette {
  Rgb background{0.97f, 0.97f, 0.97f};  // outside the world and the side panel
  Rgb floor{0.90f, 0.90f, 0.88f};
  Rgb wall{0.25f, 0.25f, 0.27f};
  Rgb truth{0.0f, 0.0f, 0.0f};
  Rgb odometry{0.55f, 0.55f, 0.55f};
  Rgb kidnap{0.85f, 0.0f, 0.0f};
  Rgb person{0.95f, 0.62f, 0.25f};
  Rgb beacon{0.45f, 0.2f, 0.6f};
  Rgb laser{0.9f, 0.2f, 0.2f};
  Rgb line_of_sight{0.1f, 0.65f, 0.2f};
  Rgb occluded{0.9f, 0.0f, 0.0f};
  Rgb camera{0.95f, 0.8f, 0.1f};
  Rgb sighting{0.1f, 0.55f, 0.85f};        // a range-bearing detection of a landmark
  Rgb robot_sighting{0.85f, 0.1f, 0.65f};  // ... of another robot
  /// One colour per localizer, in the order they run (then repeating).
  std::vector<Rgb> filters{{0.12f, 0.47f, 0.71f}, {1.0f, 0.5f, 0.05f},   {0.17f, 0.63f, 0.17f},
                           {0.58f, 0.4f, 0.74f},  {0.55f, 0.34f, 0.29f}, {0.89f, 0.47f, 0.76f},
                           {0.09f, 0.75f, 0.81f}, {0.74f, 0.74f, 0.13f}};
  Rgb filter(std::size_t i) const { return filters[i % filters.size()]; }
};

/// Where the world lands in the image: an aspect-preserving fit of the world's bounds into the
/// map area (the image less the side panel).
struct View {
  double x_min = 0, y_min = 0, x_max = 1, y_max = 1;  // world rectangle shown [m]
  double scale_px_per_m = 1;
  int map_width_px = 0, height_px = 0;  // the map area, from the image's left edge
  cv::Point2d to_pixel(double x, double y) const {
    return {(x - x_min) * scale_px_per_m, (y_max - y) * scale_px_per_m};
  }
};

class TopDownRenderer {
 public:
  TopDownRenderer(const WorldDef& world, int width_px, int height_px, bool draw_particles = true);

  /// Draws `frame` with GL into the current context (of width_px x height_px).
  void draw(const FrameState& frame);
  /// The frame's image (BGR): the static world with the trails, the particle clouds, and over them
  /// the drawn layer (RGBA, premultiplied, rows from the top, as the context returns it).
  void compose(const FrameState& frame, const std::uint8_t* rgba, cv::Mat& bgr) const;
  /// Where overlay() left room for the first robot's camera view (empty: none).
  struct Panel {
    std::optional<cv::Rect> camera;
  };
  /// Text, legend and labels onto the composed image (BGR). With `camera_view`, room for the
  /// first robot's camera view (when it has a camera) under the filters' errors, before the key
  /// to the map's symbols, whose lines give way when the panel is short of room.
  Panel overlay(const FrameState& frame, cv::Mat& bgr, bool camera_view = false) const;
  /// The first robot's camera view (BGR, its own resolution) scaled into `place` (overlay's),
  /// with a caption and a tick over each detection's bearing.
  void inset_camera(const FrameState& frame, const cv::Mat& camera_bgr, const cv::Rect& place,
                    cv::Mat& bgr) const;

  const View& view() const { return view_; }
  const Palette& palette() const { return palette_; }

 private:
  struct Trail {
    std::vector<std::vector<cv::Point2d>> segments;  // broken where the robot was carried
    // How far it is painted onto trails_: up to point `painted_point` of segment
    // `painted_segment`; its painted length for the dashes [px].
    std::size_t painted_segment = 0, painted_point = 0;
    double painted_px = 0.0;
  };
  void remember(const FrameState& frame);
  void draw_static();
  /// Paints the trails' pieces added since the last frame onto trails_.
  void paint_trails();
  void paint(Trail& trail, const Rgb& colour, int thickness_px, bool dashed);

  WorldDef world_;
  int width_px_, height_px_;
  bool draw_particles_;
  Palette palette_;
  View view_;
  unsigned int map_texture_ = 0;  // occupancy map, if the world has one
  cv::Mat background_;            // the static world as drawn (BGR), from the first frame on
  cv::Mat trails_;                // background_ with the trails painted so far (BGR)
  std::vector<Trail> truth_, odometry_;
  std::vector<Trail> estimates_;  // by localizer
  std::vector<std::string> labels_;
  std::vector<int> truth_kidnaps_;  // by robot, at its last floor frame
};

}  // namespace locsim::render
