// Localization error and cost metrics (SPEC section 6), from an estimate series against the truth.
#pragma once

#include <optional>
#include <vector>

namespace locsim {

struct ErrorSample {
  double t_s = 0.0;
  double dx_m = 0.0, dy_m = 0.0;  // estimate - truth
  double dtheta_rad = 0.0;        // wrapped
  long steps = 0;                 // perception updates (camera, ultrasonic, laser) delivered so far
};

struct ConvergenceCriterion {
  double position_m = 0.1;                   // error at or below this...
  double heading_rad = 0.17453292519943295;  // ...and this (10 deg)...
  int hold_samples = 10;                     // ...for this many consecutive samples
};

struct ErrorSummary {
  std::size_t samples = 0;
  double position_rms_m = 0.0, position_mean_m = 0.0, position_max_m = 0.0;
  double x_rms_m = 0.0, y_rms_m = 0.0;
  double heading_rms_rad = 0.0, heading_mean_rad = 0.0, heading_max_rad = 0.0;  // of |error|
  std::optional<double> converged_at_s;    // start of the first run that holds the criterion
  std::optional<long> converged_at_steps;  // perception updates from the first sample to then
  double time_lost_s =
      0.0;  // time with the error outside the criterion's bounds (carried time aside)
};

ErrorSummary summarize_errors(const std::vector<ErrorSample>& samples,
                              const ConvergenceCriterion& criterion = {});

struct CostSummary {
  std::size_t calls = 0;
  double mean_us = 0.0;
  double p99_us = 0.0;
  double max_us = 0.0;
};

/// `seconds`: one wall-clock duration per call.
CostSummary summarize_costs(std::vector<float> seconds);

}  // namespace locsim
