// The particle-filter skeleton that every particle filter of locsim is built on (mcl, srl, asrl,
// augmented_mcl; amcl and ultrasonic_amcl's AMCL; fastslam, fastslam_afsa, pso_pf), and that a
// plugin author's filter can be built on too (docs/plugins.md, "A particle filter"). As nav2 AMCL's
// pf/: one small core with the models plugged in. The core owns the particles (poses and
// weights), the filter's random stream and the odometry not yet applied, and does what every
// particle filter does alike:
//   initialise  known start: Gaussian about the host's guess; global: uniform over the free cells
//   weigh       per-particle log likelihoods -> normalised weights, the measurement's likelihood
//               under the belief (what SRL, ASRL and w_slow / w_fast act on), N_eff
//   resample    low-variance or roulette draws; a filter's own per-particle data follows them
//   recover     Thrun's w_slow / w_fast averages (LikelihoodAverages)
//   report      the estimate moved by the odometry since the last update, the particles exported
// The motion model (sample_motion, sample_wheel_motion, ...), the sensor model and what the filter
// does with the likelihood (reset, inject, nothing) stay the filter's.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "locsim/localizer.h"
#include "locsim/localizer.hpp"
#include "locsim/models.hpp"
#include "locsim/particles.hpp"
#include "locsim/random.hpp"

namespace locsim::sdk {

/// How resample() draws: low-variance (systematic: one uniform, n evenly spaced pointers; the
/// least resampling noise) or roulette (n independent draws, as paper 004).
enum class Resampler { kLowVariance, kRoulette };

/// A `resampler` parameter's value: "low_variance" or "roulette".
inline Resampler resampler_from(std::string_view name) {
  if (name == "low_variance") return Resampler::kLowVariance;
  if (name == "roulette") return Resampler::kRoulette;
  throw std::invalid_argument("resampler must be roulette or low_variance, not '" +
                              std::string(name) + "'");
}

/// The free space of the host's occupancy grid (cells of value 0), for poses uniform over it:
/// global localization's start, random injection. A copy: the grid need not outlive it.
class FreeSpace {
 public:
  FreeSpace() = default;
  explicit FreeSpace(const locsim_occupancy_grid& grid)
      : origin_x_m_(grid.origin_x),
        origin_y_m_(grid.origin_y),
        resolution_m_(grid.resolution_m),
        width_(grid.width > 0 ? static_cast<std::size_t>(grid.width) : 0),
        height_(grid.height > 0 ? static_cast<std::size_t>(grid.height) : 0) {
    if (grid.cells == nullptr || grid.width <= 0 || grid.height <= 0) return;
    const std::size_t cells = width_ * height_;
    possible_.assign(cells, false);
    for (std::size_t i = 0; i < cells; ++i) {
      if (grid.cells[i] != 0) continue;
      free_cells_.push_back(i);
      possible_[i] = true;
    }
    // Free cells joined to the grid's edge lie outside the walls (the grid has a margin round
    // the world's geometry). If some free cells are not so joined, walls close them in, and only
    // those are where the robot can be; if all are (a world without closing walls, such as an
    // imported dataset's landmarks alone), the robot may be anywhere free, the grid's outside
    // included: its extent is the geometry's, not the robot's.
    std::vector<bool> outside(cells, false);
    std::vector<std::size_t> stack;
    const auto visit = [&](std::size_t col, std::size_t row) {
      const std::size_t i = row * width_ + col;
      if (possible_[i] && !outside[i]) {
        outside[i] = true;
        stack.push_back(i);
      }
    };
    for (std::size_t col = 0; col < width_; ++col) visit(col, 0), visit(col, height_ - 1);
    for (std::size_t row = 0; row < height_; ++row) visit(0, row), visit(width_ - 1, row);
    while (!stack.empty()) {
      const std::size_t i = stack.back();
      stack.pop_back();
      const std::size_t col = i % width_, row = i / width_;
      if (col > 0) visit(col - 1, row);
      if (col + 1 < width_) visit(col + 1, row);
      if (row > 0) visit(col, row - 1);
      if (row + 1 < height_) visit(col, row + 1);
    }
    std::size_t enclosed = 0;
    for (std::size_t i = 0; i < cells; ++i) enclosed += possible_[i] && !outside[i] ? 1 : 0;
    enclosed_ = enclosed > 0;
    if (enclosed_)
      for (std::size_t i = 0; i < cells; ++i) possible_[i] = possible_[i] && !outside[i];
  }
  /// No free cell (or no grid): nothing to sample from.
  bool empty() const { return free_cells_.empty(); }
  std::size_t free_cells() const { return free_cells_.size(); }
  /// Whether the robot can be at (x, y): in a free cell that walls close in, or, in a world
  /// whose walls close nothing in, in a free cell or outside the grid. Without a grid (empty())
  /// nothing is known, and every point may be.
  bool possible(double x_m, double y_m) const {
    if (free_cells_.empty()) return !std::isnan(x_m) && !std::isnan(y_m);
    const double col = std::floor((x_m - origin_x_m_) / resolution_m_);
    const double row = std::floor((y_m - origin_y_m_) / resolution_m_);
    if (std::isnan(col) || std::isnan(row)) return false;
    if (!(col >= 0.0 && row >= 0.0 && col < static_cast<double>(width_) &&
          row < static_cast<double>(height_)))
      return !enclosed_;
    return possible_[static_cast<std::size_t>(row) * width_ + static_cast<std::size_t>(col)];
  }
  /// Whether walls close some free space in (then only it is possible()).
  bool enclosed() const { return enclosed_; }

  /// A pose uniform over the free space: a free cell, a point uniform in it, a heading uniform
  /// in [-pi, pi). Exact however much of the grid is walls (no rejection). Not for an empty().
  Pose sample(Random& random) const {
    const std::size_t cell = free_cells_[std::min(
        free_cells_.size() - 1,
        static_cast<std::size_t>(random.uniform() * static_cast<double>(free_cells_.size())))];
    const auto col = static_cast<double>(cell % width_);
    const auto row = static_cast<double>(cell / width_);
    // One draw per statement: the order is part of the filter's random stream.
    const double x = origin_x_m_ + (col + random.uniform()) * resolution_m_;
    const double y = origin_y_m_ + (row + random.uniform()) * resolution_m_;
    const double theta = random.uniform(-std::numbers::pi, std::numbers::pi);
    return {x, y, theta};
  }

 private:
  double origin_x_m_ = 0.0, origin_y_m_ = 0.0, resolution_m_ = 1.0;
  std::size_t width_ = 0, height_ = 0;
  std::vector<std::size_t> free_cells_;
  std::vector<bool> possible_;  // by cell, row-major
  bool enclosed_ = false;
};

/// The odometry a filter has seen and how much of it its particles have taken. A filter that
/// moves its particles once per update (the odometry model's alphas are per update) keeps the
/// mark at its last update; between updates its estimate is the particles' mean then, moved by
/// the odometry since (follow: the motion's noise comes with the next update's sampling).
///
/// With a gyro (use_gyro and observe_imu), each odometry step turns by what the gyro measured
/// and travels the wheels' distance along that arc (Borenstein and Feng's gyrodometry, taken
/// always: a MEMS gyro's bias, 1e-3 rad/s, turns less in a minute than a 1 % wheel-base error
/// does in one turn). Wheels that spin against a wall, and a push that turns the robot, turn
/// the wheels' odometry but not the gyro: the difference is slip (OdometryDelta::slip_rad),
/// which widens the translation's noise as much as that turn would have.
class OdometryFollower {
 public:
  /// Whether the IMU's yaw rate gives the heading (when observe_imu has readings; default on).
  void use_gyro(bool on) { use_gyro_ = on; }

  /// An IMU reading (its yaw rate).
  void observe_imu(double t_s, const locsim_imu& imu) {
    if (use_gyro_) gyro_.observe(t_s, imu);
  }

  /// The latest odometry (at t_s, for the gyro); the first also sets the mark.
  void observe(double t_s, const locsim_odometry& odometry) {
    const Pose before = now_;
    const double before_s = now_s_;
    const Pose wheels(odometry.odom_pose.x, odometry.odom_pose.y, odometry.odom_pose.theta);
    const double gyro_rad =
        use_gyro_ ? gyro_.turn_at(t_s) : std::numeric_limits<double>::quiet_NaN();
    const bool gyro_step = !std::isnan(gyro_rad) && !std::isnan(gyro_then_rad_);
    if (!ready() || (!gyro_step && !turned_by_gyro_)) {
      now_ = wheels;  // the wheels' own odometry, exactly, until the gyro first turns a step
    } else if (!gyro_step) {  // no gyro for this step: the wheels' turn
      now_ = compose(now_, between(wheels_, wheels));
    } else {
      const Pose step = between(wheels_, wheels);
      const double turn_rad = gyro_rad - gyro_then_rad_;
      now_ = compose(now_, turned_step(step, turn_rad));
      slip_rad_ += step(2) - turn_rad;
      turned_by_gyro_ = true;
    }
    wheels_ = wheels;
    gyro_then_rad_ = gyro_rad;
    // The step just taken and its interval: the rate advance_to() extrapolates at.
    last_dt_s_ = ready() && t_s > before_s ? t_s - before_s : 0.0;
    last_step_ = ready() ? between(before, now_) : Pose::Zero();
    now_s_ = t_s;
    ahead_ = Pose::Zero(), ahead_s_ = t_s;
    if (!ready()) mark_ = now_, slip_at_mark_rad_ = slip_rad_;
    ready_ = true;
  }
  /// Brings now() on to t_s, after the latest odometry reading, for a reading of another sensor
  /// taken then (a scan between two odometry readings): the last step's motion per second,
  /// extrapolated, no further than one step's interval past its reading (odometry that stopped
  /// coming is not driven on), never back. The next observe() puts the odometry's own pose in
  /// its place; since_mark() differences the two, so that what the particles take adds up to
  /// the odometry's motion (as OdometryTracker::advance_to).
  void advance_to(double t_s) {
    if (!ready() || !(last_dt_s_ > 0.0) || !(t_s > ahead_s_)) return;
    const double to_s = std::min(t_s, now_s_ + last_dt_s_);
    if (!(to_s > ahead_s_)) return;
    const double share = (to_s - now_s_) / last_dt_s_;
    const double travel_m = wheel_travel_from_increment(last_step_, 0.0).first;
    ahead_ = advance_by_velocity(Pose::Zero(), travel_m * share, last_step_(2) * share, 1.0);
    ahead_s_ = to_s;
  }
  /// The latest odometry, without its time: the wheels' turn (no gyro).
  void observe(const locsim_odometry& odometry) {
    observe(std::numeric_limits<double>::quiet_NaN(), odometry);
  }
  /// Whether an odometry reading has come (now() and mark() before: zero).
  bool ready() const { return ready_; }
  /// The odometry pose now: the latest reading's, brought on by advance_to().
  Pose now() const { return ahead_s_ > now_s_ ? compose(now_, ahead_) : now_; }
  const Pose& mark() const { return mark_; }
  /// The motion since the mark, rotate-translate-rotate, with the wheels' slip since.
  OdometryDelta since_mark() const {
    OdometryDelta d = decompose(mark_, now());
    d.slip_rad = std::abs(slip_rad_ - slip_at_mark_rad_);
    return d;
  }
  /// The wheels' turn less the gyro's, summed over every step so far (signed, so that the
  /// wheels' tick-by-tick jitter cancels) [rad].
  double slip_rad() const { return slip_rad_; }
  /// The particles have taken the odometry up to now.
  void mark_now() { mark_ = now(), slip_at_mark_rad_ = slip_rad_; }
  /// `at_mark` (a pose of the mark's time) moved by the odometry since the mark.
  Pose follow(const Pose& at_mark) const {
    return ready() ? compose(at_mark, between(mark_, now())) : at_mark;
  }

 private:
  bool use_gyro_ = true, turned_by_gyro_ = false, ready_ = false;
  Pose now_ = Pose::Zero(), mark_ = Pose::Zero();            // with the gyro's turn
  double now_s_ = std::numeric_limits<double>::quiet_NaN();  // the latest reading's time
  Pose last_step_ = Pose::Zero();  // the latest reading's step, in the previous pose's frame
  double last_dt_s_ = 0.0;         // and its interval (0: no rate to extrapolate at)
  Pose ahead_ = Pose::Zero();      // advance_to()'s motion beyond now_
  double ahead_s_ = std::numeric_limits<double>::quiet_NaN();  // the time it reaches
  Pose wheels_ = Pose::Zero();  // the wheels' odometry pose at the last reading
  GyroIntegrator gyro_;
  double gyro_then_rad_ =
      std::numeric_limits<double>::quiet_NaN();     // the gyro's turn at the last odometry reading
  double slip_rad_ = 0.0, slip_at_mark_rad_ = 0.0;  // sum of the wheels' turn less the gyro's
};

/// Thrun's w_slow / w_fast (Probabilistic Robotics table 8.3): two exponential averages of the
/// measurement likelihood; w_fast falling below w_slow says the belief stopped explaining the
/// measurements (a kidnapping), and 1 - w_fast / w_slow of the particles are worth replacing.
struct LikelihoodAverages {
  double alpha_slow = 0.0;  // rate of the long-term average [-]
  double alpha_fast = 0.0;  // rate of the short-term average, above alpha_slow [-]
  double w_slow = 0.0, w_fast = 0.0;

  /// Takes one update's average likelihood w_avg (the first starts both averages at it).
  void update(double w_avg) {
    w_slow = w_slow == 0.0 ? w_avg : w_slow + alpha_slow * (w_avg - w_slow);
    w_fast = w_fast == 0.0 ? w_avg : w_fast + alpha_fast * (w_avg - w_fast);
  }
  /// 1 - w_fast / (level w_slow): the share to replace when positive (level 1: Thrun's; below 1
  /// it waits for a deeper fall).
  double deficit(double level = 1.0) const { return 1.0 - w_fast / (level * w_slow); }
  /// Forgets both (after the filter was restarted from elsewhere).
  void reset() { w_slow = w_fast = 0.0; }
};

/// What an update's measurement said about the belief (ParticleFilter::weigh).
struct Evidence {
  /// log sum_i w_i p(z | x_i) with the weights before the update: the measurement's likelihood
  /// under the belief (with equal weights, the mean likelihood over the particles).
  double log_likelihood = 0.0;
  /// The same over the first `head` particles only (their weights renormalised).
  double log_likelihood_head = 0.0;
  double n_eff = 0.0;  // effective sample size after the update, 1 / sum w^2 [-]
};

/// The particles, their random stream and odometry, and the steps every particle filter shares.
/// A filter with data of its own per particle (FastSLAM's landmark maps) keeps it in vectors
/// beside these and passes them to resample() or keep(), which reorder them alike.
class ParticleFilter {
 public:
  ParticleFilter(std::size_t count, std::uint64_t seed,
                 Resampler resampler = Resampler::kLowVariance)
      : random_(seed), resampler_(resampler) {
    particles_.resize(count);
  }

  ParticleSet& particles() { return particles_; }
  const ParticleSet& particles() const { return particles_; }
  std::size_t size() const { return particles_.size(); }
  Random& random() { return random_; }
  OdometryFollower& odometry() { return odometry_; }
  const OdometryFollower& odometry() const { return odometry_; }

  /// A known start (init.initial_pose_known): Gaussian about the host's initial pose with its
  /// covariance's standard deviations; a global start: uniform over `free` (which must then not
  /// be empty). Equal weights.
  void initialise(const locsim_init& init, const FreeSpace& free) {
    if (!init.initial_pose_known && free.empty())
      throw std::invalid_argument(
          "a global start (initial pose unknown) needs an occupancy grid with free cells; this "
          "world has none");
    const std::size_t n = particles_.size();
    for (std::size_t i = 0; i < n; ++i) {
      if (init.initial_pose_known) {
        particles_.x[i] =
            init.initial_pose.x + random_.normal(std::sqrt(init.initial_covariance[0]));
        particles_.y[i] =
            init.initial_pose.y + random_.normal(std::sqrt(init.initial_covariance[4]));
        particles_.theta[i] =
            wrap(init.initial_pose.theta + random_.normal(std::sqrt(init.initial_covariance[8])));
      } else {
        set(i, free.sample(random_));
      }
    }
    particles_.weight.assign(n, n > 0 ? 1.0 / static_cast<double>(n) : 0.0);
  }

  /// Every particle at `pose` (a SLAM filter's start: where the robot is defines the map).
  void place_all(const Pose& pose) {
    const std::size_t n = particles_.size();
    for (std::size_t i = 0; i < n; ++i) set(i, pose);
    particles_.weight.assign(n, n > 0 ? 1.0 / static_cast<double>(n) : 0.0);
  }

  /// `count` particles drawn from N(mean, covariance) with equal weights (a restart from another
  /// estimator's belief). covariance must be positive definite.
  void scatter(const Pose& mean, const Eigen::Matrix3d& covariance, std::size_t count) {
    const Eigen::LLT<Eigen::Matrix3d> llt(covariance);
    const Eigen::Matrix3d l = llt.matrixL();
    particles_.resize(count);
    for (std::size_t i = 0; i < count; ++i) {
      // One draw per statement (a constructor's arguments are unsequenced and compilers differ),
      // the last component first.
      const double z2 = random_.normal(1.0), z1 = random_.normal(1.0), z0 = random_.normal(1.0);
      const Eigen::Vector3d p = mean + l * Eigen::Vector3d(z0, z1, z2);
      particles_.x[i] = p(0), particles_.y[i] = p(1), particles_.theta[i] = wrap(p(2));
    }
  }

  /// Multiplies every weight by its particle's likelihood exp(log_likelihood[i]) and normalises,
  /// in logs (one shift by the largest, then one exp per particle: no underflow, whatever the
  /// number of measurements in the update). `head`: also the likelihood over the first `head`
  /// particles (those that are not fresh guesses; all by default).
  Evidence weigh(const std::vector<double>& log_likelihood, std::size_t head = SIZE_MAX) {
    const std::size_t n = particles_.size();
    if (log_likelihood.size() != n)
      throw std::invalid_argument("weigh: one log likelihood per particle");
    if (n == 0) return {};
    head = std::min(head, n);
    std::vector<double>& w = particles_.weight;
    double prior_head = 0.0;
    for (std::size_t i = 0; i < head; ++i) prior_head += w[i];
    // The prior weight's log (tiny ones floored: a particle at weight 0 stays comparable);
    // after resampling all are equal, and one log serves them all.
    log_weight_.resize(n);
    const bool equal = std::all_of(w.begin(), w.end(), [&](double v) { return v == w[0]; });
    const double log_equal = std::log(std::max(w[0], 1e-300));
    for (std::size_t i = 0; i < n; ++i)
      log_weight_[i] = (equal ? log_equal : std::log(std::max(w[i], 1e-300))) + log_likelihood[i];
    const double top = *std::max_element(log_weight_.begin(), log_weight_.end());
    for (std::size_t i = 0; i < n; ++i) w[i] = log_weight_[i] - top;
    vector_math::exp(w, w);
    double sum_head = 0.0;
    for (std::size_t i = 0; i < head; ++i) sum_head += w[i];
    const double sum = normalize(w);
    Evidence evidence;
    evidence.log_likelihood = top + std::log(sum);
    evidence.log_likelihood_head =
        prior_head > 0.0 ? top + std::log(sum_head / prior_head) : evidence.log_likelihood;
    evidence.n_eff = effective_sample_size(w);
    return evidence;
  }

  /// Draws size() particles by the weights (the filter's Resampler), equal weights after.
  /// `extra`: the filter's own per-particle vectors, reordered alike.
  template <class... Extra>
  void resample(std::vector<Extra>&... extra) {
    if (resampler_ == Resampler::kRoulette)
      roulette_resample(particles_.weight, random_, chosen_, spacings_);
    else
      low_variance_resample(particles_.weight, random_, chosen_);
    keep(chosen_, extra...);
  }

  /// The particles `chosen` (indices, repeats allowed) become the set, with equal weights;
  /// `extra` follows (a filter's own resampling scheme: KLD sampling, directed resampling).
  template <class... Extra>
  void keep(const std::vector<std::size_t>& chosen, std::vector<Extra>&... extra) {
    apply_resample(particles_, chosen, scratch_);
    (gather(extra, chosen), ...);
  }

  /// Weights all equal (after particles were added or replaced by hand).
  void equalise_weights() {
    const std::size_t n = particles_.size();
    particles_.weight.assign(n, n > 0 ? 1.0 / static_cast<double>(n) : 0.0);
  }

  /// Particle i's pose.
  Pose pose(std::size_t i) const { return {particles_.x[i], particles_.y[i], particles_.theta[i]}; }
  void set(std::size_t i, const Pose& pose) {
    particles_.x[i] = pose(0), particles_.y[i] = pose(1), particles_.theta[i] = pose(2);
  }

  /// The weighted mean (circular in heading) and covariance of the first `count` particles
  /// (all by default), moved by the odometry since the mark.
  Estimate estimate(std::size_t count = SIZE_MAX) const {
    Pose mean;
    Eigen::Matrix3d covariance;
    mean_and_covariance(particles_, mean, covariance, count);
    mean = odometry_.follow(mean);
    return {{mean(0), mean(1), mean(2)}, covariance};
  }

  /// The particles for the host (locsim_localizer's particles call; videos and frames draw them).
  void export_particles(std::vector<locsim_pose2>& poses, std::vector<double>& weights) const {
    for (std::size_t i = 0; i < particles_.size(); ++i) {
      poses.push_back({particles_.x[i], particles_.y[i], particles_.theta[i]});
      weights.push_back(particles_.weight[i]);
    }
  }

 private:
  template <class T>
  static void gather(std::vector<T>& data, const std::vector<std::size_t>& chosen) {
    std::vector<T> next;
    next.reserve(chosen.size());
    for (const std::size_t k : chosen) next.push_back(data[k]);
    data = std::move(next);
  }

  Random random_;
  Resampler resampler_;
  ParticleSet particles_, scratch_;
  OdometryFollower odometry_;
  std::vector<std::size_t> chosen_;
  std::vector<double> spacings_, log_weight_;
};

}  // namespace locsim::sdk
