// World variation per seed: each seed draws the true wheel radii and wheel base, the motors'
// limits, the floor's friction, the start poses, the movers' speeds and start phases and the
// waypoints' jitter, within the tolerances the world declares (VariationDef), so that repeated
// runs differ the way repeated trials of a real robot do. docs/worlds.md#variation.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>

#include "sim/scenario/scenario_def.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

/// What `seed` draws for `world` and `scenario` (bound: every drive names its robot). Each
/// quantity comes from its own stream, make_stream(seed, "variation/<what>/<name>"), so the same
/// seed gives the same world, and adding a mover changes no other draw. Start poses and waypoints
/// are redrawn (up to kFreeTries) until the robot's footprint there is free of obstacles, else
/// keep their declared value. Empty (`applied` false) when the world says `variation: none`.
DrawnVariation draw_variation(const WorldDef& world, const ScenarioDef& scenario,
                              std::uint64_t seed);

/// Makes `world` and `scenario` the drawn ones: true geometry, limits, friction and starts into
/// the world (the encoders keep believing in the declared wheel base and radius), speeds and
/// phases into the movers, jittered paths into the drives. Records `drawn` in `world.drawn`.
/// Throws InputError when `drawn` does not fit the world (a log's record of another world).
void apply_variation(const DrawnVariation& drawn, WorldDef& world, ScenarioDef& scenario);

/// Draws and applies: what `locsim run` does before anything uses the world.
void vary_world(WorldDef& world, ScenarioDef& scenario, std::uint64_t seed);

/// run.json's and the log header's record of the draws; from_json reads what to_json wrote.
nlohmann::ordered_json to_json(const DrawnVariation& drawn);
DrawnVariation drawn_variation_from_json(const nlohmann::json& record);

inline constexpr int kFreeTries = 20;

}  // namespace locsim
