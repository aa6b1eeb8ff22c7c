// World files (YAML) → WorldDef, with every problem reported at its file, line, column and key.
#pragma once

#include <filesystem>
#include <map>
#include <string>

#include "sim/common/yaml_node.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

/// Reads and checks a world file, including a referenced ROS map and an inline scenario.
/// Throws InputError.
WorldDef load_world(const std::filesystem::path& file);

/// The colours a world names (`color: red`), with the RGB they draw with.
const std::map<std::string, Rgb>& named_colors();
/// The same from an already parsed document; relative paths resolve against `base_dir`.
WorldDef parse_world(const YamlNode& root, const std::filesystem::path& base_dir);

/// Reads a ROS map_server `map.yaml` and its image. Throws InputError.
OccupancyMapDef load_occupancy_map(const std::filesystem::path& map_yaml);

FootprintDef parse_footprint(const YamlNode& node);
/// A robot's `command_response:` (also the `robot:` section `locsim calibrate` writes).
CommandResponseDef parse_command_response(const YamlNode& node);
/// A robot's `side_slip:` (also a calibration file's, read by twin).
SideSlipDef parse_side_slip(const YamlNode& node);

}  // namespace locsim
