#include "sim/run/replay.hpp"

#include <chrono>
#include <fstream>
#include <map>

#include "sim/common/errors.hpp"
#include "sim/common/yaml_node.hpp"
#include "sim/run/run_log.hpp"
#include "sim/run/run_outputs.hpp"
#include "sim/run/runner.hpp"
#include "sim/scenario/scenario_loader.hpp"
#include "sim/world/occupancy.hpp"
#include "sim/world/physics_world.hpp"
#include "sim/world/world_loader.hpp"

namespace locsim {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

ReplayResult replay_log(const ReplayOptions& options) {
  if (options.localizers.empty()) throw InputError("replay: give at least one --localizer");
  LogReader reader(options.log_file);
  const json& header = reader.header();
  // The world and scenario as they were recorded (their text is in the log).
  WorldDef world;
  ScenarioDef scenario;
  try {
    const fs::path world_dir = header.at("world_dir").get<std::string>();
    world = parse_world(YamlNode::load_string(header.at("world_yaml"), header.at("world_file")),
                        world_dir);
    world.source = header.at("world_file").get<std::string>();
    if (!header.at("scenario_yaml").is_null()) {
      scenario = parse_scenario(
          YamlNode::load_string(header["scenario_yaml"], header["scenario_file"]), world_dir);
      scenario.source = header["scenario_file"].get<std::string>();
    } else if (world.scenario) {
      scenario = *world.scenario;
      scenario.source = world.source;
    }
    scenario.duration_s = header.at("duration_s");
  } catch (const json::exception& e) {
    throw InputError(SourceLocation{options.log_file.string()}, "",
                     std::string("header lacks a field: ") + e.what());
  }
  bind_scenario(scenario, world);
  const std::uint64_t seed = header.at("seed");

  std::vector<LocalizerSpec> specs;
  for (const std::string& text : options.localizers) specs.push_back(parse_localizer_spec(text));
  const PhysicsWorld physics(world);  // only for the occupancy grid given to the localizers
  const OccupancyGrid grid =
      rasterize_static_world(physics, scenario.localization.grid_resolution_m);
  std::vector<std::unique_ptr<LocalizerHost>> hosts;
  for (const RobotDef& robot : world.robots) {
    hosts.push_back(std::make_unique<LocalizerHost>(specs, world, robot, scenario.localization,
                                                    grid, seed, options.convergence));
  }

  const fs::path& out = options.out_dir;
  if (fs::exists(out) && !fs::is_empty(out) && !options.overwrite) {
    throw InputError("--out: folder '" + out.string() +
                     "' is not empty; choose another or pass --overwrite");
  }
  fs::create_directories(out);
  std::vector<fs::path> robot_dirs;
  std::vector<std::vector<std::ofstream>> estimates(world.robots.size());
  std::vector<std::ofstream> groundtruth;
  for (std::size_t i = 0; i < world.robots.size(); ++i) {
    robot_dirs.push_back(world.robots.size() == 1 ? out : out / world.robots[i].name);
    fs::create_directories(robot_dirs.back());
    groundtruth.emplace_back(robot_dirs.back() / "groundtruth.tum", std::ios::binary);
    groundtruth.back() << "# timestamp tx ty tz qx qy qz qw  (true pose of robot '"
                       << world.robots[i].name << "', TUM format, z = 0)\n";
    for (const auto& instance : hosts[i]->instances()) {
      auto& file = estimates[i].emplace_back(robot_dirs.back() / (instance->label() + ".tum"),
                                             std::ios::binary);
      file << "# timestamp tx ty tz qx qy qz qw  (estimate of localizer '" << instance->label()
           << "', plugin " << instance->table().name << ", TUM format)\n";
    }
  }

  std::ofstream events(out / "events.csv", std::ios::binary);
  events << "t_s,kind,robot,details\n";
  ReplayResult result;
  std::map<std::string, std::vector<double>> kidnaps;
  const auto start = std::chrono::steady_clock::now();
  LogRecord record;
  std::string line;
  while (reader.next(record)) {
    ++result.records;
    switch (record.type) {
      case LogRecord::Type::kReading:
        if (static_cast<std::size_t>(record.reading.robot) < hosts.size())
          hosts[record.reading.robot]->deliver(record.reading);
        result.replayed_s = record.reading.t_s;
        break;
      case LogRecord::Type::kEvent:
        if (record.event.kind == "kidnap") kidnaps[record.event.robot].push_back(record.event.t_s);
        line.clear();
        append_fixed(line, record.event.t_s, 4);
        line += ',' + record.event.kind + ',' + record.event.robot + ",\"" + record.event.details +
                "\"\n";
        events << line;
        break;
      case LogRecord::Type::kGroundTruth: {
        const auto i = static_cast<std::size_t>(record.robot);
        if (i >= hosts.size()) break;
        line.clear();
        append_tum(line, record.t_s, record.pose.x, record.pose.y, record.pose.theta);
        groundtruth[i] << line;
        auto& instances = hosts[i]->instances();
        for (std::size_t k = 0; k < instances.size(); ++k) {
          instances[k]->diagnostics(record.t_s);  // sampled for their means
          const std::optional<locsim_estimate> estimate = instances[k]->estimate(record.t_s);
          if (!estimate) continue;
          line.clear();
          append_tum(line, record.t_s, estimate->pose.x, estimate->pose.y, estimate->pose.theta);
          estimates[i][k] << line;
          instances[k]->add_error({record.t_s, estimate->pose.x - record.pose.x,
                                   estimate->pose.y - record.pose.y,
                                   wrap_angle(estimate->pose.theta - record.pose.theta)});
        }
        result.replayed_s = record.t_s;
        break;
      }
      case LogRecord::Type::kEnd:
        break;
    }
  }
  result.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  json localizers = json::array();
  for (std::size_t i = 0; i < hosts.size(); ++i) {
    for (const json& entry :
         write_localizer_metrics(robot_dirs[i], world.robots[i].name, *hosts[i],
                                 kidnaps[world.robots[i].name], result.replayed_s)) {
      localizers.push_back(entry);
    }
  }
  json run = {{"locsim_version", locsim_version()},
              {"status", "replayed"},
              {"log_file", options.log_file.string()},
              {"recorded_with", header.value("locsim_version", "")},
              {"seed", seed},
              {"world_file", header["world_file"]},
              {"replayed_s", result.replayed_s},
              {"records", result.records},
              {"localizers", localizers},
              {"timing", {{"wall_s", result.wall_s}}}};
  write_json_atomically(out / "run.json", run);
  return result;
}

}  // namespace locsim
