// What each synthetic sensor is: rate, mounting, and its noise model, with defaults that
// reproduce the papers' set-ups (../shared/SPEC.md). Beside every number its unit and the range
// the loader holds it to (sim/common/range.hpp).
// Angles in the robot frame are counter-clockwise positive (x forward, y left).
#pragma once

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "sim/common/math.hpp"
#include "sim/common/range.hpp"
#include "sim/sensors/readings.hpp"

namespace locsim {

/// Shared by every sensor.
struct SensorCommon {
  bool enabled = true;
  double rate_hz = 10.0;  // must divide the physics rate [Hz]
  static constexpr Range kRateRange = kSampleRateRange;
  Pose2 mount;  // pose of the sensor frame in the robot frame: kBodyFrameRange, any heading
  // Where the robot's software believes the sensor is (default: where it is). Readings given in
  // the robot frame are converted from the sensor frame with this pose, and the mount a reading
  // reports is this one, so a sensor mounted off its believed place errs as a real one whose
  // mounting was never measured does: MRCLAM robot 4's camera sits 8.5 cm ahead of where its
  // detections are taken from (docs/reports/sim_to_real/measurements.md).
  std::optional<Pose2> believed_mount{};
  const Pose2& reported_mount() const { return believed_mount ? *believed_mount : mount; }
  // Spells of silence: a radio out of its anchors' reach or behind a building, a driver that
  // restarts, a bus that drops frames for seconds. The sensor is silent this share of the time
  // on average, in spells of outage_mean_s on average, with the times in and between spells
  // exponentially distributed (a two-state Markov process), drawn from the sensor's own stream
  // ("sensor/ROBOT/KIND/outage"): its readings' noise is the same with outages as without. A
  // spell of silence is not a dropped reading (the ultrasonic's dropout_probability): a filter
  // must coast through it. 0: never silent.
  double outage_fraction = 0.0;  // [-]
  static constexpr Range kOutageFractionRange{0.0, 0.99, ""};
  double outage_mean_s = 5.0;  // [s]
  static constexpr Range kOutageMeanRange{1e-3, 1e6, "s"};
  // Spells of two kinds: this share of them last outage_long_mean_s on average, the rest
  // outage_mean_s (outage_fraction stays the share of the time silent). A real camera is blind
  // for seconds now and then and, rarely, for a minute (MRCLAM robot 4: 75 s with landmarks in
  // view), which one kind of spell with the same share never gives. 0: one kind.
  double outage_long_share = 0.0;  // [-]
  static constexpr Range kOutageLongShareRange{0.0, 0.99, ""};
  double outage_long_mean_s = 60.0;  // [s], kOutageMeanRange
  /// The mean length of a spell, of either kind [s].
  double outage_spell_mean_s() const {
    return (1.0 - outage_long_share) * outage_mean_s + outage_long_share * outage_long_mean_s;
  }
};

/// Quadrature wheel encoders, and the odometry pose a base integrates from them.
struct EncodersDef {
  SensorCommon common{true, 50.0, {}};
  int ticks_per_rev = 4096;  // counts per wheel revolution (after quadrature) [-]
  static constexpr Range kTicksRange{1.0, 16777216.0, ""};
  // Paper 002's non-systematic error: after a wheel rolls d metres its count has drifted by a
  // random walk of variance K^2 |d| (UMBmark values of the paper). [m^1/2]
  double k_left = 0.0013;
  double k_right = 0.0012;
  static constexpr Range kKRange{0.0, 1.0, "m^1/2"};
  // Correlation of the two wheels' errors over a step: a common-mode part (both counts long or
  // short together: tyre compression, a soft floor, a base whose reported motion is its command)
  // moves the robot along its heading without turning it. The distance's variance goes as
  // (1 + rho), the turn's as (1 - rho), for equal k. 0: independent wheels (paper 002). [-]
  double k_correlation = 0.0;
  static constexpr Range kKCorrelationRange{-0.99, 0.99, ""};
  std::optional<double> odometry_wheel_base_m;  // the base's belief; default: the true one [m]
  static constexpr Range kWheelBaseRange{0.01, 100.0, "m"};
  // What each reading carries (OdometryField bits; YAML: a list of ticks, pose, velocity). A
  // simulated base reports its wheels' mean velocity over the last sample period as measured.
  std::uint8_t reports = kOdometryTicks | kOdometryPose;
  // What is counted: the wheels' rotation, or the body-velocity command the base was given (as
  // bases that log their command rather than their encoders do, MRCLAM's among them), turned
  // into the nominal wheels' rotation it asks for. The robot's command_response then decides how
  // far the motion lags and falls short of it; the K error above is added to it either way.
  enum class Measures { kWheels, kCommand };
  Measures measures = Measures::kWheels;
  // Where the reported pose's heading (and turn rate) comes from: the wheels' difference, or a
  // gyro the base fuses, as many bases do (a Roomba's, a Husky's, CMU's Plaza robot's): the
  // body's true turn plus the gyro's bias and white noise, so that the heading drifts with time,
  // not with the turns. Ticks count the wheels either way; the distance is the wheels'.
  enum class Heading { kWheels, kGyro };
  Heading heading = Heading::kWheels;
  double gyro_bias_radps = 0.0;  // the base gyro's bias, constant over a run [rad/s]
  static constexpr Range kGyroBiasRange{-10.0, 10.0, "rad/s"};
  double gyro_bias_sigma = 0.0;  // spread of a draw per run about gyro_bias_radps [rad/s]
  static constexpr Range kGyroBiasSigmaRange{0.0, 10.0, "rad/s"};
  double gyro_noise_density = 1.7e-4;  // white noise, as the IMU's default [rad/s/sqrt(Hz)]
  static constexpr Range kGyroNoiseRange{0.0, 10.0, "rad/s/sqrt(Hz)"};
  // The gyro's scale factor error: it reports (1 + s) times the body's turn [-].
  double gyro_scale_error = 0.0;
  static constexpr Range kGyroScaleRange{-0.5, 0.5, ""};
};

/// Planar IMU: yaw rate and body-frame accelerations at the mount point.
struct ImuDef {
  SensorCommon common{true, 100.0, {}};
  double gyro_noise_density = 1.7e-4;  // white noise [rad/s/sqrt(Hz)]
  static constexpr Range kGyroNoiseRange{0.0, 10.0, "rad/s/sqrt(Hz)"};
  double gyro_bias_sigma = 1e-3;  // spread of the initial bias [rad/s]
  static constexpr Range kGyroBiasRange{0.0, 10.0, "rad/s"};
  double gyro_bias_random_walk = 2e-5;  // bias drift [rad/s^2/sqrt(Hz)]
  static constexpr Range kGyroWalkRange{0.0, 10.0, "rad/s^2/sqrt(Hz)"};
  double gyro_range = 8.7;  // saturation, +-500 deg/s [rad/s]
  static constexpr Range kGyroRangeRange{0.01, 1000.0, "rad/s"};
  double accel_noise_density = 2e-3;  // [m/s^2/sqrt(Hz)]
  static constexpr Range kAccelNoiseRange{0.0, 100.0, "m/s^2/sqrt(Hz)"};
  double accel_bias_sigma = 0.02;  // [m/s^2]
  static constexpr Range kAccelBiasRange{0.0, 100.0, "m/s^2"};
  double accel_bias_random_walk = 3e-4;  // [m/s^3/sqrt(Hz)]
  static constexpr Range kAccelWalkRange{0.0, 100.0, "m/s^3/sqrt(Hz)"};
  double accel_range = 39.24;  // saturation, +-4 g [m/s^2]
  static constexpr Range kAccelRangeRange{0.01, 10000.0, "m/s^2"};
};

/// Pan-tilt-zoom colour camera that detects landmarks (paper 004: Sony EVI-D100P, 160 x 120).
struct PtzCameraDef {
  SensorCommon common{true, 10.0, {}};
  double height_m = 0.4;  // optical centre above the floor, kHeightRange [m]
  // Image size; a rendered camera's image (4 bytes a pixel, several copies) counts in the world's
  // memory budget. [px]
  int width_px = 160;
  int height_px = 120;
  static constexpr Range kImageSizeRange{8.0, 8192.0, "px"};
  double hfov_rad = deg_to_rad(65.0);  // horizontal field of view at zoom 1 [rad]
  static constexpr Range kHfovRange{deg_to_rad(0.1), deg_to_rad(170.0), "rad"};
  double zoom_max = 10.0;  // optical zoom range 1..zoom_max [-]
  static constexpr Range kZoomRange{1.0, 1000.0, ""};
  double pan_min_rad = deg_to_rad(-100.0);  // [rad]
  double pan_max_rad = deg_to_rad(100.0);   // [rad]
  static constexpr Range kPanRange{deg_to_rad(-360.0), deg_to_rad(360.0), "rad"};
  double max_pan_rate_radps = deg_to_rad(100.0);  // pan servo speed [rad/s]
  static constexpr Range kPanRateRange{deg_to_rad(0.01), deg_to_rad(10000.0), "rad/s"};
  double tilt_rad = 0.0;  // up positive [rad]
  static constexpr Range kTiltRange{deg_to_rad(-80.0), deg_to_rad(80.0), "rad"};
  double zoom = 1.0;         // initial zoom, 1..zoom_max [-]
  double min_range_m = 0.3;  // closer landmarks are not recognised [m]
  double max_range_m = 8.0;  // farther landmarks are not recognised [m]
  static constexpr Range kRangeRange{0.0, 10000.0, "m"};
  double pixel_noise_px = 0.5;  // edge localisation noise, before rounding to pixels [px]
  static constexpr Range kPixelNoiseRange{0.0, 1000.0, "px"};
  int min_blob_px = 2;  // fewer visible columns or rows: not detected [px]
  static constexpr Range kMinBlobRange{1.0, 8192.0, "px"};
  double miss_probability = 0.02;  // a visible landmark is not reported, kProbabilityRange [-]
  double false_detections_per_frame = 0.01;  // Poisson mean of phantom detections [-]
  static constexpr Range kFalseDetectionsRange{0.0, 100.0, ""};
  bool report_ids = false;  // false: only colours (association is the filter's job)
  // A blob that touches the image border is cut: its centre column (bearing) or its rows
  // (distance) are wrong, so a careful detector drops it.
  bool reject_border_blobs = true;
  // analytic: each landmark projected through the pinhole model (noise, miss and phantoms as
  // above); rendered: the image is rendered and segmented by colour (sim/sensors/camera_image.hpp)
  enum class Mode { kAnalytic, kRendered };
  Mode mode = Mode::kAnalytic;
};

/// Omnidirectional camera: 360 deg range-bearing to landmarks (paper 002).
struct OmniCameraDef {
  SensorCommon common{true, 10.0, {}};
  double max_range_m = 6.0;  // [m]
  static constexpr Range kMaxRangeRange{0.01, 10000.0, "m"};
  // Gaussian in the local frame: sigma_major along the ray, sigma_minor across it (paper 002's
  // C_L); single frames are poor, up to ~0.8 m. sigma_major grows by sigma_major_per_m. [m]
  double sigma_major_m = 0.25;
  double sigma_minor_m = 0.08;
  static constexpr Range kSigmaRange{0.0, 1000.0, "m"};
  double sigma_major_per_m = 0.0;  // [m/m]
  static constexpr Range kSigmaPerMRange{0.0, 10.0, "m/m"};
  bool report_ids = true;
};

/// A detector's noise process per target (RangeBearingDef's noise_correlation_* keys): a fast
/// first-order part and a slow part holding slow_share of the variance. Outside RangeBearingDef so
/// that std::optional of it is constructible inside it (a nested class's member initialisers are
/// not complete until the enclosing class is, for clang).
struct NoiseCorrelation {
  double fast_s = 0.0;      // [s]
  double slow_s = 0.0;      // [s]
  double slow_share = 0.0;  // [-]
};

/// A range-bearing landmark sensor with a limited field of view: a camera reading barcodes (the
/// MRCLAM robots'), or any detector that gives a range and a bearing per landmark. Gaussian noise
/// in range and bearing (spread growing with range, and a bias, as `locsim calibrate` fits them),
/// missed and false detections. Optionally sees the other robots too.
struct RangeBearingDef {
  SensorCommon common{true, 10.0, {}};
  double fov_rad = deg_to_rad(60.0);  // centred on the mount's x axis [rad]
  static constexpr Range kFovRange{deg_to_rad(0.01), deg_to_rad(360.0), "rad"};
  double min_range_m = 0.1;  // closer targets are not reported [m]
  double max_range_m = 6.0;  // farther targets are not reported [m]
  static constexpr Range kRangeRange{0.0, 10000.0, "m"};
  double sigma_range_m = 0.05;     // range spread at zero range [m]
  double sigma_range_per_m = 0.0;  // added per metre of range [m/m]
  double range_bias_m = 0.0;       // added to every range [m]
  double range_bias_per_m = 0.0;   // added per metre of range (a scale error) [m/m]
  // What the range reported is. kDistance: the distance r from the sensor to the target.
  // kDepth: the target's distance along the sensor's x axis, r cos(bearing), as a camera that
  // ranges by a marker's apparent size or by stereo depth reports it (MRCLAM's cameras:
  // docs/reports/sim_to_real/measurements.md). The bias line range_bias_m + range_bias_per_m x
  // and the spread line sigma_range_m + sigma_range_per_m x take x = the value reported before
  // noise: r, or the depth. Either way min_range_m and max_range_m select targets by their
  // distance, and a false detection's range is uniform over them.
  enum class RangeModel { kDistance, kDepth };
  RangeModel range_model = RangeModel::kDistance;
  static constexpr Range kSigmaRange{0.0, 1000.0, "m"};
  static constexpr Range kBiasRange{-1000.0, 1000.0, "m"};
  static constexpr Range kSigmaPerMRange{0.0, 10.0, "m/m"};
  static constexpr Range kBiasPerMRange{-10.0, 10.0, "m/m"};
  double sigma_bearing_rad = deg_to_rad(1.0);  // [rad]
  double bearing_bias_rad = 0.0;               // [rad]
  static constexpr Range kSigmaBearingRange{0.0, 3.2, "rad"};
  static constexpr Range kBearingBiasRange{-3.2, 3.2, "rad"};
  double miss_probability = 0.0;  // a visible target is not reported [-]
  // The chance of reporting a visible target falls with its distance r as (1 - miss_probability)
  // e^(-r / detection_decay_m): a marker's image shrinks with range (MRCLAM's cameras: about 4 m,
  // docs/reports/sim_to_real/README.md); 0: misses independent of range. [m]
  double detection_decay_m = 0.0;
  static constexpr Range kDetectionDecayRange{0.0, 1e6, "m"};
  /// The chance that a visible target `range_m` away is not reported.
  double miss_probability_at(double range_m) const {
    return detection_decay_m > 0.0
               ? 1.0 - (1.0 - miss_probability) * std::exp(-range_m / detection_decay_m)
               : miss_probability;
  }
  // False detections per reading (Poisson mean), uniform over the field of view and range, with
  // an id drawn from the map's (or -1 without ids). [-]
  double false_detections = 0.0;
  static constexpr Range kFalseDetectionsRange{0.0, 100.0, ""};
  // Time constant of each target's range and bearing noise (a first-order Gauss-Markov process
  // per target: correlation exp(-dt / tau) between its detections dt apart; the spreads above
  // stay the stationary ones). A real detector's error persists while the view of the target
  // does (MRCLAM: 0.9 from one detection to the next); 0: independent. [s]
  double noise_correlation_s = 0.0;
  static constexpr Range kCorrelationRange{0.0, 1e6, "s"};
  // A slower part of that noise (a second process per target, of its own draws): this share of
  // the variance persists over noise_correlation_slow_s (MRCLAM: about half for a minute, as the
  // view of a landmark changes slowly; `locsim calibrate` fits both); 0: none. [-], [s]
  double noise_correlation_slow_share = 0.0;
  static constexpr Range kSlowShareRange{0.0, 0.99, ""};
  double noise_correlation_slow_s = 0.0;
  using Correlation = NoiseCorrelation;
  Correlation range_correlation() const {
    return {noise_correlation_s, noise_correlation_slow_s, noise_correlation_slow_share};
  }
  // The bearing's own (keys bearing_noise_correlation_s, _slow_s, _slow_share; any of them set
  // sets all three, the others 0). Unset, the bearing's noise persists as the range's. A camera's
  // bearing and range errors need not persist alike: MRCLAM's bearing errors are half white where
  // its ranges' persist for seconds (docs/reports/sim_to_real/measurements.md).
  std::optional<Correlation> bearing_correlation;
  Correlation bearing_or_range_correlation() const {
    return bearing_correlation.value_or(range_correlation());
  }
  bool report_ids = true;
  bool sees_robots = false;  // other robots are detected too (target robot, id = index)
};

/// Receivers on the robot ranging to the world's fixed ultrasonic beacons (paper 003).
struct UltrasonicDef {
  SensorCommon common{true, 20.0, {}};
  struct Receiver {
    Vec2 position_m{0.0, 0.0};  // in the robot frame, kBodyFrameRange [m]
    double height_m = 0.4;      // above the floor, kHeightRange [m]
  };
  // Two receivers (left A1, right A2) give the yaw as in the paper.
  std::vector<Receiver> receivers{{{0.0, 0.15}, 0.4}, {{0.0, -0.15}, 0.4}};
  static constexpr std::size_t kMaxReceivers = 64;  // each ranges every beacon at every sample
  double sigma_m = 0.02;                            // time-of-flight noise, "+-5 cm" class [m]
  static constexpr Range kSigmaRange{0.0, 1000.0, "m"};
  // A ranging system's systematic error (a clock's rate, an antenna's delay: a UWB radio's ranges
  // are a few per cent long): range = d + range_bias_m + range_bias_per_m d + noise.
  double range_bias_m = 0.0;  // [m]
  static constexpr Range kRangeBiasRange{-1000.0, 1000.0, "m"};
  double range_bias_per_m = 0.0;  // a scale error [m/m]
  static constexpr Range kRangeBiasPerMRange{-0.9, 10.0, "m/m"};
  // How many beacons one reading ranges: 0 every beacon (paper 003's ultrasonic, all at once), n
  // the next n of the world's beacons in turn (a UWB tag polling its anchors one at a time).
  int beacons_per_reading = 0;
  static constexpr Range kBeaconsPerReadingRange{0.0, 1000000.0, ""};
  double max_range_m = 30.0;  // [m]
  static constexpr Range kMaxRangeRange{0.01, 100000.0, "m"};
  double dropout_probability = 0.01;  // a line-of-sight reading lost anyway [-]
  // When the line of sight is blocked: a non-line-of-sight reading (longer by a reflected-path
  // bias) with this probability, else no reading.
  double nlos_probability = 0.5;  // [-]
  double nlos_bias_min_m = 0.1;   // shortest extra path [m]
  double nlos_bias_mean_m = 0.6;  // mean extra path (min + exponential) [m]
  static constexpr Range kNlosBiasRange{0.0, 10000.0, "m"};
  // Injected ranging errors (paper 003's MATLAB simulation): a line-of-sight reading lengthened
  // as a non-line-of-sight one, with this probability, whatever the geometry.
  double outlier_probability = 0.0;  // [-]
};

/// 2D laser scanner with the beam-model mixture (Thrun et al., Probabilistic Robotics 6.3).
struct LaserDef {
  SensorCommon common{true, 10.0, {}};
  double fov_rad = deg_to_rad(270.0);  // [rad], centred on the mount's x axis
  static constexpr Range kFovRange{deg_to_rad(0.01), deg_to_rad(360.0), "rad"};
  int beams = 271;
  static constexpr Range kBeamsRange{1.0, 100000.0, ""};
  double min_range_m = 0.05;  // [m]
  double max_range_m = 8.0;   // readings at max range mean "nothing" [m]
  static constexpr Range kRangeRange{0.0, 10000.0, "m"};
  double sigma_m = 0.01;  // Gaussian on true hits [m]
  static constexpr Range kSigmaRange{0.0, 1000.0, "m"};
  double p_short = 0.01;      // phantom short reading, exponential with rate lambda_short [-]
  double lambda_short = 1.0;  // [1/m]
  static constexpr Range kLambdaShortRange{0.001, 1000.0, "1/m"};
  double p_max = 0.005;     // spurious max-range reading [-]
  double p_random = 0.005;  // uniform in [0, max_range] [-]
};

/// The sensors of one robot. Absent ones are off.
struct SensorsDef {
  std::optional<EncodersDef> encoders;
  std::optional<ImuDef> imu;
  std::optional<PtzCameraDef> ptz_camera;
  std::optional<OmniCameraDef> omni_camera;
  std::optional<UltrasonicDef> ultrasonic;
  std::optional<LaserDef> laser;
  std::optional<RangeBearingDef> range_bearing;
};

/// The common settings of the sensor of `kind` in `sensors`; null when the robot has none.
const SensorCommon* sensor_common(const SensorsDef& sensors, SensorKind kind);
/// Whether the robot has the sensor of `kind`, enabled.
bool sensor_enabled(const SensorsDef& sensors, SensorKind kind);

}  // namespace locsim
