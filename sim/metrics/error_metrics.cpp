#include "sim/metrics/error_metrics.hpp"

#include <Eigen/Cholesky>
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
  std::optional<bool> inside;  // the truth inside the 95 % ellipse; none: no covariance to judge
  if (e.covariance) {
    const Eigen::Matrix3d p =
        Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(e.covariance->data());
    // Cholesky succeeds only for a positive definite matrix: the others are left out.
    const Eigen::LLT<Eigen::Matrix3d> pose(p);
    const Eigen::LLT<Eigen::Matrix2d> xy(p.topLeftCorner<2, 2>());
    if (pose.info() == Eigen::Success && xy.info() == Eigen::Success) {
      const Eigen::Vector3d error(e.dx_m, e.dy_m, e.dtheta_rad);
      // A positive definite but tiny covariance can make them overflow: capped (kNeesCap), so
      // that a sum of many stays finite and a mean says "hopelessly overconfident" as a number.
      const auto capped = [](double v) { return std::isnan(v) ? kNeesCap : std::min(v, kNeesCap); };
      const double position_nees = capped(error.head<2>().dot(xy.solve(error.head<2>())));
      const double nees = capped(error.dot(pose.solve(error)));
      ++consistency_samples_;
      sum_nees_ += nees;
      nees_.add(nees);
      sum_position_nees_ += position_nees;
      inside = position_nees <= kChiSquare2Dof95;
      inside_95_ += *inside ? 1 : 0;
    }
  }
  if (within_position_ && e.t_s - within_position_->t_s <= kJumpWindowS &&
      std::hypot(e.dx_m - within_position_->dx_m, e.dy_m - within_position_->dy_m) > kJumpM) {
    ++jumps_;
    if (!first_jump_s_) first_jump_s_ = within_position_->t_s;
    within_position_.reset();  // one jump until the error is back within the bound
  }
  if (position <= criterion_.position_m) within_position_ = e;
  position_max_m_ = std::max(position_max_m_, position);
  heading_max_rad_ = std::max(heading_max_rad_, heading);
  if (converged_at_s_) {
    ++tracking_samples_;
    tracking_sum_sq_ += position * position;
    tracking_consistency_ += inside ? 1 : 0;
    tracking_inside_ += inside.value_or(false) ? 1 : 0;
  } else {
    const bool in = position <= criterion_.position_m && heading <= criterion_.heading_rad;
    run_ = in ? run_ + 1 : 0;
    run_sum_sq_ = in ? run_sum_sq_ + position * position : 0.0;
    run_consistency_ = in ? run_consistency_ + (inside ? 1 : 0) : 0;
    run_inside_ = in ? run_inside_ + (inside.value_or(false) ? 1 : 0) : 0;
    if (run_ == 1) run_start_ = e;
    if (in && run_ >= criterion_.hold_samples) {
      converged_at_s_ = run_start_.t_s;
      converged_at_steps_ = run_start_.steps - first_.steps;
      tracking_samples_ = static_cast<std::size_t>(run_);  // tracking since the run's start
      tracking_sum_sq_ = run_sum_sq_;
      tracking_consistency_ = run_consistency_;
      tracking_inside_ = run_inside_;
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
  s.tracking_samples = tracking_samples_;
  if (tracking_samples_ > 0)
    s.tracking_position_rms_m =
        std::sqrt(tracking_sum_sq_ / static_cast<double>(tracking_samples_));
  s.tracking_consistency_samples = tracking_consistency_;
  if (tracking_consistency_ > 0)
    s.tracking_inside_95_fraction =
        static_cast<double>(tracking_inside_) / static_cast<double>(tracking_consistency_);
  s.jumps = jumps_;
  s.first_jump_s = first_jump_s_;
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
  s.consistency_samples = consistency_samples_;
  if (consistency_samples_ > 0) {
    const double m = static_cast<double>(consistency_samples_);
    s.nees_mean = sum_nees_ / m;
    s.nees_median = nees_.quantile(0.5);
    s.position_nees_mean = sum_position_nees_ / m;
    s.inside_95_fraction = static_cast<double>(inside_95_) / m;
  }
  return s;
}

ErrorSummary summarize_errors(const std::vector<ErrorSample>& samples,
                              const ConvergenceCriterion& criterion) {
  ErrorAccumulator accumulator(criterion);
  for (const ErrorSample& e : samples) accumulator.add(e);
  return accumulator.summary();
}

LogHistogram::LogHistogram(double lowest, double ratio, std::size_t bins)
    : lowest_(lowest), log_ratio_(std::log(ratio)), bins_(bins, 0) {}

void LogHistogram::add(double value) {
  ++count_;
  max_ = std::max(max_, value);
  const double bin = value > lowest_ ? std::log(value / lowest_) / log_ratio_ : 0.0;
  // Above the range, infinite or NaN: the last bin (a cast of those to an integer is undefined).
  const auto last = static_cast<double>(bins_.size() - 1);
  ++bins_[bin < last ? static_cast<std::size_t>(bin) : bins_.size() - 1];
}

double LogHistogram::quantile(double q) const {
  if (count_ == 0) return 0.0;
  const auto rank = std::max<std::size_t>(
      1, static_cast<std::size_t>(std::ceil(q * static_cast<double>(count_))));
  std::size_t seen = 0;
  for (std::size_t i = 0; i < bins_.size(); ++i) {
    seen += bins_[i];
    if (seen >= rank) {
      // The last bin holds everything above the range: the largest value stands for it.
      if (i + 1 == bins_.size()) return max_;
      // The geometric middle, capped by the maximum (so that one value reports that value).
      return std::min(lowest_ * std::exp(log_ratio_ * (static_cast<double>(i) + 0.5)), max_);
    }
  }
  return max_;
}

void CostAccumulator::add(double seconds) {
  ++calls_;
  sum_s_ += seconds;
  max_s_ = std::max(max_s_, seconds);
  histogram_.add(seconds);
}

CostSummary CostAccumulator::summary() const {
  CostSummary c;
  c.calls = calls_;
  if (calls_ == 0) return c;
  c.mean_us = 1e6 * sum_s_ / static_cast<double>(calls_);
  c.max_us = 1e6 * max_s_;
  c.p99_us = 1e6 * histogram_.quantile(0.99);
  return c;
}

CostSummary summarize_costs(const std::vector<float>& seconds) {
  CostAccumulator accumulator;
  for (const float s : seconds) accumulator.add(s);
  return accumulator.summary();
}

}  // namespace locsim
