// omni_kf: paper 002's self-localization from two landmarks seen by an omnidirectional camera
// (SPEC section 4), with the paper's multi-frame Kalman fusion.
//  - single: each frame in which both landmarks are seen gives the pose by triangulation: the
//    position from the two ranges (the circles' intersection on the side the bearings say), the
//    heading from the two bearings; between such frames the odometry carries the last fix.
//  - multi: the observations of the last `frames` frames are moved into the current robot frame
//    by the odometry (position shifted, covariance C_L = diag(sigma_major^2, sigma_minor^2) along
//    and across the ray rotated with it), Kalman-combined per landmark,
//      C' = C1 - C1 (C1 + C2)^-1 C1,  x' = x1 + C1 (C1 + C2)^-1 (x2 - x1),
//    and the fused positions triangulated.
// The pose covariance is the fused observations' covariance propagated through the
// triangulation (a numerical Jacobian). Landmarks by id (the omni camera reports them) or, when
// it does not, by a colour no other landmark of the map has. The paper uses one fixed pair:
// `landmark_a` and `landmark_b` pick it. By default every landmark of the map is followed and
// each fix uses the pair, among those seen, whose triangulated position is the most certain
// (smallest trace of its covariance): well-conditioned pairs, and a fix wherever any two are seen.
// By default (`fix: least_squares`, beyond the paper) the fix is then the weighted least-squares
// pose of every landmark seen (the SDK's fit_pose_to_points), started at that pair's
// triangulation: the triangulation takes the position from the ranges alone, the camera's noisy
// axis (0.25 m along the ray against 0.08 across), and ignores every other landmark seen.
// `fix: triangulate` is the paper's.
// Between fixes the pose follows the odometry (turned by the gyro where the robot has one, as the
// other filters: a push turns the robot while its wheels drive straight) and its covariance grows
// by paper 002's wheel noise (predict_by_wheels), so that it says how far the pose may have drifted
// since the last fix.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <deque>
#include <locsim/localizer.hpp>
#include <locsim/models.hpp>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

namespace {

namespace sdk = locsim::sdk;
using Vec2 = Eigen::Vector2d;
using Mat2 = Eigen::Matrix2d;

using Observation = sdk::PointEstimate;

class OmniKf final : public sdk::Localizer {
 public:
  explicit OmniKf(const locsim_init& init)
      : wheel_base_m_(init.robot->wheel_base_m), odometry_(init.robot->wheel_base_m) {
    const sdk::Params params(init);
    const std::string mode = params.string("mode");
    if (mode != "single" && mode != "multi")
      throw std::invalid_argument("mode must be single or multi, not '" + mode + "'");
    multi_ = mode == "multi";
    frames_ = static_cast<std::size_t>(params.integer("frames"));
    sigma_major_ = params.number("sigma_major_m");
    sigma_minor_ = params.number("sigma_minor_m");
    sigma_major_per_m_ = params.number("sigma_major_per_m");
    const std::string fix = params.string("fix");
    if (fix != "least_squares" && fix != "triangulate")
      throw std::invalid_argument("fix must be least_squares or triangulate, not '" + fix + "'");
    least_squares_ = fix == "least_squares";
    k_left_ = params.number("k_left");
    k_right_ = params.number("k_right");
    response_ = sdk::CommandFollower(sdk::CommandResponse::from(params));
    odometry_.use_gyro(params.flag("use_gyro"));
    if (init.map == nullptr || init.map->landmark_count < 2)
      throw std::invalid_argument("needs two landmarks on the map");
    const long long id_a = params.integer("landmark_a"), id_b = params.integer("landmark_b");
    if ((id_a < 0) != (id_b < 0))
      throw std::invalid_argument("give both landmark_a and landmark_b, or neither");
    if (id_a >= 0 && id_a == id_b)
      throw std::invalid_argument("landmark_a and landmark_b are the same landmark");
    for (std::size_t i = 0; i < init.map->landmark_count; ++i) {
      const locsim_landmark& l = init.map->landmarks[i];
      if (id_a >= 0 && l.id != id_a && l.id != id_b) continue;
      landmarks_.push_back({l.id, l.color != nullptr ? l.color : "", Vec2(l.x, l.y)});
    }
    if (id_a >= 0) {
      for (const long long id : {id_a, id_b}) {
        if (std::none_of(landmarks_.begin(), landmarks_.end(),
                         [&](const Landmark& l) { return l.id == id; }))
          throw std::invalid_argument("no landmark with id " + std::to_string(id));
      }
      // The paper's order: a, then b.
      if (landmarks_[0].id != id_a) std::swap(landmarks_[0], landmarks_[1]);
    }
    for (Landmark& l : landmarks_) {
      l.unique_color =
          !l.color.empty() &&
          std::count_if(init.map->landmarks, init.map->landmarks + init.map->landmark_count,
                        [&](const locsim_landmark& other) {
                          return other.color != nullptr && l.color == other.color;
                        }) == 1;
    }
    if (init.initial_pose_known) {
      fix_ = sdk::Pose(init.initial_pose.x, init.initial_pose.y, init.initial_pose.theta);
      for (int k = 0; k < 9; ++k) covariance_(k / 3, k % 3) = init.initial_covariance[k];
    }
  }

  void on_odometry(double t_s, const locsim_odometry& reading) override {
    // Odometry that reports the command (command_*) is first run through the base's response.
    const locsim_odometry& odometry = response_.follow(t_s, reading);
    const std::optional<sdk::OdometryStep> step = odometry_.update(t_s, odometry);
    if (!odom_) {
      odom_ = sdk::Pose(odometry.odom_pose.x, odometry.odom_pose.y, odometry.odom_pose.theta);
    } else if (step) {
      // The covariance grows about the pose the estimate has before this step.
      sdk::Pose before = current_pose();
      sdk::predict_by_wheels(before, covariance_, step->d_left_m, step->d_right_m, wheel_base_m_,
                             k_left_, k_right_, 0.5 * wheel_base_m_ * std::abs(step->slip_rad));
      odom_ = sdk::compose(*odom_, step->pose_increment);
    }
    if (!odom_at_fix_) odom_at_fix_ = odom_;
  }
  void on_imu(double t_s, const locsim_imu& imu) override { odometry_.observe_imu(t_s, imu); }

  void on_landmarks(double, const locsim_landmarks& reading) override {
    if (reading.camera != LOCSIM_CAMERA_OMNI || !odom_) return;
    Frame frame{*odom_, std::vector<std::optional<Observation>>(landmarks_.size())};
    for (std::size_t i = 0; i < reading.count; ++i) {
      const locsim_detection& d = reading.detections[i];
      // Another robot seen is not on the map; using it (cooperative localization) would need
      // that robot's estimate, which this filter does not have.
      if (d.target != LOCSIM_TARGET_LANDMARK) continue;
      for (std::size_t k = 0; k < landmarks_.size(); ++k) {
        const Landmark& l = landmarks_[k];
        const bool match =
            d.id >= 0 ? d.id == l.id : (l.unique_color && d.color != nullptr && l.color == d.color);
        if (match) frame.seen[k] = observe(d.range_m, d.bearing_rad);
      }
    }
    frames_seen_.push_back(std::move(frame));
    while (frames_seen_.size() > (multi_ ? frames_ : 1)) frames_seen_.pop_front();
    // Each landmark's observations moved into the current robot frame and fused.
    std::vector<std::optional<Observation>> fused(landmarks_.size());
    for (const Frame& f : frames_seen_) {
      const sdk::Pose then_in_now = sdk::between(*odom_, f.odom);  // that frame in this one
      const double c = std::cos(then_in_now(2)), s = std::sin(then_in_now(2));
      Mat2 rotation;
      rotation << c, -s, s, c;
      for (std::size_t k = 0; k < landmarks_.size(); ++k) {
        if (!f.seen[k]) continue;
        const Observation moved{rotation * f.seen[k]->p + then_in_now.head<2>(),
                                rotation * f.seen[k]->c * rotation.transpose()};
        fused[k] = fused[k] ? sdk::kalman_combine(*fused[k], moved) : moved;
      }
    }
    // The pair whose fix is the most certain in position.
    std::optional<sdk::Pose> best_pose;
    Eigen::Matrix3d best_covariance = Eigen::Matrix3d::Zero();
    bool two_seen = false;
    for (std::size_t a = 0; a < landmarks_.size(); ++a) {
      for (std::size_t b = a + 1; b < landmarks_.size(); ++b) {
        if (!fused[a] || !fused[b]) continue;
        two_seen = true;
        const auto pose = sdk::two_landmark_pose(landmarks_[a].world, landmarks_[b].world,
                                                 fused[a]->p, fused[b]->p);
        if (!pose) continue;
        const Eigen::Matrix3d covariance = pair_covariance(a, b, *fused[a], *fused[b], *pose);
        if (!best_pose || covariance.topLeftCorner<2, 2>().trace() <
                              best_covariance.topLeftCorner<2, 2>().trace()) {
          best_pose = pose;
          best_covariance = covariance;
        }
      }
    }
    if (!two_seen) return;
    if (!best_pose) {
      ++rejected_;
      return;
    }
    if (least_squares_) {
      std::vector<Vec2> world;
      std::vector<Observation> seen;
      for (std::size_t k = 0; k < landmarks_.size(); ++k) {
        if (!fused[k]) continue;
        world.push_back(landmarks_[k].world);
        seen.push_back(*fused[k]);
      }
      if (const auto fit = sdk::fit_pose_to_points(world, seen, *best_pose)) {
        best_pose = fit->pose;
        best_covariance = fit->covariance;
        ++fitted_;
      }
    }
    fix_ = *best_pose;
    odom_at_fix_ = odom_;
    covariance_ = best_covariance;
    ++fixes_;
  }

  sdk::Estimate estimate() const override {
    const sdk::Pose pose = current_pose();
    return {{pose(0), pose(1), sdk::wrap(pose(2))}, covariance_};
  }

  std::vector<std::pair<std::string, double>> diagnostics() const override {
    return {{"fixes", static_cast<double>(fixes_)},
            {"fixes_least_squares", static_cast<double>(fitted_)},
            {"rejected", static_cast<double>(rejected_)}};
  }

 private:
  struct Landmark {
    int id;
    std::string color;
    Vec2 world;
    bool unique_color = false;  // no other landmark of the map has it: a colour identifies it
  };
  struct Frame {
    sdk::Pose odom;                                // odometry when it was taken
    std::vector<std::optional<Observation>> seen;  // per landmark, in that frame's robot frame
  };

  /// The last fix followed by the odometry since.
  sdk::Pose current_pose() const {
    if (odom_ && odom_at_fix_) return sdk::compose(fix_, sdk::between(*odom_at_fix_, *odom_));
    return fix_;
  }

  /// A detection as a point in the robot frame with the camera's C_L rotated onto the ray.
  Observation observe(double range, double bearing) const {
    const double c = std::cos(bearing), s = std::sin(bearing);
    Mat2 rotation;
    rotation << c, -s, s, c;
    const double major = sigma_major_ + sigma_major_per_m_ * range;
    const Mat2 local = Eigen::Vector2d(major * major, sigma_minor_ * sigma_minor_).asDiagonal();
    return {range * Vec2(c, s), rotation * local * rotation.transpose()};
  }

  /// Covariance of the pose triangulated from landmarks `first` and `second`: J C J^T, unless it
  /// claims more certainty in some direction than the Cramer-Rao bound of the two observations
  /// allows (no unbiased pose from them can be that certain): then J C J^T plus the bound. That
  /// happens where
  /// the triangulation's linearisation fails: near the landmarks' line the two range circles
  /// barely meet, the law of cosines is clamped and J loses a column, and a fix with a nearly
  /// singular covariance would win the choice of pair and make the NEES astronomical.
  Eigen::Matrix3d pair_covariance(std::size_t first, std::size_t second, const Observation& a,
                                  const Observation& b, const sdk::Pose& pose) const {
    const Eigen::Matrix3d propagated = propagate(first, second, a, b);
    const auto bound = sdk::covariance_from_information(
        sdk::points_information({landmarks_[first].world, landmarks_[second].world}, {a, b}, pose)
            .information);
    if (!bound) return propagated;
    // propagated v = lambda bound v: lambda >= 1 in every direction for an estimator that returns
    // the true pose from noiseless observations (as the triangulation does). Equality is common
    // (it is efficient in some directions), so a margin for the numerical Jacobian's rounding.
    const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::Matrix3d> ratio(propagated, *bound);
    // Below it, the linearisation has lost a direction (not its spread in the others): add the
    // bound rather than replace the propagated covariance by it.
    if (ratio.info() != Eigen::Success) return propagated + *bound;
    return ratio.eigenvalues().minCoeff() < 0.9 ? propagated + *bound : propagated;
  }

  /// Covariance of the pose triangulated from landmarks `first` and `second`: J C J^T, J by central
  /// differences over the four coordinates of the two fused observations.
  Eigen::Matrix3d propagate(std::size_t first, std::size_t second, const Observation& a,
                            const Observation& b) const {
    Eigen::Matrix<double, 4, 1> z;
    z << a.p, b.p;
    const auto f = [&](const Eigen::Matrix<double, 4, 1>& v) {
      return sdk::two_landmark_pose(landmarks_[first].world, landmarks_[second].world, v.head<2>(),
                                    v.tail<2>());
    };
    const auto centre = f(z);
    Eigen::Matrix<double, 3, 4> jacobian = Eigen::Matrix<double, 3, 4>::Zero();
    constexpr double kStep = 1e-5;
    for (int i = 0; i < 4; ++i) {
      Eigen::Matrix<double, 4, 1> up = z, down = z;
      up(i) += kStep, down(i) -= kStep;
      const auto pu = f(up), pd = f(down);
      if (!pu || !pd || !centre) continue;
      Eigen::Vector3d d = *pu - *pd;
      d(2) = sdk::wrap(d(2));
      jacobian.col(i) = d / (2.0 * kStep);
    }
    Eigen::Matrix4d c = Eigen::Matrix4d::Zero();
    c.topLeftCorner<2, 2>() = a.c;
    c.bottomRightCorner<2, 2>() = b.c;
    return jacobian * c * jacobian.transpose();
  }

  bool multi_ = true, least_squares_ = true;
  std::size_t frames_ = 10;
  double sigma_major_, sigma_minor_, sigma_major_per_m_;
  double wheel_base_m_, k_left_, k_right_;
  sdk::OdometryTracker odometry_;  // the steps between readings, turned by the gyro
  sdk::CommandFollower response_;
  std::vector<Landmark> landmarks_;  // the pair given, else the whole map
  std::deque<Frame> frames_seen_;
  std::optional<sdk::Pose> odom_, odom_at_fix_;
  sdk::Pose fix_ = sdk::Pose::Zero();
  Eigen::Matrix3d covariance_ = Eigen::Matrix3d::Identity() * 100.0;  // no fix yet: unknown
  long fixes_ = 0, fitted_ = 0, rejected_ = 0;
};

constexpr locsim_param_decl kParams[] = {
    {"mode", LOCSIM_PARAM_STRING, 0, 0, 0, "multi",
     "single (each frame triangulated alone) or multi (frames fused, paper 002)"},
    {"frames", LOCSIM_PARAM_INT, 10, 1, 1000, nullptr,
     "multi: frames fused, the current one included [-]"},
    {"sigma_major_m", LOCSIM_PARAM_DOUBLE, 0.25, 1e-6, 100.0, nullptr,
     "observation noise along the ray (the camera's C_L) [m]"},
    {"sigma_minor_m", LOCSIM_PARAM_DOUBLE, 0.08, 1e-6, 100.0, nullptr,
     "observation noise across the ray [m]"},
    {"sigma_major_per_m", LOCSIM_PARAM_DOUBLE, 0.0, 0.0, 10.0, nullptr,
     "growth of the along-ray noise with range [m/m]"},
    {"landmark_a", LOCSIM_PARAM_INT, -1, -1, 1000000, nullptr,
     "id of the first landmark of a fixed pair, as the paper (-1: any pair seen, the most "
     "certain)"},
    {"landmark_b", LOCSIM_PARAM_INT, -1, -1, 1000000, nullptr,
     "id of the second landmark of a fixed pair (-1: any pair seen)"},
    {"fix", LOCSIM_PARAM_STRING, 0, 0, 0, "least_squares",
     "least_squares (the pose that best explains every landmark seen, along and across each ray) "
     "or triangulate (paper 002: the most certain pair's ranges and bearings)"},
    LOCSIM_WHEEL_NOISE_PARAMS,
    LOCSIM_COMMAND_RESPONSE_PARAMS,
    LOCSIM_GYRO_PARAMS};

}  // namespace

LOCSIM_LOCALIZER(OmniKf, "omni_kf",
                 "Two-landmark omni-vision localization, single or multi-frame Kalman fusion "
                 "(paper 002)",
                 kParams)
