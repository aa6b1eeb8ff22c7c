#include "sim/sensors/sensor.hpp"

#include <algorithm>
#include <cmath>

#include "sim/sensors/models.hpp"

namespace locsim {

const char* sensor_name(SensorKind kind) {
  switch (kind) {
    case SensorKind::kEncoders:
      return "encoders";
    case SensorKind::kImu:
      return "imu";
    case SensorKind::kPtzCamera:
      return "ptz_camera";
    case SensorKind::kOmniCamera:
      return "omni_camera";
    case SensorKind::kUltrasonic:
      return "ultrasonic";
    case SensorKind::kLaser:
      return "laser";
    case SensorKind::kRangeBearing:
      return "range_bearing";
  }
  return "?";
}

std::optional<SensorKind> sensor_kind(std::string_view name) {
  for (const SensorKind kind : kSensorKinds) {
    if (name == sensor_name(kind)) return kind;
  }
  return std::nullopt;
}

std::string sensor_names() {
  std::string names;
  for (const SensorKind kind : kSensorKinds) {
    if (!names.empty()) names += ", ";
    names += sensor_name(kind);
  }
  return names;
}

const char* odometry_field_name(OdometryField field) {
  switch (field) {
    case kOdometryTicks:
      return "ticks";
    case kOdometryPose:
      return "pose";
    case kOdometryVelocity:
      return "velocity";
  }
  return "?";
}

std::string odometry_fields_text(std::uint8_t fields) {
  std::string text;
  for (const OdometryField field : kOdometryFields) {
    if ((fields & field) == 0) continue;
    if (!text.empty()) text += ", ";
    text += odometry_field_name(field);
  }
  return text.empty() ? "none" : text;
}

const char* detection_target_name(DetectionTarget target) {
  switch (target) {
    case DetectionTarget::kLandmark:
      return "landmark";
    case DetectionTarget::kRobot:
      return "robot";
  }
  return "?";
}

const SensorCommon* sensor_common(const SensorsDef& sensors, SensorKind kind) {
  const auto common = [](const auto& def) -> const SensorCommon* {
    return def ? &def->common : nullptr;
  };
  switch (kind) {
    case SensorKind::kEncoders:
      return common(sensors.encoders);
    case SensorKind::kImu:
      return common(sensors.imu);
    case SensorKind::kPtzCamera:
      return common(sensors.ptz_camera);
    case SensorKind::kOmniCamera:
      return common(sensors.omni_camera);
    case SensorKind::kUltrasonic:
      return common(sensors.ultrasonic);
    case SensorKind::kLaser:
      return common(sensors.laser);
    case SensorKind::kRangeBearing:
      return common(sensors.range_bearing);
  }
  return nullptr;
}

bool sensor_enabled(const SensorsDef& sensors, SensorKind kind) {
  const SensorCommon* common = sensor_common(sensors, kind);
  return common != nullptr && common->enabled;
}

const char* range_status_name(RangeStatus status) {
  switch (status) {
    case RangeStatus::kLineOfSight:
      return "los";
    case RangeStatus::kNonLineOfSight:
      return "nlos";
    case RangeStatus::kDropped:
      return "dropped";
    case RangeStatus::kOutOfRange:
      return "out_of_range";
  }
  return "?";
}

std::optional<ReadingData> Sensor::sample(const SensorContext& context) {
  // Measuring even during a fault keeps the sensor's internal state (integrators, bias walks,
  // its random stream) on the same course as without the fault.
  std::optional<ReadingData> data = measure(context);
  std::erase_if(faults_, [&](const ActiveFault& f) { return context.t_s >= f.until_s; });
  bool dropout = false, stuck = false;
  double bias = 0.0;
  for (const ActiveFault& fault : faults_) {
    switch (fault.def.mode) {
      case SensorFaultDef::Mode::kDropout:
        dropout = true;
        break;
      case SensorFaultDef::Mode::kStuck:
        stuck = true;
        break;
      case SensorFaultDef::Mode::kBias:
        bias += fault.def.bias;
        break;
    }
  }
  if (stuck) return last_;
  if (data && bias != 0.0) apply_bias(*data, bias);
  if (data) last_ = data;
  if (dropout || silent(context.t_s)) return std::nullopt;
  return data;
}

bool Sensor::silent(double t_s) {
  if (!outage_rng_) return false;
  const double f = common_.outage_fraction;
  const double q = common_.outage_long_share;
  const double in_mean_s = common_.outage_spell_mean_s() * (1.0 - f) / f;  // the share out is f
  // A spell's kind is drawn only when there are two: worlds of one kind keep their draws.
  const auto spell = [&](bool out, double long_odds) {
    double mean_s = in_mean_s;
    if (out) {
      mean_s = common_.outage_mean_s;
      if (q > 0.0 && outage_rng_->uniform() < long_odds) mean_s = common_.outage_long_mean_s;
    }
    return -mean_s * std::log(1.0 - outage_rng_->uniform());
  };
  if (std::isnan(switch_s_)) {  // the first sample: in a spell with the process's own odds
    out_ = outage_rng_->uniform() < f;
    // A spell under way is long by the share of the silent time long spells take (and, being
    // exponential, has their whole mean still to run).
    switch_s_ = t_s + spell(out_, q * common_.outage_long_mean_s / common_.outage_spell_mean_s());
  }
  while (t_s >= switch_s_) {
    out_ = !out_;
    switch_s_ += spell(out_, q);
  }
  return out_;
}

void Sensor::inject(const SensorFaultDef& fault, double now_s) {
  const double until =
      fault.duration_s > 0.0 ? now_s + fault.duration_s : std::numeric_limits<double>::infinity();
  faults_.push_back({fault, until});
}

std::vector<std::unique_ptr<Sensor>> make_sensors(const RobotDef& robot, std::uint64_t seed,
                                                  const PanPolicyDef* pan_policy) {
  std::vector<std::unique_ptr<Sensor>> sensors;
  const SensorsDef& defs = robot.sensors;
  const auto stream = [&](SensorKind kind) {
    return make_stream(seed, "sensor/" + robot.name + "/" + sensor_name(kind));
  };
  if (defs.encoders && defs.encoders->common.enabled) {
    sensors.push_back(
        std::make_unique<EncoderSensor>(*defs.encoders, robot, stream(SensorKind::kEncoders)));
  }
  if (defs.imu && defs.imu->common.enabled) {
    sensors.push_back(std::make_unique<ImuSensor>(*defs.imu, stream(SensorKind::kImu)));
  }
  if (defs.ptz_camera && defs.ptz_camera->common.enabled) {
    sensors.push_back(std::make_unique<PtzCameraSensor>(*defs.ptz_camera,
                                                        pan_policy ? *pan_policy : PanPolicyDef{},
                                                        stream(SensorKind::kPtzCamera)));
  }
  if (defs.omni_camera && defs.omni_camera->common.enabled) {
    sensors.push_back(
        std::make_unique<OmniCameraSensor>(*defs.omni_camera, stream(SensorKind::kOmniCamera)));
  }
  if (defs.ultrasonic && defs.ultrasonic->common.enabled) {
    sensors.push_back(
        std::make_unique<UltrasonicSensor>(*defs.ultrasonic, stream(SensorKind::kUltrasonic)));
  }
  if (defs.laser && defs.laser->common.enabled) {
    sensors.push_back(std::make_unique<LaserSensor>(*defs.laser, stream(SensorKind::kLaser)));
  }
  if (defs.range_bearing && defs.range_bearing->common.enabled) {
    sensors.push_back(std::make_unique<RangeBearingSensor>(*defs.range_bearing,
                                                           stream(SensorKind::kRangeBearing)));
  }
  for (const std::unique_ptr<Sensor>& sensor : sensors) {
    // Its own stream: a sensor's noise draws are the same with outages as without.
    if (sensor->common().outage_fraction > 0.0) {
      sensor->set_outage_stream(make_stream(
          seed, "sensor/" + robot.name + "/" + sensor_name(sensor->kind()) + "/outage"));
    }
  }
  return sensors;
}

}  // namespace locsim
