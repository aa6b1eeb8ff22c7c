#include "sim/metrics/landmark_metrics.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <tuple>

namespace locsim {

std::vector<LandmarkMatch> match_landmarks(const std::vector<LandmarkPoint>& mapped,
                                           const std::vector<LandmarkPoint>& truth, double gate_m) {
  std::vector<LandmarkMatch> candidates;
  for (std::size_t m = 0; m < mapped.size(); ++m) {
    for (std::size_t t = 0; t < truth.size(); ++t) {
      const double d = std::hypot(mapped[m].x_m - truth[t].x_m, mapped[m].y_m - truth[t].y_m);
      if (d <= gate_m) candidates.push_back({m, t, d});
    }
  }
  std::sort(candidates.begin(), candidates.end(),
            [](const LandmarkMatch& a, const LandmarkMatch& b) {
              return std::tie(a.distance_m, a.mapped, a.truth) <
                     std::tie(b.distance_m, b.mapped, b.truth);
            });
  std::vector<bool> mapped_taken(mapped.size(), false), truth_taken(truth.size(), false);
  std::vector<LandmarkMatch> matches;
  for (const LandmarkMatch& c : candidates) {
    if (mapped_taken[c.mapped] || truth_taken[c.truth]) continue;
    mapped_taken[c.mapped] = truth_taken[c.truth] = true;
    matches.push_back(c);
  }
  return matches;
}

LandmarkMapSummary summarize_landmark_map(const std::vector<LandmarkPoint>& mapped,
                                          const std::vector<LandmarkPoint>& truth,
                                          const std::set<int>& observed_ids, double gate_m) {
  LandmarkMapSummary s;
  s.matches = match_landmarks(mapped, truth, gate_m);
  s.mapped = mapped.size();
  s.matched = s.matches.size();
  s.spurious = s.mapped - s.matched;
  std::vector<bool> truth_matched(truth.size(), false);
  for (const LandmarkMatch& m : s.matches) truth_matched[m.truth] = true;
  for (std::size_t t = 0; t < truth.size(); ++t) {
    if (observed_ids.count(truth[t].id) == 0) continue;
    ++s.observed;
    if (!truth_matched[t]) ++s.missed;
  }
  if (!s.matches.empty()) {
    double sum = 0.0, sum_sq = 0.0, max = 0.0;
    for (const LandmarkMatch& m : s.matches) {
      sum += m.distance_m;
      sum_sq += m.distance_m * m.distance_m;
      max = std::max(max, m.distance_m);
    }
    const auto n = static_cast<double>(s.matches.size());
    s.error_rms_m = std::sqrt(sum_sq / n);
    s.error_mean_m = sum / n;
    s.error_max_m = max;
    s.aligned_within = static_cast<std::size_t>(std::count_if(
        s.matches.begin(), s.matches.end(),
        [](const LandmarkMatch& m) { return m.distance_m <= kLandmarkAlignedGateM; }));
  }
  if (s.matches.size() >= 3) {
    Eigen::MatrixXd from(2, s.matches.size()), to(2, s.matches.size());
    for (std::size_t k = 0; k < s.matches.size(); ++k) {
      from.col(static_cast<Eigen::Index>(k)) << mapped[s.matches[k].mapped].x_m,
          mapped[s.matches[k].mapped].y_m;
      to.col(static_cast<Eigen::Index>(k)) << truth[s.matches[k].truth].x_m,
          truth[s.matches[k].truth].y_m;
    }
    const Eigen::MatrixXd motion = Eigen::umeyama(from, to, false);  // 3 x 3, homogeneous
    const Eigen::MatrixXd moved =
        (motion.topLeftCorner<2, 2>() * from).colwise() + motion.topRightCorner<2, 1>();
    const Eigen::VectorXd distance = (moved - to).colwise().norm();
    const auto n = static_cast<double>(distance.size());
    s.aligned_rms_m = std::sqrt(distance.squaredNorm() / n);
    s.aligned_mean_m = distance.sum() / n;
    s.aligned_max_m = distance.maxCoeff();
    s.aligned_within =
        static_cast<std::size_t>((distance.array() <= kLandmarkAlignedGateM).count());
  }
  return s;
}

}  // namespace locsim
