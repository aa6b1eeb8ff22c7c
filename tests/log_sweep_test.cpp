// Experiments over recorded logs (`logs:`) and `replay --seed`: runs are configurations x logs x
// seeds, the seeds vary the particle filters and not the deterministic ones, the results name the
// log, and a bad or changed log is refused where the experiment names it.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "sim/common/errors.hpp"
#include "sim/common/random.hpp"
#include "sim/experiments/experiment.hpp"
#include "sim/experiments/sweep.hpp"
#include "sim/producers/import_log.hpp"
#include "tests/test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

/// A generated dataset written as a log: `robots` robots driving circles among four landmarks
/// for 30 s, odometry as commanded velocities at 10 Hz (the true motion deviates from them by
/// noise drawn from `noise`), exact ground truth, and every landmark within 6 m seen at 10 Hz with
/// noisy range and bearing.
fs::path write_circle_log(const fs::path& file, const std::string& noise, int robots = 1) {
  ImportedDataset d;
  d.name = "circles";
  d.source = {{"format", "test"}};
  const std::vector<Vec2> landmarks{{-3.0, -3.0}, {3.0, -3.0}, {3.0, 3.0}, {-3.0, 3.0}};
  for (std::size_t i = 0; i < landmarks.size(); ++i)
    d.landmarks.push_back({static_cast<int>(i) + 1, landmarks[i]});
  RandomStream rng = make_stream(1, "test/" + noise);
  constexpr double kDt = 0.1, kSpeedMps = 0.3, kTurnRadps = 0.2;
  for (int r = 0; r < robots; ++r) {
    ImportedRobot robot;
    robot.name = "robot" + std::to_string(r + 1);
    Pose2 truth{1.5 * r, -1.5, 0.0};
    for (int k = 0; k <= 300; ++k) {
      const double t_s = kDt * k;
      ImportedRobot::Odometry o;
      o.t_s = t_s;
      o.reading.fields = kOdometryVelocity;
      o.reading.v_mps = kSpeedMps;
      o.reading.omega_radps = kTurnRadps;
      robot.odometry.push_back(o);
      robot.truth.push_back({t_s, truth});
      ImportedRobot::Detections seen;
      seen.t_s = t_s;
      for (std::size_t i = 0; i < landmarks.size(); ++i) {
        const double dx = landmarks[i].x() - truth.x, dy = landmarks[i].y() - truth.y;
        const double range_m = std::hypot(dx, dy);
        if (range_m > 6.0) continue;
        Detection detection;
        detection.id = static_cast<int>(i) + 1;
        detection.truth_id = detection.id;
        detection.range_m = range_m + rng.normal(0.0, 0.05);
        detection.bearing_rad =
            wrap_angle(std::atan2(dy, dx) - truth.theta + rng.normal(0.0, 0.02));
        seen.detections.push_back(detection);
      }
      robot.detections.push_back(seen);
      const double v = kSpeedMps * (1.0 + rng.normal(0.0, 0.05)),
                   omega = kTurnRadps + rng.normal(0.0, 0.02);
      truth = {truth.x + v * kDt * std::cos(truth.theta), truth.y + v * kDt * std::sin(truth.theta),
               wrap_angle(truth.theta + omega * kDt)};
    }
    d.robots.push_back(std::move(robot));
  }
  write_import(std::move(d), {}, file);
  return file;
}

/// An experiment in `dir` over `logs` (YAML list items, relative to it) with `seeds` (a YAML value,
/// or none), a particle filter and the EKF; `extra` lines are added at its top level.
fs::path write_log_experiment(const fs::path& dir, const std::string& logs,
                              const std::string& seeds = "", const std::string& extra = "") {
  const fs::path file = dir / "experiment.yaml";
  std::ofstream(file) << "name: over_logs\n"
                      << extra << "logs: " << logs << "\n"
                      << (seeds.empty() ? "" : "seeds: " + seeds + "\n") << "timeout_s: 120\n"
                      << "localizers:\n  - plugin: mcl\n    params: {particles: 300}\n"
                      << "  - plugin: ekf_landmarks\n";
  return file;
}

/// results.csv as rows keyed by column name.
std::vector<std::map<std::string, std::string>> read_csv(const fs::path& file) {
  std::istringstream text(testing::read_file(file));
  std::string line;
  std::getline(text, line);
  std::vector<std::string> columns;
  std::istringstream header(line);
  for (std::string column; std::getline(header, column, ',');) columns.push_back(column);
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(text, line)) {
    std::istringstream fields(line);
    std::map<std::string, std::string> row;
    std::string field;
    for (const std::string& column : columns) {
      std::getline(fields, field, ',');  // the tests' reasons are empty: no quoted commas
      row[column] = field;
    }
    rows.push_back(row);
  }
  return rows;
}

std::string experiment_error(const fs::path& experiment) {
  try {
    load_experiment(experiment);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(ReplaySeed, VariesTheParticleFilterNotTheDeterministicFiltersAndRunJsonSaysWhich) {
  const fs::path dir = testing::temp_dir("replay_seed");
  const fs::path log = write_circle_log(dir / "circle.locsimlog", "a");
  const std::string replay = "replay " + log.string() +
                             " -q --no-readings --localizer mcl:particles=300 --localizer "
                             "ekf_landmarks --localizer odometry --out ";
  for (const auto& [folder, seed] : std::vector<std::pair<std::string, std::string>>{
           {"default", ""}, {"own", " --seed 0"}, {"other", " --seed 7"}}) {
    const testing::Outcome outcome = testing::locsim(replay + (dir / folder).string() + seed);
    ASSERT_EQ(outcome.exit_code, 0) << outcome.output;
  }
  const auto file = [&](const std::string& folder, const std::string& name) {
    return testing::read_file(dir / folder / name);
  };
  // The log's own seed (an import's is 0) by default: a replay of a run repeats it exactly.
  EXPECT_EQ(json::parse(file("default", "run.json"))["seed"], 0);
  EXPECT_EQ(json::parse(file("other", "run.json"))["seed"], 7);
  EXPECT_EQ(json::parse(file("other", "run.json"))["recorded_seed"], 0);
  EXPECT_EQ(file("default", "mcl.tum"), file("own", "mcl.tum"));
  EXPECT_NE(file("default", "mcl.tum"), file("other", "mcl.tum"));
  // An import's initial guess is exact (sigma 0): nothing random is left in these two.
  for (const char* deterministic : {"ekf_landmarks.tum", "odometry.tum"}) {
    ASSERT_FALSE(file("default", deterministic).empty()) << deterministic;
    EXPECT_EQ(file("default", deterministic), file("other", deterministic)) << deterministic;
  }
  const testing::Outcome bad = testing::locsim(replay + (dir / "bad").string() + " --seed -1");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  testing::expect_contains(bad.output, "--seed");
}

TEST(LogExperiment, TwoLogsTimesTwoSeedsNameTheirLogAndOnlyTheParticleFilterVaries) {
  const fs::path dir = testing::temp_dir("two_logs");
  fs::create_directories(dir / "data");
  write_circle_log(dir / "data" / "first.locsimlog", "first");
  write_circle_log(dir / "data" / "second.locsimlog", "second");
  const fs::path experiment =
      write_log_experiment(dir, "[data/first.locsimlog, data/second.locsimlog]", "[1, 2]");

  const ExperimentDef e = load_experiment(experiment);
  std::vector<std::string> ids;
  for (const RunUnit& run : expand_runs(e)) ids.push_back(run.id);
  EXPECT_EQ(ids,
            (std::vector<std::string>{"mcl/first/seed-1", "mcl/first/seed-2", "mcl/second/seed-1",
                                      "mcl/second/seed-2", "ekf_landmarks/first/seed-1",
                                      "ekf_landmarks/first/seed-2", "ekf_landmarks/second/seed-1",
                                      "ekf_landmarks/second/seed-2"}));
  // The logs are inputs of the fingerprint, like a world.
  EXPECT_EQ(e.files.back(), dir / "data" / "second.locsimlog");

  SweepOptions options;
  options.experiment_file = experiment;
  options.out_dir = dir / "out";
  options.jobs = 2;
  options.locsim_binary = LOCSIM_BINARY;
  const SweepSummary summary = run_sweep(options);
  EXPECT_EQ(summary.ran, 8u);
  EXPECT_EQ(summary.not_ok, 0u);

  std::map<std::string, std::map<std::string, std::string>> by_id;
  for (const auto& row : read_csv(dir / "out" / "results.csv")) by_id[row.at("id")] = row;
  ASSERT_EQ(by_id.size(), 8u);
  for (const auto& [id, row] : by_id) {
    EXPECT_EQ(row.at("status"), "ok") << id;
    EXPECT_EQ(row.at("log"), id.find("/first/") != std::string::npos ? "first" : "second") << id;
    EXPECT_EQ(id.substr(id.size() - 1), row.at("seed")) << id;
    // The EKF follows the circle on these logs: the run scored a real trajectory.
    if (id.starts_with("ekf")) {
      EXPECT_LT(std::stod(row.at("position_rms_m")), 0.3) << id;
    }
  }
  const auto rms = [&](const std::string& id) { return by_id.at(id).at("position_rms_m"); };
  const auto trajectory = [&](const std::string& id, const std::string& label) {
    return testing::read_file(dir / "out" / "runs" / id / (label + ".tum"));
  };
  for (const std::string log : {"first", "second"}) {
    EXPECT_NE(rms("mcl/" + log + "/seed-1"), rms("mcl/" + log + "/seed-2")) << log;
    EXPECT_NE(trajectory("mcl/" + log + "/seed-1", "mcl"),
              trajectory("mcl/" + log + "/seed-2", "mcl"));
    EXPECT_EQ(trajectory("ekf_landmarks/" + log + "/seed-1", "ekf_landmarks"),
              trajectory("ekf_landmarks/" + log + "/seed-2", "ekf_landmarks"))
        << log;
  }
  EXPECT_NE(rms("ekf_landmarks/first/seed-1"), rms("ekf_landmarks/second/seed-1"));

  // The report pools the logs per configuration and shows each log's own rows.
  const testing::Outcome report = testing::locsim("report " + (dir / "out").string());
  ASSERT_EQ(report.exit_code, 0) << report.output;
  const std::string md = testing::read_file(dir / "out" / "report.md");
  testing::expect_contains(md, "## Per log");
  testing::expect_contains(md, "| mcl | first | 2 | 2 |");
  testing::expect_contains(md, "| ekf_landmarks | second | 2 | 2 |");

  // A log that changed since (here: imported again from other data) is not joined.
  write_circle_log(dir / "data" / "second.locsimlog", "changed");
  options.resume = true;
  try {
    run_sweep(options);
    FAIL() << "a resume over a changed log ran";
  } catch (const InputError& error) {
    testing::expect_contains(error.what(), "file data/second.locsimlog changed");
  }
}

TEST(LogExperiment, SeedsDefaultToEachLogsOwn) {
  const fs::path dir = testing::temp_dir("own_seeds");
  write_circle_log(dir / "a.locsimlog", "a");
  write_circle_log(dir / "b.locsimlog", "b");
  std::vector<std::string> ids;
  for (const RunUnit& run :
       expand_runs(load_experiment(write_log_experiment(dir, "[a.locsimlog, b.locsimlog]"))))
    ids.push_back(run.id);
  EXPECT_EQ(ids, (std::vector<std::string>{"mcl/a/seed-0", "mcl/b/seed-0", "ekf_landmarks/a/seed-0",
                                           "ekf_landmarks/b/seed-0"}));
}

TEST(LogExperiment, EachNamedRobotOfALogIsRunAsALogOfItsOwn) {
  const fs::path dir = testing::temp_dir("robots");
  write_circle_log(dir / "pair.locsimlog", "pair", 2);
  const ExperimentDef experiment = load_experiment(
      write_log_experiment(dir, "[{file: pair.locsimlog, robots: [robot2, robot1]}]", "[4]"));
  std::vector<std::string> ids;
  for (const RunUnit& run : expand_runs(experiment)) ids.push_back(run.id);
  EXPECT_EQ(ids, (std::vector<std::string>{"mcl/pair-robot2/seed-4", "mcl/pair-robot1/seed-4",
                                           "ekf_landmarks/pair-robot2/seed-4",
                                           "ekf_landmarks/pair-robot1/seed-4"}));
  const testing::Outcome sweep = testing::locsim("sweep " + (dir / "experiment.yaml").string() +
                                                 " --out " + (dir / "out").string() + " --jobs 2");
  ASSERT_EQ(sweep.exit_code, 0) << sweep.output;
  const auto rows = read_csv(dir / "out" / "results.csv");
  ASSERT_EQ(rows.size(), 4u);
  for (const auto& row : rows) EXPECT_EQ(row.at("status"), "ok") << row.at("id");

  // A replay of one robot scores what that robot scores in a replay of the whole log (the EKF is
  // deterministic): the same records, renumbered.
  const auto whole = testing::locsim("replay " + (dir / "pair.locsimlog").string() + " --out " +
                                     (dir / "whole").string() + " --localizer ekf_landmarks -q");
  ASSERT_EQ(whole.exit_code, 0) << whole.output;
  const auto one =
      testing::locsim("replay " + (dir / "pair.locsimlog").string() + " --out " +
                      (dir / "one").string() + " --localizer ekf_landmarks --robots robot2 -q");
  ASSERT_EQ(one.exit_code, 0) << one.output;
  const json in_whole = json::parse(testing::read_file(dir / "whole" / "robot2" / "metrics.json"));
  const json alone = json::parse(testing::read_file(dir / "one" / "metrics.json"));
  EXPECT_EQ(alone["localizers"][0]["position_error_m"]["rms"],
            in_whole["localizers"][0]["position_error_m"]["rms"]);
  EXPECT_EQ(json::parse(testing::read_file(dir / "one" / "run.json"))["replayed_robots"],
            json::array({"robot2"}));
  const auto nobody = testing::locsim("replay " + (dir / "pair.locsimlog").string() + " --out " +
                                      (dir / "none").string() + " --robots nobody -q");
  EXPECT_EQ(nobody.exit_code, 2);
  testing::expect_contains(nobody.output, "no robot named 'nobody' in the log (its robots: ");
  EXPECT_FALSE(fs::exists(dir / "none"));
}

TEST(LogExperiment, BadLogsAreReportedWhereTheExperimentNamesThem) {
  const fs::path dir = testing::temp_dir("bad_logs");
  write_circle_log(dir / "a.locsimlog", "a");
  fs::create_directories(dir / "other");
  write_circle_log(dir / "other" / "a.locsimlog", "b");
  write_circle_log(dir / "pair.locsimlog", "pair", 2);
  std::ofstream(dir / "cut.locsimlog") << testing::read_file(dir / "a.locsimlog").substr(0, 400);

  // experiment.yaml's first line is `name:`; `extra` comes on line 2, `logs:` after it.
  EXPECT_EQ(experiment_error(write_log_experiment(
                dir, "[a.locsimlog]", "",
                "world: " + std::string(LOCSIM_SOURCE_DIR) + "/worlds/demo/demo.yaml\n")),
            (dir / "experiment.yaml").string() +
                ":2:8: 'world': give either logs (each log holds its world, scenario and "
                "duration) or world (or worlds), scenario, duration_s and variation, not both");
  testing::expect_contains(
      experiment_error(write_log_experiment(dir, "[a.locsimlog]", "[1]", "duration_s: 10\n")),
      "experiment.yaml:2:13: 'duration_s': give either logs");
  testing::expect_contains(
      experiment_error(write_log_experiment(dir, "[a.locsimlog, missing.locsimlog]")),
      "experiment.yaml:2:21: 'logs[1]': no such file '" + (dir / "missing.locsimlog").string() +
          "'");
  testing::expect_contains(
      experiment_error(write_log_experiment(dir, "[a.locsimlog, other/a.locsimlog]")),
      "experiment.yaml:2:21: 'logs[1]': the file name 'a' is also that of");
  testing::expect_contains(experiment_error(write_log_experiment(dir, "[cut.locsimlog]")),
                           "experiment.yaml:2:8: 'logs[0]': " + (dir / "cut.locsimlog").string());
  testing::expect_contains(experiment_error(write_log_experiment(dir, "[pair.locsimlog]")),
                           "experiment.yaml:2:8: 'logs[0]': the log has 2 robots");
  testing::expect_contains(
      experiment_error(
          write_log_experiment(dir, "[{file: pair.locsimlog, robots: [robot1, nobody]}]")),
      "'logs[0].robots[1]': no robot named 'nobody' in the log (its robots: robot1, robot2)");
  testing::expect_contains(
      experiment_error(write_log_experiment(dir, "[{file: pair.locsimlog, robot: [robot1]}]")),
      "'logs[0].robot'");
  testing::expect_contains(experiment_error(write_log_experiment(dir, "[]")),
                           "'logs': give at least one log");

  // The command line exits with 2 and creates no folder.
  const testing::Outcome sweep =
      testing::locsim("sweep " + write_log_experiment(dir, "[missing.locsimlog]").string() +
                      " --out " + (dir / "out").string());
  EXPECT_EQ(sweep.exit_code, 2) << sweep.output;
  testing::expect_contains(sweep.output, "'logs[0]': no such file");
  EXPECT_FALSE(fs::exists(dir / "out"));
}

}  // namespace
}  // namespace locsim
