#include "sim/sensors/sensor_loader.hpp"

#include <cmath>
#include <numbers>
#include <vector>

#include "sim/common/format.hpp"

namespace locsim {

std::string divides_physics_rate(double rate_hz, double step_hz) {
  const double ratio = step_hz / rate_hz;
  if (rate_hz > step_hz || std::abs(ratio - std::round(ratio)) > 1e-9) {
    return "rate " + short_number(rate_hz) + " Hz must divide the physics rate (" +
           short_number(step_hz) + " Hz)";
  }
  return {};
}

namespace {

void check_rate(const YamlNode& where, double rate_hz, double step_hz) {
  if (const std::string problem = divides_physics_rate(rate_hz, step_hz); !problem.empty()) {
    where.fail(problem);
  }
}

/// The choice the string key `key` of `node` names among `choices` (name, value), `fallback` when
/// it is absent; fails naming the names otherwise ("must be wheels or gyro, not 'x'").
template <class E>
E get_choice(const YamlNode& node, std::string_view key, E fallback,
             std::initializer_list<std::pair<std::string_view, E>> choices) {
  const auto value = node.find(key);
  if (!value) return fallback;
  const std::string name = value->as_string();
  std::string names;
  std::size_t i = 0;
  for (const auto& [choice, e] : choices) {
    if (choice == name) return e;
    if (i > 0) names += i + 1 == choices.size() ? " or " : ", ";
    names += choice;
    ++i;
  }
  value->fail("must be " + names + ", not '" + name + "'");
}

/// Reads one sensor's section: the common keys plus its own, read by `read_own`. An empty
/// section (`imu:` or `imu: {}`) turns the sensor on with its defaults.
template <class Def, class ReadOwn>
Def parse_section(const YamlNode& node, Def def, double step_hz,
                  std::initializer_list<std::string_view> own_keys, ReadOwn read_own) {
  if (!node.is_null()) {
    std::vector<std::string_view> allowed{"enabled",           "rate_hz",           "mount",
                                          "believed_mount",    "outage_fraction",   "outage_mean_s",
                                          "outage_long_share", "outage_long_mean_s"};
    allowed.insert(allowed.end(), own_keys.begin(), own_keys.end());
    node.allow_keys(allowed);
    def.common.enabled = node.get_bool("enabled", def.common.enabled);
    def.common.rate_hz = node.get_double("rate_hz", def.common.rate_hz, SensorCommon::kRateRange);
    if (const auto mount = node.find("mount")) def.common.mount = mount->as_pose(kBodyFrameRange);
    if (const auto believed = node.find("believed_mount"))
      def.common.believed_mount = believed->as_pose(kBodyFrameRange);
    def.common.outage_fraction = node.get_double("outage_fraction", def.common.outage_fraction,
                                                 SensorCommon::kOutageFractionRange);
    def.common.outage_mean_s =
        node.get_double("outage_mean_s", def.common.outage_mean_s, SensorCommon::kOutageMeanRange);
    def.common.outage_long_share = node.get_double(
        "outage_long_share", def.common.outage_long_share, SensorCommon::kOutageLongShareRange);
    def.common.outage_long_mean_s = node.get_double(
        "outage_long_mean_s", def.common.outage_long_mean_s, SensorCommon::kOutageMeanRange);
    read_own(def);
  }
  check_rate(node.has("rate_hz") ? node["rate_hz"] : node, def.common.rate_hz, step_hz);
  return def;
}

}  // namespace

SensorsDef parse_sensors(const YamlNode& node, double step_hz) {
  node.allow_keys(
      {"encoders", "imu", "ptz_camera", "omni_camera", "ultrasonic", "laser", "range_bearing"});
  SensorsDef sensors;
  if (const auto n = node.find("encoders")) {
    sensors.encoders = parse_section(
        *n, EncodersDef{}, step_hz,
        {"ticks_per_rev", "k_left", "k_right", "k_correlation", "odometry_wheel_base_m", "reports",
         "measures", "heading", "gyro_bias_radps", "gyro_bias_sigma", "gyro_noise_density",
         "gyro_scale_error"},
        [&](EncodersDef& d) {
          d.measures = get_choice(*n, "measures", d.measures,
                                  {{"wheels", EncodersDef::Measures::kWheels},
                                   {"command", EncodersDef::Measures::kCommand}});
          if (const auto reports = n->find("reports")) {
            d.reports = 0;
            for (const YamlNode& item : reports->items()) {
              const std::string field = item.as_string();
              std::uint8_t bit = 0;
              for (const OdometryField f : kOdometryFields) {
                if (field == odometry_field_name(f)) bit = f;
              }
              if (bit == 0) item.fail("must be ticks, pose or velocity, not '" + field + "'");
              d.reports |= bit;
            }
            if (d.reports == 0) reports->fail("give at least one of ticks, pose, velocity");
          }
          d.ticks_per_rev = static_cast<int>(
              n->get_int("ticks_per_rev", d.ticks_per_rev, EncodersDef::kTicksRange));
          d.k_left = n->get_double("k_left", d.k_left, EncodersDef::kKRange);
          d.k_right = n->get_double("k_right", d.k_right, EncodersDef::kKRange);
          d.k_correlation =
              n->get_double("k_correlation", d.k_correlation, EncodersDef::kKCorrelationRange);
          if (const auto base = n->find("odometry_wheel_base_m")) {
            d.odometry_wheel_base_m = base->as_double(EncodersDef::kWheelBaseRange);
          }
          d.heading = get_choice(
              *n, "heading", d.heading,
              {{"wheels", EncodersDef::Heading::kWheels}, {"gyro", EncodersDef::Heading::kGyro}});
          d.gyro_bias_radps =
              n->get_double("gyro_bias_radps", d.gyro_bias_radps, EncodersDef::kGyroBiasRange);
          d.gyro_bias_sigma =
              n->get_double("gyro_bias_sigma", d.gyro_bias_sigma, EncodersDef::kGyroBiasSigmaRange);
          d.gyro_noise_density = n->get_double("gyro_noise_density", d.gyro_noise_density,
                                               EncodersDef::kGyroNoiseRange);
          d.gyro_scale_error =
              n->get_double("gyro_scale_error", d.gyro_scale_error, EncodersDef::kGyroScaleRange);
          if (d.heading != EncodersDef::Heading::kGyro) {
            for (const char* key :
                 {"gyro_bias_radps", "gyro_bias_sigma", "gyro_noise_density", "gyro_scale_error"})
              if (const auto gyro = n->find(key))
                gyro->fail("describes the gyro of `heading: gyro`, which this base has not");
          }
        });
  }
  if (const auto n = node.find("imu")) {
    sensors.imu = parse_section(
        *n, ImuDef{}, step_hz,
        {"gyro_noise_density", "gyro_bias_sigma", "gyro_bias_random_walk", "gyro_range",
         "accel_noise_density", "accel_bias_sigma", "accel_bias_random_walk", "accel_range"},
        [&](ImuDef& d) {
          d.gyro_noise_density =
              n->get_double("gyro_noise_density", d.gyro_noise_density, ImuDef::kGyroNoiseRange);
          d.gyro_bias_sigma =
              n->get_double("gyro_bias_sigma", d.gyro_bias_sigma, ImuDef::kGyroBiasRange);
          d.gyro_bias_random_walk = n->get_double("gyro_bias_random_walk", d.gyro_bias_random_walk,
                                                  ImuDef::kGyroWalkRange);
          d.gyro_range = n->get_double("gyro_range", d.gyro_range, ImuDef::kGyroRangeRange);
          d.accel_noise_density =
              n->get_double("accel_noise_density", d.accel_noise_density, ImuDef::kAccelNoiseRange);
          d.accel_bias_sigma =
              n->get_double("accel_bias_sigma", d.accel_bias_sigma, ImuDef::kAccelBiasRange);
          d.accel_bias_random_walk = n->get_double(
              "accel_bias_random_walk", d.accel_bias_random_walk, ImuDef::kAccelWalkRange);
          d.accel_range = n->get_double("accel_range", d.accel_range, ImuDef::kAccelRangeRange);
        });
  }
  if (const auto n = node.find("ptz_camera")) {
    sensors.ptz_camera = parse_section(
        *n, PtzCameraDef{}, step_hz,
        {"height_m",
         "width_px",
         "height_px",
         "hfov",
         "hfov_deg",
         "zoom_max",
         "pan_min",
         "pan_min_deg",
         "pan_max",
         "pan_max_deg",
         "max_pan_rate",
         "max_pan_rate_deg",
         "tilt",
         "tilt_deg",
         "zoom",
         "min_range_m",
         "max_range_m",
         "pixel_noise_px",
         "min_blob_px",
         "miss_probability",
         "false_detections_per_frame",
         "report_ids",
         "reject_border_blobs",
         "mode"},
        [&](PtzCameraDef& d) {
          d.height_m = n->get_double("height_m", d.height_m, kHeightRange);
          d.width_px =
              static_cast<int>(n->get_int("width_px", d.width_px, PtzCameraDef::kImageSizeRange));
          d.height_px =
              static_cast<int>(n->get_int("height_px", d.height_px, PtzCameraDef::kImageSizeRange));
          d.hfov_rad = n->get_angle("hfov", d.hfov_rad, PtzCameraDef::kHfovRange);
          d.zoom_max = n->get_double("zoom_max", d.zoom_max, PtzCameraDef::kZoomRange);
          d.pan_min_rad = n->get_angle("pan_min", d.pan_min_rad, PtzCameraDef::kPanRange);
          d.pan_max_rad = n->get_angle("pan_max", d.pan_max_rad, PtzCameraDef::kPanRange);
          if (d.pan_min_rad > d.pan_max_rad) n->fail("pan_min exceeds pan_max");
          d.max_pan_rate_radps =
              n->get_angle("max_pan_rate", d.max_pan_rate_radps, PtzCameraDef::kPanRateRange);
          d.tilt_rad = n->get_angle("tilt", d.tilt_rad, PtzCameraDef::kTiltRange);
          d.zoom = n->get_double("zoom", d.zoom, PtzCameraDef::kZoomRange);
          if (d.zoom > d.zoom_max) n->fail("zoom must be in [1, zoom_max]");
          d.min_range_m = n->get_double("min_range_m", d.min_range_m, PtzCameraDef::kRangeRange);
          d.max_range_m = n->get_double("max_range_m", d.max_range_m, PtzCameraDef::kRangeRange);
          if (d.min_range_m >= d.max_range_m) n->fail("min_range_m must be below max_range_m");
          d.pixel_noise_px =
              n->get_double("pixel_noise_px", d.pixel_noise_px, PtzCameraDef::kPixelNoiseRange);
          d.min_blob_px = static_cast<int>(
              n->get_int("min_blob_px", d.min_blob_px, PtzCameraDef::kMinBlobRange));
          d.miss_probability =
              n->get_double("miss_probability", d.miss_probability, kProbabilityRange);
          d.false_detections_per_frame =
              n->get_double("false_detections_per_frame", d.false_detections_per_frame,
                            PtzCameraDef::kFalseDetectionsRange);
          d.report_ids = n->get_bool("report_ids", d.report_ids);
          d.reject_border_blobs = n->get_bool("reject_border_blobs", d.reject_border_blobs);
          d.mode = get_choice(*n, "mode", d.mode,
                              {{"analytic", PtzCameraDef::Mode::kAnalytic},
                               {"rendered", PtzCameraDef::Mode::kRendered}});
        });
  }
  if (const auto n = node.find("omni_camera")) {
    sensors.omni_camera = parse_section(
        *n, OmniCameraDef{}, step_hz,
        {"max_range_m", "sigma_major_m", "sigma_minor_m", "sigma_major_per_m", "report_ids"},
        [&](OmniCameraDef& d) {
          d.max_range_m =
              n->get_double("max_range_m", d.max_range_m, OmniCameraDef::kMaxRangeRange);
          d.sigma_major_m =
              n->get_double("sigma_major_m", d.sigma_major_m, OmniCameraDef::kSigmaRange);
          d.sigma_minor_m =
              n->get_double("sigma_minor_m", d.sigma_minor_m, OmniCameraDef::kSigmaRange);
          d.sigma_major_per_m = n->get_double("sigma_major_per_m", d.sigma_major_per_m,
                                              OmniCameraDef::kSigmaPerMRange);
          d.report_ids = n->get_bool("report_ids", d.report_ids);
        });
  }
  if (const auto n = node.find("ultrasonic")) {
    sensors.ultrasonic = parse_section(
        *n, UltrasonicDef{}, step_hz,
        {"receivers", "sigma_m", "range_bias_m", "range_bias_per_m", "beacons_per_reading",
         "max_range_m", "dropout_probability", "nlos_probability", "nlos_bias_min_m",
         "nlos_bias_mean_m", "outlier_probability"},
        [&](UltrasonicDef& d) {
          if (const auto receivers = n->find("receivers")) {
            d.receivers.clear();
            for (const YamlNode& item : receivers->items()) {
              item.allow_keys({"position", "height_m"});
              if (d.receivers.size() == UltrasonicDef::kMaxReceivers) {
                item.fail("at most " + std::to_string(UltrasonicDef::kMaxReceivers) +
                          " receivers (each ranges every beacon at every sample)");
              }
              d.receivers.push_back({item["position"].as_vec2(kBodyFrameRange),
                                     item.get_double("height_m", 0.4, kHeightRange)});
            }
            if (d.receivers.empty()) receivers->fail("give at least one receiver");
          }
          d.sigma_m = n->get_double("sigma_m", d.sigma_m, UltrasonicDef::kSigmaRange);
          d.range_bias_m =
              n->get_double("range_bias_m", d.range_bias_m, UltrasonicDef::kRangeBiasRange);
          d.range_bias_per_m = n->get_double("range_bias_per_m", d.range_bias_per_m,
                                             UltrasonicDef::kRangeBiasPerMRange);
          d.beacons_per_reading =
              static_cast<int>(n->get_int("beacons_per_reading", d.beacons_per_reading,
                                          UltrasonicDef::kBeaconsPerReadingRange));
          d.max_range_m =
              n->get_double("max_range_m", d.max_range_m, UltrasonicDef::kMaxRangeRange);
          d.dropout_probability =
              n->get_double("dropout_probability", d.dropout_probability, kProbabilityRange);
          d.nlos_probability =
              n->get_double("nlos_probability", d.nlos_probability, kProbabilityRange);
          d.nlos_bias_min_m =
              n->get_double("nlos_bias_min_m", d.nlos_bias_min_m, UltrasonicDef::kNlosBiasRange);
          d.nlos_bias_mean_m =
              n->get_double("nlos_bias_mean_m", d.nlos_bias_mean_m, UltrasonicDef::kNlosBiasRange);
          d.outlier_probability =
              n->get_double("outlier_probability", d.outlier_probability, kProbabilityRange);
          if (d.nlos_bias_mean_m < d.nlos_bias_min_m) {
            (*n)["nlos_bias_mean_m"].fail("must be >= nlos_bias_min_m");
          }
        });
  }
  if (const auto n = node.find("laser")) {
    sensors.laser = parse_section(
        *n, LaserDef{}, step_hz,
        {"fov", "fov_deg", "beams", "min_range_m", "max_range_m", "sigma_m", "p_short",
         "lambda_short", "p_max", "p_random"},
        [&](LaserDef& d) {
          d.fov_rad = n->get_angle("fov", d.fov_rad, LaserDef::kFovRange);
          d.beams = static_cast<int>(n->get_int("beams", d.beams, LaserDef::kBeamsRange));
          d.min_range_m = n->get_double("min_range_m", d.min_range_m, LaserDef::kRangeRange);
          d.max_range_m = n->get_double("max_range_m", d.max_range_m, LaserDef::kRangeRange);
          if (d.min_range_m >= d.max_range_m) n->fail("min_range_m must be below max_range_m");
          d.sigma_m = n->get_double("sigma_m", d.sigma_m, LaserDef::kSigmaRange);
          d.p_short = n->get_double("p_short", d.p_short, kProbabilityRange);
          d.lambda_short =
              n->get_double("lambda_short", d.lambda_short, LaserDef::kLambdaShortRange);
          d.p_max = n->get_double("p_max", d.p_max, kProbabilityRange);
          d.p_random = n->get_double("p_random", d.p_random, kProbabilityRange);
          if (d.p_short + d.p_max + d.p_random > 1.0)
            n->fail("p_short + p_max + p_random exceeds 1");
        });
  }
  if (const auto n = node.find("range_bearing")) {
    sensors.range_bearing = parse_section(
        *n, RangeBearingDef{}, step_hz,
        {"fov",
         "fov_deg",
         "min_range_m",
         "max_range_m",
         "sigma_range_m",
         "sigma_range_per_m",
         "range_bias_m",
         "range_bias_per_m",
         "range_model",
         "sigma_bearing",
         "sigma_bearing_deg",
         "bearing_bias",
         "bearing_bias_deg",
         "miss_probability",
         "detection_decay_m",
         "false_detections",
         "noise_correlation_s",
         "noise_correlation_slow_s",
         "noise_correlation_slow_share",
         "bearing_noise_correlation_s",
         "bearing_noise_correlation_slow_s",
         "bearing_noise_correlation_slow_share",
         "report_ids",
         "sees_robots"},
        [&](RangeBearingDef& d) {
          using D = RangeBearingDef;
          d.fov_rad = n->get_angle("fov", d.fov_rad, D::kFovRange);
          d.min_range_m = n->get_double("min_range_m", d.min_range_m, D::kRangeRange);
          d.max_range_m = n->get_double("max_range_m", d.max_range_m, D::kRangeRange);
          if (d.min_range_m >= d.max_range_m) n->fail("min_range_m must be below max_range_m");
          d.sigma_range_m = n->get_double("sigma_range_m", d.sigma_range_m, D::kSigmaRange);
          d.sigma_range_per_m =
              n->get_double("sigma_range_per_m", d.sigma_range_per_m, D::kSigmaPerMRange);
          d.range_bias_m = n->get_double("range_bias_m", d.range_bias_m, D::kBiasRange);
          d.range_bias_per_m =
              n->get_double("range_bias_per_m", d.range_bias_per_m, D::kBiasPerMRange);
          d.range_model = get_choice(
              *n, "range_model", d.range_model,
              {{"distance", D::RangeModel::kDistance}, {"depth", D::RangeModel::kDepth}});
          // A target 90 deg or more off the axis has no depth (zero or negative).
          if (d.range_model == D::RangeModel::kDepth && d.fov_rad >= std::numbers::pi) {
            n->find("range_model")
                ->fail("depth needs a field of view below 180 deg, not " +
                       rounded_number(rad_to_deg(d.fov_rad), 6) + " deg");
          }
          d.sigma_bearing_rad =
              n->get_angle("sigma_bearing", d.sigma_bearing_rad, D::kSigmaBearingRange);
          d.bearing_bias_rad =
              n->get_angle("bearing_bias", d.bearing_bias_rad, D::kBearingBiasRange);
          d.miss_probability =
              n->get_double("miss_probability", d.miss_probability, kProbabilityRange);
          d.detection_decay_m =
              n->get_double("detection_decay_m", d.detection_decay_m, D::kDetectionDecayRange);
          d.false_detections =
              n->get_double("false_detections", d.false_detections, D::kFalseDetectionsRange);
          d.noise_correlation_s =
              n->get_double("noise_correlation_s", d.noise_correlation_s, D::kCorrelationRange);
          d.noise_correlation_slow_s = n->get_double(
              "noise_correlation_slow_s", d.noise_correlation_slow_s, D::kCorrelationRange);
          d.noise_correlation_slow_share = n->get_double(
              "noise_correlation_slow_share", d.noise_correlation_slow_share, D::kSlowShareRange);
          if (n->find("bearing_noise_correlation_s") ||
              n->find("bearing_noise_correlation_slow_s") ||
              n->find("bearing_noise_correlation_slow_share")) {
            RangeBearingDef::Correlation& b = d.bearing_correlation.emplace();
            b.fast_s = n->get_double("bearing_noise_correlation_s", 0.0, D::kCorrelationRange);
            b.slow_s = n->get_double("bearing_noise_correlation_slow_s", 0.0, D::kCorrelationRange);
            b.slow_share =
                n->get_double("bearing_noise_correlation_slow_share", 0.0, D::kSlowShareRange);
          }
          d.report_ids = n->get_bool("report_ids", d.report_ids);
          d.sees_robots = n->get_bool("sees_robots", d.sees_robots);
        });
  }
  return sensors;
}

}  // namespace locsim
