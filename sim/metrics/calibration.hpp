// Noise calibration from logs with ground truth (`locsim calibrate`): how far the odometry and
// the landmark detections a localizer is given stray from what the true path implies, fitted to
// the noise models locsim's localizers and simulated sensors use, so that a filter can run on a
// dataset (or a world) with noise measured rather than guessed. docs/real_data.md.
//
// Every quantity is measured on what a plugin sees (the host's translation of the readings,
// sim/plugin_host ReadingTranslator) over the intervals a filter uses it:
// - motion: between consecutive perception steps (readings with a detection of a landmark on the
//   map: a landmark particle filter applies odometry once per such step), the odometry's
//   increment against the true one. Fitted by maximum likelihood to the odometry model's
//   alpha1..alpha4 (the SDK's motion_spread, in both its standard-deviation and variance forms,
//   through the end pose's covariance so that a short step's ill-defined direction does not
//   matter) and to the wheel model's k_left, k_right (the SDK's predict_by_wheels over each of the
//   interval's odometry readings, as ekf_landmarks predicts); with velocity readings, the velocity
//   model's alpha1..alpha4 (Thrun's table 5.3: variance of v from v^2 and omega^2, of omega from
//   v^2 and omega^2) over the same intervals.
// - detections: each one's range and bearing against those of its landmark (its id, else the
//   nearest of its colour) from the true pose. Detections farther than `outlier_sigmas` robust
//   standard deviations (MAD, per range bin) are false; the rest give the bias and spread as lines
//   in range (for a range-bearing sensor also in depth, the true range times the cosine of the true
//   bearing, and the model that explains the ranges better is chosen); missed: landmarks in a
//   range-bearing sensor's field of view and range, not hidden by walls, that no inlier reported.
// - ranges to beacons (the world's `ultrasonic` sensor: UWB, ultrasonic): each range against the
//   true slant range from its receiver. Ranges farther than `outlier_sigmas` robust standard
//   deviations from the bias line are outliers (echoes); the rest give the bias line (an antenna's
//   delay, a clock's rate) and the spread. A log without landmark detections (range-only data)
//   takes its perception steps, for the motion, at the readings with ranges.
#pragma once

#include <array>
#include <cstddef>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace locsim {

struct WorldDef;
struct RangeBearingDef;
struct Pose2;
class StaticRaycaster;

/// A landmark a range-bearing sensor has in view.
struct LandmarkInView {
  std::size_t index = 0;  // into world.landmarks
  double range_m = 0.0;   // from the sensor
};

/// The landmarks a range-bearing sensor on a robot at `pose` would report if it missed none: in
/// its range and field of view, not behind a wall. Other robots and moving obstacles, which also
/// hide landmarks, are not in a log's world and are ignored.
std::vector<LandmarkInView> landmarks_in_view(const WorldDef& world, const StaticRaycaster& walls,
                                              const RangeBearingDef& sensor, const Pose2& pose);

struct CalibrationOptions {
  std::vector<std::string> robots;  // names of the robots to use; empty: all
  double outlier_sigmas = 5.0;      // gate of a false detection, in robust sigmas [-]
  static constexpr double kMinOutlierSigmas = 2.0, kMaxOutlierSigmas = 100.0;
  std::size_t range_bins = 8;  // at most this many bins of equal counts in range [-]
  static constexpr std::size_t kMaxRangeBins = 100;
};

/// y = at_zero + per_unit * x.
struct LineFit {
  double at_zero = 0.0;
  double per_unit = 0.0;
  double at(double x) const { return at_zero + per_unit * x; }
};

struct RangeBin {
  std::size_t count = 0;
  double range_m = 0.0;             // mean true range of the bin [m]
  double range_error_mean_m = 0.0;  // measured - true [m]
  double range_error_std_m = 0.0;   // about the fitted bias line [m]
  double range_error_rms_m = 0.0;   // about zero [m]
  double bearing_error_mean_rad = 0.0;
  double bearing_error_std_rad = 0.0;
};

/// The averaging rates augmented_mcl's injection_level is measured with (its defaults, Thrun's
/// and nav2's recommended values); written beside the level, which holds only with them.
inline constexpr double kAugmentedAlphaSlow = 0.001, kAugmentedAlphaFast = 0.1;

/// A range model of the range_bearing sensor (its `range_model`) fitted to the inliers: the
/// measured range against x, the true distance r (distance) or the true depth r cos(bearing)
/// (depth, the bearing from the robot's x axis), as the simulated sensor takes them.
struct RangeModelFit {
  LineFit bias_m;               // measured range - x against x (range_bias_m, range_bias_per_m)
  LineFit spread_m;             // standard deviation about the bias line against x (sigma_range_*)
  double residual_rms_m = 0.0;  // about the bias line
};

/// A robot's camera where its detections say it is: its offset from the mount they are given
/// from (the sensor's believed mount; docs/sensors.md), fitted to the bearings. A camera off its
/// believed place sees each landmark from there, an error that changes with the landmark's
/// bearing and range, which neither a range nor a bearing bias takes out.
struct CameraOffset {
  std::string robot;
  double x_m = 0.0, y_m = 0.0;        // forward and left of the believed mount [m]
  double sd_x_m = 0.0, sd_y_m = 0.0;  // block jackknife, blocks of kBlock_s of one robot's log
  double correlation = 0.0;           // of the two estimates [-]
  double bearing_bias_rad = 0.0;      // the robot's own, fitted with them [rad]
  std::size_t detections = 0, blocks = 0;
  double wald = 0.0;  // offset' covariance^-1 offset: chi-square with 2 degrees of freedom [-]
  // Beyond kWald with at least kMinBlocks blocks: the sensor's noise is measured from there and
  // the twin mounts that robot's camera there.
  bool significant = false;
  static constexpr double kBlock_s = 60.0;  // the bearings' errors persist for tens of seconds
  static constexpr std::size_t kMinBlocks = 8;
  static constexpr double kWald = 13.82;  // chi-square(2) at 0.999
};

/// A range-bearing sensor's bearing noise measured from where each camera is (its significant
/// offset taken out): the sensor settings calibrate writes for a twin whose cameras sit there.
/// The ranges are a camera's own calibration's, from its believed place, and keep their fit.
struct CameraPlaceNoise {
  double bearing_bias_rad = 0.0, bearing_spread_rad = 0.0;
};

/// A range-bearing camera's spells of blindness: each robot's true path in cells of
/// kFramesPerCell of its camera's frames (the median interval between its readings with a
/// detection), each with the landmarks in view and whether any was detected, explained by a
/// camera that is either seeing (each landmark in view detected at `rate_hz` on average, as a
/// Poisson process: exactly a fixed-rate camera's independent misses) or silent (the sensor's
/// outage_fraction, outage_mean_s: a two-state Markov process), by maximum likelihood (the forward
/// algorithm of the two-state hidden Markov model). A real camera goes blind for a minute with
/// landmarks in view (MRCLAM robot 4, 75 s), which independent misses at the same average never
/// do.
struct CameraSilences {
  static constexpr double kFramesPerCell = 4.0;
  std::size_t cells = 0;  // with a landmark in view [-]
  double cell_s = 0.0;    // the cells' mean length [s]
  double rate_hz = 0.0;   // per landmark in view while seeing [1/s]
  double fraction = 0.0, mean_s = 0.0;
  double long_share = 0.0, long_mean_s = 0.0;  // two kinds of spell: 0 when one explains them
  double gain_nats = 0.0;                      // log-likelihood over a camera that is never silent
  bool significant = false;     // by the Bayesian information criterion (two more parameters)
  double long_gain_nats = 0.0;  // two kinds over one (kept by the same criterion)
};

/// One camera kind's detections (range_bearing, ptz_camera, omni_camera).
struct DetectionCalibration {
  std::string camera;
  std::size_t readings = 0;    // readings of this camera with a true pose
  std::size_t detections = 0;  // of landmarks (detections of robots are not used)
  std::size_t inliers = 0;
  std::size_t false_detections = 0;  // outliers, and ids or colours not on the map
  double false_per_reading = 0.0;    // Poisson mean, as the simulated sensor takes it [-]
  LineFit range_bias_m;              // measured - true range against true range
  LineFit range_spread_m;            // standard deviation about the bias line
  LineFit range_rms_m;               // about zero: the noise a filter that ignores bias must allow
  double bearing_bias_rad = 0.0, bearing_spread_rad = 0.0, bearing_rms_rad = 0.0;
  // range_bearing only: both range models (the distance one's lines are range_bias_m and
  // range_spread_m) and the one chosen, "distance" or "depth"; the sensor settings, and the noise
  // correlation, are the chosen model's.
  std::optional<RangeModelFit> distance_model, depth_model;
  std::string range_model = "distance";
  std::vector<RangeBin> bins;
  // A range_bearing sensor's field of view decides what it should have seen.
  std::optional<std::size_t> visible, missed;
  std::optional<double> miss_probability;
  // How the chance of detecting a landmark in view falls with its range r, p(r) = (1 -
  // miss_probability_at_zero) e^(-r / decay_m), when that explains the detections better than a
  // constant chance by more than the Bayesian information criterion asks for (the sensor's
  // detection_decay_m). Fitted over every reading and landmark in view; for a log whose camera
  // reports only readings with a detection (MRCLAM's), conditioned on at least one.
  struct DetectionDecay {
    double miss_probability_at_zero = 0.0;
    double decay_m = 0.0;
    double gain_nats = 0.0;  // over a constant chance
    bool conditioned = false;
  };
  std::optional<DetectionDecay> detection_decay;
  // The likelihood a landmark particle filter (with the noise written for it) that tracks the
  // robot gives each step, its belief spread about the true pose as the localizers' motion noise
  // and the detections make it: its median, and the resetting levels at its `reset_quantile`
  // (srl's `threshold`, asrl's `p_t` with mu 1, augmented_mcl's `injection_level`: the ratio
  // w_fast / w_slow of its per-detection likelihood with kAugmentedAlpha*, both averages started
  // at the robot's mean). Unset with fewer than 10 steps.
  std::optional<double> reset_quantile, step_likelihood_median, srl_threshold, asrl_p_t,
      augmented_injection_level;
  // The landmark particle filters' outlier_likelihood (false detections over the measured span);
  // unset without false detections.
  std::optional<double> outlier_likelihood;
  // Time constant of each landmark's noise (the sensor's noise_correlation_s; 0: independent),
  // from this many pairs of consecutive detections of a landmark by a robot.
  std::optional<double> noise_correlation_s;
  std::size_t noise_correlation_pairs = 0;
  // Two time constants, when they explain the pairs significantly better than one (correlation
  // w e^(-dt / slow_s) + (1 - w) e^(-dt / fast_s)): what the localizers take (their
  // noise_correlation_s, _slow_s, _slow_share). The sensor's single one stays above.
  struct TwoCorrelations {
    double fast_s = 0.0, slow_s = 0.0, slow_share = 0.0;
    double gain_nats = 0.0;  // log-likelihood over the single time constant's
  };
  std::optional<TwoCorrelations> noise_correlation_two;
  // The range's and the bearing's each their own (one time constant: slow_share 0), when that
  // explains the pairs better than the joint fit above (Bayesian information criterion): the
  // sensor's noise_correlation_* and bearing_noise_correlation_*, the localizers' likewise.
  struct ChannelCorrelations {
    TwoCorrelations range, bearing;
    double gain_nats = 0.0;  // log-likelihood over the joint fit's
  };
  std::optional<ChannelCorrelations> channel_correlations;
  // range_bearing only: each robot's camera offset (robots with too few detections left out),
  // and, when any is significant, the bearings' noise from the cameras' places. The fields above
  // are the noise from the believed places, which the localizers (that do not know the robots'
  // offsets) take.
  std::vector<CameraOffset> camera_offsets;
  std::optional<CameraPlaceNoise> from_camera_places;
  // range_bearing only, with a field of view to say what was in view: its spells of blindness.
  std::optional<CameraSilences> silences;
};

/// Spells of silence in a sensor's readings (its outage_fraction, outage_mean_s): an interval
/// between two of a robot's readings longer than kPeriods times the median interval holds one,
/// as long as the interval less that median; the mean length and share of the time are those
/// of the simulator's exponential spells that leave such gaps (shorter ones pass for dropped
/// readings). None with fewer than kMinOutages.
struct OutageFit {
  static constexpr double kPeriods = 4.0;
  static constexpr std::size_t kMinOutages = 3;
  std::size_t outages = 0;
  double fraction = 0.0;           // of the robots' time [-]
  double mean_s = 0.0;             // [s]
  double median_interval_s = 0.0;  // between readings, pooled over the robots [s]
};
/// From each robot's reading times (never decreasing).
OutageFit fit_outages(const std::vector<std::vector<double>>& reading_times_s);

/// A ranging sensor's ranges (the world's `ultrasonic`).
struct RangingCalibration {
  std::size_t readings = 0;         // with a true pose
  std::size_t ranges = 0;           // finite ones, to beacons on the map
  std::size_t beacons = 0;          // on the map
  double ranges_per_reading = 0.0;  // per receiver, mean [-]
  std::size_t inliers = 0;
  std::size_t long_outliers = 0, short_outliers = 0;  // beyond the gate, either way
  double outlier_share = 0.0;                         // of the ranges [-]
  LineFit bias_m;                                     // measured - true against the true range
  double spread_m = 0.0;  // standard deviation of the inliers about the bias line [m]
  double rms_m = 0.0;     // of the inliers about zero: what a filter ignoring the bias allows [m]
  // The long outliers' excess over the bias line: the simulated sensor's non-line-of-sight
  // extra path (minimum + exponential with this mean). Unset with fewer than 5.
  std::optional<double> excess_min_m, excess_mean_m;
  struct Beacon {
    int id = 0;
    std::size_t inliers = 0;
    double mean_residual_m = 0.0, spread_m = 0.0;  // about the common bias line [m]
  };
  std::vector<Beacon> by_beacon;  // a beacon of its own bias shows as a mean residual
  struct Bin {
    std::size_t count = 0;
    double range_m = 0.0, mean_residual_m = 0.0, spread_m = 0.0;
  };
  std::vector<Bin> bins;  // by true range, equal counts: whether the spread grows with range
  // Time constant of a beacon's errors between consecutive ranges to it (0: independent), from
  // this many pairs.
  std::optional<double> noise_correlation_s;
  std::size_t noise_correlation_pairs = 0;
  OutageFit outages;  // the readings' spells of silence
};

/// The laser's beam model (the simulated sensor's mixture, Thrun et al., Probabilistic Robotics
/// 6.3: a hit with Gaussian noise, a short reading from something unmapped, a reading at the
/// maximum range, a uniform one), fitted by maximum likelihood (EM) to scans against the ranges
/// the map gives at the true pose. A map's own errors count as the sensor's.
struct LaserCalibration {
  std::size_t scans = 0;         // with a true pose
  std::size_t beams = 0;         // used: at most kMaxBeamsPerScan of a scan, evenly spread
  std::size_t beams_mapped = 0;  // of them, with a mapped obstacle within the maximum range
  double max_range_m = 0.0;
  double sigma_m = 0.0, p_short = 0.0, lambda_short = 0.0, p_max = 0.0, p_random = 0.0;
  double hit_bias_m = 0.0;      // mean measured - mapped range of the hits (the fit takes 0) [m]
  double log_likelihood = 0.0;  // per beam [nats]
  int iterations = 0;           // of EM
  static constexpr std::size_t kMaxBeamsPerScan = 90;
};

struct OdometryModelFit {
  double alpha1 = 0.0, alpha2 = 0.0, alpha3 = 0.0, alpha4 = 0.0;
  // The error of an interval that no motion explains (fitted beside the alphas; no localizer
  // models it): standard deviations [m], [rad].
  double floor_position_m = 0.0, floor_heading_rad = 0.0;
  double log_likelihood = 0.0;  // per interval [nats]
};

/// The wheel model with its two wheels' errors correlated (the simulated encoders'
/// k_correlation): what a twin's encoders take when the correlation explains the intervals
/// better than independent wheels. The localizers keep the independent fit.
struct CorrelatedWheels {
  double k_left = 0.0, k_right = 0.0;  // [m^1/2]
  double k_correlation = 0.0;          // [-]
  double gain_nats = 0.0;              // log-likelihood over independent wheels'
};

/// The wheel model (paper 002's k per wheel, with a floor per interval whatever the motion).
struct WheelModelFit {
  double k_left = 0.0, k_right = 0.0;                      // [m^1/2]
  double floor_position_m = 0.0, floor_heading_rad = 0.0;  // per interval
  double mean_nees = 0.0;                                  // 3 when it fits the errors
};

/// How the robots' motion follows what their odometry reports, when it reports a velocity that
/// leads the motion (a base that logs its command: the robot's CommandResponseDef), fitted to the
/// truth's velocity on a 20 ms grid: a dead time shared by both channels, a first-order time
/// constant and a gain per channel (grid over the dead time and time constants, the gain by least
/// squares). Kept when the lag explains the truth better than any gain alone does.
struct CommandResponseFit {
  double dead_time_s = 0.0;
  double time_constant_v_s = 0.0, time_constant_omega_s = 0.0;
  double gain_v = 1.0, gain_omega = 1.0;
  double seconds = 0.0;  // of odometry with a true velocity [s]
  // The truth's velocity's residual variance about the model, over its variance about the
  // reported velocity as it is (gain 1, no lag) and about the best gain without a lag. [-]
  double residual_v = 0.0, residual_omega = 0.0;
  double residual_gain_only_v = 0.0, residual_gain_only_omega = 0.0;
  bool leads = false;  // the lag explains enough more than a gain: the response is written
  // The wheel model's noise of the odometry passed through the response (what the motion does
  // beyond it): the noise a simulated base that measures its command adds. [m^1/2]
  std::optional<double> k_left, k_right;
  // The same with the wheels' errors correlated, when that explains them better (the twin's).
  std::optional<CorrelatedWheels> correlated_wheels;
  // The wheel model of the odometry run through the whole response (sdk::CommandFollower): the
  // noise a localizer that follows the response (command_*) is left with.
  std::optional<WheelModelFit> localizer;
  // The same k fitted over spans of several perception steps: constant for white noise, growing
  // when the errors are correlated from step to step.
  struct Span {
    std::size_t steps = 0;
    double mean_interval_s = 0.0, k_left = 0.0, k_right = 0.0;
  };
  std::vector<Span> localizer_by_span;
  // How the base's gain wanders about the response (the true distance or turn over the
  // response's, less 1, over windows of 2, 5, 10 and 20 s), as a first-order Gauss-Markov process
  // whose window means have variance sigma^2 f(W / tau), f(x) = 2 (x - 1 + e^-x) / x^2, beside
  // noise independent from step to step (c W / M^2 for a window that moved M): the localizers'
  // gain_wander_*. One tau for both channels; sigma 0: no wander found (fit_gain_wander).
  struct GainWander {
    double sigma = 0.0;                // relative [-]
    double correlation_s = 0.0;        // tau [s]
    double log_likelihood_gain = 0.0;  // [nats] over step-to-step noise alone, both channels
    struct Window {
      double window_s = 0.0, sd = 0.0;
      std::size_t count = 0;
    };
    std::vector<Window> windows;
  };
  std::optional<GainWander> gain_wander_v, gain_wander_omega;
};

/// How the body slid off its heading (the robot's SideSlipDef), from the truth alone: over
/// windows of 1, 2, 4 and 8 s of each unbroken truth track, the displacement across the heading
/// D (each truth step's, across its mid heading) against the travel along it S, and the turn's
/// sum of v omega dt C. D has mean tan(crab) S - c C and variance k^2 M g(W / tau) + 2 sigma_p^2,
/// M the distance travelled, g(x) = (x - 1 + e^-x) / x (the wander's drift, 1 for W >> tau),
/// sigma_p the truth's own position noise. Maximum likelihood (the mean by weighted least squares
/// inside Nelder-Mead over k^2, tau, sigma_p^2), windows beyond 5 sigma (a GPS fix re-acquired)
/// dropped once; each part kept when it gains more than BIC's half log(windows) per parameter.
struct SideSlipFit {
  double crab_angle_rad = 0.0;          // 0 when not kept
  double cornering_compliance_s = 0.0;  // 0 when not kept
  double wander_k = 0.0;                // [m^1/2]; 0 when not kept
  double wander_correlation_s = 1.0;    // [s]
  double truth_noise_m = 0.0;           // sigma_p [m]
  std::size_t windows = 0, dropped = 0;
  double distance_m = 0.0;  // travelled over the 1 s windows
  // What each part gains over the fit without it [nats].
  double crab_gain = 0.0, cornering_gain = 0.0, wander_gain = 0.0;
  bool any() const {
    return crab_angle_rad != 0.0 || cornering_compliance_s != 0.0 || wander_k > 0.0;
  }
};

struct MotionCalibration {
  std::size_t intervals = 0;           // perception-step intervals used
  double mean_interval_s = 0.0;        // their mean length
  double mean_travel_m = 0.0;          // and the odometry's mean travel over one
  OdometryModelFit odometry_std;       // standard-deviation form (variance_form false)
  OdometryModelFit odometry_variance;  // Thrun's variance form
  bool variance_form = false;          // the form with the higher likelihood
  double k_left = 0.0, k_right = 0.0;  // wheel model [m^1/2]
  double k_floor_position_m = 0.0, k_floor_heading_rad = 0.0;  // as OdometryModelFit's
  // The wheel model with the wheels' errors correlated, when that explains them better (the
  // twin's encoders; the localizers take k_left, k_right above).
  std::optional<CorrelatedWheels> correlated_wheels;
  double k_log_likelihood = 0.0;  // per interval [nats]
  /// The fitted wheel model's normalised estimation error squared, mean over the intervals
  /// (3 when the model's covariance matches the errors).
  double k_mean_nees = 0.0;
  std::optional<OdometryModelFit> velocity;  // only from velocity readings
  std::size_t velocity_intervals = 0;
  /// Where the odometry's heading comes from (the encoders' `heading`), told apart by which model
  /// explains the intervals' heading errors better: the wheels' (variance with each wheel's
  /// travel, k_left^2 |d_left| + k_right^2 |d_right| over b^2, and a wheel-base error of each
  /// robot's, an error in proportion to the turn) or a gyro's (a bias of each robot's times the
  /// interval, and a random walk, q^2 dt; its scale error, in proportion to the turn, fitted once
  /// it is told). Both with a floor (the truth's own heading noise).
  struct HeadingFit {
    bool gyro = false;
    double wheels_log_likelihood = 0.0, gyro_log_likelihood = 0.0;  // per interval [nats]
    double bias_radps = 0.0, bias_sigma = 0.0;  // mean and spread of the robots' biases
    std::vector<double> bias_by_track_radps;
    double bias_walk = 0.0;      // its random walk within a recording [rad/s per root second]
    double scale_error = 0.0;    // the gyro turns (1 + scale_error) times the body; 0: wheels [-]
    double noise_density = 0.0;  // q [rad/s/sqrt(Hz)]
    double floor_rad = 0.0;      // the gyro model's
    // The wheels' k from the intervals' distances alone, one for both wheels (a gyro base's: its
    // wheels only measure the distance) [m^1/2]; and that fit's floor [m].
    double distance_k = 0.0, distance_floor_m = 0.0;
  };
  std::optional<HeadingFit> heading;  // unset with fewer than 10 intervals or under a command
  std::optional<CommandResponseFit> command;  // only from velocity readings
  std::optional<SideSlipFit> side_slip;       // unset with fewer than 20 windows
};

struct Calibration {
  std::vector<std::string> sources;  // "LOG (robot, robot)"
  std::optional<MotionCalibration> motion;
  std::vector<DetectionCalibration> cameras;  // those with landmark detections
  std::optional<RangingCalibration> ranging;  // with ranges to beacons on the map
  std::optional<LaserCalibration> laser;      // with scans in a world with walls or a map
  /// Everything, with the bins for plots (calibration.json).
  nlohmann::ordered_json to_json() const;
  /// The parameter file for localizers (`localizer_params:`, for --params) and the sensor
  /// settings for a world (`sensors:`), with a header saying what was measured on what.
  std::string to_yaml() const;
};

/// The beacon filters: calibrate writes the ranges' noise in their own sections of the parameter
/// file (the landmark filters' keys of the same names are the camera's).
inline constexpr std::array<std::string_view, 3> kBeaconFilters{"ultrasonic_ekf", "ultrasonic_amcl",
                                                                "beacon_mcl"};

/// The group of a localizer parameter `locsim calibrate` writes ("wheel noise", "detection
/// bias", ...: what one measurement decides together), by key, a plugin section's too (the
/// ranges' bias and spread in a beacon filter's: "ranging bias", "ranging spread"); empty for
/// a key calibrate does not write. Checks of a calibration swap parameters a group at a time.
std::string_view parameter_group(std::string_view key, std::string_view plugin = {});

/// Reads every log (each with its own world) and fits the noise over the chosen robots together.
/// Throws InputError for unreadable logs, unknown robot names, or logs without ground truth, and
/// when nothing could be measured.
Calibration calibrate(const std::vector<std::filesystem::path>& logs,
                      const CalibrationOptions& options);

/// A few lines for the command line: what was measured, and the main numbers.
std::string describe(const Calibration& calibration);

}  // namespace locsim
