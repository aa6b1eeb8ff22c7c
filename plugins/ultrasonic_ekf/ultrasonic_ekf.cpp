// ultrasonic_ekf: paper 003's ultrasonic + IMU localization (SPEC section 5). Each ultrasonic
// round: every receiver's position by trilateration from the fixed beacons (least squares with
// more than three), the robot's pose from the two receivers (midpoint, and the yaw from one to
// the other), velocities by finite difference from the last round; then an EKF over
// s = (x, y, vx, vy, theta) predicts with the IMU (forward acceleration, yaw rate; sdk::imu_motion)
// and updates on that observation (x, y, theta, vx, vy). Slant ranges are made horizontal with
// the beacons' and receivers' heights. The gate-less trilateration is the paper's method, and
// its weakness: a range lengthened by a person in the beam moves the solution.
#include <Eigen/Dense>
#include <cmath>
#include <locsim/localizer.hpp>
#include <locsim/models.hpp>
#include <map>
#include <optional>
#include <vector>

namespace {

namespace sdk = locsim::sdk;

class UltrasonicEkf final : public sdk::Localizer {
 public:
  explicit UltrasonicEkf(const locsim_init& init) {
    const sdk::Params params(init);
    sigma_accel_ = params.number("sigma_accel");
    sigma_gyro_ = params.number("sigma_gyro");
    sigma_position_ = params.number("sigma_position_m");
    sigma_yaw_ = params.number("sigma_yaw_deg") * std::numbers::pi / 180.0;
    sigma_velocity_ = params.number("sigma_velocity");
    if (init.map == nullptr || init.map->beacon_count < 3)
      throw std::invalid_argument("needs at least three ultrasonic beacons on the map");
    for (std::size_t i = 0; i < init.map->beacon_count; ++i) {
      const locsim_beacon& b = init.map->beacons[i];
      beacons_[b.id] = {Eigen::Vector2d(b.x, b.y), b.height_m};
    }
    if (init.initial_pose_known) {
      state_ << init.initial_pose.x, init.initial_pose.y, 0.0, 0.0, init.initial_pose.theta;
      covariance_.setZero();
      covariance_(0, 0) = init.initial_covariance[0],
                     covariance_(1, 1) = init.initial_covariance[4];
      covariance_(4, 4) = init.initial_covariance[8];
      covariance_(2, 2) = covariance_(3, 3) = 0.01;
      initialised_ = true;
    }
  }

  void on_imu(double t_s, const locsim_imu& imu) override {
    if (last_imu_s_ && initialised_) {
      const double dt = t_s - *last_imu_s_;
      if (dt > 0.0) predict(dt);
    }
    last_imu_s_ = t_s;
    // The forward axis of the robot in the IMU frame.
    accel_ =
        std::cos(imu.mount_theta) * imu.accel_x_mps2 - std::sin(imu.mount_theta) * imu.accel_y_mps2;
    yaw_rate_ = imu.yaw_rate_radps;
  }

  void on_beacon_ranges(double t_s, const locsim_beacon_ranges& reading) override {
    // Per receiver: beacon positions and horizontal distances.
    std::map<int, Receiver> receivers;
    for (std::size_t i = 0; i < reading.count; ++i) {
      const locsim_beacon_range& r = reading.ranges[i];
      const auto beacon = beacons_.find(r.beacon_id);
      if (!std::isfinite(r.range_m) || beacon == beacons_.end()) continue;
      const double dz = beacon->second.height_m - r.receiver_height_m;
      const double horizontal = std::sqrt(std::max(0.0, r.range_m * r.range_m - dz * dz));
      Receiver& receiver = receivers[r.receiver];
      receiver.in_robot = Eigen::Vector2d(r.receiver_x, r.receiver_y);
      receiver.anchors.push_back(beacon->second.position);
      receiver.ranges.push_back(horizontal);
    }
    std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> found;  // (world, robot frame)
    for (const auto& [index, receiver] : receivers) {
      if (const auto p = sdk::trilaterate(receiver.anchors, receiver.ranges))
        found.emplace_back(*p, receiver.in_robot);
    }
    if (found.size() < 2) {
      ++missed_;
      return;
    }
    const sdk::Pose pose =
        sdk::align_two_points(found[0].first, found[1].first, found[0].second, found[1].second);
    Eigen::Vector2d velocity = Eigen::Vector2d::Zero();
    if (last_fix_ && t_s > last_fix_s_)
      velocity = (pose.head<2>() - last_fix_->head<2>()) / (t_s - last_fix_s_);
    const bool had_fix = last_fix_.has_value();
    last_fix_ = pose, last_fix_s_ = t_s;
    ++fixes_;
    if (!initialised_) {
      state_ << pose(0), pose(1), 0.0, 0.0, pose(2);
      covariance_ = Eigen::Matrix<double, 5, 5>::Identity();
      covariance_.diagonal() << sq(sigma_position_), sq(sigma_position_), 1.0, 1.0, sq(sigma_yaw_);
      initialised_ = true;
      return;
    }
    // z = (x, y, theta, vx, vy) observes the state directly: H picks the components.
    Eigen::Matrix<double, 5, 5> h = Eigen::Matrix<double, 5, 5>::Zero();
    h(0, 0) = h(1, 1) = h(2, 4) = h(3, 2) = h(4, 3) = 1.0;
    Eigen::Matrix<double, 5, 1> z;
    z << pose(0), pose(1), pose(2), velocity.x(), velocity.y();
    Eigen::Matrix<double, 5, 1> r;
    const double sigma_v = had_fix ? sigma_velocity_ : 1e3;  // no velocity from the first fix
    r << sq(sigma_position_), sq(sigma_position_), sq(sigma_yaw_), sq(sigma_v), sq(sigma_v);
    Eigen::Matrix<double, 5, 1> innovation = z - h * state_;
    innovation(2) = sdk::wrap(innovation(2));
    const Eigen::Matrix<double, 5, 5> s =
        h * covariance_ * h.transpose() + Eigen::Matrix<double, 5, 5>(r.asDiagonal());
    const Eigen::Matrix<double, 5, 5> gain = covariance_ * h.transpose() * s.inverse();
    state_ += gain * innovation;
    state_(4) = sdk::wrap(state_(4));
    // Joseph form: stays symmetric and positive.
    const Eigen::Matrix<double, 5, 5> i_kh = Eigen::Matrix<double, 5, 5>::Identity() - gain * h;
    covariance_ = i_kh * covariance_ * i_kh.transpose() +
                  gain * Eigen::Matrix<double, 5, 5>(r.asDiagonal()) * gain.transpose();
  }

  sdk::Estimate estimate() const override {
    sdk::Estimate e;
    e.pose = {state_(0), state_(1), state_(4)};
    e.covariance << covariance_(0, 0), covariance_(0, 1), covariance_(0, 4), covariance_(1, 0),
        covariance_(1, 1), covariance_(1, 4), covariance_(4, 0), covariance_(4, 1),
        covariance_(4, 4);
    return e;
  }

  std::vector<std::pair<std::string, double>> diagnostics() const override {
    return {{"fixes", static_cast<double>(fixes_)}, {"missed", static_cast<double>(missed_)}};
  }

 private:
  struct Beacon {
    Eigen::Vector2d position;
    double height_m;
  };
  struct Receiver {
    Eigen::Vector2d in_robot;
    std::vector<Eigen::Vector2d> anchors;
    std::vector<double> ranges;
  };
  static double sq(double v) { return v * v; }

  void predict(double dt) {
    const Eigen::Matrix<double, 5, 5> f = sdk::imu_motion_jacobian(state_, accel_, dt);
    const Eigen::Matrix<double, 5, 2> g = sdk::imu_noise_jacobian(state_, dt);
    state_ = sdk::imu_motion(state_, accel_, yaw_rate_, dt);
    const Eigen::Vector2d noise(sq(sigma_accel_), sq(sigma_gyro_));
    covariance_ = f * covariance_ * f.transpose() + g * noise.asDiagonal() * g.transpose();
  }

  std::map<int, Beacon> beacons_;
  sdk::ImuState state_ = sdk::ImuState::Zero();
  Eigen::Matrix<double, 5, 5> covariance_ = Eigen::Matrix<double, 5, 5>::Identity() * 100.0;
  bool initialised_ = false;
  std::optional<double> last_imu_s_;
  double accel_ = 0.0, yaw_rate_ = 0.0;
  std::optional<sdk::Pose> last_fix_;
  double last_fix_s_ = 0.0;
  double sigma_accel_, sigma_gyro_, sigma_position_, sigma_yaw_, sigma_velocity_;
  long fixes_ = 0, missed_ = 0;
};

constexpr locsim_param_decl kParams[] = {
    {"sigma_accel", LOCSIM_PARAM_DOUBLE, 0.3, 1e-6, 100.0, nullptr,
     "process noise of the forward acceleration [m/s^2]"},
    {"sigma_gyro", LOCSIM_PARAM_DOUBLE, 0.02, 1e-6, 10.0, nullptr,
     "process noise of the yaw rate [rad/s]"},
    {"sigma_position_m", LOCSIM_PARAM_DOUBLE, 0.05, 1e-6, 100.0, nullptr,
     "noise of a trilaterated position [m]"},
    {"sigma_yaw_deg", LOCSIM_PARAM_DOUBLE, 15.0, 1e-6, 180.0, nullptr,
     "noise of the yaw from the two receivers (0.3 m apart: about 1.4 sigma_position / 0.3) [deg]"},
    {"sigma_velocity", LOCSIM_PARAM_DOUBLE, 1.0, 1e-6, 100.0, nullptr,
     "noise of a finite-difference velocity (about 1.4 sigma_position x rate) [m/s]"}};

}  // namespace

LOCSIM_LOCALIZER(UltrasonicEkf, "ultrasonic_ekf",
                 "Ultrasonic trilateration + IMU EKF over (x, y, vx, vy, theta) (paper 003)",
                 kParams)
