// The scorer's judgement of whether a laser tells a robot's place apart (LaserPlaceJudge), on
// grids drawn here: an empty rectangular room looks the same turned half round, a featureless
// corridor the same shifted along, and a pillar off the room's axes breaks the symmetry.
#include "sim/metrics/laser_place.hpp"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace locsim
