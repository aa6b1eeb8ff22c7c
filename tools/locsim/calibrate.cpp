// `locsim calibrate`: measure odometry and detection noise in logs with ground truth.
#include <cstddef>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/metrics/calibration.hpp"

namespace locsim::cli::calibrate_cmd {

/// What the command line gives; its options write into it, so it lives as long as the command.
struct State {
  std::vector<std::string> logs;
  std::string out, robots = "all";
  CalibrationOptions options;
  bool overwrite = false, quiet = false;
};

int execute(State& s) {
  s.options.robots = robot_names(s.robots);
  const std::filesystem::path out(s.out);
  if (out.empty()) throw InputError("--out: the path is empty");
  check_output_folder(out, "--out");
  for (const char* name : {"calibration.yaml", "calibration.json"}) {
    if (std::filesystem::exists(out / name) && !s.overwrite) {
      throw InputError("--out: " + (out / name).string() +
                       " exists (pass --overwrite to replace it)");
    }
  }
  const std::vector<std::filesystem::path> logs(s.logs.begin(), s.logs.end());
  const Calibration result = calibrate(logs, s.options);
  make_output_folder(out, "--out");
  // The pair together: a failed write leaves neither half of a new pair beside an old one.
  const std::string json_text = result.to_json().dump(2) + '\n', yaml_text = result.to_yaml();
  write_files({{out / "calibration.json", json_text}, {out / "calibration.yaml", yaml_text}});
  if (!s.quiet) std::printf("%s", describe(result).c_str());
  return kExitOk;
}

}  // namespace locsim::cli::calibrate_cmd

namespace locsim::cli {

Command add_calibrate(CLI::App& app) {
  const auto state = std::make_shared<calibrate_cmd::State>();
  CLI::App* const calibrate = app.add_subcommand(
      "calibrate",
      "Measure odometry and detection noise in logs with ground truth; write a parameter file "
      "for the localizers (--params) and sensor settings for a world (docs/real_data.md)");
  calibrate->add_option("logs", state->logs, "Logs (run --log, or locsim import)")->required();
  calibrate
      ->add_option("--out", state->out,
                   "Folder for calibration.yaml and calibration.json (`locsim report` plots them)")
      ->required();
  calibrate->add_option("--robots", state->robots,
                        "The robots to use, by name, as robot1,robot3; or all");
  calibrate
      ->add_option("--outlier-sigmas", state->options.outlier_sigmas,
                   "A detection this many robust standard deviations off is false [-]")
      ->check(
          number_in(CalibrationOptions::kMinOutlierSigmas, CalibrationOptions::kMaxOutlierSigmas))
      ->capture_default_str();
  calibrate
      ->add_option("--range-bins", state->options.range_bins,
                   "At most this many range bins for the detection noise [-]")
      ->check(CLI::Range(std::size_t{1}, CalibrationOptions::kMaxRangeBins))
      ->capture_default_str();
  calibrate->add_flag("--overwrite", state->overwrite,
                      "Replace calibration.yaml and calibration.json in --out");
  calibrate->add_flag("-q,--quiet", state->quiet, "No summary");
  return {calibrate, [state] { return calibrate_cmd::execute(*state); }};
}

}  // namespace locsim::cli
