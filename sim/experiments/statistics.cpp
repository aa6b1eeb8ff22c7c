#include "sim/experiments/statistics.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace locsim {

double student_t_975(std::size_t dof) {
  // Exact to 3 decimals for 1..30 degrees of freedom; beyond, the Cornish-Fisher expansion
  // around the normal quantile (error below 1e-4 there).
  static constexpr double kTable[] = {12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306,
                                      2.262,  2.228, 2.201, 2.179, 2.160, 2.145, 2.131, 2.120,
                                      2.110,  2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064,
                                      2.060,  2.056, 2.052, 2.048, 2.045, 2.042};
  if (dof == 0) return 0.0;
  if (dof <= 30) return kTable[dof - 1];
  const double z = 1.959963984540054, n = static_cast<double>(dof);
  return z + (z * z * z + z) / (4 * n) +
         (5 * std::pow(z, 5) + 16 * z * z * z + 3 * z) / (96 * n * n);
}

Aggregate aggregate(std::vector<double> values) {
  Aggregate a;
  a.n = values.size();
  if (values.empty()) return a;
  a.mean = std::accumulate(values.begin(), values.end(), 0.0) / static_cast<double>(a.n);
  if (a.n > 1) {
    double sq = 0.0;
    for (const double v : values) sq += (v - a.mean) * (v - a.mean);
    const double stddev = std::sqrt(sq / static_cast<double>(a.n - 1));
    a.ci95 = student_t_975(a.n - 1) * stddev / std::sqrt(static_cast<double>(a.n));
  }
  std::sort(values.begin(), values.end());
  a.median = a.n % 2 == 1 ? values[a.n / 2] : 0.5 * (values[a.n / 2 - 1] + values[a.n / 2]);
  return a;
}

}  // namespace locsim
