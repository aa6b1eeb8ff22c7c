// The `sensors:` section of a robot → SensorsDef.
#pragma once

#include "sim/common/yaml_node.hpp"
#include "sim/sensors/sensor_defs.hpp"

namespace locsim {

/// `step_hz` is the physics rate every sensor rate must divide. Throws InputError.
SensorsDef parse_sensors(const YamlNode& node, double step_hz);

}  // namespace locsim
