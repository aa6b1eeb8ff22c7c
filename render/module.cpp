// The render module's entry points: `locsim run` loads liblocsim_render.so with dlopen only when
// a video or frames are asked for, so that runs without one (and every run of a sweep) start
// without OpenGL, OpenCV and FFmpeg (about 250 shared libraries, 0.3 s per process here).
#include <cstdio>
#include <exception>

#include "render/loader.hpp"
#include "render/rendered_camera.hpp"
#include "render/video_recorder.hpp"

namespace {

/// Runs `make` (it returns what the caller frees through the matching destroy function): 0, or
/// 1 with the exception's message in `error`. No exception crosses the C boundary.
template <class T, class Make>
int create(T** out, char* error, std::size_t error_size, Make make) {
  try {
    *out = make();
    return 0;
  } catch (const std::exception& e) {
    std::snprintf(error, error_size, "%s", e.what());
    return 1;
  }
}

}  // namespace

extern "C" {

LOCSIM_RENDER_EXPORT std::uint32_t locsim_render_abi() {
  return locsim::render::kRenderAbi;
}

LOCSIM_RENDER_EXPORT int locsim_render_create(const locsim::VideoOptions* options,
                                              locsim::FrameSink** out, char* error,
                                              std::size_t error_size) {
  return create(out, error, error_size, [&]() -> locsim::FrameSink* {
    return new locsim::render::VideoRecorder(*options);  // freed by locsim_render_destroy
  });
}

LOCSIM_RENDER_EXPORT void locsim_render_destroy(locsim::FrameSink* sink) {
  delete sink;
}

LOCSIM_RENDER_EXPORT int locsim_render_create_imager(const locsim::WorldDef* world,
                                                     const locsim::PtzCameraDef* camera,
                                                     const char* backend,
                                                     locsim::LandmarkImager** out, char* error,
                                                     std::size_t error_size) {
  return create(out, error, error_size, [&]() -> locsim::LandmarkImager* {
    // Freed by locsim_render_destroy_imager.
    return new locsim::render::RenderedCamera(*world, *camera, backend);
  });
}

LOCSIM_RENDER_EXPORT void locsim_render_destroy_imager(locsim::LandmarkImager* imager) {
  delete imager;
}

}  // extern "C"
