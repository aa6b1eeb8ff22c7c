#include "sim/producers/log_source.hpp"

#include "sim/common/errors.hpp"
#include "sim/common/yaml_node.hpp"
#include "sim/scenario/scenario_loader.hpp"
#include "sim/world/world_loader.hpp"

namespace locsim {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

LogSource::LogSource(const fs::path& file) : reader_(file) {
  reader_.check_end();  // a cut log is refused before any output exists
  const json& header = reader_.header();
  try {
    const fs::path world_dir = header.at("world_dir").get<std::string>();
    world_ = parse_world(YamlNode::load_string(header.at("world_yaml"), header.at("world_file")),
                         world_dir);
    world_.source = header.at("world_file").get<std::string>();
    if (!header.at("scenario_yaml").is_null()) {
      scenario_ = parse_scenario(
          YamlNode::load_string(header["scenario_yaml"], header["scenario_file"]), world_dir);
      scenario_.source = header["scenario_file"].get<std::string>();
    } else if (world_.scenario) {
      scenario_ = *world_.scenario;
      scenario_.source = world_.source;
    }
    scenario_.duration_s = header.at("duration_s");
    seed_ = header.at("seed");
  } catch (const json::exception& e) {
    throw InputError(SourceLocation{file.string()}, "",
                     std::string("header lacks a field: ") + e.what());
  }
  bind_scenario(scenario_, world_);
}

}  // namespace locsim
