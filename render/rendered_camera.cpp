#include "render/rendered_camera.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "sim/common/errors.hpp"

namespace locsim::render {

namespace {

struct Hsv {
  double hue_deg, saturation, value;  // [0, 360), [0, 1], [0, 1]
};

Hsv to_hsv(double r, double g, double b) {
  const double top = std::max({r, g, b}), bottom = std::min({r, g, b});
  const double range = top - bottom;
  double hue = 0.0;
  if (range > 0.0) {
    if (top == r) {
      hue = 60.0 * std::fmod((g - b) / range + 6.0, 6.0);
    } else if (top == g) {
      hue = 60.0 * ((b - r) / range + 2.0);
    } else {
      hue = 60.0 * ((r - g) / range + 4.0);
    }
  }
  return {hue, top > 0.0 ? range / top : 0.0, top};
}

double hue_distance_deg(double a, double b) {
  const double d = std::abs(a - b);
  return std::min(d, 360.0 - d);
}

}  // namespace

LandmarkSegmenter::LandmarkSegmenter(const std::vector<LandmarkDef>& landmarks,
                                     Tolerances tolerances) {
  std::vector<Hsv> targets;
  for (const LandmarkDef& l : landmarks) {
    const std::string label = color_label(l);
    if (std::find(labels_.begin(), labels_.end(), label) != labels_.end() ||
        std::find(unsegmentable_.begin(), unsegmentable_.end(), label) != unsegmentable_.end()) {
      continue;
    }
    const Hsv hsv = to_hsv(l.color[0] / 255.0, l.color[1] / 255.0, l.color[2] / 255.0);
    if (hsv.saturation < 0.25 || hsv.value < 0.2) {
      unsegmentable_.push_back(label);
      continue;
    }
    labels_.push_back(label);
    targets.push_back(hsv);
  }
  if (labels_.size() > 254) throw RenderError("more than 254 landmark colours to segment");
  // The table: each 5-bit cell's centre colour, classified once.
  constexpr int kCells = 1 << kBits;
  table_.assign(static_cast<std::size_t>(kCells) * kCells * kCells, 0);
  for (int r = 0; r < kCells; ++r) {
    for (int g = 0; g < kCells; ++g) {
      for (int b = 0; b < kCells; ++b) {
        const auto centre = [](int cell) { return (cell + 0.5) / kCells; };
        const Hsv hsv = to_hsv(centre(r), centre(g), centre(b));
        double best = tolerances.hue_deg;
        for (std::size_t k = 0; k < targets.size(); ++k) {
          const double d = hue_distance_deg(hsv.hue_deg, targets[k].hue_deg);
          if (d <= best && hsv.saturation >= tolerances.min_saturation * targets[k].saturation &&
              hsv.value >= tolerances.min_value * targets[k].value) {
            best = d;
            table_[(static_cast<std::size_t>(r) << (2 * kBits)) |
                   (static_cast<std::size_t>(g) << kBits) | static_cast<std::size_t>(b)] =
                static_cast<std::uint8_t>(k + 1);
          }
        }
      }
    }
  }
}

std::vector<ImageBlob> LandmarkSegmenter::find(const std::uint8_t* rgba, int width_px,
                                               int height_px) {
  classes_.create(height_px, width_px, CV_8UC1);
  std::vector<bool> present(labels_.size() + 1, false);
  constexpr int kShift = 8 - kBits;
  for (int row = 0; row < height_px; ++row) {
    const std::uint8_t* in = rgba + static_cast<std::size_t>(row) * width_px * 4;
    std::uint8_t* out = classes_.ptr<std::uint8_t>(row);
    for (int col = 0; col < width_px; ++col, in += 4) {
      const std::uint8_t k = table_[(static_cast<std::size_t>(in[0] >> kShift) << (2 * kBits)) |
                                    (static_cast<std::size_t>(in[1] >> kShift) << kBits) |
                                    static_cast<std::size_t>(in[2] >> kShift)];
      out[col] = k;
      present[k] = true;
    }
  }
  std::vector<ImageBlob> blobs;
  for (std::size_t k = 1; k < present.size(); ++k) {
    if (!present[k]) continue;
    cv::compare(classes_, static_cast<double>(k), mask_, cv::CMP_EQ);
    const int count =
        cv::connectedComponentsWithStats(mask_, components_, stats_, centroids_, 8, CV_32S);
    for (int c = 1; c < count; ++c) {  // 0 is the background
      ImageBlob blob;
      blob.color = labels_[k - 1];
      blob.first_column = stats_.at<int>(c, cv::CC_STAT_LEFT);
      blob.end_column = blob.first_column + stats_.at<int>(c, cv::CC_STAT_WIDTH);
      blob.top_row = stats_.at<int>(c, cv::CC_STAT_TOP);
      blob.bottom_row = blob.top_row + stats_.at<int>(c, cv::CC_STAT_HEIGHT);
      blob.pixels = stats_.at<int>(c, cv::CC_STAT_AREA);
      blobs.push_back(std::move(blob));
    }
  }
  return blobs;
}

RenderedCamera::RenderedCamera(const WorldDef& world, const PtzCameraDef& camera,
                               const std::string& backend)
    : context_(make_gl_context(backend, camera.width_px, camera.height_px)),
      segmenter_(world.landmarks) {
  context_->make_current();
  renderer_ = std::make_unique<CameraViewRenderer>(world);
}

std::vector<ImageBlob> RenderedCamera::look(const CameraShot& shot,
                                            const std::vector<ScenePrism>& moving,
                                            const std::string& self) {
  if (shot.width_px != context_->width() || shot.height_px != context_->height()) {
    throw RenderError("camera image " + std::to_string(shot.width_px) + "x" +
                      std::to_string(shot.height_px) + " does not match its context");
  }
  context_->make_current();
  renderer_->draw(shot, moving, self);
  last_rgba_ = context_->finish_frame();
  return segmenter_.find(last_rgba_, shot.width_px, shot.height_px);
}

cv::Mat RenderedCamera::last_image() const {
  cv::Mat bgr;
  if (last_rgba_ == nullptr) return bgr;
  const cv::Mat rgba(context_->height(), context_->width(), CV_8UC4,
                     const_cast<std::uint8_t*>(last_rgba_));
  cv::cvtColor(rgba, bgr, cv::COLOR_RGBA2BGR);
  return bgr;
}

}  // namespace locsim::render
