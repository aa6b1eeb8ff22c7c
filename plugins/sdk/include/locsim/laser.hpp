// Laser models over the host's occupancy grid, for plugin authors: the exact Euclidean distance
// transform and the likelihood field (Thrun, Burgard and Fox, Probabilistic Robotics, 6.4) as a
// table of per-cell log likelihoods, so that weighing a beam is a transform and a lookup.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <span>
#include <stdexcept>
#include <vector>

#include "locsim/localizer.h"
#include "locsim/vector_math.hpp"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define LOCSIM_SDK_X86_DISPATCH 1
#endif

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
    const auto log_p_of = [&](double squared_cells) {
      const double dist = std::min(std::sqrt(squared_cells) * grid.resolution_m, def.max_dist_m);
      return static_cast<float>(std::log(
          norm * std::exp(-0.5 * dist * dist / (def.sigma_hit_m * def.sigma_hit_m)) + uniform));
    };
    // A cell's value depends on its squared distance alone, a whole number of cells squared:
    // each distinct one below the cap is computed once (an exponential and a logarithm per cell
    // were most of building a field), every capped one is the same value.
    const float capped = log_p_of(std::numeric_limits<double>::infinity());
    const double cap_cells = def.max_dist_m / grid.resolution_m;
    std::vector<float> by_square(
        static_cast<std::size_t>(std::clamp(cap_cells * cap_cells + 2.0, 1.0, 65536.0)),
        std::numeric_limits<float>::quiet_NaN());
    log_p_.resize(d2.size());
    for (std::size_t i = 0; i < d2.size(); ++i) {
      const double squared = d2[i];
      if (squared < static_cast<double>(by_square.size()) && squared == std::floor(squared)) {
        float& known = by_square[static_cast<std::size_t>(squared)];
        if (std::isnan(known)) known = log_p_of(squared);
        log_p_[i] = known;
      } else {
        log_p_[i] =
            std::sqrt(squared) * grid.resolution_m >= def.max_dist_m ? capped : log_p_of(squared);
      }
    }
  }

  /// log p of an end point at (x, y) in the world.
  float log_p(double x, double y) const {
    const double gx = (x - origin_x_) * inv_resolution_, gy = (y - origin_y_) * inv_resolution_;
    // Compared as doubles first (NaN is off the map), then truncated: on the map that is floor,
    // without floor's library call (baseline x86-64 has no rounding instruction), and a far-off
    // point never overflows the integer conversion.
    if (!(gx >= 0.0 && gy >= 0.0 && gx < static_cast<double>(width_) &&
          gy < static_cast<double>(height_)))
      return log_off_map_;
    return log_p_[static_cast<std::size_t>(static_cast<std::int64_t>(gy) * width_ +
                                           static_cast<std::int64_t>(gx))];
  }
  /// For each pose i (x[i], y[i], theta[i] in the world), the sum over the end points (ex[b],
  /// ey[b]) in the robot frame of the log p of the end point moved to that pose: a particle's log
  /// likelihood of a scan. Summed in float in end-point order, then widened to double into
  /// out[i]. The inner loop of a laser particle filter (AMCL weighs 60 end points per particle):
  /// on a processor with AVX2 four poses go at a time, the same operations in the same order as
  /// the one-pose path, so that the sums are bit-identical whichever path runs (the SDK compiles
  /// with -ffp-contract=off: a fused multiply-add would round differently).
  void sum_log_p(std::span<const double> x, std::span<const double> y,
                 std::span<const double> theta, std::span<const double> ex,
                 std::span<const double> ey, std::span<double> out) const {
    sum_log_p(x, y, theta, ex, ey, out, simd_available());
  }
  /// The same, with the four-pose path allowed or not (tests compare the two).
  void sum_log_p(std::span<const double> x, std::span<const double> y,
                 std::span<const double> theta, std::span<const double> ex,
                 std::span<const double> ey, std::span<double> out, bool simd) const {
    const std::size_t n = x.size();
    if (y.size() != n || theta.size() != n || out.size() != n || ey.size() != ex.size())
      throw std::invalid_argument("sum_log_p: one x, y, theta and out per pose, one ey per ex");
    // Per block of poses: the pose in grid units and the rotation scaled to grid units, so that
    // an end point costs two products and two sums per coordinate.
    Block block;
    for (std::size_t start = 0; start < n; start += Block::kPoses) {
      const std::size_t m = std::min(Block::kPoses, n - start);
      vector_math::sincos(theta.subspan(start, m), std::span(block.sx).first(m),
                          std::span(block.cx).first(m));
      for (std::size_t k = 0; k < m; ++k) {
        block.px[k] = (x[start + k] - origin_x_) * inv_resolution_;
        block.py[k] = (y[start + k] - origin_y_) * inv_resolution_;
        block.cx[k] *= inv_resolution_, block.sx[k] *= inv_resolution_;
      }
      std::size_t k = 0;
#ifdef LOCSIM_SDK_X86_DISPATCH
      if (simd && index_fits_int32()) {
        k = m - m % 4;
        sum_four_poses_avx2(block, k, ex, ey, out.data() + start);
      }
#else
      (void)simd;
#endif
      for (; k < m; ++k) out[start + k] = sum_one_pose(block, k, ex, ey);
    }
  }
  /// For each position k (x[k], y[k] in the world), the sum of log_p(x[k] + dx[i], y[k] + dy[i])
  /// over every stride-th point i: one scan, already turned to a heading, tried at many positions
  /// (a place search's lattice). Summed in double in point order: the bits of calling log_p point
  /// after point, which the four-position path (AVX2) keeps.
  void sum_log_p_shifted(std::span<const double> x, std::span<const double> y,
                         std::span<const double> dx, std::span<const double> dy, std::size_t stride,
                         std::span<double> out) const {
    sum_log_p_shifted(x, y, dx, dy, stride, out, simd_available());
  }
  /// The same, with the four-position path allowed or not (tests compare the two).
  void sum_log_p_shifted(std::span<const double> x, std::span<const double> y,
                         std::span<const double> dx, std::span<const double> dy, std::size_t stride,
                         std::span<double> out, bool simd) const {
    const std::size_t n = x.size();
    if (y.size() != n || out.size() != n || dy.size() != dx.size() || stride == 0)
      throw std::invalid_argument(
          "sum_log_p_shifted: one x, y and out per position, one dy per dx, a stride above 0");
    std::size_t k = 0;
#ifdef LOCSIM_SDK_X86_DISPATCH
    if (simd && index_fits_int32()) {
      k = n - n % 4;
      sum_shifted_four_avx2(x.data(), y.data(), k, dx, dy, stride, out.data());
    }
#else
    (void)simd;
#endif
    for (; k < n; ++k) {
      double sum = 0.0;
      for (std::size_t i = 0; i < dx.size(); i += stride) sum += log_p(x[k] + dx[i], y[k] + dy[i]);
      out[k] = sum;
    }
  }
  /// log p of each end point (ex[b], ey[b]) of one scan in the robot frame, seen from one pose
  /// (x, y in the world, heading cos_theta, sin_theta): out[b] = log_p(x + cos ex - sin ey,
  /// y + sin ex + cos ey), those operations in that order, so the bits of log_p point by point.
  /// A search's objective (a pose's fit to a scan, tried at pose after pose), four end points at
  /// a time on AVX2; the caller sums them in its own order and precision.
  void log_p_at(double x, double y, double cos_theta, double sin_theta, std::span<const double> ex,
                std::span<const double> ey, std::span<float> out) const {
    log_p_at(x, y, cos_theta, sin_theta, ex, ey, out, simd_available());
  }
  /// The same, with the four-point path allowed or not (tests compare the two).
  void log_p_at(double x, double y, double cos_theta, double sin_theta, std::span<const double> ex,
                std::span<const double> ey, std::span<float> out, bool simd) const {
    const std::size_t n = ex.size();
    if (ey.size() != n || out.size() != n)
      throw std::invalid_argument("log_p_at: one ey and one out per ex");
    std::size_t b = 0;
#ifdef LOCSIM_SDK_X86_DISPATCH
    if (simd && index_fits_int32()) {
      b = n - n % 4;
      log_p_four_points_avx2(x, y, cos_theta, sin_theta, ex.data(), ey.data(), b, out.data());
    }
#else
    (void)simd;
#endif
    for (; b < n; ++b)
      out[b] = log_p(x + cos_theta * ex[b] - sin_theta * ey[b],
                     y + sin_theta * ex[b] + cos_theta * ey[b]);
  }
  /// Whether this processor runs sum_log_p's four-pose path.
  static bool simd_available() {
#ifdef LOCSIM_SDK_X86_DISPATCH
    static const bool avx2 = __builtin_cpu_supports("avx2");
    return avx2;
#else
    return false;
#endif
  }

  float log_off_map() const {
    return log_off_map_;
  }
  double origin_x() const {
    return origin_x_;
  }
  double origin_y() const {
    return origin_y_;
  }
  double inv_resolution() const {
    return inv_resolution_;
  }
  std::int64_t width() const {
    return width_;
  }
  std::int64_t height() const {
    return height_;
  }
  const std::vector<float>& table() const {
    return log_p_;
  }

 private:
  /// Poses in grid units, a block small enough to stay in the first-level cache.
  struct Block {
    static constexpr std::size_t kPoses = 256;
    double px[kPoses], py[kPoses], cx[kPoses], sx[kPoses];
  };
  bool index_fits_int32() const {
    return width_ * height_ <= std::numeric_limits<std::int32_t>::max();
  }

  /// One pose's sum: the reference for the four-pose path, which must match it bit for bit.
  double sum_one_pose(const Block& p, std::size_t k, std::span<const double> ex,
                      std::span<const double> ey) const {
    const auto fwidth = static_cast<double>(width_), fheight = static_cast<double>(height_);
    float sum = 0.0f;
    for (std::size_t b = 0; b < ex.size(); ++b) {
      const double gx = p.px[k] + p.cx[k] * ex[b] - p.sx[k] * ey[b];
      const double gy = p.py[k] + p.sx[k] * ex[b] + p.cx[k] * ey[b];
      // Compared as doubles first (NaN is off the map): truncation is then floor.
      const bool on_map = gx >= 0.0 && gy >= 0.0 && gx < fwidth && gy < fheight;
      sum += on_map ? log_p_[static_cast<std::size_t>(static_cast<std::int64_t>(gy) * width_ +
                                                      static_cast<std::int64_t>(gx))]
                    : log_off_map_;
    }
    return static_cast<double>(sum);
  }

#ifdef LOCSIM_SDK_X86_DISPATCH
  /// log p at four grid coordinates (cells, as doubles), log_off_map_ in the lanes off the map:
  /// log_p's lookup four lanes at a time. Inlined into both AVX2 loops, where the compiler hoists
  /// the constants out of the loops.
  __attribute__((target("avx2"), always_inline)) __m128 gather_log_p_avx2(__m256d gx,
                                                                          __m256d gy) const {
    const __m256d zero = _mm256_setzero_pd();
    const __m256d fwidth = _mm256_set1_pd(static_cast<double>(width_));
    const __m256d fheight = _mm256_set1_pd(static_cast<double>(height_));
    const __m256d on_map = _mm256_and_pd(
        _mm256_and_pd(_mm256_cmp_pd(gx, zero, _CMP_GE_OQ), _mm256_cmp_pd(gy, zero, _CMP_GE_OQ)),
        _mm256_and_pd(_mm256_cmp_pd(gx, fwidth, _CMP_LT_OQ),
                      _mm256_cmp_pd(gy, fheight, _CMP_LT_OQ)));
    // Off-map lanes are zeroed before the conversion (no overflow) and masked in the gather.
    const __m128i col = _mm256_cvttpd_epi32(_mm256_and_pd(on_map, gx));
    const __m128i row = _mm256_cvttpd_epi32(_mm256_and_pd(on_map, gy));
    const __m128i index =
        _mm_add_epi32(_mm_mullo_epi32(row, _mm_set1_epi32(static_cast<std::int32_t>(width_))), col);
    // The four 64-bit masks as four 32-bit ones: the low half of each.
    const __m128 mask =
        _mm_shuffle_ps(_mm256_castps256_ps128(_mm256_castpd_ps(on_map)),
                       _mm256_extractf128_ps(_mm256_castpd_ps(on_map), 1), _MM_SHUFFLE(2, 0, 2, 0));
    return _mm_mask_i32gather_ps(_mm_set1_ps(log_off_map_), log_p_.data(), index, mask, 4);
  }
#endif

#ifdef LOCSIM_SDK_X86_DISPATCH
  /// Poses 0..count-1 of the block (count a multiple of four), four at a time: the lanes of each
  /// vector are four poses, each going through sum_one_pose's operations in its order.
  __attribute__((target("avx2"))) void sum_four_poses_avx2(const Block& p, std::size_t count,
                                                           std::span<const double> ex,
                                                           std::span<const double> ey,
                                                           double* out) const {
    for (std::size_t k = 0; k < count; k += 4) {
      const __m256d px = _mm256_loadu_pd(p.px + k), py = _mm256_loadu_pd(p.py + k);
      const __m256d cx = _mm256_loadu_pd(p.cx + k), sx = _mm256_loadu_pd(p.sx + k);
      __m128 sum = _mm_setzero_ps();
      for (std::size_t b = 0; b < ex.size(); ++b) {
        const __m256d bx = _mm256_set1_pd(ex[b]), by = _mm256_set1_pd(ey[b]);
        const __m256d gx =
            _mm256_sub_pd(_mm256_add_pd(px, _mm256_mul_pd(cx, bx)), _mm256_mul_pd(sx, by));
        const __m256d gy =
            _mm256_add_pd(_mm256_add_pd(py, _mm256_mul_pd(sx, bx)), _mm256_mul_pd(cx, by));
        sum = _mm_add_ps(sum, gather_log_p_avx2(gx, gy));
      }
      _mm256_storeu_pd(out + k, _mm256_cvtps_pd(sum));
    }
  }
#endif

#ifdef LOCSIM_SDK_X86_DISPATCH
  /// Positions 0..count-1 (count a multiple of four), four at a time: each lane is one position
  /// going through log_p's operations, accumulated as the one-position loop does.
  __attribute__((target("avx2"))) void sum_shifted_four_avx2(
      const double* x, const double* y, std::size_t count, std::span<const double> dx,
      std::span<const double> dy, std::size_t stride, double* out) const {
    const __m256d zero = _mm256_setzero_pd();
    const __m256d origin_x = _mm256_set1_pd(origin_x_), origin_y = _mm256_set1_pd(origin_y_);
    const __m256d inv_resolution = _mm256_set1_pd(inv_resolution_);
    for (std::size_t k = 0; k < count; k += 4) {
      const __m256d px = _mm256_loadu_pd(x + k), py = _mm256_loadu_pd(y + k);
      __m256d sum = zero;
      for (std::size_t i = 0; i < dx.size(); i += stride) {
        const __m256d gx = _mm256_mul_pd(
            _mm256_sub_pd(_mm256_add_pd(px, _mm256_set1_pd(dx[i])), origin_x), inv_resolution);
        const __m256d gy = _mm256_mul_pd(
            _mm256_sub_pd(_mm256_add_pd(py, _mm256_set1_pd(dy[i])), origin_y), inv_resolution);
        sum = _mm256_add_pd(sum, _mm256_cvtps_pd(gather_log_p_avx2(gx, gy)));
      }
      _mm256_storeu_pd(out + k, sum);
    }
  }
#endif

#ifdef LOCSIM_SDK_X86_DISPATCH
  /// End points 0..count-1 (count a multiple of four), four at a time: each lane is one end point
  /// going through log_p_at's operations, then log_p's.
  __attribute__((target("avx2"))) void log_p_four_points_avx2(double x, double y, double c,
                                                              double s, const double* ex,
                                                              const double* ey, std::size_t count,
                                                              float* out) const {
    const __m256d px = _mm256_set1_pd(x), py = _mm256_set1_pd(y);
    const __m256d cx = _mm256_set1_pd(c), sx = _mm256_set1_pd(s);
    const __m256d origin_x = _mm256_set1_pd(origin_x_), origin_y = _mm256_set1_pd(origin_y_);
    const __m256d inv_resolution = _mm256_set1_pd(inv_resolution_);
    for (std::size_t b = 0; b < count; b += 4) {
      const __m256d bx = _mm256_loadu_pd(ex + b), by = _mm256_loadu_pd(ey + b);
      const __m256d wx =
          _mm256_sub_pd(_mm256_add_pd(px, _mm256_mul_pd(cx, bx)), _mm256_mul_pd(sx, by));
      const __m256d wy =
          _mm256_add_pd(_mm256_add_pd(py, _mm256_mul_pd(sx, bx)), _mm256_mul_pd(cx, by));
      const __m256d gx = _mm256_mul_pd(_mm256_sub_pd(wx, origin_x), inv_resolution);
      const __m256d gy = _mm256_mul_pd(_mm256_sub_pd(wy, origin_y), inv_resolution);
      _mm_storeu_ps(out + b, gather_log_p_avx2(gx, gy));
    }
  }
#endif

  double origin_x_ = 0.0, origin_y_ = 0.0, inv_resolution_ = 1.0;
  std::int64_t width_ = 0, height_ = 0;
  float log_off_map_ = 0.0f;
  std::vector<float> log_p_;
};

/// A scan's beams held against the map from a pose: how many pass through an occupied cell more
/// than the margin before their end (`through`: beams the pose cannot explain whatever moves
/// about, since something the map does not hold, a person or a cart, can shorten a beam, but
/// nothing lengthens one past a wall), and how many end in free space, no occupied cell within
/// the margin of their end along the ray (`short_of_walls`: on something the map does not hold,
/// or a pose that is wrong).
struct BeamsAgainstMap {
  std::size_t through = 0, short_of_walls = 0;
};

/// The beams, seen from the pose (x, y, theta), against `grid`: `sensor_x`, `sensor_y` where they
/// start, `end_x`, `end_y` where they end, in the robot frame. The ray is walked in half-cell
/// steps to the margin past its end; cells off the grid are free.
inline BeamsAgainstMap beams_against_map(const locsim_occupancy_grid& grid, double x, double y,
                                         double theta, double sensor_x, double sensor_y,
                                         const std::vector<double>& end_x,
                                         const std::vector<double>& end_y, double margin_m) {
  const double c = std::cos(theta), s = std::sin(theta);
  const double ox = x + c * sensor_x - s * sensor_y, oy = y + s * sensor_x + c * sensor_y;
  const double step_m = 0.5 * grid.resolution_m, inv_resolution = 1.0 / grid.resolution_m;
  BeamsAgainstMap out;
  for (std::size_t k = 0; k < end_x.size(); ++k) {
    const double ex = x + c * end_x[k] - s * end_y[k];
    const double ey = y + s * end_x[k] + c * end_y[k];
    const double range = std::hypot(ex - ox, ey - oy);
    if (!(range > 0.0)) continue;
    const double ux = (ex - ox) / range, uy = (ey - oy) / range;
    bool wall_at_end = false, through = false;
    for (double d = 0.0; d <= range + margin_m; d += step_m) {
      const double gx = (ox + d * ux - grid.origin_x) * inv_resolution;
      const double gy = (oy + d * uy - grid.origin_y) * inv_resolution;
      if (!(gx >= 0.0 && gy >= 0.0 && gx < grid.width && gy < grid.height)) continue;
      if (grid.cells[static_cast<std::size_t>(gy) * static_cast<std::size_t>(grid.width) +
                     static_cast<std::size_t>(gx)] == 0)
        continue;
      if (d < range - margin_m) {
        through = true;
      } else {
        wall_at_end = true;
      }
      break;
    }
    out.through += through ? 1 : 0;
    out.short_of_walls += !through && !wall_at_end ? 1 : 0;
  }
  return out;
}

}  // namespace locsim::sdk
