// Localization error and cost metrics (SPEC section 6), accumulated as the samples come: memory
// does not grow with the length of a run.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "sim/common/math.hpp"
#include "sim/common/range.hpp"

namespace locsim {

struct ErrorSample {
  double t_s = 0.0;
  double dx_m = 0.0, dy_m = 0.0;  // estimate - truth
  double dtheta_rad = 0.0;        // wrapped
  long steps = 0;                 // perception updates (camera, ultrasonic, laser) delivered so far
  /// The estimate's covariance, row-major over (x, y, theta) [m^2, m rad, rad^2]; none: the
  /// sample says nothing of consistency.
  std::optional<std::array<double, 9>> covariance;
};

/// Counts of positive values in geometric bins [lowest r^k, lowest r^(k+1)), for quantiles of a
/// long series in constant memory; values below `lowest` fall in the first bin, above the range
/// in the last. A quantile is its bin's geometric middle, capped by the largest value seen.
class LogHistogram {
 public:
  LogHistogram(double lowest, double ratio, std::size_t bins);
  void add(double value);
  /// The bin holding the ceil(q n)-th smallest value (q in (0, 1]); 0 when empty.
  double quantile(double q) const;

 private:
  double lowest_, log_ratio_;
  std::vector<std::uint32_t> bins_;
  std::size_t count_ = 0;
  double max_ = 0.0;
};

/// A jump: the estimate's error moving by more than kJumpM within kJumpWindowS of a sample
/// within the convergence criterion's position bound. A tracking filter that takes a wrong guess
/// (a recovery's injected pose winning over a scan spoilt by people) jumps; a filter losing
/// track slowly (odometry drifting after a push) does not, and is seen in its tracking RMS.
inline constexpr double kJumpM = 2.0;
inline constexpr double kJumpWindowS = 1.0;

/// A NEES above this (or NaN, from a covariance of 1e-300) counts as this in the statistics.
inline constexpr double kNeesCap = 1e100;

/// The chi-square 95 % quantile with two degrees of freedom: a position error e with
/// e^T P^-1 e at most this lies inside the covariance P's 95 % ellipse.
inline constexpr double kChiSquare2Dof95 = 5.991464547107979;

struct ConvergenceCriterion {
  double position_m = 0.1;  // error at or below this... [m]
  static constexpr Range kPositionRange{1e-6, 10000.0, "m"};
  double heading_rad = 0.17453292519943295;  // ...and this (10 deg)... [rad]
  static constexpr Range kHeadingRange{deg_to_rad(1e-6), deg_to_rad(180.0), "rad"};
  int hold_samples = 10;  // ...for this many consecutive samples
  static constexpr Range kHoldRange{1.0, 1000000.0, ""};
};

struct ErrorSummary {
  std::size_t samples = 0;
  double position_rms_m = 0.0, position_mean_m = 0.0, position_max_m = 0.0;
  double x_rms_m = 0.0, y_rms_m = 0.0;
  double heading_rms_rad = 0.0, heading_mean_rad = 0.0, heading_max_rad = 0.0;  // of |error|
  std::optional<double> converged_at_s;    // start of the first run that holds the criterion
  std::optional<long> converged_at_steps;  // perception updates from the first sample to then
  // How well it tracks once it has converged: the position RMS over the samples from
  // converged_at_s on (a later loss included), and how many they are. 0 samples: never converged.
  std::size_t tracking_samples = 0;
  double tracking_position_rms_m = 0.0;
  // Of those, the ones with a positive definite covariance, and the share whose true position
  // lies inside the estimate's 95 % ellipse: honest while it claims to know where it is.
  std::size_t tracking_consistency_samples = 0;
  double tracking_inside_95_fraction = 0.0;
  // Jumps (kJumpM, kJumpWindowS) and when the first one began (the last sample within the bound).
  std::size_t jumps = 0;
  std::optional<double> first_jump_s;
  double time_lost_s =
      0.0;  // time with the error outside the criterion's bounds (carried time aside)
  // Whether the covariance is honest, over the samples whose covariance is positive definite
  // (`consistency_samples`; a zero or singular covariance claims nothing to test): the mean
  // normalised estimation error squared e^T P^-1 e of the pose (x, y, theta; 3 when the
  // covariance matches the errors, above when it is overconfident) and of the position (2), and
  // the share of samples whose true position lies inside the estimate's 95 % ellipse (0.95).
  // The mean is the textbook statistic (ANEES) but a few samples can decide it (a lost filter's
  // 1e30); the median (to within 3 %) says what is typical.
  std::size_t consistency_samples = 0;
  double nees_mean = 0.0, nees_median = 0.0, position_nees_mean = 0.0, inside_95_fraction = 0.0;
};

/// The error summary of a series of samples, one at a time.
class ErrorAccumulator {
 public:
  explicit ErrorAccumulator(const ConvergenceCriterion& criterion = {}) : criterion_(criterion) {}
  void add(const ErrorSample& sample);
  ErrorSummary summary() const;
  bool empty() const { return samples_ == 0; }
  double first_t_s() const { return first_.t_s; }
  double last_t_s() const { return last_.t_s; }

 private:
  bool within(const ErrorSample& e) const;
  ConvergenceCriterion criterion_;
  std::size_t samples_ = 0;
  double sum_sq_ = 0, sum_ = 0, sum_sq_x_ = 0, sum_sq_y_ = 0, sum_sq_h_ = 0, sum_h_ = 0;
  double position_max_m_ = 0, heading_max_rad_ = 0;
  int run_ = 0;                                       // consecutive samples within the bounds
  double run_sum_sq_ = 0;                             // of their position errors
  std::size_t run_consistency_ = 0, run_inside_ = 0;  // of their covariances
  std::size_t tracking_samples_ = 0;                  // from convergence on
  double tracking_sum_sq_ = 0;
  std::size_t tracking_consistency_ = 0, tracking_inside_ = 0;
  // The latest sample within the criterion's position bound, while no jump has left it since.
  std::optional<ErrorSample> within_position_;
  std::size_t jumps_ = 0;
  std::optional<double> first_jump_s_;
  ErrorSample run_start_;          // the first of them
  ErrorSample first_, last_;       // first and latest sample
  double typical_interval_s_ = 0;  // between the first two samples
  double time_lost_s_ = 0;         // of the samples before the latest
  std::size_t consistency_samples_ = 0, inside_95_ = 0;
  double sum_nees_ = 0, sum_position_nees_ = 0;
  LogHistogram nees_{1e-6, 1.05, 2400};  // 1e-6 to 1e45
  std::optional<double> converged_at_s_;
  std::optional<long> converged_at_steps_;
};

/// The same over a whole series at once.
ErrorSummary summarize_errors(const std::vector<ErrorSample>& samples,
                              const ConvergenceCriterion& criterion = {});

struct CostSummary {
  std::size_t calls = 0;
  double mean_us = 0.0;
  double p99_us = 0.0;  // to within 2 % (a log-spaced histogram)
  double max_us = 0.0;
};

/// Wall-clock cost of calls, one duration at a time, in constant memory: exact count, mean and
/// maximum, the 99th percentile from a histogram of 2 %-wide bins from 10 ns to 1000 s.
class CostAccumulator {
 public:
  void add(double seconds);
  CostSummary summary() const;

 private:
  LogHistogram histogram_{1e-8, 1.02, 1280};  // 1.02^1280 = 1e11: 10 ns to 1000 s
  std::size_t calls_ = 0;
  double sum_s_ = 0.0, max_s_ = 0.0;
};

/// `seconds`: one wall-clock duration per call.
CostSummary summarize_costs(const std::vector<float>& seconds);

}  // namespace locsim
