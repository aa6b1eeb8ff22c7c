// How the robots are driven and what happens to them, on a timeline. Beside each number its unit
// and the range the loader holds it to (sim/common/range.hpp); every time is in
// kSimulatedTimeRange, every position in kWorldCoordinateRange.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "sim/common/errors.hpp"
#include "sim/common/math.hpp"
#include "sim/common/range.hpp"

namespace locsim {

struct VelocityCommand {
  double t_s = 0.0;    // when it starts [s]
  double v_mps = 0.0;  // forward speed [m/s]
  static constexpr Range kSpeedRange{-50.0, 50.0, "m/s"};
  double w_radps = 0.0;  // turn rate, counter-clockwise [rad/s]
  static constexpr Range kTurnRateRange{-100.0, 100.0, "rad/s"};
};

/// The behaviour that drives one robot. It steers by the true pose: the scenario is the
/// experimenter's hand, not the robot's navigation, so runs are comparable across localizers.
struct DriveDef {
  enum class Mode { kIdle, kWaypoints, kVelocity, kWander, kTrajectory };
  Mode mode = Mode::kIdle;
  std::string robot;           // which robot; may be empty when the world has one
  double start_after_s = 0.0;  // stands still until then, whatever the mode [s]
  // kWaypoints
  std::vector<Vec2> path_m;
  bool loop = true;
  double speed_mps = 0.3;  // cruise speed (also kWander) [m/s]
  static constexpr Range kSpeedRange{0.0, 50.0, "m/s"};
  double max_turn_rate_radps = 1.0;  // (also kWander's turning rate) [rad/s]
  static constexpr Range kTurnRateRange{0.001, 100.0, "rad/s"};
  double tolerance_m = 0.05;  // waypoint reached within this distance [m]
  static constexpr Range kToleranceRange{0.001, 100.0, "m"};
  double heading_gain = 2.0;  // turn rate per heading error [1/s]
  static constexpr Range kHeadingGainRange{0.001, 1000.0, "1/s"};
  // After a kidnap: on to the waypoint it was heading for (kContinue), or to the nearest one it
  // can drive to in a straight line, its footprint clear of walls and static shapes
  // (kNearestInSight: a world with inner walls, where the old target may be behind one).
  enum class AfterKidnap { kContinue, kNearestInSight };
  AfterKidnap after_kidnap = AfterKidnap::kContinue;
  // kVelocity
  std::vector<VelocityCommand> commands;
  // kWander
  double clearance_m = 0.6;  // turn away when something is this close ahead [m]
  static constexpr Range kClearanceRange{0.001, 100.0, "m"};
  // How often it looks ahead (three rays), as a robot's controller would, not at every physics
  // step: the rays were most of a wandering fleet's physics time [Hz].
  double clearance_check_hz = 20.0;
  static constexpr Range kClearanceCheckRange{0.1, 10000.0, "Hz"};
  // kTrajectory: the poses to be at, times increasing (the twin of a recorded robot, say:
  // `locsim twin`); tracked by feedback, so the robot stays on the path whatever the physics.
  std::vector<StampedPose> trajectory;
  std::filesystem::path poses_file;  // where they came from ("" when given inline)
  SourceLocation where;              // of the drive's entry, for messages
  std::string key_path;              // e.g. "scenario.drive", for messages
};

/// How the scenario points a PTZ camera.
struct PanPolicyDef {
  enum class Mode { kFixed, kSweep, kNearestLandmark };
  Mode mode = Mode::kFixed;
  std::string robot;
  double pan_rad = 0.0;                      // kFixed [rad]
  double sweep_min_rad = deg_to_rad(-90.0);  // [rad]
  double sweep_max_rad = deg_to_rad(90.0);   // [rad]
  static constexpr Range kPanRange{deg_to_rad(-360.0), deg_to_rad(360.0), "rad"};
  double sweep_rate_radps = deg_to_rad(30.0);  // [rad/s]
  static constexpr Range kSweepRateRange{deg_to_rad(0.01), deg_to_rad(10000.0), "rad/s"};
  SourceLocation where;
  std::string key_path;
};

struct SensorFaultDef {
  enum class Mode { kDropout, kStuck, kBias };
  Mode mode = Mode::kDropout;
  double duration_s = 0.0;  // 0: until the end of the run [s]
  double bias = 0.0;        // kBias: added to the main quantity (see docs/sensors.md)
  static constexpr Range kBiasRange{-10000.0, 10000.0, ""};
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
  Vec2 impulse_ns{0.0, 0.0};  // world frame [N s]
  static constexpr Range kImpulseRange{-100000.0, 100000.0, "N s"};
  double angular_impulse_nms = 0.0;  // [N m s]
  static constexpr Range kAngularImpulseRange{-100000.0, 100000.0, "N m s"};
  // kFriction
  std::string region;     // a floor region's name, or "floor" for the default
  double friction = 0.8;  // kFrictionRange [-]
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
  static constexpr Range kSigmaXyRange{0.0, 10000.0, "m"};
  double sigma_theta_rad = 0.08726646259971647;  // 5 deg [rad]
  static constexpr Range kSigmaThetaRange{0.0, deg_to_rad(360.0), "rad"};
  // Of the occupancy grid given to localizers; its cells count in the world's memory budget [m]
  double grid_resolution_m = 0.05;
  static constexpr Range kGridResolutionRange{0.001, 100.0, "m"};
  InputPlace grid_resolution_place;  // for the memory check, which needs the world
};

struct ScenarioDef {
  std::string name = "scenario";
  std::filesystem::path source;  // file it came from ("" when a section of the world file)
  double duration_s = 60.0;      // simulated time of the run; `--duration` too [s]
  static constexpr Range kDurationRange{0.001, kSimulatedTimeRange.max, "s"};
  double groundtruth_hz = 50.0;  // rate of groundtruth.tum; divides the physics rate [Hz]
  static constexpr Range kGroundTruthRateRange = kSampleRateRange;
  InputPlace groundtruth_hz_place;  // for the divisibility check, which needs the world
  std::vector<DriveDef> drives;
  std::vector<EventDef> events;            // sorted by time; ties keep file order
  std::vector<PanPolicyDef> pan_policies;  // one per robot with a PTZ camera, at most
  LocalizationDef localization;
};

}  // namespace locsim
