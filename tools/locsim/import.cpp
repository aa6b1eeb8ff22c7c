// `locsim import`: turn a real dataset into a log that `locsim replay` runs.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/producers/generic_import.hpp"
#include "sim/producers/import_log.hpp"
#include "sim/producers/locsim_bag.hpp"
#include "sim/producers/mrclam_import.hpp"
#include "sim/producers/rosbag_import.hpp"

namespace locsim::cli::import_cmd {

/// What the command line gives; its options write into it, so it lives as long as the command.
struct State {
  std::string format, source, out, robots = "all";
  ImportWindow window;
  double duration_s = 0.0;
  CLI::Option* duration = nullptr;  // given or not: the window's duration is optional
  bool overwrite = false, quiet = false;
  // rosbag2
  std::string topics_file, laser, odometry, imu, truth, map, base_frame, odom_frame, start;
  bool receive_time = false, list = false, ignore_log_header = false;
};

/// --start "x,y,theta" [m, m, rad].
Pose2 parse_start(const std::string& text) {
  Pose2 pose;
  double* const parts[3] = {&pose.x, &pose.y, &pose.theta};
  std::size_t at = 0;
  for (int i = 0; i < 3; ++i) {
    const std::size_t end = i < 2 ? text.find(',', at) : text.size();
    const std::string part = end == std::string::npos ? "" : text.substr(at, end - at);
    const auto [stop, error] = std::from_chars(part.data(), part.data() + part.size(), *parts[i]);
    if (part.empty() || error != std::errc() || stop != part.data() + part.size() ||
        !std::isfinite(*parts[i])) {
      throw InputError("--start: expected x,y,theta (metres, metres, radians), got " +
                       quote_input(text));
    }
    at = end + 1;
  }
  return pose;
}

/// The bag's topics, and what the import makes of them (--list).
void print_topics(const RosbagDataset& read) {
  std::size_t name_width = 5, type_width = 4;
  for (const RosbagTopicUse& topic : read.topics) {
    name_width = std::max(name_width, topic.name.size());
    type_width = std::max(type_width, topic.type.size());
  }
  std::printf("%-*s  %-*s  %9s  %s\n", static_cast<int>(name_width), "topic",
              static_cast<int>(type_width), "type", "messages", "use");
  for (const RosbagTopicUse& topic : read.topics) {
    std::printf("%-*s  %-*s  %9llu  %s\n", static_cast<int>(name_width),
                printable(topic.name).c_str(), static_cast<int>(type_width),
                printable(topic.type).c_str(), static_cast<unsigned long long>(topic.messages),
                topic.use.c_str());
  }
  for (const std::string& note : read.notes) std::printf("note: %s\n", note.c_str());
}

RosbagDataset read_bag(const State& s) {
  RosbagImportOptions options;
  options.bag = s.source;
  if (!s.topics_file.empty()) options.topics = read_rosbag_topics(s.topics_file);
  RosbagTopics& topics = options.topics;
  for (const auto& [given, into] :
       {std::pair{&s.laser, &topics.laser}, std::pair{&s.odometry, &topics.odometry},
        std::pair{&s.imu, &topics.imu}, std::pair{&s.truth, &topics.truth},
        std::pair{&s.base_frame, &topics.base_frame},
        std::pair{&s.odom_frame, &topics.odom_frame}}) {
    if (!given->empty()) *into = *given;
  }
  // --map names a topic (/map) or a map_server YAML file.
  if (s.map.ends_with(".yaml") || s.map.ends_with(".yml")) {
    topics.map_yaml = s.map;
  } else if (!s.map.empty()) {
    topics.map = s.map;
  }
  options.receive_time = s.receive_time;
  if (!s.start.empty()) options.start = parse_start(s.start);
  return read_rosbag2(options);
}

int execute(State& s) {
  if (*s.duration) s.window.duration_s = s.duration_s;
  if (s.format != "rosbag2") {
    for (const auto& [given, option] :
         {std::pair{!s.topics_file.empty() || !s.laser.empty() || !s.odometry.empty() ||
                        !s.imu.empty() || !s.truth.empty() || !s.map.empty() ||
                        !s.base_frame.empty() || !s.odom_frame.empty() || !s.start.empty() ||
                        s.receive_time || s.ignore_log_header,
                    "--topics, --laser, --odom, --imu, --truth, --map, --base-frame, "
                    "--odom-frame, --start, --receive-time and --ignore-log-header"},
          std::pair{s.list, "--list"}}) {
      if (given) throw InputError(std::string(option) + ": for rosbag2 only");
    }
  }
  if (s.list) {
    print_topics(read_bag(s));
    return kExitOk;
  }
  if (s.out.empty()) throw InputError("--out: the log file to write is required");
  std::error_code out_error;
  const std::filesystem::file_status out_status = std::filesystem::status(s.out, out_error);
  if (out_error && out_status.type() != std::filesystem::file_type::not_found) {
    throw InputError("--out: " + s.out + " cannot be looked up: " + out_error.message());
  }
  if (std::filesystem::is_directory(out_status)) {
    throw InputError("--out: " + s.out + " is a folder; name the log file");
  }
  check_output_folder(std::filesystem::path(s.out).parent_path(), "--out");
  if (std::filesystem::exists(out_status) && !s.overwrite) {
    throw InputError("--out: " + s.out + " exists (pass --overwrite to replace it)");
  }
  if (s.format != "mrclam" && s.robots != "all") {
    throw InputError(
        "--robots: for mrclam only (a generic dataset's robots are its "
        "sub-folders)");
  }
  MrclamImportOptions mrclam;
  mrclam.dir = s.source;
  if (s.robots != "all") {
    std::istringstream list(s.robots);
    std::string item;
    while (std::getline(list, item, ',')) {
      int subject = 0;
      const auto [end, error] = std::from_chars(item.data(), item.data() + item.size(), subject);
      if (item.empty() || error != std::errc() || end != item.data() + item.size()) {
        throw InputError("--robots: expected robot numbers as 1,3 or all, got '" + s.robots + "'");
      }
      mrclam.robots.push_back(subject);
    }
    if (mrclam.robots.empty()) throw InputError("--robots: no robot given");
  }
  // A bag locsim exported is rebuilt into the log it came from (its world carried along).
  if (s.format == "rosbag2" && !s.ignore_log_header) {
    if (const auto records = rebuild_locsim_log(s.source, s.out)) {
      if (!s.quiet) {
        std::printf(
            "%s: a bag locsim exported: %llu records rebuilt, its world as exported -> %s\n",
            s.source.c_str(), static_cast<unsigned long long>(*records), s.out.c_str());
      }
      return kExitOk;
    }
  }
  std::vector<std::string> notes;
  ImportedDataset dataset;
  if (s.format == "rosbag2") {
    RosbagDataset read = read_bag(s);
    dataset = std::move(read.dataset);
    notes = std::move(read.notes);
  } else {
    dataset = s.format == "generic" ? read_generic(s.source) : read_mrclam(mrclam);
  }
  const ImportSummary summary = write_import(std::move(dataset), s.window, s.out);
  if (!s.quiet) {
    std::printf("%s: %s -> %s\n", s.source.c_str(), describe(summary).c_str(), s.out.c_str());
    for (const std::string& note : notes) std::printf("note: %s\n", note.c_str());
  }
  return kExitOk;
}

}  // namespace locsim::cli::import_cmd

namespace locsim::cli {

Command add_import(CLI::App& app) {
  const auto state = std::make_shared<import_cmd::State>();
  CLI::App* const import_command = app.add_subcommand(
      "import", "Turn a real dataset into a log that `locsim replay` runs (docs/real_data.md)");
  import_command->add_option("format", state->format, "mrclam, generic or rosbag2")
      ->required()
      ->check(CLI::IsMember({"mrclam", "generic", "rosbag2"}));
  import_command
      ->add_option("source", state->source,
                   "The dataset's folder (rosbag2: the bag's folder, or its .mcap or .db3 file)")
      ->required();
  import_command->add_option("--out", state->out, "The log file to write (.locsimlog)");
  import_command->add_option("--robots", state->robots,
                             "mrclam: the robots to import, as 1,3 (subjects 1-5), or all");
  import_command
      ->add_option("--from", state->window.from_s,
                   "Start this many seconds after the dataset's first time stamp")
      ->check(number_in(0.0, 1e7));
  state->duration =
      import_command->add_option("--duration", state->duration_s, "Import this many seconds")
          ->check(number_above(0.0, 1e7));
  import_command->add_flag("--overwrite", state->overwrite, "Replace an existing log file");
  import_command->add_flag("-q,--quiet", state->quiet, "No summary line");
  const std::string bag = "rosbag2";
  import_command
      ->add_flag("--list", state->list,
                 "rosbag2: list the bag's topics and what an import makes of them; "
                 "write nothing")
      ->group(bag);
  import_command
      ->add_option("--topics", state->topics_file,
                   "rosbag2: a YAML file naming the topics (keys: laser, odometry, imu, "
                   "truth, map, map_yaml, base_frame, odom_frame)")
      ->group(bag);
  import_command->add_option("--laser", state->laser, "rosbag2: the LaserScan topic")->group(bag);
  import_command
      ->add_option("--odom", state->odometry,
                   "rosbag2: the Odometry topic, or tf (the odom -> base transform)")
      ->group(bag);
  import_command->add_option("--imu", state->imu, "rosbag2: the Imu topic")->group(bag);
  import_command
      ->add_option("--truth", state->truth,
                   "rosbag2: the true poses: a PoseStamped, PoseWithCovarianceStamped or "
                   "Odometry topic, or tf:FRAME (a motion-capture body's transform)")
      ->group(bag);
  import_command
      ->add_option("--map", state->map,
                   "rosbag2: the OccupancyGrid topic, or a map_server YAML file")
      ->group(bag);
  import_command
      ->add_option("--base-frame", state->base_frame,
                   "rosbag2: the robot's frame (default: the odometry's child frame)")
      ->group(bag);
  import_command
      ->add_option("--odom-frame", state->odom_frame,
                   "rosbag2: the odometry's frame, for --odom tf (default: odom)")
      ->group(bag);
  import_command
      ->add_option("--start", state->start,
                   "rosbag2: the start pose x,y,theta on the map [m, m, rad] (default: "
                   "the first true pose)")
      ->group(bag);
  import_command
      ->add_flag("--receive-time", state->receive_time,
                 "rosbag2: time readings by when the bag received them, not by their "
                 "headers' stamps")
      ->group(bag);
  import_command
      ->add_flag("--ignore-log-header", state->ignore_log_header,
                 "rosbag2: read a bag locsim exported by its ROS topics alone, as any other bag "
                 "(without it, its /locsim/log_header rebuilds the exported log and its world)")
      ->group(bag);
  import_command->footer(
      std::string(
          "mrclam: a UTIAS MRCLAM dataset's folder (Barcodes.dat, Landmark_Groundtruth.dat,\n"
          "RobotN_Odometry.dat, RobotN_Groundtruth.dat, RobotN_Measurement.dat).\n"
          "generic: a folder of CSV files a few lines of Python write from any dataset, one "
          "robot's\n"
          "in it or one sub-folder per robot:\n"
          "  odometry.csv      t,v,omega | t,x,y,theta       groundtruth.tum  t x y z qx qy qz qw\n"
          "  map.csv           id,x,y[,color] (landmarks)    detections.csv   t,id,range,bearing\n"
          "  imu.csv           t,yaw_rate[,accel_x,accel_y]  beacons.csv      id,x,y[,z]\n"
          "  ranges.csv        t,beacon,range[,receiver]     scans.csv        t,ranges (laser)\n"
          "  occupancy.yaml    a ROS map_server map          robot.yaml       geometry, sensors\n"
          "(docs/real_data.md#the-generic-format says every column and key).\n"
          "rosbag2: a ROS 2 recording: a folder with metadata.yaml, or one .mcap or .db3 file.\n"
          "Topics are found by their types (/scan, /odom, /imu, /map, /ground_truth among "
          "several),\nor named; --list shows what is in the bag and what becomes of it "
          "(docs/ros.md).\n\n") +
      kExitCodes);
  return {import_command, [state] { return import_cmd::execute(*state); }};
}

}  // namespace locsim::cli
