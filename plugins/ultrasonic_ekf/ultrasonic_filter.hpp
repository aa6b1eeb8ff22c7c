// Paper 003's ultrasonic + IMU EKF over s = (x, y, vx, vy, theta, b), shared by the ultrasonic_ekf
// plugin and the ultrasonic_amcl fusion; b is the bias of the turn rate (the IMU's gyro, or the
// gyro a gyro-fused odometry turns by), estimated when given a prior spread, else held. It predicts
// with the IMU (body-frame acceleration, yaw rate; sdk::imu_motion), or, on a robot without one (a
// lawnmower ranging to UWB anchors), by the wheels' odometry (sdk::diff_drive_motion with paper
// 002's wheel noise), and updates on each ultrasonic round in one of two ways:
//  - trilateration (the paper): every receiver's position from the beacons (least squares with
//    more than three), the pose from the two receivers, velocities by finite difference; the EKF
//    observes (x, y, theta, vx, vy). No gate: a range lengthened by a person in the beam moves
//    the solution, and the filter follows it.
//  - ranges (beyond the paper): one scalar observation per receiver and beacon, the slant range
//    (sdk::beacon_range), each passed through a Mahalanobis gate against the prediction before a
//    joint update. A non-line-of-sight range is longer by at least a reflected path's extra
//    length, many sigmas for a tracking filter, so the gate drops it. When most ranges fail the
//    gate round after round, the filter is lost (kidnapped): it restarts from trilateration,
//    or, where echoes outnumber the direct paths (rooms behind walls), from the fix most of the
//    ranges agree with.
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <locsim/localizer.hpp>
#include <locsim/models.hpp>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace ultrasonic {

namespace sdk = locsim::sdk;

struct UltrasonicEkfDef {
  enum class Mode { kTrilateration, kRanges };
  Mode mode = Mode::kRanges;
  // What predicts: the IMU, the wheels, or the wheels until the first IMU reading (a robot
  // without an IMU never gives one).
  enum class Motion { kAuto, kImu, kWheels };
  Motion motion = Motion::kAuto;
  double k_left = 0.0013, k_right = 0.0012;  // wheel noise, motion by the wheels [m^1/2]
  // Motion by the wheels: the body's drift across its heading (sdk::side_slip_covariance).
  double side_slip_k = 0.0;  // [m^1/2]
  // Motion by the wheels: noise of every round whatever the motion (locsim calibrate's floor).
  double motion_floor_m = 0.0, motion_floor_rad = 0.0;
  // The gyro the heading turns by (the odometry's, motion by the wheels; its bias also the IMU's
  // when the IMU predicts): the turn's bias is the state's sixth component.
  sdk::GyroHeading gyro;
  double sigma_accel = 0.3;        // process noise of the forward acceleration [m/s^2]
  double sigma_gyro = 0.02;        // process noise of the yaw rate [rad/s]
  double sigma_position_m = 0.05;  // trilaterated position [m]
  double sigma_yaw_rad = 0.26;     // yaw from the two receivers [rad]
  double sigma_velocity = 1.0;     // finite-difference velocity [m/s]
  double sigma_range_m = 0.03;     // one slant range (ranges mode) [m]
  // The ranging system's systematic error, taken out of each range as it comes:
  // d = (range - range_bias_m) / (1 + range_bias_per_m).
  double range_bias_m = 0.0, range_bias_per_m = 0.0;
  double corrected_range_m(double range_m) const {
    return (range_m - range_bias_m) / (1.0 + range_bias_per_m);
  }
  /// sigma_range_m of a corrected range.
  double corrected_sigma_m() const { return sigma_range_m / (1.0 + range_bias_per_m); }
  double gate_chi2 = 9.0;      // squared Mahalanobis distance accepted per range [-]
  double fix_gate_chi2 = 0.0;  // trilateration: the same for a fix's (x, y); 0: no gate [-]
  int lost_after_rounds = 10;  // rounds with most ranges gated out before a restart [-]
};

/// The parameters both plugins declare, and the definition read back from them.
inline constexpr locsim_param_decl kUltrasonicParams[] = {
    {"mode", LOCSIM_PARAM_STRING, 0, 0, 0, "ranges",
     "trilateration (the paper: fix, then update) or ranges (gated update on each range)"},
    {"sigma_accel", LOCSIM_PARAM_DOUBLE, 0.3, 1e-6, 100.0, nullptr,
     "process noise of the forward acceleration [m/s^2]"},
    {"sigma_gyro", LOCSIM_PARAM_DOUBLE, 0.02, 1e-6, 10.0, nullptr,
     "process noise of the yaw rate [rad/s]"},
    {"sigma_position_m", LOCSIM_PARAM_DOUBLE, 0.05, 1e-6, 100.0, nullptr,
     "noise of a trilaterated position [m]"},
    {"sigma_yaw_deg", LOCSIM_PARAM_DOUBLE, 15.0, 1e-6, 180.0, nullptr,
     "noise of the yaw from the two receivers (0.3 m apart: about 1.4 sigma_position / 0.3) [deg]"},
    {"sigma_velocity", LOCSIM_PARAM_DOUBLE, 1.0, 1e-6, 100.0, nullptr,
     "noise of a finite-difference velocity (about 1.4 sigma_position x rate) [m/s]"},
    {"sigma_range_m", LOCSIM_PARAM_DOUBLE, 0.03, 1e-6, 10.0, nullptr,
     "noise of one slant range, ranges mode [m]"},
    {"gate_chi2", LOCSIM_PARAM_DOUBLE, 9.0, 0.1, 1e6, nullptr,
     "squared Mahalanobis distance above which a range is dropped (9: 3 sigma), ranges mode [-]"},
    {"fix_gate_chi2", LOCSIM_PARAM_DOUBLE, 0.0, 0.0, 1e6, nullptr,
     "trilateration mode: squared Mahalanobis distance (2 dof) above which a fix's position is "
     "dropped (lost_after_rounds refused in a row: restart); 0: no gate, as the paper [-]"},
    {"lost_after_rounds", LOCSIM_PARAM_INT, 10, 1, 100000, nullptr,
     "rounds in a row with most ranges (or the fix) gated out before restarting from "
     "trilateration [-]"},
    {"range_bias_m", LOCSIM_PARAM_DOUBLE, 0.0, -100.0, 100.0, nullptr,
     "added to every range by the ranging system (an antenna's delay; locsim calibrate), taken "
     "out of each range [m]"},
    {"range_bias_per_m", LOCSIM_PARAM_DOUBLE, 0.0, -0.9, 10.0, nullptr,
     "added per metre of distance (a scale error; locsim calibrate), taken out likewise [m/m]"},
    {"motion", LOCSIM_PARAM_STRING, 0, 0, 0, "auto",
     "what predicts the motion: imu (paper 003), wheels (the odometry, with k_left and k_right), "
     "or auto: the wheels until the first IMU reading, the IMU from then on (a robot without an "
     "IMU moves by its wheels)"},
    LOCSIM_WHEEL_NOISE_PARAMS,
    LOCSIM_SIDE_SLIP_PARAM,
    {"motion_floor_m", LOCSIM_PARAM_DOUBLE, 0.0, 0, 10, nullptr,
     "motion by the wheels: position noise added at every round of ranges whatever the motion, "
     "per axis (locsim calibrate) [m]"},
    {"motion_floor_deg", LOCSIM_PARAM_DOUBLE, 0.0, 0, 180, nullptr,
     "motion by the wheels: heading noise added likewise (locsim calibrate) [deg]"},
    LOCSIM_GYRO_HEADING_PARAMS};

UltrasonicEkfDef ultrasonic_def(const sdk::Params& params);

class UltrasonicEkf {
 public:
  /// (x, y, vx, vy, theta, heading-rate bias).
  using State = Eigen::Matrix<double, 6, 1>;
  using Covariance = Eigen::Matrix<double, 6, 6>;

  UltrasonicEkf(const UltrasonicEkfDef& def, const locsim_init& init);

  void on_imu(double t_s, const locsim_imu& imu);
  /// Predicts by the wheels' travel since the last reading when the motion is the wheels'.
  void on_odometry(double t_s, const locsim_odometry& odometry);
  void on_beacon_ranges(double t_s, const locsim_beacon_ranges& reading);

  /// Another estimate of (x, y, theta) with its covariance (the fusion's AMCL pose), gated like
  /// a range: false, and no update, when its squared Mahalanobis distance exceeds gate_chi2.
  bool update_pose(const sdk::Pose& pose, const Eigen::Matrix3d& covariance, double gate_chi2);
  /// Starts over at `pose` (velocity zero) with this covariance of (x, y, theta); the heading
  /// rate's bias is kept (a kidnapping does not change the gyro), its correlations dropped.
  void reset(const sdk::Pose& pose, const Eigen::Matrix3d& covariance);

  bool initialised() const { return initialised_; }
  sdk::Pose pose() const { return {state_(0), state_(1), state_(4)}; }
  /// The turn rate's bias as estimated, and its standard deviation [rad/s].
  double heading_rate_bias() const { return state_(5); }
  double heading_rate_bias_sigma() const { return std::sqrt(covariance_(5, 5)); }
  Eigen::Matrix3d pose_covariance() const;
  sdk::Estimate estimate() const;
  /// The latest round: ranges received, ranges used (after the gate).
  int round_ranges() const { return round_ranges_; }
  int round_accepted() const { return round_accepted_; }
  std::vector<std::pair<std::string, double>> diagnostics() const;

 private:
  struct Beacon {
    Eigen::Vector2d position;
    double height_m;
  };
  struct Range {
    Eigen::Vector2d receiver;  // robot frame [m]
    int receiver_index;
    const Beacon* beacon;
    double dz_m, range_m;
  };

  void predict(double dt);
  /// The pose part (x, y, theta) and the bias moved by one odometry step with paper 002's wheel
  /// noise: the EKF's F and G on those components (sdk::move_with_heading_bias), the velocities
  /// left as they are.
  void predict_by_wheels(const sdk::OdometryStep& step);
  /// Whether the wheels move the estimate now (motion wheels, or auto before any IMU reading).
  bool by_wheels() const;
  std::optional<sdk::Pose> trilaterate_pose(const std::vector<Range>& ranges) const;
  void update_trilateration(double t_s, const std::vector<Range>& ranges);
  void update_ranges(const std::vector<Range>& ranges);
  /// Starts over from this round's trilateration if the fix explains most of its ranges; else,
  /// from the fix that the most of them agree with (echo_robust_fix), if it explains more of
  /// them than the estimate does and at least four per receiver.
  bool restart(const std::vector<Range>& ranges);
  /// A fix robust to echoes, for rooms where most ranges come back off walls: per receiver, of
  /// the positions trilaterated from every three of its ranges, the one the most of its ranges
  /// agree with and none contradicts (an echo only lengthens a range), refined on those; the
  /// pose from the two receivers. With the number of
  /// ranges it explains, the fewer of the two receivers'.
  std::optional<std::pair<sdk::Pose, int>> echo_robust_fix(const std::vector<Range>& ranges) const;
  /// How many of the ranges a pose explains (within the restart's tolerance).
  int explained(const sdk::Pose& pose, const std::vector<Range>& ranges) const;
  /// The EKF update for innovation z - h(s) with Jacobian H and noise R (Joseph form).
  void correct(const Eigen::MatrixXd& h, const Eigen::VectorXd& innovation,
               const Eigen::MatrixXd& r);

  UltrasonicEkfDef def_;
  std::map<int, Beacon> beacons_;
  /// The IMU's state: the first five components.
  sdk::ImuState imu_state() const { return state_.head<5>(); }
  /// Adds the bias's random walk over dt (held when not estimated).
  void walk_bias(double dt);

  State state_ = State::Zero();
  Covariance covariance_ = Covariance::Identity() * 100.0;
  bool initialised_ = false;
  std::optional<double> last_imu_s_;
  double wheel_base_m_;
  sdk::OdometryTracker wheels_;
  Eigen::Vector2d accel_ = Eigen::Vector2d::Zero();  // body frame (forward, left) [m/s^2]
  double yaw_rate_ = 0.0;
  std::optional<sdk::Pose> last_fix_;
  double last_fix_s_ = 0.0;
  int round_ranges_ = 0, round_accepted_ = 0, lost_rounds_ = 0;
  long fixes_ = 0, missed_ = 0, fixes_gated_ = 0, ranges_used_ = 0, ranges_gated_ = 0,
       restarts_ = 0, echo_restarts_ = 0;
};

}  // namespace ultrasonic
