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
#include <vector>

#include "sim/common/math.hpp"
#include "sim/sensors/readings.hpp"

namespace locsim {

struct ImportedLandmark {
  int id = 0;
  Vec2 position_m{0.0, 0.0};
  std::string color = {};  // a named colour (world_loader named_colors); empty: one in turn
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
  };
  struct Detections {
    double t_s = 0.0;
    std::vector<Detection> detections;
  };
  struct Imu {
    double t_s = 0.0;
    ImuReading reading;
  };
  std::vector<Odometry> odometry;  // each in time order
  std::vector<StampedPose> truth;
  std::vector<Detections> detections;
  std::vector<Imu> imu;        // none: the robot has no IMU
  std::optional<Pose2> start;  // default: the first true pose in the window
  // The range-bearing sensor's settings; unset ones are taken from the imported detections
  // (every robot's: one camera model), or the sensor's defaults when there are none.
  std::optional<double> fov_rad, min_range_m, max_range_m;
};

struct ImportedDataset {
  std::string name;               // the world's name
  nlohmann::ordered_json source;  // the header's "source"; t0 is added under `t0_key`
  std::string t0_key = "t0_s";
  std::vector<ImportedLandmark> landmarks;
  std::vector<ImportedRobot> robots;
  // Detections dropped while reading: when, and why (counted by reason within the window, for
  // the summary and the header).
  struct Dropped {
    double t_s = 0.0;
    std::string reason;
  };
  std::vector<Dropped> dropped;
};

/// Which part of the dataset to import: [from_s, from_s + duration_s] after t0 (the earliest
/// time stamp of the imported data); the log's times start at t0 + from_s.
struct ImportWindow {
  double from_s = 0.0;
  std::optional<double> duration_s;
};

struct ImportSummary {
  std::size_t records = 0;  // written, the end record not counted
  std::size_t odometry = 0, detection_readings = 0, detections = 0, ground_truth = 0, imu = 0;
  std::vector<std::string> robots;
  double t0_s = 0.0;        // the log's time 0 in the dataset's times
  double duration_s = 0.0;  // of the log
  std::map<std::string, std::size_t> dropped;
  nlohmann::ordered_json header;
  std::string world_yaml;
};

/// Writes the log through a temporary file renamed at the end: a failed import leaves nothing
/// (and an older file of that name stays as it was). Throws InputError when the window holds no
/// data or a robot has no start pose.
ImportSummary write_import(ImportedDataset dataset, const ImportWindow& window,
                           const std::filesystem::path& out);

/// "12345 records (...), robots ..., dropped ..." for the command line.
std::string describe(const ImportSummary& summary);

}  // namespace locsim
