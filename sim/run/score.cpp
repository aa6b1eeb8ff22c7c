#include "sim/run/score.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>

#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/consumers/config_json.hpp"
#include "sim/consumers/run_recorder.hpp"
#include "sim/metrics/scorer.hpp"
#include "sim/producers/log_source.hpp"
#include "sim/producers/text_table.hpp"
#include "sim/rosbag/bag.hpp"
#include "sim/rosbag/message_definition.hpp"
#include "sim/run/runner.hpp"
#include "sim/run/session.hpp"
#include "sim/world/occupancy.hpp"
#include "sim/world/physics_world.hpp"

namespace fs = std::filesystem;

namespace locsim {
namespace {

/// An estimate stamped up to this much after a true pose is still the estimate at it: TUM files
/// print times to a tenth of a millisecond, a bag's stamps are rounded to the nanosecond. [s]
constexpr double kStampTolerance_s = 1e-4;

bool is_label(const std::string& label) {
  return !label.empty() && label.size() <= 64 &&
         std::all_of(label.begin(), label.end(), [](char c) {
           return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                  c == '_' || c == '-';
         });
}

double estimate_yaw(const rosbag::Value& q) {
  const double x = q.number("x"), y = q.number("y"), z = q.number("z"), w = q.number("w");
  return std::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
}

bool is_bag(const fs::path& file) {
  if (fs::is_directory(file)) return true;
  const std::string extension = file.extension().string();
  return extension == ".mcap" || extension == ".db3";
}

}  // namespace

ExternalTrajectory read_external_estimate(const ExternalEstimate& estimate, std::int64_t epoch_ns) {
  ExternalTrajectory out;
  if (!is_bag(estimate.file)) {
    if (!estimate.topic.empty()) {
      throw InputError("--topic " + quote_input(estimate.topic) + ": " + estimate.file.string() +
                       " is not a bag (a folder, .mcap or .db3)");
    }
    for (const StampedPose& p : read_tum(estimate.file)) {
      out.t_s.push_back(p.t_s);
      out.poses.push_back(p.pose);
      out.covariances.emplace_back();
    }
  } else {
    if (estimate.topic.empty()) {
      throw InputError(estimate.file.string() +
                       ": a bag: name the estimate's topic with --topic (e.g. /amcl_pose)");
    }
    rosbag::BagReader bag(estimate.file);
    std::shared_ptr<rosbag::MessageDefinition> definition;
    std::string type;
    bag.read([&](const rosbag::BagTopic& topic, const rosbag::BagMessage& message) {
      if (topic.name != estimate.topic) return;
      const std::string short_type = rosbag::short_type_name(topic.type);
      try {
        if (!definition) {
          type = short_type;
          if (type != "geometry_msgs/PoseWithCovarianceStamped" && type != "nav_msgs/Odometry" &&
              type != "geometry_msgs/PoseStamped") {
            throw InputError("--topic " + estimate.topic + " is a " + topic.type +
                             ", not a PoseWithCovarianceStamped, Odometry or PoseStamped");
          }
          definition = std::make_shared<rosbag::MessageDefinition>(
              topic.definition_encoding == "ros2msg"
                  ? rosbag::MessageDefinition(topic.type, topic.definition)
                  : rosbag::MessageDefinition::known(topic.type));
        }
        const rosbag::Value value = definition->decode(message.data);
        const std::int64_t stamp =
            static_cast<std::int64_t>(value.number("header.stamp.sec")) * 1'000'000'000 +
            static_cast<std::int64_t>(value.number("header.stamp.nanosec"));
        const rosbag::Value& pose =
            type == "geometry_msgs/PoseStamped" ? value.at("pose") : value.at("pose.pose");
        out.t_s.push_back(static_cast<double>(stamp - epoch_ns) / 1e9);
        out.poses.push_back({pose.number("position.x"), pose.number("position.y"),
                             estimate_yaw(pose.at("orientation"))});
        if (type == "geometry_msgs/PoseStamped") {
          out.covariances.emplace_back();
        } else {
          // ROS's 6 x 6 over (x, y, z, roll, pitch, yaw): the rows and columns of x, y and yaw.
          const std::vector<double>& c = value.numbers("pose.covariance");
          std::array<double, 9> planar{};
          constexpr int kIndex[3] = {0, 1, 5};
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) planar[3 * i + j] = c[6 * kIndex[i] + kIndex[j]];
          out.covariances.emplace_back(planar);
        }
      } catch (const InputError&) {
        throw;
      } catch (const std::exception& e) {
        throw InputError(message.where() + ", topic " + topic.name + ": " + e.what());
      }
    });
  }
  if (out.t_s.empty()) {
    throw InputError(estimate.file.string() + (estimate.topic.empty() ? "" : " " + estimate.topic) +
                     ": no estimate in it");
  }
  // In time order (a bag's files, a TUM file written out of order).
  std::vector<std::size_t> order(out.t_s.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return out.t_s[a] < out.t_s[b]; });
  ExternalTrajectory sorted;
  for (const std::size_t i : order) {
    sorted.t_s.push_back(out.t_s[i]);
    sorted.poses.push_back(out.poses[i]);
    sorted.covariances.push_back(out.covariances[i]);
  }
  return sorted;
}

ScoreResult score_estimates(const ScoreOptions& options) {
  if (options.estimates.empty()) throw InputError("--estimate: give at least one");
  std::vector<fs::path> inputs{options.log_file};
  for (const ExternalEstimate& e : options.estimates) {
    if (!is_label(e.label)) {
      throw InputError("--label " + quote_input(e.label) +
                       ": a label is 1 to 64 ASCII letters, digits, '_' and '-' (it names files)");
    }
    inputs.push_back(e.file);
  }
  for (std::size_t i = 0; i < options.estimates.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (options.estimates[i].label == options.estimates[j].label) {
        throw InputError("--label " + options.estimates[i].label + " is given twice");
      }
    }
  }
  RunFolder::check(options.out_dir, options.overwrite, inputs);

  LogSource source(options.log_file, options.robot.empty()
                                         ? std::vector<std::string>{}
                                         : std::vector<std::string>{options.robot});
  const WorldDef& world = source.world();
  if (world.robots.size() != 1) {
    throw InputError(options.log_file.string() + ": the log has " +
                     std::to_string(world.robots.size()) +
                     " robots: name the one the estimates are of with --robot");
  }
  // The log's time 0 in Unix time: an imported bag's epoch and window, else locsim's export's.
  std::int64_t epoch_ns = 1'000'000'000;
  if (const auto& header = source.header(); header.contains("source")) {
    const auto& from = header["source"];
    if (from.contains("t0_unix_ns")) {
      epoch_ns =
          from["t0_unix_ns"].get<std::int64_t>() + std::llround(from.value("t0_s", 0.0) * 1e9);
    }
  }
  std::vector<ExternalTrajectory> trajectories;
  for (const ExternalEstimate& e : options.estimates) {
    trajectories.push_back(read_external_estimate(e, epoch_ns));
  }

  std::vector<LocalizerInfo> infos;
  for (const ExternalEstimate& e : options.estimates) {
    LocalizerInfo info;
    info.robot = 0;
    info.robot_name = world.robots[0].name;
    info.label = e.label;
    info.plugin = "external";
    info.plugin_file = e.file.string();
    info.params_json = nlohmann::json{{"file", e.file.string()}, {"topic", e.topic}}.dump();
    infos.push_back(info);
  }
  const PhysicsWorld physics(world);
  const OccupancyGrid grid =
      rasterize_static_world(physics, source.scenario().localization.grid_resolution_m);
  Scorer scorer(world, infos, options.convergence, &grid);

  nlohmann::ordered_json run;
  run["locsim_version"] = locsim_version();
  run["status"] = "running";
  run["command"] = "score";
  run["log_file"] = options.log_file.string();
  run["seed"] = source.seed();
  run["robots"] = robots_json(world);
  run["config"] = {{"world", to_json(world)}, {"scenario", to_json(source.scenario())}};
  const RunFolder folder = RunFolder::make(options.out_dir, world, run.dump(2) + "\n");
  folder.prepare(options.overwrite, inputs);
  RunRecorder recorder(folder, world, infos, false);

  ScoreResult result;
  result.samples.assign(options.estimates.size(), 0);
  std::vector<std::size_t> next(options.estimates.size(), 0);
  Record record;
  while (source.next(record)) {
    scorer.consume(record);
    recorder.consume(record);
    if (record.type != Record::Type::kGroundTruth || !truth_known(record.pose)) continue;
    ++result.true_poses;
    for (std::size_t k = 0; k < trajectories.size(); ++k) {
      // The latest estimate at this instant: what the localizer had said by then.
      const ExternalTrajectory& e = trajectories[k];
      while (next[k] < e.t_s.size() && e.t_s[next[k]] <= record.t_s + kStampTolerance_s) ++next[k];
      if (next[k] == 0) continue;  // none yet
      const std::size_t i = next[k] - 1;
      EstimateSample sample;
      sample.localizer = k;
      sample.t_s = record.t_s;
      sample.truth = record.pose;
      sample.pose = e.poses[i];
      if (e.covariances[i]) sample.covariance = *e.covariances[i];
      scorer.estimate(sample);
      recorder.estimate(sample);
      ++result.samples[k];
    }
  }
  recorder.close();
  std::vector<LocalizerFinal> finals(options.estimates.size());
  const nlohmann::ordered_json summaries = scorer.write(folder.robot_dirs, finals);
  run["status"] = "completed";
  run["true_poses"] = result.true_poses;
  nlohmann::ordered_json estimates = nlohmann::ordered_json::array();
  for (std::size_t k = 0; k < options.estimates.size(); ++k) {
    estimates.push_back({{"label", options.estimates[k].label},
                         {"file", options.estimates[k].file.string()},
                         {"topic", options.estimates[k].topic},
                         {"estimates", trajectories[k].t_s.size()},
                         {"scored_at", result.samples[k]}});
  }
  run["estimates"] = estimates;
  run["localizers"] = summaries;
  write_json_atomically(options.out_dir / "run.json", run);
  return result;
}

namespace {

/// A JSON object file of a run folder, or InputError naming it.
nlohmann::ordered_json read_run_file(const fs::path& file) {
  nlohmann::ordered_json j;
  try {
    j = nlohmann::ordered_json::parse(read_text(file));
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(file.string() + ": not valid JSON (" + e.what() + ")");
  }
  if (!j.is_object()) throw InputError(file.string() + ": not a JSON object");
  return j;
}

/// Replaces the entry of `list` whose `key` is `value`, or appends `entry`.
void put_entry(nlohmann::ordered_json& list, const nlohmann::ordered_json& entry, const char* key) {
  for (nlohmann::ordered_json& e : list) {
    if (e.is_object() && e.value(key, nlohmann::ordered_json()) == entry[key]) {
      e = entry;
      return;
    }
  }
  list.push_back(entry);
}

}  // namespace

fs::path log_of_run(const fs::path& run_dir) {
  const fs::path run_file = run_dir / "run.json";
  if (!fs::is_regular_file(run_file)) {
    throw InputError(run_dir.string() + ": not a run folder (no run.json)");
  }
  const nlohmann::ordered_json run = read_run_file(run_file);
  if (run.value("status", "") == "running") {
    throw InputError(run_file.string() + ": the run is still going on (status running)");
  }
  if (!run.contains("log_file") || !run["log_file"].is_string()) {
    throw InputError(
        run_file.string() +
        ": the run kept no log (run it with --log FILE, or replay a log), or give a log "
        "instead of the run folder");
  }
  const fs::path log = run["log_file"].get<std::string>();
  if (!fs::exists(log)) {
    throw InputError(run_file.string() + ": its log_file " + log.string() +
                     " is not there (a path relative to where the run was started): give the log "
                     "itself instead of the run folder");
  }
  return log;
}

ScoreResult score_into_run(const fs::path& run_dir, ScoreOptions options) {
  options.log_file = log_of_run(run_dir);
  const fs::path run_file = run_dir / "run.json";
  nlohmann::ordered_json run = read_run_file(run_file);
  // The robot's folder in the run, and the labels its metrics.json has.
  const nlohmann::ordered_json robots = run.value("robots", nlohmann::ordered_json::array());
  fs::path robot_dir;
  for (const auto& robot : robots) {
    if (options.robot.empty() ? robots.size() == 1 : robot.value("name", "") == options.robot)
      robot_dir = run_dir / robot.value("folder", ".");
  }
  if (robot_dir.empty()) {
    throw InputError(run_file.string() + (options.robot.empty()
                                              ? ": a run of several robots: name one with --robot"
                                              : ": no robot " + quote_input(options.robot)));
  }
  const fs::path metrics_file = robot_dir / "metrics.json";
  nlohmann::ordered_json metrics =
      fs::exists(metrics_file) ? read_run_file(metrics_file) : nlohmann::ordered_json::object();
  if (!metrics.contains("localizers")) metrics["localizers"] = nlohmann::ordered_json::array();
  for (const ExternalEstimate& e : options.estimates) {
    bool external = false;
    for (const auto& entry : metrics["localizers"]) {
      if (entry.value("label", "") == e.label) {
        if (entry.value("plugin", "") != "external") {
          throw InputError("--label " + e.label + ": one of the run's own localizers has it");
        }
        external = true;  // scored before: replaced
      }
    }
    if (!external && fs::exists(robot_dir / (e.label + ".tum"))) {
      throw InputError("--label " + e.label + ": the run has a file " + e.label +
                       ".tum of its own");
    }
  }

  // Scored into a folder of its own inside the run, then joined with the run's files.
  const fs::path partial = run_dir / ".score.partial";
  std::error_code ignored;
  fs::remove_all(partial, ignored);
  options.out_dir = partial;
  options.overwrite = false;
  ScoreResult result;
  try {
    result = score_estimates(options);
    const nlohmann::ordered_json scored = read_run_file(partial / "metrics.json");
    const nlohmann::ordered_json scored_run = read_run_file(partial / "run.json");
    for (const ExternalEstimate& e : options.estimates) {
      fs::copy_file(partial / (e.label + ".tum"), robot_dir / (e.label + ".tum"),
                    fs::copy_options::overwrite_existing);
    }
    for (const auto& entry : scored["localizers"]) put_entry(metrics["localizers"], entry, "label");
    if (!run.contains("localizers")) run["localizers"] = nlohmann::ordered_json::array();
    for (const auto& entry : scored_run["localizers"]) put_entry(run["localizers"], entry, "label");
    if (!run.contains("scored")) run["scored"] = nlohmann::ordered_json::array();
    for (const auto& entry : scored_run["estimates"]) put_entry(run["scored"], entry, "label");
    write_json_atomically(metrics_file, metrics);
    write_json_atomically(run_file, run);
  } catch (...) {
    fs::remove_all(partial, ignored);
    throw;
  }
  fs::remove_all(partial, ignored);
  return result;
}

}  // namespace locsim
