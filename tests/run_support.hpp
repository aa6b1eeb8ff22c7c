// Running a simulation in a test and reading what it measured.
#pragma once

#include <nlohmann/json.hpp>

#include "sim/run/runner.hpp"
#include "test_support.hpp"

namespace locsim::testing {

/// Runs `options` and returns its metrics.json.
inline nlohmann::json run_metrics(const RunOptions& options) {
  run_simulation(options);
  return nlohmann::json::parse(read_file(options.out_dir / "metrics.json"));
}

}  // namespace locsim::testing
