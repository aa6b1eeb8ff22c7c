#include "render/video_recorder.hpp"

#include <cstdio>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "sim/common/errors.hpp"

namespace locsim::render {

namespace fs = std::filesystem;

VideoRecorder::VideoRecorder(VideoOptions options) : options_(std::move(options)) {
  if (!options_.video_file && !options_.frames_dir)
    throw RenderError("nothing to write: give a video file or a frames folder");
  if (!(options_.fps > 0.0 && options_.fps <= 1000.0))
    throw RenderError("--video-fps must be in (0, 1000]");
  if (!(options_.speed > 0.0)) throw RenderError("--video-speed must be positive");
  // Encoders want even sizes (4:2:0 chroma).
  if (options_.width_px % 2 != 0 || options_.height_px % 2 != 0)
    throw RenderError("--video-size must have an even width and height");
}

VideoRecorder::~VideoRecorder() {
  try {
    finish();
  } catch (...) {
    // Destructors do not throw; finish() reported through the run already, if it could.
  }
}

void VideoRecorder::start(const WorldDef& world) {
  context_ = make_gl_context(options_.backend, options_.width_px, options_.height_px);
  world_ = world;
  renderer_ = std::make_unique<TopDownRenderer>(world, options_.width_px, options_.height_px,
                                                options_.particles);
  if (options_.video_file) {
    encoder_ = std::make_unique<VideoEncoder>(*options_.video_file, options_.width_px,
                                              options_.height_px, options_.fps);
    codec_ = encoder_->codec();
  }
  if (options_.frames_dir) {
    std::error_code error;  // a RenderError (exit 4) like every other video failure
    fs::create_directories(*options_.frames_dir, error);
    if (error) {
      throw RenderError("--frames: cannot make '" + options_.frames_dir->string() +
                        "': " + error.message());
    }
  }
  worker_ = std::thread([this] { work(); });
}

void VideoRecorder::frame(const FrameState& frame) {
  if (!context_) throw RenderError("frame before start");
  rethrow_worker_error();
  context_->make_current();
  renderer_->draw(frame);
  cv::Mat& bgr = bgr_;  // the worker gets copies: this one is reused
  renderer_->compose(frame, context_->finish_frame(), bgr);
  const TopDownRenderer::Panel panel = renderer_->overlay(frame, bgr, options_.camera_view);
  if (panel.camera) {
    const CameraShot& shot = frame.robots[0].camera->shot;
    if (!camera_context_) {
      camera_context_ = make_gl_context(options_.backend, shot.width_px, shot.height_px);
      camera_renderer_ = std::make_unique<CameraViewRenderer>(world_);
    }
    camera_context_->make_current();
    std::vector<ScenePrism> moving;
    for (const FrameMover& m : frame.movers)
      moving.push_back({m.name, m.kind, m.pose, m.footprint, m.height_m});
    for (const FrameRobot& r : frame.robots)
      if (!r.carried) moving.push_back({r.name, "robot", r.pose, r.footprint, r.height_m});
    camera_renderer_->draw(shot, moving, frame.robots[0].name);
    const cv::Mat rgba(shot.height_px, shot.width_px, CV_8UC4,
                       const_cast<std::uint8_t*>(camera_context_->finish_frame()));
    cv::cvtColor(rgba, camera_bgr_, cv::COLOR_RGBA2BGR);
    renderer_->inset_camera(frame, camera_bgr_, *panel.camera, bgr);
  }
  Queued item;
  {
    std::lock_guard lock(mutex_);
    if (!spare_.empty()) {
      item = std::move(spare_.back());  // no new buffers (and page faults) for every frame
      spare_.pop_back();
    }
  }
  item.index = frames_;
  // The colour conversion here rather than on the worker: x264 there is the slower of the two.
  if (encoder_) VideoEncoder::to_i420(bgr, item.i420);
  if (options_.frames_dir) bgr.copyTo(item.bgr);
  {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return queue_.size() < kQueued || worker_error_; });
    queue_.push_back(std::move(item));
  }
  changed_.notify_all();
  ++frames_;
}

void VideoRecorder::work() {
  for (;;) {
    Queued item;
    {
      std::unique_lock lock(mutex_);
      changed_.wait(lock, [&] { return !queue_.empty() || closing_; });
      if (queue_.empty()) return;  // closing, all written
      item = std::move(queue_.front());
    }
    try {
      if (encoder_) encoder_->write_i420(item.i420);
      if (options_.frames_dir) {
        char name[32];
        std::snprintf(name, sizeof name, "frame_%06ld.png", item.index);
        const fs::path file = *options_.frames_dir / name;
        // Fast zlib level: frames are for looking at, not archiving.
        if (!cv::imwrite(file.string(), item.bgr, {cv::IMWRITE_PNG_COMPRESSION, 1}))
          throw RenderError("cannot write '" + file.string() + "'");
      }
    } catch (...) {
      std::lock_guard lock(mutex_);
      worker_error_ = std::current_exception();
      queue_.clear();
      changed_.notify_all();
      return;
    }
    {
      std::lock_guard lock(mutex_);
      queue_.pop_front();
      spare_.push_back(std::move(item));
    }
    changed_.notify_all();
  }
}

void VideoRecorder::rethrow_worker_error() {
  std::lock_guard lock(mutex_);
  if (worker_error_) std::rethrow_exception(worker_error_);
}

void VideoRecorder::finish() {
  if (finished_) return;
  finished_ = true;
  if (worker_.joinable()) {
    {
      std::lock_guard lock(mutex_);
      closing_ = true;
    }
    changed_.notify_all();
    worker_.join();  // every queued frame written
  }
  // The MP4's index is written even after an error, so that the frames before it play.
  if (encoder_) encoder_->close();
  rethrow_worker_error();
}

}  // namespace locsim::render
