// beacon_mcl: Monte Carlo localization on ranges to beacons (UWB anchors, ultrasonic
// transmitters), for robots that range and have no IMU to integrate (ultrasonic_ekf's paper 003
// setting has one). Built on the SDK's particle-filter skeleton (sdk::ParticleFilter), as the
// landmark filters are:
//   move    every odometry reading, each particle by its own draw of the wheels' travel (paper
//           002's wheel model, k_left, k_right; turned by the gyro where the robot has one; or,
//           for an odometry that turns by a gyro (odometry_heading gyro), the distance by the
//           wheels and the turn less each particle's own hypothesis of the gyro's bias), across
//           its heading by a draw of the body's side slip (side_slip_k, sdk::add_side_slip), and
//           at every round of ranges by the noise a step has whatever its motion (motion_floor_*)
//           and a roughening that keeps a finite set from collapsing;
//   weigh   each range, its systematic error taken out (range_bias_*), against the slant range
//           from the particle's receiver to the beacon (sdk::beacon_range): a Gaussian of
//           sigma_range_m beside a flat outlier_likelihood (an echo, a blocked path), so that one
//           range far off cannot decide the weights;
//   resample when the effective sample size falls below half the particles.
// A range says nothing about the heading: the particles whose heading is wrong move the wrong
// way and lose weight, so the heading comes from the motion, as with one receiver it must.
#include <cmath>
#include <locsim/localizer.hpp>
#include <locsim/models.hpp>
#include <locsim/particle_filter.hpp>
#include <locsim/particles.hpp>
#include <map>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace {

namespace sdk = locsim::sdk;

constexpr locsim_param_decl kParams[] = {
    {"particles", LOCSIM_PARAM_INT, 1000, 1, 1000000, nullptr, "number of particles [-]"},
    LOCSIM_WHEEL_NOISE_PARAMS,
    LOCSIM_SIDE_SLIP_PARAM,
    LOCSIM_GYRO_PARAMS,
    {"motion_floor_m", LOCSIM_PARAM_DOUBLE, 0.0, 0, 10, nullptr,
     "position noise of every round of ranges whatever the motion, per axis (locsim calibrate) "
     "[m]"},
    {"motion_floor_deg", LOCSIM_PARAM_DOUBLE, 0.0, 0, 180, nullptr,
     "heading noise of every round whatever the motion (locsim calibrate) [deg]"},
    {"roughening_m", LOCSIM_PARAM_DOUBLE, 0.01, 0, 10, nullptr,
     "position noise added to every particle at every round beside the floor (in quadrature), so "
     "that a finite set does not collapse [m]"},
    {"roughening_deg", LOCSIM_PARAM_DOUBLE, 0.5, 0, 180, nullptr,
     "heading noise added likewise [deg]"},
    {"sigma_range_m", LOCSIM_PARAM_DOUBLE, 0.03, 1e-6, 100, nullptr,
     "noise of one range (locsim calibrate) [m]"},
    {"range_bias_m", LOCSIM_PARAM_DOUBLE, 0.0, -100.0, 100.0, nullptr,
     "added to every range by the ranging system (locsim calibrate), taken out of each [m]"},
    {"range_bias_per_m", LOCSIM_PARAM_DOUBLE, 0.0, -0.9, 10.0, nullptr,
     "added per metre of distance (a scale error; locsim calibrate), taken out likewise [m/m]"},
    {"outlier_likelihood", LOCSIM_PARAM_DOUBLE, 0.05, 0, 1, nullptr,
     "added to every range's likelihood (1 = perfect match): the chance that it is an echo, so "
     "that one far off cannot decide the weights; 0: every range is direct [-]"},
    {"resampler", LOCSIM_PARAM_STRING, 0, 0, 0, "low_variance", "low_variance or roulette"},
    LOCSIM_GYRO_HEADING_PARAMS};

class BeaconMcl final : public sdk::Localizer {
 public:
  explicit BeaconMcl(const locsim_init& init) : BeaconMcl(init, sdk::Params(init)) {}

  void on_imu(double t_s, const locsim_imu& imu) override { wheels_.observe_imu(t_s, imu); }

  void on_odometry(double t_s, const locsim_odometry& odometry) override {
    if (const auto step = wheels_.update(t_s, odometry)) move(*step);
  }

  void on_beacon_ranges(double t_s, const locsim_beacon_ranges& reading) override {
    // The ranges belong to the poses of their own time, which may lie after the last odometry.
    if (const auto step = wheels_.advance_to(t_s)) move(*step);
    ranges_.clear();
    for (std::size_t i = 0; i < reading.count; ++i) {
      const locsim_beacon_range& r = reading.ranges[i];
      const auto beacon = beacons_.find(r.beacon_id);
      if (!std::isfinite(r.range_m) || beacon == beacons_.end()) continue;
      ranges_.push_back({Eigen::Vector2d(r.receiver_x, r.receiver_y), beacon->second.first,
                         beacon->second.second - r.receiver_height_m,
                         (r.range_m - range_bias_m_) / (1.0 + range_bias_per_m_)});
    }
    if (ranges_.empty()) return;
    sdk::add_motion_floor(pf_.particles(), floor_, pf_.random());
    sdk::ParticleSet& p = pf_.particles();
    log_likelihood_.assign(p.size(), 0.0);
    const double sigma = sigma_range_m_ / (1.0 + range_bias_per_m_);
    for (std::size_t i = 0; i < p.size(); ++i) {
      const sdk::Pose pose(p.x[i], p.y[i], p.theta[i]);
      for (const Range& r : ranges_) {
        const double z =
            (r.range_m - sdk::beacon_range(pose, r.receiver, r.beacon, r.dz_m).range_m) / sigma;
        // The match (1 at a perfect one) with the flat chance of an echo beside it.
        log_likelihood_[i] += std::log(std::exp(-0.5 * z * z) + outlier_likelihood_);
      }
    }
    const sdk::Evidence evidence = pf_.weigh(log_likelihood_);
    n_eff_ = evidence.n_eff;
    ++rounds_;
    if (n_eff_ < 0.5 * static_cast<double>(pf_.size())) {
      if (gyro_.active)
        pf_.resample(bias_radps_);
      else
        pf_.resample();
      ++resamples_;
    }
  }

  sdk::Estimate estimate() const override { return pf_.estimate(); }

  void particles(std::vector<locsim_pose2>& poses, std::vector<double>& weights) const override {
    pf_.export_particles(poses, weights);
  }
  std::vector<std::pair<std::string, double>> diagnostics() const override {
    std::vector<std::pair<std::string, double>> out{{"n_eff", n_eff_},
                                                    {"rounds", static_cast<double>(rounds_)},
                                                    {"resamples", static_cast<double>(resamples_)}};
    if (gyro_.active && !bias_radps_.empty()) {
      // The particles' weighted mean bias.
      const sdk::ParticleSet& p = pf_.particles();
      double mean = 0.0, total = 0.0;
      for (std::size_t i = 0; i < p.size(); ++i)
        mean += p.weight[i] * bias_radps_[i], total += p.weight[i];
      out.emplace_back("heading_rate_bias_radps", total > 0.0 ? mean / total : 0.0);
    }
    return out;
  }

 private:
  void move(const sdk::OdometryStep& step) {
    if (gyro_.active) {
      move_by_gyro(step);
    } else {
      sdk::sample_wheel_motion(pf_.particles(), step.d_left_m, step.d_right_m, wheel_base_m_,
                               k_left_, k_right_, pf_.random(),
                               0.5 * wheel_base_m_ * std::abs(step.slip_rad));
    }
    sdk::add_side_slip(pf_.particles(), 0.5 * (step.d_left_m + step.d_right_m), side_slip_k_,
                       pf_.random());
  }

  /// An odometry that turns by a gyro: each particle moves by the wheels' distance with its own
  /// draw of their noise, (k_left^2 |dl| + k_right^2 |dr|) / 4, and by the gyro's turn a taken as
  /// (a - b_i dt) / (1 + s) with its own bias b_i and a draw of the turn's noise; b_i walks.
  void move_by_gyro(const sdk::OdometryStep& step) {
    sdk::ParticleSet& p = pf_.particles();
    sdk::Random& random = pf_.random();
    while (bias_radps_.size() < p.size())
      bias_radps_.push_back(gyro_.bias_radps + random.normal(gyro_.bias_sigma));
    // The rest of a step after advance_to() may span a negative time: its bias term keeps the
    // sign (the steps' turns add up), its noise does not.
    const double dt = std::max(step.dt_s, 0.0);
    const double distance_m = 0.5 * (step.d_left_m + step.d_right_m);
    const double turn_rad = (step.d_right_m - step.d_left_m) / wheel_base_m_;
    const double distance_sigma = 0.5 * std::sqrt(k_left_ * k_left_ * std::abs(step.d_left_m) +
                                                  k_right_ * k_right_ * std::abs(step.d_right_m));
    const double turn_sigma = gyro_.noise_density * std::sqrt(dt);
    const double walk = gyro_.bias_walk * std::sqrt(dt);
    const double half_base = 0.5 * wheel_base_m_;
    for (std::size_t i = 0; i < p.size(); ++i) {
      const double d = distance_m + random.normal(distance_sigma);
      const double a = (turn_rad - bias_radps_[i] * step.dt_s) / (1.0 + gyro_.scale_error) +
                       random.normal(turn_sigma);
      const sdk::Pose moved =
          sdk::diff_drive_motion(sdk::Pose(p.x[i], p.y[i], p.theta[i]), d - half_base * a,
                                 d + half_base * a, wheel_base_m_);
      p.x[i] = moved(0), p.y[i] = moved(1), p.theta[i] = moved(2);
      bias_radps_[i] += random.normal(walk);
    }
  }

  struct Range {
    Eigen::Vector2d receiver;  // robot frame [m]
    Eigen::Vector2d beacon;    // world [m]
    double dz_m, range_m;      // the range with its bias taken out
  };

  BeaconMcl(const locsim_init& init, const sdk::Params& params)
      : pf_(static_cast<std::size_t>(params.integer("particles")), init.seed,
            sdk::resampler_from(params.string("resampler"))),
        wheel_base_m_(init.robot != nullptr ? init.robot->wheel_base_m : 0.0),
        wheels_(wheel_base_m_),
        k_left_(params.number("k_left")),
        k_right_(params.number("k_right")),
        side_slip_k_(params.number("side_slip_k")),
        sigma_range_m_(params.number("sigma_range_m")),
        range_bias_m_(params.number("range_bias_m")),
        range_bias_per_m_(params.number("range_bias_per_m")),
        outlier_likelihood_(params.number("outlier_likelihood")),
        gyro_(sdk::GyroHeading::from(params)) {
    if (init.map == nullptr || init.map->beacon_count == 0)
      throw std::invalid_argument("needs beacons on the map");
    if (!(wheel_base_m_ > 0.0)) throw std::invalid_argument("needs the robot's wheel base");
    for (std::size_t i = 0; i < init.map->beacon_count; ++i) {
      const locsim_beacon& b = init.map->beacons[i];
      beacons_[b.id] = {Eigen::Vector2d(b.x, b.y), b.height_m};
    }
    wheels_.use_gyro(params.flag("use_gyro"));
    constexpr double kDeg = std::numbers::pi / 180.0;
    floor_.floor_position_m =
        std::hypot(params.number("motion_floor_m"), params.number("roughening_m"));
    floor_.floor_heading_rad =
        std::hypot(params.number("motion_floor_deg"), params.number("roughening_deg")) * kDeg;
    const sdk::FreeSpace free =
        init.map->grid.cells != nullptr ? sdk::FreeSpace(init.map->grid) : sdk::FreeSpace();
    pf_.initialise(init, free);
  }

  sdk::ParticleFilter pf_;
  double wheel_base_m_;
  sdk::OdometryTracker wheels_;
  double k_left_, k_right_, side_slip_k_, sigma_range_m_, range_bias_m_, range_bias_per_m_,
      outlier_likelihood_;
  sdk::GyroHeading gyro_;
  std::vector<double> bias_radps_;  // each particle's gyro bias (odometry_heading gyro)
  sdk::OdometryNoise floor_;        // only its floor_* are used
  std::map<int, std::pair<Eigen::Vector2d, double>> beacons_;  // id -> (position, height)
  std::vector<Range> ranges_;
  std::vector<double> log_likelihood_;
  double n_eff_ = 0.0;
  long rounds_ = 0, resamples_ = 0;
};

}  // namespace

LOCSIM_LOCALIZER(BeaconMcl, "beacon_mcl",
                 "Monte Carlo localization on ranges to beacons, moving by the wheels (UWB, "
                 "ultrasonic; no IMU needed)",
                 kParams)
