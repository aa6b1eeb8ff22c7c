// The sensor models. docs/sensors.md states each one's equations and parameters.
#pragma once

#include "sim/sensors/sensor.hpp"

namespace locsim {

/// Counts wheel rotation (slip, collisions and kidnaps show as on a real robot) with paper 002's
/// distance-proportional random error, and dead-reckons the odometry pose from the counts; it
/// reports what EncodersDef::reports names (the velocity: the counted travel over the period).
class EncoderSensor final : public Sensor {
 public:
  EncoderSensor(const EncodersDef& def, const RobotDef& robot, RandomStream rng);
  bool supports_bias() const override { return false; }
  /// Measuring the command: integrates the rotation it asks of the nominal wheels.
  void on_physics_step(const SensorContext& context) override;

 protected:
  std::optional<ReadingData> measure(const SensorContext& context) override;
  void apply_bias(ReadingData&, double) const override {}

 private:
  EncodersDef def_;
  double nominal_radius_m_;
  double wheel_base_m_;
  double commanded_angle_rad_[2] = {0.0, 0.0};  // Measures::kCommand: asked of the wheels
  double true_angle_rad_[2] = {0.0, 0.0};       // wheel rotation at the last sample
  double counted_angle_rad_[2] = {0.0, 0.0};    // what the encoder has counted, with its error
  std::int64_t ticks_[2] = {0, 0};
  double gyro_turn_rad_ = 0.0;             // Heading::kGyro: the body's turn since the last sample
  std::optional<double> gyro_bias_radps_;  // drawn at the first sample
  Pose2 odometry_;
  double last_sample_s_ = 0.0;  // for the velocity over the last period [s]
};

/// Yaw rate and specific force at the mount, averaged over each sample interval (the IMU's
/// anti-alias filter), with white noise, a random-walk bias and saturation.
class ImuSensor final : public Sensor {
 public:
  ImuSensor(const ImuDef& def, RandomStream rng);
  void on_physics_step(const SensorContext& context) override;

 protected:
  std::optional<ReadingData> measure(const SensorContext& context) override;
  void apply_bias(ReadingData& data, double bias) const override;

 private:
  ImuDef def_;
  bool initialised_ = false;
  bool was_carried_ = false;
  Vec2 previous_velocity_{0.0, 0.0};  // of the mount point, world frame [m/s]
  double sum_yaw_rate_ = 0.0;
  Vec2 sum_accel_{0.0, 0.0};
  int steps_ = 0;
  double gyro_bias_ = 0.0;
  Vec2 accel_bias_{0.0, 0.0};
};

/// Landmark detections from a pinhole colour camera on a pan unit: bearing from the blob's
/// column centre, distance from its height in rows (the landmark's height is known), both from
/// pixel-quantised, noisy edges; occluded columns are cut out of the blob.
class PtzCameraSensor final : public Sensor {
 public:
  PtzCameraSensor(const PtzCameraDef& def, const PanPolicyDef& policy, RandomStream rng);
  double pan_rad() const { return pan_rad_; }
  double focal_px() const;
  const PtzCameraDef& def() const { return def_; }
  /// The renderer for mode: rendered (required before the first sample in that mode).
  void set_imager(std::shared_ptr<LandmarkImager> imager) { imager_ = std::move(imager); }

 protected:
  std::optional<ReadingData> measure(const SensorContext& context) override;
  void apply_bias(ReadingData& data, double bias) const override;

 private:
  void steer(const SensorContext& context);
  std::optional<Detection> look_at(const SensorContext& context, const Pose2& camera,
                                   const LandmarkDef& landmark);
  /// mode: rendered: the blobs of the rendered image, back-projected.
  void look_rendered(const SensorContext& context, const Pose2& camera, PtzReading& reading);
  /// A detection from a blob's centre column and top and bottom rows, knowing the landmark's
  /// height (and radius).
  Detection back_project(double u_centre, double top_row, double bottom_row,
                         const LandmarkDef& landmark) const;

  PtzCameraDef def_;
  PanPolicyDef policy_;
  double pan_rad_ = 0.0;
  double last_steer_s_ = 0.0;
  int sweep_direction_ = 1;
  std::shared_ptr<LandmarkImager> imager_;
};

/// 360 deg range-bearing to landmarks with a Gaussian in the local frame (paper 002).
class OmniCameraSensor final : public Sensor {
 public:
  OmniCameraSensor(const OmniCameraDef& def, RandomStream rng)
      : Sensor(SensorKind::kOmniCamera, def.common, rng), def_(def) {}

 protected:
  std::optional<ReadingData> measure(const SensorContext& context) override;
  void apply_bias(ReadingData& data, double bias) const override;

 private:
  OmniCameraDef def_;
};

/// Range and bearing to the landmarks (and optionally the other robots) in a field of view and
/// range interval, in line of sight: Gaussian noise in range (spread and bias growing with range)
/// and bearing, missed and false detections (a barcode camera as MRCLAM's robots carry).
class RangeBearingSensor final : public Sensor {
 public:
  RangeBearingSensor(const RangeBearingDef& def, RandomStream rng)
      : Sensor(SensorKind::kRangeBearing, def.common, rng), def_(def) {}

 protected:
  std::optional<ReadingData> measure(const SensorContext& context) override;
  void apply_bias(ReadingData& data, double bias) const override;

 private:
  /// The target at `position_m` (of radius `radius_m`, on `body`) as measured from `sensor`, or
  /// nothing when it is outside the field of view or range, hidden, or missed.
  std::optional<Detection> observe(const SensorContext& context, const Pose2& sensor,
                                   const Vec2& position_m, double radius_m, std::size_t target);
  /// A false detection, uniform over the field of view and range interval.
  Detection phantom(const SensorContext& context);
  /// Per target (landmarks, then robots): the time of its last noise and its processes' values.
  struct TargetNoise {
    double last_t_s = -1.0, fast = 0.0, slow = 0.0;
  };
  /// Standard normal noise of a target's detection at `t_s`, correlated with its previous one
  /// as `correlation` says (the range's, or the bearing's); `draw` and `slow_draw` are this
  /// detection's fresh N(0, 1) for each process.
  static double correlated(const RangeBearingDef::Correlation& correlation,
                           std::vector<TargetNoise>& state, std::size_t target, double t_s,
                           double draw, double slow_draw);
  RangeBearingDef def_;
  std::vector<TargetNoise> range_noise_, bearing_noise_;
};

/// Time-of-flight ranges from each receiver to each fixed beacon; blocked lines of sight give a
/// longer non-line-of-sight range or nothing (paper 003's multi-path effect).
class UltrasonicSensor final : public Sensor {
 public:
  UltrasonicSensor(const UltrasonicDef& def, RandomStream rng)
      : Sensor(SensorKind::kUltrasonic, def.common, rng), def_(def) {}

 protected:
  std::optional<ReadingData> measure(const SensorContext& context) override;
  void apply_bias(ReadingData& data, double bias) const override;

 private:
  double reflected_extra_m();  // a reflected path's extra length [m]
  UltrasonicDef def_;
  std::size_t next_beacon_ = 0;  // beacons_per_reading: the first beacon of the next reading
};

/// Beams against everything (people included) with the beam-model mixture.
class LaserSensor final : public Sensor {
 public:
  LaserSensor(const LaserDef& def, RandomStream rng);

 protected:
  std::optional<ReadingData> measure(const SensorContext& context) override;
  void apply_bias(ReadingData& data, double bias) const override;

 private:
  LaserDef def_;
  std::vector<Vec2> directions_;    // unit beam directions in the mount frame
  std::vector<double> angles_rad_;  // their angles, increasing
  FanCandidates candidates_;        // the moving bodies each beam can hit, scan by scan
};

/// Angle of beam `i` of `beams` over `fov_rad`, centred on 0.
double laser_beam_angle(int i, int beams, double fov_rad);

}  // namespace locsim
