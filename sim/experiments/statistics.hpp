// Aggregates over seeds: mean with a 95 % confidence interval (Student t) and the median.
#pragma once

#include <cstddef>
#include <vector>

namespace locsim {

struct Aggregate {
  std::size_t n = 0;
  double mean = 0.0;
  double ci95 = 0.0;  // half-width: mean +- ci95; 0 for n < 2
  double median = 0.0;
};

Aggregate aggregate(std::vector<double> values);

/// Two-sided 97.5 % quantile of Student's t with `dof` degrees of freedom.
double student_t_975(std::size_t dof);

}  // namespace locsim
