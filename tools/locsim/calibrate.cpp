// `locsim calibrate`: measure odometry and detection noise in logs with ground truth; with several
// logs, check that the calibration describes the robots rather than one recording.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/experiments/calibration_check.hpp"
#include "sim/metrics/calibration.hpp"

namespace locsim::cli::calibrate_cmd {

/// What the command line gives; its options write into it, so it lives as long as the command.
struct State {
  std::vector<std::string> logs;
  std::string out, robots = "all";
  CalibrationOptions options;
  std::string check = "auto";     // --check: localizers that replay; "none"; "auto"
  std::uint64_t check_seeds = 0;  // --check-seeds: 0, each log's own seed
  int jobs = 1;
  double flag_above = 0.25;
  bool overwrite = false, quiet = false;
};

/// The calibration file with the check's flags in its header, where a user of the file reads.
std::string with_flags(const std::string& yaml, const std::vector<std::string>& flags) {
  if (flags.empty()) return yaml;
  std::string header =
      "# Flagged: a recording's calibration moves a localizer's RMS on another "
      "(calibration.json \"transfer\"):\n";
  for (const std::string& line : flags) header += "#   " + line + "\n";
  const std::size_t at = yaml.find("localizer_params:");
  return at == std::string::npos ? header + yaml : yaml.substr(0, at) + header + yaml.substr(at);
}

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
  const bool checked = logs.size() >= 2;
  // auto: chosen by what the logs hold, once calibrated (built-in plugins: nothing to refuse).
  const bool auto_check = s.check == "auto";
  const std::vector<std::string> localizers = s.check == "none" || auto_check
                                                  ? std::vector<std::string>{}
                                                  : comma_names(s.check, "--check");
  // The check's folders are its own outputs: replaced whole with --overwrite, never holding an
  // input.
  for (const char* name : {"recordings", "transfer"}) {
    const std::filesystem::path dir = out / name;
    if (!checked || !std::filesystem::exists(dir)) continue;
    if (!s.overwrite) {
      throw InputError("--out: " + dir.string() + " exists (pass --overwrite to replace it)");
    }
    for (const std::filesystem::path& log : logs) {
      const auto relative = std::filesystem::weakly_canonical(log).lexically_relative(
          std::filesystem::weakly_canonical(dir));
      if (!relative.empty() && *relative.begin() != "..") {
        throw InputError(log.string() + ": lies in " + dir.string() +
                         ", which --overwrite would replace: move it out first");
      }
    }
  }
  CalibrationCheckOptions check;
  check.logs = logs;
  check.calibration = s.options;
  check.pooled_file = out / "calibration.yaml";
  check.out_dir = out;
  check.localizers = localizers;
  for (std::uint64_t seed = 1; seed <= s.check_seeds; ++seed) check.seeds.push_back(seed);
  check.jobs = s.jobs;
  check.flag_above = s.flag_above;
  // Its bad input refused before anything is written.
  if (checked && !auto_check) checked_recordings(check);
  const Calibration result = calibrate(logs, s.options);
  if (auto_check) {
    // The landmark EKF where there are detections, else the beacon EKF where there are ranges.
    if (!result.cameras.empty())
      check.localizers = {"ekf_landmarks"};
    else if (result.ranging)
      check.localizers = {"ultrasonic_ekf"};
    if (checked) checked_recordings(check);
  }
  make_output_folder(out, "--out");
  for (const char* name : {"recordings", "transfer"}) {
    if (checked) std::filesystem::remove_all(out / name);
  }
  // The pair together: a failed write leaves neither half of a new pair beside an old one.
  nlohmann::ordered_json json = result.to_json();
  const std::string yaml_text = result.to_yaml();
  write_files(
      {{out / "calibration.json", json.dump(2) + '\n'}, {out / "calibration.yaml", yaml_text}});
  if (!s.quiet) std::printf("%s", describe(result).c_str());
  if (!checked) return kExitOk;

  const CalibrationCheck checks = check_calibration(check, catch_sigint());
  const nlohmann::ordered_json found = checks.to_json();
  for (const auto& [key, value] : found.items()) json[key] = value;
  write_files({{out / "calibration.json", json.dump(2) + '\n'},
               {out / "calibration.yaml", with_flags(yaml_text, checks.flags())}});
  if (!s.quiet) std::printf("%s", checks.describe().c_str());
  if (checks.interrupted) return kExitInterrupted;
  if (checks.errors > 0) {
    std::fflush(stdout);
    std::fprintf(stderr,
                 "locsim calibrate: %zu replay%s ended in error (locsim could not produce a "
                 "result): see %s/transfer (results.csv, each run's log.txt)\n",
                 checks.errors, checks.errors == 1 ? "" : "s", out.c_str());
    return kExitFailure;
  }
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
  calibrate
      ->add_option("--check", state->check,
                   "With several logs: the localizers that replay each log with each log's "
                   "calibration (comma-separated names), none, or auto: ekf_landmarks for logs "
                   "with detections, ultrasonic_ekf for logs with ranges to beacons only")
      ->capture_default_str();
  calibrate
      ->add_option("--check-seeds", state->check_seeds,
                   "Replay each with seeds 1..N (particle filters vary by seed; with two or more, "
                   "each change gets a 95 % interval); default: each log's own seed")
      ->transform(whole_number_in(1, 1000));
  calibrate->add_option("-j,--jobs", state->jobs, "Replays at a time, each its own process")
      ->transform(whole_number_in(1, 4096))
      ->capture_default_str();
  calibrate
      ->add_option("--flag-above", state->flag_above,
                   "Flag a calibration that moves a localizer's RMS on another log by more than "
                   "this share [-]")
      ->check(number_in(CalibrationCheckOptions::kFlagRange.min,
                        CalibrationCheckOptions::kFlagRange.max))
      ->capture_default_str();
  calibrate->add_flag("--overwrite", state->overwrite,
                      "Replace calibration.yaml, calibration.json, recordings/ and transfer/ in "
                      "--out");
  calibrate->add_flag("-q,--quiet", state->quiet, "No summary");
  calibrate->footer(
      "With two logs or more (recordings of the same robots: datasets, halves of one, one robot\n"
      "each), calibrate also fits each log alone (--out/recordings/NAME/) and reports how far\n"
      "each value spreads over them; then --check replays every log with every log's calibration\n"
      "and the pooled one (--out/transfer/, a sweep) and flags a calibration that moves a\n"
      "localizer's position RMS on another log by more than --flag-above against that log's own,\n"
      "naming what moves it (each group of parameters swapped alone). calibration.json has it all\n"
      "(\"recordings\", \"spread\", \"transfer\"), calibration.yaml's header the flags\n"
      "(docs/real_data.md).\n\n"
      "Exit codes:\n"
      "  0    calibrated (flags are findings, not failures)\n"
      "  1    a replay of the check ended in error (locsim could not produce its result: its\n"
      "       log.txt under --out/transfer says why), or a failure not caused by the input\n"
      "  2    bad input: a log unreadable, without ground truth or too short to measure (the\n"
      "       message names it), --robots a log does not hold, two logs of one file name, an\n"
      "       output that exists without --overwrite; nothing is written (but for a log too\n"
      "       short to be calibrated alone: the pooled calibration is)\n"
      "  3    a --check plugin not found or not loadable\n"
      "  130  interrupted (Ctrl-C) during the check: calibration.* and recordings/ are written,\n"
      "       the replays so far are in --out/transfer");
  return {calibrate, [state] { return calibrate_cmd::execute(*state); }};
}

}  // namespace locsim::cli
