// Whether a robot's laser scans tell its true place apart from every other place of the static
// map: the scorer's judgement of a kidnap as recoverable for a filter that localizes on the laser.
// A scan in a symmetric room or a featureless corridor fits several poses equally well, and no
// filter on that laser can know which one the robot was put down at; counting such a kidnap
// against it would measure the world, not the filter.
//
// The judgement is a likelihood ratio over the scans after the landing (probes, one a second),
// each beam end point weighed by AMCL's likelihood field (the model amcl uses), all summed: the
// truth's log likelihood, refined to its local best, against the best other place (a pose at least
// kOtherPlaceM or kOtherPlaceDeg from the truth that explains the same scans, moved along the
// robot's true motion between them). The scans tell the place apart when the truth's
// likelihood exceeds every other place's by more than a factor kTellsApartRatio.
#pragma once

#include <locsim/laser.hpp>
#include <locsim/place_search.hpp>
#include <optional>
#include <vector>

#include "sim/common/math.hpp"
#include "sim/world/occupancy.hpp"

namespace locsim {

/// One laser scan after a landing: the true pose when it was taken and its beams' end points in
/// the robot frame (hits only: max-range and short readings left out).
struct LaserProbe {
  Pose2 truth;
  std::vector<Vec2> end_points;
};

struct LaserPlaceVerdict {
  bool told_apart = false;
  /// ln of the truth's likelihood over the best other place's; +inf when no other place fits at
  /// all (every candidate was refined back to the truth).
  double log_ratio = 0.0;
  /// Where the best other place is, from the truth at the first probe.
  std::optional<double> other_m, other_deg;
};

class LaserPlaceJudge {
 public:
  static constexpr double kOtherPlaceM = 1.0;       // nearer and alike is the same place [m]
  static constexpr double kOtherPlaceDeg = 30.0;    // ... or turned less than this [deg]
  static constexpr double kTellsApartRatio = 20.0;  // the truth 20 times as likely: odds 95 %

  explicit LaserPlaceJudge(const OccupancyGrid& grid);

  /// The verdict over `probes` (in time order; at least one).
  LaserPlaceVerdict judge(const std::vector<LaserProbe>& probes) const;

 private:
  sdk::LikelihoodField sharp_;  // AMCL's defaults: sigma_hit 0.2 m
  sdk::PlaceSearch search_;     // the coarse search, on a smoothed field (sigma_hit 0.5 m)
};

}  // namespace locsim
