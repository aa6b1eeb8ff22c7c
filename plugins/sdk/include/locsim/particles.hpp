// Particle-filter pieces shared by locsim's particle filters and open to every plugin author:
// a structure-of-arrays particle set, the odometry motion model of the ASRL paper (and Thrun's
// variance form), the landmark likelihood, roulette-wheel and low-variance resampling, the
// effective sample size and circular means. Header-only; deterministic for a given seed.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

#include "locsim/localizer.h"
#include "locsim/models.hpp"

namespace locsim::sdk {

/// Seeded random numbers. The engine is std::mt19937_64 (its output the standard fixes); the
/// conversions are written out so that results do not depend on the standard library.
class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }  // [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Standard normal (Marsaglia's polar method).
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u, v, s;
    do {
      u = 2.0 * uniform() - 1.0;
      v = 2.0 * uniform() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double f = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = v * f;
    has_spare_ = true;
    return u * f;
  }
  double normal(double stddev) { return stddev * normal(); }

 private:
  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

/// Particles as structure of arrays: the loops over them vectorise and never allocate.
struct ParticleSet {
  std::vector<double> x, y, theta, weight;
  std::size_t size() const { return x.size(); }
  void resize(std::size_t n) {
    x.resize(n), y.resize(n), theta.resize(n),
        weight.assign(n, n > 0 ? 1.0 / static_cast<double>(n) : 0.0);
  }
};

/// Odometry between two poses, decomposed rotate-translate-rotate (SPEC section 2):
///   trans = |p' - p|, rot1 = atan2(y' - y, x' - x) - theta, rot2 = theta' - theta - rot1.
struct OdometryDelta {
  double rot1 = 0.0, trans = 0.0, rot2 = 0.0;
};

inline OdometryDelta decompose(const Pose& from, const Pose& to) {
  OdometryDelta d;
  const double dx = to(0) - from(0), dy = to(1) - from(1);
  d.trans = std::hypot(dx, dy);
  // Below a millimetre the direction of travel is noise: treat the motion as a pure rotation.
  d.rot1 = d.trans < 1e-3 ? 0.0 : wrap(std::atan2(dy, dx) - from(2));
  d.rot2 = wrap(to(2) - from(2) - d.rot1);
  return d;
}

/// The paper's alpha_1..alpha_4 (defaults from paper 004).
struct OdometryNoise {
  double alpha1 = 0.0014;    // rotation noise from rotation
  double alpha2 = 0.000125;  // rotation noise from translation
  double alpha3 = 0.01;      // translation noise from translation
  double alpha4 = 0.26;      // translation noise from rotation
  /// false: the paper's form, sample(b) with standard deviation b = alpha_i |.| + alpha_j |.|;
  /// true: Thrun's (Probabilistic Robotics table 5.6), variance b = alpha_i (.)^2 + alpha_j (.)^2.
  bool variance_form = false;
};

/// One noisy version of `d` (the paper's sample_motion_model_odometry).
inline OdometryDelta sample_delta(const OdometryDelta& d, const OdometryNoise& n, Random& random) {
  const auto spread = [&](double a, double u, double b, double v) {
    return n.variance_form ? std::sqrt(a * u * u + b * v * v) : a * std::abs(u) + b * std::abs(v);
  };
  return {d.rot1 + random.normal(spread(n.alpha1, d.rot1, n.alpha2, d.trans)),
          d.trans + random.normal(spread(n.alpha4, d.rot1 + d.rot2, n.alpha3, d.trans)),
          d.rot2 + random.normal(spread(n.alpha1, d.rot2, n.alpha2, d.trans))};
}

/// Moves every particle by its own noisy sample of `d`.
inline void sample_motion(ParticleSet& p, const OdometryDelta& d, const OdometryNoise& n,
                          Random& random) {
  for (std::size_t i = 0; i < p.size(); ++i) {
    const OdometryDelta s = sample_delta(d, n, random);
    const double heading = p.theta[i] + s.rot1;
    p.x[i] += s.trans * std::cos(heading);
    p.y[i] += s.trans * std::sin(heading);
    p.theta[i] = wrap(heading + s.rot2);
  }
}

/// log of the landmark likelihood below scaled to 1 at a perfect match: -(e_r^2 + e_phi^2) / 2,
/// the errors in units of their sigma. A mean of these is dimensionless, so a threshold on it (SRL,
/// ASRL's p_t) means the same whatever the units and noise levels; the density above is this minus
/// a constant.
inline double landmark_log_match(double x, double y, double theta, double range, double bearing,
                                 double lx, double ly, double sigma_range, double sigma_bearing) {
  const double dx = lx - x, dy = ly - y;
  const double er = (range - std::sqrt(dx * dx + dy * dy)) / sigma_range;
  const double eb = wrap(bearing - (std::atan2(dy, dx) - theta)) / sigma_bearing;
  return -0.5 * (er * er + eb * eb);
}

/// log p(z | x, m) for one range-bearing detection of a landmark at (lx, ly): the sum of the two
/// components' normal log densities, N(r - r^; 0, sigma_r^2) N(phi - phi^; 0, sigma_phi^2). Sum
/// these over a step's detections and take one exp: cheaper, and no underflow on the way.
inline double landmark_log_likelihood(double x, double y, double theta, double range,
                                      double bearing, double lx, double ly, double sigma_range,
                                      double sigma_bearing) {
  return landmark_log_match(x, y, theta, range, bearing, lx, ly, sigma_range, sigma_bearing) -
         std::log(2.0 * std::numbers::pi * sigma_range * sigma_bearing);
}

/// The same as a density.
inline double landmark_likelihood(double x, double y, double theta, double range, double bearing,
                                  double lx, double ly, double sigma_range, double sigma_bearing) {
  return std::exp(
      landmark_log_likelihood(x, y, theta, range, bearing, lx, ly, sigma_range, sigma_bearing));
}

/// Normalises weights to sum 1; returns their sum before (0: all zero, then they become equal).
inline double normalize(std::vector<double>& w) {
  double sum = 0.0;
  for (const double v : w) sum += v;
  if (!(sum > 0.0) || !std::isfinite(sum)) {
    std::fill(w.begin(), w.end(), w.empty() ? 0.0 : 1.0 / static_cast<double>(w.size()));
    return 0.0;
  }
  for (double& v : w) v /= sum;
  return sum;
}

/// N_eff = 1 / sum w^2 of normalised weights.
inline double effective_sample_size(const std::vector<double>& w) {
  double sq = 0.0;
  for (const double v : w) sq += v * v;
  return sq > 0.0 ? 1.0 / sq : 0.0;
}

/// Roulette-wheel (multinomial) resampling as in the paper: cumulative weights, n independent
/// uniform draws, each finding its particle by binary search. Writes the chosen indices.
inline void roulette_resample(const std::vector<double>& w, Random& random,
                              std::vector<std::size_t>& chosen, std::vector<double>& cumulative) {
  const std::size_t n = w.size();
  cumulative.resize(n);
  double sum = 0.0;
  for (std::size_t i = 0; i < n; ++i) cumulative[i] = sum += w[i];
  chosen.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const double u = random.uniform() * sum;
    chosen[k] = std::min<std::size_t>(
        static_cast<std::size_t>(std::upper_bound(cumulative.begin(), cumulative.end(), u) -
                                 cumulative.begin()),
        n - 1);
  }
}

/// Low-variance (systematic) resampling: one uniform draw, n evenly spaced pointers.
inline void low_variance_resample(const std::vector<double>& w, Random& random,
                                  std::vector<std::size_t>& chosen) {
  const std::size_t n = w.size();
  chosen.resize(n);
  if (n == 0) return;
  double sum = 0.0;
  for (const double v : w) sum += v;
  const double step = sum / static_cast<double>(n);
  double pointer = random.uniform() * step, cumulative = w[0];
  std::size_t i = 0;
  for (std::size_t k = 0; k < n; ++k, pointer += step) {
    while (pointer > cumulative && i + 1 < n) cumulative += w[++i];
    chosen[k] = i;
  }
}

/// Replaces the set by the chosen particles with equal weights (scratch: reused storage).
inline void apply_resample(ParticleSet& p, const std::vector<std::size_t>& chosen,
                           ParticleSet& scratch) {
  scratch.resize(chosen.size());
  for (std::size_t k = 0; k < chosen.size(); ++k) {
    scratch.x[k] = p.x[chosen[k]], scratch.y[k] = p.y[chosen[k]],
    scratch.theta[k] = p.theta[chosen[k]];
  }
  std::swap(p.x, scratch.x), std::swap(p.y, scratch.y), std::swap(p.theta, scratch.theta);
  p.weight.assign(chosen.size(), chosen.empty() ? 0.0 : 1.0 / static_cast<double>(chosen.size()));
}

/// Weighted mean pose (circular mean of the headings) and its covariance (heading deviations
/// taken about the circular mean).
inline void mean_and_covariance(const ParticleSet& p, Pose& mean, Eigen::Matrix3d& covariance) {
  double sw = 0, sx = 0, sy = 0, ss = 0, sc = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double w = p.weight[i];
    sw += w, sx += w * p.x[i], sy += w * p.y[i], ss += w * std::sin(p.theta[i]),
        sc += w * std::cos(p.theta[i]);
  }
  if (!(sw > 0.0)) sw = 1.0;
  mean = {sx / sw, sy / sw, std::atan2(ss, sc)};
  covariance.setZero();
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Eigen::Vector3d d(p.x[i] - mean(0), p.y[i] - mean(1), wrap(p.theta[i] - mean(2)));
    covariance += p.weight[i] / sw * d * d.transpose();
  }
}

}  // namespace locsim::sdk
