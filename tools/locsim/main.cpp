// The locsim command line. Exit codes: 0 ok, 1 failure, 2 bad input, 130 interrupted.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <iostream>

#include "sim/common/errors.hpp"
#include "sim/run/runner.hpp"
#include "sim/run/simulation.hpp"

namespace {

std::atomic<bool> g_interrupted{false};

extern "C" void on_sigint(int) {
  g_interrupted.store(true);
}

constexpr const char* kExitCodes = R"(Exit codes:
  0    success
  1    failure not caused by the input (I/O error, internal error)
  2    bad input: command line, world, scenario or map file (the message names file:line:col and key)
  130  interrupted (Ctrl-C); the run folder keeps what was written, run.json says "interrupted")";

int validate(const std::string& world, const std::optional<std::string>& scenario) {
  const locsim::RunInputs inputs = locsim::load_run_inputs(
      world, scenario ? std::optional<std::filesystem::path>(*scenario) : std::nullopt,
      std::nullopt);
  // Building the world checks what only the physics can: robots starting in collision.
  const locsim::Simulation sim(inputs.world, inputs.scenario, 1);
  std::printf(
      "%s: ok (%zu robot%s, %d static fixtures, %zu movers, %zu landmarks, %zu beacons, "
      "scenario '%s' %.1f s, %zu events)\n",
      world.c_str(), sim.robot_count(), sim.robot_count() == 1 ? "" : "s",
      sim.world().static_fixture_count(), inputs.world.movers.size(), inputs.world.landmarks.size(),
      inputs.world.beacons.size(), inputs.scenario.name.c_str(), inputs.scenario.duration_s,
      inputs.scenario.events.size());
  return locsim::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"locsim: a simulator for mobile-robot localization research"};
  app.footer(kExitCodes);
  app.set_version_flag("--version", locsim::locsim_version());
  app.require_subcommand(1);

  locsim::RunOptions options;
  std::string world_file;
  std::optional<std::string> scenario_file;
  std::string out_dir;
  bool quiet = false;
  CLI::App* run = app.add_subcommand("run", "Simulate a world and write a run folder");
  run->add_option("world", world_file, "World file (YAML)")->required();
  run->add_option("--scenario", scenario_file,
                  "Scenario file (YAML); default: the world's own 'scenario:' section");
  run->add_option("--seed", options.seed, "Run seed; every random stream derives from it")
      ->capture_default_str();
  run->add_option("--duration", options.duration_s, "Simulated seconds (overrides the scenario)")
      ->check(CLI::PositiveNumber);
  run->add_option("--out", out_dir, "Output folder (default: a new folder under runs/)");
  run->add_flag("--realtime", options.realtime, "Pace the simulation to the wall clock");
  run->add_flag("--overwrite", options.overwrite, "Allow writing into a non-empty folder");
  run->add_flag("-q,--quiet", quiet, "No progress line and no summary");
  run->footer(
      "Writes run.json (resolved configuration, seed, version, timing), groundtruth.tum (true\n"
      "pose, TUM format) and events.csv (every scenario event). With several robots each has its\n"
      "own sub-folder for groundtruth.tum.\n\n" +
      std::string(kExitCodes));

  std::string validate_world;
  std::optional<std::string> validate_scenario;
  CLI::App* check = app.add_subcommand("validate", "Check a world (and scenario) without running");
  check->add_option("world", validate_world, "World file (YAML)")->required();
  check->add_option("--scenario", validate_scenario, "Scenario file (YAML)");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? locsim::kExitOk : locsim::kExitBadInput;
  }

  try {
    if (*check) return validate(validate_world, validate_scenario);

    options.world_file = world_file;
    if (scenario_file) options.scenario_file = *scenario_file;
    options.out_dir = out_dir;
    options.progress = !quiet && isatty(STDERR_FILENO);
    std::signal(SIGINT, on_sigint);
    const locsim::RunResult result = locsim::run_simulation(options, &g_interrupted);
    if (!quiet) {
      std::printf("%s: %s, %.1f s simulated in %.2f s (%.0fx real time) -> %s\n",
                  world_file.c_str(), result.status.c_str(), result.simulated_s, result.wall_s,
                  result.wall_s > 0 ? result.simulated_s / result.wall_s : 0.0,
                  result.out_dir.c_str());
    }
    return result.status == "interrupted" ? locsim::kExitInterrupted : locsim::kExitOk;
  } catch (const locsim::InputError& e) {
    std::fprintf(stderr, "locsim: error: %s\n", e.what());
    return locsim::kExitBadInput;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "locsim: failure: %s\n", e.what());
    return locsim::kExitFailure;
  }
}
