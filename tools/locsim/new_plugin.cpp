// `locsim new-plugin NAME DIR`: a buildable out-of-tree localizer skeleton.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>

#include "commands.hpp"
#include "plugin_template.hpp"
#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"

namespace locsim::cli::new_plugin_cmd {

/// What the command line gives; its options write into it, so it lives as long as the command.
struct State {
  std::string name, dir;
};

int execute(const std::string& name, const std::filesystem::path& dir) {
  const bool valid = !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
  }) && !(name[0] >= '0' && name[0] <= '9');
  // A C identifier, and short enough for the file name (255 bytes) with room to spare.
  if (!valid || name.size() > 64) {
    throw InputError("new-plugin: name " + quote_input(name) +
                     " must be [a-z_][a-z0-9_]*, at most 64 characters");
  }
  if (std::filesystem::exists(dir) && !std::filesystem::is_empty(dir)) {
    throw InputError("new-plugin: folder '" + dir.string() + "' exists and is not empty");
  }
  const auto fill = [&](std::string text) {
    for (std::size_t at = text.find("{{name}}"); at != std::string::npos;
         at = text.find("{{name}}", at)) {
      text.replace(at, 8, name);
    }
    return text;
  };
  const std::filesystem::path made = make_output_folder(dir, "new-plugin");
  const std::string cmake = fill(kTemplateCMakeLists), source = fill(kTemplateSource);
  try {
    write_files({{dir / "CMakeLists.txt", cmake}, {dir / (name + ".cpp"), source}});
  } catch (...) {
    std::error_code ignored;
    if (!made.empty()) std::filesystem::remove_all(made, ignored);
    throw;
  }
  std::printf(
      "wrote %s/CMakeLists.txt and %s/%s.cpp\nbuild: cmake -S %s -B %s/build "
      "-DCMAKE_PREFIX_PATH=<locsim prefix> && cmake --build %s/build\n",
      dir.c_str(), dir.c_str(), name.c_str(), dir.c_str(), dir.c_str(), dir.c_str());
  return kExitOk;
}

}  // namespace locsim::cli::new_plugin_cmd

namespace locsim::cli {

Command add_new_plugin(CLI::App& app) {
  const auto state = std::make_shared<new_plugin_cmd::State>();
  CLI::App* const new_plugin =
      app.add_subcommand("new-plugin", "Write a buildable out-of-tree localizer skeleton");
  new_plugin->add_option("name", state->name, "Plugin name, [a-z_][a-z0-9_]*")->required();
  new_plugin->add_option("dir", state->dir, "Folder to create")->required();
  return {new_plugin, [state] { return new_plugin_cmd::execute(state->name, state->dir); }};
}

}  // namespace locsim::cli
