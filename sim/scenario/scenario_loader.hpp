// Scenario files (YAML, or the `scenario:` section of a world) → ScenarioDef.
#pragma once

#include <filesystem>

#include "sim/common/yaml_node.hpp"
#include "sim/scenario/scenario_def.hpp"

namespace locsim {

struct WorldDef;

ScenarioDef load_scenario(const std::filesystem::path& file);
ScenarioDef parse_scenario(const YamlNode& node, const std::filesystem::path& base_dir);

/// Checks the names a scenario uses (robots, floor regions, obstacles) against the world and
/// fills in the robot of drives and events when the world has a single one. Throws InputError.
void bind_scenario(ScenarioDef& scenario, const WorldDef& world);

}  // namespace locsim
