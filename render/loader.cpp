#include "render/loader.hpp"

#include <dlfcn.h>

#include <cstdlib>
#include <utility>

#include "sim/common/errors.hpp"

namespace locsim::render {

namespace fs = std::filesystem;

std::vector<fs::path> render_module_candidates(std::vector<fs::path> folders) {
  // Asked for by name: that one only (falling back to another would hide the mistake).
  if (const char* env = std::getenv("LOCSIM_RENDER_MODULE"); env != nullptr && *env != '\0')
    return {fs::path(env)};
  if (folders.empty()) {
    std::error_code error;
    const fs::path exe = fs::read_symlink("/proc/self/exe", error);
    if (!error) folders = {exe.parent_path(), exe.parent_path() / LOCSIM_RENDER_FROM_BIN};
  }
  std::vector<fs::path> out;
  for (const fs::path& folder : folders)
    out.push_back((folder / "liblocsim_render.so").lexically_normal());
  return out;
}

RenderModule::RenderModule(void* handle, fs::path path) : handle_(handle), path_(std::move(path)) {}

RenderModule::~RenderModule() {
  if (handle_ != nullptr) dlclose(handle_);
}

std::shared_ptr<RenderModule> RenderModule::load(std::vector<fs::path> folders) {
  std::string tried;
  for (const fs::path& candidate : render_module_candidates(std::move(folders))) {
    if (!fs::exists(candidate)) {
      tried += "\n  " + candidate.string() + ": not there";
      continue;
    }
    void* handle = dlopen(candidate.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) {
      const char* why = dlerror();
      tried += "\n  " + candidate.string() + ": " + (why != nullptr ? why : "dlopen failed");
      continue;
    }
    std::shared_ptr<RenderModule> module(new RenderModule(handle, candidate));
    const auto abi = reinterpret_cast<std::uint32_t (*)()>(dlsym(handle, "locsim_render_abi"));
    module->create_ =
        reinterpret_cast<decltype(module->create_)>(dlsym(handle, "locsim_render_create"));
    module->destroy_ =
        reinterpret_cast<decltype(module->destroy_)>(dlsym(handle, "locsim_render_destroy"));
    module->create_imager_ = reinterpret_cast<decltype(module->create_imager_)>(
        dlsym(handle, "locsim_render_create_imager"));
    module->destroy_imager_ = reinterpret_cast<decltype(module->destroy_imager_)>(
        dlsym(handle, "locsim_render_destroy_imager"));
    if (abi == nullptr || module->create_ == nullptr || module->destroy_ == nullptr ||
        module->create_imager_ == nullptr || module->destroy_imager_ == nullptr) {
      tried += "\n  " + candidate.string() + ": not a locsim render module";
      continue;
    }
    if (abi() != kRenderAbi) {
      tried += "\n  " + candidate.string() + ": built from another version of locsim";
      continue;
    }
    return module;
  }
  throw RenderError(
      "cannot load the renderer (liblocsim_render.so) for --video/--frames or a rendered "
      "camera:" +
      tried);
}

std::shared_ptr<FrameSink> RenderModule::make_recorder(const VideoOptions& options) {
  FrameSink* sink = nullptr;
  char error[1024] = {};
  if (create_(&options, &sink, error, sizeof error) != 0 || sink == nullptr)
    throw RenderError(error[0] != '\0' ? error : "the renderer could not be created");
  // The sink keeps the module loaded for as long as it lives.
  return std::shared_ptr<FrameSink>(
      sink, [module = shared_from_this(), destroy = destroy_](FrameSink* s) { destroy(s); });
}

std::shared_ptr<LandmarkImager> RenderModule::make_imager(const WorldDef& world,
                                                          const PtzCameraDef& camera,
                                                          const std::string& backend) {
  LandmarkImager* imager = nullptr;
  char error[1024] = {};
  if (create_imager_(&world, &camera, backend.c_str(), &imager, error, sizeof error) != 0 ||
      imager == nullptr) {
    throw RenderError(std::string("rendered camera: ") +
                      (error[0] != '\0' ? error : "the renderer could not be created"));
  }
  return std::shared_ptr<LandmarkImager>(
      imager,
      [module = shared_from_this(), destroy = destroy_imager_](LandmarkImager* i) { destroy(i); });
}

}  // namespace locsim::render
