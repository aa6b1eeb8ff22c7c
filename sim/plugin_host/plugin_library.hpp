// Finding and loading localizer plugins: dlopen(RTLD_NOW | RTLD_LOCAL), the entry point, and the
// checks of its table (ABI version, struct size, required functions). Handles close by RAII.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "locsim/localizer.h"

namespace locsim {

class PluginLibrary {
 public:
  /// Loads a plugin file; with a `source`, the filter that source defines, through the plugin's
  /// locsim_localizer_load (a loader plugin such as python). Throws PluginError saying exactly
  /// what is wrong.
  explicit PluginLibrary(const std::filesystem::path& file,
                         const std::filesystem::path& source = {});
  ~PluginLibrary();
  PluginLibrary(const PluginLibrary&) = delete;
  PluginLibrary& operator=(const PluginLibrary&) = delete;

  const locsim_localizer& table() const { return *table_; }
  const std::filesystem::path& path() const { return path_; }
  /// The source file a loader plugin runs (empty for a plain plugin).
  const std::filesystem::path& source() const { return source_; }
  /// The file that defines the filter, for messages and fingerprints: its source, else the
  /// library.
  const std::filesystem::path& definition() const { return source_.empty() ? path_ : source_; }
  /// The ABI version the plugin was built for, LOCSIM_LOCALIZER_ABI_VERSION_OLDEST to
  /// LOCSIM_LOCALIZER_ABI_VERSION: the host gives it the structs of that version.
  std::uint32_t abi_version() const { return abi_version_; }
  /// The kinds of reading the plugin says it uses (LOCSIM_READING_BIT), 0 when it does not say
  /// (built for a version before 3, or it looks at every reading itself).
  std::uint32_t readings() const { return readings_; }

 private:
  std::filesystem::path path_, source_;
  void* handle_ = nullptr;
  const locsim_localizer* table_ = nullptr;
  std::uint32_t abi_version_ = 0;
  std::uint32_t readings_ = 0;
};

/// Where plugins are looked for, in order: each folder of LOCSIM_PLUGIN_PATH (colon-separated),
/// the build's plugin folder (next to the locsim binary), the install's plugin folder
/// (LIBDIR/locsim/plugins, found from the binary's folder).
std::vector<std::filesystem::path> plugin_search_path();

/// A plugin's file: `name_or_file` itself when it names a file (has a '/' or ends in .so), else
/// locsim_NAME.so in the search path. Throws PluginError listing where it looked.
std::filesystem::path find_plugin(const std::string& name_or_file);

/// Every locsim_*.so in the search path (the first of each name wins).
std::vector<std::filesystem::path> list_plugin_files();

/// Every *.py in the search path (the first of each name wins): the scripts `python:NAME` runs.
std::vector<std::filesystem::path> list_source_files();

/// The source file a loader plugin is to run, absolute: `name_or_file` itself when it names a file
/// (has a '/' or ends in .py), else NAME.py in the search path. Throws PluginError listing where
/// it looked.
std::filesystem::path find_source(const std::string& name_or_file);

/// Plugins loaded once per library and source, shared by the specs that name them.
class PluginCache {
 public:
  /// `plugin` as find_plugin takes it; `source` as find_source takes it, or empty.
  std::shared_ptr<const PluginLibrary> load(const std::string& plugin, const std::string& source);

 private:
  std::map<std::string, std::shared_ptr<const PluginLibrary>> loaded_;  // by file and source
};

}  // namespace locsim
