// Running a simulation in a test and reading what it measured.
#pragma once

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "sim/run/runner.hpp"
#include "sim/world/generator.hpp"
#include "test_support.hpp"

namespace locsim::testing {

/// Runs `options` and returns its metrics.json.
inline nlohmann::json run_metrics(const RunOptions& options) {
  run_simulation(options);
  return nlohmann::json::parse(read_file(options.out_dir / "metrics.json"));
}

/// A run of a generated world (a fresh one, not the suite's), written with its output into the
/// temporary folder `name`: world.yaml and out/.
inline RunOptions generated_run(const std::string& name, const GeneratorDef& def,
                                std::uint64_t seed, double duration_s,
                                std::vector<std::string> localizers) {
  const std::filesystem::path dir = temp_dir(name);
  std::ofstream(dir / "world.yaml") << generate_world(def).yaml;
  RunOptions options;
  options.world_file = dir / "world.yaml";
  options.seed = seed;
  options.duration_s = duration_s;
  options.out_dir = dir / "out";
  options.localizers = std::move(localizers);
  return options;
}

}  // namespace locsim::testing
