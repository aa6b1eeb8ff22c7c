// The tables of a sweep over a suite of worlds (`worlds:`): each configuration per family of
// worlds (summary_by_family.csv) and, when part of the suite is held back, on the part its
// defaults were chosen on beside the part they were not (summary_by_part.csv), each also a
// section of summary.md. Read from the runs' results (results.jsonl), as every sweep table.
#pragma once

#include <cstddef>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

namespace locsim {

/// A text as one CSV field: quoted when it holds a ',' or '"', on one line.
std::string csv_field(const std::string& text);
/// A JSON number with `decimals` decimals; empty for anything else (null: not measured).
std::string csv_number(const nlohmann::ordered_json& value, int decimals = 6);

/// A run's kidnaps as a test of recovery, from its metrics: those that moved the robot beyond
/// the convergence criterion (a carry within it leaves a tracking filter converged, testing
/// nothing); of those, the ones the localizer's sensors showed enough after the landing to
/// recover from (the segment's `recoverable`), and how many of these it recovered from; how
/// well it tracked once converged, pooled over its segments (RMS, the truth inside the 95 %
/// ellipse); its jumps while tracking; and a SLAM filter's map.
struct RunRecovery {
  std::size_t kidnaps = 0, recoverable = 0, recovered = 0;
  std::size_t tracking_samples = 0;
  double tracking_sum_sq = 0.0;
  std::size_t tracking_consistency_samples = 0;
  double tracking_inside = 0.0;  // samples inside the 95 % ellipse
  std::size_t jumps = 0;
  // landmark_map of metrics.json: true landmarks seen, pairs within the aligned gate, mapped,
  // spurious; none for a filter that builds no map.
  struct Map {
    std::size_t observed = 0, aligned_within = 0, mapped = 0, spurious = 0;
  };
  std::optional<Map> map;
  std::optional<double> tracking_rms_m() const;
  std::optional<double> tracking_inside_95() const;
};

RunRecovery recovery_of(const nlohmann::ordered_json& metrics);

/// Wilson's 95 % interval of a proportion k/n: unlike k/n +- 1.96 se, it stays within [0, 1]
/// and is not empty at 0 or n.
std::pair<double, double> wilson_95(std::size_t k, std::size_t n);

/// summary_by_family.csv and summary.md's "Per world family"; nothing for an experiment of one
/// world or of logs.
void write_family_tables(const std::filesystem::path& out_dir,
                         const std::vector<nlohmann::ordered_json>& results,
                         const std::vector<std::string>& configs, std::ostream& md);

/// A gap between the parts wider than this is called out in words [share points].
inline constexpr double kPartGapPoints = 10.0;

/// summary_by_part.csv and summary.md's "Chosen on and held back": the same figures on the
/// worlds the defaults were chosen on and on those held back (`held_back: true` in the
/// experiment's `worlds:`), side by side, gaps wider than kPartGapPoints said in words. Nothing
/// when no world is held back.
void write_part_tables(const std::filesystem::path& out_dir,
                       const std::vector<nlohmann::ordered_json>& results,
                       const std::vector<std::string>& configs, std::ostream& md);

}  // namespace locsim
