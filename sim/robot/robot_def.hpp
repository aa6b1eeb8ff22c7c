// What a differential-drive robot is made of. Defaults describe a small indoor research robot
// (Pioneer-like): 10 kg, 0.35 m wheel base, 5 cm wheels.
#pragma once

#include <algorithm>
#include <string>
#include <vector>

#include "sim/common/errors.hpp"
#include "sim/common/math.hpp"
#include "sim/common/range.hpp"
#include "sim/sensors/sensor_defs.hpp"

namespace locsim {

/// The outline of a body seen from above, in the body frame (x forward, y left).
/// A footprint's shape has a mass (robots) and takes part in contacts: below a centimetre Box2D's
/// float maths (its 5 mm slop, its assert that a polygon's area exceeds 1.2e-7 m²) break down.
struct FootprintDef {
  enum class Kind { kCircle, kBox, kPolygon };
  Kind kind = Kind::kCircle;
  double radius_m = 0.2;  // kCircle [m]
  static constexpr Range kRadiusRange{0.01, 50.0, "m"};
  Vec2 size_m{0.4, 0.3};  // kBox: length along x, width along y [m]
  static constexpr Range kSizeRange{0.02, 100.0, "m"};
  // kPolygon: convex, counter-clockwise, <= 8 vertices kMinPointSpacingM apart, within
  // kBodyFrameRange, at least kMinPolygonAreaM2 [m]
  std::vector<Vec2> points_m;
  static constexpr double kMinPolygonAreaM2 = 1e-4;  // [m²]
};

/// Radius of the smallest circle about the body origin that holds the footprint. [m]
inline double bounding_radius(const FootprintDef& footprint) {
  switch (footprint.kind) {
    case FootprintDef::Kind::kCircle:
      return footprint.radius_m;
    case FootprintDef::Kind::kBox:
      return 0.5 * footprint.size_m.norm();
    case FootprintDef::Kind::kPolygon: {
      double radius = 0.0;
      for (const Vec2& p : footprint.points_m) radius = std::max(radius, p.norm());
      return radius;
    }
  }
  return 0.0;
}

/// How the base's motion follows its body-velocity command, before the wheels' speed controllers
/// (ramp, torque, floor): the command acts after a dead time, through a first-order lag per
/// channel, scaled by a gain. A real base's controller, bus and motor lag; a base that travels a
/// few per cent less than it is told (MRCLAM's robots: dead time 0.04-0.14 s, time constants
/// 0.10-0.40 s, gains 0.90-0.99; docs/reports/sim_to_real). An odometry that reports the command
/// (EncodersDef::Measures::kCommand) then leads the motion, with errors correlated over the lag.
/// The defaults pass the command through unchanged.
struct CommandResponseDef {
  double dead_time_s = 0.0;  // the base acts on a command this long after it is given [s]
  static constexpr Range kDeadTimeRange{0.0, 10.0, "s"};
  double time_constant_v_s = 0.0;      // first-order lag of the forward speed [s]
  double time_constant_omega_s = 0.0;  // first-order lag of the turn rate [s]
  static constexpr Range kTimeConstantRange{0.0, 100.0, "s"};
  double gain_v = 1.0;      // forward speed reached per commanded [-]
  double gain_omega = 1.0;  // turn rate reached per commanded [-]
  static constexpr Range kGainRange{0.01, 100.0, ""};
  // The gains wander about gain_v and gain_omega, as (1 + g) times them, each g a first-order
  // Gauss-Markov process of this standard deviation [-] (sdk::GainWander: a floor, a load, a
  // tyre that make the base drive a few per cent more or less for seconds; MRCLAM's about 0.15
  // over 1-3 s) and time constant [s], drawn from the robot's own stream ("response/" + name).
  double gain_wander_v = 0.0;
  double gain_wander_omega = 0.0;
  static constexpr Range kGainWanderRange{0.0, 10.0, ""};
  double gain_wander_correlation_s = 1.0;
  static constexpr Range kGainWanderCorrelationRange{1e-3, 1e6, "s"};
  bool wanders() const { return gain_wander_v > 0.0 || gain_wander_omega > 0.0; }
  bool identity() const {
    return dead_time_s == 0.0 && time_constant_v_s == 0.0 && time_constant_omega_s == 0.0 &&
           gain_v == 1.0 && gain_omega == 1.0 && !wanders();
  }
};

/// How the body slides sideways on its wheels. A diff-drive's kinematics holds the body to its
/// heading; on grass, gravel or soft tyres it is not: the body travels at a small angle to its
/// heading, slides outward in a turn as the tyres give under the lateral acceleration v ω, and
/// drifts from side to side for a second at a time. Measured on CMU Plaza's lawnmower (RTK-GPS
/// against its own heading, docs/reports/sim_to_real): a wander of 0.047 m^1/2 over 0.2-0.8 s at
/// 1 and 3.5 m/s alike, 0.079 s of cornering compliance, a crab of -0.9 degrees; MRCLAM's indoor
/// robots under Vicon: 0.012 m^1/2, too little to move a filter.
/// The wheels' contact takes the slide as the lateral velocity it gives the body (still within
/// the friction circle); the encoders do not count it. The defaults hold the body to its heading.
struct SideSlipDef {
  // The body travels at this angle to its heading, to the left positive: v tan(crab) sideways.
  double crab_angle_rad = 0.0;  // [rad]
  static constexpr Range kCrabAngleRange{deg_to_rad(-30.0), deg_to_rad(30.0), "rad"};
  // The slide in a turn: -c v omega sideways (outward for c > 0), the tyres' cornering
  // compliance over their grip. [s]
  double cornering_compliance_s = 0.0;
  static constexpr Range kCorneringComplianceRange{-10.0, 10.0, "s"};
  // The wander: a first-order Gauss-Markov lateral velocity of standard deviation
  // k sqrt(|v| / (2 tau)), so that the sideways drift's variance grows by k^2 per metre travelled
  // (the wheel noise's k, across the heading) and nothing happens at rest; drawn from the robot's
  // own stream ("slip/" + name). [m^1/2], [s]
  double wander_k = 0.0;
  static constexpr Range kWanderKRange{0.0, 10.0, "m^1/2"};
  double wander_correlation_s = 1.0;
  static constexpr Range kWanderCorrelationRange{1e-3, 1e6, "s"};
  bool any() const {
    return crab_angle_rad != 0.0 || cornering_compliance_s != 0.0 || wander_k > 0.0;
  }
};

struct RobotDef {
  std::string name = "robot";
  FootprintDef footprint;
  double mass_kg = 10.0;  // whole robot [kg]
  static constexpr Range kMassRange{0.01, 1e5, "kg"};
  double wheel_base_m = 0.35;  // distance between the wheel contact points [m]
  static constexpr Range kWheelBaseRange{0.01, 100.0, "m"};
  double wheel_radius_m = 0.05;        // nominal radius the robot believes in (odometry) [m]
  double wheel_radius_left_m = 0.05;   // true left radius; != nominal is a systematic error [m]
  double wheel_radius_right_m = 0.05;  // true right radius [m]
  static constexpr Range kWheelRadiusRange{0.001, 10.0, "m"};
  double wheel_inertia_kgm2 = 0.002;  // wheel plus reflected rotor inertia, per wheel [kg m²]
  static constexpr Range kWheelInertiaRange{1e-6, 1000.0, "kg m^2"};
  double max_wheel_speed_radps = 20.0;  // motor speed limit [rad/s]
  static constexpr Range kWheelSpeedRange{0.01, 10000.0, "rad/s"};
  double max_wheel_accel_radps2 = 30.0;  // speed controller's ramp limit [rad/s²]
  static constexpr Range kWheelAccelRange{0.01, 1e6, "rad/s^2"};
  double max_wheel_torque_nm = 5.0;  // motor torque limit at the wheel [N m]
  static constexpr Range kWheelTorqueRange{0.001, 1e6, "N m"};
  double drive_load_fraction = 0.8;  // share of the weight on the two drive wheels [-]
  static constexpr Range kDriveLoadRange = kProbabilityRange;
  double height_m = 0.4;  // top of the body; blocks ultrasound below it [m]
  static constexpr Range kHeightRange = kBodyHeightRange;
  CommandResponseDef command_response;  // how the motion follows the command
  SideSlipDef side_slip;                // how the body slides off its heading
  Pose2 start;           // initial true pose in the world: kWorldCoordinateRange, any heading
  SensorsDef sensors;    // absent sensors are off
  SourceLocation where;  // of the robot's entry, for messages
  std::string key_path;  // of the robot's entry, e.g. "robots[0]", for messages
};

/// The wheel base the robot believes in: its encoders' odometry and the localizers are told this
/// one; `wheel_base_m` is the true one the physics drives with. [m]
inline double believed_wheel_base_m(const RobotDef& robot) {
  return robot.sensors.encoders
             ? robot.sensors.encoders->odometry_wheel_base_m.value_or(robot.wheel_base_m)
             : robot.wheel_base_m;
}

}  // namespace locsim
