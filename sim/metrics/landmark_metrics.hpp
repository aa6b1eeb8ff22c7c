// How well a SLAM filter mapped the landmarks: its final map matched one-to-one to the true
// landmarks, the matched pairs' position errors, what it invented and what it failed to map.
#pragma once

#include <cstddef>
#include <optional>
#include <set>
#include <vector>

namespace locsim {

/// A mapped landmark is matched to a true one only within this distance [m]. A SLAM filter's
/// landmark this far from every true landmark is counted as spurious, not as a large error: past
/// a metre, on the worlds' landmark spacing of a few metres, it no longer stands for that landmark.
inline constexpr double kLandmarkMatchGateM = 1.0;

/// A matched landmark counts as mapped well when, after the alignment below, it lies within this
/// of the true one [m]: the room's shape kept, whatever frame the filter started in.
inline constexpr double kLandmarkAlignedGateM = 0.3;

struct LandmarkPoint {
  int id = 0;  // the filter's numbering (mapped) or the world's (true)
  double x_m = 0.0, y_m = 0.0;
};

struct LandmarkMatch {
  std::size_t mapped = 0;  // index into the mapped landmarks
  std::size_t truth = 0;   // index into the true landmarks
  double distance_m = 0.0;
};

/// One-to-one greedy matching: every pair within `gate_m` (inclusive), by increasing distance
/// (ties by mapped index, then true index), each taken unless either side is already matched.
/// Deterministic; the result is in the order the pairs were taken.
std::vector<LandmarkMatch> match_landmarks(const std::vector<LandmarkPoint>& mapped,
                                           const std::vector<LandmarkPoint>& truth,
                                           double gate_m = kLandmarkMatchGateM);

struct LandmarkMapSummary {
  std::size_t mapped = 0;    // landmarks in the filter's map
  std::size_t matched = 0;   // of them, matched to a true landmark
  std::size_t spurious = 0;  // mapped - matched
  std::size_t observed = 0;  // true landmarks the robot's cameras detected during the run
  std::size_t missed = 0;    // observed true landmarks left unmatched
  // Over the matched pairs' distances [m]; nullopt when nothing matched.
  std::optional<double> error_rms_m, error_mean_m, error_max_m;
  // The same after the rigid motion (rotation and translation, no scale) that brings the mapped
  // landmarks of the pairs closest to the true ones (least squares); nullopt below three pairs
  // (two fix the motion but for their distance). A SLAM map is built in the frame of the
  // filter's start, and the start is known only roughly: 0.2 m and 1.3 degrees off put
  // landmarks 10 m away 0.4 m off, however well they are mapped.
  std::optional<double> aligned_rms_m, aligned_mean_m, aligned_max_m;
  // Matched pairs within kLandmarkAlignedGateM after that motion (below three pairs: the pairs
  // within it as they are).
  std::size_t aligned_within = 0;
  std::vector<LandmarkMatch> matches;
};

/// `observed_ids`: ids of the true landmarks that were ever detected; only these count as missed
/// (a filter cannot map a landmark it was never shown).
LandmarkMapSummary summarize_landmark_map(const std::vector<LandmarkPoint>& mapped,
                                          const std::vector<LandmarkPoint>& truth,
                                          const std::set<int>& observed_ids,
                                          double gate_m = kLandmarkMatchGateM);

}  // namespace locsim
