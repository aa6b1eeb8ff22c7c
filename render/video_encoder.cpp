#include "render/video_encoder.hpp"

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/imgutils.h>
#include <libavutil/opt.h>
}

#include <algorithm>
#include <cctype>
#include <cstring>
#include <opencv2/imgproc.hpp>

#include "sim/common/errors.hpp"

namespace locsim::render {

namespace fs = std::filesystem;

namespace {

std::string av_error(int code) {
  char text[AV_ERROR_MAX_STRING_SIZE] = {};
  av_strerror(code, text, sizeof text);
  return text;
}

}  // namespace

struct VideoEncoder::State {
  AVFormatContext* format = nullptr;
  AVCodecContext* codec = nullptr;
  AVStream* stream = nullptr;
  AVFrame* frame = nullptr;
  AVPacket* packet = nullptr;
  cv::Mat yuv;  // I420 conversion buffer, reused
  bool header_written = false;
  bool closed = false;

  ~State() {
    av_packet_free(&packet);
    av_frame_free(&frame);
    avcodec_free_context(&codec);
    if (format != nullptr) {
      if (format->pb != nullptr) avio_closep(&format->pb);
      avformat_free_context(format);
    }
  }

  /// Sends `f` (nullptr: flush) and writes every packet the encoder has ready.
  void encode(AVFrame* f, const fs::path& file) {
    int status = avcodec_send_frame(codec, f);
    if (status < 0)
      throw RenderError("video '" + file.string() + "': encoding: " + av_error(status));
    for (;;) {
      status = avcodec_receive_packet(codec, packet);
      if (status == AVERROR(EAGAIN) || status == AVERROR_EOF) return;
      if (status < 0)
        throw RenderError("video '" + file.string() + "': encoding: " + av_error(status));
      av_packet_rescale_ts(packet, codec->time_base, stream->time_base);
      packet->stream_index = stream->index;
      status = av_interleaved_write_frame(format, packet);  // takes the packet's data
      if (status < 0)
        throw RenderError("video '" + file.string() + "': writing: " + av_error(status));
    }
  }
};

VideoEncoder::VideoEncoder(const fs::path& file, int width, int height, double fps)
    : state_(std::make_unique<State>()), file_(file) {
  const auto fail = [&](const std::string& what, int code = 0) {
    throw RenderError("video '" + file.string() + "': " + what +
                      (code != 0 ? ": " + av_error(code) : std::string()));
  };
  std::string extension = file.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension != ".mp4" && extension != ".mkv" && extension != ".mov" && extension != ".avi")
    fail("use .mp4, .mkv, .mov or .avi");
  if (width % 2 != 0 || height % 2 != 0) fail("width and height must be even (4:2:0 chroma)");
  if (file.has_parent_path()) {
    std::error_code error;  // a RenderError (exit 4) like every other video failure
    fs::create_directories(file.parent_path(), error);
    if (error) fail("cannot make its folder: " + error.message());
  }
  av_log_set_level(AV_LOG_ERROR);  // x264's statistics are not for the run's console
  State& s = *state_;
  int status = avformat_alloc_output_context2(&s.format, nullptr, nullptr, file.c_str());
  if (status < 0 || s.format == nullptr) fail("no container format for it", status);
  // Same frames, same bytes: no library version strings or timestamps in the file.
  s.format->flags |= AVFMT_FLAG_BITEXACT;

  const AVCodec* encoder = extension == ".avi" ? nullptr : avcodec_find_encoder_by_name("libx264");
  codec_ = "H.264";
  if (encoder == nullptr) {
    encoder = avcodec_find_encoder(AV_CODEC_ID_MPEG4);
    codec_ = "MPEG-4";
  }
  if (encoder == nullptr) fail("FFmpeg has neither an H.264 nor an MPEG-4 encoder");
  s.codec = avcodec_alloc_context3(encoder);
  s.codec->width = width;
  s.codec->height = height;
  const AVRational rate = av_d2q(fps, 100000);
  s.codec->time_base = av_inv_q(rate);
  s.codec->framerate = rate;
  s.codec->pix_fmt = AV_PIX_FMT_YUV420P;
  s.codec->gop_size = std::max(1, static_cast<int>(fps * 2.0));  // a key frame every 2 s: seekable
  s.codec->flags |= AV_CODEC_FLAG_BITEXACT;
  // One encoder thread: x264's output depends on its thread count, and a video must not depend
  // on the machine's cores. The recorder already encodes on its own thread, beside the renderer;
  // more x264 threads on two cores only compete with it (112 vs 125 frames/s, docs/render.md).
  s.codec->thread_count = 1;
  if (s.format->oformat->flags & AVFMT_GLOBALHEADER) s.codec->flags |= AV_CODEC_FLAG_GLOBAL_HEADER;
  if (codec_ == "H.264") {
    av_opt_set(s.codec->priv_data, "preset", "veryfast", 0);
    av_opt_set(s.codec->priv_data, "crf", "23", 0);
    // veryfast's rate control (its mb-tree lookahead keeps the static world sharp and cheap) with
    // superfast's motion search: one sub-pixel refinement, diamond search. On the demo's frames
    // x264 needs 0.7x the time for 1.06x the bytes at the same SSIM (docs/render.md); the time
    // of a whole preset step (superfast) costs twice the bytes.
    av_opt_set(s.codec->priv_data, "x264-params", "subme=1:me=dia", 0);
  } else {
    s.codec->bit_rate =
        static_cast<std::int64_t>(0.15 * width * height * fps);  // ~4 Mbit/s at 720p30
  }
  status = avcodec_open2(s.codec, encoder, nullptr);
  if (status < 0) fail("cannot open the " + codec_ + " encoder", status);
  s.stream = avformat_new_stream(s.format, nullptr);
  if (s.stream == nullptr) fail("cannot add a video stream");
  s.stream->time_base = s.codec->time_base;
  s.stream->avg_frame_rate = rate;
  status = avcodec_parameters_from_context(s.stream->codecpar, s.codec);
  if (status < 0) fail("codec parameters", status);
  status = avio_open(&s.format->pb, file.c_str(), AVIO_FLAG_WRITE);
  if (status < 0) fail("cannot open for writing", status);
  status = avformat_write_header(s.format, nullptr);
  if (status < 0) fail("cannot write the header", status);
  s.header_written = true;

  s.frame = av_frame_alloc();
  s.packet = av_packet_alloc();
  s.frame->format = AV_PIX_FMT_YUV420P;
  s.frame->width = width;
  s.frame->height = height;
  status = av_frame_get_buffer(s.frame, 0);
  if (status < 0) fail("frame buffer", status);
}

VideoEncoder::~VideoEncoder() {
  try {
    close();
  } catch (...) {
    // Reported by an explicit close(); a destructor does not throw.
  }
}

void VideoEncoder::to_i420(const cv::Mat& bgr, cv::Mat& i420) {
  // OpenCV's fixed-point BT.601 (limited range, as players expect) is exact integer arithmetic,
  // so deterministic, and ten times faster than swscale with exact rounding (docs/render.md).
  cv::cvtColor(bgr, i420, cv::COLOR_BGR2YUV_I420);
}

void VideoEncoder::write(const cv::Mat& bgr) {
  State& s = *state_;
  if (bgr.type() != CV_8UC3 || bgr.cols != s.codec->width || bgr.rows != s.codec->height) {
    throw RenderError("video '" + file_.string() + "': frame is not " +
                      std::to_string(s.codec->width) + "x" + std::to_string(s.codec->height) +
                      " BGR");
  }
  to_i420(bgr, s.yuv);
  write_i420(s.yuv);
}

void VideoEncoder::write_i420(const cv::Mat& i420) {
  State& s = *state_;
  if (s.closed) throw RenderError("video '" + file_.string() + "': write after close");
  const int width = s.codec->width;
  const int height = s.codec->height;
  if (i420.type() != CV_8UC1 || i420.cols != width || i420.rows != height * 3 / 2 ||
      !i420.isContinuous()) {
    throw RenderError("video '" + file_.string() + "': frame is not " + std::to_string(width) +
                      "x" + std::to_string(height) + " YUV 4:2:0");
  }
  const int made_writable = av_frame_make_writable(s.frame);
  if (made_writable < 0) throw RenderError("video: frame buffer: " + av_error(made_writable));
  const std::uint8_t* plane = i420.data;  // Y plane, then U, then V
  for (int p = 0; p < 3; ++p) {
    const int plane_width = p == 0 ? width : width / 2;
    const int plane_height = p == 0 ? height : height / 2;
    for (int row = 0; row < plane_height; ++row) {
      std::memcpy(s.frame->data[p] + static_cast<std::ptrdiff_t>(row) * s.frame->linesize[p],
                  plane + static_cast<std::ptrdiff_t>(row) * plane_width, plane_width);
    }
    plane += static_cast<std::ptrdiff_t>(plane_width) * plane_height;
  }
  s.frame->pts = frames_;
  s.encode(s.frame, file_);
  ++frames_;
}

void VideoEncoder::close() {
  State& s = *state_;
  if (s.closed) return;
  s.closed = true;
  s.encode(nullptr, file_);  // drain the encoder's delayed frames
  const int status = av_write_trailer(s.format);
  if (status < 0) throw RenderError("video '" + file_.string() + "': index: " + av_error(status));
  avio_closep(&s.format->pb);
}

}  // namespace locsim::render
