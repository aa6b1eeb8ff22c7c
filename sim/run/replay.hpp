// `locsim replay`: localizers run on a recorded log, without simulating. The folder it writes
// holds the same LABEL.tum and metrics.json (timing aside) as a `locsim run` with those
// localizers would, because the readings and the order of deliveries are the same.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "sim/metrics/error_metrics.hpp"

namespace locsim {

struct ReplayOptions {
  std::filesystem::path log_file;
  std::filesystem::path out_dir;
  std::vector<std::string> localizers;
  ConvergenceCriterion convergence;
  bool overwrite = false;
};

struct ReplayResult {
  double replayed_s = 0.0;  // simulated time covered
  double wall_s = 0.0;
  std::size_t records = 0;
};

/// Throws InputError (bad log, bad parameters), PluginError (plugins).
ReplayResult replay_log(const ReplayOptions& options);

}  // namespace locsim
