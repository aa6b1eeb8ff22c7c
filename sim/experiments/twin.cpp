#include "sim/experiments/twin.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <set>
#include <tuple>

#include "sim/common/base64.hpp"
#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/common/format.hpp"
#include "sim/common/yaml_node.hpp"
#include "sim/metrics/calibration.hpp"
#include "sim/producers/log_source.hpp"
#include "sim/run/runner.hpp"
#include "sim/sensors/scene_rays.hpp"
#include "sim/sensors/sensor_loader.hpp"
#include "sim/world/physics_world.hpp"
#include "sim/world/world_loader.hpp"

namespace locsim {

namespace fs = std::filesystem;

namespace {

std::string seven_digits(double value) {
  return rounded_number(value, 7);
}

/// The true path thinned to one pose per 1/rate_hz (the first and last always kept).
std::vector<StampedPose> sample_path(const std::vector<StampedPose>& truth, double rate_hz) {
  std::vector<StampedPose> out;
  const double period_s = 1.0 / rate_hz;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    // Equal times (a duplicated line) would make the drive's times stand still.
    if (!out.empty() && !(truth[i].t_s > out.back().t_s)) continue;
    const bool last = i + 1 == truth.size();
    if (out.empty() || last || truth[i].t_s >= out.back().t_s + period_s - 1e-9)
      out.push_back(truth[i]);
  }
  return out;
}

/// The 99.5th percentile (a few glitches in a path do not set it).
double percentile_995(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto at =
      v.begin() + static_cast<std::ptrdiff_t>(0.995 * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), at, v.end());
  return *at;
}

/// The rates a sensor may have: divisors of the physics rate (sim/sensors: rate_hz must divide
/// it) that a camera could have, whole (1, 2, 4, 5, 10 ... Hz) or one every whole number of
/// seconds, down to 0.1 Hz.
std::vector<double> sensor_rates(double step_hz) {
  std::vector<double> rates;
  for (int k = 1; step_hz / k >= 0.1 && k <= 100000; ++k) {
    const double rate = step_hz / k;
    const auto whole = [](double x) { return std::abs(x - std::round(x)) < 1e-9; };
    if (whole(rate) || whole(1.0 / rate)) rates.push_back(rate);
  }
  return rates;
}

/// A calibration.yaml's `sensors:` section: sensor name → (key, value text).
using SensorSettings = std::map<std::string, std::vector<std::pair<std::string, std::string>>>;

/// The `sensors:` of the calibration file `file`, checked as a robot's `sensors:` in a world of
/// physics rate `step_hz` is (sensor names, keys, ranges), so that a misspelt sensor or key is an
/// error at this file's line rather than a setting the twin silently leaves out.
SensorSettings read_calibration_sensors(const fs::path& file, double step_hz) {
  const YamlNode root = YamlNode::load_file(file);
  const YamlNode sensors = root["sensors"];
  SensorSettings out;
  if (sensors.is_null()) return out;
  parse_sensors(sensors, step_hz);
  for (const auto& [sensor, settings] : sensors.entries()) {
    if (settings.is_null()) continue;  // `imu:`: the sensor on, no setting to merge
    for (const auto& [key, value] : settings.entries()) {
      if (!value.is_scalar()) value.fail("expected a number (a sensor setting of `calibrate`)");
      // Copied into the twin as text, which is written back as it reads: numbers, and plain
      // words (`range_model: depth`). parse_sensors has checked each against its key (a number's
      // range, a word's choices); anything else would need quoting to stay what it is.
      const std::string text = value.as_string();
      const bool word = !text.empty() &&
                        std::isalpha(static_cast<unsigned char>(text.front())) != 0 &&
                        std::all_of(text.begin(), text.end(), [](char ch) {
                          return std::isalnum(static_cast<unsigned char>(ch)) != 0 || ch == '_';
                        });
      if (!word) {
        constexpr double kLargest = std::numeric_limits<double>::max();
        value.as_double(Range{-kLargest, kLargest, ""});
      }
      out[sensor].emplace_back(key, text);
    }
  }
  return out;
}

double setting(const SensorSettings& settings, const std::string& sensor, const std::string& key,
               double fallback) {
  const auto found = settings.find(sensor);
  if (found == settings.end()) return fallback;
  for (const auto& [k, v] : found->second) {
    if (k == key) return std::stod(v);
  }
  return fallback;
}

/// The `robot:` section of the calibration file `file` (how the motion follows the command, how
/// the body slides), checked as a robot's keys are; each none when the file has none.
struct CalibratedRobot {
  std::optional<CommandResponseDef> response;
  std::optional<SideSlipDef> side_slip;
};
CalibratedRobot read_calibration_robot(const fs::path& file) {
  const YamlNode root = YamlNode::load_file(file);
  const auto robot = root.find("robot");
  if (!robot || robot->is_null()) return {};
  robot->allow_keys({"command_response", "side_slip"});
  CalibratedRobot out;
  if (const auto response = robot->find("command_response"))
    out.response = parse_command_response(*response);
  if (const auto slip = robot->find("side_slip")) out.side_slip = parse_side_slip(*slip);
  return out;
}

/// The `camera_offsets:` of the calibration file `file` (robot name -> where its range-bearing
/// camera is from where its detections are given, forward and left [m]); empty without.
std::map<std::string, Vec2> read_camera_offsets(const fs::path& file) {
  const YamlNode root = YamlNode::load_file(file);
  std::map<std::string, Vec2> out;
  const auto offsets = root.find("camera_offsets");
  if (!offsets || offsets->is_null()) return out;
  for (const auto& [name, offset] : offsets->entries()) {
    offset.allow_keys({"x", "y"});
    out[name] =
        Vec2(offset["x"].as_double(kBodyFrameRange), offset["y"].as_double(kBodyFrameRange));
  }
  return out;
}

/// A pose as the world file writes it: {x, y, theta}, seven digits each.
YAML::Node pose_node(const Pose2& pose) {
  YAML::Node node(YAML::NodeType::Map);
  node.SetStyle(YAML::EmitterStyle::Flow);
  node["x"] = seven_digits(pose.x);
  node["y"] = seven_digits(pose.y);
  node["theta"] = seven_digits(pose.theta);
  return node;
}

/// Headroom over the path's demand on the motors: the trajectory drive's feedback needs some.
constexpr double kDriveMargin = 1.5;

/// The path's demand on a differential drive's wheels: the 99.5th percentile of |v| + |omega| b / 2
/// over the wheel radius between samples, and of its change per second (a percentile: a truth
/// sample off by a glitch would otherwise set the limit). [rad/s], [rad/s^2]
std::pair<double, double> wheel_demand(const std::vector<StampedPose>& path, double wheel_base_m,
                                       double wheel_radius_m) {
  std::vector<double> speed, accel;
  double last_speed = 0.0, last_t = 0.0;
  for (std::size_t k = 1; k < path.size(); ++k) {
    const double dt = path[k].t_s - path[k - 1].t_s;
    if (!(dt > 0.0)) continue;
    const double v = (path[k].pose.position() - path[k - 1].pose.position()).norm() / dt;
    const double omega = std::abs(wrap_angle(path[k].pose.theta - path[k - 1].pose.theta)) / dt;
    const double wheel = (v + 0.5 * wheel_base_m * omega) / wheel_radius_m;
    const double t = 0.5 * (path[k].t_s + path[k - 1].t_s);
    if (!speed.empty() && t > last_t) accel.push_back(std::abs(wheel - last_speed) / (t - last_t));
    speed.push_back(wheel);
    last_speed = wheel, last_t = t;
  }
  return {percentile_995(std::move(speed)), percentile_995(std::move(accel))};
}

}  // namespace

Twin make_twin(const TwinOptions& options, const fs::path& world_file) {
  if (const std::string problem = out_of_range(options.pose_rate_hz, TwinOptions::kPoseRateRange);
      !problem.empty()) {
    throw InputError("--pose-rate-hz: " + problem);
  }
  LogSource source(options.log);
  const WorldDef& world = source.world();
  const ScenarioDef& scenario = source.scenario();
  const std::string log_name = options.log.string();

  std::vector<bool> chosen(world.robots.size(), options.robots.empty());
  for (const std::string& name : options.robots) {
    const auto found = std::find_if(world.robots.begin(), world.robots.end(),
                                    [&](const RobotDef& r) { return r.name == name; });
    if (found == world.robots.end()) {
      std::string names;
      for (const RobotDef& r : world.robots) names += (names.empty() ? "" : ", ") + r.name;
      throw InputError("--robots: no robot named '" + name + "' in " + log_name +
                       " (its robots: " + names + ")");
    }
    chosen[static_cast<std::size_t>(found - world.robots.begin())] = true;
  }

  Twin twin;
  std::vector<std::vector<StampedPose>> truth(world.robots.size());
  std::vector<std::vector<double>> ranged_s(world.robots.size());  // beacon-range readings' times
  std::size_t data_readings = 0, data_detections = 0;
  std::set<std::string> kidnapped;
  Record record;
  while (source.next(record)) {
    switch (record.type) {
      case Record::Type::kGroundTruth:
        if (chosen[static_cast<std::size_t>(record.robot)] && truth_known(record.pose))
          truth[static_cast<std::size_t>(record.robot)].push_back({record.t_s, record.pose});
        break;
      case Record::Type::kReading:
        if (record.reading.kind == SensorKind::kUltrasonic &&
            chosen[static_cast<std::size_t>(record.reading.robot)]) {
          const auto& ranges = std::get<UltrasonicReading>(record.reading.data).ranges;
          if (std::any_of(ranges.begin(), ranges.end(),
                          [](const BeaconRange& r) { return std::isfinite(r.range_m); }))
            ranged_s[static_cast<std::size_t>(record.reading.robot)].push_back(record.reading.t_s);
        }
        if (record.reading.kind == SensorKind::kRangeBearing &&
            chosen[static_cast<std::size_t>(record.reading.robot)]) {
          ++data_readings;
          for (const Detection& d : std::get<RangeBearingReading>(record.reading.data).detections)
            data_detections += d.target == DetectionTarget::kLandmark ? 1 : 0;
        }
        break;
      case Record::Type::kEvent:
        if (record.event.kind == "kidnap") kidnapped.insert(record.event.robot);
        break;
      case Record::Type::kEnd:
        break;
    }
  }
  {
    std::vector<double> intervals_s;
    for (const std::vector<StampedPose>& poses : truth) {
      for (std::size_t k = 1; k < poses.size(); ++k)
        if (poses[k].t_s > poses[k - 1].t_s) intervals_s.push_back(poses[k].t_s - poses[k - 1].t_s);
    }
    twin.groundtruth_hz = scenario.groundtruth_hz;
    if (!intervals_s.empty()) {
      const auto middle = intervals_s.begin() + static_cast<std::ptrdiff_t>(intervals_s.size() / 2);
      std::nth_element(intervals_s.begin(), middle, intervals_s.end());
      twin.log_truth_hz = 1.0 / *middle;
      for (const double rate : sensor_rates(world.physics.step_hz)) {
        if (std::abs(std::log(rate / twin.log_truth_hz)) <
            std::abs(std::log(twin.groundtruth_hz / twin.log_truth_hz)))
          twin.groundtruth_hz = rate;
      }
    }
  }
  std::erase_if(ranged_s, [](const std::vector<double>& t) { return t.empty(); });
  if (!ranged_s.empty()) twin.ranging_silences = fit_outages(ranged_s);
  for (const std::string& name : kidnapped) {
    twin.warnings.push_back("robot '" + name +
                            "' was kidnapped in the log: the twin drives it from where it was "
                            "taken to where it was put down (kidnappings are not reproduced)");
  }

  const SensorSettings calibrated =
      options.calibration ? read_calibration_sensors(*options.calibration, world.physics.step_hz)
                          : SensorSettings{};
  std::map<std::string, Vec2> camera_offsets = options.calibration
                                                   ? read_camera_offsets(*options.calibration)
                                                   : std::map<std::string, Vec2>{};
  // On the heap: GCC 12 takes a std::optional's members for maybe uninitialised below.
  const CalibratedRobot calibrated_robot =
      options.calibration ? read_calibration_robot(*options.calibration) : CalibratedRobot{};
  const std::unique_ptr<const CommandResponseDef> response =
      calibrated_robot.response
          ? std::make_unique<const CommandResponseDef>(*calibrated_robot.response)
          : nullptr;
  const std::unique_ptr<const SideSlipDef> side_slip =
      calibrated_robot.side_slip && calibrated_robot.side_slip->any()
          ? std::make_unique<const SideSlipDef>(*calibrated_robot.side_slip)
          : nullptr;

  // The paths, and what a range-bearing camera on them would have in view.
  const PhysicsWorld physics(world);
  const StaticRaycaster walls = StaticRaycaster::from_world(physics);
  double robot_seconds = 0.0, in_view_sum = 0.0, in_view_weighted_sum = 0.0;
  std::size_t in_view_samples = 0;
  double detection_decay_m = 0.0;
  std::optional<RangeBearingDef> camera_def;
  for (std::size_t i = 0; i < world.robots.size(); ++i) {
    if (!chosen[i]) continue;
    const RobotDef& robot = world.robots[i];
    if (truth[i].empty()) {
      throw InputError(log_name + ": robot '" + robot.name +
                       "' has no ground truth: a twin drives each robot along its true path");
    }
    TwinRobot out;
    out.name = robot.name;
    out.poses_file = world_file.stem().string() + "_" + robot.name + ".tum";
    out.path = sample_path(truth[i], options.pose_rate_hz);
    std::tie(out.truth_jumps, out.largest_truth_jump_m) = clear_truth_jumps(out.path);
    out.from_s = out.path.front().t_s;
    out.to_s = out.path.back().t_s;
    for (std::size_t k = 1; k < out.path.size(); ++k)
      out.path_length_m += (out.path[k].pose.position() - out.path[k - 1].pose.position()).norm();
    if (robot.sensors.range_bearing) {
      camera_def = robot.sensors.range_bearing;
      robot_seconds += out.to_s - out.from_s;
      detection_decay_m = setting(calibrated, "range_bearing", "detection_decay_m",
                                  robot.sensors.range_bearing->detection_decay_m);
      for (const StampedPose& p : out.path) {
        for (const LandmarkInView& l :
             landmarks_in_view(world, walls, *robot.sensors.range_bearing, p.pose)) {
          in_view_sum += 1.0;
          in_view_weighted_sum +=
              detection_decay_m > 0.0 ? std::exp(-l.range_m / detection_decay_m) : 1.0;
        }
        ++in_view_samples;
      }
    }
    const auto [speed, accel] = wheel_demand(out.path, robot.wheel_base_m, robot.wheel_radius_m);
    if (kDriveMargin * speed > robot.max_wheel_speed_radps)
      out.max_wheel_speed_radps = kDriveMargin * speed;
    if (kDriveMargin * accel > robot.max_wheel_accel_radps2)
      out.max_wheel_accel_radps2 = kDriveMargin * accel;
    twin.robots.push_back(std::move(out));
  }

  // The camera: as many landmark detections per second as the log has.
  if (camera_def && options.match_detections) {
    TwinCamera c;
    c.duration_s = robot_seconds;
    c.data_readings = data_readings;
    c.data_detections = data_detections;
    c.in_view_mean = in_view_samples ? in_view_sum / static_cast<double>(in_view_samples) : 0.0;
    c.detection_decay_m = detection_decay_m;
    c.in_view_weighted_mean =
        in_view_samples ? in_view_weighted_sum / static_cast<double>(in_view_samples) : 0.0;
    c.calibrated_miss_probability =
        setting(calibrated, "range_bearing", "miss_probability", camera_def->miss_probability);
    c.calibrated_false_per_reading =
        setting(calibrated, "range_bearing", "false_detections", camera_def->false_detections);
    c.rate_hz = camera_def->common.rate_hz;
    c.miss_probability = c.calibrated_miss_probability;
    c.false_per_reading = c.calibrated_false_per_reading;
    // A camera silent for spells (the calibration's outage_fraction) sees only the rest of the
    // time: its rate and misses are matched to the log's detections over that rest.
    c.outage_fraction =
        setting(calibrated, "range_bearing", "outage_fraction", camera_def->common.outage_fraction);
    const double seeing_s = robot_seconds * (1.0 - c.outage_fraction);
    if (seeing_s > 0.0) {
      c.data_detections_per_s = static_cast<double>(data_detections) / robot_seconds;
      const double false_per_s =
          c.calibrated_false_per_reading * static_cast<double>(data_readings) / seeing_s;
      const double true_per_s = static_cast<double>(data_detections) / seeing_s - false_per_s;
      if (!(c.in_view_weighted_mean > 0.0)) {
        c.note = "no landmark is ever in view along the paths: the camera's settings are kept";
      } else if (!(true_per_s > 0.0)) {
        c.note = "the log has no detections of landmarks: the camera's settings are kept";
      } else {
        // The rate that keeps the calibrated miss probability, rounded to one the physics allows
        // (but never one so low that even seeing everything would not give the log's count).
        // With a decay, a landmark in view counts its share of a near one's chance.
        const double wanted_hz =
            true_per_s /
            ((1.0 - std::min(c.calibrated_miss_probability, 0.999)) * c.in_view_weighted_mean);
        const double least_hz = true_per_s / c.in_view_weighted_mean;
        const std::vector<double> rates = sensor_rates(world.physics.step_hz);
        double best = rates.front();
        bool found = false;
        for (const double r : rates) {
          if (r + 1e-12 < least_hz) continue;
          if (!found || std::abs(std::log(r / wanted_hz)) < std::abs(std::log(best / wanted_hz)))
            best = r;
          found = true;
        }
        if (!found)
          c.note = "the log sees more than a camera at the physics rate could: rate " +
                   seven_digits(best) + " Hz, nothing missed";
        c.rate_hz = best;
        c.miss_probability =
            std::clamp(1.0 - true_per_s / (best * c.in_view_weighted_mean), 0.0, 1.0);
        c.false_per_reading = false_per_s / best;
      }
    }
    twin.camera = c;
  }

  // The world: the log's, with the robots chosen, the calibrated noise, and the scenario that
  // drives them along their paths.
  // The map's files, from the log (it carries every file its world names), to be written where
  // the twin's world names them: relative to its folder as to the log's.
  if (world.map) {
    const auto& header = source.header();
    const fs::path world_dir = header.at("world_dir").get<std::string>();
    const auto* files = header.contains("files") ? &header.at("files") : nullptr;
    for (const fs::path& file : {world.map->yaml_file, world.map->image_file}) {
      const fs::path relative = file.lexically_normal().lexically_relative(world_dir);
      const std::string key = InputSandbox::key(file);
      if (relative.empty() || *relative.begin() == ".." || files == nullptr ||
          !files->contains(key)) {
        throw InputError(SourceLocation{options.log.string()}, "",
                         "the world's map file " + quote_input(file.string()) +
                             " is not one the log carries within its world's folder, so the "
                             "twin cannot write it beside its world");
      }
      // LogSource has decoded every carried file once: this one is valid base64.
      twin.world_files.emplace_back(relative,
                                    base64_decode(files->at(key).get<std::string>()).value());
    }
  }
  YAML::Node doc = YAML::Load(source.header().at("world_yaml").get<std::string>());
  YAML::Node robots(YAML::NodeType::Sequence);
  std::set<std::string> used_sensors;
  std::size_t twin_index = 0;
  for (std::size_t i = 0; i < world.robots.size(); ++i) {
    if (!chosen[i]) continue;
    YAML::Node robot = doc["robots"][i];
    const TwinRobot& t = twin.robots[twin_index++];
    robot["start"] = pose_node(t.path.front().pose);
    if (t.max_wheel_speed_radps)
      robot["max_wheel_speed_radps"] = seven_digits(*t.max_wheel_speed_radps);
    if (t.max_wheel_accel_radps2) {
      // The torque in proportion, so that the motor can give the acceleration.
      robot["max_wheel_accel_radps2"] = seven_digits(*t.max_wheel_accel_radps2);
      robot["max_wheel_torque_nm"] =
          seven_digits(world.robots[i].max_wheel_torque_nm * *t.max_wheel_accel_radps2 /
                       world.robots[i].max_wheel_accel_radps2);
    }
    if (response) {
      YAML::Node r(YAML::NodeType::Map);
      r.SetStyle(YAML::EmitterStyle::Flow);
      r["dead_time_s"] = seven_digits(response->dead_time_s);
      r["time_constant_v_s"] = seven_digits(response->time_constant_v_s);
      r["time_constant_omega_s"] = seven_digits(response->time_constant_omega_s);
      r["gain_v"] = seven_digits(response->gain_v);
      r["gain_omega"] = seven_digits(response->gain_omega);
      if (response->wanders()) {
        r["gain_wander_v"] = seven_digits(response->gain_wander_v);
        r["gain_wander_omega"] = seven_digits(response->gain_wander_omega);
        r["gain_wander_correlation_s"] = seven_digits(response->gain_wander_correlation_s);
      }
      robot["command_response"] = r;
    }
    if (side_slip) {
      YAML::Node r(YAML::NodeType::Map);
      r.SetStyle(YAML::EmitterStyle::Flow);
      r["crab_angle_deg"] = seven_digits(rad_to_deg(side_slip->crab_angle_rad));
      r["cornering_compliance_s"] = seven_digits(side_slip->cornering_compliance_s);
      r["wander_k"] = seven_digits(side_slip->wander_k);
      r["wander_correlation_s"] = seven_digits(side_slip->wander_correlation_s);
      robot["side_slip"] = r;
    }
    YAML::Node sensors = robot["sensors"];
    for (const auto& [sensor, settings] : calibrated) {
      if (!sensors[sensor]) continue;
      used_sensors.insert(sensor);
      for (const auto& [key, value] : settings) sensors[sensor][key] = value;
    }
    const auto offset = camera_offsets.find(world.robots[i].name);
    if (offset != camera_offsets.end() && world.robots[i].sensors.range_bearing) {
      // The camera where the log's detections say it is; its detections still given from where
      // the log's robot believes it is.
      const Pose2 believed = world.robots[i].sensors.range_bearing->common.reported_mount();
      sensors["range_bearing"]["mount"] = pose_node(
          Pose2{believed.x + offset->second.x(), believed.y + offset->second.y(), believed.theta});
      sensors["range_bearing"]["believed_mount"] = pose_node(believed);
      // Its ranges as the log's: a camera's range is its own calibration's, reported from its
      // believed place (MRCLAM robot 4's camera, 8 cm ahead, ranges 4.5 cm longer than the five
      // robots' pooled bias, not 8 cm shorter). A camera c_x ahead sees a landmark's depth c_x
      // shorter (exactly, in depth mode; in distance mode within (1 - cos(bearing)) c_x).
      const RangeBearingDef& camera = *world.robots[i].sensors.range_bearing;
      const double bias_m =
          setting(calibrated, "range_bearing", "range_bias_m", camera.range_bias_m);
      sensors["range_bearing"]["range_bias_m"] = seven_digits(bias_m + offset->second.x());
      twin.robots[twin_index - 1].camera_offset_m = offset->second;
      camera_offsets.erase(offset);
    }
    if (twin.ranging_silences && world.robots[i].sensors.ultrasonic) {
      const OutageFit& silences = *twin.ranging_silences;
      sensors["ultrasonic"]["outage_fraction"] = seven_digits(silences.fraction);
      if (silences.outages > 0)
        sensors["ultrasonic"]["outage_mean_s"] = seven_digits(silences.mean_s);
    }
    if (twin.camera && world.robots[i].sensors.range_bearing && twin.camera->note.empty()) {
      // Exact: the loader checks that the rate divides the physics rate.
      sensors["range_bearing"]["rate_hz"] = short_number(twin.camera->rate_hz);
      sensors["range_bearing"]["miss_probability"] = seven_digits(twin.camera->miss_probability);
      sensors["range_bearing"]["false_detections"] = seven_digits(twin.camera->false_per_reading);
    }
    robots.push_back(YAML::Clone(robot));
  }
  for (const auto& [name, offset] : camera_offsets) {
    twin.warnings.push_back("the calibration's camera offset of robot '" + name +
                            "' is not used: no robot of the twin with a range-bearing sensor has "
                            "that name");
  }
  for (const auto& [sensor, settings] : calibrated) {
    if (!used_sensors.contains(sensor))
      twin.warnings.push_back("the calibration's '" + sensor +
                              "' settings are not used: no robot of the twin has that sensor");
  }
  doc["robots"] = robots;

  YAML::Node s(YAML::NodeType::Map);
  s["name"] = "twin";
  s["duration_s"] = seven_digits(scenario.duration_s);
  s["groundtruth_hz"] = seven_digits(twin.groundtruth_hz);
  YAML::Node localization(YAML::NodeType::Map);
  localization.SetStyle(YAML::EmitterStyle::Flow);
  localization["initial_pose"] = scenario.localization.initial_pose_known ? "known" : "unknown";
  localization["landmarks_known"] = scenario.localization.landmarks_known;
  localization["sigma_xy_m"] = seven_digits(scenario.localization.sigma_xy_m);
  localization["sigma_theta"] = seven_digits(scenario.localization.sigma_theta_rad);
  s["localization"] = localization;
  YAML::Node drives(YAML::NodeType::Sequence);
  for (const TwinRobot& t : twin.robots) {
    YAML::Node drive(YAML::NodeType::Map);
    drive.SetStyle(YAML::EmitterStyle::Flow);
    drive["robot"] = t.name;
    drive["mode"] = "trajectory";
    drive["poses_file"] = t.poses_file.string();
    drives.push_back(drive);
  }
  s["drive"] = drives;
  doc["scenario"] = s;

  std::string text = "# Generated by `locsim twin " + log_name +
                     "` (docs/real_data.md): a simulated twin of the log.\n"
                     "# Each robot follows its recorded true path (the .tum files beside this "
                     "file, " +
                     seven_digits(options.pose_rate_hz) + " poses per second).\n";
  text += "# The truth is sampled at " + seven_digits(twin.groundtruth_hz) +
          " Hz, as the log's is, so that estimates are scored as often.\n";
  if (options.calibration)
    text += "# Sensor noise: the `sensors:` of " + options.calibration->string() + ".\n";
  if (response)
    text +=
        "# Each robot follows its command through the calibration's `command_response`; "
        "the drive tells it the path's velocity ahead by its lag.\n";
  if (side_slip)
    text +=
        "# Each robot's body slides off its heading as the calibration's `side_slip` says; "
        "the drive keeps it on its path.\n";
  if (twin.camera && twin.camera->note.empty()) {
    const TwinCamera& c = *twin.camera;
    text += "# range_bearing: rate " + seven_digits(c.rate_hz) + " Hz, miss_probability " +
            rounded_number(c.miss_probability, 3) +
            (c.detection_decay_m > 0.0 ? " at zero range (detection_decay_m " +
                                             rounded_number(c.detection_decay_m, 3) + ")"
                                       : std::string()) +
            " (calibrated: " + rounded_number(c.calibrated_miss_probability, 3) +
            "), so that the twin sees the " + rounded_number(c.data_detections_per_s, 3) +
            " landmark detections per second the log has,\n#   with " +
            rounded_number(c.in_view_mean, 3) + " landmarks in view on average along the paths.\n";
  }
  YAML::Emitter emitter;
  emitter << doc;
  text += emitter.c_str();
  text += "\n";
  twin.world_yaml = std::move(text);
  return twin;
}

Twin write_twin(const TwinOptions& options, const fs::path& world_file, bool overwrite) {
  if (world_file.empty()) throw InputError("--out: the path is empty");
  Twin twin = make_twin(options, world_file);
  const fs::path dir = world_file.parent_path();
  check_output_folder(dir.empty() ? fs::path(".") : dir, "--out");
  std::vector<fs::path> files{world_file};
  for (const TwinRobot& r : twin.robots) files.push_back(dir / r.poses_file);
  for (const auto& [relative, bytes] : twin.world_files) files.push_back(dir / relative);
  std::vector<fs::path> inputs{options.log};
  if (options.calibration) inputs.push_back(*options.calibration);
  for (const fs::path& f : files) {
    if (fs::is_directory(f)) throw InputError("--out: " + f.string() + " is a folder");
    for (const fs::path& input : inputs) {
      std::error_code error;
      if (fs::equivalent(f, input, error)) {
        throw InputError("--out: " + f.string() + " is " + input.string() +
                         ", which this command reads: writing it would destroy it");
      }
    }
    if (!overwrite && fs::exists(f))
      throw InputError("--out: " + f.string() + " exists (pass --overwrite to replace it)");
  }
  std::map<std::string, std::string> texts;  // by file, as the loaders will ask for them
  const fs::path world_path = fs::absolute(world_file);
  texts[InputSandbox::key(world_path)] = twin.world_yaml;
  for (const TwinRobot& r : twin.robots) {
    std::string tum = "# " + r.name + "'s true path from " + options.log.string() +
                      " (locsim twin): t x y z qx qy qz qw\n";
    for (const StampedPose& p : r.path) {
      append_tum(tum, p.t_s, p.pose.x, p.pose.y, p.pose.theta);
    }
    texts[InputSandbox::key(world_path.parent_path() / r.poses_file)] = std::move(tum);
  }
  for (const auto& [relative, bytes] : twin.world_files)
    texts[InputSandbox::key(world_path.parent_path() / relative)] = bytes;
  // Loaded as it will be, from memory, before anything is written: a twin refused leaves no file.
  try {
    const InputSandbox sandbox(texts, "the twin");
    load_run_inputs(world_path, std::nullopt, std::nullopt);
  } catch (const InputError& e) {
    throw InputError(std::string("the twin of ") + options.log.string() +
                     " does not load (a bug, or a log whose world names files the twin does not "
                     "write), so nothing was written: " +
                     e.what());
  }
  const fs::path made = dir.empty() ? fs::path() : make_output_folder(dir, "--out");
  // Every file written before any replaces an old one (write_files), the world renamed last: a
  // world file is never left naming paths that were not written.
  std::vector<fs::path> made_folders{made};
  std::vector<std::pair<fs::path, std::string_view>> written;
  for (const TwinRobot& r : twin.robots) {
    written.emplace_back(dir / r.poses_file,
                         texts.at(InputSandbox::key(world_path.parent_path() / r.poses_file)));
  }
  written.emplace_back(world_file, twin.world_yaml);
  try {
    for (const auto& [relative, bytes] : twin.world_files) {
      // A map in a sub-folder of the log's world's folder goes into the same one of the twin's.
      if (relative.has_parent_path())
        made_folders.push_back(make_missing_folders(dir / relative.parent_path(), "--out: "));
      written.insert(written.begin(), {dir / relative, bytes});
    }
    write_files(written);
  } catch (...) {
    std::error_code ignored;
    for (const fs::path& folder : made_folders)
      if (!folder.empty()) fs::remove_all(folder, ignored);
    throw;
  }
  return twin;
}

std::pair<std::size_t, double> clear_truth_jumps(std::vector<StampedPose>& path) {
  // What a wheeled robot's traction allows (friction coefficient 1 at most): a step may depart
  // from its neighbours' velocity by half a step's travel at this acceleration.
  constexpr double kTractionMps2 = 9.81;
  // And by more than the path's own noise: this many times the 99.5th percentile of the steps'
  // departures (a truth too noisy to tell a jump from its noise keeps its steps).
  constexpr double kJumpFactor = 3.0;
  // How fast the path catches up with a jump it was held back from: a brisk robot's.
  constexpr double kCatchUpMps2 = 1.0;
  const std::size_t n = path.size();
  if (n < 6) return {0, 0.0};
  // Step k goes from pose k to pose k + 1; its departure from the velocity of the two steps
  // either side (their median per axis: one jump spoils one neighbour, not the median).
  std::vector<Vec2> velocity(n - 1);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    velocity[k] =
        (path[k + 1].pose.position() - path[k].pose.position()) / (path[k + 1].t_s - path[k].t_s);
  }
  std::vector<Vec2> departure(n - 1, Vec2::Zero());
  std::vector<double> departure_m(n - 1, 0.0);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    std::vector<double> vx, vy;
    for (const std::ptrdiff_t offset : {-2, -1, 1, 2}) {
      const auto j = static_cast<std::ptrdiff_t>(k) + offset;
      if (j < 0 || j >= static_cast<std::ptrdiff_t>(n - 1)) continue;
      vx.push_back(velocity[static_cast<std::size_t>(j)].x());
      vy.push_back(velocity[static_cast<std::size_t>(j)].y());
    }
    const auto median = [](std::vector<double>& v) {
      std::sort(v.begin(), v.end());
      const std::size_t m = v.size() / 2;
      return v.size() % 2 == 1 ? v[m] : 0.5 * (v[m - 1] + v[m]);
    };
    const Vec2 local(median(vx), median(vy));
    departure[k] = (velocity[k] - local) * (path[k + 1].t_s - path[k].t_s);
    departure_m[k] = departure[k].norm();
  }
  const double noise_m = percentile_995(departure_m);
  double largest_m = 0.0;
  std::size_t jumps = 0;
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const double dt = path[k + 1].t_s - path[k].t_s;
    const double jump_m = departure_m[k];
    if (!(jump_m > 0.5 * kTractionMps2 * dt * dt) || !(jump_m > kJumpFactor * noise_m)) continue;
    ++jumps;
    largest_m = std::max(largest_m, jump_m);
    // The path from the jump on is held back by it, and takes it up over the time a bang-bang
    // acceleration at kCatchUpMps2 needs to cover it.
    const double ramp_s = 2.0 * std::sqrt(jump_m / kCatchUpMps2);
    const double from_s = path[k].t_s;
    for (std::size_t j = k + 1; j < n && path[j].t_s - from_s < ramp_s; ++j) {
      const double taken =
          0.5 * (1.0 - std::cos(std::numbers::pi * (path[j].t_s - from_s) / ramp_s));
      path[j].pose.x -= (1.0 - taken) * departure[k].x();
      path[j].pose.y -= (1.0 - taken) * departure[k].y();
    }
  }
  return {jumps, largest_m};
}

std::string describe(const Twin& twin) {
  std::string text;
  for (const TwinRobot& r : twin.robots) {
    text += "twin: " + r.name + ": " + std::to_string(r.path.size()) + " poses over " +
            fixed(r.to_s - r.from_s, 1) + " s, " + fixed(r.path_length_m, 1) + " m (" +
            r.poses_file.string() + ")\n";
    if (r.camera_offset_m) {
      text += "twin: " + r.name + ": range_bearing mounted " +
              fixed(100.0 * r.camera_offset_m->x(), 1) + " cm forward, " +
              fixed(100.0 * r.camera_offset_m->y(), 1) +
              " cm left of where its detections are given from (the calibration's camera offset)\n";
    }
    if (r.truth_jumps > 0) {
      text += "twin: " + r.name + ": the truth jumps " + std::to_string(r.truth_jumps) +
              " time(s), by up to " + fixed(r.largest_truth_jump_m, 2) +
              " m, where no robot moves so: smoothed out of the path the twin drives\n";
    }
  }
  if (twin.ranging_silences) {
    const OutageFit& f = *twin.ranging_silences;
    text += f.outages > 0
                ? "twin: ultrasonic silent " + fixed(f.fraction, 3) +
                      " of the time, in spells of " + fixed(f.mean_s, 2) +
                      " s on average, as the log's ranges (" + std::to_string(f.outages) +
                      " gaps beyond " + fixed(OutageFit::kPeriods, 0) + " readings' interval)\n"
                : std::string("twin: ultrasonic never silent: the log's ranges have no gaps\n");
  }
  text += "twin: the truth sampled at " + seven_digits(twin.groundtruth_hz) +
          " Hz (the log's: " + fixed(twin.log_truth_hz, 2) +
          " Hz), so that estimates are scored as often\n";
  if (twin.camera) {
    const TwinCamera& c = *twin.camera;
    if (c.note.empty()) {
      text += "twin: range_bearing at " + seven_digits(c.rate_hz) + " Hz, miss probability " +
              fixed(c.miss_probability, 3) + " (calibrated " +
              fixed(c.calibrated_miss_probability, 3) + "), " + fixed(c.false_per_reading, 4) +
              " false per reading: " + fixed(c.data_detections_per_s, 2) +
              " landmark detections per second as the log, " + fixed(c.in_view_mean, 2) +
              " landmarks in view on average" +
              (c.outage_fraction > 0.0
                   ? ", blind " + fixed(c.outage_fraction, 3) + " of the time (the calibration's)"
                   : std::string()) +
              "\n";
    } else {
      text += "twin: range_bearing: " + c.note + "\n";
    }
  }
  for (const std::string& w : twin.warnings) text += "twin: warning: " + w + "\n";
  return text;
}

}  // namespace locsim
