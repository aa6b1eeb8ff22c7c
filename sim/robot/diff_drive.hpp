// A differential-drive robot in the Box2D world.
//
// Each wheel is a motor-driven rotation (what encoders count) that pushes the body through a
// friction-limited contact with the floor. The contact force is whatever brings the wheel's
// contact point to roll without slipping this step, capped by the friction circle |F| <= mu N;
// when the cap binds, the wheel and the body part ways: that is slip. The motor tracks the
// commanded wheel speed under an acceleration ramp and a torque limit, against the contact
// force's reaction, so a wheel on ice spins up while the body barely moves and a robot pushing a
// wall keeps its wheels turning (when mu N r is below the motor's torque limit).
#pragma once

#include <box2d/box2d.h>

#include <deque>
#include <optional>
#include <utility>

#include "sim/common/random.hpp"
#include "sim/robot/robot_def.hpp"
#include "sim/world/physics_world.hpp"

namespace locsim {

struct WheelState {
  double radius_m = 0.05;    // true radius [m]
  double angle_rad = 0.0;    // cumulative rotation, what an ideal encoder counts [rad]
  double speed_radps = 0.0;  // [rad/s]
  double traction_n = 0.0;   // last longitudinal floor force on the robot [N]
  bool slipping = false;     // the friction cap bound in the last step
};

class DiffDriveRobot {
 public:
  DiffDriveRobot(const RobotDef& def, PhysicsWorld& world, int index);
  DiffDriveRobot(const DiffDriveRobot&) = delete;
  DiffDriveRobot& operator=(const DiffDriveRobot&) = delete;

  const RobotDef& def() const { return def_; }
  const std::string& name() const { return def_.name; }

  /// Body velocity command, converted to wheel speeds with the nominal geometry, through the
  /// robot's command_response (dead time, lag, gain; from the next apply_drive on when it is not
  /// the identity). [m/s, rad/s]
  void command(double v_mps, double w_radps);
  /// The stream the command response's gain wander draws from (Simulation gives each robot
  /// its own, derived from the run's seed); needed only when the response wanders.
  void seed_response(RandomStream stream);
  /// The stream the side slip's wander draws from (Simulation: "slip/" + name); needed only
  /// when the robot's side_slip wanders.
  void seed_side_slip(RandomStream stream);
  /// The latest command as given (what a base that logs its command reports). [m/s], [rad/s]
  double given_v_mps() const { return given_v_mps_; }
  double given_omega_radps() const { return given_w_radps_; }
  /// Motor and floor forces for the coming step. Call before the world steps.
  void apply_drive(double dt_s, const FloorFriction& floor);

  Pose2 pose() const;
  Vec2 velocity_mps() const;  // of the body origin, world frame
  double yaw_rate_radps() const;
  const WheelState& left() const { return wheels_[0]; }
  const WheelState& right() const { return wheels_[1]; }

  /// Kidnapping: off the floor (no collisions), wheels stopped and not counting.
  void lift();
  /// Puts the robot down at `pose`, at rest.
  void put_down(const Pose2& pose);
  bool carried() const { return carried_; }
  /// An impulse at the body's centre of mass (world frame). [N s, N m s]
  void push(const Vec2& impulse_ns, double angular_impulse_nms);

  b2Body* body() { return body_; }
  const b2Body* body() const { return body_; }
  const b2Shape& shape() const;

 private:
  RobotDef def_;
  double gravity_mps2_;
  b2Body* body_ = nullptr;  // owned by the b2World
  b2CircleShape circle_;
  b2PolygonShape polygon_;
  WheelState wheels_[2];  // left, right
  /// Wheel speed targets for a body velocity, scaled alike when one exceeds the motor's limit.
  void set_wheel_targets(double v_mps, double w_radps);
  /// One step of the command response: the command given dead_time_s ago, through the lag.
  void advance_response(double dt_s);
  /// The lateral velocity the wheels' contact gives the body this step (SideSlipDef), at the
  /// body's forward speed and turn rate. [m/s]
  double side_slip_mps(double dt_s, double forward_mps, double w_radps);

  double commanded_radps_[2] = {0.0, 0.0};
  double given_v_mps_ = 0.0, given_w_radps_ = 0.0;
  // The command response's state: commands given but not yet acting (oldest first; the robot
  // was at rest before its first), and the lag's output. [m/s], [rad/s]
  std::deque<std::pair<double, double>> pending_;
  double acting_v_mps_ = 0.0, acting_w_radps_ = 0.0;
  std::optional<RandomStream> wander_rng_;
  double wander_v_ = 0.0, wander_omega_ = 0.0;  // the gains' errors g
  std::optional<RandomStream> slip_rng_;
  double slip_wander_ = 0.0;  // the side slip's wander, unit standard deviation [-]
  double slip_dt_s_ = 0.0, slip_tan_crab_ = 0.0, slip_phi_ = 0.0, slip_renewal_ = 0.0;
  bool carried_ = false;
};

}  // namespace locsim
