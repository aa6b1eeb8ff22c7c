// Particle-filter pieces shared by locsim's particle filters and open to every plugin author:
// a structure-of-arrays particle set, the odometry motion model of the ASRL paper (and Thrun's
// variance form), the landmark likelihood, roulette-wheel and low-variance resampling, the
// effective sample size and circular means. Header-only; deterministic for a given seed.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <optional>
#include <span>
#include <stdexcept>
#include <utility>
#include <vector>

#include "locsim/localizer.h"
#include "locsim/models.hpp"
#include "locsim/random.hpp"
#include "locsim/vector_math.hpp"

namespace locsim::sdk {

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
  /// How much more (or less) the wheels turned than the body (a gyro's measure; 0 without
  /// one): wheels that slipped, whose travel is as doubtful as after that turn [rad].
  double slip_rad = 0.0;
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
  /// Noise a step has whatever its motion (on real data: a robot that creeps while its odometry
  /// stands still, timing; `locsim calibrate` measures it): standard deviations added to the
  /// position along each axis [m] and to the heading [rad] after the motion. 0: none, and no
  /// random draws for it, so that a filter without it keeps its random stream.
  double floor_position_m = 0.0;
  double floor_heading_rad = 0.0;
};

/// The standard deviations of the noise on each part of `d` (the paper's b):
///   rot1: alpha1 |rot1| + alpha2 trans,  trans: alpha4 (|rot1 + rot2| + slip) + alpha3 trans,
///   rot2: alpha1 |rot2| + alpha2 trans  (or the square roots of alpha u^2 + alpha v^2).
/// Reversing decomposes as rot1 ~ +-pi and rot2 ~ -+pi, a half turn the wheels never made: each
/// rotation's noise comes from min(|rot|, pi - |rot|) (as ROS amcl's odometry model), so that
/// driving backwards is as noisy as driving forwards, and rot1 + rot2 is wrapped.
inline OdometryDelta motion_spread(const OdometryDelta& d, const OdometryNoise& n) {
  const auto spread = [&](double a, double u, double b, double v) {
    return n.variance_form ? std::sqrt(a * u * u + b * v * v) : a * std::abs(u) + b * std::abs(v);
  };
  const auto turned = [](double rot) {
    return std::min(std::abs(rot), std::numbers::pi - std::abs(rot));
  };
  return {spread(n.alpha1, turned(d.rot1), n.alpha2, d.trans),
          spread(n.alpha4, std::abs(wrap(d.rot1 + d.rot2)) + d.slip_rad, n.alpha3, d.trans),
          spread(n.alpha1, turned(d.rot2), n.alpha2, d.trans)};
}

/// One noisy version of `d` (the paper's sample_motion_model_odometry).
inline OdometryDelta sample_delta(const OdometryDelta& d, const OdometryNoise& n, Random& random) {
  const OdometryDelta s = motion_spread(d, n);
  const double rot1 = d.rot1 + random.normal(s.rot1);
  const double trans = d.trans + random.normal(s.trans);
  return {rot1, trans, d.rot2 + random.normal(s.rot2)};
}

/// Adds the noise every step has whatever its motion (OdometryNoise::floor_*) to every particle.
inline void add_motion_floor(ParticleSet& p, const OdometryNoise& n, Random& random) {
  if (n.floor_position_m > 0.0) {
    for (std::size_t i = 0; i < p.size(); ++i) {
      p.x[i] += random.normal(n.floor_position_m);
      p.y[i] += random.normal(n.floor_position_m);
    }
  }
  if (n.floor_heading_rad > 0.0) {
    for (std::size_t i = 0; i < p.size(); ++i)
      p.theta[i] = wrap(p.theta[i] + random.normal(n.floor_heading_rad));
  }
}

/// The body's side slip (side_slip_covariance) for a step of `distance_m`: each particle moved
/// across its own heading by a draw of N(0, k^2 |d|). Draws nothing when k or the step is 0.
inline void add_side_slip(ParticleSet& p, double distance_m, double k, Random& random) {
  if (k <= 0.0 || distance_m == 0.0) return;
  const double sigma = k * std::sqrt(std::abs(distance_m));
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double across = random.normal(sigma);
    p.x[i] -= std::sin(p.theta[i]) * across;
    p.y[i] += std::cos(p.theta[i]) * across;
  }
}

/// Moves every particle by its own noisy sample of `d` (the spreads are the same for all).
inline void sample_motion(ParticleSet& p, const OdometryDelta& d, const OdometryNoise& n,
                          Random& random) {
  const OdometryDelta s = motion_spread(d, n);
  // Per block of particles: the noise drawn particle after particle (rot1, trans, rot2: the
  // random stream's order does not depend on the block size), then the sines and cosines of the
  // new headings in one vector pass, which costs a fifth of a sincos call per particle.
  constexpr std::size_t kBlock = 256;
  std::array<double, kBlock> heading, trans, rot2, sin_h, cos_h;
  for (std::size_t start = 0; start < p.size(); start += kBlock) {
    const std::size_t m = std::min(kBlock, p.size() - start);
    for (std::size_t k = 0; k < m; ++k) {
      const double rot1 = d.rot1 + random.normal(s.rot1);
      trans[k] = d.trans + random.normal(s.trans);
      rot2[k] = d.rot2 + random.normal(s.rot2);
      heading[k] = p.theta[start + k] + rot1;
    }
    vector_math::sincos(std::span(heading).first(m), std::span(sin_h).first(m),
                        std::span(cos_h).first(m));
    for (std::size_t k = 0; k < m; ++k) {
      const std::size_t i = start + k;
      p.x[i] += trans[k] * cos_h[k];
      p.y[i] += trans[k] * sin_h[k];
      p.theta[i] = wrap(heading[k] + rot2[k]);
    }
  }
  add_motion_floor(p, n, random);
}

/// Moves every particle by its own noisy sample of one step of wheel travel (dl, dr) [m]:
/// paper 002's wheel model, each wheel's travel drawn with variance k^2 |d| (k [m^1/2]), then
/// diff_drive_motion. Unlike the per-step alphas its noise adds up the same whatever the step
/// length, so a filter may apply it at every odometry reading. `slip_m`: travel the wheels
/// slipped by (OdometryStep::slip_rad times half the wheel base), a spread added to each wheel's.
inline void sample_wheel_motion(ParticleSet& p, double d_left_m, double d_right_m,
                                double wheel_base_m, double k_left, double k_right, Random& random,
                                double slip_m = 0.0) {
  const auto spread = [&](double k, double d) {
    return slip_m == 0.0 ? k * std::sqrt(std::abs(d))
                         : std::sqrt(k * k * std::abs(d) + slip_m * slip_m);
  };
  const double spread_left = spread(k_left, d_left_m);
  const double spread_right = spread(k_right, d_right_m);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double dl = d_left_m + random.normal(spread_left);
    const double dr = d_right_m + random.normal(spread_right);
    const Pose moved = diff_drive_motion(Pose(p.x[i], p.y[i], p.theta[i]), dl, dr, wheel_base_m);
    p.x[i] = moved(0), p.y[i] = moved(1), p.theta[i] = moved(2);
  }
}

/// Each particle's own gain errors (GainWander): a hypothesis about how far the base's gains are
/// off, weighed with its pose; resample them with the particles (ParticleFilter::resample(v,
/// omega)) and draw a new particle's from the prior (draw()).
struct ParticleGains {
  std::vector<double> v, omega;
  /// One particle's gains from the process's stationary distribution N(0, sigma^2).
  std::pair<double, double> draw(const GainWander& wander, Random& random) const {
    const double g_v = random.normal(wander.sigma_v);
    return {g_v, random.normal(wander.sigma_omega)};
  }
  /// As many as `n` particles, the new ones drawn from the prior.
  void fit(std::size_t n, const GainWander& wander, Random& random) {
    while (v.size() < n) {
      const auto [g_v, g_omega] = draw(wander, random);
      v.push_back(g_v), omega.push_back(g_omega);
    }
    v.resize(n), omega.resize(n);
  }
};

/// sample_wheel_motion for a base whose gains wander: each particle's gains first move on by
/// dt_s of their process; its noisy wheel travel (as sample_wheel_motion draws it) is then scaled
/// by them (wheels_with_gains), as predict_by_wheels_and_gains predicts.
inline void sample_wheel_motion(ParticleSet& p, ParticleGains& gains, const GainWander& wander,
                                double dt_s, double d_left_m, double d_right_m, double wheel_base_m,
                                double k_left, double k_right, Random& random,
                                double slip_m = 0.0) {
  gains.fit(p.size(), wander, random);
  const double phi = wander.phi(dt_s), renewal = std::sqrt(1.0 - phi * phi);
  const double step_v = wander.sigma_v * renewal, step_omega = wander.sigma_omega * renewal;
  const double spread_left = std::sqrt(k_left * k_left * std::abs(d_left_m) + slip_m * slip_m);
  const double spread_right = std::sqrt(k_right * k_right * std::abs(d_right_m) + slip_m * slip_m);
  for (std::size_t i = 0; i < p.size(); ++i) {
    gains.v[i] = phi * gains.v[i] + random.normal(step_v);
    gains.omega[i] = phi * gains.omega[i] + random.normal(step_omega);
    const double left = d_left_m + random.normal(spread_left);
    const double right = d_right_m + random.normal(spread_right);
    const auto [dl, dr] = wheels_with_gains(left, right, gains.v[i], gains.omega[i]);
    const Pose moved = diff_drive_motion(Pose(p.x[i], p.y[i], p.theta[i]), dl, dr, wheel_base_m);
    p.x[i] = moved(0), p.y[i] = moved(1), p.theta[i] = moved(2);
  }
}

/// log of the landmark likelihood below scaled to 1 at a perfect match:
///   -e_r^2 / (2 sigma_r^2) - (1 - cos e_phi) / sigma_phi^2,
/// e_r = r - r^ the range error, e_phi = phi - phi^ the bearing error. The bearing term is the
/// von Mises density with concentration 1 / sigma_phi^2, the circle's own normal: periodic with
/// no wrapping, within 1 % of the Gaussian's e^2 / (2 sigma^2) up to 14 degrees of error, and
/// computed from a dot product where the Gaussian needs an atan2 (the batch form below is the
/// inner loop of a landmark particle filter). A mean of these is dimensionless, so a threshold on
/// it (SRL, ASRL's p_t) means the same whatever the units and noise levels.
inline double landmark_log_match(double x, double y, double theta, double range, double bearing,
                                 double lx, double ly, double sigma_range, double sigma_bearing) {
  const double dx = lx - x, dy = ly - y;
  const double r = std::sqrt(dx * dx + dy * dy);
  // cos e_phi = u . (d / r), u the measured direction in the world (heading + bearing).
  const double ux = std::cos(theta + bearing), uy = std::sin(theta + bearing);
  const double cos_error = r > 0.0 ? (ux * dx + uy * dy) / r : 0.0;
  const double er = (range - r) / sigma_range;
  return -0.5 * er * er - (1.0 - cos_error) / (sigma_bearing * sigma_bearing);
}

/// log of the von Mises normaliser relative to the Gaussian's: log(2 pi I0(k) e^-k) -
/// log(sqrt(2 pi / k)), k = 1 / sigma^2; tends to 0 as sigma shrinks (1e-4 at 2 degrees).
inline double von_mises_log_normaliser_excess(double sigma) {
  const double k = 1.0 / (sigma * sigma);
  // log(I0(k) e^-k): its power series sum_j (k^2 / 4)^j / (j!)^2 for small k, else the
  // asymptotic series (relative error below 1e-5 from k = 15). Written out: libc++ has no
  // std::cyl_bessel_i.
  double log_scaled_i0;
  if (k < 15.0) {
    double term = 1.0, sum = 1.0;
    for (int j = 1; j < 80; ++j) sum += term *= 0.25 * k * k / (j * j);
    log_scaled_i0 = std::log(sum) - k;
  } else {
    log_scaled_i0 =
        -0.5 * std::log(2.0 * std::numbers::pi * k) +
        std::log1p(1.0 / (8.0 * k) + 9.0 / (128.0 * k * k) + 225.0 / (3072.0 * k * k * k));
  }
  return std::log(2.0 * std::numbers::pi) + log_scaled_i0 -
         0.5 * std::log(2.0 * std::numbers::pi / k);
}

/// log p(z | x, m) for one range-bearing detection of a landmark at (lx, ly): a normal density
/// N(r - r^; 0, sigma_r^2) on the range times the von Mises density on the bearing (above). Sum
/// these over a step's detections and take one exp: cheaper, and no underflow on the way.
inline double landmark_log_likelihood(double x, double y, double theta, double range,
                                      double bearing, double lx, double ly, double sigma_range,
                                      double sigma_bearing) {
  return landmark_log_match(x, y, theta, range, bearing, lx, ly, sigma_range, sigma_bearing) -
         std::log(2.0 * std::numbers::pi * sigma_range * sigma_bearing) -
         von_mises_log_normaliser_excess(sigma_bearing);
}

/// The same as a density.
inline double landmark_likelihood(double x, double y, double theta, double range, double bearing,
                                  double lx, double ly, double sigma_range, double sigma_bearing) {
  return std::exp(
      landmark_log_likelihood(x, y, theta, range, bearing, lx, ly, sigma_range, sigma_bearing));
}

/// Each particle's heading as a unit vector, computed once per step for the batch likelihoods.
struct Headings {
  std::vector<double> cos, sin;
  void compute(const ParticleSet& p) {
    cos.resize(p.size()), sin.resize(p.size());
    vector_math::sincos(p.theta, sin, cos);
  }
};

/// landmark_log_match for every particle at once, into `out` (resized): Eigen's packet maths,
/// so it vectorises whatever the compiler flags. `headings` must be computed for `p`.
inline void landmark_log_match(const ParticleSet& p, const Headings& headings, double range,
                               double bearing, double lx, double ly, double sigma_range,
                               double sigma_bearing, std::vector<double>& out) {
  using Array = Eigen::ArrayXd;
  const auto n = static_cast<Eigen::Index>(p.size());
  out.resize(p.size());
  const Eigen::Map<const Array> x(p.x.data(), n), y(p.y.data(), n), c(headings.cos.data(), n),
      s(headings.sin.data(), n);
  Eigen::Map<Array> log_match(out.data(), n);
  const double cb = std::cos(bearing), sb = std::sin(bearing);
  // Two passes so that the square root is taken once: out holds r, then the log match.
  log_match = ((lx - x).square() + (ly - y).square()).sqrt();
  const double inv_sr = 1.0 / sigma_range, kappa = 1.0 / (sigma_bearing * sigma_bearing);
  // u = (cos(theta + phi), sin(theta + phi)) by the angle-sum identities; cos e = u . d / r.
  log_match = -0.5 * ((range - log_match) * inv_sr).square() -
              kappa * (1.0 - ((c * cb - s * sb) * (lx - x) + (s * cb + c * sb) * (ly - y)) /
                                 log_match.max(1e-300));
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

/// Roulette-wheel (multinomial) resampling as in the paper: n independent draws, each picking
/// particle i with probability w_i. The draws are generated already sorted (the normalised partial
/// sums of n + 1 exponentials are n sorted uniforms), so one pass along the cumulative weights
/// finds them all: O(n) instead of a binary search per draw, the same distribution. Writes the
/// chosen indices, ascending; `spacings` is reused storage.
inline void roulette_resample(const std::vector<double>& w, Random& random,
                              std::vector<std::size_t>& chosen, std::vector<double>& spacings) {
  const std::size_t n = w.size();
  chosen.resize(n);
  if (n == 0) return;
  spacings.resize(n + 1);
  double partial = 0.0;
  for (double& e : spacings) e = partial += random.exponential();
  double sum = 0.0;
  for (const double v : w) sum += v;
  const double scale = sum / partial;  // maps the partial sums onto [0, sum of weights)
  double cumulative = w[0];
  std::size_t i = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double u = spacings[k] * scale;
    while (u >= cumulative && i + 1 < n) cumulative += w[++i];
    chosen[k] = i;
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

/// Systematic draws for a count not known in advance (KLD sampling stops when the draws cover
/// enough bins): the k-th draw takes the pointer u + v(k) (mod 1) along the cumulative weights,
/// v the base-2 van der Corput sequence (0, 1/2, 1/4, 3/4, ...), so that every prefix of the draws
/// is spread evenly over all the weights, as a low-variance comb of that many teeth would be.
/// A comb of max_particles teeth walked in order and stopped early draws only from the head of
/// the set: the particles at its end (the newest guesses, the mode resampled last) were never
/// drawn (amcl lost a recovered truth to its twin that way).
class OpenEndedDraws {
 public:
  OpenEndedDraws() = default;
  /// Over `cumulative` (the running sums of the weights, the last their total), with one uniform
  /// offset u in [0, 1).
  OpenEndedDraws(const std::vector<double>& cumulative, double u) { reset(cumulative, u); }
  /// Starts the draws again over `cumulative` (kept by reference: it must outlive the draws),
  /// keeping the guide table's storage.
  void reset(const std::vector<double>& cumulative, double u) {
    cumulative_ = cumulative.data(), n_ = cumulative.size(), u_ = u, k_ = 0;
    if (n_ == 0) return;
    total_ = cumulative.back();
    // A guide table (Chen and Asau, 1974): the total cut into n equal buckets, and per bucket j
    // the first particle whose running sum lies in bucket j or later. A draw's particle is then
    // between the guides of its bucket and the next, one or two candidates on average, where a
    // binary search over all of them took log2 n dependent loads (half of AMCL's resampling).
    scale_ = static_cast<double>(n_) / total_;
    guide_.resize(n_ + 1);
    std::size_t j = 0;
    for (std::size_t i = 0; i < n_; ++i) {
      const std::size_t b = bucket(cumulative_[i]);
      while (j <= b) guide_[j++] = i;
    }
    while (j <= n_) guide_[j++] = n_;
  }
  /// The next draw's particle index: the first whose running sum exceeds the pointer (as
  /// std::upper_bound finds it), the last if none does.
  std::size_t next() {
    if (n_ == 0) return 0;
    double v = u_ + radical_inverse(k_++);
    if (v >= 1.0) v -= 1.0;
    const double pointer = v * total_;
    // The answer is in [guide[j], guide[j + 1]]: a running sum before guide[j] lies in an earlier
    // bucket than the pointer, so is not above it, and the one at guide[j + 1] in a later bucket,
    // so above it (bucket() never decreases as its argument grows).
    const std::size_t j = bucket(pointer);
    const std::size_t lo = std::min(guide_[j], n_ - 1), hi = std::min(guide_[j + 1], n_ - 1);
    // std::upper_bound over [lo, hi] without branches: the draws jump about the weights, and a
    // mispredicted branch per halving cost more than the comparisons.
    const double* first = cumulative_ + lo;
    std::size_t length = hi - lo + 1;
    while (length > 1) {
      const std::size_t half = length / 2;
      first = first[half - 1] <= pointer ? first + half : first;
      length -= half;
    }
    const auto index =
        static_cast<std::size_t>(first - cumulative_) + (*first <= pointer ? 1u : 0u);
    return std::min(index, n_ - 1);
  }
  /// Base-2 radical inverse of k: its bits mirrored about the binary point.
  static double radical_inverse(std::uint64_t k) {
    // The bits mirrored by swapping ever larger halves: six steps instead of 64.
    k = ((k >> 1) & 0x5555555555555555ull) | ((k & 0x5555555555555555ull) << 1);
    k = ((k >> 2) & 0x3333333333333333ull) | ((k & 0x3333333333333333ull) << 2);
    k = ((k >> 4) & 0x0F0F0F0F0F0F0F0Full) | ((k & 0x0F0F0F0F0F0F0F0Full) << 4);
    k = ((k >> 8) & 0x00FF00FF00FF00FFull) | ((k & 0x00FF00FF00FF00FFull) << 8);
    k = ((k >> 16) & 0x0000FFFF0000FFFFull) | ((k & 0x0000FFFF0000FFFFull) << 16);
    k = (k >> 32) | (k << 32);
    return static_cast<double>(k >> 11) * 0x1.0p-53;  // the top 53 bits: exact in a double
  }

 private:
  /// The bucket of a value in [0, total]: non-decreasing in it, n - 1 at most (NaN there too).
  std::size_t bucket(double value) const {
    const double scaled = value * scale_;
    return scaled < static_cast<double>(n_) ? static_cast<std::size_t>(std::max(scaled, 0.0))
                                            : n_ - 1;
  }

  const double* cumulative_ = nullptr;
  std::size_t n_ = 0;
  double u_ = 0.0, total_ = 0.0, scale_ = 0.0;
  std::uint64_t k_ = 0;
  std::vector<std::size_t> guide_;  // n + 1 entries, the last n
};

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

/// The standard normal quantile: z with P(Z <= z) = p, 0 < p < 1 (Acklam's rational
/// approximation, then one Halley step on erfc: full double precision). normal_quantile(0.99) is
/// 2.3263: the z of KLD sampling for a 99 % bound (not 0.99 itself, as some AMCLs pass).
inline double normal_quantile(double p) {
  if (!(p > 0.0 && p < 1.0)) return std::numeric_limits<double>::quiet_NaN();
  static constexpr double a[] = {-3.969683028665376e+01, 2.209460984245205e+02,
                                 -2.759285104469687e+02, 1.383577518672690e+02,
                                 -3.066479806614716e+01, 2.506628277459239e+00};
  static constexpr double b[] = {-5.447609879822406e+01, 1.615858368580409e+02,
                                 -1.556989798598866e+02, 6.680131188771972e+01,
                                 -1.328068155288572e+01};
  static constexpr double c[] = {-7.784894002430293e-03, -3.223964580411365e-01,
                                 -2.400758277161838e+00, -2.549732539343734e+00,
                                 4.374664141464968e+00,  2.938163982698783e+00};
  static constexpr double d[] = {7.784695709041462e-03, 3.224671290700398e-01,
                                 2.445134137142996e+00, 3.754408661907416e+00};
  constexpr double low = 0.02425;
  double x;
  if (p < low || p > 1.0 - low) {
    const double q = std::sqrt(-2.0 * std::log(p < low ? p : 1.0 - p));
    x = (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
        ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0);
    if (p > 1.0 - low) x = -x;
  } else {
    const double q = p - 0.5, r = q * q;
    x = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
        (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0);
  }
  const double e = 0.5 * std::erfc(-x / std::numbers::sqrt2) - p;
  const double u = e * std::sqrt(2.0 * std::numbers::pi) * std::exp(0.5 * x * x);
  return x - u / (1.0 + 0.5 * x * u);
}

/// KLD sampling's bound (Fox 2003): the particles needed so that, with probability 1 - delta,
/// the KL divergence between the sample-based and the true posterior over k occupied bins stays
/// below epsilon: (k - 1) / (2 epsilon) (1 - 2 / (9 (k - 1)) + sqrt(2 / (9 (k - 1))) z)^3,
/// z = normal_quantile(1 - delta). One bin: 1.
inline std::size_t kld_sample_count(std::size_t bins, double epsilon, double z) {
  if (bins <= 1) return 1;
  const double k = static_cast<double>(bins - 1);
  const double a = 2.0 / (9.0 * k);
  const double c = 1.0 - a + std::sqrt(a) * z;
  return static_cast<std::size_t>(std::ceil(k / (2.0 * epsilon) * c * c * c));
}

/// A pose's (x, y, heading) bin: cells of the bin size in x and y, and in heading.
struct PoseBin {
  std::int64_t x = 0, y = 0, theta = 0;
  bool operator==(const PoseBin&) const = default;
};

/// The distinct bins that poses fall in, numbered in the order first seen: what KLD sampling
/// counts (Fox 2003) and clustering joins to its neighbours. An open-addressing table with linear
/// probing over a flat array: adding a particle is a hash, a probe or two and no allocation, where
/// a node-based std::unordered_map allocated per new bin and chased pointers (a quarter of AMCL's
/// update at 5 000 particles). Numbering by first sight, not the table's order, keeps everything
/// that walks the bins independent of the hash.
class PoseBins {
 public:
  static constexpr std::size_t kNone = SIZE_MAX;

  PoseBins(double bin_xy_m, double bin_theta_rad)
      : bin_xy_m_(bin_xy_m), bin_theta_rad_(bin_theta_rad) {}

  /// The bin of the pose (x, y, theta), theta wrapped first.
  PoseBin bin_of(double x, double y, double theta) const {
    return {static_cast<std::int64_t>(std::floor(x / bin_xy_m_)),
            static_cast<std::int64_t>(std::floor(y / bin_xy_m_)),
            static_cast<std::int64_t>(std::floor(wrap(theta) / bin_theta_rad_))};
  }
  double bin_theta_rad() const { return bin_theta_rad_; }

  /// The bin's number, and whether it was new.
  std::pair<std::size_t, bool> insert(const PoseBin& bin) {
    if (2 * (bins_.size() + 1) > slots_.size()) grow();
    std::size_t slot = hash(bin) & (slots_.size() - 1);
    for (;; slot = (slot + 1) & (slots_.size() - 1)) {
      const std::uint32_t held = slots_[slot];
      if (held == 0) break;
      if (bins_[held - 1] == bin) return {held - 1, false};
    }
    bins_.push_back(bin);
    slots_[slot] = static_cast<std::uint32_t>(bins_.size());
    return {bins_.size() - 1, true};
  }
  /// The bin's number, or kNone if no pose fell in it.
  std::size_t find(const PoseBin& bin) const {
    if (slots_.empty()) return kNone;
    for (std::size_t slot = hash(bin) & (slots_.size() - 1);;
         slot = (slot + 1) & (slots_.size() - 1)) {
      const std::uint32_t held = slots_[slot];
      if (held == 0) return kNone;
      if (bins_[held - 1] == bin) return held - 1;
    }
  }
  std::size_t size() const { return bins_.size(); }
  /// The bins by number.
  const std::vector<PoseBin>& bins() const { return bins_; }
  /// Forgets every bin (the table keeps its size: the next use fills it alike).
  void clear() {
    bins_.clear();
    std::fill(slots_.begin(), slots_.end(), 0u);
  }

 private:
  static std::size_t hash(const PoseBin& b) {
    // Each coordinate through a different odd multiplier, then the high bits folded down
    // (neighbouring bins differ in their low bits only).
    std::uint64_t h = static_cast<std::uint64_t>(b.x) * 0x9E3779B97F4A7C15ull ^
                      static_cast<std::uint64_t>(b.y) * 0xC2B2AE3D27D4EB4Full ^
                      static_cast<std::uint64_t>(b.theta) * 0x165667B19E3779F9ull;
    h ^= h >> 29;
    h *= 0xBF58476D1CE4E5B9ull;
    return static_cast<std::size_t>(h ^ (h >> 32));
  }
  void grow() {
    if (bins_.size() >= std::numeric_limits<std::uint32_t>::max() / 2)
      throw std::length_error("PoseBins: too many bins");
    slots_.assign(std::max<std::size_t>(64, 2 * slots_.size()), 0u);
    for (std::size_t i = 0; i < bins_.size(); ++i) {
      std::size_t slot = hash(bins_[i]) & (slots_.size() - 1);
      while (slots_[slot] != 0) slot = (slot + 1) & (slots_.size() - 1);
      slots_[slot] = static_cast<std::uint32_t>(i + 1);
    }
  }

  double bin_xy_m_, bin_theta_rad_;
  std::vector<PoseBin> bins_;
  std::vector<std::uint32_t> slots_;  // 0: empty; else the bin's number + 1
};

/// Weighted mean pose (circular mean of the headings) and its covariance (heading deviations
/// taken about the circular mean), of the first `count` particles (all by default).
inline void mean_and_covariance(const ParticleSet& p, Pose& mean, Eigen::Matrix3d& covariance,
                                std::size_t count = SIZE_MAX) {
  const std::size_t n = std::min(count, p.size());
  double sw = 0, sx = 0, sy = 0, ss = 0, sc = 0;
  constexpr std::size_t kBlock = 256;
  std::array<double, kBlock> sin_t, cos_t;
  for (std::size_t start = 0; start < n; start += kBlock) {
    const std::size_t m = std::min(kBlock, n - start);
    vector_math::sincos(std::span(p.theta).subspan(start, m), std::span(sin_t).first(m),
                        std::span(cos_t).first(m));
    for (std::size_t k = 0; k < m; ++k) {
      const double w = p.weight[start + k];
      sw += w, sx += w * p.x[start + k], sy += w * p.y[start + k], ss += w * sin_t[k],
          sc += w * cos_t[k];
    }
  }
  if (!(sw > 0.0)) sw = 1.0;
  mean = {sx / sw, sy / sw, std::atan2(ss, sc)};
  // Sum of (w / sw) d d^T, each entry summed in a local: summed in `covariance`, every particle
  // stored and reloaded all nine (most of the function's time at 5000 particles, by perf).
  std::array<double, 9> sum{};  // row-major
  for (std::size_t i = 0; i < n; ++i) {
    const std::array<double, 3> d = {p.x[i] - mean(0), p.y[i] - mean(1),
                                     wrap(p.theta[i] - mean(2))};
    const double share = p.weight[i] / sw;
    for (std::size_t r = 0; r < 3; ++r) {
      const double scaled = share * d[r];
      for (std::size_t c = 0; c < 3; ++c) sum[3 * r + c] += scaled * d[c];
    }
  }
  for (std::size_t r = 0; r < 3; ++r)
    for (std::size_t c = 0; c < 3; ++c)
      covariance(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c)) = sum[3 * r + c];
}

/// The clusters of a particle set: particles binned (PoseBins), occupied bins joined to their 26
/// neighbours (headings wrapping round), each cluster's weight and weighted mean. A set split
/// between two places (a recovery's guesses beside the belief, a symmetric room) has a mean
/// between them, where no particle is; a cluster's mean is one of the places (AMCL's estimate is
/// the heaviest cluster's, nav2 pf_cluster_stats). Buffers are kept from call to call: no
/// allocation once warm.
class ParticleClusters {
 public:
  static constexpr std::size_t kNone = PoseBins::kNone;

  /// Bins the first `counted` particles (the rest neither weigh nor bridge clusters) into `bins`
  /// (cleared first) and joins them.
  void compute(const ParticleSet& particles, std::size_t counted, PoseBins& bins) {
    const std::size_t n = particles.size();
    bins.clear();
    particle_bin_.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      particle_bin_[i] =
          i < counted
              ? bins.insert(bins.bin_of(particles.x[i], particles.y[i], particles.theta[i])).first
              : kNone;
    compute_binned(particles, bins, particle_bin_);
  }

  /// The same with the particles already binned: `particle_bin[i]` the number in `bins` of
  /// particle i's bin, kNone for one left out.
  void compute_binned(const ParticleSet& particles, const PoseBins& bins,
                      const std::vector<std::size_t>& particle_bin) {
    const std::size_t n = particles.size();
    // Union-find over the bins and their neighbours. A cluster's root is its lowest-numbered bin
    // (the first a particle fell in), whatever the order of the joins: the tie-break between
    // equally heavy clusters below is then the particles' order, not the hash table's.
    parent_.resize(bins.size());
    for (std::size_t b = 0; b < parent_.size(); ++b) parent_[b] = b;
    const auto root = [&](std::size_t b) {
      while (parent_[b] != b) b = parent_[b] = parent_[parent_[b]];
      return b;
    };
    const double bin_theta_rad = bins.bin_theta_rad();
    const auto theta_bins =
        static_cast<std::int64_t>(std::ceil(2.0 * std::numbers::pi / bin_theta_rad));
    const auto low_theta = static_cast<std::int64_t>(std::floor(-std::numbers::pi / bin_theta_rad));
    for (std::size_t index = 0; index < bins.size(); ++index) {
      const PoseBin bin = bins.bins()[index];
      for (std::int64_t dx = -1; dx <= 1; ++dx)
        for (std::int64_t dy = -1; dy <= 1; ++dy)
          for (std::int64_t dt = -1; dt <= 1; ++dt) {
            PoseBin other{bin.x + dx, bin.y + dy, bin.theta + dt};
            // Headings wrap around.
            if (other.theta < low_theta) other.theta += theta_bins;
            if (other.theta >= low_theta + theta_bins) other.theta -= theta_bins;
            const std::size_t found = bins.find(other);
            if (found == PoseBins::kNone) continue;
            const std::size_t a = root(index), b = root(found);
            parent_[std::max(a, b)] = std::min(a, b);
          }
    }
    particle_cluster_.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      particle_cluster_[i] = particle_bin[i] == kNone ? kNone : root(particle_bin[i]);
    weight_.assign(bins.size(), 0.0);
    // A run of particles in one cluster (resampled copies sit side by side) summed in a local
    // and stored once: the same sums in the same order, without a store and reload per particle.
    std::size_t current = kNone;
    double current_weight = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t cluster = particle_cluster_[i];
      if (cluster == kNone) continue;
      if (cluster != current) {
        if (current != kNone) weight_[current] = current_weight;
        current = cluster, current_weight = weight_[cluster];
      }
      current_weight += particles.weight[i];
    }
    if (current != kNone) weight_[current] = current_weight;
    // Each cluster's centre: weighted mean position and circular mean heading, in one pass.
    sums_.assign(4 * bins.size(), 0.0);
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t cluster = particle_cluster_[i];
      if (cluster == kNone) continue;
      const double w = particles.weight[i];
      double* sum = &sums_[4 * cluster];
      sum[0] += w * particles.x[i], sum[1] += w * particles.y[i];
      sum[2] += w * std::cos(particles.theta[i]), sum[3] += w * std::sin(particles.theta[i]);
    }
    heaviest_ = weight_.empty()
                    ? kNone
                    : static_cast<std::size_t>(std::max_element(weight_.begin(), weight_.end()) -
                                               weight_.begin());
  }

  /// The heaviest cluster (kNone when no particle was counted).
  std::size_t heaviest() const { return heaviest_; }
  /// A cluster's total weight (of the counted particles' weights as they are); 0 for a number
  /// that is no cluster's.
  double weight(std::size_t cluster) const {
    return cluster < weight_.size() ? weight_[cluster] : 0.0;
  }
  /// The clusters' numbers in increasing order (a cluster is numbered by its first bin).
  template <class F>
  void for_each(F&& f) const {
    for (std::size_t c = 0; c < weight_.size(); ++c)
      if (parent_[c] == c && weight_[c] > 0.0) f(c);
  }

  /// A cluster's weighted mean position and circular mean heading (the origin for a cluster of
  /// weight 0).
  Pose centre(std::size_t cluster) const {
    const double w = weight(cluster);
    if (!(w > 0.0)) return Pose::Zero();
    const double* sum = &sums_[4 * cluster];
    return {sum[0] / w, sum[1] / w, std::atan2(sum[3], sum[2])};
  }

  /// A cluster's weighted mean (circular in heading) and covariance.
  void moments(const ParticleSet& particles, std::size_t cluster, Pose& mean,
               Eigen::Matrix3d& covariance) const {
    members_.resize(0);
    for (std::size_t i = 0; i < particles.size(); ++i) {
      if (particle_cluster_[i] != cluster) continue;
      members_.x.push_back(particles.x[i]), members_.y.push_back(particles.y[i]),
          members_.theta.push_back(particles.theta[i]),
          members_.weight.push_back(particles.weight[i]);
    }
    mean_and_covariance(members_, mean, covariance);
  }

 private:
  std::vector<std::size_t> particle_bin_, parent_, particle_cluster_;
  std::vector<double> weight_, sums_;  // sums_: per cluster, w x, w y, w cos, w sin
  std::size_t heaviest_ = kNone;
  mutable ParticleSet members_;
};

/// The estimate of a particle filter that does not leap to a new place on one update's say: the
/// mode it reported (the cluster nearest its last estimate moved by the odometry since, or, when
/// no particle is left there, that pose itself) is kept until another cluster has been the
/// heaviest, in the same place, for `switch_updates` updates in a row, or holds `switch_share` of
/// the two's weight (when the reported mode has no particle left, persistence alone counts). A set
/// split between the belief and a recovery's guesses (a push the filter did not see, a false
/// detection reset on) reports the belief until the evidence has settled; a kidnapped robot's new
/// place wins a few updates later. The mean reported is that of every particle within the gate of
/// the mode's centre; the covariance is the second moment of every counted particle about it: a
/// strong rival widens it, so the ellipse says the filter is unsure while it is.
class StableMode {
 public:
  struct Settings {
    int switch_updates = 6;     // updates in a row a rival must be the heaviest cluster [-]
    double switch_share = 0.9;  // a rival holding this share of the weight wins at once [-]
    double gate_m = 1.0;        // the reported mode, the same rival: within this... [m]
    double gate_rad = 0.5235987755982988;  // ...and this (30 deg) [rad]
  };
  StableMode() = default;
  explicit StableMode(const Settings& settings) : settings_(settings) {}

  /// After an update: `held`, the last estimate moved by the odometry since (none at the first
  /// update: the heaviest cluster wins).
  void update(const ParticleSet& particles, std::size_t counted, PoseBins& bins,
              const std::optional<Pose>& held) {
    clusters_.compute(particles, counted, bins);
    choose(particles, counted, held);
  }

  /// The clusters update() computes; a filter that bins its particles anyway (AMCL's KLD
  /// sampling) computes them itself (compute_binned) and then calls choose().
  ParticleClusters& clusters() { return clusters_; }

  /// update()'s choice, on the clusters as computed.
  void choose(const ParticleSet& particles, std::size_t counted, const std::optional<Pose>& held) {
    const std::size_t heaviest = clusters_.heaviest();
    if (heaviest == ParticleClusters::kNone) return;
    const auto near = [&](const Pose& a, const Pose& b) {
      return std::hypot(a(0) - b(0), a(1) - b(1)) <= settings_.gate_m &&
             std::abs(wrap(a(2) - b(2))) <= settings_.gate_rad;
    };
    // The reported mode: the heaviest cluster near the held estimate.
    std::size_t kept = ParticleClusters::kNone;
    if (held) {
      clusters_.for_each([&](std::size_t c) {
        if (near(clusters_.centre(c), *held) &&
            (kept == ParticleClusters::kNone || clusters_.weight(c) > clusters_.weight(kept)))
          kept = c;
      });
    }
    const Pose rival = clusters_.centre(heaviest);
    bool keep = false;
    if (held && kept != heaviest) {
      rival_updates_ = rival_ && near(rival, *rival_) ? rival_updates_ + 1 : 1;
      rival_ = rival;
      // With no particle left where the reported mode was, one update's weights say little (a
      // mirror pose in a symmetric room can take nine tenths of them): only persistence counts.
      const bool outweighs =
          kept != ParticleClusters::kNone &&
          clusters_.weight(heaviest) >=
              settings_.switch_share * (clusters_.weight(heaviest) + clusters_.weight(kept));
      keep = rival_updates_ < settings_.switch_updates && !outweighs;
    }
    if (!keep) {
      rival_updates_ = 0;
      rival_.reset();
    }
    const std::size_t n = std::min(counted, particles.size());
    if (keep && kept == ParticleClusters::kNone) {
      mean_ = *held;  // nothing left where it was: that pose, as unsure as the particles say
    } else {
      // The mean of every particle within the gate of the mode's centre: of a wide but single
      // cloud, which bins split into fragments, the whole cloud's mean, not a fragment's.
      const Pose centre = clusters_.centre(keep ? kept : heaviest);
      double sw = 0.0, sx = 0.0, sy = 0.0, sc = 0.0, ss = 0.0;
      for (std::size_t i = 0; i < n; ++i) {
        const Pose p{particles.x[i], particles.y[i], particles.theta[i]};
        if (!near(p, centre)) continue;
        const double w = particles.weight[i];
        sw += w, sx += w * p(0), sy += w * p(1), sc += w * std::cos(p(2)), ss += w * std::sin(p(2));
      }
      mean_ = sw > 0.0 ? Pose(sx / sw, sy / sw, std::atan2(ss, sc)) : centre;
    }
    if (const auto spread = second_moment(particles, counted, mean_)) covariance_ = *spread;
  }

  /// The weighted second moment of the first `counted` particles about `about` (headings wrapped
  /// about it); none when they weigh nothing.
  static std::optional<Eigen::Matrix3d> second_moment(const ParticleSet& particles,
                                                      std::size_t counted, const Pose& about) {
    double sw = 0.0;
    Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
    for (std::size_t i = 0; i < std::min(counted, particles.size()); ++i) {
      const Eigen::Vector3d d(particles.x[i] - about(0), particles.y[i] - about(1),
                              wrap(particles.theta[i] - about(2)));
      sum += particles.weight[i] * d * d.transpose();
      sw += particles.weight[i];
    }
    if (!(sw > 0.0)) return std::nullopt;
    return Eigen::Matrix3d(sum / sw);
  }

  const Pose& mean() const { return mean_; }
  const Eigen::Matrix3d& covariance() const { return covariance_; }

 private:
  Settings settings_;
  ParticleClusters clusters_;
  int rival_updates_ = 0;
  std::optional<Pose> rival_;  // where the heaviest cluster was while the reported mode held
  Pose mean_{0.0, 0.0, 0.0};
  Eigen::Matrix3d covariance_ = Eigen::Matrix3d::Identity();
};

}  // namespace locsim::sdk
