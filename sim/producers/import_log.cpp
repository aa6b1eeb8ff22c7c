#include "sim/producers/import_log.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <set>
#include <stdexcept>
#include <tuple>

#include "sim/common/base64.hpp"
#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/common/format.hpp"
#include "sim/common/yaml_node.hpp"
#include "sim/run/runner.hpp"
#include "sim/sensors/sensor_defs.hpp"
#include "sim/stream/log_file.hpp"
#include "sim/stream/record_checks.hpp"
#include "sim/world/pgm.hpp"
#include "sim/world/world_loader.hpp"

namespace locsim {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

namespace {

// The generated world's physics rate: the Vicon rate of MRCLAM's ground truth, and a rate with
// many divisors for the sensors' nominal rates.
constexpr double kPhysicsHz = 100.0;
// The name the dataset's occupancy map (its YAML) has in the generated world's folder.
constexpr const char* kMapFile = "occupancy.yaml";
constexpr std::array<double, 9> kNominalRatesHz{1, 2, 4, 5, 10, 20, 25, 50, 100};
// Named colours of the world format that draw well on the floor, given to landmarks in turn.
constexpr std::array<const char*, 10> kPalette{"red",  "green",   "blue",   "orange", "purple",
                                               "cyan", "magenta", "yellow", "brown",  "pink"};

/// The divisor of the physics rate nearest (in ratio) to the data's mean rate: the sensors'
/// rate_hz must divide the physics rate, and readings come at the dataset's own times anyway.
template <typename Samples>
double nominal_rate_hz(const Samples& samples) {
  if (samples.size() < 2 || !(samples.back().t_s > samples.front().t_s)) return 1.0;
  const double mean_hz =
      static_cast<double>(samples.size() - 1) / (samples.back().t_s - samples.front().t_s);
  double best = kNominalRatesHz.front();
  for (const double rate : kNominalRatesHz) {
    if (std::abs(std::log(rate / mean_hz)) < std::abs(std::log(best / mean_hz))) best = rate;
  }
  return best;
}

/// Keeps the samples in [lo, hi] and makes their times relative to lo.
template <typename Sample>
void window_samples(std::vector<Sample>& samples, double lo, double hi) {
  std::erase_if(samples, [&](const Sample& s) { return s.t_s < lo || s.t_s > hi; });
  for (Sample& s : samples) s.t_s -= lo;
}

std::string number(double value) {
  return short_number(value);
}

/// A time for a message, to the microsecond: a dataset's time rebuilt from the log's (t + t0) or
/// a difference of two is not exactly the number the file gave ("0.012000083923339844").
std::string time_text(double t_s) {
  std::string text = fixed(t_s, 6);
  while (text.back() == '0') text.pop_back();
  if (text.back() == '.') text.pop_back();
  return text;
}

/// `text` as a YAML scalar, double-quoted and escaped: a JSON string is one (YAML 1.2 reads JSON),
/// so no text (a newline, a quote, "a: b") can end the scalar and write a key of its own into the
/// generated world. Every string that enters the world's YAML goes through here.
std::string yaml_string(const std::string& text) {
  return json(text).dump();
}

/// Whether the JSON value's strings are all UTF-8, as the log's header must be (a path is bytes;
/// nlohmann's dump refuses others with a raw type_error).
bool is_json_text(const json& value) {
  try {
    (void)value.dump();
    return true;
  } catch (const json::type_error&) {
    return false;
  }
}

/// Refuses an `out` (or its temporary) that is one of the files the import read: the log would
/// replace, or its temporary overwrite, the dataset's own file. Before anything is written.
void check_not_a_dataset_file(const fs::path& out, const fs::path& partial,
                              const std::vector<fs::path>& files) {
  for (const fs::path& file : files) {
    for (const fs::path& written : {out, partial}) {
      std::error_code error;  // set when either does not exist: then they are not one file
      if (fs::equivalent(written, file, error)) {
        // Named as the reader named it too when the paths differ (a link, "a/../b").
        throw InputError(
            "--out: " + quote_input(out.string()) +
            (written == out ? "" : ": its temporary " + quote_input(written.string())) +
            " is a file of the dataset being imported" +
            (written == file ? "" : " (" + quote_input(file.string()) + ")") +
            ", which the log would replace: name another file");
      }
    }
  }
}

/// The earliest sample of some streams, and where it stands.
/// Calls f(samples, source) for each of the robot's streams: the readings of each kind, and the
/// true poses.
template <typename Robot, typename F>
void for_each_stream(Robot& robot, F&& f) {
  f(robot.odometry, robot.odometry_source);
  f(robot.truth, robot.truth_source);
  f(robot.detections, robot.detections_source);
  f(robot.imu, robot.imu_source);
  f(robot.ranges, robot.ranges_source);
  f(robot.scans, robot.scans_source);
}

struct Earliest {
  double t_s = std::numeric_limits<double>::infinity();
  SourceLocation where;

  template <typename Samples>
  void consider(const Samples& samples, const StreamSource& source) {
    // Each stream is in time order (the readers check it): its first sample is its earliest.
    if (!samples.empty() && samples.front().t_s < t_s) {
      t_s = samples.front().t_s;
      where = {source.file, samples.front().at.line, samples.front().at.column};
    }
  }
};

/// The first sample of a stream (in the log's times) beyond the longest time a log can span.
struct Beyond {
  double t_s = std::numeric_limits<double>::infinity();
  SourceLocation where;
  std::string key;

  template <typename Samples>
  void consider(const Samples& samples, const StreamSource& source) {
    const auto it = std::find_if(samples.begin(), samples.end(), [](const auto& sample) {
      return sample.t_s > kSimulatedTimeRange.max;
    });
    if (it != samples.end() && it->t_s < t_s) {
      t_s = it->t_s;
      where = {source.file, it->at.line, it->at.column};
      key = source.time_key;
    }
  }
};

}  // namespace

LaserDef laser_spread(double first_rad, double last_rad, int beams, double min_range_m,
                      double max_range_m, const Pose2& mount) {
  LaserDef def;
  def.beams = beams;
  def.min_range_m = min_range_m;
  def.max_range_m = max_range_m;
  const double span_rad = last_rad - first_rad;
  const double full_turn = 2.0 * std::numbers::pi;
  if (span_rad > full_turn + 1e-9) {
    throw std::invalid_argument(std::to_string(beams) + " beams from angle_min " +
                                short_number(first_rad) + " to " + short_number(last_rad) +
                                " rad span more than a full turn");
  }
  // LaserDef treats a field of view of a full turn as beams 2 pi / n apart; a span of 2 pi means
  // n - 1 gaps, which a field of view just short of it gives.
  def.fov_rad = beams == 1 ? LaserDef::kFovRange.min
                           : std::clamp(span_rad, LaserDef::kFovRange.min, full_turn - 2e-9);
  def.common.mount = mount;
  def.common.mount.theta =
      wrap_angle(mount.theta + (beams == 1 ? first_rad : 0.5 * (first_rad + last_rad)));
  return def;
}

ImportedMap read_map_server_map(const fs::path& yaml_file, std::vector<fs::path>& files_read) {
  const fs::path dir = yaml_file.parent_path().empty() ? fs::path(".") : yaml_file.parent_path();
  ImportedMap map;
  map.yaml_file = yaml_file;
  map.yaml_text = read_input_file(map.yaml_file, kMaxYamlFileBytes);
  const YamlNode root = YamlNode::load_string(map.yaml_text, map.yaml_file.string());
  const YamlNode image = root["image"];
  const fs::path name = fs::path(image.as_string()).lexically_normal();
  if (name.empty() || name.is_absolute() || name.has_root_name() || *name.begin() == "..")
    image.fail("the image must be a file in the map's folder (a relative path within it)");
  const fs::path image_file = dir / name;
  // A symbolic link that leads out of the folder is refused as such a path is.
  std::error_code error;
  const fs::path real_dir = fs::weakly_canonical(dir, error);
  const fs::path real_image = error ? fs::path() : fs::weakly_canonical(image_file, error);
  const auto [outside, ignored] =
      std::mismatch(real_dir.begin(), real_dir.end(), real_image.begin(), real_image.end());
  if (error || outside != real_dir.end())
    image.fail("the image leads out of the map's folder (a symbolic link to " +
               quote_input(real_image.string()) + ")");
  map.image_name = name.generic_string();
  try {
    map.image_bytes = read_input_file(image_file, kMaxPgmFileBytes);
  } catch (const InputError& e) {
    image.fail(e.what());
  }
  check_imported_map(map);
  files_read.push_back(map.yaml_file);
  files_read.push_back(image_file);
  return map;
}

void check_imported_map(const ImportedMap& map) {
  const fs::path yaml = fs::absolute(map.yaml_file);
  const InputSandbox sandbox(
      {{InputSandbox::key(yaml), map.yaml_text},
       {InputSandbox::key(yaml.parent_path() / map.image_name), map.image_bytes}},
      "the map " + quote_input(map.yaml_file.string()));
  (void)load_occupancy_map(yaml);
}

std::string imported_world_name(std::string_view prefix, const fs::path& dir) {
  fs::path folder = fs::absolute(dir).lexically_normal();
  if (!folder.has_filename()) folder = folder.parent_path();  // "data/" and "." name their folder
  std::string name(prefix);
  for (const char c : folder.filename().string()) {
    const bool safe = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                      c == '-' || c == '_' || c == '.';
    name += safe ? c : '_';
  }
  return name;
}

ImportSummary write_import(ImportedDataset dataset, const ImportWindow& window,
                           const fs::path& out) {
  const fs::path partial = out.string() + ".partial";
  check_not_a_dataset_file(out, partial, dataset.files);
  const SourceLocation where{dataset.source.value("path", std::string())};
  if (!is_json_text(dataset.source)) {
    throw InputError(where, "",
                     "the dataset's path (or a robot's name) is not UTF-8 text, which the log's "
                     "header must hold: rename the folder");
  }
  Earliest earliest;
  for (const ImportedRobot& robot : dataset.robots) {
    for_each_stream(robot, [&](const auto& samples, const StreamSource& source) {
      earliest.consider(samples, source);
    });
  }
  const double t0 = earliest.t_s;
  if (!std::isfinite(t0)) throw InputError(where, "", "the dataset holds no readings");
  const double lo = t0 + window.from_s;
  const double hi =
      window.duration_s ? lo + *window.duration_s : std::numeric_limits<double>::infinity();

  ImportSummary summary;
  summary.t0_s = lo;
  for (const auto& d : dataset.dropped) {
    if (d.t_s >= lo && d.t_s <= hi) ++summary.dropped[d.reason];
  }
  double end_s = 0.0;
  double max_bearing_rad = 0.0;
  double min_range_m = std::numeric_limits<double>::infinity(), max_range_m = 0.0;
  for (ImportedRobot& robot : dataset.robots) {
    Beyond beyond;
    for_each_stream(robot, [&](auto& samples, const StreamSource& source) {
      window_samples(samples, lo, hi);
      beyond.consider(samples, source);
      if (!samples.empty()) end_s = std::max(end_s, samples.back().t_s);
    });
    if (std::isfinite(beyond.t_s)) {
      throw InputError(
          beyond.where, beyond.key,
          "time " + time_text(beyond.t_s + lo) + " s is " + time_text(beyond.t_s) +
              " s after the log's start (" + time_text(lo) + " s: the earliest time stamp, at " +
              earliest.where.str() +
              (window.from_s > 0.0 ? ", plus --from " + time_text(window.from_s) + " s" : "") +
              "); a log spans at most " + rounded_number(kSimulatedTimeRange.max) +
              " s (116 days): import a window of the dataset (--from S --duration S)");
    }
    if (!robot.start) {
      if (robot.truth.empty()) {
        throw InputError(where, "",
                         "robot " + quote_input(robot.name) +
                             " has no ground truth in the imported time window, so it has no "
                             "start pose (give one, or import another window)");
      }
      robot.start = robot.truth.front().pose;
      if (!truth_known(*robot.start)) {
        throw InputError(
            where, "",
            "robot " + quote_input(robot.name) + " has no ground truth, so it needs a start pose");
      }
    }
    for (const auto& reading : robot.detections) {
      for (const Detection& d : reading.detections) {
        max_bearing_rad = std::max(max_bearing_rad, std::abs(d.bearing_rad));
        min_range_m = std::min(min_range_m, d.range_m);
        max_range_m = std::max(max_range_m, d.range_m);
      }
    }
    summary.robots.push_back(robot.name);
  }
  // The sensor as the data shows it: the field of view and the ranges that held every detection.
  const RangeBearingDef defaults;
  double fov_rad = defaults.fov_rad, min_m = defaults.min_range_m, max_m = defaults.max_range_m;
  if (std::isfinite(min_range_m)) {
    fov_rad = std::clamp(2.0 * max_bearing_rad, RangeBearingDef::kFovRange.min,
                         RangeBearingDef::kFovRange.max);
    min_m = min_range_m;
    // The loader wants min < max; a single distance seen gives the narrowest such interval.
    max_m = max_range_m > min_range_m ? max_range_m : min_range_m + 1e-3;
  }

  // The generated world (docs/real_data.md): the landmarks, the robots at their first true
  // poses, no walls; the scenario only says how long the log is and that the start is known.
  std::map<int, std::string> colors;
  std::string yaml = "# Generated by `locsim import` (docs/real_data.md)\n";
  yaml += "name: " + yaml_string(dataset.name) + "\n";
  yaml += "physics: {step_hz: " + number(kPhysicsHz) + "}\n";
  // The map's files, carried in the header under the world's folder (log_source reads them from
  // there, whatever the folder is when it is replayed).
  const fs::path world_dir = fs::absolute(out).parent_path();
  std::map<std::string, std::string> carried;
  if (dataset.map) {
    yaml += "map: " + yaml_string(kMapFile) + "\n";
    carried[InputSandbox::key(world_dir / kMapFile)] = dataset.map->yaml_text;
    carried[InputSandbox::key(world_dir / dataset.map->image_name)] = dataset.map->image_bytes;
  }
  if (!dataset.beacons.empty()) yaml += "beacons:\n";
  for (const ImportedBeacon& b : dataset.beacons) {
    yaml += "  - {id: " + std::to_string(b.id) + ", position: [" + number(b.position_m.x()) + ", " +
            number(b.position_m.y()) + "], height_m: " + number(b.height_m) + "}\n";
  }
  if (!dataset.landmarks.empty()) yaml += "landmarks:\n";
  for (std::size_t i = 0; i < dataset.landmarks.size(); ++i) {
    const ImportedLandmark& l = dataset.landmarks[i];
    const std::string color = l.color.empty() ? kPalette[i % kPalette.size()] : l.color;
    colors[l.id] = color;
    yaml += "  - {id: " + std::to_string(l.id) + ", position: [" + number(l.position_m.x()) + ", " +
            number(l.position_m.y()) + "], color: " + yaml_string(color) + ", radius_m: 0.05}\n";
  }
  yaml += "robots:\n";
  for (const ImportedRobot& robot : dataset.robots) {
    yaml += "  - name: " + yaml_string(robot.name) + "\n";
    yaml += "    footprint: {radius_m: " + number(robot.radius_m) + "}\n";
    yaml += "    wheel_base_m: " + number(robot.wheel_base_m) + "\n";
    yaml += "    wheel_radius_m: " + number(robot.wheel_radius_m) + "\n";
    yaml += "    start: {x: " + number(robot.start->x) + ", y: " + number(robot.start->y) +
            ", theta: " + number(robot.start->theta) + "}\n";
    yaml += "    sensors:\n";
    std::uint8_t reports = 0;
    for (const auto& o : robot.odometry) reports |= o.reading.fields;
    if (reports == 0) reports = kOdometryVelocity;
    std::string report_list;
    for (const auto& [bit, name] : {std::pair{kOdometryTicks, "ticks"},
                                    {kOdometryPose, "pose"},
                                    {kOdometryVelocity, "velocity"}}) {
      if ((reports & bit) != 0) report_list += std::string(report_list.empty() ? "" : ", ") + name;
    }
    // Nominal rates (the readings keep the dataset's own times).
    yaml += "      encoders: {rate_hz: " + number(nominal_rate_hz(robot.odometry)) +
            ", reports: [" + report_list + "]}\n";
    if (!robot.imu.empty()) {
      // Nominal rate; the readings keep the dataset's times. No noise settings: the data have
      // their own.
      yaml += "      imu: {rate_hz: " + number(nominal_rate_hz(robot.imu)) + "}\n";
    }
    if (!robot.ranges.empty()) {
      // The ranging sensor: its receivers where robot.yaml puts them, and a maximum range that
      // holds every range of the data (a longer one would be dropped by a simulation of it).
      // Nominal rate; no noise settings: the data have their own (locsim calibrate fits them).
      double longest_m = 0.0;
      for (const auto& round : robot.ranges) {
        for (const BeaconRange& r : round.ranges)
          if (std::isfinite(r.range_m)) longest_m = std::max(longest_m, r.range_m);
      }
      std::string receivers;
      for (const UltrasonicDef::Receiver& receiver : robot.receivers) {
        receivers += std::string(receivers.empty() ? "" : ", ") + "{position: [" +
                     number(receiver.position_m.x()) + ", " + number(receiver.position_m.y()) +
                     "], height_m: " + number(receiver.height_m) + "}";
      }
      const double ranging_max_m = robot.ranging_max_range_m.value_or(
          std::max(longest_m, UltrasonicDef::kMaxRangeRange.min));
      yaml += "      ultrasonic: {rate_hz: " + number(nominal_rate_hz(robot.ranges)) +
              ", receivers: [" + receivers + "], max_range_m: " + number(ranging_max_m) + "}\n";
    }
    if (robot.laser) {
      // As the scans give it; no noise settings: the data have their own.
      const LaserDef& l = *robot.laser;
      yaml += "      laser: {rate_hz: " + number(nominal_rate_hz(robot.scans)) +
              ", fov: " + number(l.fov_rad) + ", beams: " + std::to_string(l.beams) +
              ", min_range_m: " + number(l.min_range_m) +
              ", max_range_m: " + number(l.max_range_m) +
              ", mount: {x: " + number(l.common.mount.x) + ", y: " + number(l.common.mount.y) +
              ", theta: " + number(l.common.mount.theta) + "}}\n";
    }
    // A robot that ranges beacons and neither detects nor has landmarks to detect has no camera
    // (a twin of it would otherwise simulate one).
    if (!robot.detections.empty() || !dataset.landmarks.empty() ||
        (robot.ranges.empty() && robot.scans.empty())) {
      yaml += "      range_bearing: {rate_hz: " + number(nominal_rate_hz(robot.detections)) +
              ", fov: " + number(robot.fov_rad.value_or(fov_rad)) +
              ", min_range_m: " + number(robot.min_range_m.value_or(min_m)) +
              ", max_range_m: " + number(robot.max_range_m.value_or(max_m)) +
              ", sees_robots: true}\n";
    }
  }
  summary.duration_s = std::max(end_s, ScenarioDef::kDurationRange.min);
  yaml += "scenario:\n  name: imported\n  duration_s: " + number(summary.duration_s) + "\n";
  yaml += "  groundtruth_hz: " + number(kPhysicsHz) + "\n";
  yaml += "  localization: {initial_pose: known, sigma_xy_m: 0, sigma_theta: 0}\n";

  const std::string world_file = dataset.name + ".yaml";
  if (!is_json_text(world_dir.string())) {
    throw InputError("--out: " + quote_input(out.string()) +
                     ": the path is not UTF-8 text, which the log's header must hold");
  }
  // Checked as LogSource will read it: a dataset whose numbers the world format refuses (a
  // landmark beyond the coordinate range, say) is refused here, before anything is written.
  {
    const InputSandbox sandbox(carried, "the import");
    parse_world(YamlNode::load_string(yaml, world_file), world_dir);
  }

  // The records in stream order (stream/record.hpp): by time; at equal times the readings
  // (robot by robot, odometry before detections), then the true poses.
  struct Entry {
    double t_s;
    int cls;  // 0 reading, 1 ground truth
    std::size_t robot;
    // 0 odometry, 1 IMU, 2 ranges, 3 laser, 4 detections (the simulator's order: encoders, IMU,
    // ranging, laser, cameras).
    int kind;
    std::size_t index;
    bool operator<(const Entry& o) const {
      return std::tie(t_s, cls, robot, kind, index) <
             std::tie(o.t_s, o.cls, o.robot, o.kind, o.index);
    }
  };
  std::vector<Entry> order;
  for (std::size_t r = 0; r < dataset.robots.size(); ++r) {
    const ImportedRobot& robot = dataset.robots[r];
    for (std::size_t i = 0; i < robot.odometry.size(); ++i)
      order.push_back({robot.odometry[i].t_s, 0, r, 0, i});
    for (std::size_t i = 0; i < robot.imu.size(); ++i)
      order.push_back({robot.imu[i].t_s, 0, r, 1, i});
    for (std::size_t i = 0; i < robot.ranges.size(); ++i)
      order.push_back({robot.ranges[i].t_s, 0, r, 2, i});
    for (std::size_t i = 0; i < robot.scans.size(); ++i)
      order.push_back({robot.scans[i].t_s, 0, r, 3, i});
    for (std::size_t i = 0; i < robot.detections.size(); ++i)
      order.push_back({robot.detections[i].t_s, 0, r, 4, i});
    for (std::size_t i = 0; i < robot.truth.size(); ++i)
      order.push_back({robot.truth[i].t_s, 1, r, 0, i});
  }
  std::sort(order.begin(), order.end());

  json source = dataset.source;
  source[dataset.t0_key] = lo;
  json dropped = json::object();
  for (const auto& [reason, count] : summary.dropped) dropped[reason] = count;
  source["dropped_detections"] = dropped;
  json header = {{"format", "locsim-log"},   {"locsim_version", locsim_version()},
                 {"seed", std::uint64_t{0}},  // nothing random in an import
                 {"world_file", world_file}, {"world_dir", world_dir.string()},
                 {"world_yaml", yaml},       {"scenario_file", nullptr},
                 {"scenario_yaml", nullptr}, {"duration_s", summary.duration_s},
                 {"source", source}};
  if (!carried.empty()) {
    json files = json::object();
    for (const auto& [key, bytes] : carried) files[key] = base64_encode(bytes);
    header["files"] = files;
  }

  // The log's folder is made when missing, as `run --log` does, and removed again on failure.
  const fs::path made =
      make_missing_folders(out.parent_path(), "cannot write " + out.string() + ": ");
  try {
    LogWriter writer(partial, header);
    StreamOrderCheck stream_order;
    Record record;
    for (const Entry& e : order) {
      const ImportedRobot& robot = dataset.robots[e.robot];
      if (e.cls == 1) {
        record.type = Record::Type::kGroundTruth;
        record.t_s = e.t_s;
        record.robot = static_cast<int>(e.robot);
        record.pose = robot.truth[e.index].pose;
        if (truth_known(record.pose)) {
          ++summary.ground_truth;
        } else {
          ++summary.unscored_samples;
        }
      } else {
        record.type = Record::Type::kReading;
        record.reading.t_s = e.t_s;
        record.reading.robot = static_cast<int>(e.robot);
        if (e.kind == 0) {
          record.reading.kind = SensorKind::kEncoders;
          record.reading.data = robot.odometry[e.index].reading;
          ++summary.odometry;
        } else if (e.kind == 1) {
          record.reading.kind = SensorKind::kImu;
          record.reading.data = robot.imu[e.index].reading;
          ++summary.imu;
        } else if (e.kind == 2) {
          record.reading.kind = SensorKind::kUltrasonic;
          UltrasonicReading reading{robot.ranges[e.index].ranges};
          summary.ranges += reading.ranges.size();
          record.reading.data = std::move(reading);
          ++summary.range_readings;
        } else if (e.kind == 3) {
          record.reading.kind = SensorKind::kLaser;
          const LaserScan& scan = robot.scans[e.index].scan;
          summary.laser_no_returns +=
              static_cast<std::size_t>(std::count(scan.ranges_m.begin(), scan.ranges_m.end(),
                                                  static_cast<float>(robot.laser->max_range_m)));
          record.reading.data = scan;
          ++summary.laser_scans;
        } else {
          record.reading.kind = SensorKind::kRangeBearing;
          RangeBearingReading reading{robot.detections[e.index].detections};
          for (Detection& d : reading.detections) {
            // An unidentified detection (id -1) has no colour either.
            if (d.target == DetectionTarget::kLandmark && d.id >= 0) d.color = colors.at(d.id);
          }
          summary.detections += reading.detections.size();
          record.reading.data = std::move(reading);
          ++summary.detection_readings;
        }
      }
      // What a replay will refuse is refused here, before the log exists, at the sample's line:
      // the dataset's own numbers out of a world file's ranges (a Vicon x of 1e30), two true
      // poses at one instant.
      std::string problem = record_value_problem(record);
      const bool order_problem = problem.empty();
      if (order_problem) problem = stream_order.problem(record);
      if (!problem.empty()) {
        const StreamSource& stream = e.cls == 1    ? robot.truth_source
                                     : e.kind == 0 ? robot.odometry_source
                                     : e.kind == 1 ? robot.imu_source
                                     : e.kind == 2 ? robot.ranges_source
                                     : e.kind == 3 ? robot.scans_source
                                                   : robot.detections_source;
        const SamplePlace at = e.cls == 1    ? robot.truth[e.index].at
                               : e.kind == 0 ? robot.odometry[e.index].at
                               : e.kind == 1 ? robot.imu[e.index].at
                               : e.kind == 2 ? robot.ranges[e.index].at
                               : e.kind == 3 ? robot.scans[e.index].at
                                             : robot.detections[e.index].at;
        // The pose a second one contradicts: the robot's previous one, at the same time.
        if (order_problem && e.cls == 1 && e.index > 0 && robot.truth[e.index - 1].t_s == e.t_s)
          problem += " (line " + std::to_string(robot.truth[e.index - 1].at.line) + ")";
        // An order problem is the time's (its column); a value one is somewhere on the line.
        throw InputError(SourceLocation{stream.file, at.line, order_problem ? at.column : 0},
                         order_problem ? stream.time_key : "",
                         "robot " + quote_input(robot.name) +
                             ", t = " + time_text(record_time_s(record) + lo) + " s (" +
                             time_text(record_time_s(record)) + " s into the log): " + problem);
      }
      writer.consume(record);
      ++summary.records;
    }
    writer.finish();
    fs::rename(partial, out);
  } catch (...) {
    std::error_code ignored;
    fs::remove(partial, ignored);
    if (!made.empty()) fs::remove_all(made, ignored);
    throw;
  }
  summary.header = header;
  summary.world_yaml = yaml;
  return summary;
}

std::string describe(const ImportSummary& s) {
  std::string robots;
  for (const std::string& name : s.robots) robots += (robots.empty() ? "" : ", ") + name;
  std::string text =
      std::to_string(s.records) + " records (" + std::to_string(s.odometry) + " odometry, " +
      (s.imu > 0 ? std::to_string(s.imu) + " IMU, " : std::string()) +
      (s.range_readings > 0 ? std::to_string(s.range_readings) + " range readings with " +
                                  std::to_string(s.ranges) + " ranges, "
                            : std::string()) +
      (s.laser_scans > 0 ? std::to_string(s.laser_scans) + " laser scans (" +
                               std::to_string(s.laser_no_returns) + " beams without a return), "
                         : std::string()) +
      (s.detection_readings > 0 || (s.range_readings == 0 && s.laser_scans == 0)
           ? std::to_string(s.detection_readings) + " detection readings with " +
                 std::to_string(s.detections) + " detections, "
           : std::string()) +
      std::to_string(s.ground_truth) + " true poses" +
      (s.unscored_samples > 0
           ? ", " + std::to_string(s.unscored_samples) + " sampling instants without truth"
           : std::string()) +
      ") of " + std::to_string(s.robots.size()) + " robots (" + robots + "), " +
      fixed(s.duration_s, 3) + " s from t0 = " + fixed(s.t0_s, 3) + " s";
  std::size_t dropped = 0;
  std::string reasons;
  for (const auto& [reason, count] : s.dropped) {
    dropped += count;
    reasons += (reasons.empty() ? "" : ", ") + std::to_string(count) + " " + reason;
  }
  if (dropped == 0 && s.detection_readings == 0 && (s.range_readings > 0 || s.laser_scans > 0))
    return text;  // no camera
  text += dropped == 0 ? "; no detection dropped"
                       : "; dropped " + std::to_string(dropped) + " detections (" + reasons + ")";
  return text;
}

}  // namespace locsim
