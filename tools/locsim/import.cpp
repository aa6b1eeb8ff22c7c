// `locsim import`: turn a real dataset into a log that `locsim replay` runs.
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <system_error>

#include "commands.hpp"
#include "common.hpp"
#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/producers/generic_import.hpp"
#include "sim/producers/import_log.hpp"
#include "sim/producers/mrclam_import.hpp"

namespace locsim::cli::import_cmd {

/// What the command line gives; its options write into it, so it lives as long as the command.
struct State {
  std::string format, source, out, robots = "all";
  ImportWindow window;
  double duration_s = 0.0;
  CLI::Option* duration = nullptr;  // given or not: the window's duration is optional
  bool overwrite = false, quiet = false;
};

int execute(State& s) {
  if (*s.duration) s.window.duration_s = s.duration_s;
  if (s.out.empty()) throw InputError("--out: the path is empty");
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
  if (s.format == "generic" && s.robots != "all") {
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
  const ImportSummary summary = write_import(
      s.format == "generic" ? read_generic(s.source) : read_mrclam(mrclam), s.window, s.out);
  if (!s.quiet) {
    std::printf("%s: %s -> %s\n", s.source.c_str(), describe(summary).c_str(), s.out.c_str());
  }
  return kExitOk;
}

}  // namespace locsim::cli::import_cmd

namespace locsim::cli {

Command add_import(CLI::App& app) {
  const auto state = std::make_shared<import_cmd::State>();
  CLI::App* const import_command = app.add_subcommand(
      "import", "Turn a real dataset into a log that `locsim replay` runs (docs/real_data.md)");
  import_command->add_option("format", state->format, "mrclam or generic")
      ->required()
      ->check(CLI::IsMember({"mrclam", "generic"}));
  import_command->add_option("source", state->source, "The dataset's folder")->required();
  import_command->add_option("--out", state->out, "The log file to write (.locsimlog)")->required();
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
          "(docs/real_data.md#the-generic-format says every column and key).\n\n") +
      kExitCodes);
  return {import_command, [state] { return import_cmd::execute(*state); }};
}

}  // namespace locsim::cli
