// The resolved configuration (every default filled in) as JSON, for run.json.
#pragma once

#include <nlohmann/json.hpp>

#include "sim/scenario/scenario_def.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

nlohmann::ordered_json to_json(const WorldDef& world);
nlohmann::ordered_json to_json(const ScenarioDef& scenario);

}  // namespace locsim
