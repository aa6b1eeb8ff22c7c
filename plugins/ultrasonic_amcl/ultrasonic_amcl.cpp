// ultrasonic_amcl: paper 003's fusion of the ultrasonic + IMU EKF with AMCL on the laser
// (SPEC section 5). The EKF (ultrasonic_filter.hpp) is the output; AMCL (amcl_filter.hpp) runs
// beside it on odometry and the laser, and the two meet in three places:
//  - moving: after each AMCL update its estimate (covariance floored) updates the EKF as an
//    observation of (x, y, theta), gated by Mahalanobis distance: AMCL gives the heading and the
//    smoothness the ultrasonic lacks, the ultrasonic the absolute position AMCL can lose;
//  - standing still (no wheel motion for still_s): the ultrasonic pose initialises AMCL's
//    particles, once per stop, if AMCL disagrees with it (global localization without exploring);
//  - lost: when AMCL disagrees with a confident EKF for pull_after_updates updates in a row, its
//    particles are drawn again around the EKF's pose (after a kidnapping the ultrasonic restarts
//    from trilateration within a second, and pulls AMCL back with it).
#include <array>
#include <locsim/localizer.hpp>
#include <string_view>

#include "../amcl/amcl_filter.hpp"
#include "../ultrasonic_ekf/ultrasonic_filter.hpp"

namespace {

namespace sdk = locsim::sdk;

constexpr locsim_param_decl kFusionParams[] = {
    {"still_s", LOCSIM_PARAM_DOUBLE, 0.5, 0.0, 1e6, nullptr,
     "no wheel motion this long means standing still: the ultrasonic may seed AMCL [s]"},
    {"seed_max_sigma_m", LOCSIM_PARAM_DOUBLE, 0.2, 1e-6, 100.0, nullptr,
     "the EKF seeds or pulls AMCL only when its position sigma is below this [m]"},
    {"fusion_gate_chi2", LOCSIM_PARAM_DOUBLE, 16.0, 0.1, 1e6, nullptr,
     "squared Mahalanobis distance beyond which AMCL's pose is not fused (and counts as "
     "disagreeing) [-]"},
    {"pull_after_updates", LOCSIM_PARAM_INT, 5, 1, 100000, nullptr,
     "AMCL updates in a row disagreeing with a confident EKF before AMCL is drawn again [-]"},
    {"amcl_sigma_min_m", LOCSIM_PARAM_DOUBLE, 0.05, 0.0, 10.0, nullptr,
     "floor on AMCL's position sigma when fused: its particle spread is optimistic, its error "
     "about the map's cell (paper 003's lab: 5.8 cm RMS on a 5 cm grid) [m]"},
    {"amcl_sigma_min_deg", LOCSIM_PARAM_DOUBLE, 1.0, 0.0, 180.0, nullptr,
     "floor on AMCL's heading sigma when fused [deg]"}};

template <std::size_t A, std::size_t B, std::size_t C>
constexpr std::array<locsim_param_decl, A + B + C> join(const locsim_param_decl (&a)[A],
                                                        const locsim_param_decl (&b)[B],
                                                        const locsim_param_decl (&c)[C]) {
  std::array<locsim_param_decl, A + B + C> out{};
  std::size_t i = 0;
  for (const auto& p : a) out[i++] = p;
  for (const auto& p : b) out[i++] = p;
  for (const auto& p : c) out[i++] = p;
  return out;
}
// AMCL's random injection off: the ultrasonic fix restarts the fusion after a kidnap, and
// guesses elsewhere would only compete with it. AMCL turns by the wheels, as paper 003's (the
// IMU drives the EKF), and its estimate is its heaviest cluster (the fusion gates that pose by
// its covariance).
constexpr auto kParams = [] {
  auto params = join(ultrasonic::kUltrasonicParams, amcl::kAmclParams, kFusionParams);
  for (locsim_param_decl& p : params) {
    const std::string_view name = p.name;
    if (name == "recovery_alpha_slow" || name == "recovery_alpha_fast" || name == "use_gyro")
      p.default_number = 0.0;
    if (name == "estimate") p.default_string = "heaviest";
  }
  return params;
}();

class UltrasonicAmcl final : public sdk::Localizer {
 public:
  explicit UltrasonicAmcl(const locsim_init& init) : UltrasonicAmcl(init, sdk::Params(init)) {}

  void on_imu(double t_s, const locsim_imu& imu) override {
    ekf_.on_imu(t_s, imu);
    amcl_.on_imu(t_s, imu);
  }

  void on_beacon_ranges(double t_s, const locsim_beacon_ranges& reading) override {
    ekf_.on_beacon_ranges(t_s, reading);
    // Standing still: the ultrasonic pose starts AMCL where it stands, once per stop.
    if (t_s - last_motion_s_ >= still_s_ && !seeded_this_stop_ && confident() && !amcl_agrees()) {
      seed_amcl();
      seeded_this_stop_ = true;
    }
  }

  void on_odometry(double t_s, const locsim_odometry& odometry) override {
    const sdk::Pose odom(odometry.odom_pose.x, odometry.odom_pose.y, odometry.odom_pose.theta);
    if (!last_odom_ || (odom - *last_odom_).cwiseAbs().maxCoeff() > 1e-9) {
      last_motion_s_ = t_s;
      seeded_this_stop_ = false;
    }
    last_odom_ = odom;
    ekf_.on_odometry(t_s, odometry);
    amcl_.on_odometry(t_s, odometry);
  }

  void on_laser(double t_s, const locsim_laser_scan& scan) override {
    if (!amcl_.on_laser(t_s, scan) || !ekf_.initialised()) return;
    const sdk::Estimate a = amcl_.estimate();
    const bool fused =
        ekf_.update_pose({a.pose.x, a.pose.y, a.pose.theta}, floored(a.covariance), gate_chi2_);
    if (fused) {
      ++fused_, disagreeing_ = 0;
    } else if (confident() && ++disagreeing_ >= pull_after_updates_) {
      seed_amcl();
      disagreeing_ = 0;
    }
  }

  sdk::Estimate estimate() const override { return ekf_.estimate(); }

  void particles(std::vector<locsim_pose2>& poses, std::vector<double>& weights) const override {
    amcl_.particles(poses, weights);
  }

  std::vector<std::pair<std::string, double>> diagnostics() const override {
    auto d = ekf_.diagnostics();
    for (auto& entry : amcl_.diagnostics()) d.emplace_back("amcl_" + entry.first, entry.second);
    d.emplace_back("fused", static_cast<double>(fused_));
    d.emplace_back("amcl_seeded", static_cast<double>(seeded_));
    return d;
  }

 private:
  UltrasonicAmcl(const locsim_init& init, const sdk::Params& params)
      : ekf_(ultrasonic::ultrasonic_def(params), init),
        amcl_(params, init, init.seed),
        still_s_(params.number("still_s")),
        seed_max_sigma_m_(params.number("seed_max_sigma_m")),
        gate_chi2_(params.number("fusion_gate_chi2")),
        pull_after_updates_(static_cast<int>(params.integer("pull_after_updates"))),
        amcl_sigma_min_m_(params.number("amcl_sigma_min_m")),
        amcl_sigma_min_rad_(params.number("amcl_sigma_min_deg") * std::numbers::pi / 180.0) {}

  bool confident() const {
    if (!ekf_.initialised()) return false;
    const Eigen::Matrix3d c = ekf_.pose_covariance();
    return std::sqrt(std::max(c(0, 0), c(1, 1))) < seed_max_sigma_m_;
  }

  bool amcl_agrees() const {
    const sdk::Estimate a = amcl_.estimate();
    Eigen::Vector3d d(a.pose.x, a.pose.y, a.pose.theta);
    d -= ekf_.pose();
    d(2) = sdk::wrap(d(2));
    const Eigen::Matrix3d s = ekf_.pose_covariance() + floored(a.covariance);
    return d.dot(s.ldlt().solve(d)) <= gate_chi2_;
  }

  void seed_amcl() {
    Eigen::Matrix3d c = ekf_.pose_covariance();
    c(0, 0) += amcl_sigma_min_m_ * amcl_sigma_min_m_;
    c(1, 1) += amcl_sigma_min_m_ * amcl_sigma_min_m_;
    c(2, 2) += amcl_sigma_min_rad_ * amcl_sigma_min_rad_;
    amcl_.reseed(ekf_.pose(), c);
    ++seeded_;
  }

  Eigen::Matrix3d floored(Eigen::Matrix3d c) const {
    c(0, 0) = std::max(c(0, 0), amcl_sigma_min_m_ * amcl_sigma_min_m_);
    c(1, 1) = std::max(c(1, 1), amcl_sigma_min_m_ * amcl_sigma_min_m_);
    c(2, 2) = std::max(c(2, 2), amcl_sigma_min_rad_ * amcl_sigma_min_rad_);
    return c;
  }

  ultrasonic::UltrasonicEkf ekf_;
  amcl::AmclFilter amcl_;
  double still_s_, seed_max_sigma_m_, gate_chi2_;
  int pull_after_updates_;
  double amcl_sigma_min_m_, amcl_sigma_min_rad_;
  std::optional<sdk::Pose> last_odom_;
  double last_motion_s_ = 0.0;
  bool seeded_this_stop_ = false;
  int disagreeing_ = 0;
  long fused_ = 0, seeded_ = 0;
};

}  // namespace

LOCSIM_LOCALIZER(UltrasonicAmcl, "ultrasonic_amcl",
                 "Paper 003's fusion: ultrasonic + IMU EKF fused with AMCL on the laser; the "
                 "ultrasonic seeds AMCL at stops and pulls it back when lost",
                 kParams)
