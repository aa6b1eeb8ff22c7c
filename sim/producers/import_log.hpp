// What an importer of a real dataset (mrclam_import, generic_import) hands on: the dataset's
// landmarks, robots and time-stamped readings, which write_import turns into a version-2
// .locsimlog (a generated world in its header, the records in stream order) that `locsim replay`
// runs like a recorded one. docs/real_data.md.
#pragma once

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "sim/common/math.hpp"
#include "sim/common/range.hpp"
#include "sim/sensors/readings.hpp"
#include "sim/sensors/sensor_defs.hpp"

namespace locsim {

/// The time stamps a dataset may give, absolute (Unix times, ~1.7e9 s) or relative. Within 1e10 s
/// (the year 2286) a double still resolves 2 microseconds; a time given in nanoseconds by mistake
/// (1.7e18), or a 1e308, is refused at its line instead of becoming a log of 1e308 s. [s]
inline constexpr Range kDatasetTimeRange{-1e10, 1e10, "s"};

/// Where a sample's time stamp stands in its stream's file (1-based line and column), so that a
/// problem found only when the streams are put together (a log too long, a second true pose at
/// one instant) is reported at the line that causes it.
struct SamplePlace {
  int line = 0;
  int column = 0;
};

/// The file a stream of samples was read from, and the name of its time column, for messages.
struct StreamSource {
  std::string file;
  std::string time_key;
};

struct ImportedLandmark {
  int id = 0;
  Vec2 position_m{0.0, 0.0};
  std::string color = {};  // a named colour (world_loader named_colors); empty: one in turn
};

/// A beacon that robots range to (a UWB anchor, an ultrasonic transmitter): the world's
/// `beacons[]`.
struct ImportedBeacon {
  int id = 0;
  Vec2 position_m{0.0, 0.0};
  double height_m = 0.0;  // above the floor; ranges are slant ranges from the receiver [m]
};

/// One robot's data; times as the dataset gives them (absolute or relative) [s].
struct ImportedRobot {
  std::string name;
  // Geometry for the generated world [m].
  double radius_m = 0.2;
  double wheel_base_m = 0.3;
  double wheel_radius_m = 0.05;
  struct Odometry {
    double t_s = 0.0;
    OdometryReading reading;
    SamplePlace at;
  };
  struct Truth {
    double t_s = 0.0;
    Pose2 pose;
    SamplePlace at;
    Truth() = default;
    // Not an aggregate: a dataset built in code (tests, benchmarks) writes `{t_s, pose}`, without
    // a place and without -Wmissing-field-initializers.
    Truth(double time_s, const Pose2& true_pose, SamplePlace place = {})
        : t_s(time_s), pose(true_pose), at(place) {}
  };
  struct Detections {
    double t_s = 0.0;
    std::vector<Detection> detections;
    SamplePlace at;  // the first of the rows of its time
  };
  struct Imu {
    double t_s = 0.0;
    ImuReading reading;
    SamplePlace at;
  };
  std::vector<Odometry> odometry;  // each in time order
  /// True poses; a dataset without truth gives unknown_truth() poses at the instants its
  /// localizers are to be sampled (their estimates kept, nothing scored), and a start.
  std::vector<Truth> truth;
  std::vector<Detections> detections;
  std::vector<Imu> imu;  // none: the robot has no IMU
  /// A round of ranges to beacons (the rows of one time).
  struct Ranges {
    double t_s = 0.0;
    std::vector<BeaconRange> ranges;
    SamplePlace at;  // the first of the rows of its time
  };
  std::vector<Ranges> ranges;  // none: the robot has no ranging sensor
  struct Scan {
    double t_s = 0.0;
    LaserScan scan;  // every scan of one robot has `laser->beams` ranges
    SamplePlace at;
  };
  std::vector<Scan> scans;  // none: the robot has no laser
  StreamSource odometry_source, truth_source, detections_source, imu_source, ranges_source,
      scans_source;
  std::optional<Pose2> start;  // default: the first true pose in the window
  // The range-bearing sensor's settings; unset ones are taken from the imported detections
  // (every robot's: one camera model), or the sensor's defaults when there are none.
  std::optional<double> fov_rad, min_range_m, max_range_m;
  // The ranging sensor (the world's `ultrasonic`): where its receivers sit on the robot, and the
  // longest range it reports (unset: the longest the data hold).
  std::vector<UltrasonicDef::Receiver> receivers{{{0.0, 0.0}, 0.0}};
  std::optional<double> ranging_max_range_m;
  // The laser (the world's `laser`): its beams as the simulated one spreads them (centred on the
  // mount's x axis; a scan's own first and last angles are turned into the mount's heading), its
  // ranges and its beam count (every scan's). Set with scans.
  std::optional<LaserDef> laser;
};

/// A ROS map_server map (YAML and image) the dataset gives: the world's `map`, carried in the log
/// (a replay reads nothing but the log).
struct ImportedMap {
  std::filesystem::path yaml_file;  // where it was read, for messages
  std::string yaml_text;
  std::string image_name;  // the YAML's `image`, relative, within the dataset's folder
  std::string image_bytes;
};

/// A ROS map_server map (its YAML and the image it names, which must lie in the YAML's folder: a
/// map from someone else must not make an import read /etc/passwd into a log), read once and
/// checked as the world's loader will read it from the log. Adds both files to `files_read`.
/// Throws InputError at the YAML's line.
ImportedMap read_map_server_map(const std::filesystem::path& yaml_file,
                                std::vector<std::filesystem::path>& files_read);

/// Checks `map` as the world's loader will read it from the log (its image by the YAML's `image`
/// beside it). Throws InputError naming the map.
void check_imported_map(const ImportedMap& map);

struct ImportedDataset {
  std::string name;               // the world's name
  nlohmann::ordered_json source;  // the header's "source"; t0 is added under `t0_key`
  std::string t0_key = "t0_s";
  std::vector<ImportedLandmark> landmarks;
  std::vector<ImportedBeacon> beacons;
  std::optional<ImportedMap> map;  // the walls a laser sees (optional)
  std::vector<ImportedRobot> robots;
  // Detections dropped while reading: when, and why (counted by reason within the window, for
  // the summary and the header).
  struct Dropped {
    double t_s = 0.0;
    std::string reason;
  };
  std::vector<Dropped> dropped;
  /// Every file the reader read: the log must not replace one of them (write_import refuses an
  /// `out` that is one, before anything is written).
  std::vector<std::filesystem::path> files;
};

/// The generated world's name for the dataset in `dir`: `prefix` and the folder's name, whose
/// characters other than ASCII letters, digits, '-', '_' and '.' become '_'. A folder may be named
/// anything a file system takes (control characters, bytes that are not UTF-8); the world's name
/// reaches YAML, JSON, file names and terminals.
std::string imported_world_name(std::string_view prefix, const std::filesystem::path& dir);

/// Which part of the dataset to import: [from_s, from_s + duration_s] after t0 (the earliest
/// time stamp of the imported data); the log's times start at t0 + from_s.
struct ImportWindow {
  double from_s = 0.0;
  std::optional<double> duration_s;
};

struct ImportSummary {
  std::size_t records = 0;           // written, the end record not counted
  std::size_t unscored_samples = 0;  // sampling instants without truth (unknown_truth)
  std::size_t odometry = 0, detection_readings = 0, detections = 0, ground_truth = 0, imu = 0,
              range_readings = 0, ranges = 0, laser_scans = 0, laser_no_returns = 0;
  std::vector<std::string> robots;
  double t0_s = 0.0;        // the log's time 0 in the dataset's times
  double duration_s = 0.0;  // of the log
  std::map<std::string, std::size_t> dropped;
  nlohmann::ordered_json header;
  std::string world_yaml;
};

/// Writes the log through a temporary file renamed at the end: a failed import leaves nothing
/// (and an older file of that name stays as it was). Throws InputError, before anything is
/// written, when `out` is one of the dataset's files, the window holds no data, spans more than a
/// log can (kSimulatedTimeRange; at the line of the first sample beyond), a robot has no start
/// pose, or a record would not pass a replay's checks (at its sample's line).
ImportSummary write_import(ImportedDataset dataset, const ImportWindow& window,
                           const std::filesystem::path& out);

/// The simulated laser whose `beams` beams spread as a ROS LaserScan's do from `first_rad` to
/// `last_rad` (its angle_min and its last beam's angle) on `mount`: LaserDef's beams are centred
/// on the mount's x axis, so the scan's middle angle turns the mount. Exact (to 1e-8 rad) for any
/// span short of a full turn; a scan whose last beam repeats its first (-pi..pi) is one. Throws
/// std::invalid_argument, saying the angles, when they span more than a full turn.
LaserDef laser_spread(double first_rad, double last_rad, int beams, double min_range_m,
                      double max_range_m, const Pose2& mount);

/// "12345 records (...), robots ..., dropped ..." for the command line.
std::string describe(const ImportSummary& summary);

}  // namespace locsim
