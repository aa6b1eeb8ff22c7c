// The bytes a run will write, estimated from its world and options before it starts, so that a
// run that would fill the disk (a 100 000-beam laser at 10 kHz writes 1 GB in 19 s; a
// `duration_s: 1e7`) is refused at once, naming what makes it large, instead of failing hours
// later with a full disk.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include "sim/common/errors.hpp"
#include "sim/scenario/scenario_def.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

/// The most a run writes unless --max-output-gib says otherwise. [bytes]
inline constexpr std::uint64_t kDefaultMaxOutputBytes = std::uint64_t{16} << 30;

/// What a run will write: its total, and the largest single part with the place in the world
/// file that decides it.
struct OutputEstimate {
  double total_bytes = 0.0;
  double largest_bytes = 0.0;
  InputPlace largest_place;
  std::string largest_what;
};

/// The outputs of `world` run through `scenario`: ground truth, `localizers` estimate files per
/// robot, readings/ when `readings`, the log when `log`. Upper estimates of each row's text.
OutputEstimate estimate_run_output(const WorldDef& world, const ScenarioDef& scenario,
                                   bool readings, bool log, std::size_t localizers);

/// Throws InputError when the estimate exceeds `max_bytes` (naming the largest part's place,
/// and --max-output-gib), or the free space of the filesystem `out_dir` will be on.
void check_run_output(const OutputEstimate& estimate, std::uint64_t max_bytes,
                      const std::filesystem::path& out_dir);

}  // namespace locsim
