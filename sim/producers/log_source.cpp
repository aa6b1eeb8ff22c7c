#include "sim/producers/log_source.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <type_traits>
#include <variant>

#include "sim/common/base64.hpp"
#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/common/yaml_node.hpp"
#include "sim/scenario/scenario_loader.hpp"
#include "sim/world/variation.hpp"
#include "sim/world/world_loader.hpp"

namespace locsim {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

LogSource::LogSource(const fs::path& file, const std::vector<std::string>& robots) : reader_(file) {
  reader_.check_end();  // a cut log is refused before any output exists
  const json& header = reader_.header();
  const auto fail = [&](const std::string& problem) {
    throw InputError(SourceLocation{file.string()}, "", "header: " + problem);
  };
  if (!header.is_object()) fail("not a JSON object of named fields");
  if (header.value("format", json()) != "locsim-log") fail("'format' is not \"locsim-log\"");
  // A field the writer (runner.cpp, log_header) always writes as a string; `optional`: or null.
  const auto text = [&](const char* key, bool optional = false) -> std::optional<std::string> {
    const auto field = header.find(key);
    if (field == header.end()) fail(std::string("lacks the field '") + key + "'");
    if (optional && field->is_null()) return std::nullopt;
    if (!field->is_string())
      fail(std::string("'") + key + "' is not a string" + (optional ? " or null" : ""));
    return field->get<std::string>();
  };
  const auto number = [&](const char* key) -> const json& {
    const auto field = header.find(key);
    if (field == header.end()) fail(std::string("lacks the field '") + key + "'");
    return *field;
  };
  try {
    // The world is rebuilt from the log alone: the files its text names are the ones the header
    // carries, whatever their paths say; the folders are only the names they are filed under.
    std::map<std::string, std::string> carried;
    if (const auto files = header.find("files"); files != header.end()) {
      if (!files->is_object()) fail("files is not a map of file names to their contents");
      for (const auto& [name, content] : files->items()) {
        if (!content.is_string()) fail("files: " + quote_input(name) + " is not a base64 string");
        std::optional<std::string> bytes = base64_decode(content.get_ref<const std::string&>());
        if (!bytes) fail("files: " + quote_input(name) + " is not valid base64");
        carried.emplace(InputSandbox::key(name), std::move(*bytes));
      }
    }
    const InputSandbox sandbox(std::move(carried), "the log '" + file.string() + "'");
    const fs::path world_dir = *text("world_dir");
    const std::string world_file = *text("world_file");
    world_ = parse_world(YamlNode::load_string(*text("world_yaml"), world_file), world_dir);
    world_.source = world_file;
    if (const std::optional<std::string> scenario_yaml = text("scenario_yaml", true)) {
      // Logs before scenario_dir filed a scenario's files under the world's folder.
      std::optional<std::string> scenario_dir;
      if (header.contains("scenario_dir")) scenario_dir = text("scenario_dir", true);
      const std::optional<std::string> scenario_file = text("scenario_file", true);
      if (!scenario_file) fail("'scenario_file' is null beside a scenario_yaml");
      scenario_ = parse_scenario(YamlNode::load_string(*scenario_yaml, *scenario_file),
                                 scenario_dir ? fs::path(*scenario_dir) : world_dir);
      scenario_.source = *scenario_file;
    } else if (world_.scenario) {
      scenario_ = *world_.scenario;
      scenario_.source = world_.source;
    }
    // Numbers as the writer wrote them (runner.cpp, log_header): converting others would be
    // undefined (a negative or fractional seed) or meaningless.
    const json& duration = number("duration_s");
    if (!duration.is_number()) fail("duration_s is not a number of seconds");
    if (const std::string problem =
            out_of_range(duration.get<double>(), ScenarioDef::kDurationRange);
        !problem.empty()) {
      fail("duration_s: " + problem);
    }
    scenario_.duration_s = duration.get<double>();
    const json& seed = number("seed");
    if (!seed.is_number_unsigned()) fail("seed is not an unsigned integer");
    seed_ = seed.get<std::uint64_t>();
  } catch (const json::exception& e) {
    // Every field is checked above: this is a field of a kind not foreseen, named by nlohmann.
    fail(std::string("a field of another type: ") + e.what());
  }
  bind_scenario(scenario_, world_);
  // The world the recording ran in: the variation its seed drew, as recorded (a log without one
  // ran the declared world).
  if (const auto variation = header.find("variation"); variation != header.end()) {
    try {
      apply_variation(drawn_variation_from_json(*variation), world_, scenario_);
    } catch (const InputError& e) {
      fail(e.what());
    }
  } else {
    world_.variation.enabled = false;
  }
  if (robots.empty()) return;

  // The view: the robots asked for, in the world's order; the scenario's parts about the others
  // dropped (a replay drives nothing: they only name robots).
  view_index_.assign(world_.robots.size(), -1);
  std::set<std::string> wanted(robots.begin(), robots.end());
  WorldDef view = world_;
  view.robots.clear();
  for (std::size_t i = 0; i < world_.robots.size(); ++i) {
    if (!wanted.erase(world_.robots[i].name)) continue;
    view_index_[i] = static_cast<int>(view.robots.size());
    view.robots.push_back(world_.robots[i]);
  }
  if (!wanted.empty()) {
    std::string names;
    for (const RobotDef& r : world_.robots) names += (names.empty() ? "" : ", ") + r.name;
    throw InputError(
        SourceLocation{file.string()}, "",
        "no robot named '" + *wanted.begin() + "' in the log (its robots: " + names + ")");
  }
  const auto kept = [&](const std::string& name) {
    return std::any_of(view.robots.begin(), view.robots.end(),
                       [&](const RobotDef& r) { return r.name == name; });
  };
  std::erase_if(scenario_.drives, [&](const DriveDef& d) { return !kept(d.robot); });
  std::erase_if(scenario_.pan_policies, [&](const PanPolicyDef& p) { return !kept(p.robot); });
  std::erase_if(scenario_.events,
                [&](const EventDef& e) { return !e.robot.empty() && !kept(e.robot); });
  view_ = std::move(view);
}

bool LogSource::next(Record& record) {
  do {
    if (!reader_.next(record)) return false;
    check(record);
    for (const std::string& problem : {record_value_problem(record), order_.problem(record)}) {
      if (!problem.empty()) reader_.reject(problem);
    }
  } while (view_ && !to_view(record));
  return true;
}

bool LogSource::to_view(Record& record) const {
  const auto index = [&](int recorded) {
    return recorded < 0 ? -1 : view_index_[static_cast<std::size_t>(recorded)];
  };
  switch (record.type) {
    case Record::Type::kReading: {
      record.reading.robot = index(record.reading.robot);
      if (record.reading.robot < 0) return false;
      std::visit(
          [&](auto& data) {
            using T = std::decay_t<decltype(data)>;
            if constexpr (std::is_same_v<T, PtzReading> || std::is_same_v<T, OmniReading> ||
                          std::is_same_v<T, RangeBearingReading>) {
              std::erase_if(data.detections, [&](Detection& d) {
                if (d.target != DetectionTarget::kRobot) return false;
                // Dropped when it is of a robot the view does not hold.
                const int seen = d.id >= 0 ? d.id : d.truth_id;
                if (seen >= 0 && index(seen) < 0) return true;
                if (d.id >= 0) d.id = index(d.id);
                if (d.truth_id >= 0) d.truth_id = index(d.truth_id);
                return false;
              });
            }
          },
          record.reading.data);
      return true;
    }
    case Record::Type::kGroundTruth:
      record.robot = index(record.robot);
      return record.robot >= 0;
    case Record::Type::kEvent:
      if (record.robot < 0) return true;  // about the world, not a robot
      record.robot = index(record.robot);
      return record.robot >= 0;
    case Record::Type::kEnd:
      return true;
  }
  return true;
}

void LogSource::check_contents(const Record& record, const RobotDef& robot) const {
  const Reading& reading = record.reading;
  const SensorsDef& sensors = robot.sensors;
  const auto check_detections = [&](const std::vector<Detection>& detections) {
    for (const Detection& d : detections) {
      // An unidentified robot (-1) is allowed: a sensor without ids reports none.
      if (d.target == DetectionTarget::kRobot && d.id != -1 &&
          (d.id < 0 || static_cast<std::size_t>(d.id) >= world_.robots.size() ||
           d.id == reading.robot)) {
        reader_.reject("a detection of robot " + std::to_string(d.id) + " by robot '" + robot.name +
                       "', which is not another robot of the world's " +
                       std::to_string(world_.robots.size()));
      }
    }
  };
  std::visit(
      [&](const auto& data) {
        using T = std::decay_t<decltype(data)>;
        if constexpr (std::is_same_v<T, OdometryReading>) {
          if (data.fields != sensors.encoders->reports) {
            reader_.reject("an odometry reading with fields " + odometry_fields_text(data.fields) +
                           "; robot '" + robot.name + "'s encoders report " +
                           odometry_fields_text(sensors.encoders->reports));
          }
        } else if constexpr (std::is_same_v<T, UltrasonicReading>) {
          for (const BeaconRange& range : data.ranges) {
            if (range.receiver < 0 ||
                static_cast<std::size_t>(range.receiver) >= sensors.ultrasonic->receivers.size())
              reader_.reject("an ultrasonic range from receiver " + std::to_string(range.receiver) +
                             ", which robot '" + robot.name + "' does not have");
          }
        } else if constexpr (std::is_same_v<T, LaserScan>) {
          const std::size_t beams = data.ranges_m.size();
          if (beams != static_cast<std::size_t>(sensors.laser->beams))
            reader_.reject("a laser scan of " + std::to_string(beams) + " beams; robot '" +
                           robot.name + "'s laser has " + std::to_string(sensors.laser->beams));
        } else if constexpr (std::is_same_v<T, PtzReading> || std::is_same_v<T, OmniReading> ||
                             std::is_same_v<T, RangeBearingReading>) {
          check_detections(data.detections);
        }
      },
      reading.data);
}

void LogSource::check(const Record& record) const {
  const std::size_t robots = world_.robots.size();
  const auto robot_known = [&](int robot) {
    return robot >= 0 && static_cast<std::size_t>(robot) < robots;
  };
  switch (record.type) {
    case Record::Type::kReading: {
      const Reading& reading = record.reading;
      if (!robot_known(reading.robot)) {
        reader_.reject("a reading of robot " + std::to_string(reading.robot) + " in a world of " +
                       std::to_string(robots) + " robots");
      }
      const RobotDef& robot = world_.robots[static_cast<std::size_t>(reading.robot)];
      const SensorsDef& sensors = robot.sensors;
      const bool known = sensor_enabled(sensors, reading.kind);
      if (known) check_contents(record, robot);
      if (!known) {
        reader_.reject(std::string("a reading of the ") + sensor_name(reading.kind) +
                       ", which robot '" + robot.name + "' does not have");
      }
      break;
    }
    case Record::Type::kGroundTruth:
      if (!robot_known(record.robot)) {
        reader_.reject("a true pose of robot " + std::to_string(record.robot) + " in a world of " +
                       std::to_string(robots) + " robots");
      }
      break;
    case Record::Type::kEvent:
      if (record.robot != -1 && !robot_known(record.robot)) {
        reader_.reject("an event about robot " + std::to_string(record.robot) + " in a world of " +
                       std::to_string(robots) + " robots");
      }
      break;
    case Record::Type::kEnd:
      break;
  }
}

}  // namespace locsim
