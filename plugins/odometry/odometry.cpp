// odometry: dead reckoning from the wheel encoders, the baseline every paper compares with.
// Its covariance grows with paper 002's input noise, diag(K_L^2 |d_L|, K_R^2 |d_R|).
#include <cmath>
#include <locsim/localizer.hpp>
#include <locsim/models.hpp>
#include <optional>

namespace {

using locsim::sdk::Pose;

class Odometry final : public locsim::sdk::Localizer {
 public:
  explicit Odometry(const locsim_init& init)
      : k_left_(locsim::sdk::Params(init).number("k_left")),
        k_right_(locsim::sdk::Params(init).number("k_right")),
        wheel_base_m_(init.robot->wheel_base_m),
        odometry_(init.robot->wheel_base_m),
        response_(locsim::sdk::CommandResponse::from(locsim::sdk::Params(init))) {
    if (init.initial_pose_known) {
      pose_ = {init.initial_pose.x, init.initial_pose.y, init.initial_pose.theta};
      covariance_ =
          Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(init.initial_covariance);
    } else {
      // No idea where it is: start at the origin, say so in the covariance.
      covariance_ = Eigen::Vector3d(1e6, 1e6, 10.0).asDiagonal();
    }
  }

  void on_odometry(double t_s, const locsim_odometry& odometry) override {
    // The ticks' travel, or (a source without ticks) the travel that makes the odometry pose's
    // increment: the same noise model either way. Odometry that reports the command (command_*)
    // is first run through the base's response.
    if (const auto step = odometry_.update(t_s, response_.follow(t_s, odometry))) {
      locsim::sdk::predict_by_wheels(pose_, covariance_, step->d_left_m, step->d_right_m,
                                     wheel_base_m_, k_left_, k_right_);
    }
  }

  locsim::sdk::Estimate estimate() const override {
    return {{pose_(0), pose_(1), pose_(2)}, covariance_};
  }

 private:
  double k_left_, k_right_, wheel_base_m_;
  Pose pose_ = Pose::Zero();
  Eigen::Matrix3d covariance_;
  locsim::sdk::OdometryTracker odometry_;
  locsim::sdk::CommandFollower response_;
};

constexpr locsim_param_decl kParams[] = {
    {"k_left", LOCSIM_PARAM_DOUBLE, 0.0013, 0.0, 1.0, nullptr,
     "left wheel random error, variance K^2 |d| (paper 002) [m^1/2]"},
    {"k_right", LOCSIM_PARAM_DOUBLE, 0.0012, 0.0, 1.0, nullptr, "right wheel random error [m^1/2]"},
    LOCSIM_COMMAND_RESPONSE_PARAMS,
};

}  // namespace

LOCSIM_LOCALIZER(Odometry, "odometry", "Dead reckoning from the wheel encoders (the baseline)",
                 kParams)
