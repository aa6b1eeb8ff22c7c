// The `sensors:` section of a robot → SensorsDef.
#pragma once

#include <string>

#include "sim/common/yaml_node.hpp"
#include "sim/sensors/sensor_defs.hpp"

namespace locsim {

/// "" when a sample rate divides the physics rate (samples fall on physics steps), else what is
/// wrong.
std::string divides_physics_rate(double rate_hz, double step_hz);

/// `step_hz` is the physics rate every sensor rate must divide. Throws InputError.
SensorsDef parse_sensors(const YamlNode& node, double step_hz);

}  // namespace locsim
