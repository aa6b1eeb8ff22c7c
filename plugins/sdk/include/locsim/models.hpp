// Filter maths shared by locsim's localizers and available to every plugin author: motion and
// measurement models with their analytic Jacobians (each tested against finite differences with
// locsim/numeric_jacobian.hpp).
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "locsim/localizer.h"

namespace locsim::sdk {

using Pose = Eigen::Vector3d;  // (x [m], y [m], theta [rad])

/// Wraps to (-pi, pi].
inline double wrap(double angle) {
  if (angle > -std::numbers::pi && angle <= std::numbers::pi)
    return angle;  // the common case, cheap
  double a = std::remainder(angle, 2.0 * std::numbers::pi);
  if (a <= -std::numbers::pi) a += 2.0 * std::numbers::pi;
  return a;
}

/// Differential-drive dead reckoning over one step of wheel travel (d_left, d_right) [m] with
/// wheel base b [m], on the mid-heading:
///   D = (dl + dr) / 2, a = (dr - dl) / b,
///   x' = x + D cos(theta + a/2), y' = y + D sin(theta + a/2), theta' = theta + a.
/// F = d x' / d x (3x3), G = d x' / d (dl, dr) (3x2), when asked for.
inline Pose diff_drive_motion(const Pose& x, double d_left, double d_right, double wheel_base,
                              Eigen::Matrix3d* F = nullptr,
                              Eigen::Matrix<double, 3, 2>* G = nullptr) {
  const double D = 0.5 * (d_left + d_right);
  const double a = (d_right - d_left) / wheel_base;
  const double heading = x(2) + 0.5 * a;
  const double c = std::cos(heading), s = std::sin(heading);
  if (F != nullptr) {
    *F << 1, 0, -D * s,  //
        0, 1, D * c,     //
        0, 0, 1;
  }
  if (G != nullptr) {
    // dD/ddl = dD/ddr = 1/2; da/ddl = -1/b, da/ddr = 1/b; heading moves by a/2.
    const double half_b = 0.5 / wheel_base;
    *G << 0.5 * c + D * s * half_b, 0.5 * c - D * s * half_b,  //
        0.5 * s - D * c * half_b, 0.5 * s + D * c * half_b,    //
        -1.0 / wheel_base, 1.0 / wheel_base;
  }
  return {x(0) + D * c, x(1) + D * s, wrap(x(2) + a)};
}

/// Kalman prediction of pose x and covariance P by one step of wheel travel, with paper 002's
/// input noise Q = diag(k_left^2 |d_left|, k_right^2 |d_right|) (plus slip_m^2 on each wheel:
/// travel the wheels slipped by, OdometryStep::slip_rad times half the wheel base), the two
/// wheels' errors correlated by k_correlation rho (Q's off-diagonal rho k_left k_right
/// sqrt(|d_left| |d_right|), as the simulated encoders' k_correlation makes them):
/// P' = F P F^T + G Q G^T.
inline void predict_by_wheels(Pose& x, Eigen::Matrix3d& P, double d_left, double d_right,
                              double wheel_base, double k_left, double k_right, double slip_m = 0.0,
                              double k_correlation = 0.0) {
  Eigen::Matrix3d F;
  Eigen::Matrix<double, 3, 2> G;
  x = diff_drive_motion(x, d_left, d_right, wheel_base, &F, &G);
  const double slip_m2 = slip_m * slip_m;
  Eigen::Matrix2d Q = Eigen::Vector2d(k_left * k_left * std::abs(d_left) + slip_m2,
                                      k_right * k_right * std::abs(d_right) + slip_m2)
                          .asDiagonal();
  Q(0, 1) = Q(1, 0) =
      k_correlation * k_left * k_right * std::sqrt(std::abs(d_left) * std::abs(d_right));
  P = F * P * F.transpose() + G * Q * G.transpose();
}

/// The body's side slip as motion noise: a drift across the heading that wheels and a gyro do not
/// see (a base on grass, CMU Plaza's lawnmower; the simulator's `side_slip` wander, what
/// `locsim calibrate` writes as `side_slip_k`), its variance growing by k^2 per metre travelled.
/// The world-frame position covariance of a step of `distance_m` along `heading_rad`:
/// k^2 |d| n n^T, n = (-sin, cos) the heading's normal.
inline Eigen::Matrix2d side_slip_covariance(double heading_rad, double distance_m, double k) {
  const Eigen::Vector2d n(-std::sin(heading_rad), std::cos(heading_rad));
  return k * k * std::abs(distance_m) * n * n.transpose();
}

/// side_slip_covariance's k as a plugin parameter, for every filter that predicts by the wheels.
// clang-format off
#define LOCSIM_SIDE_SLIP_PARAM                                                                     \
  {"side_slip_k", LOCSIM_PARAM_DOUBLE, 0.0, 0.0, 1.0, nullptr,                                     \
   "the body's drift across its heading, variance k^2 per metre travelled (0: held to its heading) [m^1/2]"}
// clang-format on

/// Paper 002's wheel noise (predict_by_wheels' k_left, k_right) as plugin parameters: one
/// declaration for every filter that predicts by the wheels.
// clang-format off
#define LOCSIM_WHEEL_NOISE_PARAMS                                                                  \
  {"k_left", LOCSIM_PARAM_DOUBLE, 0.0013, 0.0, 1.0, nullptr, "left wheel random error [m^1/2]"},   \
  {"k_right", LOCSIM_PARAM_DOUBLE, 0.0012, 0.0, 1.0, nullptr, "right wheel random error [m^1/2]"}
// clang-format on

/// Range and bearing from the pose to a point landmark:
///   r = |m - p|, phi = atan2(my - y, mx - x) - theta;  H = d(r, phi) / d x (2x3).
inline Eigen::Vector2d range_bearing(const Pose& x, const Eigen::Vector2d& landmark,
                                     Eigen::Matrix<double, 2, 3>* H = nullptr) {
  const double dx = landmark.x() - x(0), dy = landmark.y() - x(1);
  const double q = dx * dx + dy * dy;
  const double r = std::sqrt(q);
  if (H != nullptr) {
    *H << -dx / r, -dy / r, 0,  //
        dy / q, -dx / q, -1;
  }
  return {r, wrap(std::atan2(dy, dx) - x(2))};
}

/// How noisy a camera's detection is, by the camera that made it: the standard deviations of its
/// range [m] and bearing [rad] at the measured range. The PTZ camera and the range-bearing sensor
/// measure range from an image row, so its noise grows with the range (and its square); the
/// omnidirectional camera's is an ellipse along and across the ray (paper 002's C_L), across the
/// ray a distance, so as a bearing it is wider near the robot (floored at 1 mm of range: a
/// detection at the robot is neither certain in bearing nor infinite).
/// The omnidirectional camera's noise as plugin parameters (DetectionNoise::from reads them),
/// defaults the simulator's omni camera: one declaration for every plugin that weighs it.
// clang-format off
#define LOCSIM_OMNI_NOISE_PARAMS                                                                   \
  {"omni_sigma_major_m", LOCSIM_PARAM_DOUBLE, 0.25, 1e-6, 100.0, nullptr,                          \
   "omnidirectional camera: noise along the ray (the camera's sigma_major_m) [m]"},                \
  {"omni_sigma_major_per_m", LOCSIM_PARAM_DOUBLE, 0.0, 0.0, 10.0, nullptr,                         \
   "omnidirectional camera: growth of the along-ray noise with range [m/m]"},                      \
  {"omni_sigma_minor_m", LOCSIM_PARAM_DOUBLE, 0.08, 1e-6, 100.0, nullptr,                          \
   "omnidirectional camera: noise across the ray [m]"}
// clang-format on

struct DetectionNoise {
  double sigma_range_m = 0.02;          // PTZ, range-bearing: at zero range [m]
  double sigma_range_per_m = 0.0;       // ... growth with the range [m/m]
  double sigma_range_per_m2 = 0.015;    // ... growth with the range's square [1/m]
  double sigma_bearing_rad = 0.026;     // ... bearing [rad]
  double omni_sigma_major_m = 0.25;     // omni: along the ray [m]
  double omni_sigma_major_per_m = 0.0;  // ... its growth with the range [m/m]
  double omni_sigma_minor_m = 0.08;     // ... across the ray [m]

  /// From a plugin's parameters of these names (sigma_bearing_deg in degrees), as
  /// ekf_landmarks and the landmark particle filters declare them.
  template <class Params>
  static DetectionNoise from(const Params& params) {
    return {params.number("sigma_range_m"),
            params.number("sigma_range_per_m"),
            params.number("sigma_range_per_m2"),
            params.number("sigma_bearing_deg") * std::numbers::pi / 180.0,
            params.number("omni_sigma_major_m"),
            params.number("omni_sigma_major_per_m"),
            params.number("omni_sigma_minor_m")};
  }

  struct Sigmas {
    double range_m, bearing_rad;
  };
  Sigmas at(int32_t camera, double range_m) const {
    if (camera == LOCSIM_CAMERA_OMNI) {
      return {omni_sigma_major_m + omni_sigma_major_per_m * range_m,
              std::atan2(omni_sigma_minor_m, std::max(range_m, 1e-3))};
    }
    return {sigma_range_m + (sigma_range_per_m + sigma_range_per_m2 * range_m) * range_m,
            sigma_bearing_rad};
  }
};

/// A camera's systematic error, as `locsim calibrate` measures it, taken out of each detection
/// before a filter weighs it: a bearing bias, and a range that is a line in the distance r or, for
/// a camera that measures depth along its axis (MRCLAM's; the range_bearing sensor's
/// `range_model: depth`), in the depth r cos(phi):
///   distance: z = range_bias_m + (1 + range_bias_per_m) r,
///   depth:    z = range_bias_m + (1 + range_bias_per_m) r cos(phi).
/// corrected() inverts it at the measured bearing less its bias; the identity by default. The
/// range's noise is that of z (DetectionNoise::at at model_x_m, the model's r or r cos(phi)),
/// times range_scale.
// clang-format off
#define LOCSIM_DETECTION_BIAS_PARAMS                                                               \
  {"range_model", LOCSIM_PARAM_STRING, 0, 0, 0, "distance",                                       \
   "what a PTZ or range-bearing camera's range measures (locsim calibrate): distance, or depth "   \
   "along the camera's axis (r cos(bearing))"},                                                    \
  {"range_bias_m", LOCSIM_PARAM_DOUBLE, 0.0, -100.0, 100.0, nullptr,                              \
   "range offset, taken out of every detection's range (locsim calibrate) [m]"},                   \
  {"range_bias_per_m", LOCSIM_PARAM_DOUBLE, 0.0, -0.9, 10.0, nullptr,                             \
   "range scale error: the range measures (1 + this) times the distance or depth [m/m]"},         \
  {"bearing_bias_deg", LOCSIM_PARAM_DOUBLE, 0.0, -90.0, 90.0, nullptr,                            \
   "bearing offset, taken out of every detection's bearing [deg]"},                                \
  {"noise_correlation_s", LOCSIM_PARAM_DOUBLE, 0.0, 0.0, 1e6, nullptr,                            \
   "how long a target's detection errors persist (locsim calibrate): a detection of a target "     \
   "seen dt before counts (1 - rho) / (1 + rho) of an independent one, rho = exp(-dt / this); "    \
   "0: independent [s]"},                                                                          \
  {"noise_correlation_slow_s", LOCSIM_PARAM_DOUBLE, 0.0, 0.0, 1e6, nullptr,                       \
   "... a slower part of the errors persists this long (locsim calibrate; 0: none) [s]"},          \
  {"noise_correlation_slow_share", LOCSIM_PARAM_DOUBLE, 0.0, 0.0, 0.99, nullptr,                  \
   "... the slow part's share of the errors' variance: however often a target is seen, its "      \
   "detections together weigh at most 1 / this of one [-]"},                                      \
  {"bearing_noise_correlation_s", LOCSIM_PARAM_DOUBLE, -1.0, -1.0, 1e6, nullptr,                  \
   "the bearing's own noise_correlation_s, when its errors persist otherwise than the range's "    \
   "(locsim calibrate); -1: the range's [s]"},                                                     \
  {"bearing_noise_correlation_slow_s", LOCSIM_PARAM_DOUBLE, -1.0, -1.0, 1e6, nullptr,             \
   "the bearing's own noise_correlation_slow_s; -1: the range's [s]"},                            \
  {"bearing_noise_correlation_slow_share", LOCSIM_PARAM_DOUBLE, -1.0, -1.0, 0.99, nullptr,        \
   "the bearing's own noise_correlation_slow_share; -1: the range's [-]"}
// clang-format on

struct DetectionBias {
  bool depth = false;             // range_model depth: the range measures r cos(phi)
  double range_bias_m = 0.0;      // z at zero distance or depth [m]
  double range_bias_per_m = 0.0;  // z's scale error [m/m]
  double bearing_bias_rad = 0.0;  // [rad]

  /// From a plugin's parameters LOCSIM_DETECTION_BIAS_PARAMS declares (bearing in degrees);
  /// throws std::invalid_argument for a range_model other than distance or depth.
  template <class Params>
  static DetectionBias from(const Params& params) {
    const auto model = params.string("range_model");
    if (model != "distance" && model != "depth") {
      throw std::invalid_argument("range_model must be distance or depth, not '" +
                                  std::string(model) + "'");
    }
    return {model == "depth", params.number("range_bias_m"), params.number("range_bias_per_m"),
            params.number("bearing_bias_deg") * std::numbers::pi / 180.0};
  }

  struct Corrected {
    double range_m;      // the distance the detection says
    double bearing_rad;  // the bearing less its bias
    double model_x_m;    // (z - range_bias_m) / (1 + range_bias_per_m): distance, or depth
    double range_scale;  // d range_m / d z: the range's noise is z's times this
  };
  Corrected corrected(double range_m, double bearing_rad) const {
    const double bearing = wrap(bearing_rad - bearing_bias_rad);
    const double x_m = (range_m - range_bias_m) / (1.0 + range_bias_per_m);
    // A depth camera sees less than 180 deg; at the edge of a wide view the cosine is floored
    // (at 84 deg off axis), so that a stray bearing cannot make a range ten times its depth.
    const double along = depth ? std::max(std::cos(bearing), 0.1) : 1.0;
    return {std::max(x_m, 0.0) / along, bearing, x_m, 1.0 / ((1.0 + range_bias_per_m) * along)};
  }
};

/// Detections of one target whose errors persist (a first-order Gauss-Markov process of time
/// constant tau per target, as the simulated sensors' noise_correlation_s makes them and
/// `locsim calibrate` measures them) do not carry independent information. A detection that
/// follows the target's previous one by dt adds (1 - rho) / (1 + rho) of an independent one's
/// information, rho = exp(-dt / tau): its variances are inflated by (1 + rho) / (1 - rho). For
/// two detections this gives exactly the variance of their mean, sigma^2 (1 + rho) / 2; for a
/// long run at a steady interval, the mean's asymptotic variance; the first after a long gap
/// counts in full. Targets are told apart by camera and id, or (a camera without ids) colour.
///
/// Real errors also have a slow part (MRCLAM's camera: about half the variance persists for a
/// minute, the view of a landmark changing slowly): a share w of the variance that decorrelates
/// over tau_slow, the rest over tau. Then a run of detections of a target tells, about anything
/// they all measure alike, the information of generalised least squares: a Kalman filter per
/// target over (m, s, f), m what is measured (no prior), s and f the slow and fast errors (unit
/// Gauss-Markov processes), each detection m + sqrt(w) s + sqrt(1 - w) f. A detection adds the
/// growth of 1 / P_mm: exact for any intervals, never more than an independent detection, and
/// at most about (1 + T / (2 tau_slow)) / w over a run of T seconds however dense.
class CorrelatedDetections {
 public:
  explicit CorrelatedDetections(double correlation_s = 0.0, double slow_correlation_s = 0.0,
                                double slow_share = 0.0)
      : tau_s_(correlation_s),
        slow_tau_s_(slow_correlation_s),
        slow_share_(slow_correlation_s > 0.0 ? slow_share : 0.0) {}
  /// From a plugin's parameters LOCSIM_DETECTION_BIAS_PARAMS declares.
  template <class Params>
  static CorrelatedDetections from(const Params& params) {
    return CorrelatedDetections(params.number("noise_correlation_s"),
                                params.number("noise_correlation_slow_s"),
                                params.number("noise_correlation_slow_share"));
  }
  /// The factor on the variances of this detection at t_s (1 without correlation, or for a
  /// target not seen before); remembers the time.
  double inflation(std::int32_t camera, const locsim_detection& detection, double t_s) {
    if (!(tau_s_ > 0.0) && !(slow_share_ > 0.0)) return 1.0;
    const auto key =
        std::tuple{camera, detection.id,
                   detection.id >= 0 || detection.color == nullptr ? std::string()
                                                                   : std::string(detection.color)};
    const auto [it, first] = seen_.try_emplace(key);
    Seen& seen = it->second;
    const double dt_s = first ? 0.0 : std::max(t_s - seen.last_s, 0.0);
    seen.last_s = t_s;
    if (!(slow_share_ > 0.0)) {
      if (first) return 1.0;
      const double rho = std::exp(-dt_s / tau_s_);
      return (1.0 + rho) / std::max(1.0 - rho, 1e-12);
    }
    // Prediction: m stays, the errors decay (a target not seen before: their stationary spread).
    const double rho_slow = first ? 0.0 : std::exp(-dt_s / slow_tau_s_);
    const double rho_fast = first || !(tau_s_ > 0.0) ? 0.0 : std::exp(-dt_s / tau_s_);
    if (first) {
      seen.P = Eigen::Matrix3d::Zero();
      seen.P(0, 0) = kNoPrior;
    }
    const Eigen::DiagonalMatrix<double, 3> F(1.0, rho_slow, rho_fast);
    seen.P = F * seen.P * F;
    seen.P(1, 1) += 1.0 - rho_slow * rho_slow;
    seen.P(2, 2) += 1.0 - rho_fast * rho_fast;
    // Update by one detection, y = H (m, s, f), no noise beside the errors in the state.
    const Eigen::RowVector3d H(1.0, std::sqrt(slow_share_), std::sqrt(1.0 - slow_share_));
    const double before = 1.0 / seen.P(0, 0);
    const Eigen::Vector3d PHt = seen.P * H.transpose();
    // A second detection at the instant of the last (a camera that reports a target twice)
    // has the same errors: nothing new, and no variance left to divide by.
    if (!(H.dot(PHt) > 1e-12)) return 1e12;
    seen.P -= PHt * PHt.transpose() / H.dot(PHt);
    seen.P = 0.5 * (seen.P + seen.P.transpose()).eval();
    if (first) return 1.0;
    const double added = 1.0 / seen.P(0, 0) - before;
    return 1.0 / std::clamp(added, 1e-12, 1.0);
  }

 private:
  static constexpr double kNoPrior = 1e8;  // P_mm before the first detection (unit variances)
  struct Seen {
    double last_s = 0.0;                          // the target's last detection
    Eigen::Matrix3d P = Eigen::Matrix3d::Zero();  // of (m, s, f), with a slow part
  };
  double tau_s_, slow_tau_s_, slow_share_;
  std::map<std::tuple<std::int32_t, std::int32_t, std::string>, Seen> seen_;
};

/// A range and bearing detection's two errors, each persisting as its own CorrelatedDetections
/// says (noise_correlation_* for the range; bearing_noise_correlation_*, each -1 by default, the
/// range's, for the bearing): a camera's bearing errors may decorrelate faster than its ranges'
/// (MRCLAM's are half white, where its ranges' persist for seconds), and a filter that weighs
/// both alike trusts one too much and the other too little.
class CorrelatedRangeBearing {
 public:
  CorrelatedRangeBearing() = default;
  CorrelatedRangeBearing(CorrelatedDetections range, std::optional<CorrelatedDetections> bearing)
      : range_(std::move(range)), bearing_(std::move(bearing)) {}
  /// From a plugin's parameters LOCSIM_DETECTION_BIAS_PARAMS declares.
  template <class Params>
  static CorrelatedRangeBearing from(const Params& params) {
    const double tau_s = params.number("noise_correlation_s");
    const double slow_s = params.number("noise_correlation_slow_s");
    const double share = params.number("noise_correlation_slow_share");
    const auto own = [&](const char* key, double range_value) {
      const double value = params.number(key);
      return value < 0.0 ? range_value : value;
    };
    const double bearing_tau_s = own("bearing_noise_correlation_s", tau_s);
    const double bearing_slow_s = own("bearing_noise_correlation_slow_s", slow_s);
    const double bearing_share = own("bearing_noise_correlation_slow_share", share);
    const bool same = bearing_tau_s == tau_s && bearing_slow_s == slow_s && bearing_share == share;
    return {
        CorrelatedDetections(tau_s, slow_s, share),
        same ? std::nullopt
             : std::optional(CorrelatedDetections(bearing_tau_s, bearing_slow_s, bearing_share))};
  }
  /// The factors on a detection's range and bearing variances (CorrelatedDetections::inflation).
  struct Inflation {
    double range = 1.0, bearing = 1.0;
  };
  Inflation inflation(std::int32_t camera, const locsim_detection& detection, double t_s) {
    const double range = range_.inflation(camera, detection, t_s);
    return {range, bearing_ ? bearing_->inflation(camera, detection, t_s) : range};
  }

 private:
  CorrelatedDetections range_;
  std::optional<CorrelatedDetections> bearing_;  // none: the range's
};

/// Pose composition a (+) b: b expressed in a's frame, mapped to a's parent frame.
inline Pose compose(const Pose& a, const Pose& b) {
  const double c = std::cos(a(2)), s = std::sin(a(2));
  return {a(0) + c * b(0) - s * b(1), a(1) + s * b(0) + c * b(1), wrap(a(2) + b(2))};
}

/// The pose of b in a's frame: a^-1 (+) b.
inline Pose between(const Pose& a, const Pose& b) {
  const double c = std::cos(a(2)), s = std::sin(a(2));
  const double dx = b(0) - a(0), dy = b(1) - a(1);
  return {c * dx + s * dy, -s * dx + c * dy, wrap(b(2) - a(2))};
}

/// sin(x) / x, with its Taylor series where the quotient loses precision (|x| < 1e-4: the
/// series' next term, x^4 / 120, is below 1e-18).
inline double sinc(double x) {
  return std::abs(x) < 1e-4 ? 1.0 - x * x / 6.0 : std::sin(x) / x;
}

/// The pose reached from `x` by driving at forward velocity v [m/s] and angular velocity omega
/// [rad/s], both held for dt [s]: an exact circular arc (a straight line when omega = 0). Its
/// chord has length v dt sinc(omega dt / 2) and points along the mid-heading:
///   x' = x + c cos(theta + omega dt / 2), y' = y + c sin(theta + omega dt / 2),
///   theta' = theta + omega dt,   c = v dt sinc(omega dt / 2),
/// which equals x + (v / omega)(sin(theta') - sin(theta)), ... without the division by omega.
inline Pose advance_by_velocity(const Pose& x, double v_mps, double omega_radps, double dt_s) {
  const double turn = omega_radps * dt_s;
  const double chord = v_mps * dt_s * sinc(0.5 * turn);
  const double heading = x(2) + 0.5 * turn;
  return {x(0) + chord * std::cos(heading), x(1) + chord * std::sin(heading), wrap(x(2) + turn)};
}

/// An odometry pose dead-reckoned from velocity readings: each reading's velocity holds from its
/// time until the next reading (a commanded velocity, as MRCLAM logs it), integrated along an
/// exact arc (advance_by_velocity). The host builds locsim_odometry.odom_pose with this when
/// the source reports no pose; a plugin may use it on its own readings likewise.
class VelocityOdometry {
 public:
  explicit VelocityOdometry(const Pose& start = Pose::Zero()) : pose_(start) {}
  /// The pose at t_s (the previous velocity held until then), then holds the new velocity.
  const Pose& update(double t_s, double v_mps, double omega_radps) {
    if (last_t_s_) {
      pose_ = advance_by_velocity(pose_, v_mps_, omega_radps_, std::max(0.0, t_s - *last_t_s_));
    }
    last_t_s_ = t_s;
    v_mps_ = v_mps;
    omega_radps_ = omega_radps;
    return pose_;
  }
  const Pose& pose() const { return pose_; }

 private:
  Pose pose_;
  std::optional<double> last_t_s_;
  double v_mps_ = 0.0, omega_radps_ = 0.0;
};

/// How a base that reports its command moves (`locsim calibrate`'s command response, the
/// simulated robot's `command_response`): the command applied after a dead time, through a
/// first-order lag and a gain per channel,
///   tau_v dv/dt + v = gain_v v_cmd(t - dead_time),  tau_omega domega/dt + omega = gain_omega ...
/// The identity (the defaults) is a base that moves as it reports.
// clang-format off
#define LOCSIM_COMMAND_RESPONSE_PARAMS                                                             \
  {"command_dead_time_s", LOCSIM_PARAM_DOUBLE, 0.0, 0.0, 10.0, nullptr,                           \
   "odometry that reports the command (locsim calibrate): the robot starts to follow it this "    \
   "much later [s]"},                                                                              \
  {"command_time_constant_v_s", LOCSIM_PARAM_DOUBLE, 0.0, 0.0, 100.0, nullptr,                    \
   "... the forward velocity follows it with this first-order time constant [s]"},                \
  {"command_time_constant_omega_s", LOCSIM_PARAM_DOUBLE, 0.0, 0.0, 100.0, nullptr,                \
   "... the turn rate with this one [s]"},                                                         \
  {"command_gain_v", LOCSIM_PARAM_DOUBLE, 1.0, 0.01, 100.0, nullptr,                              \
   "... reaching this share of the commanded forward velocity [-]"},                               \
  {"command_gain_omega", LOCSIM_PARAM_DOUBLE, 1.0, 0.01, 100.0, nullptr,                          \
   "... and of the commanded turn rate [-]"}
// clang-format on

struct CommandResponse {
  double dead_time_s = 0.0;            // [s]
  double time_constant_v_s = 0.0;      // [s]
  double time_constant_omega_s = 0.0;  // [s]
  double gain_v = 1.0;                 // [-]
  double gain_omega = 1.0;             // [-]

  bool identity() const {
    return dead_time_s == 0.0 && time_constant_v_s == 0.0 && time_constant_omega_s == 0.0 &&
           gain_v == 1.0 && gain_omega == 1.0;
  }
  /// From a plugin's parameters LOCSIM_COMMAND_RESPONSE_PARAMS declares.
  template <class Params>
  static CommandResponse from(const Params& params) {
    return {params.number("command_dead_time_s"), params.number("command_time_constant_v_s"),
            params.number("command_time_constant_omega_s"), params.number("command_gain_v"),
            params.number("command_gain_omega")};
  }
};

/// Odometry readings as a CommandResponse makes them: each reading's velocity is a command, held
/// from its time until the next reading (as VelocityOdometry takes it); follow() gives the
/// reading with the velocity the base has through the response and odom_pose integrated from
/// it (ticks dropped). The lag is integrated exactly for the held input, the pose along arcs
/// of at most 20 ms at each one's mean velocities. The base is taken as settled at the first
/// reading's command. A reading without a velocity, or the identity response, passes unchanged.
class CommandFollower {
 public:
  explicit CommandFollower(const CommandResponse& response = {}) : response_(response) {}

  const locsim_odometry& follow(double t_s, const locsim_odometry& reading) {
    if (response_.identity() || (reading.fields & LOCSIM_ODOMETRY_VELOCITY) == 0 ||
        !std::isfinite(t_s)) {
      return reading;
    }
    if (std::isnan(now_s_)) {
      now_s_ = t_s;
      pose_ = Pose(reading.odom_pose.x, reading.odom_pose.y, reading.odom_pose.theta);
      input_ = {response_.gain_v * reading.v_mps, response_.gain_omega * reading.omega_radps};
      velocity_ = input_;
    } else {
      advance_to(t_s);
    }
    pending_.push_back({t_s + response_.dead_time_s, reading.v_mps, reading.omega_radps});
    apply_due();
    out_ = reading;
    out_.fields = LOCSIM_ODOMETRY_VELOCITY | LOCSIM_ODOMETRY_POSE;
    out_.left_ticks = out_.right_ticks = 0;
    out_.odom_pose = {pose_(0), pose_(1), pose_(2)};
    out_.v_mps = velocity_.first;
    out_.omega_radps = velocity_.second;
    return out_;
  }

 private:
  struct Command {
    double applies_s, v_mps, omega_radps;
  };
  /// Commands whose dead time has passed become the input.
  void apply_due() {
    while (!pending_.empty() && pending_.front().applies_s <= now_s_) {
      input_ = {response_.gain_v * pending_.front().v_mps,
                response_.gain_omega * pending_.front().omega_radps};
      pending_.pop_front();
    }
  }
  /// One channel over h seconds at input u: the velocity at the end and the mean over h
  /// (v = u + (v0 - u) e^(-s/tau)).
  static std::pair<double, double> lag(double v0, double u, double tau_s, double h_s) {
    if (!(tau_s > 0.0)) return {u, u};
    const double rise = -std::expm1(-h_s / tau_s);  // 1 - e^(-h/tau), exact for a short h
    return {u + (v0 - u) * (1.0 - rise), u + (v0 - u) * tau_s * rise / h_s};
  }
  void advance_to(double t_s) {
    constexpr double kMaxArcS = 0.02;
    while (now_s_ < t_s) {
      const double until = pending_.empty() ? t_s : std::min(t_s, pending_.front().applies_s);
      const double next_s = std::min(until, now_s_ + kMaxArcS);
      const double h_s = next_s - now_s_;
      if (h_s > 0.0) {
        const auto [v_end, v_mean] =
            lag(velocity_.first, input_.first, response_.time_constant_v_s, h_s);
        const auto [omega_end, omega_mean] =
            lag(velocity_.second, input_.second, response_.time_constant_omega_s, h_s);
        pose_ = advance_by_velocity(pose_, v_mean, omega_mean, h_s);
        velocity_ = {v_end, omega_end};
      }
      now_s_ = next_s;
      apply_due();
    }
  }

  CommandResponse response_;
  double now_s_ = std::numeric_limits<double>::quiet_NaN();
  Pose pose_ = Pose::Zero();
  std::pair<double, double> input_{0.0, 0.0}, velocity_{0.0, 0.0};  // (v, omega)
  std::deque<Command> pending_;
  locsim_odometry out_{};
};

/// How the base's gains wander (`locsim calibrate` measures it; the simulated robot's
/// command_response makes it): the base drives (1 + g_v) times the distance its odometry (through
/// the response) says and turns (1 + g_omega) times its turn, each g a first-order Gauss-Markov
/// process of standard deviation sigma and time constant tau,
///   g(t + dt) = phi g(t) + e,  phi = exp(-dt / tau),  e ~ N(0, sigma^2 (1 - phi^2)).
/// The wheel noise k is independent from one reading to the next, so its errors average out over
/// a run; a gain that is off for seconds (a floor, a load, a tyre) moves the robot the wrong way
/// for all of them. Zero sigma (the defaults): no wander.
// clang-format off
#define LOCSIM_GAIN_WANDER_PARAMS                                                                  \
  {"gain_wander_v", LOCSIM_PARAM_DOUBLE, 0.0, 0.0, 10.0, nullptr,                                  \
   "the base drives (1 + g) times the distance its odometry says, g wandering about 0 with this "  \
   "standard deviation (locsim calibrate; 0: no wander) [-]"},                                     \
  {"gain_wander_omega", LOCSIM_PARAM_DOUBLE, 0.0, 0.0, 10.0, nullptr,                              \
   "... and turns (1 + g) times its turn, g with this standard deviation [-]"},                    \
  {"gain_wander_correlation_s", LOCSIM_PARAM_DOUBLE, 1.0, 1e-3, 1e6, nullptr,                      \
   "... both wandering with this time constant [s]"}
// clang-format on

struct GainWander {
  double sigma_v = 0.0;        // [-]
  double sigma_omega = 0.0;    // [-]
  double correlation_s = 1.0;  // tau [s]

  bool active() const { return sigma_v > 0.0 || sigma_omega > 0.0; }
  /// phi = exp(-dt / tau): how much of the gains is left after dt_s.
  double phi(double dt_s) const { return std::exp(-std::max(dt_s, 0.0) / correlation_s); }
  /// From a plugin's parameters LOCSIM_GAIN_WANDER_PARAMS declares.
  template <class Params>
  static GainWander from(const Params& params) {
    return {params.number("gain_wander_v"), params.number("gain_wander_omega"),
            params.number("gain_wander_correlation_s")};
  }
};

/// The wheel travel of a base whose gains are off by (g_v, g_omega) when its wheels say (dl, dr):
///   D' = (1 + g_v) D, a' b / 2 = (1 + g_omega) a b / 2  ->  dl' = D' - a' b / 2, dr' = D' + a' b
///   / 2.
inline std::pair<double, double> wheels_with_gains(double d_left, double d_right, double g_v,
                                                   double g_omega) {
  const double D = 0.5 * (d_left + d_right), half_turn = 0.5 * (d_right - d_left);
  return {(1.0 + g_v) * D - (1.0 + g_omega) * half_turn,
          (1.0 + g_v) * D + (1.0 + g_omega) * half_turn};
}

/// A pose and the base's gain errors, (x, y, theta, g_v, g_omega): the state of a Kalman filter
/// that carries the gain wander.
using PoseGains = Eigen::Matrix<double, 5, 1>;
using PoseGainsCovariance = Eigen::Matrix<double, 5, 5>;

/// One step of the state with gains by the wheels' travel (dl, dr) and phi = GainWander::phi(dt):
///   pose' = diff_drive_motion(pose, wheels_with_gains(dl, dr, g_v, g_omega)),  g' = phi g.
/// F = d x' / d x (5x5), L = d x' / d (dl, dr) (5x2), when asked for.
inline PoseGains move_with_gains(const PoseGains& x, double d_left, double d_right,
                                 double wheel_base, double phi,
                                 Eigen::Matrix<double, 5, 5>* F = nullptr,
                                 Eigen::Matrix<double, 5, 2>* L = nullptr) {
  const auto [dl, dr] = wheels_with_gains(d_left, d_right, x(3), x(4));
  Eigen::Matrix3d F_pose;
  Eigen::Matrix<double, 3, 2> G;  // d pose' / d (dl', dr')
  const Pose moved = diff_drive_motion(x.head<3>(), dl, dr, wheel_base, &F_pose, &G);
  if (F != nullptr) {
    const double D = 0.5 * (d_left + d_right), half_turn = 0.5 * (d_right - d_left);
    Eigen::Matrix2d by_gains;   // d (dl', dr') / d (g_v, g_omega)
    by_gains << D, -half_turn,  //
        D, half_turn;
    F->setZero();
    F->topLeftCorner<3, 3>() = F_pose;
    F->topRightCorner<3, 2>() = G * by_gains;
    F->bottomRightCorner<2, 2>() = phi * Eigen::Matrix2d::Identity();
  }
  if (L != nullptr) {
    const double v = 0.5 * (1.0 + x(3)), w = 0.5 * (1.0 + x(4));
    Eigen::Matrix2d by_wheels;  // d (dl', dr') / d (dl, dr)
    by_wheels << v + w, v - w,  //
        v - w, v + w;
    L->setZero();
    L->topRows<3>() = G * by_wheels;
  }
  PoseGains out;
  out << moved, phi * x(3), phi * x(4);
  return out;
}

/// predict_by_wheels for the state with gains over dt_s: P' = F P F^T + L Q L^T + the gains' own
/// noise sigma^2 (1 - phi^2), Q paper 002's wheel noise (and slip) as predict_by_wheels takes it.
inline void predict_by_wheels_and_gains(PoseGains& x, PoseGainsCovariance& P, double d_left,
                                        double d_right, double wheel_base, double k_left,
                                        double k_right, double slip_m, const GainWander& wander,
                                        double dt_s) {
  const double phi = wander.phi(dt_s);
  Eigen::Matrix<double, 5, 5> F;
  Eigen::Matrix<double, 5, 2> L;
  x = move_with_gains(x, d_left, d_right, wheel_base, phi, &F, &L);
  const double slip_m2 = slip_m * slip_m;
  const Eigen::Matrix2d Q = Eigen::Vector2d(k_left * k_left * std::abs(d_left) + slip_m2,
                                            k_right * k_right * std::abs(d_right) + slip_m2)
                                .asDiagonal();
  P = F * P * F.transpose() + L * Q * L.transpose();
  const double renewal = 1.0 - phi * phi;
  P(3, 3) += wander.sigma_v * wander.sigma_v * renewal;
  P(4, 4) += wander.sigma_omega * wander.sigma_omega * renewal;
}

/// A tracking filter that rejects most of what it sees is lost (a push its wheels did not feel, a
/// kidnap): its covariance must say so, and widen until what it sees fits again, or the filter
/// stays sure of a pose it left long ago. LostWatch keeps a running count of the rejections in
/// excess of the detections accepted (+1 a rejection, -1 an acceptance, never below 0: a CUSUM
/// test of "most are rejected" against "few are"); while it is at least after_rejections, each
/// rejection widens the pose's covariance as a random walk of growth_m (position) and growth_rad
/// (heading) per root second over the time since the count last left 0, then since the last
/// widening, up to max_m / max_rad (never narrowing it: wider than that, a linearised update
/// means little). Why a count in excess and not a run or a share: a belief off by more than the
/// gate still lets the odd detection through near its edge, which breaks a run; a sensor with
/// gross outliers (a tenth of its detections, spread over every target, some in bursts) fills a
/// short window's share by chance, while its count in excess drifts down by 0.8 a detection: the
/// default 12 is the least that such a sensor (tests/twin_test.cpp's) does not reach but in a
/// burst or two over three minutes; a belief off by a push reaches it within 2-4 s.
// clang-format off
#define LOCSIM_LOST_PARAMS                                                                         \
  {"lost_after_rejections", LOCSIM_PARAM_INT, 12, 0, 1000000, nullptr,                              \
   "detections rejected in excess of those accepted (a running count, +1 a rejection, -1 an "      \
   "acceptance, never below 0) that say the pose is lost (a push the wheels did not feel, a "      \
   "kidnap): from then on each rejection widens its covariance (0: never) [-]"},                   \
  {"lost_growth_m", LOCSIM_PARAM_DOUBLE, 0.5, 0.0, 100.0, nullptr,                                 \
   "... its position spread grows by this per root second while lost [m/sqrt(s)]"},               \
  {"lost_growth_deg", LOCSIM_PARAM_DOUBLE, 20.0, 0.0, 180.0, nullptr,                              \
   "... its heading spread by this [deg/sqrt(s)]"},                                                \
  {"lost_max_m", LOCSIM_PARAM_DOUBLE, 3.0, 0.0, 1000.0, nullptr,                                   \
   "... up to this position spread [m]"},                                                          \
  {"lost_max_deg", LOCSIM_PARAM_DOUBLE, 60.0, 0.0, 180.0, nullptr,                                 \
   "... and this heading spread [deg]"}
// clang-format on

struct LostWatchDef {
  int after_rejections = 12;  // the count in excess that says lost [-]
  double growth_m = 0.5;      // position spread per root second [m/sqrt(s)]
  double growth_rad =
      20.0 * std::numbers::pi / 180;               // heading spread per root second [rad/sqrt(s)]
  double max_m = 3.0;                              // widened up to this position spread [m]
  double max_rad = 60.0 * std::numbers::pi / 180;  // ... and this heading spread [rad]

  /// From a plugin's parameters LOCSIM_LOST_PARAMS declares.
  template <class Params>
  static LostWatchDef from(const Params& params) {
    const double to_rad = std::numbers::pi / 180.0;
    return {static_cast<int>(params.integer("lost_after_rejections")),
            params.number("lost_growth_m"), params.number("lost_growth_deg") * to_rad,
            params.number("lost_max_m"), params.number("lost_max_deg") * to_rad};
  }
};

class LostWatch {
 public:
  LostWatch() = default;
  explicit LostWatch(const LostWatchDef& def) : def_(def) {}

  /// A detection the filter took.
  void accepted() {
    if (excess_ > 0) --excess_;
    if (!lost()) was_lost_ = false;
  }

  /// A detection of a known target the filter rejected at t_s [s]; when that says lost, P's pose
  /// block (x, y, theta: its first three rows and columns) is widened. True if it was.
  template <class Covariance>
  bool rejected(double t_s, Covariance& P) {
    if (def_.after_rejections <= 0) return false;
    if (excess_++ == 0) widened_s_ = t_s;  // the count leaves 0: the random walk starts here
    if (!lost()) return false;
    if (!was_lost_) ++times_lost_, was_lost_ = true;
    const double dt_s = std::max(0.0, t_s - widened_s_);
    widened_s_ = t_s;
    const double limits[3] = {def_.max_m, def_.max_m, def_.max_rad};
    const double growth[3] = {def_.growth_m, def_.growth_m, def_.growth_rad};
    for (int i = 0; i < 3; ++i) {
      const double room = limits[i] * limits[i] - P(i, i);
      if (room > 0.0) P(i, i) += std::min(growth[i] * growth[i] * dt_s, room);
    }
    return true;
  }

  /// Whether the latest detections say lost.
  bool lost() const { return def_.after_rejections > 0 && excess_ >= def_.after_rejections; }
  /// How many times the filter has become lost.
  long times_lost() const { return times_lost_; }

 private:
  LostWatchDef def_;
  long excess_ = 0;  // rejections in excess of acceptances, never below 0
  bool was_lost_ = false;
  long times_lost_ = 0;
  double widened_s_ = 0.0;  // when the count left 0, then the latest widening [s]
};

/// A pose and the bias b of the rate its heading source turns it by, (x, y, theta, b)
/// [m, m, rad, rad/s]: the state of a filter on a base whose odometry turns by a gyro (a
/// gyro-fused odometry's heading drifts by b dt; the encoders' `heading: gyro`).
using PoseHeadingBias = Eigen::Matrix<double, 4, 1>;

/// An odometry whose heading is a gyro's (the encoders' `heading: gyro`; a base that fuses one),
/// as a filter models it: the wheels measure the distance, the gyro the turn, with its bias,
/// scale error and noise; the filter estimates the bias (a state, a particle's own). From the
/// parameters LOCSIM_GYRO_HEADING_PARAMS declares; locsim calibrate writes them.
struct GyroHeading {
  bool active = false;         // odometry_heading: gyro (else wheels)
  double noise_density = 0.0;  // the turn's white noise [rad/s^1/2]
  double scale_error = 0.0;    // the gyro turns (1 + s) times the body [-]
  double bias_radps = 0.0;     // the bias's prior mean [rad/s]
  double bias_sigma = 0.0;     // its prior spread; 0: held at the mean [rad/s]
  double bias_walk = 0.0;      // its random walk [rad/s per root second]
  template <class Params>
  static GyroHeading from(const Params& params) {
    const std::string heading = params.string("odometry_heading");
    if (heading != "wheels" && heading != "gyro")
      throw std::invalid_argument("odometry_heading must be wheels or gyro, not '" + heading + "'");
    return {heading == "gyro",
            params.number("heading_noise_density"),
            params.number("heading_rate_scale_error"),
            params.number("heading_rate_bias_radps"),
            params.number("heading_rate_bias_sigma"),
            params.number("heading_rate_bias_walk")};
  }
};

// clang-format off
#define LOCSIM_GYRO_HEADING_PARAMS                                                                 \
  {"odometry_heading", LOCSIM_PARAM_STRING, 0, 0, 0, "wheels",                                     \
   "what turns the odometry, wheels or gyro (the encoders' heading): by a gyro the wheel noise "   \
   "enters the distance alone, and the filter estimates the gyro's bias (locsim calibrate)"},      \
  {"heading_noise_density", LOCSIM_PARAM_DOUBLE, 0.0, 0, 10, nullptr,                              \
   "odometry_heading gyro: the turn's noise per root second (locsim calibrate) [rad/s^1/2]"},      \
  {"heading_rate_scale_error", LOCSIM_PARAM_DOUBLE, 0.0, -0.5, 0.5, nullptr,                       \
   "odometry_heading gyro: the gyro turns (1 + this) times the body, taken out of every turn "     \
   "(locsim calibrate) [-]"},                                                                      \
  {"heading_rate_bias_radps", LOCSIM_PARAM_DOUBLE, 0.0, -1, 1, nullptr,                            \
   "bias of the gyro the heading turns by, taken out of every turn: the prior mean of the "        \
   "filter's estimate (locsim calibrate) [rad/s]"},                                                \
  {"heading_rate_bias_sigma", LOCSIM_PARAM_DOUBLE, 0.0, 0, 1, nullptr,                             \
   "that bias's prior spread: > 0 estimates it, so that the heading stays with the measurements "  \
   "however the gyro drifts; 0 holds it at the mean (locsim calibrate) [rad/s]"},                  \
  {"heading_rate_bias_walk", LOCSIM_PARAM_DOUBLE, 0.0, 0, 1, nullptr,                              \
   "the bias's random walk, when estimated (locsim calibrate) [rad/s per root second]"}
// clang-format on

/// One step by the wheels' travel (dl, dr) over dt_s when the odometry's turn a = (dr - dl) / B
/// is a gyro's, with the bias b_rate and the scale error s: a = (1 + s) t + b_rate dt for the
/// true turn t, so the pose moves by the travel of the same distance and the turn
///   t = (a - b_rate dt) / (1 + s):  (dl + delta, dr - delta), delta = B (a - t) / 2,
/// and b_rate' = b_rate. F = d x' / d x (4x4), L = d x' / d (dl, dr) (4x2), when asked for.
inline PoseHeadingBias move_with_heading_bias(const PoseHeadingBias& x, double d_left,
                                              double d_right, double wheel_base, double dt_s,
                                              double scale_error = 0.0,
                                              Eigen::Matrix4d* F = nullptr,
                                              Eigen::Matrix<double, 4, 2>* L = nullptr) {
  const double turn = (d_right - d_left) / wheel_base;
  const double gain = 1.0 / (1.0 + scale_error);
  const double delta_m = 0.5 * wheel_base * (turn - (turn - x(3) * dt_s) * gain);
  Eigen::Matrix3d F_pose;
  Eigen::Matrix<double, 3, 2> G;  // d pose' / d (dl', dr')
  const Pose moved =
      diff_drive_motion(x.head<3>(), d_left + delta_m, d_right - delta_m, wheel_base, &F_pose, &G);
  if (F != nullptr) {
    F->setIdentity();
    F->topLeftCorner<3, 3>() = F_pose;
    // d delta / d b_rate = B dt / (2 (1 + s)).
    const double by_bias = 0.5 * wheel_base * dt_s * gain;
    F->topRightCorner<3, 1>() = G * Eigen::Vector2d(by_bias, -by_bias);
  }
  if (L != nullptr) {
    // d delta / d (dl, dr) = (-k, k), k = s / (2 (1 + s)).
    const double k = 0.5 * scale_error * gain;
    Eigen::Matrix2d by_wheels;
    by_wheels << 1.0 - k, k,  //
        k, 1.0 - k;
    L->setZero();
    L->topRows<3>() = G * by_wheels;
  }
  PoseHeadingBias out;
  out << moved, x(3);
  return out;
}

/// The wheel travel (left, right) [m] of a differential drive with wheel base b [m] that moves
/// it by the pose increment `delta` (in the start pose's frame, as between() gives it), taking
/// the increment as one circular arc: the inverse of the arc above. The chord c = |(dx, dy)|
/// and the turn a = dtheta give the arc length ds = c / sinc(a / 2), signed by the chord's
/// direction along the mid-heading (backwards: negative), and
///   left = ds - b a / 2,  right = ds + b a / 2.
/// A pure rotation gives ds = 0; a sideways step (which no differential drive makes) counts
/// only by its component along the mid-heading's sign.
inline std::pair<double, double> wheel_travel_from_increment(const Pose& delta, double wheel_base) {
  const double turn = delta(2);
  const double chord = std::hypot(delta(0), delta(1));
  const double along = delta(0) * std::cos(0.5 * turn) + delta(1) * std::sin(0.5 * turn);
  const double ds = (along < 0.0 ? -chord : chord) / sinc(0.5 * turn);
  return {ds - 0.5 * wheel_base * turn, ds + 0.5 * wheel_base * turn};
}

/// The IMU's yaw rate integrated over time, each reading held until the next (the body's yaw
/// rate whatever the IMU's mount angle in the plane): the gyro's turn between two moments, for
/// odometry that turns by it (gyrodometry: OdometryFollower, OdometryTracker).
class GyroIntegrator {
 public:
  void observe(double t_s, const locsim_imu& imu) {
    if (!std::isfinite(t_s) || !std::isfinite(imu.yaw_rate_radps)) return;
    if (!std::isnan(imu_s_)) turn_rad_ += yaw_rate_radps_ * std::max(0.0, t_s - imu_s_);
    imu_s_ = t_s;
    yaw_rate_radps_ = imu.yaw_rate_radps;
  }
  /// The turn integrated up to t_s since the first reading [rad]; NaN when no reading came
  /// within kMaxGapS before t_s (a gyro silent that long has stopped: back to the wheels).
  double turn_at(double t_s) const {
    constexpr double kMaxGapS = 0.25;
    if (std::isnan(imu_s_) || !std::isfinite(t_s) || t_s - imu_s_ > kMaxGapS)
      return std::numeric_limits<double>::quiet_NaN();
    return turn_rad_ + yaw_rate_radps_ * std::max(0.0, t_s - imu_s_);
  }

 private:
  double imu_s_ = std::numeric_limits<double>::quiet_NaN();  // the last reading's time
  double turn_rad_ = 0.0, yaw_rate_radps_ = 0.0;
};

/// The step `wheels` (a pose increment in the previous pose's frame) turned by `turn_rad`
/// instead: the wheels' chord, at half their turn, rotated to half the gyro's.
inline Pose turned_step(const Pose& wheels, double turn_rad) {
  const double half = 0.5 * (turn_rad - wheels(2));
  const double c = std::cos(half), s = std::sin(half);
  return {c * wheels(0) - s * wheels(1), s * wheels(0) + c * wheels(1), turn_rad};
}

/// The parameter that turns a filter's gyro (GyroIntegrator, in OdometryFollower or
/// OdometryTracker) on or off; a filter that forwards its IMU readings declares it.
// clang-format off
#define LOCSIM_GYRO_PARAMS                                                                         \
  {"use_gyro", LOCSIM_PARAM_BOOL, 1, 0, 1, nullptr,                                                \
   "turn by the IMU's gyro where the robot has one, not by the wheels (which slip against a wall " \
   "or under a push: their extra turn widens the motion's noise); 0: the wheels' odometry alone"}
// clang-format on

/// What a filter needs from one odometry reading, whatever its source measured.
struct OdometryStep {
  double dt_s = 0.0;                       // since the previous reading
  Pose pose_increment = Pose::Zero();      // odom pose change, in the previous odom pose's frame
  double d_left_m = 0.0, d_right_m = 0.0;  // wheel travel since the previous reading
  bool travel_from_ticks = false;          // else derived from pose_increment and the wheel base
  /// With a gyro (OdometryTracker::observe_imu): the wheels' turn less the gyro's [rad]; the
  /// increment and the travel above are then turned by the gyro (same distance, the gyro's
  /// turn). 0 without.
  double slip_rad = 0.0;
};

/// Turns each odometry reading into an OdometryStep against the previous one (nothing for the
/// first): the pose increment from odom_pose (always valid, the host integrates it from the
/// velocities when the source has no pose); the wheel travel from the ticks when the source
/// has them (tick difference x meters_per_tick), else from the pose increment with the
/// nominal wheel base (wheel_travel_from_increment). velocity() is the latest reading's when its
/// source measured one. Given the IMU's readings (observe_imu), each step turns by the gyro (as
/// OdometryFollower's): the travel's difference is the gyro's turn times the wheel base, its
/// mean the wheels', and the wheels' extra turn is the step's slip_rad.
///
/// A reading of another sensor taken between two odometry readings (a recorded robot's ranges
/// or detections come when they come, not on the odometry's clock) belongs to the pose of its
/// own time: advance_to(t) gives the motion from the last odometry reading (or the last
/// advance) up to t, extrapolated from what the odometry last told, and the next update() gives
/// the rest of its step, so that the steps a filter applies add up to the odometry's. A filter
/// that updated at the last odometry pose instead would meet each such reading up to one
/// odometry interval late and lead the robot by the distance driven meanwhile.
class OdometryTracker {
 public:
  explicit OdometryTracker(double wheel_base_m) : wheel_base_m_(wheel_base_m) {}
  /// Whether the IMU's yaw rate turns the steps (when observe_imu has readings; default on).
  void use_gyro(bool on) { use_gyro_ = on; }
  void observe_imu(double t_s, const locsim_imu& imu) {
    if (use_gyro_) gyro_.observe(t_s, imu);
  }
  /// The step since the previous reading (nothing for the first); after advance_to(), the rest
  /// of it beyond the time advanced to: its wheel travel and slip less the advanced ones, its
  /// increment from the advanced pose, its dt_s from that time (negative, with the rest, when
  /// this reading came before the time advanced to).
  std::optional<OdometryStep> update(double t_s, const locsim_odometry& odometry) {
    std::optional<OdometryStep> step = wheels_step(t_s, odometry);
    if (step) last_wheels_ = *step;
    const double gyro_rad =
        use_gyro_ ? gyro_.turn_at(t_s) : std::numeric_limits<double>::quiet_NaN();
    if (step && !std::isnan(gyro_rad) && !std::isnan(gyro_then_rad_))
      turn_by_gyro(*step, gyro_rad - gyro_then_rad_);
    gyro_then_rad_ = gyro_rad;
    if (step && advanced_) {
      step->dt_s -= advanced_->dt_s;
      step->d_left_m -= advanced_->d_left_m;
      step->d_right_m -= advanced_->d_right_m;
      step->slip_rad -= advanced_->slip_rad;
      step->pose_increment = between(advanced_->pose_increment, step->pose_increment);
    }
    advanced_.reset();
    return step;
  }

  /// The motion from the last reading, or from the last advance since, up to t_s: for a source
  /// of velocities alone, the latest velocity (which holds until the next reading, as the host
  /// integrates it: exact); else the last step's wheel travel per second (ticks, a pose), turned
  /// by the gyro where the steps are. No further than one odometry interval past the last
  /// reading (odometry that stopped coming is not driven on); nothing before the second reading
  /// or when t_s is not later than the time already reached.
  std::optional<OdometryStep> advance_to(double t_s) {
    if (!last_ || !last_wheels_ || !(last_wheels_->dt_s > 0.0)) return std::nullopt;
    const double from_s = last_->t_s + (advanced_ ? advanced_->dt_s : 0.0);
    const double to_s = std::min(t_s, last_->t_s + last_wheels_->dt_s);
    if (!(to_s > from_s)) return std::nullopt;
    OdometryStep step;
    step.dt_s = to_s - from_s;
    if (velocity_ && !last_->pose_measured && !last_->ticks) {
      const auto [v_mps, omega_radps] = *velocity_;
      step.d_left_m = (v_mps - 0.5 * wheel_base_m_ * omega_radps) * step.dt_s;
      step.d_right_m = (v_mps + 0.5 * wheel_base_m_ * omega_radps) * step.dt_s;
      step.pose_increment = advance_by_velocity(Pose::Zero(), v_mps, omega_radps, step.dt_s);
    } else {
      const double share = step.dt_s / last_wheels_->dt_s;
      step.d_left_m = last_wheels_->d_left_m * share;
      step.d_right_m = last_wheels_->d_right_m * share;
      step.travel_from_ticks = last_wheels_->travel_from_ticks;
      const double travel_m = 0.5 * (step.d_left_m + step.d_right_m);
      step.pose_increment = advance_by_velocity(
          Pose::Zero(), travel_m, (step.d_right_m - step.d_left_m) / wheel_base_m_, 1.0);
    }
    const double gyro_from_rad = advanced_ ? advanced_gyro_rad_ : gyro_then_rad_;
    const double gyro_to_rad =
        use_gyro_ ? gyro_.turn_at(to_s) : std::numeric_limits<double>::quiet_NaN();
    if (!std::isnan(gyro_to_rad) && !std::isnan(gyro_from_rad))
      turn_by_gyro(step, gyro_to_rad - gyro_from_rad);
    advanced_gyro_rad_ = gyro_to_rad;
    if (!advanced_) {
      advanced_ = step;
    } else {
      advanced_->dt_s += step.dt_s;
      advanced_->d_left_m += step.d_left_m;
      advanced_->d_right_m += step.d_right_m;
      advanced_->slip_rad += step.slip_rad;
      advanced_->pose_increment = compose(advanced_->pose_increment, step.pose_increment);
    }
    return step;
  }
  /// The latest measured (v [m/s], omega [rad/s]); nullopt when the source reports none.
  const std::optional<std::pair<double, double>>& velocity() const { return velocity_; }

 private:
  // The step taken by turn_rad instead of the wheels' turn: the travel's difference is the
  // gyro's turn times the wheel base, its mean the wheels', the wheels' extra turn the slip.
  void turn_by_gyro(OdometryStep& step, double turn_rad) const {
    const double wheels_turn_rad = (step.d_right_m - step.d_left_m) / wheel_base_m_;
    const double mean_m = 0.5 * (step.d_left_m + step.d_right_m);
    step.slip_rad = wheels_turn_rad - turn_rad;
    step.d_left_m = mean_m - 0.5 * wheel_base_m_ * turn_rad;
    step.d_right_m = mean_m + 0.5 * wheel_base_m_ * turn_rad;
    step.pose_increment = turned_step(step.pose_increment, turn_rad);
  }

  std::optional<OdometryStep> wheels_step(double t_s, const locsim_odometry& odometry) {
    const Pose now(odometry.odom_pose.x, odometry.odom_pose.y, odometry.odom_pose.theta);
    const bool ticks = (odometry.fields & LOCSIM_ODOMETRY_TICKS) != 0;
    std::optional<OdometryStep> step;
    if (last_) {
      step.emplace();
      step->dt_s = t_s - last_->t_s;
      step->pose_increment = between(last_->pose, now);
      if (ticks && last_->ticks) {
        step->d_left_m =
            static_cast<double>(odometry.left_ticks - last_->left) * odometry.meters_per_tick;
        step->d_right_m =
            static_cast<double>(odometry.right_ticks - last_->right) * odometry.meters_per_tick;
        step->travel_from_ticks = true;
      } else {
        std::tie(step->d_left_m, step->d_right_m) =
            wheel_travel_from_increment(step->pose_increment, wheel_base_m_);
      }
    }
    last_ = Last{t_s,
                 now,
                 odometry.left_ticks,
                 odometry.right_ticks,
                 ticks,
                 (odometry.fields & LOCSIM_ODOMETRY_POSE) != 0};
    if ((odometry.fields & LOCSIM_ODOMETRY_VELOCITY) != 0) {
      velocity_ = std::pair{odometry.v_mps, odometry.omega_radps};
    }
    return step;
  }

  struct Last {
    double t_s = 0.0;
    Pose pose = Pose::Zero();
    std::int64_t left = 0, right = 0;
    bool ticks = false;
    bool pose_measured = false;  // the source reported the pose (else the host integrated it)
  };
  double wheel_base_m_;
  bool use_gyro_ = true;
  GyroIntegrator gyro_;
  double gyro_then_rad_ = std::numeric_limits<double>::quiet_NaN();  // at the last reading
  std::optional<Last> last_;
  std::optional<OdometryStep> last_wheels_;  // the last step, by the wheels alone
  std::optional<OdometryStep> advanced_;     // the motion advance_to() gave since last_
  double advanced_gyro_rad_ = std::numeric_limits<double>::quiet_NaN();  // the gyro's turn then
  std::optional<std::pair<double, double>> velocity_;
};

/// SDK 1's wheel-travel helper, removed in SDK 2: a plugin rebuilt against this SDK is told what
/// replaces it, not just that the name is unknown (docs/plugins.md, "ABI versions").
using WheelTravel [[deprecated(
    "locsim::sdk::WheelTravel was removed in SDK 2: use locsim::sdk::OdometryTracker (its "
    "update() gives each odometry reading's wheel travel, from the ticks or, where the source "
    "has none, from the pose; docs/plugins.md, ABI versions)")]] = OdometryTracker;

/// The robot pose in the world from two landmarks a, b at known world positions and their
/// positions pa, pb in the robot frame: position from the ranges |pa|, |pb| (intersection of
/// the two circles, on the side where b lies as seen from the robot: the sign of pa x pb), the
/// heading as the circular mean of the two bearing-implied headings. nullopt when the circles do
/// not meet (ranges inconsistent with the landmarks' distance) by more than 10 %.
inline std::optional<Pose> two_landmark_pose(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                                             const Eigen::Vector2d& pa, const Eigen::Vector2d& pb) {
  const double da = pa.norm(), db = pb.norm();
  const Eigen::Vector2d ab = b - a;
  const double l = ab.norm();
  if (l <= 0.0 || da <= 0.0 || db <= 0.0) return std::nullopt;
  // Angle at a between a->b and a->robot (law of cosines), clamped where noise breaks it.
  double cos_alpha = (l * l + da * da - db * db) / (2.0 * l * da);
  if (std::abs(cos_alpha) > 1.1) return std::nullopt;
  cos_alpha = std::clamp(cos_alpha, -1.0, 1.0);
  const double alpha = std::acos(cos_alpha);
  // pa x pb = (a - r) x (b - r) = (b - a) x (r - a), whatever the heading: positive when the
  // robot r is left of a->b, so the direction a->r turns from a->b by +alpha.
  const double cross = pa.x() * pb.y() - pa.y() * pb.x();
  const double side = cross > 0.0 ? 1.0 : -1.0;
  const double direction = std::atan2(ab.y(), ab.x()) + side * alpha;
  const Eigen::Vector2d position =
      a + da * Eigen::Vector2d(std::cos(direction), std::sin(direction));
  const auto heading_from = [&](const Eigen::Vector2d& landmark, const Eigen::Vector2d& seen) {
    const Eigen::Vector2d d = landmark - position;
    return std::atan2(d.y(), d.x()) - std::atan2(seen.y(), seen.x());
  };
  const double ha = heading_from(a, pa), hb = heading_from(b, pb);
  const double heading = std::atan2(std::sin(ha) + std::sin(hb), std::cos(ha) + std::cos(hb));
  return Pose(position.x(), position.y(), heading);
}

/// A 2D point estimate with its covariance.
struct PointEstimate {
  Eigen::Vector2d p = Eigen::Vector2d::Zero();
  Eigen::Matrix2d c = Eigen::Matrix2d::Identity();
};

/// Two independent estimates of one point combined (paper 002): with K = C1 (C1 + C2)^-1,
/// x' = x1 + K (x2 - x1) and C' = C1 - K C1.
inline PointEstimate kalman_combine(const PointEstimate& e1, const PointEstimate& e2) {
  const Eigen::Matrix2d gain = e1.c * (e1.c + e2.c).inverse();
  return {e1.p + gain * (e2.p - e1.p), e1.c - gain * e1.c};
}

/// A world point m as seen from the robot at `pose`: p = R(theta)^T (m - t), and H = dp / d pose
/// (2x3) when asked: -R^T for the position, dR^T/dtheta (m - t) for the heading.
inline Eigen::Vector2d point_in_robot_frame(const Pose& pose, const Eigen::Vector2d& m,
                                            Eigen::Matrix<double, 2, 3>* H = nullptr) {
  const double c = std::cos(pose(2)), s = std::sin(pose(2));
  const Eigen::Vector2d d = m - pose.head<2>();
  if (H != nullptr) {
    *H << -c, -s, -s * d.x() + c * d.y(),  //
        s, -c, -c * d.x() - s * d.y();
  }
  return {c * d.x() + s * d.y(), -s * d.x() + c * d.y()};
}

/// The information sum_k H_k^T C_k^-1 H_k that points of known world positions seen in the robot
/// frame (each with its covariance) give about the pose, at `pose`; its inverse is the Cramer-Rao
/// bound: no unbiased pose from these points is more certain. With the weighted residuals'
/// gradient sum_k H_k^T C_k^-1 (p_k - h(pose, m_k)) and their chi2.
struct PointsInformation {
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  Eigen::Vector3d gradient = Eigen::Vector3d::Zero();
  double chi2 = 0.0;
};
inline PointsInformation points_information(const std::vector<Eigen::Vector2d>& world,
                                            const std::vector<PointEstimate>& seen,
                                            const Pose& pose) {
  PointsInformation out;
  for (std::size_t k = 0; k < std::min(world.size(), seen.size()); ++k) {
    Eigen::Matrix<double, 2, 3> H;
    const Eigen::Vector2d residual = seen[k].p - point_in_robot_frame(pose, world[k], &H);
    const Eigen::Matrix2d weight = seen[k].c.inverse();
    out.information += H.transpose() * weight * H;
    out.gradient += H.transpose() * weight * residual;
    out.chi2 += residual.dot(weight * residual);
  }
  return out;
}

/// The inverse of an information matrix, symmetrised; nullopt when it is singular (the points do
/// not fix the pose: fewer than two, or all at one place).
inline std::optional<Eigen::Matrix3d> covariance_from_information(const Eigen::Matrix3d& info) {
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(info);
  if (!lu.isInvertible()) return std::nullopt;
  const Eigen::Matrix3d inverse = lu.inverse();
  return 0.5 * (inverse + inverse.transpose());
}

/// The pose that best explains points of known world positions seen in the robot frame, each
/// with its covariance: weighted least squares, min over x of
///   sum_k (p_k - h(x, m_k))^T C_k^-1 (p_k - h(x, m_k)),   h = point_in_robot_frame,
/// by Gauss-Newton from `start` (e.g. two_landmark_pose of a pair). covariance = the inverse of
/// points_information at the solution; chi2 the weighted sum of squares there (2n - 3 degrees of
/// freedom). nullopt with fewer than two points or lists of different lengths.
struct PoseFit {
  Pose pose;
  Eigen::Matrix3d covariance;
  double chi2;
};
inline std::optional<PoseFit> fit_pose_to_points(const std::vector<Eigen::Vector2d>& world,
                                                 const std::vector<PointEstimate>& seen,
                                                 const Pose& start) {
  if (world.size() != seen.size() || world.size() < 2) return std::nullopt;
  Pose pose = start;
  // Converges in a few steps from a pair's triangulation (the model is nearly linear within a
  // few decimetres); the cap only bounds a degenerate start.
  for (int iteration = 0; iteration < 20; ++iteration) {
    const PointsInformation at = points_information(world, seen, pose);
    const Eigen::LDLT<Eigen::Matrix3d> solver(at.information);
    if (solver.info() != Eigen::Success || !solver.isPositive()) return std::nullopt;
    const Eigen::Vector3d step = solver.solve(at.gradient);
    if (!step.allFinite()) return std::nullopt;
    pose += step;
    pose(2) = wrap(pose(2));
    if (step.head<2>().norm() < 1e-9 && std::abs(step(2)) < 1e-9) break;
  }
  const PointsInformation at = points_information(world, seen, pose);
  const auto covariance = covariance_from_information(at.information);
  if (!covariance) return std::nullopt;
  return PoseFit{pose, *covariance, at.chi2};
}

/// A position from its distances to three or more known points (paper 003's ultrasonic beacons,
/// horizontal distances): the least-squares solution of the circle equations' differences,
/// 2 (x_i - x_0) . p = r_0^2 - r_i^2 + |x_i|^2 - |x_0|^2, refined by Gauss-Newton on the
/// distances themselves. nullopt with fewer than three points or when they are collinear.
inline std::optional<Eigen::Vector2d> trilaterate(const std::vector<Eigen::Vector2d>& anchors,
                                                  const std::vector<double>& ranges) {
  const auto n = static_cast<Eigen::Index>(std::min(anchors.size(), ranges.size()));
  if (n < 3) return std::nullopt;
  Eigen::MatrixXd a(n - 1, 2);
  Eigen::VectorXd b(n - 1);
  for (Eigen::Index i = 1; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    a.row(i - 1) = 2.0 * (anchors[k] - anchors[0]).transpose();
    b(i - 1) = ranges[0] * ranges[0] - ranges[k] * ranges[k] + anchors[k].squaredNorm() -
               anchors[0].squaredNorm();
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(a);
  if (qr.rank() < 2) return std::nullopt;
  Eigen::Vector2d p = qr.solve(b);
  for (int iteration = 0; iteration < 10; ++iteration) {
    Eigen::MatrixXd j(n, 2);
    Eigen::VectorXd residual(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      const Eigen::Vector2d d = p - anchors[static_cast<std::size_t>(i)];
      const double distance = std::max(d.norm(), 1e-12);
      j.row(i) = d.transpose() / distance;
      residual(i) = distance - ranges[static_cast<std::size_t>(i)];
    }
    const Eigen::Vector2d step = (j.transpose() * j).ldlt().solve(-j.transpose() * residual);
    p += step;
    if (step.norm() < 1e-12) break;
  }
  return p;
}

/// The pose that maps two points given in the robot frame (r1, r2) onto where they were found
/// in the world (w1, w2): heading from the direction between them, position from their midpoint
/// (paper 003's two receivers: x0 = (x_A1 + x_A2) / 2, yaw from A1 -> A2).
inline Pose align_two_points(const Eigen::Vector2d& w1, const Eigen::Vector2d& w2,
                             const Eigen::Vector2d& r1, const Eigen::Vector2d& r2) {
  const Eigen::Vector2d dw = w2 - w1, dr = r2 - r1;
  const double heading = wrap(std::atan2(dw.y(), dw.x()) - std::atan2(dr.y(), dr.x()));
  const double c = std::cos(heading), s = std::sin(heading);
  const Eigen::Vector2d mid_r = 0.5 * (r1 + r2), mid_w = 0.5 * (w1 + w2);
  return {mid_w.x() - (c * mid_r.x() - s * mid_r.y()), mid_w.y() - (s * mid_r.x() + c * mid_r.y()),
          heading};
}

/// The slant range [m] from a receiver mounted at `receiver` (robot frame) on a robot at `pose`
/// to a beacon at `beacon` (world), `dz` [m] above the receiver, and its gradient d range /
/// d (x, y, theta): with p = (x, y) + R(theta) receiver and e = p - beacon,
///   range = sqrt(|e|^2 + dz^2),  d/d(x, y) = e / range,  d/dtheta = e . (R'(theta) receiver) /
///   range.
struct BeaconRangeModel {
  double range_m;
  Eigen::RowVector3d jacobian;
};
inline BeaconRangeModel beacon_range(const Pose& pose, const Eigen::Vector2d& receiver,
                                     const Eigen::Vector2d& beacon, double dz) {
  const double c = std::cos(pose(2)), s = std::sin(pose(2));
  const Eigen::Vector2d rotated(c * receiver.x() - s * receiver.y(),
                                s * receiver.x() + c * receiver.y());
  const Eigen::Vector2d e = pose.head<2>() + rotated - beacon;
  const double range = std::max(std::sqrt(e.squaredNorm() + dz * dz), 1e-9);
  // R'(theta) receiver is the rotated offset turned a further 90 degrees.
  const Eigen::Vector2d d_rotated(-rotated.y(), rotated.x());
  return {range, Eigen::RowVector3d(e.x() / range, e.y() / range, e.dot(d_rotated) / range)};
}

/// Paper 003's IMU motion over the state s = (x, y, vx, vy, theta): the body-frame acceleration
/// a = (forward, left) [m/s^2] turned into the world by the heading, and the yaw rate omega
/// [rad/s], held for dt [s]. With (ax, ay) = R(theta) a:
///   x' = x + vx dt + ax dt^2 / 2,  vx' = vx + ax dt  (y, vy likewise),  theta' = theta + omega dt.
/// The paper has the forward acceleration only, and prints vx' = vx + a cos(theta) dt / 2; we
/// take the kinematics, and the lateral (centripetal) part without which every turn at speed
/// sends the prediction straight on.
using ImuState = Eigen::Matrix<double, 5, 1>;
inline ImuState imu_motion(const ImuState& s, const Eigen::Vector2d& accel_body, double omega,
                           double dt) {
  const double c = std::cos(s(4)), sn = std::sin(s(4));
  const double ax = c * accel_body.x() - sn * accel_body.y();
  const double ay = sn * accel_body.x() + c * accel_body.y();
  ImuState out;
  out << s(0) + s(2) * dt + 0.5 * ax * dt * dt, s(1) + s(3) * dt + 0.5 * ay * dt * dt,
      s(2) + ax * dt, s(3) + ay * dt, wrap(s(4) + omega * dt);
  return out;
}

/// d imu_motion / d s.
inline Eigen::Matrix<double, 5, 5> imu_motion_jacobian(const ImuState& s,
                                                       const Eigen::Vector2d& accel_body,
                                                       double dt) {
  const double c = std::cos(s(4)), sn = std::sin(s(4));
  // d (ax, ay) / d theta: the world acceleration turned a further 90 degrees.
  const double dax = -sn * accel_body.x() - c * accel_body.y();
  const double day = c * accel_body.x() - sn * accel_body.y();
  Eigen::Matrix<double, 5, 5> f = Eigen::Matrix<double, 5, 5>::Identity();
  f(0, 2) = dt, f(1, 3) = dt;
  f(0, 4) = 0.5 * dax * dt * dt, f(1, 4) = 0.5 * day * dt * dt;
  f(2, 4) = dax * dt, f(3, 4) = day * dt;
  return f;
}

/// d imu_motion / d (a_forward, a_left, omega): how the IMU's noise enters the state.
inline Eigen::Matrix<double, 5, 3> imu_noise_jacobian(const ImuState& s, double dt) {
  const double c = std::cos(s(4)), sn = std::sin(s(4));
  Eigen::Matrix<double, 5, 3> g = Eigen::Matrix<double, 5, 3>::Zero();
  g(0, 0) = 0.5 * c * dt * dt, g(1, 0) = 0.5 * sn * dt * dt, g(2, 0) = c * dt, g(3, 0) = sn * dt;
  g(0, 1) = -0.5 * sn * dt * dt, g(1, 1) = 0.5 * c * dt * dt, g(2, 1) = -sn * dt, g(3, 1) = c * dt;
  g(4, 2) = dt;
  return g;
}

}  // namespace locsim::sdk
