// Writes BGR frames into a video file with FFmpeg's libraries: H.264 (libx264, preset
// "veryfast" with superfast's motion search, CRF 23, yuv420p: plays in every common player) when
// the installed FFmpeg has it, else MPEG-4 part 2. Direct use of libavcodec, not OpenCV's writer,
// because OpenCV 4.6 offers no way to pick the x264 preset, and the default one spends 2x the
// time for a run's video.
#pragma once

#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <string>

namespace locsim::render {

class VideoEncoder {
 public:
  /// Opens `file` (.mp4, .mkv, .mov or .avi) for width x height frames at `fps`. Throws
  /// RenderError naming the file and what failed.
  VideoEncoder(const std::filesystem::path& file, int width, int height, double fps);
  ~VideoEncoder();
  VideoEncoder(const VideoEncoder&) = delete;
  VideoEncoder& operator=(const VideoEncoder&) = delete;

  /// Appends one frame (CV_8UC3, BGR, width x height).
  void write(const cv::Mat& bgr);
  /// Appends one frame already in the encoder's colours: YUV 4:2:0 as to_i420() makes it.
  void write_i420(const cv::Mat& i420);
  /// BGR to YUV 4:2:0 (I420: CV_8UC1, the Y plane, then U, then V; height * 3/2 rows), as
  /// write() converts; for a caller that converts on another thread than the encoder's.
  static void to_i420(const cv::Mat& bgr, cv::Mat& i420);
  /// Flushes the encoder and writes the container's index; the file plays after this. Called by
  /// the destructor if not before (errors then go unreported).
  void close();

  const std::string& codec() const { return codec_; }  // "H.264" or "MPEG-4"
  long frames() const { return frames_; }

 private:
  struct State;
  std::unique_ptr<State> state_;
  std::filesystem::path file_;
  std::string codec_;
  long frames_ = 0;
};

}  // namespace locsim::render
