// How the robots are driven and what happens to them, on a timeline.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "sim/common/errors.hpp"
#include "sim/common/math.hpp"

namespace locsim {

struct VelocityCommand {
  double t_s = 0.0;      // when it starts [s]
  double v_mps = 0.0;    // forward speed [m/s]
  double w_radps = 0.0;  // turn rate, counter-clockwise [rad/s]
};

/// The behaviour that drives one robot. It steers by the true pose: the scenario is the
/// experimenter's hand, not the robot's navigation, so runs are comparable across localizers.
struct DriveDef {
  enum class Mode { kIdle, kWaypoints, kVelocity, kWander };
  Mode mode = Mode::kIdle;
  std::string robot;           // which robot; may be empty when the world has one
  double start_after_s = 0.0;  // stands still until then, whatever the mode [s]
  // kWaypoints
  std::vector<Vec2> path_m;
  bool loop = true;
  double speed_mps = 0.3;            // cruise speed (also kWander) [m/s]
  double max_turn_rate_radps = 1.0;  // (also kWander's turning rate) [rad/s]
  double tolerance_m = 0.05;         // waypoint reached within this distance [m]
  double heading_gain = 2.0;         // turn rate per heading error [1/s]
  // kVelocity
  std::vector<VelocityCommand> commands;
  // kWander
  double clearance_m = 0.6;  // turn away when something is this close ahead [m]
  SourceLocation where;      // of the drive's entry, for messages
  std::string key_path;      // e.g. "scenario.drive", for messages
};

/// How the scenario points a PTZ camera.
struct PanPolicyDef {
  enum class Mode { kFixed, kSweep, kNearestLandmark };
  Mode mode = Mode::kFixed;
  std::string robot;
  double pan_rad = 0.0;  // kFixed [rad]
  double sweep_min_rad = deg_to_rad(-90.0);
  double sweep_max_rad = deg_to_rad(90.0);
  double sweep_rate_radps = deg_to_rad(30.0);
  SourceLocation where;
  std::string key_path;
};

struct SensorFaultDef {
  enum class Mode { kDropout, kStuck, kBias };
  Mode mode = Mode::kDropout;
  double duration_s = 0.0;  // 0: until the end of the run
  double bias = 0.0;        // kBias: added to the main quantity (see docs/sensors.md)
};

struct EventDef {
  enum class Kind { kKidnap, kPush, kFriction, kObstacle, kSensorFault, kEnd };
  Kind kind = Kind::kEnd;
  double at_s = 0.0;  // [s]
  std::string robot;  // kKidnap, kPush: which robot; may be empty when the world has one
  // kKidnap: a given pose, or a random free pose (inside `random_min_m`..`random_max_m` when
  // given, else the world's bounds).
  std::optional<Pose2> to;
  std::optional<Vec2> random_min_m, random_max_m;
  double carry_s = 0.0;  // how long the robot is off the floor, wheels still [s]
  // kPush
  Vec2 impulse_ns{0.0, 0.0};         // world frame [N s]
  double angular_impulse_nms = 0.0;  // [N m s]
  // kFriction
  std::string region;  // a floor region's name, or "floor" for the default
  double friction = 0.8;
  // kObstacle
  std::string obstacle;
  bool start_moving = true;  // start (true) or stop (false)
  // kSensorFault (robot as above)
  std::string sensor;  // encoders, imu, ptz_camera, omni_camera, ultrasonic, laser
  SensorFaultDef fault;
  SourceLocation where;  // of the event's entry, for messages
  std::string key_path;  // e.g. "scenario.events[2].kidnap", for messages
};

/// What localizers are told at the start.
struct LocalizationDef {
  bool initial_pose_known = true;  // false: global localization, no initial pose
  bool landmarks_known = true;     // false: SLAM, the map given to localizers has no landmarks
  double sigma_xy_m = 0.1;         // the initial guess is the truth plus N(0, sigma^2) [m]
  double sigma_theta_rad = 0.08726646259971647;  // 5 deg [rad]
  double grid_resolution_m = 0.05;               // of the occupancy grid given to localizers [m]
};

struct ScenarioDef {
  std::string name = "scenario";
  std::filesystem::path source;  // file it came from ("" when a section of the world file)
  double duration_s = 60.0;      // simulated time of the run [s]
  double groundtruth_hz = 50.0;  // rate of groundtruth.tum; divides the physics rate [Hz]
  std::vector<DriveDef> drives;
  std::vector<EventDef> events;            // sorted by time; ties keep file order
  std::vector<PanPolicyDef> pan_policies;  // one per robot with a PTZ camera, at most
  LocalizationDef localization;
};

}  // namespace locsim
