#include "sim/run/runner.hpp"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>
#include <type_traits>
#include <variant>

#include "sim/plugin_host/localizer_host.hpp"
#include "sim/run/config_json.hpp"
#include "sim/run/frame_capture.hpp"
#include "sim/run/run_log.hpp"
#include "sim/run/run_outputs.hpp"
#include "sim/run/simulation.hpp"
#include "sim/scenario/scenario_loader.hpp"
#include "sim/sensors/models.hpp"
#include "sim/world/occupancy.hpp"
#include "sim/world/world_loader.hpp"

#ifndef LOCSIM_VERSION_STRING
#define LOCSIM_VERSION_STRING "unknown"
#endif

namespace locsim {

const char* locsim_version() {
  return LOCSIM_VERSION_STRING;
}

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

RunInputs load_run_inputs(const fs::path& world_file, const std::optional<fs::path>& scenario_file,
                          std::optional<double> duration_s) {
  RunInputs inputs{load_world(world_file), ScenarioDef{}};
  if (scenario_file) {
    inputs.scenario = load_scenario(*scenario_file);
  } else if (inputs.world.scenario) {
    inputs.scenario = *inputs.world.scenario;
    inputs.scenario.source = world_file;
  } else {
    inputs.scenario.source = world_file;  // defaults: idle robots for 60 s
  }
  if (duration_s) {
    if (!(*duration_s > 0.0)) throw InputError("--duration: must be > 0");
    inputs.scenario.duration_s = *duration_s;
  }
  bind_scenario(inputs.scenario, inputs.world);
  return inputs;
}

namespace {

/// Writes the files of one run as it goes, flushing often so that a crash or Ctrl-C keeps
/// everything up to the last few steps.
class RunWriter {
 public:
  RunWriter(const fs::path& dir, const Simulation& sim,
            std::vector<std::unique_ptr<LocalizerHost>>& hosts)
      : dir_(dir), hosts_(hosts) {
    const std::size_t n = sim.robot_count();
    stride_ = std::llround(sim.world_def().physics.step_hz / sim.scenario().groundtruth_hz);
    for (std::size_t i = 0; i < n; ++i) {
      const fs::path robot_dir = n == 1 ? dir : dir / sim.robot(i).name();
      fs::create_directories(robot_dir);
      robot_dirs_.push_back(robot_dir);
      auto& file = groundtruth_.emplace_back(robot_dir / "groundtruth.tum", std::ios::binary);
      if (!file)
        throw std::runtime_error("cannot write " + (robot_dir / "groundtruth.tum").string());
      file << "# timestamp tx ty tz qx qy qz qw  (true pose of robot '" << sim.robot(i).name()
           << "', TUM format, z = 0)\n";
    }
    for (std::size_t i = 0; i < n; ++i) open_readings(sim, i);
    for (std::size_t i = 0; i < hosts_.size(); ++i) {
      auto& files = estimates_.emplace_back();
      for (const auto& instance : hosts_[i]->instances()) {
        const fs::path path = robot_dirs_[i] / (instance->label() + ".tum");
        auto& file = files.emplace_back(std::make_unique<std::ofstream>(path, std::ios::binary));
        if (!*file) throw std::runtime_error("cannot write " + path.string());
        *file << "# timestamp tx ty tz qx qy qz qw  (estimate of localizer '" << instance->label()
              << "', plugin " << instance->table().name << ", TUM format)\n";
      }
    }
    events_.open(dir / "events.csv", std::ios::binary);
    if (!events_) throw std::runtime_error("cannot write " + (dir / "events.csv").string());
    events_ << "t_s,kind,robot,details\n";
  }

  /// readings/ of robot `i`: one CSV per sensor, and sensors.json with their configuration.
  void open_readings(const Simulation& sim, std::size_t i) {
    const auto& sensors = sim.sensors(i);
    readings_.emplace_back();
    if (sensors.empty()) return;
    const fs::path dir = robot_dirs_[i] / "readings";
    fs::create_directories(dir);
    static const char* kHeaders[] = {
        "t_s,left_ticks,right_ticks,odom_x_m,odom_y_m,odom_theta_rad",
        "t_s,yaw_rate_radps,accel_x_mps2,accel_y_mps2",
        "t_s,pan_rad,tilt_rad,zoom,detections,color,id,range_m,bearing_rad,truth_id",
        "t_s,detections,color,id,range_m,bearing_rad,truth_id",
        "t_s,receiver,beacon_id,range_m,truth_status",
        "t_s,ranges_m",
    };
    for (const auto& sensor : sensors) {
      const auto kind = static_cast<std::size_t>(sensor->kind());
      auto& file = readings_.back()[kind];
      const fs::path path = dir / (std::string(sensor_name(sensor->kind())) + ".csv");
      file = std::make_unique<std::ofstream>(path, std::ios::binary);
      if (!*file) throw std::runtime_error("cannot write " + path.string());
      *file << kHeaders[kind] << '\n';
    }
    const json config = to_json(sim.world_def())["robots"][i]["sensors"];
    json described = config;
    if (described.contains("laser")) {
      const LaserDef& laser = *sim.robot(i).def().sensors.laser;
      json angles = json::array();
      for (int b = 0; b < laser.beams; ++b)
        angles.push_back(laser_beam_angle(b, laser.beams, laser.fov_rad));
      described["laser"]["beam_angles_rad"] = angles;
    }
    std::ofstream(dir / "sensors.json", std::ios::binary) << described.dump(2) << '\n';
  }

  void write(const Reading& reading) {
    auto& file = readings_[reading.robot][static_cast<std::size_t>(reading.kind)];
    if (!file) return;
    line_.clear();
    const auto number = [&](double value, int decimals) {
      line_ += ',';
      append_fixed(line_, value, decimals);
    };
    const auto start_row = [&] { append_fixed(line_, reading.t_s, 4); };
    std::visit(
        [&](const auto& data) {
          using T = std::decay_t<decltype(data)>;
          if constexpr (std::is_same_v<T, EncoderReading>) {
            start_row();
            line_ += ',' + std::to_string(data.left_ticks) + ',' + std::to_string(data.right_ticks);
            number(data.odometry.x, 6);
            number(data.odometry.y, 6);
            number(data.odometry.theta, 6);
            line_ += '\n';
          } else if constexpr (std::is_same_v<T, ImuReading>) {
            start_row();
            number(data.yaw_rate_radps, 6);
            number(data.accel_mps2.x(), 5);
            number(data.accel_mps2.y(), 5);
            line_ += '\n';
          } else if constexpr (std::is_same_v<T, PtzReading> || std::is_same_v<T, OmniReading>) {
            std::string prefix;
            append_fixed(prefix, reading.t_s, 4);
            if constexpr (std::is_same_v<T, PtzReading>) {
              prefix += ',';
              append_fixed(prefix, data.pan_rad, 6);
              prefix += ',';
              append_fixed(prefix, data.tilt_rad, 6);
              prefix += ',';
              append_fixed(prefix, data.zoom, 3);
            }
            prefix += ',' + std::to_string(data.detections.size());
            if (data.detections.empty()) line_ += prefix + ",,,,,\n";
            for (const Detection& d : data.detections) {
              line_ += prefix + ',' + d.color + ',' + std::to_string(d.id);
              number(d.range_m, 4);
              number(d.bearing_rad, 6);
              line_ += ',' + std::to_string(d.truth_id) + '\n';
            }
          } else if constexpr (std::is_same_v<T, UltrasonicReading>) {
            for (const BeaconRange& r : data.ranges) {
              start_row();
              line_ += ',' + std::to_string(r.receiver) + ',' + std::to_string(r.beacon_id);
              number(r.range_m, 4);
              line_ += ',';
              line_ += range_status_name(r.truth_status);
              line_ += '\n';
            }
          } else if constexpr (std::is_same_v<T, LaserScan>) {
            start_row();
            line_ += ',';
            for (std::size_t b = 0; b < data.ranges_m.size(); ++b) {
              if (b > 0) line_ += ' ';
              append_fixed(line_, data.ranges_m[b], 3);
            }
            line_ += '\n';
          }
        },
        reading.data);
    *file << line_;
  }

  /// Called after every step (and once before the first) with the step's readings, after the
  /// localizers have had them.
  void record(Simulation& sim, const std::vector<Reading>& readings) {
    for (const Reading& reading : readings) {
      write(reading);
      if (log_ != nullptr) log_->reading(reading);
    }
    for (const SimEvent& event : sim.take_events()) {
      line_.clear();
      append_fixed(line_, event.t_s, 4);
      line_ += ',' + event.kind + ',' + event.robot + ",\"" + event.details + "\"\n";
      events_ << line_;
      if (event.kind == "kidnap") kidnaps_[event.robot].push_back(event.t_s);
      if (log_ != nullptr) {
        int robot = -1;
        for (std::size_t i = 0; i < sim.robot_count(); ++i) {
          if (sim.robot(i).name() == event.robot) robot = static_cast<int>(i);
        }
        log_->event(event, robot);
      }
    }
    if (sim.step_index() % stride_ != 0 || sim.step_index() == last_step_) return;
    last_step_ = sim.step_index();
    for (std::size_t i = 0; i < sim.robot_count(); ++i) {
      const DiffDriveRobot& robot = sim.robot(i);
      if (robot.carried()) continue;  // in the air: no floor pose to report or compare with
      const Pose2 pose = robot.pose();
      line_.clear();
      append_tum(line_, sim.time_s(), pose.x, pose.y, pose.theta);
      groundtruth_[i] << line_;
      if (log_ != nullptr) log_->groundtruth(sim.time_s(), static_cast<int>(i), pose);
      if (i >= hosts_.size()) continue;
      auto& instances = hosts_[i]->instances();
      for (std::size_t k = 0; k < instances.size(); ++k) {
        instances[k]->diagnostics(sim.time_s());  // sampled for their means
        const std::optional<locsim_estimate> estimate = instances[k]->estimate(sim.time_s());
        if (!estimate) continue;
        line_.clear();
        append_tum(line_, sim.time_s(), estimate->pose.x, estimate->pose.y, estimate->pose.theta);
        *estimates_[i][k] << line_;
        instances[k]->add_error({sim.time_s(), estimate->pose.x - pose.x, estimate->pose.y - pose.y,
                                 wrap_angle(estimate->pose.theta - pose.theta)});
      }
    }
    if (sim.step_index() % (stride_ * 50) == 0) flush();
  }

  void set_log(LogWriter* log) { log_ = log; }

  void flush() {
    if (log_ != nullptr) log_->flush();
    for (auto& file : groundtruth_) file.flush();
    for (auto& robot : estimates_) {
      for (auto& file : robot) file->flush();
    }
    for (auto& robot : readings_) {
      for (auto& file : robot) {
        if (file) file->flush();
      }
    }
    events_.flush();
  }

  const std::vector<fs::path>& robot_dirs() const { return robot_dirs_; }
  /// Kidnap times of a robot so far [s].
  std::vector<double> kidnaps(const std::string& robot) const {
    const auto it = kidnaps_.find(robot);
    return it == kidnaps_.end() ? std::vector<double>{} : it->second;
  }

 private:
  fs::path dir_;
  std::int64_t stride_ = 1;
  std::int64_t last_step_ = -1;
  std::vector<fs::path> robot_dirs_;
  std::vector<std::ofstream> groundtruth_;
  std::ofstream events_;
  std::vector<std::array<std::unique_ptr<std::ofstream>, 6>> readings_;  // by robot, SensorKind
  std::vector<std::unique_ptr<LocalizerHost>>& hosts_;                   // by robot
  std::vector<std::vector<std::unique_ptr<std::ofstream>>> estimates_;   // by robot, localizer
  std::map<std::string, std::vector<double>> kidnaps_;                   // by robot
  LogWriter* log_ = nullptr;
  std::string line_;
};

fs::path default_out_dir(const RunInputs& inputs, std::uint64_t seed) {
  const std::time_t now = std::time(nullptr);
  char stamp[32];
  std::strftime(stamp, sizeof(stamp), "%Y%m%d-%H%M%S", std::localtime(&now));
  const std::string base =
      inputs.world.name + "-" + inputs.scenario.name + "-seed" + std::to_string(seed) + "-" + stamp;
  fs::path dir = fs::path("runs") / base;
  for (int suffix = 2; fs::exists(dir); ++suffix) {
    dir = fs::path("runs") / (base + "-" + std::to_string(suffix));
  }
  return dir;
}

}  // namespace

RunResult run_simulation(const RunOptions& options, const std::atomic<bool>* interrupt) {
  // Everything that can be wrong with the input is found before the folder is made.
  RunInputs inputs = load_run_inputs(options.world_file, options.scenario_file, options.duration_s);
  Simulation sim(inputs.world, inputs.scenario, options.seed, options.make_landmark_imager);
  // Plugins are loaded and created before anything is written too (exit 3 leaves no folder).
  std::vector<std::unique_ptr<LocalizerHost>> hosts;
  if (!options.localizers.empty()) {
    std::vector<LocalizerSpec> specs;
    for (const std::string& text : options.localizers) specs.push_back(parse_localizer_spec(text));
    const OccupancyGrid grid =
        rasterize_static_world(sim.world(), inputs.scenario.localization.grid_resolution_m);
    for (std::size_t i = 0; i < sim.robot_count(); ++i) {
      hosts.push_back(std::make_unique<LocalizerHost>(specs, sim.world_def(), sim.robot(i).def(),
                                                      inputs.scenario.localization, grid,
                                                      options.seed));
    }
  }
  std::optional<FrameCapture> capture;
  const auto deliver_and_record = [&](RunWriter& writer) {
    std::vector<Reading> readings = sim.take_readings();
    for (const Reading& reading : readings) {
      if (static_cast<std::size_t>(reading.robot) < hosts.size())
        hosts[reading.robot]->deliver(reading);
    }
    writer.record(sim, readings);
    if (capture) capture->step(sim, readings, hosts);
  };

  RunResult result;
  result.out_dir =
      options.out_dir.empty() ? default_out_dir(inputs, options.seed) : options.out_dir;
  if (fs::exists(result.out_dir) && !fs::is_directory(result.out_dir)) {
    throw InputError("--out: '" + result.out_dir.string() + "' exists and is not a folder");
  }
  if (fs::exists(result.out_dir) && !fs::is_empty(result.out_dir) && !options.overwrite) {
    throw InputError("--out: folder '" + result.out_dir.string() +
                     "' is not empty; choose another or pass --overwrite");
  }
  fs::create_directories(result.out_dir);
  RunWriter writer(result.out_dir, sim, hosts);
  std::unique_ptr<LogWriter> log;
  if (options.log_file) {
    const auto text = [](const fs::path& file) {
      std::ifstream in(file, std::ios::binary);
      std::ostringstream content;
      content << in.rdbuf();
      return content.str();
    };
    // Everything replay needs to rebuild the world and its localizer inputs: the files' text.
    json header = {{"format", "locsim-log"},
                   {"locsim_version", locsim_version()},
                   {"seed", options.seed},
                   {"world_file", options.world_file.string()},
                   {"world_dir", fs::absolute(options.world_file).parent_path().string()},
                   {"world_yaml", text(options.world_file)},
                   {"scenario_file",
                    options.scenario_file ? json(options.scenario_file->string()) : json(nullptr)},
                   {"scenario_yaml",
                    options.scenario_file ? json(text(*options.scenario_file)) : json(nullptr)},
                   {"duration_s", inputs.scenario.duration_s}};
    log = std::make_unique<LogWriter>(*options.log_file, header);
    writer.set_log(log.get());
  }

  const auto wall_start = std::chrono::steady_clock::now();
  auto next_progress = wall_start + std::chrono::seconds(1);
  bool progress_shown = false;
  std::string error;
  std::exception_ptr failure;
  result.status = "completed";
  try {
    if (options.video != nullptr) capture.emplace(*options.video, options.video_options, sim);
    deliver_and_record(writer);
    while (!sim.done()) {
      if (interrupt != nullptr && interrupt->load(std::memory_order_relaxed)) {
        result.status = "interrupted";
        break;
      }
      sim.step();
      deliver_and_record(writer);
      if (options.realtime) {
        std::this_thread::sleep_until(wall_start + std::chrono::duration<double>(sim.time_s()));
      }
      if (options.progress && (sim.step_index() & 255) == 0) {
        const auto now = std::chrono::steady_clock::now();
        if (now >= next_progress) {
          const double wall = std::chrono::duration<double>(now - wall_start).count();
          std::fprintf(
              stderr, "\r  t = %.1f / %.1f s (%3.0f%%), %.0fx real time   ", sim.time_s(),
              inputs.scenario.duration_s,
              100.0 * static_cast<double>(sim.step_index()) / static_cast<double>(sim.end_step()),
              sim.time_s() / wall);
          next_progress = now + std::chrono::milliseconds(500);
          progress_shown = true;
        }
      }
    }
  } catch (const std::exception& e) {
    result.status = "failed";
    error = e.what();
    failure = std::current_exception();
  }
  if (progress_shown) std::fprintf(stderr, "\n");
  writer.flush();
  if (options.video != nullptr) {
    // Closed whatever the status: the frames so far make a valid video of a failed run too.
    try {
      options.video->finish();
    } catch (const std::exception& e) {
      if (!failure) {
        result.status = "failed";
        error = std::string("video: ") + e.what();
        failure = std::current_exception();
      }
    }
  }
  if (log && result.status == "completed") log->finish();  // else it reads as truncated, rightly
  result.wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  result.simulated_s = sim.time_s();
  result.state_hash = sim.state_hash();

  json run;
  run["locsim_version"] = locsim_version();
  run["status"] = result.status;
  if (!error.empty()) run["error"] = error;
  run["seed"] = options.seed;
  run["world_file"] = options.world_file.string();
  run["scenario_file"] = inputs.scenario.source.string();
  run["simulated_s"] = result.simulated_s;
  run["steps"] = sim.step_index();
  char hash[24];
  std::snprintf(hash, sizeof(hash), "%016llx", static_cast<unsigned long long>(result.state_hash));
  run["state_hash"] = hash;
  json robots = json::array();
  for (std::size_t i = 0; i < sim.robot_count(); ++i) {
    const RobotStats& stats = sim.stats(i);
    const Pose2 pose = sim.robot(i).pose();
    robots.push_back({{"name", sim.robot(i).name()},
                      {"folder", fs::relative(writer.robot_dirs()[i], result.out_dir).string()},
                      {"final_pose", {{"x", pose.x}, {"y", pose.y}, {"theta", pose.theta}}},
                      {"ground_distance_m", stats.ground_distance_m},
                      {"wheel_distance_left_m", stats.wheel_distance_left_m},
                      {"wheel_distance_right_m", stats.wheel_distance_right_m},
                      {"slip_time_s", stats.slip_time_s},
                      {"collisions", stats.collisions},
                      {"kidnaps", stats.kidnaps}});
  }
  run["robots"] = robots;
  json localizers = json::array();
  for (std::size_t i = 0; i < hosts.size(); ++i) {
    for (const json& entry :
         write_localizer_metrics(writer.robot_dirs()[i], sim.robot(i).name(), *hosts[i],
                                 writer.kidnaps(sim.robot(i).name()), sim.time_s())) {
      localizers.push_back(entry);
    }
  }
  if (!hosts.empty()) run["localizers"] = localizers;
  run["config"] = {{"world", to_json(inputs.world)}, {"scenario", to_json(inputs.scenario)}};
  // Wall-clock figures vary from run to run; they are kept last, in this one block, so that
  // everything else in the run folder is byte-identical for the same inputs and seed.
  run["timing"] = {
      {"wall_s", result.wall_s},
      {"real_time_factor", result.wall_s > 0.0 ? result.simulated_s / result.wall_s : 0.0},
      {"realtime_paced", options.realtime}};
  write_json_atomically(result.out_dir / "run.json", run);
  if (failure) std::rethrow_exception(failure);
  return result;
}

}  // namespace locsim
