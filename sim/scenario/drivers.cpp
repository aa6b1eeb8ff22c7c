#include "sim/scenario/drivers.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

namespace locsim {

namespace {

class IdleDriver final : public Driver {
 public:
  VelocityCommand update(double t_s, const DiffDriveRobot&, const PhysicsWorld&) override {
    return {t_s, 0.0, 0.0};
  }
};

/// Turns toward the current waypoint (in place when it lies more than 60° off the heading) and
/// drives at cruise speed, slowing down for the last waypoint of an open path.
class WaypointDriver final : public Driver {
 public:
  explicit WaypointDriver(DriveDef def) : def_(std::move(def)) {}

  VelocityCommand update(double t_s, const DiffDriveRobot& robot,
                         const PhysicsWorld& world) override {
    if (done_) return {t_s, 0.0, 0.0};
    const Pose2 pose = robot.pose();
    // Put down far from where it was at the last step: it was carried (no step drives 0.5 m).
    const bool carried = last_position_ && (pose.position() - *last_position_).norm() > kCarriedM;
    last_position_ = pose.position();
    if (carried && def_.after_kidnap == DriveDef::AfterKidnap::kNearestInSight)
      next_ = nearest_in_sight(pose.position(), robot, world);
    Vec2 to_target = def_.path_m[next_] - pose.position();
    // Skips the waypoints already reached; a looping path that lies wholly within the tolerance
    // of the robot is passed through once per step, not forever.
    for (std::size_t skipped = 0; to_target.norm() < def_.tolerance_m; ++skipped) {
      if (skipped == def_.path_m.size()) return {t_s, 0.0, 0.0};
      if (next_ + 1 < def_.path_m.size()) {
        ++next_;
      } else if (def_.loop) {
        next_ = 0;
      } else {
        done_ = true;
        return {t_s, 0.0, 0.0};
      }
      to_target = def_.path_m[next_] - pose.position();
    }
    const double heading_error = wrap_angle(std::atan2(to_target.y(), to_target.x()) - pose.theta);
    const double w = std::clamp(def_.heading_gain * heading_error, -def_.max_turn_rate_radps,
                                def_.max_turn_rate_radps);
    double v = std::abs(heading_error) > std::numbers::pi / 3.0
                   ? 0.0
                   : def_.speed_mps * std::cos(heading_error);
    const bool last = !def_.loop && next_ + 1 == def_.path_m.size();
    if (last) v = std::min(v, to_target.norm());  // arrive gently: 1 m/s per metre left
    return {t_s, v, w};
  }

 private:
  static constexpr double kCarriedM = 0.5;
  static constexpr double kSightStepM = 0.05;

  /// The nearest waypoint the robot's footprint can slide to in a straight line without
  /// touching static geometry (people move on); the nearest of all when none can be.
  std::size_t nearest_in_sight(const Vec2& from, const DiffDriveRobot& robot,
                               const PhysicsWorld& world) const {
    const b2Fixture* fixture = robot.body()->GetFixtureList();
    const auto reachable = [&](const Vec2& to) {
      if (fixture == nullptr) return true;
      const Vec2 d = to - from;
      const double heading = std::atan2(d.y(), d.x());
      const int steps = std::max(1, static_cast<int>(std::ceil(d.norm() / kSightStepM)));
      for (int i = 1; i <= steps; ++i) {
        const Vec2 p = from + d * (static_cast<double>(i) / steps);
        if (!world.is_free_of_static(*fixture->GetShape(), Pose2{p.x(), p.y(), heading}))
          return false;
      }
      return true;
    };
    std::size_t best = next_, best_any = next_;
    double best_m = std::numeric_limits<double>::infinity(), best_any_m = best_m;
    for (std::size_t k = 0; k < def_.path_m.size(); ++k) {
      const double m = (def_.path_m[k] - from).norm();
      if (m < best_any_m) best_any_m = m, best_any = k;
      if (m < best_m && reachable(def_.path_m[k])) best_m = m, best = k;
    }
    return std::isfinite(best_m) ? best : best_any;
  }

  DriveDef def_;
  std::size_t next_ = 0;
  bool done_ = false;
  std::optional<Vec2> last_position_;  // at the last update
};

/// Piecewise-constant commands; the last one holds until the end.
class VelocityDriver final : public Driver {
 public:
  explicit VelocityDriver(DriveDef def) : def_(std::move(def)) {}

  VelocityCommand update(double t_s, const DiffDriveRobot&, const PhysicsWorld&) override {
    while (next_ < def_.commands.size() && def_.commands[next_].t_s <= t_s + 1e-9) ++next_;
    if (next_ == 0) return {t_s, 0.0, 0.0};
    const VelocityCommand& current = def_.commands[next_ - 1];
    return {t_s, current.v_mps, current.w_radps};
  }

 private:
  DriveDef def_;
  std::size_t next_ = 0;
};

/// Follows timed poses: the reference pose and velocity interpolated between the samples, fed
/// forward, plus the nonlinear tracking law of De Luca, Oriolo and Samson ("Feedback control of
/// a nonholonomic car-like robot", 1998, eq. 4.13) on the error in the robot's frame, so that the
/// physics (ramps, slip, contacts) cannot make the robot drift off a recorded path. Before the
/// first sample it holds the first pose, after the last the last one.
class TrajectoryDriver final : public Driver {
 public:
  explicit TrajectoryDriver(DriveDef def) : def_(std::move(def)) {}

  VelocityCommand update(double t_s, const DiffDriveRobot& robot, const PhysicsWorld&) override {
    const std::vector<StampedPose>& samples = def_.trajectory;
    while (next_ < samples.size() && samples[next_].t_s <= t_s) ++next_;
    Pose2 reference = next_ == 0 ? samples.front().pose : samples[next_ - 1].pose;
    if (next_ > 0 && next_ < samples.size()) {
      const StampedPose& a = samples[next_ - 1];
      const StampedPose& b = samples[next_];
      const double s = (t_s - a.t_s) / (b.t_s - a.t_s);
      const double turn_rad = wrap_angle(b.pose.theta - a.pose.theta);
      reference = {a.pose.x + s * (b.pose.x - a.pose.x), a.pose.y + s * (b.pose.y - a.pose.y),
                   a.pose.theta + s * turn_rad};
    }
    const auto [v_ref, w_ref] = chord_velocity(t_s);
    const Pose2 pose = robot.pose();
    const double c = std::cos(pose.theta), s = std::sin(pose.theta);
    const double dx = reference.x - pose.x, dy = reference.y - pose.y;
    const double e_along = c * dx + s * dy;
    const double e_across = -s * dx + c * dy;
    const double e_theta = wrap_angle(reference.theta - pose.theta);
    // Gains from the reference's speed (critically damped linearisation, damping kDamping); a
    // floor so that the robot still closes along-track and heading errors while the reference
    // stands still. The lateral error's natural frequency, v sqrt(b), is held below
    // kMaxNaturalFrequency: faster, the loop outruns what the motors' ramp and the physics step
    // carry, and a fast robot's path (4 m/s: 18 rad/s) is followed by growing oscillations.
    const double lateral_gain =
        std::min(kLateralGainPerM2,
                 kMaxNaturalFrequency * kMaxNaturalFrequency / std::max(v_ref * v_ref, 1e-12));
    const double gain = std::max(
        2.0 * kDamping * std::sqrt(w_ref * w_ref + lateral_gain * v_ref * v_ref), kMinGainPerS);
    const double sinc = std::abs(e_theta) < 1e-9 ? 1.0 : std::sin(e_theta) / e_theta;
    double v_ahead = v_ref, w_ahead = w_ref;
    double gain_v = 1.0, gain_w = 1.0;
    if (const CommandResponseDef& r = robot.def().command_response; !r.identity()) {
      // A base that lags its command is told the path's velocity ahead by its lag (a dead time
      // d and a first-order lag tau delay a smooth signal by about d + tau), over its gain: the
      // command then leads the motion as a real base's does, and the feedback only corrects.
      v_ahead = chord_velocity(t_s + r.dead_time_s + r.time_constant_v_s).first;
      w_ahead = chord_velocity(t_s + r.dead_time_s + r.time_constant_omega_s).second;
      gain_v = r.gain_v;
      gain_w = r.gain_omega;
    }
    const double v = (v_ahead * std::cos(e_theta) + gain * e_along) / gain_v;
    const double w = (w_ahead + lateral_gain * v_ref * sinc * e_across + gain * e_theta) / gain_w;
    return {t_s, v, w};
  }

 private:
  /// The reference's (v, omega) at t: the chord between the samples around it along their mid
  /// heading (signed, so that a reversing robot reverses); zero outside them.
  std::pair<double, double> chord_velocity(double t_s) const {
    const std::vector<StampedPose>& samples = def_.trajectory;
    const auto after = std::upper_bound(samples.begin(), samples.end(), t_s,
                                        [](double t, const StampedPose& p) { return t < p.t_s; });
    if (after == samples.begin() || after == samples.end()) return {0.0, 0.0};
    const StampedPose& a = *(after - 1);
    const StampedPose& b = *after;
    const double dt_s = b.t_s - a.t_s;
    const double turn_rad = wrap_angle(b.pose.theta - a.pose.theta);
    const Vec2 step_m = b.pose.position() - a.pose.position();
    const double mid_rad = a.pose.theta + 0.5 * turn_rad;
    return {(step_m.x() * std::cos(mid_rad) + step_m.y() * std::sin(mid_rad)) / dt_s,
            turn_rad / dt_s};
  }
  static constexpr double kDamping = 0.7;              // [-]
  static constexpr double kLateralGainPerM2 = 20.0;    // [1/m^2]
  static constexpr double kMaxNaturalFrequency = 4.0;  // of the lateral error [rad/s]
  static constexpr double kMinGainPerS = 0.5;          // [1/s]
  DriveDef def_;
  std::size_t next_ = 0;
};

/// Drives straight; when something is within the clearance ahead, turns in place toward the
/// freer side for a random time, then goes on.
class WanderDriver final : public Driver {
 public:
  WanderDriver(DriveDef def, RandomStream rng) : def_(std::move(def)), rng_(rng) {}

  VelocityCommand update(double t_s, const DiffDriveRobot& robot,
                         const PhysicsWorld& world) override {
    if (t_s < turning_until_s_) return {t_s, 0.0, turn_direction_ * def_.max_turn_rate_radps};
    // Between looks it drives on as decided. A look a microsecond early counts as due: step
    // times are sums of dt, and the look falls on the step it is meant for.
    if (t_s < next_look_s_) return {t_s, def_.speed_mps, 0.0};
    next_look_s_ = t_s + 1.0 / def_.clearance_check_hz - kDueEarlyS;
    const Pose2 pose = robot.pose();
    const double reach = def_.clearance_m + bounding_radius(robot.def().footprint);
    const auto free_distance = [&](double bearing) {
      const Vec2 end = pose.transform({reach * std::cos(bearing), reach * std::sin(bearing)});
      return world.ray_cast(pose.position(), end, robot.body()).value_or(reach);
    };
    const double ahead = std::min({free_distance(0.0), free_distance(0.35), free_distance(-0.35)});
    if (ahead < reach) {
      turn_direction_ = free_distance(1.2) >= free_distance(-1.2) ? 1.0 : -1.0;
      const double turn_rad = rng_.uniform(0.4, 1.0) * std::numbers::pi;
      turning_until_s_ = t_s + turn_rad / def_.max_turn_rate_radps;
      next_look_s_ = turning_until_s_;  // looks again as soon as it has turned
      return {t_s, 0.0, turn_direction_ * def_.max_turn_rate_radps};
    }
    return {t_s, def_.speed_mps, 0.0};
  }

 private:
  static constexpr double kDueEarlyS = 1e-6;
  DriveDef def_;
  RandomStream rng_;
  double turning_until_s_ = -1.0;
  double next_look_s_ = -1.0;
  double turn_direction_ = 1.0;
};

/// Holds the robot still until `start_after_s`, then hands over.
class DelayedDriver final : public Driver {
 public:
  DelayedDriver(double start_after_s, std::unique_ptr<Driver> driver)
      : start_after_s_(start_after_s), driver_(std::move(driver)) {}

  VelocityCommand update(double t_s, const DiffDriveRobot& robot,
                         const PhysicsWorld& world) override {
    if (t_s < start_after_s_) return {t_s, 0.0, 0.0};
    return driver_->update(t_s, robot, world);
  }

 private:
  double start_after_s_;
  std::unique_ptr<Driver> driver_;
};

std::unique_ptr<Driver> make_undelayed_driver(const DriveDef& def, RandomStream rng) {
  switch (def.mode) {
    case DriveDef::Mode::kIdle:
      return std::make_unique<IdleDriver>();
    case DriveDef::Mode::kWaypoints:
      return std::make_unique<WaypointDriver>(def);
    case DriveDef::Mode::kVelocity:
      return std::make_unique<VelocityDriver>(def);
    case DriveDef::Mode::kWander:
      return std::make_unique<WanderDriver>(def, rng);
    case DriveDef::Mode::kTrajectory:
      return std::make_unique<TrajectoryDriver>(def);
  }
  return std::make_unique<IdleDriver>();
}

}  // namespace

std::unique_ptr<Driver> make_driver(const DriveDef& def, RandomStream rng) {
  std::unique_ptr<Driver> driver = make_undelayed_driver(def, rng);
  if (def.start_after_s > 0.0)
    return std::make_unique<DelayedDriver>(def.start_after_s, std::move(driver));
  return driver;
}

}  // namespace locsim
