// A FrameSink that renders each frame offscreen (GL context + TopDownRenderer), adds the text,
// and writes it to a video (VideoEncoder: H.264, else MPEG-4) and/or a folder of PNGs. Encoding
// and PNG writing run on a worker thread, in frame order, while the next frame renders: the
// software rasteriser barely uses a second core, the encoder does, so the two overlap.
#pragma once

#include <condition_variable>
#include <deque>
#include <exception>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "render/camera_view.hpp"
#include "render/gl_context.hpp"
#include "render/top_down.hpp"
#include "render/video_encoder.hpp"
#include "sim/consumers/frame_state.hpp"

namespace locsim::render {

class VideoRecorder final : public FrameSink {
 public:
  /// Checks the options and opens nothing yet (start() does). Throws RenderError.
  explicit VideoRecorder(VideoOptions options);
  ~VideoRecorder() override;

  void start(const WorldDef& world) override;
  void frame(const FrameState& frame) override;
  void finish() override;
  long frames() const override { return frames_; }

  /// The codec the video is written with ("H.264", "MPEG-4"), once started.
  const std::string& codec() const { return codec_; }
  /// The last frame as rendered (BGR).
  const cv::Mat& last_frame() const { return bgr_; }
  const TopDownRenderer* renderer() const { return renderer_.get(); }

 private:
  VideoOptions options_;
  std::unique_ptr<GlContext> context_;
  std::unique_ptr<TopDownRenderer> renderer_;
  WorldDef world_;
  // The camera's view for the panel: its own context at the camera's resolution.
  std::unique_ptr<GlContext> camera_context_;
  std::unique_ptr<CameraViewRenderer> camera_renderer_;
  cv::Mat camera_bgr_;
  std::unique_ptr<VideoEncoder> encoder_;
  std::string codec_;
  cv::Mat bgr_;
  long frames_ = 0;
  bool finished_ = false;

  // The worker: frames waiting to be written, at most kQueued (the renderer waits beyond).
  struct Queued {
    long index = 0;
    cv::Mat i420;  // for the video: converted by the renderer, as the encoder is the slower
    cv::Mat bgr;   // for --frames
  };
  static constexpr std::size_t kQueued = 3;
  void work();
  void rethrow_worker_error();
  std::thread worker_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Queued> queue_;
  std::vector<Queued> spare_;  // written ones, whose buffers the next frames reuse
  bool closing_ = false;
  std::exception_ptr worker_error_;
};

}  // namespace locsim::render
