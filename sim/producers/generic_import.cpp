#include "sim/producers/generic_import.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <numbers>
#include <set>

#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/common/format.hpp"
#include "sim/common/yaml_node.hpp"
#include "sim/producers/text_table.hpp"
#include "sim/robot/robot_def.hpp"
#include "sim/stream/record_checks.hpp"
#include "sim/world/pgm.hpp"
#include "sim/world/world_def.hpp"
#include "sim/world/world_loader.hpp"

namespace locsim {

namespace fs = std::filesystem;

namespace {

using Layout = TextTable::Layout;

/// The landmarks of map.csv: id -> colour ("" when it has no color column).
using LandmarkColors = std::map<int, std::string>;
/// The ids of beacons.csv.
using BeaconIds = std::set<int>;

/// Whether a sub-folder's name can name a robot: ASCII letters, digits, '_' and '-'. Stricter than
/// the world format (no spaces, dots or slashes): the name also goes into the generated world's
/// YAML, the log's JSON header, output folders, TUM file names and `--robots a,b` lists, and a
/// folder may be named anything a file system takes (newlines, quotes, bytes that are not UTF-8).
bool is_robot_name(std::string_view name) {
  return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-';
  });
}

/// Whether the dataset holds `file` (an optional one).
bool has_file(const fs::path& file) {
  return dataset_file_type(file) != fs::file_type::not_found;
}

/// The angles a scan's first and last beams may have, as a ROS LaserScan gives them. [rad]
constexpr Range kScanAngleRange{-2.0 * std::numbers::pi, 2.0 * std::numbers::pi, "rad"};

/// robot.yaml's `laser`: the scanner as a ROS LaserScan message describes it (its beam count is
/// the scans').
struct LaserSpec {
  double angle_min_rad = 0.0;
  std::optional<double> angle_max_rad, angle_increment_rad;  // one of them
  double min_range_m = 0.0, max_range_m = 0.0;
  Pose2 mount;
  std::string where;  // "robot.yaml:L:C" of the section, for messages
};

/// The simulated laser that spreads `beams` beams as `spec` does (laser_spread).
LaserDef laser_of(const LaserSpec& spec, int beams, const TextTable& scans) {
  const double last_rad = spec.angle_max_rad
                              ? *spec.angle_max_rad
                              : spec.angle_min_rad + *spec.angle_increment_rad * (beams - 1);
  try {
    return laser_spread(spec.angle_min_rad, last_rad, beams, spec.min_range_m, spec.max_range_m,
                        spec.mount);
  } catch (const std::invalid_argument& e) {
    scans.fail(scans.rows().front(), scans.column("ranges"),
               std::string(e.what()) + " (" + spec.where + ": laser)");
  }
}

/// robot.yaml: the robot's geometry, its range-bearing sensor's field of view and ranges, its
/// ranging sensor's receivers and its laser's beams, where the data cannot tell them.
std::optional<LaserSpec> read_robot_yaml(const fs::path& file, ImportedRobot& robot) {
  const YamlNode root = YamlNode::load_file(file);
  root.allow_keys(
      {"radius_m", "wheel_base_m", "wheel_radius_m", "range_bearing", "ultrasonic", "laser"});
  robot.radius_m = root.get_double("radius_m", robot.radius_m, FootprintDef::kRadiusRange);
  robot.wheel_base_m =
      root.get_double("wheel_base_m", robot.wheel_base_m, RobotDef::kWheelBaseRange);
  robot.wheel_radius_m =
      root.get_double("wheel_radius_m", robot.wheel_radius_m, RobotDef::kWheelRadiusRange);
  if (const auto sensor = root.find("range_bearing")) {
    sensor->allow_keys({"fov", "fov_deg", "min_range_m", "max_range_m"});
    if (sensor->has("fov") || sensor->has("fov_deg"))
      robot.fov_rad = sensor->get_angle("fov", 0.0, RangeBearingDef::kFovRange);
    if (sensor->has("min_range_m"))
      robot.min_range_m = sensor->get_double("min_range_m", 0.0, RangeBearingDef::kRangeRange);
    if (sensor->has("max_range_m"))
      robot.max_range_m = sensor->get_double("max_range_m", 0.0, RangeBearingDef::kRangeRange);
  }
  // The world's keys (docs/worlds.md, ultrasonic): a receiver's position on the robot and height.
  if (const auto sensor = root.find("ultrasonic")) {
    sensor->allow_keys({"receivers", "max_range_m"});
    if (const auto receivers = sensor->find("receivers")) {
      robot.receivers.clear();
      for (const YamlNode& item : receivers->items()) {
        item.allow_keys({"position", "height_m"});
        if (robot.receivers.size() == UltrasonicDef::kMaxReceivers)
          item.fail("at most " + std::to_string(UltrasonicDef::kMaxReceivers) + " receivers");
        robot.receivers.push_back({item["position"].as_vec2(kBodyFrameRange),
                                   item.get_double("height_m", 0.0, kHeightRange)});
      }
      if (robot.receivers.empty()) receivers->fail("give at least one receiver");
    }
    if (sensor->has("max_range_m")) {
      robot.ranging_max_range_m =
          sensor->get_double("max_range_m", 0.0, UltrasonicDef::kMaxRangeRange);
    }
  }
  // The names of a ROS LaserScan's fields (sensor_msgs/msg/LaserScan), the mount as a world's.
  std::optional<LaserSpec> laser;
  if (const auto sensor = root.find("laser")) {
    sensor->allow_keys({"angle_min", "angle_min_deg", "angle_max", "angle_max_deg",
                        "angle_increment", "angle_increment_deg", "min_range_m", "max_range_m",
                        "mount"});
    LaserSpec spec;
    spec.where = sensor->place().where.str();
    if (!sensor->has("angle_min") && !sensor->has("angle_min_deg"))
      sensor->fail("give angle_min (or angle_min_deg): the first beam's angle");
    spec.angle_min_rad = sensor->get_angle("angle_min", 0.0, kScanAngleRange);
    const bool max = sensor->has("angle_max") || sensor->has("angle_max_deg");
    const bool increment = sensor->has("angle_increment") || sensor->has("angle_increment_deg");
    if (max == increment) sensor->fail("give angle_max or angle_increment (one of them)");
    if (max) {
      spec.angle_max_rad = sensor->get_angle("angle_max", 0.0, kScanAngleRange);
      if (!(*spec.angle_max_rad >= spec.angle_min_rad))
        (*sensor)[sensor->has("angle_max") ? "angle_max" : "angle_max_deg"].fail(
            "must not be below angle_min (a scan's beams go counter-clockwise)");
    } else {
      spec.angle_increment_rad = sensor->get_angle("angle_increment", 0.0, kScanAngleRange);
      if (!(*spec.angle_increment_rad > 0.0))
        (*sensor)[sensor->has("angle_increment") ? "angle_increment" : "angle_increment_deg"].fail(
            "must be positive (a scan's beams go counter-clockwise)");
    }
    spec.min_range_m = sensor->get_double("min_range_m", 0.0, LaserDef::kRangeRange);
    spec.max_range_m = (*sensor)["max_range_m"].as_double(LaserDef::kRangeRange);
    if (spec.min_range_m >= spec.max_range_m) sensor->fail("min_range_m must be below max_range_m");
    if (const auto mount = sensor->find("mount")) spec.mount = mount->as_pose(kBodyFrameRange);
    laser = spec;
  }
  return laser;
}

/// scans.csv's `ranges` field of `row`: the beams' ranges separated by spaces. Beams without a
/// return (NaN, inf, or outside [min_range, max_range], as a LaserScan's consumers take them) read
/// max_range, the simulated laser's "nothing there".
std::vector<float> scan_ranges(const TextTable& scans, const TextTable::Row& row, int column,
                               const LaserSpec& spec) {
  const std::string_view text = scans.text(row, column);
  std::vector<float> ranges;
  std::size_t i = 0;
  while (true) {
    while (i < text.size() && (text[i] == ' ' || text[i] == '\t')) ++i;
    if (i == text.size()) break;
    std::size_t end = i;
    while (end < text.size() && text[end] != ' ' && text[end] != '\t') ++end;
    const std::string_view token = text.substr(i, end - i);
    float value = 0.0f;
    const auto [stop, error] = std::from_chars(token.data(), token.data() + token.size(), value);
    if (error != std::errc() || stop != token.data() + token.size()) {
      throw InputError(SourceLocation{scans.file().string(), row.line,
                                      scans.column_in_line(row, column) + static_cast<int>(i)},
                       "ranges",
                       "beam " + std::to_string(ranges.size()) + ": " +
                           quote_input(std::string(token)) +
                           " is not a range (metres, or nan / inf for no return)");
    }
    const bool returned =
        std::isfinite(value) && value >= spec.min_range_m && value < spec.max_range_m;
    ranges.push_back(returned ? value : static_cast<float>(spec.max_range_m));
    i = end;
  }
  return ranges;
}

/// The stream's source, and the file among those the import read.
StreamSource source_of(const TextTable& table, int time_column, std::vector<fs::path>& files_read) {
  files_read.push_back(table.file());
  return {table.file().string(), table.column_name(time_column)};
}

SamplePlace place_of(const TextTable& table, const TextTable::Row& row, int column) {
  return {row.line, table.column_in_line(row, column)};
}

ImportedRobot read_robot(const fs::path& dir, const std::string& name,
                         const LandmarkColors& landmarks, const BeaconIds& beacons,
                         const std::vector<std::string>& robot_names,
                         std::vector<fs::path>& files_read) {
  ImportedRobot robot;
  robot.name = name;
  std::optional<LaserSpec> laser;
  if (has_file(dir / "robot.yaml")) {
    laser = read_robot_yaml(dir / "robot.yaml", robot);
    files_read.push_back(dir / "robot.yaml");
  }

  const TextTable odometry(dir / "odometry.csv", Layout::kCsv, {"t"},
                           {"v", "omega", "x", "y", "theta"});
  const int t = odometry.column("t");
  const int v = odometry.column("v"), omega = odometry.column("omega");
  const int x = odometry.column("x"), y = odometry.column("y"), theta = odometry.column("theta");
  const bool velocity = v >= 0 && omega >= 0, pose = x >= 0 && y >= 0 && theta >= 0;
  if ((v >= 0) != (omega >= 0) || (x >= 0) != (y >= 0) || (x >= 0) != (theta >= 0) ||
      (!velocity && !pose)) {
    throw InputError(SourceLocation{odometry.file().string(), odometry.rows().front().line - 1}, "",
                     "the header row must name t,v,omega or t,x,y,theta or both");
  }
  odometry.check_times(t, kDatasetTimeRange);
  robot.odometry_source = source_of(odometry, t, files_read);
  for (const auto& row : odometry.rows()) {
    ImportedRobot::Odometry o;
    o.t_s = odometry.number(row, t);
    o.at = place_of(odometry, row, t);
    o.reading.fields = 0;
    if (velocity) {
      o.reading.fields |= kOdometryVelocity;
      o.reading.v_mps = odometry.number(row, v, kReadingSpeedRange);
      o.reading.omega_radps = odometry.number(row, omega, kReadingTurnRateRange);
    }
    if (pose) {
      o.reading.fields |= kOdometryPose;
      o.reading.odometry = {odometry.number(row, x, kWorldCoordinateRange),
                            odometry.number(row, y, kWorldCoordinateRange),
                            wrap_angle(odometry.number(row, theta, kHeadingRange))};
    }
    robot.odometry.push_back(o);
  }

  const TextTable truth = tum_table(dir / "groundtruth.tum");
  truth.check_times(0, kDatasetTimeRange);
  robot.truth_source = source_of(truth, 0, files_read);
  robot.truth.reserve(truth.rows().size());
  for (const auto& row : truth.rows()) {
    const StampedPose sample = tum_pose(truth, row);
    robot.truth.push_back({sample.t_s, sample.pose, place_of(truth, row, 0)});
  }

  if (has_file(dir / "detections.csv")) {
    const TextTable detections(dir / "detections.csv", Layout::kCsv,
                               {"t", "id", "range", "bearing"}, {"target", "color"});
    const int dt = detections.column("t"), id = detections.column("id");
    const int range = detections.column("range"), bearing = detections.column("bearing");
    const int target = detections.column("target");
    const int color = detections.column("color");
    std::set<std::string> map_colors;
    for (const auto& [landmark, c] : landmarks) map_colors.insert(c);
    detections.check_times(dt, kDatasetTimeRange);
    robot.detections_source = source_of(detections, dt, files_read);
    for (const auto& row : detections.rows()) {
      const double t_s = detections.number(row, dt);
      Detection d;
      d.range_m = detections.number(row, range, kReadingRangeRange);
      d.bearing_rad = detections.number(row, bearing);
      if (d.range_m < 0.0) detections.fail(row, range, "a negative range");
      if (std::abs(d.bearing_rad) > 2.0 * std::numbers::pi)
        detections.fail(row, bearing, "a bearing beyond +-2 pi (radians expected)");
      const std::string_view kind = target >= 0 ? detections.text(row, target) : "landmark";
      if (kind == "robot") {
        d.target = DetectionTarget::kRobot;
        const long long index =
            detections.whole(row, id, 0, static_cast<long long>(robot_names.size()) - 1);
        d.id = static_cast<int>(index);
        if (robot_names[static_cast<std::size_t>(index)] == name)
          detections.fail(row, id, "a robot cannot detect itself");
      } else if (kind == "landmark" || kind.empty()) {
        d.id =
            static_cast<int>(detections.whole(row, id, -1, static_cast<long long>(kIdRange.max)));
        if (d.id >= 0 && !landmarks.contains(d.id))
          detections.fail(row, id, "landmark " + std::to_string(d.id) + " is not in map.csv");
        // A detector that tells colours, not identities: id -1 and the colour seen.
        const std::string seen = color >= 0 ? std::string(detections.text(row, color)) : "";
        if (!seen.empty()) {
          if (!map_colors.contains(seen)) {
            detections.fail(row, color,
                            "no landmark of colour " + quote_input(seen) +
                                " in map.csv (give map.csv a color column naming each one's)");
          }
          if (const auto own = landmarks.find(d.id);
              own != landmarks.end() && own->second != seen) {
            detections.fail(row, color,
                            "landmark " + std::to_string(d.id) + " is " +
                                (own->second.empty() ? "of no colour" : own->second) +
                                " in map.csv, not " + quote_input(seen));
          }
          d.color = seen;
        }
      } else {
        detections.fail(row, target,
                        "target " + quote_input(kind) + ": expected landmark or robot");
      }
      d.truth_id = d.id;
      if (robot.detections.empty() || robot.detections.back().t_s != t_s)
        robot.detections.push_back({t_s, {}, place_of(detections, row, dt)});
      robot.detections.back().detections.push_back(d);
    }
  }

  if (has_file(dir / "imu.csv")) {
    const TextTable imu(dir / "imu.csv", Layout::kCsv, {"t", "yaw_rate"}, {"accel_x", "accel_y"});
    const int it = imu.column("t"), yaw = imu.column("yaw_rate");
    const int ax = imu.column("accel_x"), ay = imu.column("accel_y");
    if ((ax >= 0) != (ay >= 0)) {
      throw InputError(SourceLocation{imu.file().string(), imu.rows().front().line - 1}, "",
                       "the header row names accel_x or accel_y alone: give both or neither");
    }
    imu.check_times(it, kDatasetTimeRange);
    robot.imu_source = source_of(imu, it, files_read);
    for (const auto& row : imu.rows()) {
      ImportedRobot::Imu sample;
      sample.t_s = imu.number(row, it);
      sample.at = place_of(imu, row, it);
      sample.reading.yaw_rate_radps = imu.number(row, yaw, kReadingTurnRateRange);
      if (ax >= 0) {
        sample.reading.accel_mps2 = {imu.number(row, ax, kReadingAccelRange),
                                     imu.number(row, ay, kReadingAccelRange)};
      }
      robot.imu.push_back(sample);
    }
  }

  if (has_file(dir / "ranges.csv")) {
    const TextTable ranges(dir / "ranges.csv", Layout::kCsv, {"t", "beacon", "range"},
                           {"receiver"});
    const int rt = ranges.column("t"), beacon = ranges.column("beacon");
    const int range = ranges.column("range"), receiver = ranges.column("receiver");
    ranges.check_times(rt, kDatasetTimeRange);
    robot.ranges_source = source_of(ranges, rt, files_read);
    for (const auto& row : ranges.rows()) {
      const double t_s = ranges.number(row, rt);
      BeaconRange r;
      r.beacon_id =
          static_cast<int>(ranges.whole(row, beacon, 0, static_cast<long long>(kIdRange.max)));
      if (!beacons.contains(r.beacon_id)) {
        ranges.fail(row, beacon,
                    "beacon " + std::to_string(r.beacon_id) +
                        (beacons.empty() ? " is not in beacons.csv (the dataset has none)"
                                         : " is not in beacons.csv"));
      }
      r.range_m = ranges.number(row, range, kReadingRangeRange);
      if (receiver >= 0) {
        // robot.yaml's receivers, in order; without one the robot has a single receiver.
        r.receiver = static_cast<int>(
            ranges.whole(row, receiver, 0, static_cast<long long>(robot.receivers.size()) - 1));
      }
      if (robot.ranges.empty() || robot.ranges.back().t_s != t_s)
        robot.ranges.push_back({t_s, {}, place_of(ranges, row, rt)});
      robot.ranges.back().ranges.push_back(r);
    }
  }

  if (has_file(dir / "scans.csv")) {
    const TextTable scans(dir / "scans.csv", Layout::kCsv, {"t", "ranges"});
    const int st = scans.column("t"), ranges = scans.column("ranges");
    if (!laser) {
      throw InputError(SourceLocation{scans.file().string(), scans.rows().front().line - 1}, "",
                       "laser scans need the scanner's angles and ranges: give robot.yaml a "
                       "laser: {angle_min, angle_max, max_range_m} (a LaserScan's fields)");
    }
    scans.check_times(st, kDatasetTimeRange);
    robot.scans_source = source_of(scans, st, files_read);
    robot.scans.reserve(scans.rows().size());
    for (const auto& row : scans.rows()) {
      ImportedRobot::Scan scan{scans.number(row, st),
                               {scan_ranges(scans, row, ranges, *laser)},
                               place_of(scans, row, st)};
      if (scan.scan.ranges_m.empty()) scans.fail(row, ranges, "a scan without ranges");
      if (!robot.scans.empty() &&
          scan.scan.ranges_m.size() != robot.scans.front().scan.ranges_m.size()) {
        scans.fail(row, ranges,
                   "a scan of " + std::to_string(scan.scan.ranges_m.size()) +
                       " ranges; the first (line " + std::to_string(robot.scans.front().at.line) +
                       ") has " + std::to_string(robot.scans.front().scan.ranges_m.size()));
      }
      robot.scans.push_back(std::move(scan));
    }
    if (robot.scans.size() > 0 && robot.scans.front().scan.ranges_m.size() >
                                      static_cast<std::size_t>(LaserDef::kBeamsRange.max)) {
      scans.fail(scans.rows().front(), ranges,
                 "more than " + short_number(LaserDef::kBeamsRange.max) + " beams");
    }
    robot.laser =
        laser_of(*laser, static_cast<int>(robot.scans.front().scan.ranges_m.size()), scans);
  }
  return robot;
}

}  // namespace

ImportedDataset read_generic(const fs::path& dir) {
  if (dataset_file_type(dir) != fs::file_type::directory) {
    throw InputError(SourceLocation{dir.string()}, "",
                     "not a folder (expected map.csv and odometry.csv, groundtruth.tum, "
                     "detections.csv in it or in one sub-folder per robot)");
  }
  ImportedDataset dataset;
  const fs::path absolute = fs::absolute(dir).lexically_normal();
  dataset.name = imported_world_name("imported_", dir);
  LandmarkColors landmarks;
  if (has_file(dir / "map.csv")) {
    const TextTable map(dir / "map.csv", Layout::kCsv, {"id", "x", "y"}, {"color"});
    dataset.files.push_back(map.file());
    const int id_column = map.column("id"), x = map.column("x"), y = map.column("y");
    const int color = map.column("color");
    for (const auto& row : map.rows()) {
      const int id =
          static_cast<int>(map.whole(row, id_column, 0, static_cast<long long>(kIdRange.max)));
      const std::string c = color >= 0 ? std::string(map.text(row, color)) : "";
      if (!c.empty() && !named_colors().contains(c)) {
        std::string known;
        for (const auto& [n, rgb] : named_colors()) known += (known.empty() ? "" : ", ") + n;
        map.fail(row, color, "unknown colour " + quote_input(c) + " (known: " + known + ")");
      }
      if (!landmarks.emplace(id, c).second) map.fail(row, id_column, "landmark id listed twice");
      dataset.landmarks.push_back(
          {id,
           {map.number(row, x, kWorldCoordinateRange), map.number(row, y, kWorldCoordinateRange)},
           c});
    }
  }
  BeaconIds beacon_ids;
  if (has_file(dir / "beacons.csv")) {
    const TextTable beacons(dir / "beacons.csv", Layout::kCsv, {"id", "x", "y"}, {"z"});
    dataset.files.push_back(beacons.file());
    const int id_column = beacons.column("id"), x = beacons.column("x"), y = beacons.column("y");
    const int z = beacons.column("z");
    for (const auto& row : beacons.rows()) {
      const int id =
          static_cast<int>(beacons.whole(row, id_column, 0, static_cast<long long>(kIdRange.max)));
      if (!beacon_ids.insert(id).second) beacons.fail(row, id_column, "beacon id listed twice");
      dataset.beacons.push_back({id,
                                 {beacons.number(row, x, kWorldCoordinateRange),
                                  beacons.number(row, y, kWorldCoordinateRange)},
                                 z >= 0 ? beacons.number(row, z, kHeightRange) : 0.0});
    }
  }
  if (has_file(dir / "occupancy.yaml"))
    dataset.map = read_map_server_map(dir / "occupancy.yaml", dataset.files);
  std::vector<std::pair<std::string, fs::path>> robots;
  if (has_file(dir / "odometry.csv")) {
    robots.emplace_back("robot", dir);
  } else {
    // Every entry is looked at (with error codes: std::filesystem would throw a raw
    // filesystem_error at a symbolic link loop); one that cannot be looked up may be a robot's
    // folder, so it is refused, not skipped.
    std::error_code error;
    for (fs::directory_iterator it(dir, error), end; !error && it != end; it.increment(error)) {
      const fs::path& entry = it->path();
      if (dataset_file_type(entry) != fs::file_type::directory || !has_file(entry / "odometry.csv"))
        continue;
      const std::string name = entry.filename().string();
      if (!is_robot_name(name)) {
        throw InputError(SourceLocation{dir.string()}, "",
                         "the robot folder " + quote_input(name) +
                             " has a name that cannot name a robot: a robot is named after its "
                             "folder, and a robot's name is ASCII letters, digits, '_' and '-' "
                             "(docs/real_data.md); rename the folder");
      }
      robots.emplace_back(name, entry);
    }
    if (error) {
      throw InputError(SourceLocation{dir.string()}, "",
                       "cannot list the folder: " + error.message());
    }
    std::sort(robots.begin(), robots.end());
  }
  if (robots.empty()) {
    throw InputError(SourceLocation{dir.string()}, "",
                     "no odometry.csv in the folder or in any sub-folder");
  }
  std::vector<std::string> names;
  for (const auto& [name, path] : robots) names.push_back(name);
  dataset.source = {{"format", "generic"}, {"path", absolute.string()}, {"robots", names}};
  for (const auto& [name, path] : robots)
    dataset.robots.push_back(read_robot(path, name, landmarks, beacon_ids, names, dataset.files));
  return dataset;
}

}  // namespace locsim
