// `locsim plugins`: every plugin found, loaded, with its ABI version and parameters; failures
// reported each.
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>

#include "commands.hpp"
#include "sim/common/errors.hpp"
#include "sim/plugin_host/plugin_library.hpp"

namespace locsim::cli::plugins_cmd {

const char* type_name(int type) {
  switch (type) {
    case LOCSIM_PARAM_DOUBLE:
      return "double";
    case LOCSIM_PARAM_INT:
      return "int";
    case LOCSIM_PARAM_BOOL:
      return "bool";
    case LOCSIM_PARAM_STRING:
      return "string";
  }
  return "?";
}

int execute() {
  std::printf(
      "Search path (LOCSIM_PLUGIN_PATH, then the build's and the install's plugin folders):\n");
  for (const auto& folder : plugin_search_path()) std::printf("  %s\n", folder.c_str());
  const auto files = list_plugin_files();
  if (files.empty()) std::printf("\nNo plugins found.\n");
  int failures = 0;
  const auto show = [&](const std::filesystem::path& file, const std::filesystem::path& source,
                        const std::string& prefix) {
    try {
      const PluginLibrary library(file, source);
      const locsim_localizer& t = library.table();
      // The ABI version the plugin was built for: the host serves several (docs/plugins.md).
      std::printf("\n%s%s  %s  (ABI version %u)\n  %s\n", prefix.c_str(), t.name, t.description,
                  static_cast<unsigned>(library.abi_version()),
                  (source.empty() ? file : source).c_str());
      for (std::size_t i = 0; i < t.param_count; ++i) {
        const locsim_param_decl& p = t.params[i];
        std::printf("    %-20s %-6s ", p.name, type_name(p.type));
        if (p.type == LOCSIM_PARAM_STRING) {
          std::printf("default '%s'", p.default_string != nullptr ? p.default_string : "");
        } else if (p.type == LOCSIM_PARAM_BOOL) {
          std::printf("default %s", p.default_number != 0.0 ? "true" : "false");
        } else {
          std::printf("default %g in [%g, %g]", p.default_number, p.min_number, p.max_number);
        }
        std::printf("  %s\n", p.doc != nullptr ? p.doc : "");
      }
    } catch (const PluginError& e) {
      ++failures;
      std::printf("\n(failed) %s\n  %s\n", (source.empty() ? file : source).c_str(), e.what());
    }
  };
  std::optional<std::filesystem::path> python;
  for (const auto& file : files) {
    show(file, {}, "");
    if (file.filename() == "locsim_python.so") python = file;
  }
  // The scripts the python plugin runs by name (`--localizer python:NAME`).
  if (python) {
    for (const auto& script : list_source_files()) show(*python, script, "python:");
  }
  return failures > 0 ? kExitPlugin : kExitOk;
}

}  // namespace locsim::cli::plugins_cmd

namespace locsim::cli {

Command add_plugins(CLI::App& app) {
  CLI::App* const plugins =
      app.add_subcommand("plugins", "List the localizer plugins found, with their parameters");
  return {plugins, [] { return plugins_cmd::execute(); }};
}

}  // namespace locsim::cli
