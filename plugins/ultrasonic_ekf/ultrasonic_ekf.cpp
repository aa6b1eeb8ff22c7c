// ultrasonic_ekf: paper 003's ultrasonic + IMU localization (SPEC section 5) as a plugin; the
// filter itself, with its two update modes (the paper's trilateration, and gated raw ranges), is
// in ultrasonic_filter.hpp.
#include <locsim/localizer.hpp>

#include "ultrasonic_filter.hpp"

namespace {

namespace sdk = locsim::sdk;

class UltrasonicEkfPlugin final : public sdk::Localizer {
 public:
  explicit UltrasonicEkfPlugin(const locsim_init& init)
      : ekf_(ultrasonic::ultrasonic_def(sdk::Params(init)), init) {}

  void on_imu(double t_s, const locsim_imu& imu) override { ekf_.on_imu(t_s, imu); }
  void on_odometry(double t_s, const locsim_odometry& odometry) override {
    ekf_.on_odometry(t_s, odometry);
  }
  void on_beacon_ranges(double t_s, const locsim_beacon_ranges& reading) override {
    ekf_.on_beacon_ranges(t_s, reading);
  }
  sdk::Estimate estimate() const override { return ekf_.estimate(); }
  std::vector<std::pair<std::string, double>> diagnostics() const override {
    return ekf_.diagnostics();
  }

 private:
  ultrasonic::UltrasonicEkf ekf_;
};

}  // namespace

LOCSIM_LOCALIZER(UltrasonicEkfPlugin, "ultrasonic_ekf",
                 "Ultrasonic beacons + IMU EKF over (x, y, vx, vy, theta) (paper 003); "
                 "trilateration or gated raw ranges; by the wheels without an IMU",
                 ultrasonic::kUltrasonicParams)
