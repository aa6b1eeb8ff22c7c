// Monte Carlo localization on landmark detections (paper 004, SPEC section 2), with the recovery
// schemes that make the difference after a kidnapping: none (mcl), sensor resetting with a fixed
// threshold (srl, Lenser and Veloso), adaptive sensor resetting (asrl, the paper's eq. 1), and
// Thrun's w_slow/w_fast random injection (augmented_mcl, as nav2 AMCL has).
//
// One perception update (a camera frame with detections) is one "step": weight every particle by
// the detections, resample, then replace ns particles by poses drawn from the sensor
// distribution (srl, asrl) or uniformly (augmented_mcl).
#pragma once

#include <cmath>
#include <limits>
#include <locsim/localizer.hpp>
#include <locsim/particle_filter.hpp>
#include <locsim/particles.hpp>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

namespace locsim::particle_filters {

enum class Recovery { kNone, kSensorResetting, kAdaptiveSensorResetting, kAugmented };

/// Parameters every variant declares; each adds its recovery's. The detection noise defaults fit
/// locsim's PTZ camera at 160 x 120: range from the blob's height in rows, so one row is about
/// r^2 / (f h) of range and the measured error is 0.012 r^2 (docs/sensors.md); the default
/// 0.02 + 0.015 r^2 leaves a margin. Not the paper's unpublished deltas. The robustness
/// defaults (roughening, an outlier likelihood, resetting after three low steps and from two
/// detections) are for worlds nobody tuned the filter for: without them the particles collapse
/// and phantom detections decide the weights (docs/reports/suite: MCL 1.4 m -> 0.13 m in calm
/// generated rooms). The paper's settings: worlds/asrl/presets/paper004.yaml.
// clang-format off
#define LOCSIM_LANDMARK_PF_PARAMS                                                                  \
  {"particles", LOCSIM_PARAM_INT, 200, 1, 1000000, nullptr, "number of particles n [-]"},          \
  {"alpha1", LOCSIM_PARAM_DOUBLE, 0.0014, 0, 10, nullptr,                                          \
   "rotation noise from rotation (paper 004) [-]"},                                                \
  {"alpha2", LOCSIM_PARAM_DOUBLE, 0.000125, 0, 10, nullptr, "rotation noise from translation [rad/m]"}, \
  {"alpha3", LOCSIM_PARAM_DOUBLE, 0.01, 0, 10, nullptr, "translation noise from translation [-]"},  \
  {"alpha4", LOCSIM_PARAM_DOUBLE, 0.26, 0, 10, nullptr, "translation noise from rotation [m/rad]"}, \
  {"variance_form", LOCSIM_PARAM_BOOL, 0, 0, 1, nullptr,                                          \
   "Thrun's variance form of the motion noise"},                                                   \
  {"motion_model", LOCSIM_PARAM_STRING, 0, 0, 0, "odometry",                                       \
   "odometry: the paper's alpha1..alpha4 on the odometry's motion since the last step; wheels: "  \
   "each odometry reading's wheel travel with variance k^2 |d| per wheel (k_left, k_right), "     \
   "as ekf_landmarks predicts"},                                                                  \
  {"k_left", LOCSIM_PARAM_DOUBLE, 0.0013, 0.0, 1.0, nullptr,                                      \
   "motion_model wheels: left wheel random error [m^1/2]"},                                       \
  {"k_right", LOCSIM_PARAM_DOUBLE, 0.0012, 0.0, 1.0, nullptr,                                     \
   "motion_model wheels: right wheel random error [m^1/2]"},                                      \
  {"motion_floor_m", LOCSIM_PARAM_DOUBLE, 0.0, 0, 10, nullptr,                                     \
   "position noise of every step whatever its motion, per axis: the robot's (locsim calibrate) "  \
   "[m]"},                                                                                         \
  {"motion_floor_deg", LOCSIM_PARAM_DOUBLE, 0.0, 0, 180, nullptr,                                  \
   "heading noise of every step whatever its motion: the robot's (locsim calibrate) [deg]"},      \
  {"roughening_m", LOCSIM_PARAM_DOUBLE, 0.005, 0, 10, nullptr,                                     \
   "position noise added to every particle at every step beside the motion floor (the two add "   \
   "in quadrature), so that a finite set of particles does not collapse (Gordon's roughening; "   \
   "0: the paper) [m]"},                                                                           \
  {"roughening_deg", LOCSIM_PARAM_DOUBLE, 0.5, 0, 180, nullptr,                                    \
   "heading noise added likewise (0: the paper) [deg]"},                                          \
  {"regularization", LOCSIM_PARAM_DOUBLE, 0.0, 0, 10, nullptr,                                     \
   "after resampling, move each particle by a draw of the set's own covariance times (this h)^2, " \
   "h the optimal Gaussian kernel width for the particle count (the regularised particle filter; " \
   "locsim calibrate; 0: off) [-]"},                                                              \
  {"sigma_range_m", LOCSIM_PARAM_DOUBLE, 0.02, 1e-6, 100, nullptr,                                 \
   "range noise of a detection at zero range [m]"},                                                \
  {"sigma_range_per_m", LOCSIM_PARAM_DOUBLE, 0.0, 0, 10, nullptr,                                  \
   "growth of the range noise with the measured range [m/m]"},                                     \
  {"sigma_range_per_m2", LOCSIM_PARAM_DOUBLE, 0.015, 0, 10, nullptr,                               \
   "growth with the square of the range (a row of a pinhole image) [1/m]"},                        \
  {"sigma_bearing_deg", LOCSIM_PARAM_DOUBLE, 2.0, 1e-6, 180, nullptr,                              \
   "bearing noise of a detection [deg]"},                                                          \
  {"resampler", LOCSIM_PARAM_STRING, 0, 0, 0, "roulette",                                          \
   "roulette (as in the paper) or low_variance"},                                                  \
  LOCSIM_DETECTION_BIAS_PARAMS,                                                                    \
  LOCSIM_OMNI_NOISE_PARAMS,                                                                        \
  LOCSIM_COMMAND_RESPONSE_PARAMS,                                                                  \
  LOCSIM_GAIN_WANDER_PARAMS,                                                                       \
  LOCSIM_GYRO_PARAMS,                                                                              \
  {"use_ptz", LOCSIM_PARAM_BOOL, 1, 0, 1, nullptr, "use the PTZ camera's detections"},             \
  {"use_omni", LOCSIM_PARAM_BOOL, 1, 0, 1, nullptr,                                                \
   "use the omnidirectional camera's detections (a robot without one has none; 0: the paper)"},   \
  {"use_range_bearing", LOCSIM_PARAM_BOOL, 1, 0, 1, nullptr,                                      \
   "use the range-bearing sensor's detections"},                                                   \
  {"reject_inconsistent", LOCSIM_PARAM_BOOL, 1, 0, 1, nullptr,                                     \
   "in a frame with several detections, drop one that the particles explain on average below "    \
   "consistency_level while another is above it (a false detection, not a kidnapping)"},          \
  {"consistency_level", LOCSIM_PARAM_DOUBLE, 0.05, 0, 1, nullptr,                                  \
   "mean per-detection likelihood (1 = perfect match) under which a detection is inconsistent [-]"}, \
  {"outlier_likelihood", LOCSIM_PARAM_DOUBLE, 0.05, 0, 1, nullptr,                                \
   "added to every detection's likelihood (1 = perfect match): the chance that it is false, so "  \
   "that one far off cannot decide the weights (locsim calibrate); 0: every detection is true "    \
   "(the papers)"},                                                                                \
  {"impossible_likelihood", LOCSIM_PARAM_DOUBLE, 0.01, 1e-300, 1, nullptr,                        \
   "likelihood factor of a particle where the robot cannot be: in an obstacle or beyond the "     \
   "walls of the map's occupancy grid (1: the map's walls ignored, as the papers)"},              \
  {"reset_after_steps", LOCSIM_PARAM_INT, 3, 1, 1000, nullptr,                                     \
   "resetting starts when the likelihood has been low this many steps in a row (a phantom lasts " \
   "one; 1: the paper)"},                                                                          \
  {"reset_min_detections", LOCSIM_PARAM_INT, 2, 1, 1000, nullptr,                                  \
   "reset only in a step with at least this many detections (1: the paper; one detection puts "  \
   "the robot anywhere on a ring around its landmark)"},                                          \
  {"estimate", LOCSIM_PARAM_STRING, 0, 0, 0, "stable",                                             \
   "stable: the mode the filter reported (clusters of 0.5 m and 10 deg bins, as AMCL's) until "   \
   "another has outweighed it for switch_updates steps or holds switch_share of the weight, the "  \
   "covariance every particle's spread about it; mean: every particle's mean and covariance (the " \
   "paper), which lies between the places of a split set"},                                       \
  {"switch_updates", LOCSIM_PARAM_INT, 6, 1, 1000, nullptr,                                        \
   "estimate stable: steps in a row a rival mode must outweigh the reported one [-]"},            \
  {"switch_share", LOCSIM_PARAM_DOUBLE, 0.9, 0.5, 1, nullptr,                                      \
   "estimate stable: a rival mode with this share of the two's weight wins at once [-]"}
// clang-format on

class LandmarkParticleFilter : public sdk::Localizer {
 public:
  LandmarkParticleFilter(const locsim_init& init, Recovery recovery)
      : LandmarkParticleFilter(init, sdk::Params(init), recovery) {}

  void on_odometry(double t_s, const locsim_odometry& odometry) override;
  void on_imu(double t_s, const locsim_imu& imu) override {
    pf_.odometry().observe_imu(t_s, imu);
    if (wheels_) wheels_->observe_imu(t_s, imu);
  }
  void on_landmarks(double t_s, const locsim_landmarks& reading) override;
  sdk::Estimate estimate() const override;
  void particles(std::vector<locsim_pose2>& poses, std::vector<double>& weights) const override;
  std::vector<std::pair<std::string, double>> diagnostics() const override;

 private:
  struct Landmark {
    int id;
    std::string color;
    double x, y;
  };
  /// A detection of this step with what it may be: the landmarks with its id when the camera
  /// gives one, else those of its colour (none: a colour not on the map, it tells nothing).
  struct StepDetection {
    double range_m, bearing_rad, sigma_range_m, sigma_bearing_rad;
    std::vector<std::size_t> candidates;  // indices into landmarks_
  };
  LandmarkParticleFilter(const locsim_init& init, const sdk::Params& params, Recovery recovery);
  void prepare_step(double t_s, const locsim_landmarks& reading);
  /// log of the match of all this step's detections at one pose (sdk::landmark_log_match, 0 =
  /// perfect), each with its best-matching candidate.
  double log_likelihood(double x, double y, double theta) const;
  /// log(exp(log_match) + outlier_likelihood): a detection's match, false detections allowed.
  double with_outlier(double log_match) const;
  /// The same for every particle, into log_weights_ (vectorised, the step's inner loop). With
  /// reject_inconsistent, first drops the detections inconsistent with the others (step_ and
  /// step_count_ then hold the kept ones).
  void weigh_particles();
  /// A pose consistent with the detections (a ring around one landmark, weighted by the others).
  sdk::Pose sample_from_sensors();

  Recovery recovery_;
  sdk::ParticleFilter pf_;
  sdk::OdometryNoise noise_;
  sdk::DetectionNoise detection_noise_;  // by camera and range
  sdk::DetectionBias detection_bias_;    // taken out of each detection
  sdk::CorrelatedRangeBearing correlated_;
  sdk::CommandFollower response_;  // odometry that reports the command
  double regularization_ = 0.0;    // the regularised filter's kernel scale (0: off)
  sdk::GainWander wander_;         // each particle's gains wander
  sdk::ParticleGains gains_;
  bool use_ptz_, use_omni_, use_range_bearing_, reject_inconsistent_;
  double consistency_level_;
  double log_outlier_likelihood_;           // log of outlier_likelihood; -inf when 0
  double log_impossible_likelihood_ = 0.0;  // log of impossible_likelihood; 0: walls ignored
  long reset_after_steps_ = 1, low_steps_ = 0;
  std::size_t reset_min_detections_ = 1;
  // Recovery parameters.
  double srl_threshold_ = 0.0, asrl_mu_ = 1.0, asrl_pt_ = 1.0;
  sdk::LikelihoodAverages averages_;  // augmented_mcl
  double injection_level_ = 1.0;
  bool inject_uniform_ = true;  // augmented_mcl: uniform (Thrun) or from the detections
  std::vector<Landmark> landmarks_;
  sdk::FreeSpace free_;
  /// Odometry is applied once per step, just before weighting (the paper's steps 2 and 3): the
  /// alpha noise is per perception step, as in the paper, whatever the encoder rate. Between
  /// steps the estimate is the particles' mean moved by the odometry since (pf_.odometry()).
  void apply_pending_motion(double t_s);
  /// motion_model odometry with gain_wander_*: each particle's gains move on by dt_s, then scale
  /// its share of the motion since the last step (the distance by 1 + g_v, the turns by
  /// 1 + g_omega) before the paper's noise.
  void sample_motion_with_gains(const sdk::OdometryDelta& d, double dt_s);
  double last_step_s_ = std::numeric_limits<double>::quiet_NaN();
  // motion_model wheels: the particles move at every odometry reading.
  bool wheel_motion_ = false;
  double k_left_ = 0.0, k_right_ = 0.0, wheel_base_m_ = 0.0;
  std::optional<sdk::OdometryTracker> wheels_;
  double last_odometry_s_ = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> log_likelihood_, candidate_match_, mixture_;
  std::vector<std::vector<double>> detection_match_;  // per detection of the step, per particle
  sdk::Headings headings_;
  std::vector<StepDetection> step_;  // capacity reused from step to step
  std::size_t step_count_ = 0;       // detections in step_ this step
  /// The last `injected_` particles were injected after the last weighting: hypotheses for the
  /// next step, not yet evidence, so the estimate leaves them out (the paper's order: the
  /// estimate is taken after resampling, step 4, before resetting, step 5).
  std::size_t injected_ = 0;
  // estimate stable: the mode reported, updated at each step (stable_ready_ once updated).
  bool estimate_stable_ = true, stable_ready_ = false;
  sdk::PoseBins cluster_bins_{0.5, 10.0 * std::numbers::pi / 180.0};
  sdk::StableMode stable_;
  sdk::Pose odometry_at_stable_ = sdk::Pose::Zero();  // the odometry's pose at that update
  /// The stable mode's mean moved by the odometry since its update.
  sdk::Pose stable_moved() const;
  // Diagnostics of the last step.
  double n_eff_ = 0.0, mean_likelihood_ = 0.0, resets_ = 0.0, rejected_ = 0.0;
  long steps_ = 0;
};

}  // namespace locsim::particle_filters
