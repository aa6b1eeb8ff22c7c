// Loading the render module (liblocsim_render.so) at run time, as `locsim run --video` does.
// Handles close by RAII; the sink is destroyed by the module that made it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <vector>

#include "sim/run/frame_state.hpp"

#define LOCSIM_RENDER_EXPORT __attribute__((visibility("default")))

namespace locsim::render {

/// Changes whenever the structs passed across (VideoOptions, FrameState) change layout.
inline constexpr std::uint32_t kRenderAbi =
    0x10000u + static_cast<std::uint32_t>(sizeof(VideoOptions) * 31u + sizeof(FrameState) * 7u +
                                          sizeof(FrameLocalizer) * 3u + sizeof(FrameRobot));

/// Where the module is looked for, in order: $LOCSIM_RENDER_MODULE, next to the locsim binary
/// (the build tree), the install prefix's lib/locsim.
std::vector<std::filesystem::path> render_module_candidates();

class RenderModule : public std::enable_shared_from_this<RenderModule> {
 public:
  /// Loads the first module found. Throws RenderError naming where it looked and why it failed.
  static std::shared_ptr<RenderModule> load();
  ~RenderModule();
  RenderModule(const RenderModule&) = delete;
  RenderModule& operator=(const RenderModule&) = delete;

  /// A recorder for `options`. Throws RenderError with the module's message.
  std::shared_ptr<FrameSink> make_recorder(const VideoOptions& options);
  const std::filesystem::path& path() const { return path_; }

 private:
  RenderModule(void* handle, std::filesystem::path path);
  void* handle_;
  std::filesystem::path path_;
  int (*create_)(const VideoOptions*, FrameSink**, char*, std::size_t) = nullptr;
  void (*destroy_)(FrameSink*) = nullptr;
};

}  // namespace locsim::render
