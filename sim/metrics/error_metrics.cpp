#include "sim/metrics/error_metrics.hpp"

#include <algorithm>
#include <cmath>

namespace locsim {

bool ErrorAccumulator::within(const ErrorSample& e) const {
  return std::hypot(e.dx_m, e.dy_m) <= criterion_.position_m &&
         std::abs(e.dtheta_rad) <= criterion_.heading_rad;
}

void ErrorAccumulator::add(const ErrorSample& e) {
  const double position = std::hypot(e.dx_m, e.dy_m);
  const double heading = std::abs(e.dtheta_rad);
  if (samples_ == 0) {
    first_ = e;
  } else {
    // Each sample stands for the interval to the next one (the last for the typical interval);
    // gaps wider than twice the typical interval (a robot carried) count only one interval.
    if (samples_ == 1) typical_interval_s_ = e.t_s - first_.t_s;
    if (!within(last_)) {
      const double interval = e.t_s - last_.t_s;
      time_lost_s_ += interval > 2.0 * typical_interval_s_ ? typical_interval_s_ : interval;
    }
  }
  ++samples_;
  sum_sq_ += position * position;
  sum_ += position;
  sum_sq_x_ += e.dx_m * e.dx_m;
  sum_sq_y_ += e.dy_m * e.dy_m;
  sum_sq_h_ += heading * heading;
  sum_h_ += heading;
  position_max_m_ = std::max(position_max_m_, position);
  heading_max_rad_ = std::max(heading_max_rad_, heading);
  if (!converged_at_s_) {
    const bool in = position <= criterion_.position_m && heading <= criterion_.heading_rad;
    run_ = in ? run_ + 1 : 0;
    if (run_ == 1) run_start_ = e;
    if (in && run_ >= criterion_.hold_samples) {
      converged_at_s_ = run_start_.t_s;
      converged_at_steps_ = run_start_.steps - first_.steps;
    }
  }
  last_ = e;
}

ErrorSummary ErrorAccumulator::summary() const {
  ErrorSummary s;
  s.samples = samples_;
  if (samples_ == 0) return s;
  s.position_max_m = position_max_m_;
  s.heading_max_rad = heading_max_rad_;
  s.converged_at_s = converged_at_s_;
  s.converged_at_steps = converged_at_steps_;
  s.time_lost_s = time_lost_s_;
  if (!within(last_)) {
    s.time_lost_s += samples_ > 1 ? typical_interval_s_ : 0.0;  // the last stands for a typical one
  }
  const double n = static_cast<double>(samples_);
  s.position_rms_m = std::sqrt(sum_sq_ / n);
  s.position_mean_m = sum_ / n;
  s.x_rms_m = std::sqrt(sum_sq_x_ / n);
  s.y_rms_m = std::sqrt(sum_sq_y_ / n);
  s.heading_rms_rad = std::sqrt(sum_sq_h_ / n);
  s.heading_mean_rad = sum_h_ / n;
  return s;
}

ErrorSummary summarize_errors(const std::vector<ErrorSample>& samples,
                              const ConvergenceCriterion& criterion) {
  ErrorAccumulator accumulator(criterion);
  for (const ErrorSample& e : samples) accumulator.add(e);
  return accumulator.summary();
}

void CostAccumulator::add(double seconds) {
  ++calls_;
  sum_s_ += seconds;
  max_s_ = std::max(max_s_, seconds);
  const double bin = seconds > kLowestS ? std::log(seconds / kLowestS) / std::log(kBinRatio) : 0.0;
  ++bins_[std::min(kBins - 1, static_cast<std::size_t>(bin))];
}

CostSummary CostAccumulator::summary() const {
  CostSummary c;
  c.calls = calls_;
  if (calls_ == 0) return c;
  c.mean_us = 1e6 * sum_s_ / static_cast<double>(calls_);
  c.max_us = 1e6 * max_s_;
  // The bin holding the ceil(0.99 n)-th smallest duration; its geometric middle, capped by the
  // maximum (so that a run of one call reports that call).
  const auto rank = static_cast<std::size_t>(std::ceil(0.99 * static_cast<double>(calls_)));
  std::size_t seen = 0;
  for (std::size_t i = 0; i < kBins; ++i) {
    seen += bins_[i];
    if (seen >= rank) {
      const double middle = kLowestS * std::pow(kBinRatio, static_cast<double>(i) + 0.5);
      c.p99_us = 1e6 * std::min(middle, max_s_);
      break;
    }
  }
  return c;
}

CostSummary summarize_costs(const std::vector<float>& seconds) {
  CostAccumulator accumulator;
  for (const float s : seconds) accumulator.add(s);
  return accumulator.summary();
}

}  // namespace locsim
