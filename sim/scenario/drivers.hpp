// Behaviours that drive a robot: waypoints, a velocity timeline, wander, or nothing.
#pragma once

#include <memory>

#include "sim/common/random.hpp"
#include "sim/robot/diff_drive.hpp"
#include "sim/scenario/scenario_def.hpp"
#include "sim/world/physics_world.hpp"

namespace locsim {

class Driver {
 public:
  virtual ~Driver() = default;
  /// The body velocity command for the step starting at `t_s`. Steers by the true pose.
  virtual VelocityCommand update(double t_s, const DiffDriveRobot& robot,
                                 const PhysicsWorld& world) = 0;
};

/// `rng` is the driver's own stream (only wander draws from it).
std::unique_ptr<Driver> make_driver(const DriveDef& def, RandomStream rng);

}  // namespace locsim
