// Derivative-free minimisation for the few-parameter likelihood fits of `locsim calibrate`.
// Eigen has no derivative-free minimiser (its unsupported LevenbergMarquardt needs a sum of
// squares, which a Gaussian likelihood with fitted covariance is not) and GSL's is under the GPL,
// so this is the textbook Nelder–Mead simplex, small and deterministic.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <numeric>
#include <vector>

namespace locsim {

struct MinimizeResult {
  std::vector<double> x;
  double value = 0.0;
  std::size_t evaluations = 0;
};

/// Minimises f over R^n by Nelder–Mead (reflection 1, expansion 2, contraction 1/2, shrink 1/2)
/// from a simplex of `x0` and x0 + step along each axis; stops when the simplex's values differ
/// by less than `tolerance` or after `max_evaluations`. f must return a number (use a large one,
/// not NaN, outside the domain).
template <class F>
MinimizeResult minimize_nelder_mead(F&& f, const std::vector<double>& x0, double step,
                                    std::size_t max_evaluations = 2000, double tolerance = 1e-10) {
  const std::size_t n = x0.size();
  std::vector<std::vector<double>> points(n + 1, x0);
  std::vector<double> values(n + 1);
  std::size_t evaluations = 0;
  const auto eval = [&](const std::vector<double>& x) {
    ++evaluations;
    return f(x);
  };
  for (std::size_t i = 0; i < n; ++i) points[i + 1][i] += step;
  for (std::size_t i = 0; i <= n; ++i) values[i] = eval(points[i]);
  std::vector<std::size_t> order(n + 1);
  std::vector<double> centroid(n), trial(n), second(n);
  const auto along = [&](double t, std::vector<double>& out, const std::vector<double>& worst) {
    for (std::size_t j = 0; j < n; ++j) out[j] = centroid[j] + t * (worst[j] - centroid[j]);
  };
  while (evaluations < max_evaluations) {
    std::iota(order.begin(), order.end(), 0);
    // Ties broken by index: the same path on every machine.
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return values[a] < values[b]; });
    const std::size_t best = order.front(), worst = order.back(), next = order[n - 1];
    if (values[worst] - values[best] <= tolerance * (1.0 + std::abs(values[best]))) break;
    std::fill(centroid.begin(), centroid.end(), 0.0);
    for (std::size_t i = 0; i <= n; ++i) {
      if (i == worst) continue;
      for (std::size_t j = 0; j < n; ++j) centroid[j] += points[i][j] / static_cast<double>(n);
    }
    along(-1.0, trial, points[worst]);
    const double reflected = eval(trial);
    if (reflected < values[best]) {
      along(-2.0, second, points[worst]);
      const double expanded = eval(second);
      if (expanded < reflected) {
        points[worst] = second, values[worst] = expanded;
      } else {
        points[worst] = trial, values[worst] = reflected;
      }
      continue;
    }
    if (reflected < values[next]) {
      points[worst] = trial, values[worst] = reflected;
      continue;
    }
    // Contract towards the better of the worst point and its reflection.
    const bool outside = reflected < values[worst];
    along(outside ? -0.5 : 0.5, second, points[worst]);
    const double contracted = eval(second);
    if (contracted < std::min(reflected, values[worst])) {
      points[worst] = second, values[worst] = contracted;
      continue;
    }
    for (std::size_t i = 0; i <= n; ++i) {
      if (i == best) continue;
      for (std::size_t j = 0; j < n; ++j)
        points[i][j] = points[best][j] + 0.5 * (points[i][j] - points[best][j]);
      values[i] = eval(points[i]);
    }
  }
  const std::size_t best =
      static_cast<std::size_t>(std::min_element(values.begin(), values.end()) - values.begin());
  return {points[best], values[best], evaluations};
}

/// Nelder–Mead restarted from its own answer with a fresh simplex until a restart no longer
/// improves it (at most `restarts` times): a collapsed simplex is the method's known failure, and
/// a restart is the standard remedy.
template <class F>
MinimizeResult minimize_restarted(F&& f, const std::vector<double>& x0, double step,
                                  std::size_t max_evaluations = 2000, std::size_t restarts = 4) {
  MinimizeResult best = minimize_nelder_mead(f, x0, step, max_evaluations);
  for (std::size_t i = 0; i < restarts; ++i) {
    MinimizeResult again = minimize_nelder_mead(f, best.x, step, max_evaluations);
    again.evaluations += best.evaluations;
    const bool better = again.value < best.value - 1e-9 * (1.0 + std::abs(best.value));
    if (again.value < best.value) best = again;
    if (!better) break;
  }
  return best;
}

}  // namespace locsim
