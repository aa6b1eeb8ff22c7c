// ekf_landmarks: an extended Kalman filter over (x, y, theta) on the known landmark map.
// Predict with the wheel encoders' travel (paper 002's noise model); update with each camera
// detection's range and bearing, with each camera's own noise model: the PTZ camera's and the
// range-bearing sensor's grows with range (sigma_range_*), the omnidirectional camera's is an
// ellipse along and across the ray (omni_sigma_*, paper 002's C_L; across the ray it is a bearing
// noise of sigma_minor / range), with a camera's measured bias taken out (range_model,
// range_bias_*, bearing_bias_deg) and repeated detections of a target discounted when their errors
// persist (noise_correlation_*). Odometry that reports the command follows the base's response
// (command_*); a base whose gains wander (gain_wander_*) has them in the state, (x, y, theta, g_v,
// g_omega), where the detections estimate them. Detections are associated by id when the camera
// gives ids, else by colour, choosing among same-coloured landmarks the one nearest in Mahalanobis
// distance; a chi-square gate rejects false detections and wrong associations. Most detections
// rejected (lost_*: a push the wheels did not feel) widens the covariance until they fit again:
// the filter says it is lost rather than stay sure of a pose it has left, and finds the pose again
// when the landmarks it sees fit the widened belief. It has no other recovery: a kidnap far away,
// or a turn by more than lost_max_deg, it does not come back from.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <locsim/localizer.hpp>
#include <locsim/models.hpp>
#include <optional>
#include <string>
#include <vector>

namespace {

using locsim::sdk::Pose;

class EkfLandmarks final : public locsim::sdk::Localizer {
 public:
  explicit EkfLandmarks(const locsim_init& init) : odometry_(init.robot->wheel_base_m) {
    const locsim::sdk::Params params(init);
    k_left_ = params.number("k_left");
    k_right_ = params.number("k_right");
    noise_ = locsim::sdk::DetectionNoise::from(params);
    bias_ = locsim::sdk::DetectionBias::from(params);
    correlated_ = locsim::sdk::CorrelatedRangeBearing::from(params);
    response_ = locsim::sdk::CommandFollower(locsim::sdk::CommandResponse::from(params));
    wander_ = locsim::sdk::GainWander::from(params);
    gate_ = params.number("gate_chi2");
    slide_per_slip_ = params.number("slide_per_slip");
    lost_ = locsim::sdk::LostWatch(locsim::sdk::LostWatchDef::from(params));
    odometry_.use_gyro(params.flag("use_gyro"));
    use_ptz_ = params.flag("use_ptz");
    use_omni_ = params.flag("use_omni");
    use_range_bearing_ = params.flag("use_range_bearing");
    wheel_base_m_ = init.robot->wheel_base_m;
    for (size_t i = 0; i < init.map->landmark_count; ++i) {
      const locsim_landmark& l = init.map->landmarks[i];
      landmarks_.push_back({l.id, l.color, {l.x, l.y}});
    }
    if (!init.initial_pose_known) {
      throw std::invalid_argument(
          "ekf_landmarks tracks a known initial pose; it cannot localize globally");
    }
    pose_.x = {init.initial_pose.x, init.initial_pose.y, init.initial_pose.theta};
    pose_.P =
        Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(init.initial_covariance);
    if (wander_.active()) {  // the gains start at their stationary spread, unrelated to the pose
      with_gains_.emplace();
      with_gains_->x << pose_.x, 0.0, 0.0;
      with_gains_->P.setZero();
      with_gains_->P.topLeftCorner<3, 3>() = pose_.P;
      with_gains_->P(3, 3) = wander_.sigma_v * wander_.sigma_v;
      with_gains_->P(4, 4) = wander_.sigma_omega * wander_.sigma_omega;
    }
  }

  void on_odometry(double t_s, const locsim_odometry& odometry) override {
    // The ticks' travel, or (a source without ticks) the travel that makes the odometry pose's
    // increment with the nominal wheel base; turned by the gyro when the robot has one, the
    // wheels' extra turn their slip.
    // Odometry that reports the command (command_*) is first run through the base's response.
    const double dt_s = std::isnan(last_odometry_s_) ? 0.0 : t_s - last_odometry_s_;
    last_odometry_s_ = t_s;
    if (const auto step = odometry_.update(t_s, response_.follow(t_s, odometry))) {
      const double slip_m = 0.5 * wheel_base_m_ * std::abs(step->slip_rad);
      if (with_gains_) {
        locsim::sdk::predict_by_wheels_and_gains(with_gains_->x, with_gains_->P, step->d_left_m,
                                                 step->d_right_m, wheel_base_m_, k_left_, k_right_,
                                                 slip_m, wander_, dt_s);
      } else {
        locsim::sdk::predict_by_wheels(pose_.x, pose_.P, step->d_left_m, step->d_right_m,
                                       wheel_base_m_, k_left_, k_right_, slip_m);
      }
      // Wheels that slipped against the gyro (a push, a wheel spinning) say the body moved by
      // about as much, in a direction they do not show: a person's shove slid the robot 2-4
      // times its wheels' slip (crowd collisions, over 1.6 s), which the wheels' noise above,
      // along the heading only, leaves out.
      const double slide_m2 = slide_per_slip_ * slide_per_slip_ * slip_m * slip_m;
      if (with_gains_) {
        with_gains_->P(0, 0) += slide_m2, with_gains_->P(1, 1) += slide_m2;
      } else {
        pose_.P(0, 0) += slide_m2, pose_.P(1, 1) += slide_m2;
      }
    }
  }
  void on_imu(double t_s, const locsim_imu& imu) override { odometry_.observe_imu(t_s, imu); }

  void on_landmarks(double t_s, const locsim_landmarks& reading) override {
    if ((reading.camera == LOCSIM_CAMERA_PTZ && !use_ptz_) ||
        (reading.camera == LOCSIM_CAMERA_OMNI && !use_omni_) ||
        (reading.camera == LOCSIM_CAMERA_RANGE_BEARING && !use_range_bearing_)) {
      return;
    }
    for (size_t i = 0; i < reading.count; ++i) {
      // Another robot seen is not a landmark of the map; using it (cooperative localization)
      // would need that robot's estimate, which this filter does not have.
      const locsim_detection& detection = reading.detections[i];
      if (detection.target != LOCSIM_TARGET_LANDMARK) continue;
      const auto inflated = correlated_.inflation(reading.camera, detection, t_s);
      const Eigen::DiagonalMatrix<double, 2> inflation(inflated.range, inflated.bearing);
      if (reading.camera == LOCSIM_CAMERA_OMNI) {
        correct(t_s, detection, {detection.range_m, detection.bearing_rad},
                inflation * noise(reading.camera, detection.range_m));
        continue;
      }
      // The camera's measured bias taken out; the range's noise scales with the correction.
      const auto z = bias_.corrected(detection.range_m, detection.bearing_rad);
      Eigen::Matrix2d R = noise(reading.camera, z.model_x_m);
      R(0, 0) *= z.range_scale * z.range_scale;
      correct(t_s, detection, {z.range_m, z.bearing_rad}, inflation * R);
    }
  }

  locsim::sdk::Estimate estimate() const override {
    if (with_gains_) {
      const auto& x = with_gains_->x;
      return {{x(0), x(1), x(2)}, with_gains_->P.topLeftCorner<3, 3>()};
    }
    return {{pose_.x(0), pose_.x(1), pose_.x(2)}, pose_.P};
  }

  std::vector<std::pair<std::string, double>> diagnostics() const override {
    std::vector<std::pair<std::string, double>> out = {
        {"updates_accepted", accepted_},
        {"updates_rejected", rejected_},
        {"lost", lost_.lost() ? 1.0 : 0.0},
        {"times_lost", static_cast<double>(lost_.times_lost())}};
    if (with_gains_) {
      out.emplace_back("gain_error_v", with_gains_->x(3));
      out.emplace_back("gain_error_omega", with_gains_->x(4));
    }
    return out;
  }

 private:
  struct Landmark {
    int id;
    std::string color;
    Eigen::Vector2d position;
  };

  /// R: the detection's range and bearing variances, by the camera that made it.
  Eigen::Matrix2d noise(std::int32_t camera, double range_m) const {
    const auto sigma = noise_.at(camera, range_m);
    return Eigen::Vector2d(sigma.range_m * sigma.range_m, sigma.bearing_rad * sigma.bearing_rad)
        .asDiagonal();
  }

  /// The state (the pose, or the pose and the gains) and its covariance.
  template <int N>
  struct Belief {
    Eigen::Matrix<double, N, 1> x;
    Eigen::Matrix<double, N, N> P;
  };

  void correct(double t_s, const locsim_detection& detection, const Eigen::Vector2d& z,
               const Eigen::Matrix2d& R) {
    if (with_gains_)
      correct(t_s, *with_gains_, detection, z, R);
    else
      correct(t_s, pose_, detection, z, R);
  }

  /// The update by a detection's range and bearing z (bias taken out) with noise R.
  template <int N>
  void correct(double t_s, Belief<N>& b, const locsim_detection& detection,
               const Eigen::Vector2d& z, const Eigen::Matrix2d& R) {
    // Association: the candidate with the smallest Mahalanobis distance of the innovation.
    double best = std::numeric_limits<double>::infinity();
    Eigen::Vector2d best_innovation;
    Eigen::Matrix<double, 2, N> best_H;
    Eigen::Matrix2d best_S;
    const Pose pose = b.x.template head<3>();
    for (const Landmark& landmark : landmarks_) {
      const bool candidate =
          detection.id >= 0 ? landmark.id == detection.id
                            : (detection.color != nullptr && landmark.color == detection.color);
      if (!candidate) continue;
      Eigen::Matrix<double, 2, 3> H_pose;
      const Eigen::Vector2d predicted =
          locsim::sdk::range_bearing(pose, landmark.position, &H_pose);
      Eigen::Matrix<double, 2, N> H = Eigen::Matrix<double, 2, N>::Zero();
      H.template leftCols<3>() = H_pose;  // the gains are not seen, only what they did
      Eigen::Vector2d innovation = z - predicted;
      innovation(1) = locsim::sdk::wrap(innovation(1));
      const Eigen::Matrix2d S = H * b.P * H.transpose() + R;
      const double d2 = innovation.dot(S.ldlt().solve(innovation));
      if (d2 < best) best = d2, best_innovation = innovation, best_H = H, best_S = S;
    }
    if (!(best < gate_)) {
      ++rejected_;
      // A colour no landmark of the map has says nothing about the pose.
      if (std::isfinite(best)) lost_.rejected(t_s, b.P);
      return;
    }
    ++accepted_;
    lost_.accepted();
    const Eigen::Matrix<double, N, 2> K = b.P * best_H.transpose() * best_S.inverse();
    b.x += K * best_innovation;
    b.x(2) = locsim::sdk::wrap(b.x(2));
    // Joseph form: stays symmetric and positive definite.
    const Eigen::Matrix<double, N, N> I_KH = Eigen::Matrix<double, N, N>::Identity() - K * best_H;
    b.P = I_KH * b.P * I_KH.transpose() + K * R * K.transpose();
  }

  double k_left_, k_right_, gate_, wheel_base_m_, slide_per_slip_;
  locsim::sdk::DetectionNoise noise_;
  locsim::sdk::DetectionBias bias_;
  locsim::sdk::CorrelatedRangeBearing correlated_;
  locsim::sdk::CommandFollower response_;
  locsim::sdk::GainWander wander_;
  locsim::sdk::LostWatch lost_;
  bool use_ptz_, use_omni_, use_range_bearing_;
  std::vector<Landmark> landmarks_;
  Belief<3> pose_;                       // without gain wander
  std::optional<Belief<5>> with_gains_;  // with it
  double last_odometry_s_ = std::numeric_limits<double>::quiet_NaN();
  locsim::sdk::OdometryTracker odometry_;
  double accepted_ = 0, rejected_ = 0;
};

constexpr locsim_param_decl kParams[] = {
    LOCSIM_WHEEL_NOISE_PARAMS,
    {"sigma_range_m", LOCSIM_PARAM_DOUBLE, 0.02, 1e-6, 10.0, nullptr,
     "range noise at zero range (PTZ camera, range-bearing sensor) [m]"},
    {"sigma_range_per_m", LOCSIM_PARAM_DOUBLE, 0.0, 0.0, 10.0, nullptr, "range noise growth [m/m]"},
    {"sigma_range_per_m2", LOCSIM_PARAM_DOUBLE, 0.015, 0.0, 10.0, nullptr,
     "range noise growth with the square of the range (PTZ camera rows) [1/m]"},
    {"sigma_bearing_deg", LOCSIM_PARAM_DOUBLE, 1.5, 1e-6, 90.0, nullptr,
     "bearing noise of the PTZ camera and the range-bearing sensor [deg]"},
    LOCSIM_DETECTION_BIAS_PARAMS,
    LOCSIM_OMNI_NOISE_PARAMS,
    LOCSIM_COMMAND_RESPONSE_PARAMS,
    LOCSIM_GAIN_WANDER_PARAMS,
    LOCSIM_GYRO_PARAMS,
    LOCSIM_LOST_PARAMS,
    {"slide_per_slip", LOCSIM_PARAM_DOUBLE, 4.0, 0.0, 100.0, nullptr,
     "with a gyro: position noise per axis of a step, this times the wheels' slip against the "
     "gyro (half the wheel base times their extra turn): a push or a spinning wheel moved the "
     "body by about as much, in a direction the wheels do not show (0: none) [-]"},
    {"gate_chi2", LOCSIM_PARAM_DOUBLE, 9.21, 0.0, 1e9, nullptr,
     "Mahalanobis gate on the innovation (chi-square, 2 dof; 9.21 = 99 %) [-]"},
    {"use_ptz", LOCSIM_PARAM_BOOL, 1, 0, 1, nullptr, "use the PTZ camera's detections"},
    {"use_omni", LOCSIM_PARAM_BOOL, 1, 0, 1, nullptr,
     "use the omnidirectional camera's detections"},
    {"use_range_bearing", LOCSIM_PARAM_BOOL, 1, 0, 1, nullptr,
     "use the range-bearing sensor's detections"},
};

}  // namespace

LOCSIM_LOCALIZER(EkfLandmarks, "ekf_landmarks",
                 "EKF on the known landmark map with camera range-bearing", kParams)
