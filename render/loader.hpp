// Loading the render module (liblocsim_render.so) at run time, as `locsim run --video` does.
// Handles close by RAII; the sink is destroyed by the module that made it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "sim/consumers/frame_state.hpp"
#include "sim/sensors/camera_image.hpp"

#define LOCSIM_RENDER_EXPORT __attribute__((visibility("default")))

namespace locsim::render {

/// Changes whenever the structs passed across (VideoOptions, FrameState, the camera's) change
/// layout.
inline constexpr std::uint32_t kRenderAbi =
    0x20000u + static_cast<std::uint32_t>(sizeof(VideoOptions) * 31u + sizeof(FrameState) * 7u +
                                          sizeof(FrameLocalizer) * 3u + sizeof(FrameRobot) +
                                          sizeof(FrameMover) * 5u + sizeof(WorldDef) * 11u +
                                          sizeof(PtzCameraDef) * 13u + sizeof(CameraShot) * 17u +
                                          sizeof(ScenePrism) * 19u + sizeof(ImageBlob) * 23u);

/// Where the module is looked for: $LOCSIM_RENDER_MODULE alone when set; else liblocsim_render.so
/// in each of `folders`, by default the locsim binary's folder (the build tree) then the install's
/// module folder found from it (LIBDIR/locsim).
std::vector<std::filesystem::path> render_module_candidates(
    std::vector<std::filesystem::path> folders = {});

class RenderModule : public std::enable_shared_from_this<RenderModule> {
 public:
  /// Loads the first of render_module_candidates(folders) found. Throws RenderError naming where
  /// it looked and why it failed.
  static std::shared_ptr<RenderModule> load(std::vector<std::filesystem::path> folders = {});
  ~RenderModule();
  RenderModule(const RenderModule&) = delete;
  RenderModule& operator=(const RenderModule&) = delete;

  /// A recorder for `options`. Throws RenderError with the module's message.
  std::shared_ptr<FrameSink> make_recorder(const VideoOptions& options);
  /// The rendered mode's imager for one camera, on a GL context of `backend`. Throws RenderError.
  std::shared_ptr<LandmarkImager> make_imager(const WorldDef& world, const PtzCameraDef& camera,
                                              const std::string& backend);
  const std::filesystem::path& path() const { return path_; }

 private:
  RenderModule(void* handle, std::filesystem::path path);
  void* handle_;
  std::filesystem::path path_;
  int (*create_)(const VideoOptions*, FrameSink**, char*, std::size_t) = nullptr;
  void (*destroy_)(FrameSink*) = nullptr;
  int (*create_imager_)(const WorldDef*, const PtzCameraDef*, const char*, LandmarkImager**, char*,
                        std::size_t) = nullptr;
  void (*destroy_imager_)(LandmarkImager*) = nullptr;
};

}  // namespace locsim::render
