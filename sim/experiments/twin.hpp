// A simulated twin of a recorded log (`locsim twin`): a world that reproduces the log's world
// (its landmarks, walls, robots), drives each robot along its recorded true path, and gives the
// sensors the noise `locsim calibrate` measured, so that the same experiment can run on the real
// log and on simulated ones, and their results be compared (docs/real_data.md).
//
// What the twin matches, and how:
// - the path: each robot's ground truth, sampled at `pose_rate_hz`, written as a TUM file beside
//   the world and tracked by a `trajectory` drive (feedback: the robot does not drift off it);
// - the noise: calibration.yaml's `sensors:` merged into every robot's sensors, and each robot's
//   camera mounted where its `camera_offsets:` entry says, its detections given from its
//   believed place as the log's are;
// - how much the camera sees: the range-bearing sensor's rate and miss probability are set so that
//   the twin's expected number of landmark detections per second equals the log's. A real camera
//   that logs only the frames in which it read something has no rate to copy, and the calibrated
//   miss probability counts only the logged frames; the twin keeps the calibrated miss
//   probability where a rate that divides the physics rate allows it.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "sim/common/math.hpp"
#include "sim/common/range.hpp"
#include "sim/metrics/calibration.hpp"

namespace locsim {

struct TwinOptions {
  std::filesystem::path log;
  std::optional<std::filesystem::path> calibration;  // a calibration.yaml: its `sensors:`
  std::vector<std::string> robots;                   // by name; empty: all of the log's
  double pose_rate_hz = 10.0;                        // samples of the true path [Hz]
  static constexpr Range kPoseRateRange{0.1, 1000.0, "Hz"};
  bool match_detections = true;  // set the camera's rate and misses from the log's detections
};

/// How the twin's range-bearing camera was set to see as much as the log's.
struct TwinCamera {
  double duration_s = 0.0;          // robot-seconds of ground truth the counts are over [s]
  std::size_t data_detections = 0;  // of landmarks, in the log
  std::size_t data_readings = 0;    // readings of the camera in the log
  double data_detections_per_s = 0.0;
  double in_view_mean = 0.0;  // landmarks in range and field of view along the true paths
  // The calibration's detection_decay_m (0: none), and the landmarks in view each counted as
  // e^(-range / it), the share of a near one's chance it has. [m], [-]
  double detection_decay_m = 0.0;
  double in_view_weighted_mean = 0.0;
  double calibrated_miss_probability = 0.0;  // at zero range with a decay
  double calibrated_false_per_reading = 0.0;
  double outage_fraction = 0.0;  // the calibration's: the share of the time it sees nothing [-]
  double rate_hz = 0.0;          // the twin's
  double miss_probability = 0.0;
  double false_per_reading = 0.0;
  std::string note;  // why nothing was matched, when it was not
};

struct TwinRobot {
  std::string name;
  std::filesystem::path poses_file;  // the TUM file written beside the world
  std::vector<StampedPose> path;     // the true path, thinned to the pose rate
  double from_s = 0.0, to_s = 0.0;
  double path_length_m = 0.0;
  // The motor limits the path needs (its wheels' speeds and accelerations with a margin), where
  // they are beyond the world's: a twin that cannot drive as fast as the recording falls behind
  // and whips round to catch up, and its odometry with it.
  std::optional<double> max_wheel_speed_radps, max_wheel_accel_radps2;
  // The truth's jumps smoothed out of the path (clear_truth_jumps): how many, the largest [m].
  std::size_t truth_jumps = 0;
  double largest_truth_jump_m = 0.0;
  // The calibration's camera offset for this robot (its `camera_offsets:`), where the twin's
  // range-bearing camera is mounted from its believed place: forward, left [m].
  std::optional<Vec2> camera_offset_m;
};

struct Twin {
  std::string world_yaml;  // the world file's text
  /// The files of the log's world the twin's needs beside it (a map's YAML and image), by their
  /// paths relative to the world file's folder, with their bytes as the log carries them.
  std::vector<std::pair<std::filesystem::path, std::string>> world_files;
  std::vector<TwinRobot> robots;
  std::optional<TwinCamera> camera;
  // The rate the twin's truth is sampled at, so its estimates are scored as often as the log's
  // are: the log's truth rate (median interval), as the nearest rate the physics allows. A
  // filter's estimate between its updates holds; sampled at 100 Hz, a filter whose odometry
  // comes at 10 Hz is scored half a step late on average, which on the log it never is. [Hz]
  double groundtruth_hz = 0.0;
  double log_truth_hz = 0.0;  // the log's, as measured [Hz]
  // The log's ranges' spells of silence (fit_outages over the robots' beacon-range readings),
  // which the twin's ultrasonic sensors take over the calibration's: where a robot cannot range
  // its anchors depends on where it drives, not on the robot. Unset without such readings.
  std::optional<OutageFit> ranging_silences;
  std::vector<std::string> warnings;
};

/// A true path's jumps that no robot makes, smoothed into motion one could: a step that departs
/// from its neighbours' velocity by more than a wheeled robot's traction allows in one step, and
/// by more than the path's own noise (a GPS fix re-acquired, a motion-capture marker swapped), is
/// held back, and the path after it catches up smoothly. The path elsewhere is kept to the bit;
/// the count and the largest jump [m] are returned.
std::pair<std::size_t, double> clear_truth_jumps(std::vector<StampedPose>& path);

/// Builds the twin of `options.log`: the world file's text for `world_file` (whose folder the TUM
/// files are named relative to; written by write_twin). Throws InputError naming the file and
/// problem (no ground truth, an unknown robot, a calibration file that is not calibrate's).
Twin make_twin(const TwinOptions& options, const std::filesystem::path& world_file);

/// Writes the world file and its TUM files (each through a temporary name and a rename), then
/// loads the world as `locsim run` would, so that a twin that cannot run is never left behind.
/// Refuses to replace existing files unless `overwrite`.
Twin write_twin(const TwinOptions& options, const std::filesystem::path& world_file,
                bool overwrite);

/// The summary `locsim twin` prints.
std::string describe(const Twin& twin);

}  // namespace locsim
