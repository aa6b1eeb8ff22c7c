#include "landmark_pf.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <locsim/vector_math.hpp>
#include <tuple>

namespace locsim::particle_filters {

namespace {

/// The regularised particle filter's kernel (Musso, Oudjane and Le Gland 2001): after resampling,
/// each particle moves by a draw of N(0, (s h)^2 C), C the set's covariance (the heading's about
/// its circular mean), h = (4 / (n (d + 2)))^(1 / (d + 4)) the optimal width of a Gaussian kernel
/// for d = 3 dimensions and n particles, s the `regularization` scale. Where the detections are
/// sharp a resampled set holds copies of a few particles; without the kernel they stay together
/// and the set claims a certainty that n particles cannot represent (MRCLAM: MCL's truth in its
/// 95 % ellipse 69 % of the time with 200 particles, 83 % with 1000).
void regularize(sdk::ParticleSet& p, double scale, sdk::Random& random) {
  const auto n = static_cast<double>(p.size());
  if (p.size() < 2 || !(scale > 0.0)) return;
  sdk::Pose mean;
  Eigen::Matrix3d covariance;
  sdk::mean_and_covariance(p, mean, covariance);
  const double h = scale * std::pow(4.0 / (n * 5.0), 1.0 / 7.0);
  const Eigen::LLT<Eigen::Matrix3d> llt(covariance + 1e-18 * Eigen::Matrix3d::Identity());
  if (llt.info() != Eigen::Success) return;
  const Eigen::Matrix3d L = h * llt.matrixL().toDenseMatrix();
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double a = random.normal(), b = random.normal(), c = random.normal();
    const Eigen::Vector3d d = L * Eigen::Vector3d(a, b, c);
    p.x[i] += d(0);
    p.y[i] += d(1);
    p.theta[i] = sdk::wrap(p.theta[i] + d(2));
  }
}

}  // namespace

LandmarkParticleFilter::LandmarkParticleFilter(const locsim_init& init, const sdk::Params& params,
                                               Recovery recovery)
    : recovery_(recovery),
      pf_(static_cast<std::size_t>(params.integer("particles")), init.seed,
          sdk::resampler_from(params.string("resampler"))) {
  noise_ = {params.number("alpha1"), params.number("alpha2"), params.number("alpha3"),
            params.number("alpha4"), params.flag("variance_form"),
            // The robot's floor and the filter's roughening: independent, so in quadrature.
            std::hypot(params.number("motion_floor_m"), params.number("roughening_m")),
            std::hypot(params.number("motion_floor_deg"), params.number("roughening_deg")) *
                std::numbers::pi / 180.0};
  detection_noise_ = sdk::DetectionNoise::from(params);
  detection_bias_ = sdk::DetectionBias::from(params);
  correlated_ = sdk::CorrelatedRangeBearing::from(params);
  response_ = sdk::CommandFollower(sdk::CommandResponse::from(params));
  wander_ = sdk::GainWander::from(params);
  regularization_ = params.number("regularization");
  reject_inconsistent_ = params.flag("reject_inconsistent");
  consistency_level_ = params.number("consistency_level");
  log_outlier_likelihood_ = std::log(params.number("outlier_likelihood"));
  log_impossible_likelihood_ = std::log(params.number("impossible_likelihood"));
  const std::string motion_model = params.string("motion_model");
  if (motion_model != "odometry" && motion_model != "wheels")
    throw std::invalid_argument("motion_model must be odometry or wheels, not '" + motion_model +
                                "'");
  wheel_motion_ = motion_model == "wheels";
  pf_.odometry().use_gyro(params.flag("use_gyro"));
  k_left_ = params.number("k_left");
  k_right_ = params.number("k_right");
  wheel_base_m_ = init.robot->wheel_base_m;
  if (wheel_motion_) {
    wheels_.emplace(wheel_base_m_);
    wheels_->use_gyro(params.flag("use_gyro"));
  }
  const std::string estimate = params.string("estimate");
  if (estimate != "stable" && estimate != "mean")
    throw std::invalid_argument("estimate must be stable or mean, not '" + estimate + "'");
  estimate_stable_ = estimate == "stable";
  stable_ = sdk::StableMode(
      {static_cast<int>(params.integer("switch_updates")), params.number("switch_share")});
  reset_after_steps_ = params.integer("reset_after_steps");
  reset_min_detections_ = static_cast<std::size_t>(params.integer("reset_min_detections"));
  use_ptz_ = params.flag("use_ptz");
  use_omni_ = params.flag("use_omni");
  use_range_bearing_ = params.flag("use_range_bearing");
  if (!use_ptz_ && !use_omni_ && !use_range_bearing_)
    throw std::invalid_argument("use_ptz, use_omni and use_range_bearing are all off");
  switch (recovery_) {
    case Recovery::kNone:
      break;
    case Recovery::kSensorResetting:
      srl_threshold_ = params.number("threshold");
      break;
    case Recovery::kAdaptiveSensorResetting:
      asrl_mu_ = params.number("mu");
      asrl_pt_ = params.number("p_t");
      break;
    case Recovery::kAugmented:
      averages_.alpha_slow = params.number("alpha_slow");
      averages_.alpha_fast = params.number("alpha_fast");
      injection_level_ = params.number("injection_level");
      if (averages_.alpha_slow >= averages_.alpha_fast)
        throw std::invalid_argument("alpha_slow must be below alpha_fast");
      {
        const std::string injection = params.string("injection");
        if (injection != "uniform" && injection != "sensors")
          throw std::invalid_argument("injection must be uniform or sensors, not '" + injection +
                                      "'");
        inject_uniform_ = injection == "uniform";
      }
      break;
  }
  for (size_t i = 0; i < init.map->landmark_count; ++i) {
    const locsim_landmark& l = init.map->landmarks[i];
    landmarks_.push_back({l.id, l.color != nullptr ? l.color : "", l.x, l.y});
  }
  if (landmarks_.empty())
    throw std::invalid_argument("needs a landmark map; this world has no landmarks");
  free_ = sdk::FreeSpace(init.map->grid);
  if (recovery_ == Recovery::kAugmented && inject_uniform_ && free_.empty())
    throw std::invalid_argument(
        "injection uniform needs an occupancy grid with free cells; this world has none");
  pf_.initialise(init, free_);
}

void LandmarkParticleFilter::prepare_step(double t_s, const locsim_landmarks& reading) {
  if (step_.size() < reading.count) step_.resize(reading.count);
  step_count_ = 0;
  for (std::size_t k = 0; k < reading.count; ++k) {
    const locsim_detection& d = reading.detections[k];
    // Another robot seen is not on the map; using it (cooperative localization) would need that
    // robot's estimate, which this filter does not have.
    if (d.target != LOCSIM_TARGET_LANDMARK) continue;
    StepDetection& s = step_[step_count_];
    s.candidates.clear();
    for (std::size_t j = 0; j < landmarks_.size(); ++j) {
      const Landmark& l = landmarks_[j];
      if (d.id >= 0 ? l.id == d.id : (d.color != nullptr && l.color == d.color))
        s.candidates.push_back(j);
    }
    if (s.candidates.empty()) continue;  // a landmark not on the map tells nothing
    // The noise follows the camera and the measured range, the same for every particle; the
    // camera's measured bias is taken out (not the omnidirectional camera's: its noise is an
    // ellipse, not a range and a bearing), and a target seen again while its errors persist
    // weighs less.
    const auto inflation = correlated_.inflation(reading.camera, d, t_s);
    const double range_spread = std::sqrt(inflation.range);
    const double bearing_spread = std::sqrt(inflation.bearing);
    if (reading.camera == LOCSIM_CAMERA_OMNI) {
      const auto sigma = detection_noise_.at(reading.camera, d.range_m);
      s.range_m = d.range_m;
      s.bearing_rad = d.bearing_rad;
      s.sigma_range_m = range_spread * sigma.range_m;
      s.sigma_bearing_rad = bearing_spread * sigma.bearing_rad;
    } else {
      const auto z = detection_bias_.corrected(d.range_m, d.bearing_rad);
      const auto sigma = detection_noise_.at(reading.camera, z.model_x_m);
      s.range_m = z.range_m;
      s.bearing_rad = z.bearing_rad;
      s.sigma_range_m = range_spread * sigma.range_m * z.range_scale;
      s.sigma_bearing_rad = bearing_spread * sigma.bearing_rad;
    }
    ++step_count_;
  }
}

double LandmarkParticleFilter::with_outlier(double log_match) const {
  if (!std::isfinite(log_outlier_likelihood_)) return log_match;
  const double hi = std::max(log_match, log_outlier_likelihood_);
  return hi + std::log1p(std::exp(-std::abs(log_match - log_outlier_likelihood_)));
}

double LandmarkParticleFilter::log_likelihood(double x, double y, double theta) const {
  double total = 0.0;
  for (std::size_t k = 0; k < step_count_; ++k) {
    const StepDetection& d = step_[k];
    double best = -std::numeric_limits<double>::infinity();
    for (const std::size_t j : d.candidates) {
      best = std::max(
          best, sdk::landmark_log_match(x, y, theta, d.range_m, d.bearing_rad, landmarks_[j].x,
                                        landmarks_[j].y, d.sigma_range_m, d.sigma_bearing_rad));
    }
    total += with_outlier(best);
  }
  return total;
}

void LandmarkParticleFilter::weigh_particles() {
  const sdk::ParticleSet& particles = pf_.particles();
  const auto n = static_cast<Eigen::Index>(particles.size());
  headings_.compute(particles);
  if (detection_match_.size() < step_count_) detection_match_.resize(step_count_);
  // Each detection's log match at every particle, with its best-matching candidate.
  for (std::size_t k = 0; k < step_count_; ++k) {
    const StepDetection& d = step_[k];
    std::vector<double>& match = detection_match_[k];
    for (std::size_t c = 0; c < d.candidates.size(); ++c) {
      const Landmark& l = landmarks_[d.candidates[c]];
      sdk::landmark_log_match(particles, headings_, d.range_m, d.bearing_rad, l.x, l.y,
                              d.sigma_range_m, d.sigma_bearing_rad,
                              c == 0 ? match : candidate_match_);
      if (c > 0) {  // an ambiguous colour: the best-matching landmark of that colour
        Eigen::Map<Eigen::ArrayXd>(match.data(), n) =
            Eigen::Map<Eigen::ArrayXd>(match.data(), n)
                .max(Eigen::Map<Eigen::ArrayXd>(candidate_match_.data(), n));
      }
    }
  }
  // A false detection among good ones: the particles explain the others and not it. Dropped, it
  // cannot pull the weights, nor make the filter reset onto its ring; a lone detection the
  // particles do not explain is kept (a kidnapping looks the same).
  rejected_ = 0.0;
  if (reject_inconsistent_ && step_count_ >= 2) {
    std::vector<bool> consistent(step_count_);
    std::size_t consistent_count = 0;
    // The mean over at most 256 particles, evenly strided: after resampling their order is
    // random, and the test is against a level, not a fine value.
    const Eigen::Index stride = std::max<Eigen::Index>(1, n / 256);
    const Eigen::Index samples = (n + stride - 1) / stride;
    for (std::size_t k = 0; k < step_count_; ++k) {
      const double mean = Eigen::Map<const Eigen::ArrayXd, 0, Eigen::InnerStride<>>(
                              detection_match_[k].data(), samples, Eigen::InnerStride<>(stride))
                              .exp()
                              .mean();
      consistent[k] = mean >= consistency_level_;
      consistent_count += consistent[k] ? 1 : 0;
    }
    if (consistent_count > 0 && consistent_count < step_count_) {
      std::size_t kept = 0;
      for (std::size_t k = 0; k < step_count_; ++k) {
        if (!consistent[k]) continue;
        if (kept != k) {
          std::swap(step_[kept], step_[k]);
          std::swap(detection_match_[kept], detection_match_[k]);
        }
        ++kept;
      }
      rejected_ = static_cast<double>(step_count_ - kept);
      step_count_ = kept;
    }
  }
  log_likelihood_.assign(particles.size(), 0.0);
  Eigen::Map<Eigen::ArrayXd> log_w(log_likelihood_.data(), n);
  for (std::size_t k = 0; k < step_count_; ++k) {
    Eigen::Map<Eigen::ArrayXd> match(detection_match_[k].data(), n);
    if (std::isfinite(log_outlier_likelihood_)) {
      // log(p + outlier): the larger of the two plus log1p of the smaller over it. Below e^-40
      // the term adds less than 5e-18 (nothing to a log likelihood beyond 0.04 in magnitude),
      // and its tiny values made log1p ten times slower (subnormal intermediates).
      const double floor = log_outlier_likelihood_;
      mixture_.resize(particles.size());
      Eigen::Map<Eigen::ArrayXd> smaller_over_larger(mixture_.data(), n);
      smaller_over_larger = (-(match - floor).abs()).max(-40.0);
      sdk::vector_math::exp(mixture_, mixture_);
      sdk::vector_math::log1p(mixture_, mixture_);
      match = match.max(floor) + smaller_over_larger;
    }
    log_w += match;
  }
  // Where the robot cannot be (inside an obstacle, beyond the walls): odometry that says the
  // robot drove on while its wheels spun against a wall would carry the particles there.
  if (log_impossible_likelihood_ < 0.0) {
    for (Eigen::Index i = 0; i < n; ++i) {
      if (!free_.possible(particles.x[static_cast<std::size_t>(i)],
                          particles.y[static_cast<std::size_t>(i)]))
        log_w[i] += log_impossible_likelihood_;
    }
  }
}

sdk::Pose LandmarkParticleFilter::sample_from_sensors() {
  // A ring around one detected landmark, heading fixed by the bearing; with more detections,
  // several ring candidates weighted by all of them (their intersection, approximately). Only
  // where the robot can be (FreeSpace::possible): a landmark on a wall has half its ring in the
  // wall or outside the room, and a reset there is a jump to where no evidence can follow (seen
  // on generated rooms: ASRL tracking at 0.1 m jumped 7 m outside the room). In a world without
  // closing walls (MRCLAM: landmarks alone, robots driving beyond their hull) anywhere free is.
  sdk::Random& random = pf_.random();
  constexpr int kCandidates = 16;
  double best_x[kCandidates], best_y[kCandidates], best_theta[kCandidates], log_w[kCandidates];
  int made = 0;
  sdk::Pose last{0.0, 0.0, 0.0};  // the last drawn, free or not: when none is free
  for (int c = 0; c < kCandidates; ++c) {
    const StepDetection& d =
        step_[std::min(step_count_ - 1, static_cast<std::size_t>(
                                            random.uniform() * static_cast<double>(step_count_)))];
    const Landmark& l = landmarks_[d.candidates[std::min(
        d.candidates.size() - 1,
        static_cast<std::size_t>(random.uniform() * static_cast<double>(d.candidates.size())))]];
    const double r = std::max(0.05, d.range_m + random.normal(d.sigma_range_m));
    const double phi = d.bearing_rad + random.normal(d.sigma_bearing_rad);
    const double alpha =
        random.uniform(-std::numbers::pi, std::numbers::pi);  // direction robot -> landmark
    last = {l.x - r * std::cos(alpha), l.y - r * std::sin(alpha), sdk::wrap(alpha - phi)};
    if (!free_.possible(last(0), last(1))) continue;
    best_x[made] = last(0);
    best_y[made] = last(1);
    best_theta[made] = last(2);
    log_w[made] =
        step_count_ > 1 ? log_likelihood(best_x[made], best_y[made], best_theta[made]) : 0.0;
    ++made;
    if (step_count_ == 1) break;  // one detection: the ring itself is the distribution
  }
  if (made == 0) return last;
  const double top = *std::max_element(log_w, log_w + made);
  double sum = 0.0, w[kCandidates];
  for (int c = 0; c < made; ++c) sum += w[c] = std::exp(log_w[c] - top);
  double u = random.uniform() * sum;
  int pick = 0;
  while (pick + 1 < made && (u -= w[pick]) > 0.0) ++pick;
  return {best_x[pick], best_y[pick], best_theta[pick]};
}

void LandmarkParticleFilter::on_odometry(double t_s, const locsim_odometry& reading) {
  // Odometry that reports the command (command_*) is first run through the base's response.
  const locsim_odometry& odometry = response_.follow(t_s, reading);
  pf_.odometry().observe(t_s, odometry);
  if (wheel_motion_) {
    const double dt_s = std::isnan(last_odometry_s_) ? 0.0 : t_s - last_odometry_s_;
    last_odometry_s_ = t_s;
    if (const auto step = wheels_->update(t_s, odometry)) {
      const double slip_m = 0.5 * wheel_base_m_ * std::abs(step->slip_rad);
      if (wander_.active()) {
        sdk::sample_wheel_motion(pf_.particles(), gains_, wander_, dt_s, step->d_left_m,
                                 step->d_right_m, wheel_base_m_, k_left_, k_right_, pf_.random(),
                                 slip_m);
      } else {
        sdk::sample_wheel_motion(pf_.particles(), step->d_left_m, step->d_right_m, wheel_base_m_,
                                 k_left_, k_right_, pf_.random(), slip_m);
      }
    }
    pf_.odometry().mark_now();
  }
}

void LandmarkParticleFilter::apply_pending_motion(double t_s) {
  if (!pf_.odometry().ready()) return;
  const double dt_s = std::isnan(last_step_s_) ? 0.0 : t_s - last_step_s_;
  last_step_s_ = t_s;
  if (wheel_motion_) {  // moved at each odometry reading: only the step's floor is left
    sdk::add_motion_floor(pf_.particles(), noise_, pf_.random());
    return;
  }
  if (wander_.active()) {
    sample_motion_with_gains(pf_.odometry().since_mark(), dt_s);
  } else {
    sdk::sample_motion(pf_.particles(), pf_.odometry().since_mark(), noise_, pf_.random());
  }
  pf_.odometry().mark_now();
}

void LandmarkParticleFilter::sample_motion_with_gains(const sdk::OdometryDelta& d, double dt_s) {
  sdk::ParticleSet& p = pf_.particles();
  sdk::Random& random = pf_.random();
  gains_.fit(p.size(), wander_, random);
  const double phi = wander_.phi(dt_s), renewal = std::sqrt(1.0 - phi * phi);
  const sdk::OdometryDelta spread = sdk::motion_spread(d, noise_);
  for (std::size_t i = 0; i < p.size(); ++i) {
    gains_.v[i] = phi * gains_.v[i] + random.normal(wander_.sigma_v * renewal);
    gains_.omega[i] = phi * gains_.omega[i] + random.normal(wander_.sigma_omega * renewal);
    // The distance by (1 + g_v), both turns by (1 + g_omega), then the paper's noise.
    const double rot1 = (1.0 + gains_.omega[i]) * d.rot1 + random.normal(spread.rot1);
    const double trans = (1.0 + gains_.v[i]) * d.trans + random.normal(spread.trans);
    const double rot2 = (1.0 + gains_.omega[i]) * d.rot2 + random.normal(spread.rot2);
    const double heading = p.theta[i] + rot1;
    p.x[i] += trans * std::cos(heading);
    p.y[i] += trans * std::sin(heading);
    p.theta[i] = sdk::wrap(heading + rot2);
  }
  sdk::add_motion_floor(p, noise_, random);
}

void LandmarkParticleFilter::on_landmarks(double t_s, const locsim_landmarks& reading) {
  const bool wanted = (reading.camera == LOCSIM_CAMERA_PTZ && use_ptz_) ||
                      (reading.camera == LOCSIM_CAMERA_OMNI && use_omni_) ||
                      (reading.camera == LOCSIM_CAMERA_RANGE_BEARING && use_range_bearing_);
  if (!wanted) return;
  prepare_step(t_s, reading);
  if (step_count_ == 0) return;  // nothing (on the map) seen: no information, no step
  ++steps_;
  // The mode reported so far, moved by the odometry since: the stable estimate's anchor.
  const std::optional<sdk::Pose> held =
      stable_ready_ ? std::optional<sdk::Pose>(stable_moved()) : std::nullopt;
  apply_pending_motion(t_s);
  const std::size_t n = pf_.size();
  weigh_particles();
  // The likelihood of the detections under the belief, p~ = sum_i p(z | x_i) / n (each p scaled
  // to 1 at a perfect match), and the same over the belief's particles only, without those
  // injected at the last step: Thrun's w_avg estimates p(z | belief), and the random guesses,
  // which rarely fit, would pull it down by their share, so that injecting lowers w_fast, which
  // injects more, until the whole set is random at every step and the filter never converges
  // again (seen on MRCLAM: 199 of 200 particles replaced per step for the last 800 steps of a
  // run).
  const sdk::Evidence evidence = pf_.weigh(log_likelihood_, injected_ < n ? n - injected_ : n);
  const double log_mean_likelihood = evidence.log_likelihood;
  mean_likelihood_ = std::exp(log_mean_likelihood);
  injected_ = 0;
  n_eff_ = evidence.n_eff;
  if (wander_.active()) {
    gains_.fit(n, wander_, pf_.random());
    pf_.resample(gains_.v, gains_.omega);
  } else {
    pf_.resample();
  }
  regularize(pf_.particles(), regularization_, pf_.random());
  if (estimate_stable_) {  // of the weighed set, before any reset replaces particles
    stable_.update(pf_.particles(), n, cluster_bins_, held);
    stable_ready_ = true;
    odometry_at_stable_ = pf_.odometry().now();
  }

  // How many to replace.
  double fraction = 0.0;
  const double m = static_cast<double>(step_count_);  // detections of mapped landmarks
  switch (recovery_) {
    case Recovery::kNone:
      break;
    case Recovery::kSensorResetting:  // Lenser and Veloso: a fixed threshold on p~
      fraction = 1.0 - mean_likelihood_ / srl_threshold_;
      break;
    case Recovery::kAdaptiveSensorResetting:  // paper 004 eq. 1: ns = n max(0, 1 - p~ / (mu
                                              // p_t^(2m)))
      fraction =
          1.0 - std::exp(log_mean_likelihood - std::log(asrl_mu_) - 2.0 * m * std::log(asrl_pt_));
      break;
    case Recovery::kAugmented:
      // Thrun's w_slow / w_fast on the per-detection (geometric mean) likelihood, so that steps
      // with different numbers of detections compare.
      averages_.update(std::exp(evidence.log_likelihood_head / m));
      fraction = averages_.deficit(injection_level_);
      break;
  }
  // A lone false detection looks, for one frame, like a kidnapping; a kidnapping lasts.
  low_steps_ = fraction > 0.0 ? low_steps_ + 1 : 0;
  if (low_steps_ < reset_after_steps_ || step_count_ < reset_min_detections_) fraction = 0.0;
  const auto resets =
      static_cast<std::size_t>(std::floor(static_cast<double>(n) * std::clamp(fraction, 0.0, 1.0)));
  resets_ = static_cast<double>(resets);
  // Which ones: a random subset (a partial Fisher-Yates shuffle), moved to the tail so that the
  // estimate can leave them out until they have been weighted.
  sdk::ParticleSet& p = pf_.particles();
  sdk::Random& random = pf_.random();
  for (std::size_t k = 0; k < resets; ++k) {
    const std::size_t i = n - 1 - k;
    const std::size_t pick =
        std::min(i, static_cast<std::size_t>(random.uniform() * static_cast<double>(i + 1)));
    std::swap(p.x[i], p.x[pick]);
    std::swap(p.y[i], p.y[pick]);
    std::swap(p.theta[i], p.theta[pick]);
    if (wander_.active()) {  // a new hypothesis: its gains from the prior
      std::swap(gains_.v[i], gains_.v[pick]);
      std::swap(gains_.omega[i], gains_.omega[pick]);
      std::tie(gains_.v[i], gains_.omega[i]) = gains_.draw(wander_, random);
    }
    pf_.set(i, recovery_ == Recovery::kAugmented && inject_uniform_ ? free_.sample(random)
                                                                    : sample_from_sensors());
  }
  injected_ = resets;
}

sdk::Pose LandmarkParticleFilter::stable_moved() const {
  // The odometry since the stable update, not since the follower's mark: with motion_model
  // wheels the particles move, and the mark with them, at every odometry reading.
  if (!pf_.odometry().ready()) return stable_.mean();
  return sdk::compose(stable_.mean(), sdk::between(odometry_at_stable_, pf_.odometry().now()));
}

sdk::Estimate LandmarkParticleFilter::estimate() const {
  if (estimate_stable_ && stable_ready_) {
    const sdk::Pose mean = stable_moved();
    // With motion_model wheels the particles spread at every odometry reading: their spread now,
    // not at the last step (MRCLAM's camera reads a few times a second; frozen, the ellipse held
    // the truth 0.76 of the time instead of 0.87).
    if (wheel_motion_) {
      if (const auto spread = sdk::StableMode::second_moment(
              pf_.particles(), injected_ < pf_.size() ? pf_.size() - injected_ : pf_.size(), mean))
        return {{mean(0), mean(1), mean(2)}, *spread};
    }
    return {{mean(0), mean(1), mean(2)}, stable_.covariance()};
  }
  // The weighted-and-resampled part only: the injected particles are not evidence yet.
  return pf_.estimate(injected_ < pf_.size() ? pf_.size() - injected_ : pf_.size());
}

void LandmarkParticleFilter::particles(std::vector<locsim_pose2>& poses,
                                       std::vector<double>& weights) const {
  pf_.export_particles(poses, weights);
}

std::vector<std::pair<std::string, double>> LandmarkParticleFilter::diagnostics() const {
  return {{"n_eff", n_eff_},
          {"particles", static_cast<double>(pf_.size())},
          {"resets", resets_},
          {"rejected", rejected_},
          {"mean_likelihood", mean_likelihood_},
          {"steps", static_cast<double>(steps_)}};
}

}  // namespace locsim::particle_filters
