// The scorer's judgement of whether a laser tells a robot's place apart (LaserPlaceJudge), on
// grids drawn here: an empty rectangular room looks the same turned half round, a featureless
// corridor the same shifted along, and a pillar off the room's axes breaks the symmetry.
#include "sim/metrics/laser_place.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

namespace locsim {
namespace {

constexpr double kResolutionM = 0.05;

/// A grid of width x height metres with a wall round the edge and `pillars` (x0, y0, x1, y1).
OccupancyGrid room(double width_m, double height_m, const std::vector<Eigen::Vector4d>& pillars) {
  OccupancyGrid grid;
  grid.origin_m = {-0.5, -0.5};
  grid.resolution_m = kResolutionM;
  grid.width = static_cast<int>(std::lround((width_m + 1.0) / kResolutionM));
  grid.height = static_cast<int>(std::lround((height_m + 1.0) / kResolutionM));
  grid.cells.assign(static_cast<std::size_t>(grid.width) * static_cast<std::size_t>(grid.height),
                    0);
  for (int row = 0; row < grid.height; ++row) {
    for (int col = 0; col < grid.width; ++col) {
      const double x = grid.origin_m.x() + (col + 0.5) * kResolutionM;
      const double y = grid.origin_m.y() + (row + 0.5) * kResolutionM;
      bool occupied = (x < 0.0 && x > -0.1) || (x > width_m && x < width_m + 0.1) ||
                      (y < 0.0 && y > -0.1) || (y > height_m && y < height_m + 0.1);
      occupied = occupied && x > -0.1 && x < width_m + 0.1 && y > -0.1 && y < height_m + 0.1;
      for (const auto& p : pillars)
        occupied = occupied || (x > p(0) && x < p(2) && y > p(1) && y < p(3));
      if (occupied) grid.cells[static_cast<std::size_t>(row * grid.width + col)] = 100;
    }
  }
  return grid;
}

/// Ten probes a second apart, the robot driving at 0.3 m/s from `start` along its heading.
std::vector<LaserProbe> drive(const OccupancyGrid& grid, const Pose2& start) {
  std::vector<LaserProbe> probes;
  for (int k = 0; k < 10; ++k) {
    Pose2 pose = start;
    pose.x += 0.3 * k * std::cos(start.theta);
    pose.y += 0.3 * k * std::sin(start.theta);
    probes.push_back({pose, cast_rays(grid, pose, 60, 1.5 * std::numbers::pi, 8.0)});
  }
  return probes;
}

TEST(LaserPlace, AnEmptyRectangularRoomLooksTheSameTurnedHalfRound) {
  const OccupancyGrid grid = room(10.0, 6.0, {});
  const LaserPlaceVerdict verdict = LaserPlaceJudge(grid).judge(drive(grid, {2.0, 2.0, 0.3}));
  EXPECT_FALSE(verdict.told_apart) << "log ratio " << verdict.log_ratio;
  ASSERT_TRUE(verdict.other_deg.has_value());
  EXPECT_NEAR(*verdict.other_deg, 180.0, 3.0);  // the twin: (8, 4), facing the other way
  EXPECT_NEAR(*verdict.other_m, std::hypot(6.0, 2.0), 0.1);
  EXPECT_LT(std::abs(verdict.log_ratio), std::log(LaserPlaceJudge::kTellsApartRatio));
}

TEST(LaserPlace, APillarOffTheRoomsAxesTellsThePlaceApart) {
  const OccupancyGrid grid = room(10.0, 6.0, {{6.5, 3.5, 7.3, 4.3}});
  const LaserPlaceVerdict verdict = LaserPlaceJudge(grid).judge(drive(grid, {2.0, 2.0, 0.3}));
  EXPECT_TRUE(verdict.told_apart) << "log ratio " << verdict.log_ratio;
  EXPECT_GT(verdict.log_ratio, std::log(LaserPlaceJudge::kTellsApartRatio));
}

TEST(LaserPlace, AFeaturelessCorridorLooksTheSameShiftedAlong) {
  // 30 m long, 2 m wide: the 8 m laser sees two parallel walls wherever the robot is mid-way.
  const OccupancyGrid grid = room(30.0, 2.0, {});
  const LaserPlaceVerdict verdict = LaserPlaceJudge(grid).judge(drive(grid, {12.0, 1.0, 0.0}));
  EXPECT_FALSE(verdict.told_apart) << "log ratio " << verdict.log_ratio;
  ASSERT_TRUE(verdict.other_m.has_value());
  EXPECT_GE(*verdict.other_m, LaserPlaceJudge::kOtherPlaceM);
}

TEST(LaserPlace, ADoorwayInTheCorridorTellsThePlaceApart) {
  // The same corridor with a nook opening off one side at 15-16.2 m, within the laser's reach of
  // every probe: no shift along the corridor and no half turn makes the scans fit as well.
  OccupancyGrid grid = room(30.0, 2.0, {});
  for (int row = 0; row < grid.height; ++row) {
    for (int col = 0; col < grid.width; ++col) {
      const double x = grid.origin_m.x() + (col + 0.5) * kResolutionM;
      const double y = grid.origin_m.y() + (row + 0.5) * kResolutionM;
      auto& cell = grid.cells[static_cast<std::size_t>(row * grid.width + col)];
      if (y > 2.0 && y < 2.1 && x > 15.0 && x < 16.2) cell = 0;  // a doorway up
      if (y > 2.0 && y < 3.5 && x > 14.9 && x < 16.3 && !(x > 15.0 && x < 16.2)) cell = 100;
      if (y > 3.4 && y < 3.5 && x > 14.9 && x < 16.3) cell = 100;  // the nook's back wall
    }
  }
  const LaserPlaceVerdict verdict = LaserPlaceJudge(grid).judge(drive(grid, {12.0, 1.0, 0.0}));
  EXPECT_TRUE(verdict.told_apart) << "log ratio " << verdict.log_ratio << ", other at "
                                  << verdict.other_m.value_or(-1) << " m, "
                                  << verdict.other_deg.value_or(-1) << " deg";
}

// The SDK's place search (what amcl's recovery and this judge search with): the pillar room's true
// pose comes first among the places that fit a scan, refined to within centimetres; in the empty
// room the truth and its half-turned twin come first, alike.
std::pair<std::vector<double>, std::vector<double>> end_points(const OccupancyGrid& grid,
                                                               const Pose2& pose) {
  std::vector<double> x, y;
  for (const Vec2& p : cast_rays(grid, pose, 60, 1.5 * std::numbers::pi, 8.0))
    x.push_back(p.x()), y.push_back(p.y());
  return {x, y};
}

locsim_occupancy_grid view(const OccupancyGrid& grid) {
  return {grid.origin_m.x(), grid.origin_m.y(), grid.resolution_m,
          grid.width,        grid.height,       grid.cells.data()};
}

TEST(PlaceSearch, FindsTheOnePlaceThatFitsAScanAndRefinesIt) {
  const OccupancyGrid grid = room(10.0, 6.0, {{6.5, 3.5, 7.3, 4.3}});
  const sdk::PlaceSearch search(view(grid));
  const Pose2 truth{2.13, 1.87, 0.41};  // off the lattice, between its headings
  // Not a structured binding: lambdas below use the vectors (clang before C++20's P1091).
  const auto points = end_points(grid, truth);
  const std::vector<double>& x = points.first;
  const std::vector<double>& y = points.second;
  const std::vector<sdk::ScoredPose> places = search.best(x, y, 4);
  ASSERT_EQ(places.size(), 4u);
  for (std::size_t k = 1; k < places.size(); ++k) {
    EXPECT_GE(places[k - 1].log_p, places[k].log_p);
    EXPECT_TRUE(search.distinct(places[0].pose, places[k].pose));
  }
  const sdk::Pose at(truth.x, truth.y, truth.theta);
  EXPECT_LE(std::hypot(places[0].pose(0) - truth.x, places[0].pose(1) - truth.y), 0.25);
  EXPECT_LE(std::abs(sdk::wrap(places[0].pose(2) - truth.theta)), deg_to_rad(7.5));
  const sdk::LikelihoodField field(view(grid), sdk::LikelihoodFieldDef{});
  const auto fit = [&](const sdk::Pose& pose) {
    double sum = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i)
      sum += field.log_p(pose(0) + std::cos(pose(2)) * x[i] - std::sin(pose(2)) * y[i],
                         pose(1) + std::sin(pose(2)) * x[i] + std::cos(pose(2)) * y[i]);
    return sum;
  };
  const sdk::Pose refined =
      sdk::ascend(places[0].pose, fit, search.half_step_m(), search.half_step_rad()).first;
  EXPECT_LE(std::hypot(refined(0) - truth.x, refined(1) - truth.y), 0.05);
  EXPECT_LE(std::abs(sdk::wrap(refined(2) - truth.theta)), deg_to_rad(1.5));
  // The next place (the half-turned twin, the pillar out of place) refined as well fits worse by
  // more than the judge's ln 20.
  const double twin =
      sdk::ascend(places[1].pose, fit, search.half_step_m(), search.half_step_rad()).second;
  EXPECT_GT(fit(refined), twin + std::log(LaserPlaceJudge::kTellsApartRatio))
      << places[1].pose.transpose();
}

TEST(PlaceSearch, AnEmptyRoomGivesTheTruthAndItsHalfTurnedTwin) {
  const OccupancyGrid grid = room(10.0, 6.0, {});
  const sdk::PlaceSearch search(view(grid));
  const auto points = end_points(grid, {2.0, 2.0, 0.3});
  const std::vector<double>& x = points.first;
  const std::vector<double>& y = points.second;
  const std::vector<sdk::ScoredPose> places = search.best(x, y, 2);
  ASSERT_EQ(places.size(), 2u);
  const sdk::Pose twin(8.0, 4.0, sdk::wrap(0.3 + std::numbers::pi));
  const auto near = [](const sdk::Pose& a, const sdk::Pose& b) {
    return std::hypot(a(0) - b(0), a(1) - b(1)) <= 0.25 && std::abs(sdk::wrap(a(2) - b(2))) <= 0.14;
  };
  const sdk::Pose truth(2.0, 2.0, 0.3);
  EXPECT_TRUE((near(places[0].pose, truth) && near(places[1].pose, twin)) ||
              (near(places[0].pose, twin) && near(places[1].pose, truth)))
      << places[0].pose.transpose() << " / " << places[1].pose.transpose();
  EXPECT_NEAR(places[0].log_p, places[1].log_p, 3.0);
  // Skipping the truth's neighbourhood leaves the twin first.
  const std::vector<sdk::ScoredPose> others =
      search.best(x, y, 1, [&](const sdk::Pose& p) { return !search.distinct(p, truth); });
  ASSERT_EQ(others.size(), 1u);
  EXPECT_TRUE(near(others[0].pose, twin)) << others[0].pose.transpose();
}

TEST(PlaceSearch, PicksWhatSortingEveryLatticePoseWouldPick) {
  // The search selects its second pass as it weighs (a buffer cut back to the best half when
  // full) rather than sorting every pose: the same poses, scores and order as the plain
  // algorithm written out here, ties included (an empty room's symmetric twins score alike).
  const OccupancyGrid grid = room(10.0, 6.0, {});
  sdk::PlaceSearchDef def;
  def.second_pass_min = 100;  // so that the buffer fills and is cut many times
  const sdk::PlaceSearch search(view(grid), def);
  const auto points = end_points(grid, {2.0, 2.0, 0.3});
  const std::vector<double>& x = points.first;
  const std::vector<double>& y = points.second;
  sdk::LikelihoodFieldDef field_def;
  field_def.sigma_hit_m = def.sigma_hit_m;
  const sdk::LikelihoodField smooth(view(grid), field_def);
  const std::size_t n = x.size(), sparse = n / def.first_pass_points,
                    dense = n / def.second_pass_points;
  const auto weigh = [&](const sdk::Pose& pose, std::size_t stride) {
    const double c = std::cos(pose(2)), s = std::sin(pose(2));
    double sum = 0.0;
    for (std::size_t i = 0; i < n; i += stride)
      sum += smooth.log_p(pose(0) + (c * x[i] - s * y[i]), pose(1) + (s * x[i] + c * y[i]));
    return sum;
  };
  for (const bool skip_truth : {false, true}) {
    const sdk::Pose truth(2.0, 2.0, 0.3);
    const auto skip = [&](const sdk::Pose& p) { return skip_truth && !search.distinct(p, truth); };
    std::vector<sdk::ScoredPose> all;
    for (std::size_t i = 0; i < search.positions(); ++i) {
      for (int h = 0; h < def.headings; ++h) {
        const sdk::Pose pose(search.position(i).first, search.position(i).second,
                             search.heading(static_cast<std::size_t>(h)));
        if (!skip(pose)) all.push_back({pose, weigh(pose, sparse)});
      }
    }
    const auto best_first = [](const sdk::ScoredPose& a, const sdk::ScoredPose& b) {
      return a.log_p > b.log_p;
    };
    std::stable_sort(all.begin(), all.end(), best_first);
    all.resize(
        std::min(all.size(), std::max(def.second_pass_min, all.size() / def.second_pass_share)));
    for (sdk::ScoredPose& p : all) p.log_p = weigh(p.pose, dense);
    std::stable_sort(all.begin(), all.end(), best_first);
    std::vector<sdk::ScoredPose> expected;
    for (const sdk::ScoredPose& p : all) {
      if (expected.size() == 12) break;
      if (std::all_of(expected.begin(), expected.end(),
                      [&](const sdk::ScoredPose& e) { return search.distinct(e.pose, p.pose); }))
        expected.push_back(p);
    }
    const std::vector<sdk::ScoredPose> picked = search.best(x, y, 12, skip);
    ASSERT_EQ(picked.size(), expected.size());
    for (std::size_t k = 0; k < picked.size(); ++k) {
      EXPECT_EQ(picked[k].pose, expected[k].pose) << k << (skip_truth ? ", truth skipped" : "");
      EXPECT_EQ(picked[k].log_p, expected[k].log_p) << k;
    }
  }
}

}  // namespace
}  // namespace locsim
