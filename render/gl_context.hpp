// An offscreen OpenGL context that renders into memory. OSMesa (Mesa's software rasteriser,
// llvmpipe) is always there and needs no display or GPU; the interface leaves room for an EGL
// backend on machines with a GPU, chosen at run time by name.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace locsim::render {

class GlContext {
 public:
  virtual ~GlContext() = default;
  /// Makes this context current on the calling thread (GL calls go to it).
  virtual void make_current() = 0;
  /// Waits for the GL commands so far and returns the image: RGBA, 8 bits per channel, rows from
  /// the top, width * height * 4 bytes, valid until the next frame is drawn.
  virtual const std::uint8_t* finish_frame() = 0;
  virtual int width() const = 0;
  virtual int height() const = 0;
  /// "OSMesa 22.3.6 (llvmpipe)": what renders.
  virtual std::string description() const = 0;
};

/// Backends this build offers, in order of preference.
std::vector<std::string> gl_backends();

/// A context of `backend` ("osmesa") with a width x height RGBA colour buffer. Throws RenderError
/// naming the backend and why.
std::unique_ptr<GlContext> make_gl_context(const std::string& backend, int width, int height);

}  // namespace locsim::render
