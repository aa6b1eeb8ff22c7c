#include "sim/plugin_host/plugin_library.hpp"

#include <dlfcn.h>
#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdlib>
#include <set>
#include <sstream>

#include "sim/common/errors.hpp"

namespace locsim {

namespace fs = std::filesystem;

PluginLibrary::PluginLibrary(const fs::path& file, const fs::path& source)
    : path_(file), source_(source) {
  if (!fs::exists(file)) throw PluginError("plugin file '" + file.string() + "' does not exist");
  dlerror();
  handle_ = dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle_ == nullptr) {
    const char* reason = dlerror();
    throw PluginError("cannot load plugin '" + file.string() +
                      "': " + (reason != nullptr ? reason : "unknown dlopen error"));
  }
  // From here on, a failure must close the handle: the destructor does not run for a throwing
  // constructor, so clean up explicitly.
  const auto fail = [&](const std::string& message) {
    dlclose(handle_);
    handle_ = nullptr;
    throw PluginError(message);
  };
  dlerror();
  void* symbol = dlsym(handle_, LOCSIM_LOCALIZER_ENTRY_SYMBOL);
  if (symbol == nullptr) {
    fail("'" + file.string() + "' is not a locsim plugin: it exports no " +
         LOCSIM_LOCALIZER_ENTRY_SYMBOL + " function");
  }
  auto entry = reinterpret_cast<locsim_localizer_entry_fn>(symbol);
  table_ = entry(LOCSIM_LOCALIZER_ABI_VERSION);
  if (table_ == nullptr) {
    fail("plugin '" + file.string() + "' refused host ABI version " +
         std::to_string(LOCSIM_LOCALIZER_ABI_VERSION));
  }
  if (!source.empty()) {
    auto load =
        reinterpret_cast<locsim_localizer_load_fn>(dlsym(handle_, LOCSIM_LOCALIZER_LOAD_SYMBOL));
    if (load == nullptr) {
      fail("plugin '" + file.string() + "' runs no source files (it exports no " +
           LOCSIM_LOCALIZER_LOAD_SYMBOL + "), so '" + source.string() +
           "' cannot be given to it; PLUGIN:SOURCE is for loader plugins such as python");
    }
    char error[1024] = "";
    table_ = load(LOCSIM_LOCALIZER_ABI_VERSION, source.c_str(), error, sizeof error);
    if (table_ == nullptr) {
      error[sizeof error - 1] = '\0';
      fail(error[0] != '\0' ? std::string(error)
                            : "plugin '" + file.string() + "' could not load '" + source.string() +
                                  "' (it said nothing more)");
    }
  }
  abi_version_ = table_->abi_version;
  if (abi_version_ < LOCSIM_LOCALIZER_ABI_VERSION_OLDEST ||
      abi_version_ > LOCSIM_LOCALIZER_ABI_VERSION) {
    fail("plugin '" + file.string() + "' was built for localizer ABI version " +
         std::to_string(abi_version_) + "; this locsim speaks versions " +
         std::to_string(LOCSIM_LOCALIZER_ABI_VERSION_OLDEST) + " to " +
         std::to_string(LOCSIM_LOCALIZER_ABI_VERSION) + ": rebuild it against this SDK");
  }
  // Versions 1 and 2 end before `readings`.
  const std::size_t table_size =
      abi_version_ >= 3 ? sizeof(locsim_localizer) : offsetof(locsim_localizer, readings);
  if (table_->struct_size != table_size) {
    fail("plugin '" + file.string() + "' has a localizer table of " +
         std::to_string(table_->struct_size) + " bytes; ABI version " +
         std::to_string(abi_version_) + " has " + std::to_string(table_size));
  }
  if (abi_version_ >= 3) readings_ = table_->readings;
  const std::pair<const void*, const char*> required[] = {
      {table_->name, "name"},
      {table_->description, "description"},
      {reinterpret_cast<const void*>(table_->create), "create"},
      {reinterpret_cast<const void*>(table_->destroy), "destroy"},
      {reinterpret_cast<const void*>(table_->update), "update"},
      {reinterpret_cast<const void*>(table_->estimate), "estimate"}};
  for (const auto& [pointer, what] : required) {
    if (pointer == nullptr)
      fail("plugin '" + file.string() + "' leaves required '" + what + "' empty");
  }
  if (table_->param_count > 0 && table_->params == nullptr) {
    fail("plugin '" + file.string() + "' declares parameters but gives none");
  }
}

PluginLibrary::~PluginLibrary() {
  if (handle_ != nullptr) dlclose(handle_);
}

namespace {
fs::path executable_dir() {
  std::error_code error;
  const fs::path exe = fs::read_symlink("/proc/self/exe", error);
  return error ? fs::path() : exe.parent_path();
}
}  // namespace

std::vector<fs::path> plugin_search_path() {
  std::vector<fs::path> folders;
  if (const char* env = std::getenv("LOCSIM_PLUGIN_PATH"); env != nullptr) {
    std::stringstream entries(env);
    std::string entry;
    while (std::getline(entries, entry, ':')) {
      if (!entry.empty()) folders.emplace_back(entry);
    }
  }
  const fs::path exe_dir = executable_dir();
  if (!exe_dir.empty()) {
    folders.push_back(exe_dir / "plugins");  // build tree: build/plugins
    // An install: bin/ to the plugin folder of its libdir (lib/locsim/plugins under /usr/local).
    folders.push_back((exe_dir / LOCSIM_PLUGINS_FROM_BIN).lexically_normal());
  }
  return folders;
}

fs::path find_source(const std::string& name_or_file) {
  if (name_or_file.find('/') != std::string::npos || name_or_file.ends_with(".py")) {
    if (!fs::is_regular_file(name_or_file))
      throw PluginError("localizer source '" + name_or_file + "' does not exist");
    return fs::absolute(name_or_file).lexically_normal();
  }
  const std::string file = name_or_file + ".py";
  std::string looked;
  for (const fs::path& folder : plugin_search_path()) {
    if (fs::is_regular_file(folder / file)) return fs::absolute(folder / file).lexically_normal();
    looked += "\n  " + folder.string();
  }
  throw PluginError("no localizer source '" + name_or_file + "' (" + file + ") found; looked in:" +
                    looked + "\n(set LOCSIM_PLUGIN_PATH or give the file's path)");
}

std::shared_ptr<const PluginLibrary> PluginCache::load(const std::string& plugin,
                                                       const std::string& source) {
  const fs::path file = find_plugin(plugin);
  const fs::path source_file = source.empty() ? fs::path() : find_source(source);
  auto& library = loaded_[file.string() + '\n' + source_file.string()];
  if (!library) library = std::make_shared<const PluginLibrary>(file, source_file);
  return library;
}

fs::path find_plugin(const std::string& name_or_file) {
  if (name_or_file.find('/') != std::string::npos || name_or_file.ends_with(".so")) {
    if (!fs::exists(name_or_file))
      throw PluginError("plugin file '" + name_or_file + "' does not exist");
    return name_or_file;
  }
  const std::string file = "locsim_" + name_or_file + ".so";
  std::string looked;
  for (const fs::path& folder : plugin_search_path()) {
    if (fs::exists(folder / file)) return folder / file;
    looked += "\n  " + folder.string();
  }
  throw PluginError("no localizer plugin '" + name_or_file + "' (" + file +
                    ") found; looked in:" + looked +
                    "\n(set LOCSIM_PLUGIN_PATH or give the .so file's path; `locsim plugins` lists "
                    "what is found)");
}

namespace {
/// The files of the search path whose names `wanted` accepts, the first of each name, each
/// folder's sorted.
template <typename Wanted>
std::vector<fs::path> list_search_path(Wanted&& wanted) {
  std::vector<fs::path> files;
  std::set<std::string> names;
  for (const fs::path& folder : plugin_search_path()) {
    std::error_code error;
    if (!fs::is_directory(folder, error)) continue;
    std::vector<fs::path> here;
    for (const auto& entry : fs::directory_iterator(folder, error)) {
      if (wanted(entry.path().filename().string())) here.push_back(entry.path());
    }
    std::sort(here.begin(), here.end());
    for (const fs::path& file : here) {
      if (names.insert(file.filename().string()).second) files.push_back(file);
    }
  }
  return files;
}
}  // namespace

std::vector<fs::path> list_plugin_files() {
  return list_search_path(
      [](const std::string& name) { return name.starts_with("locsim_") && name.ends_with(".so"); });
}

std::vector<fs::path> list_source_files() {
  return list_search_path([](const std::string& name) { return name.ends_with(".py"); });
}

}  // namespace locsim
