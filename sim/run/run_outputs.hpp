// Output pieces shared by `locsim run` and `locsim replay`.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "sim/plugin_host/localizer_host.hpp"

namespace locsim {

/// One TUM row, `t x y 0 0 0 qz qw`, for a planar pose.
void append_tum(std::string& line, double t_s, double x, double y, double theta);

/// Writes through a temporary file and a rename: a reader never sees half a file.
void write_json_atomically(const std::filesystem::path& file,
                           const nlohmann::ordered_json& content);

/// Writes `dir`/metrics.json for one robot's localizers (their wall-clock costs in the last block,
/// "timing", so that the rest is byte-identical for the same inputs); warns on stderr of failed
/// filters. Each localizer whose final landmark map (asked at `t_end_s`) is not empty also gets
/// `dir`/LABEL_map.csv and a "landmark_map" block in its entry, the map matched to the true
/// landmarks. Returns their one-line summaries for run.json.
nlohmann::ordered_json write_localizer_metrics(const std::filesystem::path& dir,
                                               const std::string& robot, LocalizerHost& host,
                                               const std::vector<double>& kidnaps_s,
                                               double t_end_s);

}  // namespace locsim
