// Global place search on the laser, for plugin authors: the poses of the whole map that explain a
// scan best, found by brute force on a lattice (every clear position, every heading) against a
// smoothed likelihood field, then refined by coordinate ascent on the filter's own field. What
// correlative scan matching does for relocalization (Olson, "Real-time correlative scan matching",
// 2009), without its branch and bound: the maps locsim's worlds have make the lattice cheap enough
// (a 20 x 12 m room: 180 000 poses weighed on ten end points, then the best 2 000 on thirty).
//
// Used by amcl's recovery (a kidnapped filter injects guesses about these places instead of
// uniformly) and by the scorer's judgement of whether a laser tells a place apart (one search,
// one set of constants).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <numbers>
#include <span>
#include <utility>
#include <vector>

#include "locsim/laser.hpp"
#include "locsim/localizer.h"
#include "locsim/models.hpp"
#include "locsim/particle_filter.hpp"

namespace locsim::sdk {

/// Parameters of the lattice search; the defaults are the scorer's (docs/experiments.md,
/// "recoverable").
struct PlaceSearchDef {
  double step_m = 0.25;                 // lattice spacing of candidate positions [m]
  int headings = 48;                    // candidate headings per position (7.5 deg apart) [-]
  double sigma_hit_m = 0.5;             // the smoothed field's spread: a pose a lattice step off
                                        // its best still scores near it [m]
  double clearance_m = 0.1;             // a robot's centre is no nearer an obstacle [m]
  std::size_t first_pass_points = 10;   // end points every lattice pose is weighed on first [-]
  std::size_t second_pass_share = 20;   // then the best 1/share of the poses ... [-]
  std::size_t second_pass_min = 2000;   // ... (at least this many) ... [-]
  std::size_t second_pass_points = 30;  // ... on this many end points [-]
  double distinct_m = 1.0;              // places nearer than this ... [m]
  double distinct_deg = 30.0;           // ... and turned less than this are one place [deg]
};

/// A pose and the log likelihood it scored.
struct ScoredPose {
  Pose pose;
  double log_p = 0.0;
};

/// Coordinate ascent of `objective(Pose) -> double` from `at`: steps of step_m in x and y and
/// step_rad in heading, each axis both ways, halved when no step improves, down to a 64th. The
/// best pose and its objective.
template <class Objective>
std::pair<Pose, double> ascend(Pose at, const Objective& objective, double step_m,
                               double step_rad) {
  double best = objective(at);
  const double last_m = step_m / 64.0;
  for (int round = 0; round < 100 && step_m > last_m; ++round) {
    bool improved = false;
    for (int axis = 0; axis < 3; ++axis) {
      for (const double sign : {1.0, -1.0}) {
        Pose moved = at;
        moved(axis) += sign * (axis == 2 ? step_rad : step_m);
        moved(2) = wrap(moved(2));
        const double s = objective(moved);
        if (s > best) best = s, at = moved, improved = true;
      }
    }
    if (!improved) step_m *= 0.5, step_rad *= 0.5;
  }
  return {at, best};
}

class PlaceSearch {
 public:
  PlaceSearch() = default;
  /// Over the host's occupancy grid: candidate positions on the lattice where the robot can be
  /// (FreeSpace::possible) and clear of obstacles.
  explicit PlaceSearch(const locsim_occupancy_grid& grid, const PlaceSearchDef& def = {})
      : def_(def), smooth_(grid, [&] {
          LikelihoodFieldDef field;  // AMCL's z_hit, z_rand, max_dist, range_max
          field.sigma_hit_m = def.sigma_hit_m;
          return field;
        }()) {
    const FreeSpace free(grid);
    const std::vector<double> d2 =
        squared_distance_transform(grid.width, grid.height, [&](int col, int row) {
          return grid.cells[static_cast<std::size_t>(row) * static_cast<std::size_t>(grid.width) +
                            static_cast<std::size_t>(col)] != 0;
        });
    const int cells = std::max(1, static_cast<int>(std::lround(def.step_m / grid.resolution_m)));
    for (int row = cells / 2; row < grid.height; row += cells) {
      for (int col = cells / 2; col < grid.width; col += cells) {
        const double x = grid.origin_x + (col + 0.5) * grid.resolution_m;
        const double y = grid.origin_y + (row + 0.5) * grid.resolution_m;
        const double clearance =
            std::sqrt(d2[static_cast<std::size_t>(row) * static_cast<std::size_t>(grid.width) +
                         static_cast<std::size_t>(col)]) *
            grid.resolution_m;
        if (clearance < def.clearance_m || !free.possible(x, y)) continue;
        positions_x_.push_back(x);
        positions_y_.push_back(y);
      }
    }
  }

  const PlaceSearchDef& def() const { return def_; }
  /// Candidate positions of the lattice.
  std::size_t positions() const { return positions_x_.size(); }
  /// Candidate position i (x, y) [m] and candidate heading h [rad] of the lattice, in the order
  /// the search weighs them (position after position, each at every heading).
  std::pair<double, double> position(std::size_t i) const {
    return {positions_x_.at(i), positions_y_.at(i)};
  }
  double heading(std::size_t h) const { return heading_of(h); }

  /// Whether two poses are different places (distinct_m apart, or distinct_deg turned).
  bool distinct(const Pose& a, const Pose& b) const {
    return apart(a(0) - b(0), a(1) - b(1), def_.distinct_m) ||
           std::abs(wrap(a(2) - b(2))) >= def_.distinct_deg * std::numbers::pi / 180.0;
  }

  /// The `count` best distinct lattice poses for a scan's end points (x[i], y[i] in the robot
  /// frame), best first, on the smoothed field; lattice poses for which skip(pose) is true are
  /// left out. Equal scores keep the lattice's order, so the result is the same on any machine.
  template <class Skip>
  std::vector<ScoredPose> best(const std::vector<double>& x, const std::vector<double>& y,
                               std::size_t count, const Skip& skip) const {
    const std::size_t n = std::min(x.size(), y.size());
    if (n == 0 || count == 0) return {};
    const std::size_t sparse = std::max<std::size_t>(1, n / def_.first_pass_points);
    const std::size_t dense = std::max<std::size_t>(1, n / def_.second_pass_points);
    // Each heading's end points turned once, not per position: the search's main cost is the
    // lookups.
    const auto headings = static_cast<std::size_t>(def_.headings);
    std::vector<double> tx(headings * n), ty(headings * n);
    for (std::size_t h = 0; h < headings; ++h) {
      const double heading = heading_of(h);
      const double c = std::cos(heading), s = std::sin(heading);
      for (std::size_t i = 0; i < n; ++i)
        tx[h * n + i] = c * x[i] - s * y[i], ty[h * n + i] = s * x[i] + c * y[i];
    }
    const std::size_t positions = positions_x_.size();
    // The turned end points of heading h.
    const auto turned_x = [&](std::size_t h) { return std::span(tx).subspan(h * n, n); };
    const auto turned_y = [&](std::size_t h) { return std::span(ty).subspan(h * n, n); };
    // The coarse pass keeps a score and a lattice index (position * headings + heading) per pose,
    // 16 bytes, not the pose: a large map has a few hundred thousand. The index grows in the
    // lattice's order, so ordering by (score descending, index ascending) is the stable order.
    struct Candidate {
      double score;
      std::size_t index;
    };
    const auto better = [](const Candidate& a, const Candidate& b) {
      return a.score > b.score || (a.score == b.score && a.index < b.index);
    };
    const auto pose_of = [&](std::size_t index) {
      return Pose(positions_x_[index / headings], positions_y_[index / headings],
                  heading_of(index % headings));
    };
    // Only the best share of the lattice goes on to the second pass. They are selected as the
    // poses are weighed, in a buffer of twice the most that can be kept (the share of the whole
    // lattice), cut back to the best half whenever it fills: the same poses as a sort of all of
    // them cut to the share of those weighed (the selection was most of the search's time, and
    // the full list, megabytes, was paged in afresh at every search).
    const std::size_t most_kept = std::max(
        {std::size_t{1}, def_.second_pass_min, positions * headings / def_.second_pass_share});
    const auto keep_best = [&](std::vector<Candidate>& list, std::size_t kept) {
      if (list.size() <= kept) return;
      std::nth_element(list.begin(), list.begin() + static_cast<std::ptrdiff_t>(kept), list.end(),
                       better);
      list.resize(kept);
    };
    std::vector<Candidate> coarse;
    coarse.reserve(std::min(2 * most_kept, positions * headings));
    std::size_t weighed = 0;
    // Positions a block at a time: each heading's end points tried at all of the block's positions
    // in one pass (four at a time with AVX2), then the poses taken in the lattice's order.
    constexpr std::size_t kBlock = 64;
    std::vector<double> scores(kBlock * headings);
    for (std::size_t start = 0; start < positions; start += kBlock) {
      const std::size_t m = std::min(kBlock, positions - start);
      const auto block_x = std::span(positions_x_).subspan(start, m);
      const auto block_y = std::span(positions_y_).subspan(start, m);
      for (std::size_t h = 0; h < headings; ++h) {
        smooth_.sum_log_p_shifted(block_x, block_y, turned_x(h), turned_y(h), sparse,
                                  std::span(scores).subspan(h * kBlock, m));
      }
      for (std::size_t k = 0; k < m; ++k) {
        for (std::size_t h = 0; h < headings; ++h) {
          if (skip(Pose(block_x[k], block_y[k], heading_of(h)))) continue;
          coarse.push_back({scores[h * kBlock + k], (start + k) * headings + h});
          ++weighed;
          if (coarse.size() == 2 * most_kept) keep_best(coarse, most_kept);
        }
      }
    }
    keep_best(coarse, std::max(def_.second_pass_min, weighed / def_.second_pass_share));
    std::sort(coarse.begin(), coarse.end(), better);
    // Rescored on more end points, heading by heading (a heading's positions in one pass, four
    // at a time); equal new scores keep the coarse order.
    std::vector<std::size_t> first_of_heading(headings + 1, 0), by_heading(coarse.size());
    for (const Candidate& c : coarse) ++first_of_heading[c.index % headings + 1];
    for (std::size_t h = 0; h < headings; ++h) first_of_heading[h + 1] += first_of_heading[h];
    {
      std::vector<std::size_t> next(first_of_heading.begin(), first_of_heading.end() - 1);
      for (std::size_t k = 0; k < coarse.size(); ++k)
        by_heading[next[coarse[k].index % headings]++] = k;
    }
    std::vector<double> heading_x, heading_y, heading_scores;
    for (std::size_t h = 0; h < headings; ++h) {
      heading_x.clear(), heading_y.clear();
      for (std::size_t j = first_of_heading[h]; j < first_of_heading[h + 1]; ++j) {
        const std::size_t p = coarse[by_heading[j]].index / headings;
        heading_x.push_back(positions_x_[p]), heading_y.push_back(positions_y_[p]);
      }
      heading_scores.resize(heading_x.size());
      smooth_.sum_log_p_shifted(heading_x, heading_y, turned_x(h), turned_y(h), dense,
                                heading_scores);
      for (std::size_t j = first_of_heading[h]; j < first_of_heading[h + 1]; ++j)
        coarse[by_heading[j]].score = heading_scores[j - first_of_heading[h]];
    }
    std::stable_sort(coarse.begin(), coarse.end(),
                     [](const Candidate& a, const Candidate& b) { return a.score > b.score; });
    std::vector<ScoredPose> picked;
    for (const Candidate& c : coarse) {
      if (picked.size() == count) break;
      const Pose pose = pose_of(c.index);
      if (std::all_of(picked.begin(), picked.end(),
                      [&](const ScoredPose& p) { return distinct(p.pose, pose); }))
        picked.push_back({pose, c.score});
    }
    return picked;
  }
  std::vector<ScoredPose> best(const std::vector<double>& x, const std::vector<double>& y,
                               std::size_t count) const {
    return best(x, y, count, [](const Pose&) { return false; });
  }

  /// Half the lattice's steps: the start of a refinement of one of its poses.
  double half_step_m() const { return def_.step_m / 2.0; }
  double half_step_rad() const { return std::numbers::pi / def_.headings; }

 private:
  double heading_of(std::size_t h) const {
    return -std::numbers::pi + 2.0 * std::numbers::pi * static_cast<double>(h) / def_.headings;
  }

  PlaceSearchDef def_;
  /// hypot(dx, dy) >= d, hypot's own answer, from the squared length where that is far from
  /// d^2 (hypot is within an ulp of the exact length; a search asks this of every lattice pose).
  static bool apart(double dx, double dy, double d) {
    const double squared = dx * dx + dy * dy, d2 = d * d;
    if (d > 0.0 && d2 >= std::numeric_limits<double>::min() &&
        d2 <= std::numeric_limits<double>::max()) {
      if (squared > d2 * (1.0 + 1e-9)) return true;
      if (squared < d2 * (1.0 - 1e-9)) return false;
    }
    return std::hypot(dx, dy) >= d;  // near d; NaN; d 0, negative or beyond squaring
  }

  LikelihoodField smooth_;
  std::vector<double> positions_x_, positions_y_;
};

}  // namespace locsim::sdk
