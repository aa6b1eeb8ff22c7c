#include "sim/metrics/error_metrics.hpp"

#include <algorithm>
#include <cmath>

namespace locsim {

ErrorSummary summarize_errors(const std::vector<ErrorSample>& samples,
                              const ConvergenceCriterion& criterion) {
  ErrorSummary s;
  s.samples = samples.size();
  if (samples.empty()) return s;
  double sum_sq = 0, sum = 0, sum_sq_x = 0, sum_sq_y = 0, sum_sq_h = 0, sum_h = 0;
  int run = 0;
  for (const ErrorSample& e : samples) {
    const double position = std::hypot(e.dx_m, e.dy_m);
    const double heading = std::abs(e.dtheta_rad);
    sum_sq += position * position;
    sum += position;
    sum_sq_x += e.dx_m * e.dx_m;
    sum_sq_y += e.dy_m * e.dy_m;
    sum_sq_h += heading * heading;
    sum_h += heading;
    s.position_max_m = std::max(s.position_max_m, position);
    s.heading_max_rad = std::max(s.heading_max_rad, heading);
    if (!s.converged_at_s) {
      run = (position <= criterion.position_m && heading <= criterion.heading_rad) ? run + 1 : 0;
      if (run >= criterion.hold_samples) {
        const ErrorSample& first = samples[&e - samples.data() - (criterion.hold_samples - 1)];
        s.converged_at_s = first.t_s;
        s.converged_at_steps = first.steps - samples.front().steps;
      }
    }
  }
  // Each sample stands for the interval to the next one (the last for the typical interval);
  // gaps wider than twice the typical interval (a robot carried) count only one interval.
  const double typical = samples.size() > 1 ? samples[1].t_s - samples[0].t_s : 0.0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const ErrorSample& e = samples[i];
    const bool within = std::hypot(e.dx_m, e.dy_m) <= criterion.position_m &&
                        std::abs(e.dtheta_rad) <= criterion.heading_rad;
    if (within) continue;
    const double interval = i + 1 < samples.size() ? samples[i + 1].t_s - e.t_s : typical;
    s.time_lost_s += interval > 2.0 * typical ? typical : interval;
  }
  const double n = static_cast<double>(samples.size());
  s.position_rms_m = std::sqrt(sum_sq / n);
  s.position_mean_m = sum / n;
  s.x_rms_m = std::sqrt(sum_sq_x / n);
  s.y_rms_m = std::sqrt(sum_sq_y / n);
  s.heading_rms_rad = std::sqrt(sum_sq_h / n);
  s.heading_mean_rad = sum_h / n;
  return s;
}

CostSummary summarize_costs(std::vector<float> seconds) {
  CostSummary c;
  c.calls = seconds.size();
  if (seconds.empty()) return c;
  double sum = 0;
  for (const float s : seconds) sum += s;
  c.mean_us = 1e6 * sum / static_cast<double>(seconds.size());
  const std::size_t k =
      std::min(seconds.size() - 1,
               static_cast<std::size_t>(std::ceil(0.99 * static_cast<double>(seconds.size()))) - 1);
  std::nth_element(seconds.begin(), seconds.begin() + static_cast<long>(k), seconds.end());
  c.p99_us = 1e6 * seconds[k];
  c.max_us = 1e6 * *std::max_element(seconds.begin(), seconds.end());
  return c;
}

}  // namespace locsim
