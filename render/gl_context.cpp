#include "render/gl_context.hpp"

#include <GL/gl.h>
#include <GL/osmesa.h>

#include "sim/common/errors.hpp"

namespace locsim::render {

namespace {

class OsMesaContext final : public GlContext {
 public:
  OsMesaContext(int width, int height)
      : width_(width), height_(height), pixels_(static_cast<std::size_t>(width) * height * 4) {
    // Depth for the 3D camera views, stencil for concave floor regions; no accumulation buffer.
    context_ = OSMesaCreateContextExt(OSMESA_RGBA, 24, 8, 0, nullptr);
    if (context_ == nullptr) throw RenderError("osmesa: OSMesaCreateContextExt failed");
    make_current();
    OSMesaPixelStore(OSMESA_Y_UP, 0);  // row 0 at the top, as images are stored
  }
  ~OsMesaContext() override { OSMesaDestroyContext(context_); }
  OsMesaContext(const OsMesaContext&) = delete;
  OsMesaContext& operator=(const OsMesaContext&) = delete;

  void make_current() override {
    if (!OSMesaMakeCurrent(context_, pixels_.data(), GL_UNSIGNED_BYTE, width_, height_)) {
      throw RenderError("osmesa: cannot make a " + std::to_string(width_) + "x" +
                        std::to_string(height_) + " context current");
    }
  }
  const std::uint8_t* finish_frame() override {
    glFinish();
    return pixels_.data();
  }
  int width() const override { return width_; }
  int height() const override { return height_; }
  std::string description() const override {
    const auto* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
    const auto* version = reinterpret_cast<const char*>(glGetString(GL_VERSION));
    return std::string("OSMesa, ") + (renderer != nullptr ? renderer : "?") + ", GL " +
           (version != nullptr ? version : "?");
  }

 private:
  int width_, height_;
  std::vector<std::uint8_t> pixels_;
  OSMesaContext context_ = nullptr;
};

}  // namespace

std::vector<std::string> gl_backends() {
  return {"osmesa"};
}

std::unique_ptr<GlContext> make_gl_context(const std::string& backend, int width, int height) {
  if (width < 16 || height < 16 || width > 8192 || height > 8192) {
    throw RenderError("image size " + std::to_string(width) + "x" + std::to_string(height) +
                      " is outside 16..8192 pixels");
  }
  if (backend == "osmesa") return std::make_unique<OsMesaContext>(width, height);
  throw RenderError("GL backend '" + backend + "' is not in this build (available: osmesa)");
}

}  // namespace locsim::render
