#include <algorithm>
#include <cmath>
#include <iterator>
#include <numbers>
#include <stdexcept>

#include "fastslam.hpp"

namespace fastslam {

namespace {
constexpr double kDegToRad = std::numbers::pi / 180.0;

std::size_t heaviest(const std::vector<double>& weights) {
  return static_cast<std::size_t>(std::max_element(weights.begin(), weights.end()) -
                                  weights.begin());
}
}  // namespace

FastSlam::FastSlam(const locsim_init& init, const sdk::Params& params, Mover mover)
    : mover_(mover), pf_(static_cast<std::size_t>(params.integer("particles")), init.seed) {
  motion_ = {params.number("alpha1"), params.number("alpha2"), params.number("alpha3"),
             params.number("alpha4"), false};
  sigma_range_ = params.number("sigma_range_m");
  sigma_bearing_ = params.number("sigma_bearing_deg") * kDegToRad;
  sigma_cross_ = params.number("sigma_cross_m");
  omni_noise_.omni_sigma_major_m = params.number("omni_sigma_major_m");
  omni_noise_.omni_sigma_major_per_m = params.number("omni_sigma_major_per_m");
  omni_noise_.omni_sigma_minor_m = params.number("omni_sigma_minor_m");
  omni_as_range_bearing_ = params.flag("omni_as_range_bearing");
  pf_.odometry().use_gyro(params.flag("use_gyro"));
  new_landmark_chi2_ = params.number("new_landmark_chi2");
  resample_threshold_ = params.number("resample_threshold");
  use_ids_ = params.flag("use_ids");
  use_omni_ = params.flag("use_omni");
  use_ptz_ = params.flag("use_ptz");
  use_range_bearing_ = params.flag("use_range_bearing");
  map_min_observations_ = static_cast<int>(params.integer("map_min_observations"));
  prune_after_misses_ = static_cast<int>(params.integer("prune_after_misses"));
  max_range_m_ = params.number("max_range_m");
  diversity_cell_m_ = params.number("diversity_cell_m");
  diversity_cell_rad_ = params.number("diversity_cell_deg") * kDegToRad;
  if (mover_ == Mover::kFishSwarm) {
    afsa_.visual = params.number("visual_m");
    afsa_.step = params.number("step_m");
    afsa_.crowding = params.number("crowding");
    afsa_.iterations = static_cast<int>(params.integer("iterations"));
    afsa_.prey_tries = static_cast<int>(params.integer("prey_tries"));
    heading_scale_m_ = params.number("heading_scale_m");
    board_noise_from_cloud_ = params.flag("board_noise_from_cloud");
    board_sigma_m_ = params.number("board_sigma_m");
    board_sigma_rad_ = params.number("board_sigma_deg") * kDegToRad;
  } else if (mover_ == Mover::kParticleSwarm) {
    pso_.inertia = params.number("inertia");
    pso_.cognitive = params.number("cognitive");
    pso_.social = params.number("social");
    pso_.iterations = static_cast<int>(params.integer("iterations"));
    pso_.max_speed = params.number("max_speed_m");
    heading_scale_m_ = params.number("heading_scale_m");
  }
  // SLAM starts from where the robot is: that is the map's frame. A global start means nothing.
  const sdk::Pose start =
      init.initial_pose_known
          ? sdk::Pose(init.initial_pose.x, init.initial_pose.y, init.initial_pose.theta)
          : sdk::Pose::Zero();
  pf_.place_all(start);
  maps_.assign(pf_.size(), {});
  mean_ = start;
}

void FastSlam::on_odometry(double t_s, const locsim_odometry& odometry) {
  // The particles take each reading's motion (the map updates need them where the robot is);
  // the estimate, the mean at the last camera frame, follows the odometry since (pf_.odometry()).
  sdk::OdometryFollower& follower = pf_.odometry();
  follower.observe(t_s, odometry);
  if (last_odom_) {
    sdk::OdometryDelta step = sdk::decompose(*last_odom_, follower.now());
    step.slip_rad = std::abs(follower.slip_rad() - last_slip_rad_);
    sdk::sample_motion(pf_.particles(), step, motion_, pf_.random());
  }
  last_odom_ = follower.now();
  last_slip_rad_ = follower.slip_rad();
}

Eigen::Matrix2d FastSlam::noise(int32_t camera, double range) const {
  Eigen::Matrix2d r = Eigen::Matrix2d::Zero();
  if (camera == LOCSIM_CAMERA_OMNI && !omni_as_range_bearing_) {
    // Wide along the ray (the image radius maps to range coarsely), narrow across it: weighed
    // as sharp as a range-bearing sensor's, its detections of one landmark fell outside each
    // other's gates and every frame started new landmarks (a generated room: 1 of 5 mapped).
    const sdk::DetectionNoise::Sigmas s = omni_noise_.at(camera, range);
    r(0, 0) = s.range_m * s.range_m;
    r(1, 1) = s.bearing_rad * s.bearing_rad;
    return r;
  }
  const double cross = sigma_cross_ / std::max(range, 0.1);
  r(0, 0) = sigma_range_ * sigma_range_;
  r(1, 1) = sigma_bearing_ * sigma_bearing_ + cross * cross;
  return r;
}

const locsim_landmarks& FastSlam::landmarks_only(const locsim_landmarks& reading) {
  const auto of_robot = [](const locsim_detection& d) {
    return d.target != LOCSIM_TARGET_LANDMARK;
  };
  if (std::none_of(reading.detections, reading.detections + reading.count, of_robot))
    return reading;
  landmark_detections_.clear();
  std::remove_copy_if(reading.detections, reading.detections + reading.count,
                      std::back_inserter(landmark_detections_), of_robot);
  landmarks_view_ = reading;
  landmarks_view_.detections = landmark_detections_.data();
  landmarks_view_.count = landmark_detections_.size();
  return landmarks_view_;
}

void FastSlam::associate(const sdk::Pose& pose, const LandmarkMap& map,
                         const locsim_landmarks& reading, std::vector<Match>& matches) const {
  matches.clear();
  for (std::size_t d = 0; d < reading.count; ++d) {
    const locsim_detection& detection = reading.detections[d];
    Match m;
    m.z = {detection.range_m, detection.bearing_rad};
    m.r = noise(reading.camera, detection.range_m);
    if (use_ids_ && detection.id >= 0) {
      const auto it = std::find_if(map.begin(), map.end(),
                                   [&](const MapLandmark& l) { return l.id == detection.id; });
      if (it != map.end()) m.landmark = static_cast<int>(it - map.begin());
    } else {
      // A Cartesian pre-gate before the full innovation: with J = d(point)/d(z), the innovation's
      // Cartesian image is the gap between the detected point and the landmark, with covariance
      // Sigma_l + J R J^T whose largest eigenvalue is at most trace(Sigma_l) + R_rr + r^2 R_bb;
      // so d^2 >= gap^2 / that. A landmark farther than sqrt(best d^2 x that) cannot win (twice
      // the bound, for the linearisation). Most landmarks in a map fail it at one subtraction.
      const double bearing = pose(2) + m.z(1);
      const Eigen::Vector2d point(pose(0) + m.z(0) * std::cos(bearing),
                                  pose(1) + m.z(0) * std::sin(bearing));
      const double spread = m.r(0, 0) + m.z(0) * m.z(0) * m.r(1, 1);
      double best = new_landmark_chi2_;
      for (std::size_t k = 0; k < map.size(); ++k) {
        const sdk::LandmarkEstimate& l = map[k].estimate;
        if ((l.mean - point).squaredNorm() > 4.0 * best * (l.covariance.trace() + spread)) continue;
        const double d2 = sdk::landmark_innovation(l, pose, m.z, m.r).mahalanobis2;
        if (d2 < best) best = d2, m.landmark = static_cast<int>(k);
      }
    }
    matches.push_back(m);
  }
}

double FastSlam::fitness(const LandmarkMap& map, const std::vector<Match>& matches,
                         const sdk::Pose& pose) const {
  // SPEC section 3: f = sum over the associated detections of exp(-1/2 nu^T R^-1 nu).
  double f = 0.0;
  for (const Match& m : matches) {
    if (m.landmark < 0) continue;
    const Eigen::Vector2d predicted =
        sdk::range_bearing(pose, map[static_cast<std::size_t>(m.landmark)].estimate.mean);
    const Eigen::Vector2d nu(m.z(0) - predicted(0), sdk::wrap(m.z(1) - predicted(1)));
    f += std::exp(-0.5 * (nu(0) * nu(0) / m.r(0, 0) + nu(1) * nu(1) / m.r(1, 1)));  // R diagonal
  }
  return f;
}

void FastSlam::on_landmarks(double, const locsim_landmarks& given) {
  const bool wanted = (given.camera == LOCSIM_CAMERA_OMNI && use_omni_) ||
                      (given.camera == LOCSIM_CAMERA_PTZ && use_ptz_) ||
                      (given.camera == LOCSIM_CAMERA_RANGE_BEARING && use_range_bearing_);
  if (!wanted) return;
  // Other robots seen are left out: they move, so they are not landmarks to map, and using them
  // (cooperative localization) would need their estimates, which this filter does not have.
  // Negative evidence (prune) stays with the omnidirectional camera: the range-bearing sensor's
  // field of view is limited, and the SDK does not say what it is.
  const locsim_landmarks& reading = landmarks_only(given);
  const std::size_t n = pf_.size();
  std::vector<std::vector<Match>> matches(n);
  for (std::size_t i = 0; i < n; ++i) associate(pf_.pose(i), maps_[i], reading, matches[i]);

  // The second prediction: the swarm moves the poses uphill on the fitness, each particle
  // scoring a pose against its own map and associations.
  if (mover_ != Mover::kNone && reading.count > 0) {
    std::vector<sdk::Pose> poses(n);
    for (std::size_t i = 0; i < n; ++i) poses[i] = pf_.pose(i);
    // A heading error of d rad moves a detection at range r by r d metres: scaled by the mean
    // range, a step in heading moves the predictions as far as a step in position.
    double scale = heading_scale_m_;
    if (scale <= 0.0) {
      scale = 0.0;
      for (std::size_t d = 0; d < reading.count; ++d) scale += reading.detections[d].range_m;
      scale = std::max(scale / static_cast<double>(reading.count), 0.1);
    }
    afsa_.heading_scale_m = pso_.heading_scale_m = scale;
    const auto f = [&](std::size_t i, const sdk::Pose& pose) {
      return fitness(maps_[i], matches[i], pose);
    };
    evaluations_ += mover_ == Mover::kFishSwarm ? sdk::afsa_move(poses, f, afsa_, pf_.random())
                                                : sdk::pso_move(poses, f, pso_, pf_.random());
    for (std::size_t i = 0; i < n; ++i) pf_.set(i, poses[i]);
  }

  // Landmark EKFs and weights at the (moved) poses. A new landmark weighs in at the gate's
  // density: what a detection just outside every known landmark would have scored.
  std::vector<double> log_likelihoods(n);
  for (std::size_t i = 0; i < n; ++i) {
    const sdk::Pose pose = pf_.pose(i);
    LandmarkMap& map = maps_[i];
    double log_likelihood = 0.0;
    for (std::size_t d = 0; d < matches[i].size(); ++d) {
      const Match& m = matches[i][d];
      if (m.landmark >= 0) {
        MapLandmark& mapped = map[static_cast<std::size_t>(m.landmark)];
        sdk::LandmarkEstimate& landmark = mapped.estimate;
        const sdk::LandmarkInnovation innovation =
            sdk::landmark_innovation(landmark, pose, m.z, m.r);
        log_likelihood += innovation.log_likelihood();
        sdk::update_landmark(landmark, innovation, m.r);
        mapped.misses = 0;
      } else {
        const Eigen::Matrix2d s = 2.0 * m.r;  // of the order of a known landmark's S
        log_likelihood += -0.5 * new_landmark_chi2_ - std::log(2.0 * std::numbers::pi) -
                          0.5 * std::log(s.determinant());
        map.push_back(
            {sdk::init_landmark(pose, m.z, m.r), use_ids_ ? reading.detections[d].id : -1, 0});
      }
    }
    if (reading.camera == LOCSIM_CAMERA_OMNI) prune(map, pose, matches[i]);
    log_likelihoods[i] = log_likelihood;
  }
  const double n_eff = pf_.weigh(log_likelihoods).n_eff;

  // The weighted mean pose (the estimate), then the N_eff test.
  sdk::mean_and_covariance(pf_.particles(), mean_, covariance_);
  pf_.odometry().mark_now();
  n_eff_sum_ += n_eff;
  ++steps_;
  const std::size_t best = heaviest(pf_.particles().weight);
  Board board{pf_.pose(best), maps_[best], mean_};
  if (n_eff < resample_threshold_ * static_cast<double>(n)) resample();
  // The bulletin board: this step's best and this step's mean, for the next directed resampling.
  if (mover_ == Mover::kFishSwarm) board_ = std::move(board);
  std::vector<sdk::Pose> poses(pf_.size());
  for (std::size_t i = 0; i < pf_.size(); ++i) poses[i] = pf_.pose(i);
  diversity_sum_ += sdk::hamming_diversity(poses, diversity_cell_m_, diversity_cell_rad_);
}

void FastSlam::prune(LandmarkMap& map, const sdk::Pose& pose,
                     const std::vector<Match>& matches) const {
  // Negative evidence (Montemerlo et al. 2003): the omnidirectional camera sees all around, so
  // a landmark well inside its range that no detection went to is either occluded or was never
  // there: a duplicate left behind when the pose drifted past the association gate.
  if (prune_after_misses_ == 0) return;
  std::vector<char> seen(map.size(), 0);
  for (const Match& m : matches)
    if (m.landmark >= 0) seen[static_cast<std::size_t>(m.landmark)] = 1;
  for (std::size_t k = 0; k < map.size(); ++k) {
    MapLandmark& l = map[k];
    if (!seen[k] && (l.estimate.mean - pose.head<2>()).norm() < 0.9 * max_range_m_) ++l.misses;
  }
  std::erase_if(map, [&](const MapLandmark& l) { return l.misses >= prune_after_misses_; });
}

void FastSlam::resample() {
  ++resamples_;
  if (mover_ == Mover::kFishSwarm && board_) {
    // x^ = x_board + (mean_t - mean_t-1) + v: the previous step's best, moved as the mean moved
    // since (both means after their camera updates: the odometry between frames is in the
    // difference, or the board's copies would lag a frame's travel behind).
    sdk::Pose moved = board_->pose;
    const sdk::Pose& then = board_->mean;
    moved(0) += mean_(0) - then(0);
    moved(1) += mean_(1) - then(1);
    moved(2) = sdk::wrap(moved(2) + sdk::wrap(mean_(2) - then(2)));
    // v ~ N(0, Sigma): the cloud's own spread by default, so that the board's copies scatter as
    // far as the posterior is wide (a fixed sigma is either wider than a precise sensor allows,
    // and the copies weigh nothing, or narrower than the motion, and they collapse).
    const Eigen::Matrix3d sigma =
        board_noise_from_cloud_
            ? Eigen::Matrix3d(covariance_)
            : Eigen::Vector3d(board_sigma_m_ * board_sigma_m_, board_sigma_m_ * board_sigma_m_,
                              board_sigma_rad_ * board_sigma_rad_)
                  .asDiagonal()
                  .toDenseMatrix();
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(sigma);
    // LDLT with pivoting and clamped D: a degenerate cloud (all copies of one) gives no noise.
    const Eigen::Matrix3d root = ldlt.transpositionsP().transpose() *
                                 Eigen::Matrix3d(ldlt.matrixL()) *
                                 ldlt.vectorD().cwiseMax(0.0).cwiseSqrt().asDiagonal();
    // The heavier half by low-variance draws, then the board's copies: itself, then with noise.
    const std::size_t n = pf_.size();
    std::vector<std::size_t> chosen;
    sdk::directed_resample_indices(pf_.particles().weight, pf_.random(), chosen);
    pf_.keep(chosen, maps_);
    sdk::ParticleSet& p = pf_.particles();
    for (std::size_t r = 0; p.size() < n; ++r) {
      sdk::Pose copy = moved;
      if (r > 0) {
        // One draw per statement: a constructor's arguments are unsequenced and compilers
        // differ. Last component first, as gcc drew them (the results so far are gcc's).
        sdk::Random& random = pf_.random();
        const double n2 = random.normal(), n1 = random.normal(), n0 = random.normal();
        const Eigen::Vector3d v = root * Eigen::Vector3d(n0, n1, n2);
        copy(0) += v(0);
        copy(1) += v(1);
        copy(2) = sdk::wrap(copy(2) + v(2));
      }
      p.x.push_back(copy(0)), p.y.push_back(copy(1)), p.theta.push_back(copy(2));
      maps_.push_back(board_->map);
    }
    pf_.equalise_weights();
    return;
  }
  pf_.resample(maps_);
}

sdk::Estimate FastSlam::estimate() const {
  const sdk::Pose mean = pf_.odometry().follow(mean_);
  return {{mean(0), mean(1), mean(2)}, covariance_};
}

void FastSlam::particles(std::vector<locsim_pose2>& poses, std::vector<double>& weights) const {
  pf_.export_particles(poses, weights);
}

std::vector<std::pair<std::string, double>> FastSlam::diagnostics() const {
  const double steps = std::max(1.0, static_cast<double>(steps_));
  return {{"steps", static_cast<double>(steps_)},
          {"mean_n_eff", n_eff_sum_ / steps},
          {"mean_diversity", diversity_sum_ / steps},
          {"resamples", static_cast<double>(resamples_)},
          {"fitness_evaluations", static_cast<double>(evaluations_)},
          {"landmarks", static_cast<double>(maps_[heaviest(pf_.particles().weight)].size())}};
}

void FastSlam::landmark_map(std::vector<locsim_mapped_landmark>& landmarks) const {
  const LandmarkMap& map = maps_[heaviest(pf_.particles().weight)];
  for (std::size_t k = 0; k < map.size(); ++k) {
    const sdk::LandmarkEstimate& l = map[k].estimate;
    if (l.observations < map_min_observations_) continue;
    landmarks.push_back(
        {static_cast<std::int32_t>(k),
         l.mean.x(),
         l.mean.y(),
         {l.covariance(0, 0), l.covariance(0, 1), l.covariance(1, 0), l.covariance(1, 1)}});
  }
}

}  // namespace fastslam
