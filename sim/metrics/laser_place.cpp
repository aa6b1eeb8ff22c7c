#include "sim/metrics/laser_place.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <locsim/models.hpp>
#include <locsim/particle_filter.hpp>
#include <locsim/place_search.hpp>
#include <numbers>

namespace locsim {

namespace {

using sdk::Pose;

constexpr std::size_t kCandidates = 16;  // the best distinct coarse poses refined

locsim_occupancy_grid view(const OccupancyGrid& grid) {
  return {grid.origin_m.x(), grid.origin_m.y(), grid.resolution_m,
          grid.width,        grid.height,       grid.cells.data()};
}

sdk::PlaceSearchDef search_def() {
  sdk::PlaceSearchDef def;  // the SDK's defaults are the judge's
  def.distinct_m = LaserPlaceJudge::kOtherPlaceM;
  def.distinct_deg = LaserPlaceJudge::kOtherPlaceDeg;
  return def;
}

Pose pose_of(const Pose2& p) {
  return {p.x, p.y, p.theta};
}

/// A scan's end points in the robot frame, one array per coordinate (the field's batch form).
struct Scan {
  std::vector<double> x, y;
  explicit Scan(const std::vector<Vec2>& points) {
    for (const Vec2& p : points) x.push_back(p.x()), y.push_back(p.y());
  }
};

/// Sum of the log likelihoods of every end point seen from `pose`, in point order (`log_p`:
/// storage reused between calls).
double score(const sdk::LikelihoodField& f, const Pose& pose, const Scan& scan,
             std::vector<float>& log_p) {
  log_p.resize(scan.x.size());
  f.log_p_at(pose(0), pose(1), std::cos(pose(2)), std::sin(pose(2)), scan.x, scan.y, log_p);
  double sum = 0.0;
  for (const float v : log_p) sum += v;
  return sum;
}

}  // namespace

LaserPlaceJudge::LaserPlaceJudge(const OccupancyGrid& grid)
    : sharp_(view(grid), sdk::LikelihoodFieldDef{}), search_(view(grid), search_def()) {}

LaserPlaceVerdict LaserPlaceJudge::judge(const std::vector<LaserProbe>& probes) const {
  LaserPlaceVerdict verdict;
  if (probes.empty()) return verdict;
  const Pose first = pose_of(probes.front().truth);
  const auto other_place = [&](const Pose& a, const Pose& b) { return search_.distinct(a, b); };
  // Each probe's pose relative to the first: a place that explains the first scan must explain
  // the later ones too, moved along the robot's true motion (the filter has its odometry).
  std::vector<Pose> relative;
  for (const LaserProbe& p : probes) relative.push_back(sdk::between(first, pose_of(p.truth)));
  std::vector<Scan> scans;
  for (const LaserProbe& p : probes) scans.emplace_back(p.end_points);
  std::vector<float> log_p;
  const auto first_scan = [&](const Pose& at) { return score(sharp_, at, scans.front(), log_p); };
  // Every end point of every scan, as independent as amcl's own model takes them: what the laser
  // tells apart is judged by the sensor model the filters on it use.
  const auto all_scans = [&](const Pose& at) {
    double sum = 0.0;
    for (std::size_t k = 0; k < probes.size(); ++k) {
      if (scans[k].x.empty()) continue;
      sum += score(sharp_, sdk::compose(at, relative[k]), scans[k], log_p);
    }
    return sum;
  };

  // The coarse search over the whole map on the first scan, the truth's own neighbourhood left
  // out; each candidate is then fitted to the first scan (cheap) and, if it is still another
  // place, to every scan with a fine touch (a place that fits the first scan and follows the
  // robot's true motion stays aligned: the odometry a filter has is near that motion over ten
  // seconds). The refinement ends at a 64th of its first step: a twin a few millimetres off its
  // best loses a few nats over 600 end points (an empty room's half turn refined to an eighth,
  // 3 mm: 7 nats, "told apart" by the refinement alone).
  const std::vector<sdk::ScoredPose> picked =
      search_.best(scans.front().x, scans.front().y, kCandidates,
                   [&](const Pose& pose) { return !other_place(pose, first); });
  const double kFineM = 0.025, kFineRad = deg_to_rad(0.6);
  const double truth = sdk::ascend(first, all_scans, kFineM, kFineRad).second;
  double best_other = -std::numeric_limits<double>::infinity();
  for (const sdk::ScoredPose& candidate : picked) {
    const Pose fitted =
        sdk::ascend(candidate.pose, first_scan, search_.half_step_m(), search_.half_step_rad())
            .first;
    if (!other_place(fitted, first)) continue;  // back to the truth
    const auto [pose, s] = sdk::ascend(fitted, all_scans, kFineM, kFineRad);
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
