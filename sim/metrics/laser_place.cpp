#include "sim/metrics/laser_place.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <locsim/models.hpp>
#include <locsim/particle_filter.hpp>
#include <numbers>

namespace locsim {

namespace {

using sdk::Pose;

constexpr double kCoarseStepM = 0.25;         // candidate positions of the coarse search [m]
constexpr int kCoarseHeadings = 48;           // ... and headings (7.5 degrees apart)
constexpr std::size_t kFirstPassBeams = 10;   // end points of the first probe it weighs first
constexpr std::size_t kSecondPassShare = 20;  // then the best twentieth of the poses
constexpr std::size_t kSecondPassMin = 2000;  // (at least this many)
constexpr std::size_t kCoarseBeams = 30;      // on this many end points
constexpr double kClearanceM = 0.1;           // a robot's centre is no nearer an obstacle [m]
constexpr std::size_t kCandidates = 16;       // the best distinct coarse poses refined

locsim_occupancy_grid view(const OccupancyGrid& grid) {
  return {grid.origin_m.x(), grid.origin_m.y(), grid.resolution_m,
          grid.width,        grid.height,       grid.cells.data()};
}

sdk::LikelihoodField field(const OccupancyGrid& grid, double sigma_hit_m) {
  sdk::LikelihoodFieldDef def;  // AMCL's z_hit, z_rand, max_dist, range_max
  def.sigma_hit_m = sigma_hit_m;
  return {view(grid), def};
}

Pose pose_of(const Pose2& p) {
  return {p.x, p.y, p.theta};
}

/// Sum of the log likelihoods of every `stride`-th end point seen from `pose`.
double score(const sdk::LikelihoodField& f, const Pose& pose, const std::vector<Vec2>& points,
             std::size_t stride = 1) {
  const double c = std::cos(pose(2)), s = std::sin(pose(2));
  double sum = 0.0;
  for (std::size_t i = 0; i < points.size(); i += stride) {
    const Vec2& p = points[i];
    sum += f.log_p(pose(0) + c * p.x() - s * p.y(), pose(1) + s * p.x() + c * p.y());
  }
  return sum;
}

bool other_place(const Pose& a, const Pose& b) {
  return std::hypot(a(0) - b(0), a(1) - b(1)) >= LaserPlaceJudge::kOtherPlaceM ||
         std::abs(sdk::wrap(a(2) - b(2))) >= deg_to_rad(LaserPlaceJudge::kOtherPlaceDeg);
}

}  // namespace

LaserPlaceJudge::LaserPlaceJudge(const OccupancyGrid& grid)
    : grid_(grid), sharp_(field(grid, 0.2)), smooth_(field(grid, 0.5)), free_(view(grid)) {
  const std::vector<double> d2 = sdk::squared_distance_transform(
      grid.width, grid.height, [&](int col, int row) { return grid.occupied(col, row); });
  clearance_m_.reserve(d2.size());
  for (const double d : d2) clearance_m_.push_back(std::sqrt(d) * grid.resolution_m);
}

LaserPlaceVerdict LaserPlaceJudge::judge(const std::vector<LaserProbe>& probes) const {
  LaserPlaceVerdict verdict;
  if (probes.empty()) return verdict;
  const Pose first = pose_of(probes.front().truth);
  // Each probe's pose relative to the first: a place that explains the first scan must explain
  // the later ones too, moved along the robot's true motion (the filter has its odometry).
  std::vector<Pose> relative;
  for (const LaserProbe& p : probes) relative.push_back(sdk::between(first, pose_of(p.truth)));
  const auto first_scan = [&](const Pose& at) {
    return score(sharp_, at, probes.front().end_points);
  };
  // Every end point of every scan, as independent as amcl's own model takes them: what the laser
  // tells apart is judged by the sensor model the filters on it use.
  const auto all_scans = [&](const Pose& at) {
    double sum = 0.0;
    for (std::size_t k = 0; k < probes.size(); ++k) {
      const std::vector<Vec2>& points = probes[k].end_points;
      if (points.empty()) continue;
      sum += score(sharp_, sdk::compose(at, relative[k]), points);
    }
    return sum;
  };
  // Coordinate ascent on `objective`, steps halving from (step_m, step_rad) to a 64th: a twin
  // a few millimetres off its best loses a few nats over 600 end points (an empty room's half
  // turn refined to an eighth, 3 mm: 7 nats, "told apart" by the refinement alone).
  const auto refine = [](Pose at, const auto& objective, double step_m, double step_rad) {
    double best = objective(at);
    const double last_m = step_m / 64.0;
    for (int round = 0; round < 100 && step_m > last_m; ++round) {
      bool improved = false;
      for (int axis = 0; axis < 3; ++axis) {
        for (const double sign : {1.0, -1.0}) {
          Pose moved = at;
          moved(axis) += sign * (axis == 2 ? step_rad : step_m);
          moved(2) = sdk::wrap(moved(2));
          const double s = objective(moved);
          if (s > best) best = s, at = moved, improved = true;
        }
      }
      if (!improved) step_m *= 0.5, step_rad *= 0.5;
    }
    return std::pair{at, best};
  };

  // The coarse search: every free pose on a grid, weighed on the first scan's smooth field: first
  // on a few of its end points, then the best share of poses on more (each heading's end points
  // turned once, not per position: the search is the judge's main cost).
  const std::vector<Vec2>& scan = probes.front().end_points;
  const std::size_t n = scan.size();
  const std::size_t sparse = std::max<std::size_t>(1, n / kFirstPassBeams);
  const std::size_t dense = std::max<std::size_t>(1, n / kCoarseBeams);
  std::vector<std::vector<Vec2>> turned(kCoarseHeadings);
  for (int h = 0; h < kCoarseHeadings; ++h) {
    const double heading = -std::numbers::pi + 2.0 * std::numbers::pi * h / kCoarseHeadings;
    const double c = std::cos(heading), s = std::sin(heading);
    for (const Vec2& p : scan) turned[h].emplace_back(c * p.x() - s * p.y(), s * p.x() + c * p.y());
  }
  const auto weigh = [&](double x, double y, int h, std::size_t stride) {
    double sum = 0.0;
    for (std::size_t i = 0; i < n; i += stride)
      sum += smooth_.log_p(x + turned[h][i].x(), y + turned[h][i].y());
    return sum;
  };
  const int cells = std::max(1, static_cast<int>(std::lround(kCoarseStepM / grid_.resolution_m)));
  struct Candidate {
    Pose pose;
    int heading;
    double score;
  };
  std::vector<Candidate> coarse;
  for (int row = cells / 2; row < grid_.height; row += cells) {
    for (int col = cells / 2; col < grid_.width; col += cells) {
      const double x = grid_.origin_m.x() + (col + 0.5) * grid_.resolution_m;
      const double y = grid_.origin_m.y() + (row + 0.5) * grid_.resolution_m;
      if (clearance_m_[static_cast<std::size_t>(row) * static_cast<std::size_t>(grid_.width) +
                       static_cast<std::size_t>(col)] < kClearanceM ||
          !free_.possible(x, y))
        continue;
      for (int h = 0; h < kCoarseHeadings; ++h) {
        const Pose pose(x, y, -std::numbers::pi + 2.0 * std::numbers::pi * h / kCoarseHeadings);
        if (!other_place(pose, first)) continue;  // the truth's own neighbourhood
        coarse.push_back({pose, h, weigh(x, y, h, sparse)});
      }
    }
  }
  const auto best_first = [](const Candidate& a, const Candidate& b) { return a.score > b.score; };
  std::stable_sort(coarse.begin(), coarse.end(), best_first);
  coarse.resize(
      std::min(coarse.size(), std::max(kSecondPassMin, coarse.size() / kSecondPassShare)));
  for (Candidate& c : coarse) c.score = weigh(c.pose(0), c.pose(1), c.heading, dense);
  // Best first; equal scores in the order drawn, so that the verdict is the same on any machine.
  std::stable_sort(coarse.begin(), coarse.end(), best_first);
  std::vector<Pose> picked;
  for (const Candidate& c : coarse) {
    if (picked.size() == kCandidates) break;
    if (std::all_of(picked.begin(), picked.end(),
                    [&](const Pose& p) { return other_place(p, c.pose); }))
      picked.push_back(c.pose);
  }

  // Each candidate fitted to the first scan (cheap), then, if it is still another place, to every
  // scan with a fine touch (a place that fits the first scan and follows the robot's true motion
  // stays aligned: the odometry a filter has is near that motion over ten seconds).
  const double kCoarseM = kCoarseStepM / 2.0, kCoarseRad = std::numbers::pi / kCoarseHeadings;
  const double kFineM = 0.025, kFineRad = deg_to_rad(0.6);
  const double truth = refine(first, all_scans, kFineM, kFineRad).second;
  double best_other = -std::numeric_limits<double>::infinity();
  for (const Pose& candidate : picked) {
    const Pose fitted = refine(candidate, first_scan, kCoarseM, kCoarseRad).first;
    if (!other_place(fitted, first)) continue;  // back to the truth
    const auto [pose, s] = refine(fitted, all_scans, kFineM, kFineRad);
    if (!other_place(pose, first) || s <= best_other) continue;
    best_other = s;
    verdict.other_m = std::hypot(pose(0) - first(0), pose(1) - first(1));
    verdict.other_deg = std::abs(rad_to_deg(sdk::wrap(pose(2) - first(2))));
  }
  verdict.log_ratio = truth - best_other;
  verdict.told_apart = verdict.log_ratio > std::log(kTellsApartRatio);
  return verdict;
}

}  // namespace locsim
