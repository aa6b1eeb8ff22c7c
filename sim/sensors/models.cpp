#include "sim/sensors/models.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "sim/common/errors.hpp"

namespace locsim {

namespace {
constexpr double kTwoPi = 2.0 * std::numbers::pi;

/// The sensor's pose in the world.
Pose2 sensor_pose(const DiffDriveRobot& robot, const Pose2& mount) {
  const Pose2 body = robot.pose();
  const Vec2 position = body.transform(mount.position());
  return {position.x(), position.y(), wrap_angle(body.theta + mount.theta)};
}

/// Range and bearing in the robot frame of a point given in the sensor (mount) frame.
void to_robot_frame(const Pose2& mount, const Vec2& in_sensor, double& range, double& bearing) {
  const Vec2 in_robot = mount.transform(in_sensor);
  range = in_robot.norm();
  bearing = std::atan2(in_robot.y(), in_robot.x());
}

/// Poisson variate by multiplication of uniforms (small means only).
int poisson(RandomStream& rng, double mean) {
  const double limit = std::exp(-mean);
  int count = 0;
  for (double product = rng.uniform(); product > limit; product *= rng.uniform()) ++count;
  return count;
}
}  // namespace

// ---------------------------------------------------------------------------------------------
EncoderSensor::EncoderSensor(const EncodersDef& def, const RobotDef& robot, RandomStream rng)
    : Sensor(SensorKind::kEncoders, def.common, rng),
      def_(def),
      nominal_radius_m_(robot.wheel_radius_m),
      wheel_base_m_(believed_wheel_base_m(robot)),
      odometry_(robot.start) {}

void EncoderSensor::on_physics_step(const SensorContext& context) {
  // A gyro off the floor is modelled as seeing nothing, as the IMU's.
  if (def_.heading == EncodersDef::Heading::kGyro && !context.robot.carried())
    gyro_turn_rad_ += context.robot.yaw_rate_radps() * context.step_s;
  if (def_.measures != EncodersDef::Measures::kCommand) return;
  const double v_mps = context.robot.given_v_mps();
  const double half_turn_mps = 0.5 * context.robot.given_omega_radps() * wheel_base_m_;
  commanded_angle_rad_[0] += (v_mps - half_turn_mps) * context.step_s / nominal_radius_m_;
  commanded_angle_rad_[1] += (v_mps + half_turn_mps) * context.step_s / nominal_radius_m_;
}

std::optional<ReadingData> EncoderSensor::measure(const SensorContext& context) {
  const WheelState* wheels[2] = {&context.robot.left(), &context.robot.right()};
  const bool command = def_.measures == EncodersDef::Measures::kCommand;
  const double k[2] = {def_.k_left, def_.k_right};
  const double radians_per_tick = kTwoPi / def_.ticks_per_rev;
  double travel_m[2], turned[2], sigma_m[2], error_m[2];
  for (int i = 0; i < 2; ++i) {
    const double angle_rad = command ? commanded_angle_rad_[i] : wheels[i]->angle_rad;
    turned[i] = angle_rad - true_angle_rad_[i];
    true_angle_rad_[i] = angle_rad;
    // Random error: a random walk in rolled distance with variance K^2 |d|, counted as rotation
    // of the nominal wheel so that odometry sees exactly that distance error.
    const double rolled_m =
        std::abs(turned[i]) * (command ? nominal_radius_m_ : wheels[i]->radius_m);
    sigma_m[i] = k[i] * std::sqrt(rolled_m);
    error_m[i] = rolled_m > 0.0 ? rng().normal(0.0, sigma_m[i]) : 0.0;
  }
  // Correlated wheels: the right's error takes rho of the left's standardised one (the same
  // draws, so that a world without k_correlation keeps its numbers).
  if (const double rho = def_.k_correlation; rho != 0.0 && sigma_m[0] > 0.0) {
    error_m[1] =
        rho * sigma_m[1] * (error_m[0] / sigma_m[0]) + std::sqrt(1.0 - rho * rho) * error_m[1];
  }
  for (int i = 0; i < 2; ++i) {
    counted_angle_rad_[i] += turned[i] + error_m[i] / nominal_radius_m_;
    const auto ticks =
        static_cast<std::int64_t>(std::floor(counted_angle_rad_[i] / radians_per_tick));
    travel_m[i] = static_cast<double>(ticks - ticks_[i]) * radians_per_tick * nominal_radius_m_;
    ticks_[i] = ticks;
  }
  // Dead reckoning on the arc's mid-heading (exact to second order; paper 002 uses the end
  // heading, which is biased for turns).
  const double distance = 0.5 * (travel_m[0] + travel_m[1]);
  const double period_s = context.t_s - last_sample_s_;
  last_sample_s_ = context.t_s;
  double turn = (travel_m[1] - travel_m[0]) / wheel_base_m_;
  if (def_.heading == EncodersDef::Heading::kGyro) {
    // The gyro's turn: the body's times its scale, its bias over the period and white noise of
    // the period's bandwidth (a heading random walk of density^2 per second).
    if (!gyro_bias_radps_)
      gyro_bias_radps_ = rng().normal(def_.gyro_bias_radps, def_.gyro_bias_sigma);
    turn =
        (1.0 + def_.gyro_scale_error) * gyro_turn_rad_ + *gyro_bias_radps_ * period_s +
        (period_s > 0.0 ? rng().normal(0.0, def_.gyro_noise_density * std::sqrt(period_s)) : 0.0);
    gyro_turn_rad_ = 0.0;
  }
  const double mid_heading = odometry_.theta + 0.5 * turn;
  odometry_.x += distance * std::cos(mid_heading);
  odometry_.y += distance * std::sin(mid_heading);
  odometry_.theta = wrap_angle(odometry_.theta + turn);
  // What a base computing its velocity from the counts says: the mean over the last period (none
  // before the first period has passed).
  OdometryReading reading;
  reading.fields = def_.reports;
  if (reading.has(kOdometryTicks)) reading.left_ticks = ticks_[0], reading.right_ticks = ticks_[1];
  if (reading.has(kOdometryPose)) reading.odometry = odometry_;
  if (reading.has(kOdometryVelocity) && period_s > 0.0) {
    reading.v_mps = distance / period_s;
    reading.omega_radps = turn / period_s;
  }
  return reading;
}

// ---------------------------------------------------------------------------------------------
ImuSensor::ImuSensor(const ImuDef& def, RandomStream rng)
    : Sensor(SensorKind::kImu, def.common, rng), def_(def) {
  gyro_bias_ = this->rng().normal(0.0, def_.gyro_bias_sigma);
  accel_bias_ = {this->rng().normal(0.0, def_.accel_bias_sigma),
                 this->rng().normal(0.0, def_.accel_bias_sigma)};
}

void ImuSensor::on_physics_step(const SensorContext& context) {
  const DiffDriveRobot& robot = context.robot;
  if (robot.carried()) {
    was_carried_ = true;
    ++steps_;  // off the floor the IMU is modelled as seeing nothing
    return;
  }
  const Pose2 mount = sensor_pose(robot, def_.common.mount);
  const Vec2 velocity =
      from_b2(robot.body()->GetLinearVelocityFromWorldPoint(to_b2(mount.position())));
  if (!initialised_ || was_carried_) {
    previous_velocity_ = velocity;  // a put-down is not a measured acceleration
    initialised_ = true;
    was_carried_ = false;
  }
  const Vec2 accel_world = (velocity - previous_velocity_) / context.step_s;
  previous_velocity_ = velocity;
  const double c = std::cos(mount.theta), s = std::sin(mount.theta);
  sum_accel_ +=
      Vec2{c * accel_world.x() + s * accel_world.y(), -s * accel_world.x() + c * accel_world.y()};
  sum_yaw_rate_ += robot.yaw_rate_radps();
  ++steps_;
}

std::optional<ReadingData> ImuSensor::measure(const SensorContext&) {
  const double rate = def_.common.rate_hz;
  const double period = 1.0 / rate;
  const double n = std::max(steps_, 1);
  // Bias random walk over the interval, then white noise of the sample's bandwidth.
  gyro_bias_ += rng().normal(0.0, def_.gyro_bias_random_walk * std::sqrt(period));
  accel_bias_ += Vec2{rng().normal(0.0, def_.accel_bias_random_walk * std::sqrt(period)),
                      rng().normal(0.0, def_.accel_bias_random_walk * std::sqrt(period))};
  const double gyro_sigma = def_.gyro_noise_density * std::sqrt(rate);
  const double accel_sigma = def_.accel_noise_density * std::sqrt(rate);
  ImuReading reading;
  reading.yaw_rate_radps =
      std::clamp(sum_yaw_rate_ / n + gyro_bias_ + rng().normal(0.0, gyro_sigma), -def_.gyro_range,
                 def_.gyro_range);
  for (int axis = 0; axis < 2; ++axis) {
    reading.accel_mps2[axis] =
        std::clamp(sum_accel_[axis] / n + accel_bias_[axis] + rng().normal(0.0, accel_sigma),
                   -def_.accel_range, def_.accel_range);
  }
  sum_yaw_rate_ = 0.0;
  sum_accel_.setZero();
  steps_ = 0;
  return reading;
}

void ImuSensor::apply_bias(ReadingData& data, double bias) const {
  std::get<ImuReading>(data).yaw_rate_radps += bias;
}

// ---------------------------------------------------------------------------------------------
PtzCameraSensor::PtzCameraSensor(const PtzCameraDef& def, const PanPolicyDef& policy,
                                 RandomStream rng)
    : Sensor(SensorKind::kPtzCamera, def.common, rng), def_(def), policy_(policy) {
  if (policy_.mode == PanPolicyDef::Mode::kFixed) pan_rad_ = policy_.pan_rad;
  pan_rad_ = std::clamp(pan_rad_, def_.pan_min_rad, def_.pan_max_rad);
}

double PtzCameraSensor::focal_px() const {
  return 0.5 * def_.width_px / std::tan(0.5 * def_.hfov_rad) * def_.zoom;
}

void PtzCameraSensor::steer(const SensorContext& context) {
  const double elapsed = std::max(0.0, context.t_s - last_steer_s_);
  last_steer_s_ = context.t_s;
  const double max_move = def_.max_pan_rate_radps * elapsed;
  double target = pan_rad_;
  switch (policy_.mode) {
    case PanPolicyDef::Mode::kFixed:
      target = policy_.pan_rad;
      break;
    case PanPolicyDef::Mode::kSweep: {
      const double lo = std::max(policy_.sweep_min_rad, def_.pan_min_rad);
      const double hi = std::min(policy_.sweep_max_rad, def_.pan_max_rad);
      double move = std::min(policy_.sweep_rate_radps * elapsed, max_move);
      target = pan_rad_;
      // Triangle wave between the limits, reflecting at each end.
      while (move > 1e-12) {
        const double room = sweep_direction_ > 0 ? hi - target : target - lo;
        if (move <= room) {
          target += sweep_direction_ * move;
          move = 0.0;
        } else {
          target += sweep_direction_ * std::max(room, 0.0);
          move -= std::max(room, 0.0);
          sweep_direction_ = -sweep_direction_;
          if (hi - lo < 1e-9) break;
          // From a limit on, whole periods of the wave change nothing: a fast sweep over a
          // narrow range takes a few passes, not millions (fmod is exact; a move shorter than a
          // period is kept as it is).
          if (target >= lo && target <= hi) move = std::fmod(move, 2.0 * (hi - lo));
        }
      }
      break;
    }
    case PanPolicyDef::Mode::kNearestLandmark: {
      // Looks at the nearest landmark within pan reach, by the true pose (the scenario is the
      // experimenter's hand; a policy driven by the estimate belongs to the localizer).
      const Pose2 base = sensor_pose(context.robot, def_.common.mount);
      double best = kNoHit;
      for (const LandmarkDef& landmark : context.world.landmarks) {
        const Vec2 d = landmark.position_m - base.position();
        const double bearing = wrap_angle(std::atan2(d.y(), d.x()) - base.theta);
        if (bearing < def_.pan_min_rad || bearing > def_.pan_max_rad) continue;
        if (d.norm() < best && d.norm() <= def_.max_range_m) {
          best = d.norm();
          target = bearing;
        }
      }
      break;
    }
  }
  target = std::clamp(target, def_.pan_min_rad, def_.pan_max_rad);
  pan_rad_ += std::clamp(target - pan_rad_, -max_move, max_move);
}

std::optional<Detection> PtzCameraSensor::look_at(const SensorContext& context, const Pose2& camera,
                                                  const LandmarkDef& landmark) {
  const Vec2 offset = landmark.position_m - camera.position();
  const double c = std::cos(camera.theta), s = std::sin(camera.theta);
  const Vec2 local{c * offset.x() + s * offset.y(), -s * offset.x() + c * offset.y()};
  const double range = local.norm();
  if (local.x() <= 0.0 || range <= landmark.radius_m) return std::nullopt;
  const double surface_m = range - landmark.radius_m;  // horizontal distance to the near face
  if (surface_m < def_.min_range_m || surface_m > def_.max_range_m) return std::nullopt;

  const double f = focal_px();
  const double cx = 0.5 * def_.width_px, cy = 0.5 * def_.height_px;
  const double bearing = std::atan2(local.y(), local.x());
  const double half_width = std::asin(landmark.radius_m / range);
  if (std::abs(bearing) + half_width >= 0.5 * std::numbers::pi) return std::nullopt;
  // Columns: u = cx - f tan(angle); edges with noise, rounded to pixel boundaries.
  const double u_left =
      cx - f * std::tan(bearing + half_width) + rng().normal(0.0, def_.pixel_noise_px);
  const double u_right =
      cx - f * std::tan(bearing - half_width) + rng().normal(0.0, def_.pixel_noise_px);
  const int first_column = std::max(0, static_cast<int>(std::lround(u_left)));
  const int end_column = std::min(def_.width_px, static_cast<int>(std::lround(u_right)));
  if (end_column - first_column < def_.min_blob_px) return std::nullopt;
  if (def_.reject_border_blobs && (first_column == 0 || end_column == def_.width_px))
    return std::nullopt;

  // Rows of the landmark's top and bottom where it is nearest along the optical axis: a pinhole
  // image scales heights by the depth along the axis, range cos(bearing) - radius, not by the
  // distance (off-axis landmarks look taller). With tilt.
  const double tilt = def_.tilt_rad;
  const double depth_m = range * std::cos(bearing) - landmark.radius_m;
  const auto row_of = [&](double z_m) {
    return cy - f * std::tan(std::atan((z_m - def_.height_m) / depth_m) - tilt);
  };
  const double v_top =
      std::clamp(row_of(landmark.height_m) + rng().normal(0.0, def_.pixel_noise_px), 0.0,
                 static_cast<double>(def_.height_px));
  const double v_bottom = std::clamp(row_of(0.0) + rng().normal(0.0, def_.pixel_noise_px), 0.0,
                                     static_cast<double>(def_.height_px));
  const double top_row = std::round(v_top), bottom_row = std::round(v_bottom);
  if (bottom_row - top_row < def_.min_blob_px) return std::nullopt;
  if (def_.reject_border_blobs && (top_row <= 0.0 || bottom_row >= def_.height_px))
    return std::nullopt;

  // Occlusion: the longest run of columns whose ray reaches the landmark. At most 16 rays;
  // columns between rays take the nearer ray's answer.
  const int span = end_column - first_column;
  const int stride = std::max(1, (span + 15) / 16);
  int best_start = 0, best_length = 0, run_start = 0, run_length = 0;
  bool tested_visible = false;
  for (int k = 0; k < span; ++k) {
    if (k % stride == 0) {
      const double angle = camera.theta + std::atan((cx - (first_column + k + 0.5)) / f);
      const Vec2 direction{std::cos(angle), std::sin(angle)};
      // Distance along this ray to the landmark's circle (or its centre distance if grazing).
      const Vec2 oc = camera.position() - landmark.position_m;
      const double b = oc.dot(direction);
      const double disc = b * b - (oc.squaredNorm() - landmark.radius_m * landmark.radius_m);
      const double to_landmark = disc > 0.0 ? -b - std::sqrt(disc) : range;
      tested_visible = context.rays.cast(camera.position(), direction, to_landmark,
                                         context.robot.body()) >= to_landmark - 1e-6;
    }
    if (tested_visible) {
      if (run_length == 0) run_start = k;
      if (++run_length > best_length) best_length = run_length, best_start = run_start;
    } else {
      run_length = 0;
    }
  }
  if (best_length < def_.min_blob_px) return std::nullopt;

  return back_project(first_column + best_start + 0.5 * best_length, top_row, bottom_row, landmark);
}

Detection PtzCameraSensor::back_project(double u_centre, double top_row, double bottom_row,
                                        const LandmarkDef& landmark) const {
  // Bearing from the blob's centre column; from its rows, knowing the landmark's height, the
  // depth of its near side along the optical axis, x = h / (tan(e_top) - tan(e_bottom)); the
  // centre is a radius deeper, and its distance is that depth over cos(bearing).
  const double f = focal_px();
  const double cx = 0.5 * def_.width_px, cy = 0.5 * def_.height_px;
  const double bearing_estimate = std::atan((cx - u_centre) / f);
  const double e_top = def_.tilt_rad + std::atan((cy - top_row) / f);
  const double e_bottom = def_.tilt_rad + std::atan((cy - bottom_row) / f);
  const double depth_estimate = landmark.height_m / (std::tan(e_top) - std::tan(e_bottom));
  const double centre_estimate = (depth_estimate + landmark.radius_m) / std::cos(bearing_estimate);

  Detection detection;
  detection.color = color_label(landmark);
  detection.id = def_.report_ids ? landmark.id : -1;
  detection.truth_id = landmark.id;
  const Pose2& believed = def_.common.reported_mount();
  const Pose2 camera_in_robot{believed.x, believed.y, believed.theta + pan_rad_};
  to_robot_frame(
      camera_in_robot,
      {centre_estimate * std::cos(bearing_estimate), centre_estimate * std::sin(bearing_estimate)},
      detection.range_m, detection.bearing_rad);
  return detection;
}

void PtzCameraSensor::look_rendered(const SensorContext& context, const Pose2& camera,
                                    PtzReading& reading) {
  if (!imager_) {
    throw RenderError("ptz_camera of robot '" + context.robot.name() +
                      "': mode: rendered needs the renderer, which this program did not load "
                      "(`locsim run` does)");
  }
  static const std::vector<ScenePrism> kNothingMoves;
  const CameraShot shot{camera,     def_.height_m, def_.tilt_rad,
                        focal_px(), def_.width_px, def_.height_px};
  const std::vector<ImageBlob> blobs = imager_->look(
      shot, context.moving != nullptr ? *context.moving : kNothingMoves, context.robot.name());
  const double f = focal_px();
  const double cx = 0.5 * def_.width_px;
  for (const ImageBlob& blob : blobs) {
    if (blob.end_column - blob.first_column < def_.min_blob_px ||
        blob.bottom_row - blob.top_row < def_.min_blob_px) {
      continue;
    }
    if (def_.reject_border_blobs && (blob.first_column == 0 || blob.end_column == def_.width_px ||
                                     blob.top_row == 0 || blob.bottom_row == def_.height_px)) {
      continue;
    }
    // The colour says which landmarks it may be; their shape (height, radius) is the first's.
    const LandmarkDef* shape = nullptr;
    for (const LandmarkDef& l : context.world.landmarks) {
      if (color_label(l) == blob.color) {
        shape = &l;
        break;
      }
    }
    if (shape == nullptr) continue;
    const double u_centre = 0.5 * (blob.first_column + blob.end_column);
    Detection detection = back_project(u_centre, blob.top_row, blob.bottom_row, *shape);
    // The recognition range, on the estimate (the image is all the detector has).
    const double surface_m = detection.range_m - shape->radius_m;
    if (surface_m < def_.min_range_m || surface_m > def_.max_range_m) continue;
    // For the logs and metrics only: the landmark of that colour whose silhouette overlaps the
    // blob's columns most (one cut by the image border counts), else -1 (a false detection).
    detection.truth_id = -1;
    double best_overlap_px = 0.0;
    for (const LandmarkDef& l : context.world.landmarks) {
      if (color_label(l) != blob.color) continue;
      const Vec2 offset = l.position_m - camera.position();
      const double distance = offset.norm();
      if (distance <= l.radius_m) continue;
      const double bearing = wrap_angle(std::atan2(offset.y(), offset.x()) - camera.theta);
      const double half_width = std::asin(l.radius_m / distance);
      if (std::abs(bearing) + half_width >= 0.5 * std::numbers::pi) continue;
      const double u_left = cx - f * std::tan(bearing + half_width);
      const double u_right = cx - f * std::tan(bearing - half_width);
      const double overlap = std::min<double>(u_right + 1.0, blob.end_column) -
                             std::max<double>(u_left - 1.0, blob.first_column);
      if (overlap > best_overlap_px) best_overlap_px = overlap, detection.truth_id = l.id;
    }
    reading.detections.push_back(std::move(detection));
  }
}

std::optional<ReadingData> PtzCameraSensor::measure(const SensorContext& context) {
  steer(context);
  PtzReading reading;
  reading.pan_rad = pan_rad_;
  reading.tilt_rad = def_.tilt_rad;
  reading.zoom = def_.zoom;
  if (context.robot.carried()) return reading;  // in the air: sees nothing useful
  const Pose2 base = sensor_pose(context.robot, def_.common.mount);
  const Pose2 camera{base.x, base.y, wrap_angle(base.theta + pan_rad_)};
  if (def_.mode == PtzCameraDef::Mode::kRendered) {
    look_rendered(context, camera, reading);
    return reading;
  }
  for (const LandmarkDef& landmark : context.world.landmarks) {
    std::optional<Detection> detection = look_at(context, camera, landmark);
    if (detection && rng().uniform() >= def_.miss_probability) {
      reading.detections.push_back(std::move(*detection));
    }
  }
  const int phantoms =
      context.world.landmarks.empty() ? 0 : poisson(rng(), def_.false_detections_per_frame);
  const double half_fov = std::atan(0.5 * def_.width_px / focal_px());
  for (int i = 0; i < phantoms; ++i) {
    const auto& pick = context.world.landmarks[static_cast<std::size_t>(
        rng().uniform() * static_cast<double>(context.world.landmarks.size()))];
    Detection phantom;
    phantom.color = color_label(pick);
    phantom.id = def_.report_ids ? pick.id : -1;
    phantom.truth_id = -1;
    const double range = rng().uniform(def_.min_range_m, def_.max_range_m);
    const double angle = rng().uniform(-half_fov, half_fov);
    const Pose2& believed = def_.common.reported_mount();
    const Pose2 camera_in_robot{believed.x, believed.y, believed.theta + pan_rad_};
    to_robot_frame(camera_in_robot, {range * std::cos(angle), range * std::sin(angle)},
                   phantom.range_m, phantom.bearing_rad);
    reading.detections.push_back(std::move(phantom));
  }
  return reading;
}

void PtzCameraSensor::apply_bias(ReadingData& data, double bias) const {
  for (Detection& d : std::get<PtzReading>(data).detections) d.range_m += bias;
}

// ---------------------------------------------------------------------------------------------
std::optional<ReadingData> OmniCameraSensor::measure(const SensorContext& context) {
  OmniReading reading;
  if (context.robot.carried()) return reading;
  const Pose2 sensor = sensor_pose(context.robot, def_.common.mount);
  const double c = std::cos(sensor.theta), s = std::sin(sensor.theta);
  for (const LandmarkDef& landmark : context.world.landmarks) {
    const Vec2 offset = landmark.position_m - sensor.position();
    const double range = offset.norm();
    if (range > def_.max_range_m || range < 1e-6) continue;
    if (context.rays.blocked(sensor.position(), landmark.position_m, context.robot.body())) {
      // The centre is hidden, but the ray may be stopped by the landmark's own surface only.
      const Vec2 d = offset / range;
      if (context.rays.cast(sensor.position(), d, range - landmark.radius_m, context.robot.body()) <
          range - landmark.radius_m - 1e-6) {
        continue;
      }
    }
    const Vec2 local{c * offset.x() + s * offset.y(), -s * offset.x() + c * offset.y()};
    const Vec2 along = local / range;
    const Vec2 across{-along.y(), along.x()};
    const double sigma_major = def_.sigma_major_m + def_.sigma_major_per_m * range;
    // One draw per statement: the operands of + are unsequenced and compilers draw them in
    // different orders, which made the readings depend on the compiler. Across first, as gcc drew
    // them (the outputs so far, and the pinned hashes, are gcc's).
    const double across_noise_m = rng().normal(0.0, def_.sigma_minor_m);
    const double along_noise_m = rng().normal(0.0, sigma_major);
    const Vec2 noisy = local + along_noise_m * along + across_noise_m * across;
    Detection detection;
    detection.color = color_label(landmark);
    detection.id = def_.report_ids ? landmark.id : -1;
    detection.truth_id = landmark.id;
    to_robot_frame(def_.common.reported_mount(), noisy, detection.range_m, detection.bearing_rad);
    reading.detections.push_back(std::move(detection));
  }
  return reading;
}

void OmniCameraSensor::apply_bias(ReadingData& data, double bias) const {
  for (Detection& d : std::get<OmniReading>(data).detections) d.range_m += bias;
}

// ---------------------------------------------------------------------------------------------
double RangeBearingSensor::correlated(const RangeBearingDef::Correlation& correlation,
                                      std::vector<TargetNoise>& state, std::size_t target,
                                      double t_s, double draw, double slow_draw) {
  const double share = correlation.slow_share;
  if (correlation.fast_s <= 0.0 && share <= 0.0) return draw;
  if (state.size() <= target) state.resize(target + 1);
  TargetNoise& s = state[target];
  // The first detection of a target, or one after a long gap, is a fresh draw (rho ~ 0).
  const auto rho = [&](double tau_s) {
    return s.last_t_s < 0.0 || !(tau_s > 0.0) ? 0.0 : std::exp(-(t_s - s.last_t_s) / tau_s);
  };
  const double rho_fast = rho(correlation.fast_s);
  s.fast = rho_fast * s.fast + std::sqrt(1.0 - rho_fast * rho_fast) * draw;
  if (share <= 0.0) {
    s.last_t_s = t_s;
    return s.fast;
  }
  const double rho_slow = rho(correlation.slow_s);
  s.slow = rho_slow * s.slow + std::sqrt(1.0 - rho_slow * rho_slow) * slow_draw;
  s.last_t_s = t_s;
  return std::sqrt(1.0 - share) * s.fast + std::sqrt(share) * s.slow;
}

std::optional<Detection> RangeBearingSensor::observe(const SensorContext& context,
                                                     const Pose2& sensor, const Vec2& position_m,
                                                     double radius_m, std::size_t target) {
  const Vec2 offset = position_m - sensor.position();
  const double range = offset.norm();
  if (range < def_.min_range_m || range > def_.max_range_m || range < 1e-6) return std::nullopt;
  const double bearing = wrap_angle(std::atan2(offset.y(), offset.x()) - sensor.theta);
  if (std::abs(bearing) > 0.5 * def_.fov_rad) return std::nullopt;
  // Line of sight as the omni camera checks it: the centre may be hidden by the target's own
  // surface only.
  if (context.rays.blocked(sensor.position(), position_m, context.robot.body()) &&
      context.rays.cast(sensor.position(), offset / range, range - radius_m, context.robot.body()) <
          range - radius_m - 1e-6) {
    return std::nullopt;
  }
  // Drawn only when misses are asked for: the other draws of a world without them stay put.
  if (const double miss = def_.miss_probability_at(range); miss > 0.0 && rng().uniform() < miss)
    return std::nullopt;
  // One draw per statement (see OmniCameraSensor::measure): range first, then bearing.
  // With noise_correlation_s, the same draws become the innovations of each target's process.
  const double range_draw = rng().normal(0.0, 1.0);
  const double bearing_draw = rng().normal(0.0, 1.0);
  // The slow part's own draws, only when there is one: other worlds keep their numbers.
  const bool slow = def_.noise_correlation_slow_share > 0.0 ||
                    def_.bearing_or_range_correlation().slow_share > 0.0;
  const double range_slow_draw = slow ? rng().normal(0.0, 1.0) : 0.0;
  const double bearing_slow_draw = slow ? rng().normal(0.0, 1.0) : 0.0;
  // The value reported before noise, in which the bias and spread lines are: the distance, or
  // the distance along the sensor's axis (depth mode; the loader keeps the field of view below
  // 180 deg, so it is positive). In distance mode it is `range` itself, bit for bit, so that a
  // world without the key keeps its outputs.
  const double reported =
      def_.range_model == RangeBearingDef::RangeModel::kDepth ? range * std::cos(bearing) : range;
  const double range_noise_m = (def_.sigma_range_m + def_.sigma_range_per_m * reported) *
                               correlated(def_.range_correlation(), range_noise_, target,
                                          context.t_s, range_draw, range_slow_draw);
  const double bearing_noise_rad =
      def_.sigma_bearing_rad * correlated(def_.bearing_or_range_correlation(), bearing_noise_,
                                          target, context.t_s, bearing_draw, bearing_slow_draw);
  // A range is never negative, however large the noise.
  const double measured_range = std::max(
      0.0, reported + def_.range_bias_m + def_.range_bias_per_m * reported + range_noise_m);
  const double measured_bearing = bearing + def_.bearing_bias_rad + bearing_noise_rad;
  Detection detection;
  to_robot_frame(
      def_.common.reported_mount(),
      {measured_range * std::cos(measured_bearing), measured_range * std::sin(measured_bearing)},
      detection.range_m, detection.bearing_rad);
  return detection;
}

Detection RangeBearingSensor::phantom(const SensorContext& context) {
  Detection detection;
  const auto& landmarks = context.world.landmarks;
  if (!landmarks.empty()) {
    const auto& pick = landmarks[std::min(
        landmarks.size() - 1,
        static_cast<std::size_t>(rng().uniform() * static_cast<double>(landmarks.size())))];
    detection.color = color_label(pick);
    detection.id = def_.report_ids ? pick.id : -1;
  }
  const double range = rng().uniform(def_.min_range_m, def_.max_range_m);
  const double bearing = rng().uniform(-0.5 * def_.fov_rad, 0.5 * def_.fov_rad);
  to_robot_frame(def_.common.reported_mount(),
                 {range * std::cos(bearing), range * std::sin(bearing)}, detection.range_m,
                 detection.bearing_rad);
  return detection;
}

std::optional<ReadingData> RangeBearingSensor::measure(const SensorContext& context) {
  RangeBearingReading reading;
  if (context.robot.carried()) return reading;  // in the air: sees nothing useful
  const Pose2 sensor = sensor_pose(context.robot, def_.common.mount);
  const std::size_t landmarks = context.world.landmarks.size();
  for (std::size_t l = 0; l < landmarks; ++l) {
    const LandmarkDef& landmark = context.world.landmarks[l];
    std::optional<Detection> detection =
        observe(context, sensor, landmark.position_m, landmark.radius_m, l);
    if (!detection) continue;
    detection->color = color_label(landmark);
    detection->id = def_.report_ids ? landmark.id : -1;
    detection->truth_id = landmark.id;
    reading.detections.push_back(std::move(*detection));
  }
  if (def_.sees_robots && context.robots != nullptr) {
    for (std::size_t i = 0; i < context.robots->size(); ++i) {
      const DiffDriveRobot& other = *(*context.robots)[i];
      if (&other == &context.robot || other.carried()) continue;
      std::optional<Detection> detection =
          observe(context, sensor, other.pose().position(), bounding_radius(other.def().footprint),
                  landmarks + i);
      if (!detection) continue;
      detection->target = DetectionTarget::kRobot;
      detection->id = def_.report_ids ? static_cast<int>(i) : -1;
      detection->truth_id = static_cast<int>(i);
      reading.detections.push_back(std::move(*detection));
    }
  }
  if (def_.false_detections > 0.0) {
    const int count = poisson(rng(), def_.false_detections);
    for (int i = 0; i < count; ++i) reading.detections.push_back(phantom(context));
  }
  return reading;
}

void RangeBearingSensor::apply_bias(ReadingData& data, double bias) const {
  for (Detection& d : std::get<RangeBearingReading>(data).detections) d.range_m += bias;
}

// ---------------------------------------------------------------------------------------------
std::optional<ReadingData> UltrasonicSensor::measure(const SensorContext& context) {
  UltrasonicReading reading;
  if (context.robot.carried()) return reading;
  const Pose2 body = context.robot.pose();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // The beacons this reading ranges: all, or the next beacons_per_reading in turn.
  const std::vector<BeaconDef>& beacons = context.world.beacons;
  std::vector<const BeaconDef*> polled;
  const std::size_t count =
      def_.beacons_per_reading > 0
          ? std::min(beacons.size(), static_cast<std::size_t>(def_.beacons_per_reading))
          : beacons.size();
  for (std::size_t i = 0; i < count; ++i) {
    polled.push_back(
        &beacons[def_.beacons_per_reading > 0 ? (next_beacon_ + i) % beacons.size() : i]);
  }
  if (def_.beacons_per_reading > 0 && !beacons.empty())
    next_beacon_ = (next_beacon_ + count) % beacons.size();
  for (std::size_t r = 0; r < def_.receivers.size(); ++r) {
    const UltrasonicDef::Receiver& receiver = def_.receivers[r];
    const Vec2 at = body.transform(receiver.position_m);
    for (const BeaconDef* polled_beacon : polled) {
      const BeaconDef& beacon = *polled_beacon;
      BeaconRange range;
      range.receiver = static_cast<int>(r);
      range.beacon_id = beacon.id;
      const double dz = beacon.height_m - receiver.height_m;
      const double distance = std::sqrt((beacon.position_m - at).squaredNorm() + dz * dz);
      // What the system reports for the direct path, its systematic error included.
      const double reported = distance + def_.range_bias_m + def_.range_bias_per_m * distance;
      if (distance > def_.max_range_m) {
        range.range_m = nan;
        range.truth_status = RangeStatus::kOutOfRange;
      } else if (context.rays.blocked(at, receiver.height_m, beacon.position_m, beacon.height_m,
                                      context.robot.body())) {
        if (rng().uniform() < def_.nlos_probability) {
          const double extra = reflected_extra_m();  // drawn before the noise: sequenced
          range.range_m = reported + extra + rng().normal(0.0, def_.sigma_m);
          range.truth_status = RangeStatus::kNonLineOfSight;
        } else {
          range.range_m = nan;
          range.truth_status = RangeStatus::kDropped;
        }
      } else if (rng().uniform() < def_.dropout_probability) {
        range.range_m = nan;
        range.truth_status = RangeStatus::kDropped;
      } else if (def_.outlier_probability > 0.0 && rng().uniform() < def_.outlier_probability) {
        // Drawn only when asked for: worlds without injected errors keep their random streams.
        const double extra = reflected_extra_m();  // drawn before the noise: sequenced
        range.range_m = reported + extra + rng().normal(0.0, def_.sigma_m);
        range.truth_status = RangeStatus::kNonLineOfSight;
      } else {
        range.range_m = reported + rng().normal(0.0, def_.sigma_m);
        range.truth_status = RangeStatus::kLineOfSight;
      }
      reading.ranges.push_back(range);
    }
  }
  return reading;
}

double UltrasonicSensor::reflected_extra_m() {
  // Longer by at least the minimum, exponentially distributed beyond.
  return def_.nlos_bias_min_m -
         (def_.nlos_bias_mean_m - def_.nlos_bias_min_m) * std::log(1.0 - rng().uniform());
}

void UltrasonicSensor::apply_bias(ReadingData& data, double bias) const {
  for (BeaconRange& r : std::get<UltrasonicReading>(data).ranges) r.range_m += bias;
}

// ---------------------------------------------------------------------------------------------
double laser_beam_angle(int i, int beams, double fov_rad) {
  // A full circle has no duplicate beam at +-180 deg: beams are spaced 360 / beams apart.
  if (fov_rad >= 2.0 * std::numbers::pi - 1e-9) return -std::numbers::pi + fov_rad * i / beams;
  return beams <= 1 ? 0.0 : -0.5 * fov_rad + fov_rad * i / (beams - 1);
}

LaserSensor::LaserSensor(const LaserDef& def, RandomStream rng)
    : Sensor(SensorKind::kLaser, def.common, rng), def_(def) {
  for (int i = 0; i < def_.beams; ++i) {
    const double angle = laser_beam_angle(i, def_.beams, def_.fov_rad);
    directions_.emplace_back(std::cos(angle), std::sin(angle));
    angles_rad_.push_back(angle);
  }
}

std::optional<ReadingData> LaserSensor::measure(const SensorContext& context) {
  if (context.robot.carried()) return std::nullopt;
  const Pose2 sensor = sensor_pose(context.robot, def_.common.mount);
  const double c = std::cos(sensor.theta), s = std::sin(sensor.theta);
  LaserScan scan;
  scan.ranges_m.resize(directions_.size());
  context.rays.fan_candidates(sensor.position(), sensor.theta, angles_rad_, def_.max_range_m,
                              context.robot.body(), candidates_);
  for (std::size_t i = 0; i < directions_.size(); ++i) {
    const Vec2& local = directions_[i];
    const Vec2 direction{c * local.x() - s * local.y(), s * local.x() + c * local.y()};
    const double hit =
        context.rays.cast(sensor.position(), direction, def_.max_range_m, candidates_.of(i));
    double range = def_.max_range_m;
    const double u = rng().uniform();
    if (u < def_.p_random) {
      range = rng().uniform(0.0, def_.max_range_m);
    } else if (u < def_.p_random + def_.p_max) {
      range = def_.max_range_m;
    } else if (u < def_.p_random + def_.p_max + def_.p_short) {
      // Something unmapped in front: exponential, only if shorter than the true hit.
      const double phantom = -std::log(1.0 - rng().uniform()) / def_.lambda_short;
      range = std::min(phantom, std::min(hit, def_.max_range_m));
    } else if (hit <= def_.max_range_m) {
      range = hit + rng().normal(0.0, def_.sigma_m);
    }
    scan.ranges_m[i] = static_cast<float>(std::clamp(range, def_.min_range_m, def_.max_range_m));
  }
  return scan;
}

void LaserSensor::apply_bias(ReadingData& data, double bias) const {
  for (float& r : std::get<LaserScan>(data).ranges_m) r += static_cast<float>(bias);
}

}  // namespace locsim
