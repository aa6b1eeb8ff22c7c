// The filter of the amcl plugin, also the laser half of the ultrasonic_amcl fusion: adaptive
// Monte Carlo localization on the laser (Thrun, Burgard and Fox, Probabilistic Robotics 8.3 and
// 6.4; Fox 2003 for KLD sampling), with the parameter names AMCL users know:
//  - motion: the odometry model with odom_alpha1..4 (Thrun's variance form, as AMCL's "diff"),
//    applied once the robot has moved update_min_d or turned update_min_a since the last update;
//  - sensor: the likelihood field over the host's occupancy grid, laser_max_beams beams evenly
//    spread over the scan, max-range readings skipped, log likelihoods summed per particle;
//  - resampling (every resample_interval updates): low-variance draws with KLD sampling, the count
//    growing until it covers the occupied (x, y, theta) bins, kld_z a probability turned into the
//    normal quantile (0.99 -> 2.33), between min_particles and max_particles;
//  - recovery (on by default; AMCL's is off): w_slow / w_fast over the scan's likelihood, each
//    injected pose the best fit to the scan of recovery_candidates draws (guess()), the draws from
//    afar about the places a search of the whole map finds for the scan (recovery_search_updates).
// The estimate is the weighted mean of the heaviest cluster (occupied bins joined to neighbours),
// so that a multimodal cloud reports its best mode rather than the space between modes. Poses
// injected by the recovery stay out of it until a scan has weighed them: unweighed, a guess
// anywhere counts as much as a tracked particle.
#pragma once

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <locsim/laser.hpp>
#include <locsim/localizer.hpp>
#include <locsim/particle_filter.hpp>
#include <locsim/particles.hpp>
#include <locsim/place_search.hpp>
#include <numbers>
#include <optional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace amcl {

namespace sdk = locsim::sdk;

// AMCL's names and defaults (ROS 1 amcl / nav2), but kld_z is the probability 1 - delta whose
// normal quantile the bound uses, and recovery is on with the rates ROS amcl's documentation
// suggests (0.001, 0.1): a filter that never recovers from a kidnap is a poor default
// (docs/reports/suite).
inline constexpr locsim_param_decl kAmclParams[] = {
    {"min_particles", LOCSIM_PARAM_INT, 500, 1, 10000000, nullptr, "fewest particles [-]"},
    {"max_particles", LOCSIM_PARAM_INT, 5000, 1, 10000000, nullptr,
     "most particles, and the initial count [-]"},
    {"kld_err", LOCSIM_PARAM_DOUBLE, 0.01, 1e-6, 1.0, nullptr,
     "KLD bound epsilon between true and sampled posterior [-]"},
    {"kld_z", LOCSIM_PARAM_DOUBLE, 0.99, 0.5, 0.999999, nullptr,
     "probability 1 - delta that the bound holds; its normal quantile (0.99 -> 2.33) is used [-]"},
    {"kld_bin_xy", LOCSIM_PARAM_DOUBLE, 0.5, 1e-3, 100.0, nullptr, "KLD bin size in x and y [m]"},
    {"kld_bin_theta_deg", LOCSIM_PARAM_DOUBLE, 10.0, 0.1, 180.0, nullptr,
     "KLD bin size in heading [deg]"},
    {"estimate", LOCSIM_PARAM_STRING, 0, 0, 0, "stable",
     "stable: the cluster reported before (clusters of the KLD bins) until another has been the "
     "heaviest for switch_updates updates or holds switch_share of the two's weight, the "
     "covariance every particle's spread about it; heaviest: the heaviest cluster at each update "
     "(nav2), which an injected guess winning one update moves at once"},
    {"switch_updates", LOCSIM_PARAM_INT, 3, 1, 1000, nullptr,
     "estimate stable: updates in a row a rival cluster must be the heaviest [-]"},
    {"switch_share", LOCSIM_PARAM_DOUBLE, 0.9, 0.5, 1.0, nullptr,
     "estimate stable: a rival with this share of the two's weight wins at once [-]"},
    {"update_min_d", LOCSIM_PARAM_DOUBLE, 0.25, 0.0, 100.0, nullptr,
     "travel before a filter update [m]"},
    {"update_min_a", LOCSIM_PARAM_DOUBLE, 0.2, 0.0, 10.0, nullptr,
     "rotation before a filter update [rad]"},
    {"resample_interval", LOCSIM_PARAM_INT, 1, 1, 1000, nullptr,
     "filter updates between resamplings [-]"},
    {"recovery_alpha_slow", LOCSIM_PARAM_DOUBLE, 0.001, 0.0, 1.0, nullptr,
     "slow average of the beam likelihood (0: no random injection) [-]"},
    {"recovery_alpha_fast", LOCSIM_PARAM_DOUBLE, 0.1, 0.0, 1.0, nullptr,
     "fast average of the beam likelihood [-]"},
    {"recovery_level", LOCSIM_PARAM_DOUBLE, 0.7, 1e-6, 1.0, nullptr,
     "inject when w_fast falls below this share of w_slow, the share below it (1: AMCL's) [-]"},
    {"recovery_candidates", LOCSIM_PARAM_INT, 10, 1, 100000, nullptr,
     "poses drawn per injected one, half uniform and half about the estimate, the best fit to "
     "the scan kept (1: AMCL's, one uniform pose) [-]"},
    {"recovery_far_prior", LOCSIM_PARAM_DOUBLE, 1e-6, 1e-300, 1.0, nullptr,
     "prior weight of an injected pose drawn uniformly, against a particle's [-]"},
    {"recovery_near_sigma_m", LOCSIM_PARAM_DOUBLE, 1.0, 0.0, 100.0, nullptr,
     "spread in x and y of injected poses drawn about the estimate [m]"},
    {"recovery_near_sigma_deg", LOCSIM_PARAM_DOUBLE, 30.0, 0.0, 180.0, nullptr,
     "spread in heading of injected poses drawn about the estimate [deg]"},
    {"recovery_through_share", LOCSIM_PARAM_DOUBLE, 0.05, 0.0, 1.0, nullptr,
     "inject only while at least this share of the scan's beams, seen from the estimate, pass "
     "through a wall (recovery_through_margin_m before their end): people and carts shorten "
     "beams, only a wrong pose lengthens them past walls, so a scan spoilt by a crowd does not "
     "start a recovery (0: AMCL's, any low likelihood does) [-]"},
    {"recovery_through_margin_m", LOCSIM_PARAM_DOUBLE, 0.3, 0.0, 100.0, nullptr,
     "recovery_through_share: a beam passes through a wall when an occupied cell lies more than "
     "this before its end [m]"},
    {"recovery_search_updates", LOCSIM_PARAM_INT, 5, 0, 1000000, nullptr,
     "after injecting for this many updates in a row, and again every this many while it goes "
     "on, search the whole map for the places that fit the scan and draw the poses from afar "
     "about them (0: uniformly, no search) [-]"},
    {"laser_max_beams", LOCSIM_PARAM_INT, 60, 1, 100000, nullptr,
     "beams used per scan, evenly spread [-]"},
    {"laser_z_hit", LOCSIM_PARAM_DOUBLE, 0.95, 0.0, 1.0, nullptr, "hit weight [-]"},
    {"laser_z_rand", LOCSIM_PARAM_DOUBLE, 0.05, 1e-9, 1.0, nullptr, "random-reading weight [-]"},
    {"laser_sigma_hit", LOCSIM_PARAM_DOUBLE, 0.2, 1e-4, 10.0, nullptr,
     "spread of a hit about the nearest obstacle [m]"},
    {"laser_likelihood_max_dist", LOCSIM_PARAM_DOUBLE, 2.0, 0.0, 100.0, nullptr,
     "distance to obstacles beyond which it makes no difference [m]"},
    {"odom_alpha1", LOCSIM_PARAM_DOUBLE, 0.2, 0.0, 10.0, nullptr,
     "rotation noise from rotation [-]"},
    {"odom_alpha2", LOCSIM_PARAM_DOUBLE, 0.2, 0.0, 10.0, nullptr,
     "rotation noise from translation [rad^2/m^2]"},
    {"odom_alpha3", LOCSIM_PARAM_DOUBLE, 0.2, 0.0, 10.0, nullptr,
     "translation noise from translation [-]"},
    {"odom_alpha4", LOCSIM_PARAM_DOUBLE, 0.2, 0.0, 10.0, nullptr,
     "translation noise from rotation [m^2/rad^2]"},
    LOCSIM_GYRO_PARAMS};

class AmclFilter {
 public:
  /// `params` holds the kAmclParams (among others); `seed` drives its random stream.
  AmclFilter(const sdk::Params& params, const locsim_init& init, std::uint64_t seed)
      : pf_(static_cast<std::size_t>(params.integer("max_particles")), seed),
        bins_(params.number("kld_bin_xy"),
              params.number("kld_bin_theta_deg") * std::numbers::pi / 180.0) {
    const std::string estimate = params.string("estimate");
    if (estimate != "stable" && estimate != "heaviest")
      throw std::invalid_argument("estimate must be stable or heaviest, not '" + estimate + "'");
    estimate_stable_ = estimate == "stable";
    stable_ = sdk::StableMode(
        {static_cast<int>(params.integer("switch_updates")), params.number("switch_share")});
    min_particles_ = static_cast<std::size_t>(params.integer("min_particles"));
    max_particles_ = static_cast<std::size_t>(params.integer("max_particles"));
    if (min_particles_ > max_particles_)
      throw std::invalid_argument("min_particles exceeds max_particles");
    kld_err_ = params.number("kld_err");
    kld_z_ = sdk::normal_quantile(params.number("kld_z"));
    update_min_d_ = params.number("update_min_d");
    update_min_a_ = params.number("update_min_a");
    resample_interval_ = static_cast<int>(params.integer("resample_interval"));
    averages_.alpha_slow = params.number("recovery_alpha_slow");
    averages_.alpha_fast = params.number("recovery_alpha_fast");
    recovery_candidates_ = static_cast<std::size_t>(params.integer("recovery_candidates"));
    recovery_far_prior_ = params.number("recovery_far_prior");
    recovery_level_ = params.number("recovery_level");
    recovery_near_sigma_m_ = params.number("recovery_near_sigma_m");
    recovery_near_sigma_rad_ = params.number("recovery_near_sigma_deg") * std::numbers::pi / 180.0;
    recovery_search_updates_ = params.integer("recovery_search_updates");
    recovery_through_share_ = params.number("recovery_through_share");
    recovery_through_margin_m_ = params.number("recovery_through_margin_m");
    if (averages_.alpha_slow > 0.0 && averages_.alpha_fast <= averages_.alpha_slow)
      throw std::invalid_argument("recovery_alpha_fast must exceed recovery_alpha_slow");
    pf_.odometry().use_gyro(params.flag("use_gyro"));
    max_beams_ = static_cast<std::size_t>(params.integer("laser_max_beams"));
    noise_ = {params.number("odom_alpha1"), params.number("odom_alpha2"),
              params.number("odom_alpha3"), params.number("odom_alpha4"), true};
    field_def_.z_hit = params.number("laser_z_hit");
    field_def_.z_rand = params.number("laser_z_rand");
    field_def_.sigma_hit_m = params.number("laser_sigma_hit");
    field_def_.max_dist_m = params.number("laser_likelihood_max_dist");
    if (init.map == nullptr || init.map->grid.cells == nullptr || init.map->grid.width <= 0 ||
        init.map->grid.height <= 0) {
      throw std::invalid_argument("needs the occupancy grid, and this world has none");
    }
    grid_ = init.map->grid;
    grid_cells_.assign(grid_.cells,
                       grid_.cells + static_cast<std::size_t>(grid_.width) * grid_.height);
    grid_.cells = grid_cells_.data();
    free_ = sdk::FreeSpace(grid_);
    if (free_.empty()) throw std::invalid_argument("the occupancy grid has no free cell");
    if (averages_.alpha_slow > 0.0 && recovery_search_updates_ > 0) search_.emplace(grid_);
    pf_.initialise(init, free_);
    compute_estimate();
  }

  void on_odometry(double t_s, const locsim_odometry& odometry) {
    pf_.odometry().observe(t_s, odometry);
  }
  void on_imu(double t_s, const locsim_imu& imu) { pf_.odometry().observe_imu(t_s, imu); }

  /// A filter update when the robot has moved enough since the last one: true if it did. The
  /// odometry is brought on to the scan's time t_s first: a scan between two odometry readings
  /// (a recording's, on its own clock) belongs to the pose of its own time.
  bool on_laser(double t_s, const locsim_laser_scan& scan) {
    sdk::OdometryFollower& odometry = pf_.odometry();
    if (!odometry.ready()) return false;
    odometry.advance_to(t_s);
    const sdk::OdometryDelta delta = odometry.since_mark();
    const bool moved = delta.trans >= update_min_d_ ||
                       std::abs(sdk::wrap(odometry.now()(2) - odometry.mark()(2))) >= update_min_a_;
    // AMCL updates after motion, and once at start or after a reseed.
    if (!moved && updates_ > 0 && !update_pending_) return false;
    update_pending_ = false;
    if (!field_ready_ || scan.range_max != field_def_.range_max_m) {
      field_def_.range_max_m = scan.range_max;
      field_ = sdk::LikelihoodField(grid_, field_def_);
      field_ready_ = true;
    }
    sdk::sample_motion(pf_.particles(), delta, noise_, pf_.random());
    estimate_at_mark_ = odometry.follow(mean_);
    odometry.mark_now();
    weigh(scan);
    ++updates_;
    if (resample_interval_ > 0 && updates_ % resample_interval_ == 0) resample();
    compute_estimate(estimate_at_mark_);
    return true;
  }

  /// Replaces the particles by max_particles draws from N(pose, covariance) at the latest
  /// odometry (the fusion's start from an ultrasonic fix); KLD sampling thins them later.
  void reseed(const sdk::Pose& pose, const Eigen::Matrix3d& covariance) {
    pf_.scatter(pose, covariance, max_particles_);
    pf_.equalise_weights();
    fresh_ = 0;
    pf_.odometry().mark_now();
    averages_.reset();
    update_pending_ = true;  // the next scan weighs them, moving or not
    ++reseeds_;
    compute_estimate();
  }

  sdk::Estimate estimate() const {
    const sdk::Pose mean = pf_.odometry().follow(mean_);
    return {{mean(0), mean(1), mean(2)}, covariance_};
  }

  void particles(std::vector<locsim_pose2>& poses, std::vector<double>& weights) const {
    pf_.export_particles(poses, weights);
  }

  std::vector<std::pair<std::string, double>> diagnostics() const {
    return {{"particles", static_cast<double>(pf_.size())},
            {"n_eff", n_eff_},
            {"kld_bins", static_cast<double>(last_bins_)},
            {"injected", static_cast<double>(injected_)},
            {"through_share", through_share_},
            {"short_share", short_share_},
            {"updates", static_cast<double>(updates_)},
            {"reseeds", static_cast<double>(reseeds_)}};
  }

 private:
  /// Each particle's weight *= p(scan | particle) over the chosen beams: the end points in the
  /// robot frame once per scan, then per particle a rotation, a translation and a table lookup
  /// per beam (LikelihoodField::sum_log_p).
  void weigh(const locsim_laser_scan& scan) {
    beam_x_.clear(), beam_y_.clear();
    const std::size_t count = scan.count;
    const std::size_t step = std::max<std::size_t>(1, (count + max_beams_ - 1) / max_beams_);
    const double cm = std::cos(scan.mount.theta), sm = std::sin(scan.mount.theta);
    sensor_x_ = scan.mount.x, sensor_y_ = scan.mount.y;
    for (std::size_t b = 0; b < count; b += step) {
      const double r = scan.ranges[b];
      if (!(r < scan.range_max) || r < scan.range_min) continue;  // max range: no return
      const double a = scan.angles[b];
      const double sx = r * std::cos(a), sy = r * std::sin(a);
      beam_x_.push_back(scan.mount.x + cm * sx - sm * sy);
      beam_y_.push_back(scan.mount.y + sm * sx + cm * sy);
    }
    const sdk::ParticleSet& particles = pf_.particles();
    const std::size_t n = particles.size();
    log_w_.resize(n);
    field_.sum_log_p(particles.x, particles.y, particles.theta, beam_x_, beam_y_, log_w_);
    const std::size_t beams = beam_x_.size();
    const sdk::Evidence evidence = pf_.weigh(log_w_, n - fresh_);
    fresh_ = 0;
    // The scan's likelihood under the belief (weighted by the prior weights), per beam as a
    // geometric mean: w_slow / w_fast compare scans with different numbers of valid beams. Not
    // over the last resampling's guesses: unlikely by design, they would lower it, and a lower
    // average injects more guesses.
    w_avg_ = beams > 0 ? std::exp(evidence.log_likelihood_head / static_cast<double>(beams)) : 0.0;
    n_eff_ = evidence.n_eff;
  }

  /// A recovery guess and its prior weight against the particles'. Of recovery_candidates poses
  /// (every other one uniform over the free cells, the rest about the estimate), the one the
  /// latest scan fits best: Thrun, Fox, Burgard and Dellaert's mixture proposal ("Robust Monte
  /// Carlo localization for mobile robots", 2001), by best of k rather than a density tree.
  /// Uniform guesses alone fit by chance only (in a 20 x 12 m room one draw in 30 000 falls in
  /// AMCL's 0.5 m / 10 deg bin about the truth), and the filter waited many updates for one.
  /// As in the mixture, a guess is weighed by the belief too: one near the estimate (a robot
  /// pushed or slipping) counts as a particle, one from anywhere starts at recovery_far_prior,
  /// so that it takes over only when the scan fits it far better. Without that, in offices
  /// built of alike rooms a guess in the next room fitted as well as the truth whenever a
  /// passer-by spoilt a scan, and the estimate jumped there (suite: tracking 0.12 -> 2.5 m
  /// median in offices before the first kidnap).
  struct Guess {
    sdk::Pose pose;
    double prior = 1.0;
    int place = -1;  // the searched place it was drawn about, if any
  };
  Guess guess(sdk::Random& random) const {
    if (recovery_candidates_ <= 1) return {free_.sample(random), 1.0};  // AMCL's
    Guess best;
    float best_log_p = -std::numeric_limits<float>::infinity();
    for (std::size_t c = 0; c < recovery_candidates_; ++c) {
      const bool near = c % 2 == 1;
      int place = -1;
      const sdk::Pose pose = near ? near_estimate(random) : from_afar(random, place);
      const float log_p = scan_log_p(pose);
      if (log_p > best_log_p)
        best = {pose, near ? 1.0 : recovery_far_prior_, near ? -1 : place}, best_log_p = log_p;
    }
    return best;
  }

  /// A pose about the estimate, for a robot pushed or slipping rather than carried away.
  sdk::Pose near_estimate(sdk::Random& random) const {
    const double dx = random.normal(recovery_near_sigma_m_);
    const double dy = random.normal(recovery_near_sigma_m_);
    const double dtheta = random.normal(recovery_near_sigma_rad_);
    return {estimate_at_mark_(0) + dx, estimate_at_mark_(1) + dy,
            sdk::wrap(estimate_at_mark_(2) + dtheta)};
  }

  /// A pose from anywhere: about one of the places the latest search found (moved by the
  /// odometry since; `place` its index), or without them uniform over the free cells.
  sdk::Pose from_afar(sdk::Random& random, int& place) const {
    if (places_.empty()) return free_.sample(random);
    const auto k =
        std::min(places_.size() - 1,
                 static_cast<std::size_t>(random.uniform() * static_cast<double>(places_.size())));
    place = static_cast<int>(k);
    const sdk::Pose at = sdk::compose(places_[k], moved_since_search_);
    return {at(0) + random.normal(kPlaceSigmaM), at(1) + random.normal(kPlaceSigmaM),
            sdk::wrap(at(2) + random.normal(kPlaceSigmaRad))};
  }

  /// The places of the whole map that fit the latest scan best (PlaceSearch, each refined on the
  /// filter's own field), once the filter has injected for recovery_search_updates updates in a
  /// row and again every recovery_search_updates updates while it goes on; forgotten when it
  /// stops. Why: a uniform draw lands in AMCL's 0.5 m / 10 deg bin about the truth once in
  /// 30 000 in a 20 x 12 m room, and best of ten rarely; a kidnapped filter waited tens of seconds
  /// for one and often never got it (suite: 21 of the 118 kidnaps the laser tells apart
  /// unrecovered). Not at the first injecting update: a slip leaves the belief a few decimetres
  /// off for an update or two, the guesses about the estimate set that right, and a well-fitted
  /// twin elsewhere would outweigh it meanwhile.
  void search_places(bool injecting) {
    if (!search_) return;
    if (!injecting) {
      injecting_for_ = 0, searched_at_update_ = -1;
      places_.clear();
      return;
    }
    ++injecting_for_;
    if (!places_.empty())
      moved_since_search_ = sdk::between(odometry_at_search_, pf_.odometry().mark());
    const bool due =
        injecting_for_ >= recovery_search_updates_ &&
        (searched_at_update_ < 0 || updates_ - searched_at_update_ >= recovery_search_updates_);
    if (!due || beam_x_.size() < kSearchMinBeams) return;
    searched_at_update_ = updates_;
    odometry_at_search_ = pf_.odometry().mark();
    moved_since_search_ = sdk::Pose::Zero();
    places_.clear();
    const auto fit = [&](const sdk::Pose& pose) { return static_cast<double>(scan_log_p(pose)); };
    for (const sdk::ScoredPose& place : search_->best(beam_x_, beam_y_, kSearchPlaces))
      places_.push_back(
          sdk::ascend(place.pose, fit, search_->half_step_m(), search_->half_step_rad()).first);
  }

  /// log p(latest scan's chosen beams | pose).
  float scan_log_p(const sdk::Pose& pose) const {
    scan_log_p_.resize(beam_x_.size());
    field_.log_p_at(pose(0), pose(1), std::cos(pose(2)), std::sin(pose(2)), beam_x_, beam_y_,
                    scan_log_p_);
    float sum = 0.0f;
    for (const float v : scan_log_p_) sum += v;
    return sum;
  }

  /// Low-variance draws, as many as KLD sampling asks for; with recovery, some uniform poses.
  void resample() {
    double inject_probability = 0.0;
    if (averages_.alpha_slow > 0.0) {
      averages_.update(w_avg_);
      inject_probability = std::max(0.0, averages_.deficit(recovery_level_));
      // A scan the estimate explains but for shortened beams: people, not a wrong pose.
      if (inject_probability > 0.0 && recovery_through_share_ > 0.0 && !beam_x_.empty()) {
        const sdk::BeamsAgainstMap beams = sdk::beams_against_map(
            grid_, estimate_at_mark_(0), estimate_at_mark_(1), estimate_at_mark_(2), sensor_x_,
            sensor_y_, beam_x_, beam_y_, recovery_through_margin_m_);
        const auto count = static_cast<double>(beam_x_.size());
        through_share_ = static_cast<double>(beams.through) / count;
        short_share_ = static_cast<double>(beams.short_of_walls) / count;
        if (through_share_ < recovery_through_share_) inject_probability = 0.0;
      }
      search_places(inject_probability > 0.0);
    }
    sdk::ParticleSet& particles = pf_.particles();
    sdk::Random& random = pf_.random();
    const std::size_t n = particles.size();
    cumulative_.resize(n);
    double sum = 0.0;
    for (std::size_t i = 0; i < n; ++i) cumulative_[i] = sum += particles.weight[i];
    next_.resize(0);
    next_.x.reserve(max_particles_), next_.y.reserve(max_particles_),
        next_.theta.reserve(max_particles_);
    bins_.clear();
    std::size_t needed = min_particles_;
    injected_ = 0;
    guesses_.resize(0);
    guess_place_.clear();
    // Systematic draws until KLD says stop, every prefix an even spread over all the weights.
    draws_.reset(cumulative_, random.uniform());
    // A particle drawn again is in the bin it was in: binned once (drawn_bin_, per particle of
    // the old set), where a tracking filter draws its heavy particles many times over.
    drawn_bin_.assign(n, kNoBin);
    next_bin_.clear();
    // The guesses go after the draws (fresh_ of them at the end): weigh() and the estimate tell
    // them apart.
    std::size_t drawn = 0;
    for (; drawn < std::max(needed, min_particles_) && drawn < max_particles_; ++drawn) {
      bool new_bin = false;
      if (inject_probability > 0.0 && random.uniform() < inject_probability) {
        const Guess g = guess(random);
        const double x = g.pose(0), y = g.pose(1), theta = g.pose(2);
        guesses_.x.push_back(x), guesses_.y.push_back(y), guesses_.theta.push_back(theta);
        guesses_.weight.push_back(g.prior);
        guess_place_.push_back(g.place);
        ++injected_;
        new_bin = bins_.insert(bins_.bin_of(x, y, theta)).second;
      } else {
        const std::size_t i = draws_.next();
        const double x = particles.x[i], y = particles.y[i], theta = particles.theta[i];
        next_.x.push_back(x), next_.y.push_back(y), next_.theta.push_back(theta);
        if (drawn_bin_[i] == kNoBin)
          std::tie(drawn_bin_[i], new_bin) = bins_.insert(bins_.bin_of(x, y, theta));
        next_bin_.push_back(drawn_bin_[i]);
      }
      if (new_bin) needed = sdk::kld_sample_count(bins_.size(), kld_err_, kld_z_);
    }
    last_bins_ = bins_.size();
    next_.x.insert(next_.x.end(), guesses_.x.begin(), guesses_.x.end());
    next_.y.insert(next_.y.end(), guesses_.y.begin(), guesses_.y.end());
    next_.theta.insert(next_.theta.end(), guesses_.theta.begin(), guesses_.theta.end());
    fresh_ = guesses_.x.size();
    std::swap(particles.x, next_.x), std::swap(particles.y, next_.y),
        std::swap(particles.theta, next_.theta);
    pf_.equalise_weights();
    // Without guesses the bins are those of the new set, numbered in its order: what
    // compute_estimate() would bin again.
    binned_ = fresh_ == 0;
    if (binned_) std::swap(particle_bin_, next_bin_);
    if (fresh_ > 0) {
      // The prior of "carried to a searched place" is recovery_far_prior, however many guesses
      // were drawn about it: split among them. (Uniform guesses are each a place of their own.)
      // Without that a twin the search found again and again outweighed, by its numbers alone,
      // a belief a slip had left a few decimetres off for one scan.
      place_guesses_.assign(places_.size(), 0);
      for (const int k : guess_place_)
        if (k >= 0) ++place_guesses_[static_cast<std::size_t>(k)];
      for (std::size_t g = 0; g < guess_place_.size(); ++g)
        if (guess_place_[g] >= 0)
          guesses_.weight[g] /=
              static_cast<double>(place_guesses_[static_cast<std::size_t>(guess_place_[g])]);
      // A prior is against a particle's weight, 1/n after equalise_weights (until 2026-11-26
      // the priors went in as they were: a guess about the estimate weighed n particles, one
      // from afar n x 1e-6).
      std::vector<double>& weight = particles.weight;
      const double particle = weight.front();
      std::transform(guesses_.weight.begin(), guesses_.weight.end(),
                     weight.end() - static_cast<std::ptrdiff_t>(fresh_),
                     [&](double prior) { return prior * particle; });
      sdk::normalize(weight);
    }
  }

  /// Mean and covariance of the heaviest cluster of occupied bins (26-connected), of the
  /// particles a scan has weighed (all of them if none has been); with estimate stable, of the
  /// mode reported before (`held`: that estimate moved by the odometry since) while a rival has
  /// not yet settled (sdk::StableMode).
  void compute_estimate(const std::optional<sdk::Pose>& held = std::nullopt) {
    const sdk::ParticleSet& particles = pf_.particles();
    const std::size_t n = particles.size();
    // The guesses (the last fresh_) count once weighed, or when nothing else is left.
    const std::size_t counted = fresh_ < n ? n - fresh_ : n;
    sdk::ParticleClusters& clusters = stable_.clusters();
    if (binned_)
      clusters.compute_binned(particles, bins_, particle_bin_);
    else
      clusters.compute(particles, counted, bins_);
    binned_ = false;
    if (estimate_stable_) {
      stable_.choose(particles, counted, held);
      mean_ = stable_.mean();
      covariance_ = stable_.covariance();
    } else {
      clusters.moments(particles, clusters.heaviest(), mean_, covariance_);
    }
  }

  sdk::ParticleFilter pf_;  // with max_particles_ at the start; KLD sampling changes the count
  sdk::ParticleSet next_, guesses_;
  sdk::StableMode stable_;  // its clusters are the estimate's
  bool estimate_stable_ = true;
  sdk::OdometryNoise noise_;
  sdk::LikelihoodFieldDef field_def_;
  sdk::LikelihoodField field_;
  bool field_ready_ = false, update_pending_ = false;
  locsim_occupancy_grid grid_{};
  std::vector<std::uint8_t> grid_cells_;
  sdk::FreeSpace free_;
  std::size_t min_particles_, max_particles_, max_beams_, recovery_candidates_;
  double kld_err_, kld_z_, update_min_d_, update_min_a_;
  int resample_interval_;
  sdk::LikelihoodAverages averages_;  // recovery_alpha_slow, recovery_alpha_fast
  double w_avg_ = 0.0;
  double recovery_through_share_ = 0.0, recovery_through_margin_m_ = 0.0;
  double sensor_x_ = 0.0, sensor_y_ = 0.0;          // the latest scan's origin in the robot frame
  double through_share_ = 0.0, short_share_ = 0.0;  // of its beams, when last asked
  double recovery_level_, recovery_far_prior_, recovery_near_sigma_m_, recovery_near_sigma_rad_;
  // The place search (with recovery and recovery_search_updates > 0): the places it found, where
  // the odometry stood then and how far it has moved since.
  static constexpr std::size_t kSearchPlaces = 16;    // places kept per search [-]
  static constexpr std::size_t kSearchMinBeams = 10;  // fewer end points tell nothing apart [-]
  // Spread of a guess about a place: the refined place fits the scan it was found on; the robot
  // has moved since by odometry that slips [m], [rad].
  static constexpr double kPlaceSigmaM = 0.1, kPlaceSigmaRad = 2.5 * std::numbers::pi / 180.0;
  long recovery_search_updates_ = 0, searched_at_update_ = -1, injecting_for_ = 0;
  std::optional<sdk::PlaceSearch> search_;
  std::vector<sdk::Pose> places_;
  std::vector<int> guess_place_;            // per guess of the last resampling: its place
  std::vector<std::size_t> place_guesses_;  // per place: guesses drawn about it
  sdk::Pose odometry_at_search_ = sdk::Pose::Zero(), moved_since_search_ = sdk::Pose::Zero();
  sdk::Pose estimate_at_mark_ = sdk::Pose::Zero();  // the estimate moved to the latest update
  std::vector<double> beam_x_, beam_y_, log_w_, cumulative_;
  mutable std::vector<float> scan_log_p_;  // scan_log_p's per-beam terms, storage reused
  sdk::PoseBins bins_;  // KLD sampling's in resample(), the clusters' in compute_estimate()
  static constexpr std::size_t kNoBin = sdk::PoseBins::kNone;
  sdk::OpenEndedDraws draws_;
  // Per particle: its bin (particle_bin_), in the old set while resampling (drawn_bin_), in the
  // new one (next_bin_); binned_: particle_bin_ and bins_ are the current set's already.
  std::vector<std::size_t> particle_bin_, drawn_bin_, next_bin_;
  bool binned_ = false;
  std::size_t fresh_ = 0;  // the last resampling's guesses, at the end of the set, not yet weighed
  sdk::Pose mean_ = sdk::Pose::Zero();
  Eigen::Matrix3d covariance_ = Eigen::Matrix3d::Identity();
  long updates_ = 0, reseeds_ = 0;
  std::size_t last_bins_ = 0, injected_ = 0;
  double n_eff_ = 0.0;
};

}  // namespace amcl
