#include "sim/robot/diff_drive.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace locsim {

namespace {
double area(const FootprintDef& footprint) {
  switch (footprint.kind) {
    case FootprintDef::Kind::kCircle:
      return std::numbers::pi * footprint.radius_m * footprint.radius_m;
    case FootprintDef::Kind::kBox:
      return footprint.size_m.x() * footprint.size_m.y();
    case FootprintDef::Kind::kPolygon: {
      double a = 0.0;
      const auto& p = footprint.points_m;
      for (std::size_t i = 0; i < p.size(); ++i) a += cross(p[i], p[(i + 1) % p.size()]);
      return 0.5 * std::abs(a);
    }
  }
  return 1.0;
}
}  // namespace

DiffDriveRobot::DiffDriveRobot(const RobotDef& def, PhysicsWorld& world, int index)
    : def_(def), gravity_mps2_(world.physics().gravity_mps2) {
  b2BodyDef body_def;
  body_def.type = b2_dynamicBody;
  body_def.position = to_b2(def.start.position());
  body_def.angle = static_cast<float>(def.start.theta);
  body_def.allowSleep = false;
  body_def.userData.pointer = encode_tag({BodyKind::kRobot, index});
  body_ = world.box2d().CreateBody(&body_def);
  b2FixtureDef fixture;
  fixture.shape = &make_shape(def.footprint, circle_, polygon_);
  fixture.density = static_cast<float>(def.mass_kg / area(def.footprint));
  fixture.friction = 0.3f;     // body against walls and people, not the floor
  fixture.restitution = 0.1f;  // bumpers give a little
  body_->CreateFixture(&fixture);
  wheels_[0].radius_m = def.wheel_radius_left_m;
  wheels_[1].radius_m = def.wheel_radius_right_m;
}

const b2Shape& DiffDriveRobot::shape() const {
  return def_.footprint.kind == FootprintDef::Kind::kCircle ? static_cast<const b2Shape&>(circle_)
                                                            : static_cast<const b2Shape&>(polygon_);
}

void DiffDriveRobot::command(double v_mps, double w_radps) {
  given_v_mps_ = v_mps;
  given_w_radps_ = w_radps;
  // The identity response acts at once, as a robot without one always did.
  if (def_.command_response.identity()) set_wheel_targets(v_mps, w_radps);
}

void DiffDriveRobot::seed_response(RandomStream stream) {
  const CommandResponseDef& r = def_.command_response;
  wander_rng_.emplace(stream);
  // The gains start from their stationary distribution.
  wander_v_ = r.gain_wander_v * wander_rng_->normal();
  wander_omega_ = r.gain_wander_omega * wander_rng_->normal();
}

void DiffDriveRobot::seed_side_slip(RandomStream stream) {
  slip_rng_.emplace(stream);
  slip_wander_ = slip_rng_->normal();  // from its stationary distribution
}

double DiffDriveRobot::side_slip_mps(double dt_s, double forward_mps, double w_radps) {
  const SideSlipDef& d = def_.side_slip;
  // The step's constants, computed once (the physics steps at a fixed rate).
  if (dt_s != slip_dt_s_) {
    slip_dt_s_ = dt_s;
    slip_tan_crab_ = std::tan(d.crab_angle_rad);
    slip_phi_ = std::exp(-dt_s / d.wander_correlation_s);
    slip_renewal_ = std::sqrt(1.0 - slip_phi_ * slip_phi_);
  }
  double slip_mps = forward_mps * (slip_tan_crab_ - d.cornering_compliance_s * w_radps);
  if (d.wander_k > 0.0) {
    if (!slip_rng_) throw std::logic_error("a wandering side slip needs seed_side_slip");
    slip_wander_ = slip_phi_ * slip_wander_ + slip_renewal_ * slip_rng_->normal();
    // sigma^2 = k^2 |v| / (2 tau): the drift's variance, 2 sigma^2 tau per second, is k^2 a metre.
    slip_mps += d.wander_k * std::sqrt(std::abs(forward_mps) / (2.0 * d.wander_correlation_s)) *
                slip_wander_;
  }
  return slip_mps;
}

void DiffDriveRobot::advance_response(double dt_s) {
  const CommandResponseDef& r = def_.command_response;
  if (r.wanders()) {
    if (!wander_rng_) throw std::logic_error("a wandering command response needs seed_response");
    const double phi = std::exp(-dt_s / r.gain_wander_correlation_s);
    const double renewal = std::sqrt(1.0 - phi * phi);
    wander_v_ = phi * wander_v_ + r.gain_wander_v * renewal * wander_rng_->normal();
    wander_omega_ = phi * wander_omega_ + r.gain_wander_omega * renewal * wander_rng_->normal();
  }
  pending_.emplace_back(given_v_mps_, given_w_radps_);
  // The dead time in whole steps: the physics steps at a fixed rate.
  const auto delay_steps = static_cast<std::size_t>(std::lround(r.dead_time_s / dt_s));
  std::pair<double, double> acting{0.0, 0.0};
  if (pending_.size() > delay_steps) {
    acting = pending_.front();
    pending_.pop_front();
  }
  // Exact for a command held over the step.
  const auto share = [dt_s](double tau_s) {
    return tau_s > 0.0 ? -std::expm1(-dt_s / tau_s) : 1.0;
  };
  const double gain_v = r.gain_v * (1.0 + wander_v_);
  const double gain_omega = r.gain_omega * (1.0 + wander_omega_);
  acting_v_mps_ += share(r.time_constant_v_s) * (gain_v * acting.first - acting_v_mps_);
  acting_w_radps_ +=
      share(r.time_constant_omega_s) * (gain_omega * acting.second - acting_w_radps_);
  set_wheel_targets(acting_v_mps_, acting_w_radps_);
}

void DiffDriveRobot::set_wheel_targets(double v_mps, double w_radps) {
  const double half_base = 0.5 * def_.wheel_base_m;
  double left = (v_mps - w_radps * half_base) / def_.wheel_radius_m;
  double right = (v_mps + w_radps * half_base) / def_.wheel_radius_m;
  // Scale both wheels alike so that a saturated command keeps its curvature.
  const double largest = std::max(std::abs(left), std::abs(right));
  if (largest > def_.max_wheel_speed_radps) {
    const double scale = def_.max_wheel_speed_radps / largest;
    left *= scale;
    right *= scale;
  }
  commanded_radps_[0] = left;
  commanded_radps_[1] = right;
}

void DiffDriveRobot::apply_drive(double dt_s, const FloorFriction& floor) {
  // The base's controller runs on while the robot is carried.
  if (!def_.command_response.identity()) advance_response(dt_s);
  if (carried_) return;
  const double mass = body_->GetMass();
  const double inertia = body_->GetInertia() - mass * body_->GetLocalCenter().LengthSquared();
  const Vec2 center = from_b2(body_->GetWorldCenter());
  const b2Transform& transform = body_->GetTransform();
  const Vec2 forward{transform.q.c, transform.q.s};
  const Vec2 lateral{-forward.y(), forward.x()};
  const Vec2 origin = from_b2(transform.p);
  const double normal_load_n = mass * gravity_mps2_ * def_.drive_load_fraction / 2.0;
  const double half_base = 0.5 * def_.wheel_base_m;

  struct Contact {
    Vec2 arm;             // from the centre of mass to the wheel's contact point [m]
    double surface_mps;   // the wheel rim's speed if the motor reaches its target [m/s]
    double target_radps;  // wheel speed after this step's ramp [rad/s]
    double max_impulse;   // friction circle radius for this step [N s]
    double mass_forward;  // effective mass at the contact along forward and lateral [kg]
    double mass_lateral;
    Vec2 impulse{0.0, 0.0};
  } contacts[2];
  for (int i = 0; i < 2; ++i) {
    WheelState& wheel = wheels_[i];
    const double ramp = def_.max_wheel_accel_radps2 * dt_s;
    const double target =
        wheel.speed_radps + std::clamp(commanded_radps_[i] - wheel.speed_radps, -ramp, ramp);
    const Vec2 contact_point = origin + (i == 0 ? half_base : -half_base) * lateral;
    const Vec2 arm = contact_point - center;
    const double arm_f = cross(arm, forward), arm_l = cross(arm, lateral);
    contacts[i] = Contact{arm,
                          target * wheel.radius_m,
                          target,
                          floor.at(contact_point) * normal_load_n * dt_s,
                          1.0 / (1.0 / mass + arm_f * arm_f / inertia),
                          1.0 / (1.0 / mass + arm_l * arm_l / inertia)};
  }

  // Sequential impulses (as Box2D's own solver): each wheel's contact asks for the impulse that
  // makes its contact point roll without slip (rim speed forward, the side slip sideways),
  // accumulated and clamped to the friction circle. A few passes settle the coupling through the
  // rotation.
  Vec2 v = from_b2(body_->GetLinearVelocity());  // of the centre of mass
  double w = body_->GetAngularVelocity();
  // What the floor lets the body slide sideways: the contacts' lateral target (0: none, the
  // bits of a robot without side slip unchanged).
  const double slip_mps = def_.side_slip.any() ? side_slip_mps(dt_s, v.dot(forward), w) : 0.0;
  for (int pass = 0; pass < 8; ++pass) {
    double largest_change = 0.0;
    for (Contact& c : contacts) {
      const Vec2 point_velocity = v + w * Vec2{-c.arm.y(), c.arm.x()};
      const double d_forward = -(point_velocity.dot(forward) - c.surface_mps) * c.mass_forward;
      const double d_lateral = -(point_velocity.dot(lateral) - slip_mps) * c.mass_lateral;
      Vec2 accumulated = c.impulse + d_forward * forward + d_lateral * lateral;
      const double magnitude_sq = accumulated.squaredNorm();
      if (magnitude_sq > c.max_impulse * c.max_impulse) {
        accumulated *= c.max_impulse / std::sqrt(magnitude_sq);
      }
      const Vec2 delta = accumulated - c.impulse;
      c.impulse = accumulated;
      v += delta / mass;
      w += cross(c.arm, delta) / inertia;
      largest_change = std::max(largest_change, delta.cwiseAbs().maxCoeff());
    }
    if (largest_change < 1e-9) break;  // converged (N s)
  }

  for (int i = 0; i < 2; ++i) {
    Contact& c = contacts[i];
    WheelState& wheel = wheels_[i];
    const Vec2 force = c.impulse / dt_s;
    body_->ApplyForce(to_b2(force), to_b2(center + c.arm), true);
    wheel.traction_n = force.dot(forward);
    wheel.slipping = c.impulse.norm() >= c.max_impulse * (1.0 - 1e-9) && c.max_impulse > 0.0 &&
                     std::abs(wheel.traction_n) > 0.0;
    // Motor: reaching the target speed takes J (target - speed) / dt plus the floor's reaction
    // torque; beyond the torque limit the wheel accelerates only as far as the limit allows.
    const double needed_nm = def_.wheel_inertia_kgm2 * (c.target_radps - wheel.speed_radps) / dt_s +
                             wheel.traction_n * wheel.radius_m;
    if (std::abs(needed_nm) <= def_.max_wheel_torque_nm) {
      wheel.speed_radps = c.target_radps;
    } else {
      const double motor_nm = std::copysign(def_.max_wheel_torque_nm, needed_nm);
      wheel.speed_radps +=
          (motor_nm - wheel.traction_n * wheel.radius_m) / def_.wheel_inertia_kgm2 * dt_s;
    }
    wheel.angle_rad += wheel.speed_radps * dt_s;
  }
}

Pose2 DiffDriveRobot::pose() const {
  const b2Vec2& position = body_->GetPosition();
  return Pose2{position.x, position.y, wrap_angle(body_->GetAngle())};
}

Vec2 DiffDriveRobot::velocity_mps() const {
  return from_b2(body_->GetLinearVelocity());
}

double DiffDriveRobot::yaw_rate_radps() const {
  return body_->GetAngularVelocity();
}

void DiffDriveRobot::lift() {
  carried_ = true;
  // Nobody commands a robot in the air; it is put down at rest.
  given_v_mps_ = given_w_radps_ = 0.0;
  acting_v_mps_ = acting_w_radps_ = 0.0;
  pending_.clear();
  body_->SetEnabled(false);
  for (WheelState& wheel : wheels_) {
    wheel.speed_radps = 0.0;
    wheel.traction_n = 0.0;
    wheel.slipping = false;
  }
}

void DiffDriveRobot::put_down(const Pose2& pose) {
  body_->SetTransform(to_b2(pose.position()), static_cast<float>(pose.theta));
  body_->SetLinearVelocity(b2Vec2_zero);
  body_->SetAngularVelocity(0.0f);
  body_->SetEnabled(true);
  carried_ = false;
  for (WheelState& wheel : wheels_) wheel.speed_radps = 0.0;
}

void DiffDriveRobot::push(const Vec2& impulse_ns, double angular_impulse_nms) {
  body_->ApplyLinearImpulseToCenter(to_b2(impulse_ns), true);
  body_->ApplyAngularImpulse(static_cast<float>(angular_impulse_nms), true);
}

}  // namespace locsim
