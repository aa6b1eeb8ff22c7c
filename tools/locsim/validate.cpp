// `locsim validate`: check a world (and scenario) without running it.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "commands.hpp"
#include "common.hpp"
#include "sim/common/errors.hpp"
#include "sim/producers/simulation.hpp"
#include "sim/run/runner.hpp"

namespace locsim::cli::validate_cmd {

/// What the command line gives; its options write into it, so it lives as long as the command.
struct State {
  std::string world;
  std::optional<std::string> scenario;
};

int execute(const State& s) {
  const RunInputs inputs = load_run_inputs(
      s.world, s.scenario ? std::optional<std::filesystem::path>(*s.scenario) : std::nullopt,
      std::nullopt);
  // Building the world checks what only the physics can: robots starting in collision.
  const Simulation sim(inputs.world, inputs.scenario, 1, imager_factory("osmesa"));
  std::printf(
      "%s: ok (%zu robot%s, %d static fixtures, %zu movers, %zu landmarks, %zu beacons, "
      "scenario '%s' %.1f s, %zu events)\n",
      s.world.c_str(), sim.robot_count(), sim.robot_count() == 1 ? "" : "s",
      sim.world().static_fixture_count(), inputs.world.movers.size(), inputs.world.landmarks.size(),
      inputs.world.beacons.size(), inputs.scenario.name.c_str(), inputs.scenario.duration_s,
      inputs.scenario.events.size());
  return kExitOk;
}

}  // namespace locsim::cli::validate_cmd

namespace locsim::cli {

Command add_validate(CLI::App& app) {
  const auto state = std::make_shared<validate_cmd::State>();
  CLI::App* const check =
      app.add_subcommand("validate", "Check a world (and scenario) without running");
  check->add_option("world", state->world, "World file (YAML)")->required();
  check->add_option("--scenario", state->scenario, "Scenario file (YAML)");
  return {check, [state] { return validate_cmd::execute(*state); }};
}

}  // namespace locsim::cli
