// The render module's entry points: `locsim run` loads liblocsim_render.so with dlopen only when
// a video or frames are asked for, so that runs without one (and every run of a sweep) start
// without OpenGL, OpenCV and FFmpeg (about 250 shared libraries, 0.3 s per process here).
#include <cstdio>
#include <exception>

#include "render/loader.hpp"
#include "render/video_recorder.hpp"

extern "C" {

LOCSIM_RENDER_EXPORT std::uint32_t locsim_render_abi() {
  return locsim::render::kRenderAbi;
}

LOCSIM_RENDER_EXPORT int locsim_render_create(const locsim::VideoOptions* options,
                                              locsim::FrameSink** out, char* error,
                                              std::size_t error_size) {
  try {
    *out = new locsim::render::VideoRecorder(*options);  // freed by locsim_render_destroy
    return 0;
  } catch (const std::exception& e) {
    std::snprintf(error, error_size, "%s", e.what());
    return 1;
  }
}

LOCSIM_RENDER_EXPORT void locsim_render_destroy(locsim::FrameSink* sink) {
  delete sink;
}

}  // extern "C"
