// The range and unit of every number a user can give. Each is declared once, beside its field in
// the definition structs (world_def.hpp, robot_def.hpp, sensor_defs.hpp, scenario_def.hpp,
// experiment.hpp), the way Box2D's b2BodyDef documents its fields; YamlNode's readers take one for
// every number they read, so a loader cannot read a number without checking it. docs/worlds.md
// lists them all (tests/docs_ranges_test.cpp keeps the list and the declarations equal).
//
// The ranges are generous but physically meaningful, and narrow enough that no value inside them
// can break what the numbers feed: Box2D 2.4's float maths (positions, masses and inertias, its
// asserts), step counts (rate x duration must fit in 64 bits) and the memory a world needs.
#pragma once

#include <string>
#include <string_view>

namespace locsim {

struct Range {
  double min = 0.0;
  double max = 0.0;
  std::string_view unit;  // as printed after a number: "m", "kg", "Hz", "rad/s"; "" for none
  constexpr bool contains(double value) const { return value >= min && value <= max; }
};

/// "[0.01, 10000] kg". An angle's range (unit "rad", "rad/s") is shown in degrees when `degrees`.
std::string describe(const Range& range, bool degrees = false);

/// "1e+38 kg is outside [0.01, 10000] kg", or "" when `value` is inside. `value` is in degrees
/// when `degrees` (the key ended in `_deg`), and is compared in radians.
std::string out_of_range(double value, const Range& range, bool degrees = false);

// ---- ranges shared by many fields

/// Where anything can be in a world: walls, shapes, map origins, robots, waypoints, kidnap
/// targets. Box2D works in float: at 10 km one float step is 1 mm, a fifth of its contact slop
/// (b2_linearSlop, 5 mm); beyond, contacts and motion lose their resolution. [m]
inline constexpr Range kWorldCoordinateRange{-1e4, 1e4, "m"};

/// Consecutive points of walls, polygons, footprints and paths must be at least this far apart:
/// closer ones are one point to Box2D's float maths (it welds polygon vertices 2.5 mm apart). [m]
inline constexpr double kMinPointSpacingM = 0.01;

/// Any heading or orientation a user writes (poses, box angles, mounts, map yaw). Stored wrapped
/// to (-pi, pi]; magnitudes beyond this are typing mistakes, and in float would not even hold a
/// whole turn's resolution. [rad]
inline constexpr Range kHeadingRange{-1e6, 1e6, "rad"};

/// Simulated times: durations, event times, delays. Ten million seconds (116 days) at the
/// highest physics rate is 1e11 steps, far inside a 64-bit step counter. [s]
inline constexpr Range kSimulatedTimeRange{0.0, 1e7, "s"};

/// A probability. [-]
inline constexpr Range kProbabilityRange{0.0, 1.0, ""};

/// Rates of sensors and ground truth; each must also divide the physics rate, so at most 1e6
/// physics steps lie between two samples. [Hz]
inline constexpr Range kSampleRateRange{0.01, 10000.0, "Hz"};

/// Positions in a robot's own frame (sensor mounts, receivers, footprint vertices). [m]
inline constexpr Range kBodyFrameRange{-50.0, 50.0, "m"};

/// A friction coefficient (rubber on dry concrete is about 1, racing slicks reach 2). [-]
inline constexpr Range kFrictionRange{0.0, 10.0, ""};

/// Heights above the floor of what may stand on it (a beacon, a receiver, a camera). [m]
inline constexpr Range kHeightRange{0.0, 1000.0, "m"};

/// Heights of what has a body: obstacles, landmarks, people, robots. [m]
inline constexpr Range kBodyHeightRange{0.001, 1000.0, "m"};

}  // namespace locsim
