// Laser models over the host's occupancy grid, for plugin authors: the exact Euclidean distance
// transform and the likelihood field (Thrun, Burgard and Fox, Probabilistic Robotics, 6.4) as a
// table of per-cell log likelihoods, so that weighing a beam is a transform and a lookup.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <vector>

#include "locsim/localizer.h"

namespace locsim::sdk {

/// Squared Euclidean distance, in cells, from every cell of a width x height grid to the nearest
/// cell where `occupied` is true (Felzenszwalb and Huttenlocher's two-pass lower envelope of
/// parabolas: exact, linear time). No occupied cell: every distance is infinite.
template <class Occupied>
std::vector<double> squared_distance_transform(int width, int height, Occupied occupied) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const auto w = static_cast<std::size_t>(width), h = static_cast<std::size_t>(height);
  std::vector<double> d(w * h);
  for (std::size_t row = 0; row < h; ++row)
    for (std::size_t col = 0; col < w; ++col)
      d[row * w + col] = occupied(static_cast<int>(col), static_cast<int>(row)) ? 0.0 : kInf;
  // One dimension at a time: f(q) sampled at 0..n-1 -> min over q of (p - q)^2 + f(q).
  const std::size_t longest = std::max(w, h);
  std::vector<double> f(longest), out(longest), z(longest + 1);
  std::vector<std::size_t> v(longest);
  const auto pass = [&](std::size_t n) {
    std::size_t k = 0;
    std::size_t first = 0;
    while (first < n && !std::isfinite(f[first])) ++first;
    if (first == n) {
      std::fill(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n), kInf);
      return;
    }
    v[0] = first;
    z[0] = -kInf, z[1] = kInf;
    for (std::size_t q = first + 1; q < n; ++q) {
      if (!std::isfinite(f[q])) continue;  // no parabola there
      const auto dq = static_cast<double>(q);
      const auto meet = [&](std::size_t j) {  // where parabola q crosses parabola v[j]
        const auto dv = static_cast<double>(v[j]);
        return ((f[q] + dq * dq) - (f[v[j]] + dv * dv)) / (2.0 * (dq - dv));
      };
      double s = meet(k);
      while (s <= z[k]) s = meet(--k);  // z[0] = -inf ends it
      ++k;
      v[k] = q, z[k] = s, z[k + 1] = kInf;
    }
    k = 0;
    for (std::size_t q = 0; q < n; ++q) {
      while (z[k + 1] < static_cast<double>(q)) ++k;
      const double dq = static_cast<double>(q) - static_cast<double>(v[k]);
      out[q] = dq * dq + f[v[k]];
    }
  };
  for (std::size_t col = 0; col < w; ++col) {
    for (std::size_t row = 0; row < h; ++row) f[row] = d[row * w + col];
    pass(h);
    for (std::size_t row = 0; row < h; ++row) d[row * w + col] = out[row];
  }
  for (std::size_t row = 0; row < h; ++row) {
    for (std::size_t col = 0; col < w; ++col) f[col] = d[row * w + col];
    pass(w);
    for (std::size_t col = 0; col < w; ++col) d[row * w + col] = out[col];
  }
  return d;
}

/// Parameters of the likelihood field, with AMCL's names and defaults.
struct LikelihoodFieldDef {
  double z_hit = 0.95;       // weight of the hit term [-]
  double z_rand = 0.05;      // weight of the uniform term [-]
  double sigma_hit_m = 0.2;  // spread of a hit about the nearest obstacle [m]
  double max_dist_m = 2.0;   // distances beyond count as this far [m]
  double range_max_m = 8.0;  // the uniform term is z_rand / range_max [1/m]
};

/// p(z | x, m) of one beam end point: z_hit N(d; 0, sigma_hit) + z_rand / range_max, d the
/// distance from the end point to the nearest occupied cell (capped at max_dist); end points off
/// the map get the uniform term only. Stored as log p per cell (float), row-major from the
/// bottom row like the host's grid.
class LikelihoodField {
 public:
  LikelihoodField() = default;
  LikelihoodField(const locsim_occupancy_grid& grid, const LikelihoodFieldDef& def)
      : origin_x_(grid.origin_x),
        origin_y_(grid.origin_y),
        inv_resolution_(1.0 / grid.resolution_m),
        width_(grid.width),
        height_(grid.height) {
    const std::vector<double> d2 =
        squared_distance_transform(grid.width, grid.height, [&](int col, int row) {
          return grid.cells[static_cast<std::size_t>(row) * static_cast<std::size_t>(grid.width) +
                            static_cast<std::size_t>(col)] != 0;
        });
    const double uniform = def.z_rand / def.range_max_m;
    const double norm = def.z_hit / (std::sqrt(2.0 * std::numbers::pi) * def.sigma_hit_m);
    log_off_map_ = static_cast<float>(std::log(uniform));
    log_p_.resize(d2.size());
    for (std::size_t i = 0; i < d2.size(); ++i) {
      const double dist = std::min(std::sqrt(d2[i]) * grid.resolution_m, def.max_dist_m);
      log_p_[i] = static_cast<float>(std::log(
          norm * std::exp(-0.5 * dist * dist / (def.sigma_hit_m * def.sigma_hit_m)) + uniform));
    }
  }

  /// log p of an end point at (x, y) in the world.
  float log_p(double x, double y) const {
    const auto col = static_cast<std::int64_t>(std::floor((x - origin_x_) * inv_resolution_));
    const auto row = static_cast<std::int64_t>(std::floor((y - origin_y_) * inv_resolution_));
    if (col < 0 || row < 0 || col >= width_ || row >= height_) return log_off_map_;
    return log_p_[static_cast<std::size_t>(row * width_ + col)];
  }
  float log_off_map() const { return log_off_map_; }
  double origin_x() const { return origin_x_; }
  double origin_y() const { return origin_y_; }
  double inv_resolution() const { return inv_resolution_; }
  std::int64_t width() const { return width_; }
  std::int64_t height() const { return height_; }
  const std::vector<float>& table() const { return log_p_; }

 private:
  double origin_x_ = 0.0, origin_y_ = 0.0, inv_resolution_ = 1.0;
  std::int64_t width_ = 0, height_ = 0;
  float log_off_map_ = 0.0f;
  std::vector<float> log_p_;
};

}  // namespace locsim::sdk
