// Sweeps: identical results whatever the jobs, shards or interruptions; crashes and hangs fail
// their run only; bad experiment files are reported where they are wrong.
#include "sim/experiments/sweep.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <sstream>
#include <thread>

#include "sim/experiments/experiment.hpp"
#include "sim/experiments/statistics.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;

/// An experiment of `seeds` seeds x two localizers on the demo world, 4 s per run.
fs::path write_experiment(const fs::path& dir, int seeds, const std::string& extra_localizers = "",
                          double timeout_s = 60) {
  const fs::path file = dir / "experiment.yaml";
  std::ofstream(file) << "name: test\nworld: " << LOCSIM_SOURCE_DIR << "/worlds/demo/demo.yaml\n"
                      << "duration_s: 4\nseeds: {from: 1, to: " << seeds
                      << "}\ntimeout_s: " << timeout_s
                      << "\nlocalizers:\n  - plugin: odometry\n  - plugin: ekf_landmarks\n"
                      << "    grid: {sigma_bearing_deg: [1, 3]}\n"
                      << extra_localizers;
  return file;
}

SweepSummary sweep(const fs::path& experiment, const fs::path& out, int jobs, bool resume = false,
                   std::optional<std::pair<int, int>> shard = std::nullopt) {
  SweepOptions options;
  options.experiment_file = experiment;
  options.out_dir = out;
  options.jobs = jobs;
  options.resume = resume;
  options.shard = shard;
  options.locsim_binary = LOCSIM_BINARY;
  return run_sweep(options);
}

TEST(Sweep, ResultsAreTheSameWhateverTheNumberOfJobs) {
  const fs::path dir = testing::temp_dir("sweep");
  const fs::path experiment = write_experiment(dir, 3);
  const SweepSummary one = sweep(experiment, dir / "one", 1);
  EXPECT_EQ(one.total, 9u);
  EXPECT_EQ(one.not_ok, 0u);
  sweep(experiment, dir / "two", 2);
  const std::string results = testing::read_file(dir / "one/results.csv");
  EXPECT_EQ(std::count(results.begin(), results.end(), '\n'), 10);
  // Every row has the header's columns (tools read it by name).
  std::istringstream rows(results);
  std::string header, row;
  std::getline(rows, header);
  EXPECT_NE(header.find(",converged_steps,"), std::string::npos);
  EXPECT_NE(header.find(",recovery_steps"), std::string::npos);
  while (std::getline(rows, row)) {
    EXPECT_EQ(std::count(row.begin(), row.end(), ','),
              std::count(header.begin(), header.end(), ','))
        << row;
  }
  EXPECT_EQ(results, testing::read_file(dir / "two/results.csv"));
  EXPECT_EQ(testing::read_file(dir / "one/summary.csv"),
            testing::read_file(dir / "two/summary.csv"));
  EXPECT_NE(results.find("ekf_landmarks-sigma_bearing_deg=3/seed-2"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir / "one/runs/odometry/seed-1/metrics.json"));

  // The report of the sweep, as a user asks for it.
  const std::string report =
      std::string(LOCSIM_BINARY) + " report " + (dir / "one").string() + " >/dev/null";
  EXPECT_EQ(std::system(report.c_str()), 0);
  const std::string markdown = testing::read_file(dir / "one/report.md");
  EXPECT_NE(markdown.find("| ekf_landmarks-sigma_bearing_deg=1 | 3 | 3 |"), std::string::npos)
      << markdown;
  for (const char* png :
       {"error_vs_time.png", "cdf.png", "param_ekf_landmarks_sigma_bearing_deg.png"}) {
    EXPECT_GT(fs::file_size(dir / "one/report" / png), 5000u) << png;
  }
  const std::string not_a_sweep =
      std::string(LOCSIM_BINARY) + " report " + dir.string() + " 2>/dev/null";
  EXPECT_EQ(WEXITSTATUS(std::system(not_a_sweep.c_str())), 2);
}

TEST(Sweep, ShardsMergedEqualTheWholeSweep) {
  const fs::path dir = testing::temp_dir("sweep");
  const fs::path experiment = write_experiment(dir, 3);
  sweep(experiment, dir / "whole", 2);
  const SweepSummary first = sweep(experiment, dir / "a", 1, false, std::pair{1, 2});
  const SweepSummary second = sweep(experiment, dir / "b", 1, false, std::pair{2, 2});
  EXPECT_EQ(first.total + second.total, 9u);
  merge_sweeps(dir / "merged", {dir / "a", dir / "b"});
  EXPECT_EQ(testing::read_file(dir / "merged/results.csv"),
            testing::read_file(dir / "whole/results.csv"));
  EXPECT_EQ(testing::read_file(dir / "merged/summary.csv"),
            testing::read_file(dir / "whole/summary.csv"));
  // Another experiment's folder cannot be merged in.
  const fs::path other_dir = dir / "other_experiment";
  fs::create_directories(other_dir);
  sweep(write_experiment(other_dir, 1), other_dir / "out", 1);
  EXPECT_THROW(merge_sweeps(dir / "bad", {dir / "a", other_dir / "out"}), InputError);
}

TEST(Sweep, KilledWithSigkillAndResumedEqualsUninterrupted) {
  const fs::path dir = testing::temp_dir("sweep");
  const fs::path experiment = write_experiment(dir, 6);
  sweep(experiment, dir / "whole", 2);
  // Start the sweep as a user would, kill it hard once some results are in.
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    execl(LOCSIM_BINARY, LOCSIM_BINARY, "sweep", experiment.c_str(), "--jobs", "1", "--out",
          (dir / "killed").c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline) {
    const std::string lines = testing::read_file(dir / "killed/results.jsonl");
    if (std::count(lines.begin(), lines.end(), '\n') >= 3) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
  const std::string partial = testing::read_file(dir / "killed/results.jsonl");
  const auto finished = std::count(partial.begin(), partial.end(), '\n');
  EXPECT_GE(finished, 3);
  EXPECT_LT(finished, 18) << "the sweep finished before it could be killed";
  EXPECT_THROW(sweep(experiment, dir / "killed", 2), InputError);  // not without --resume
  const SweepSummary resumed = sweep(experiment, dir / "killed", 2, true);
  EXPECT_EQ(resumed.skipped, static_cast<std::size_t>(finished));
  EXPECT_EQ(testing::read_file(dir / "killed/results.csv"),
            testing::read_file(dir / "whole/results.csv"));
}

TEST(Sweep, ASegfaultOrAHangFailsItsRunOnly) {
  const fs::path dir = testing::temp_dir("sweep");
  const std::string extra = std::string("  - plugin: ") + LOCSIM_TEST_PLUGIN_DIR +
                            "/locsim_test_segfault.so\n" + "  - plugin: " + LOCSIM_TEST_PLUGIN_DIR +
                            "/locsim_test_hang.so\n";
  const fs::path experiment = write_experiment(dir, 1, extra, 3.0);
  const SweepSummary summary = sweep(experiment, dir / "out", 2);
  EXPECT_EQ(summary.total, 5u);
  EXPECT_EQ(summary.not_ok, 2u);
  const std::string results = testing::read_file(dir / "out/results.csv");
  EXPECT_NE(results.find("locsim_test_segfault/seed-1,locsim_test_segfault,1,crashed,signal 11 "
                         "(Segmentation fault)"),
            std::string::npos)
      << results;
  EXPECT_NE(results.find("locsim_test_hang/seed-1,locsim_test_hang,1,timeout,"), std::string::npos)
      << results;
  EXPECT_NE(results.find("odometry/seed-1,odometry,1,ok,"), std::string::npos);
}

TEST(Experiment, MalformedFilesAreReportedWhereTheyAreWrong) {
  const fs::path dir = testing::temp_dir("experiment");
  const auto error = [&](const std::string& text) {
    std::ofstream(dir / "bad.yaml") << text;
    try {
      load_experiment(dir / "bad.yaml");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  const std::string world = std::string("world: ") + LOCSIM_SOURCE_DIR + "/worlds/demo/demo.yaml\n";
  EXPECT_NE(error(world + "seeds: [1]\nlocalizers: []\n")
                .find("'localizers': give at least one localizer"),
            std::string::npos);
  EXPECT_NE(error(world + "seeds: {from: 5, to: 2}\nlocalizers: [{plugin: odometry}]\n")
                .find("bad.yaml:2:22: 'seeds.to': must be >= from"),
            std::string::npos);
  EXPECT_NE(error(world + "seeds: [1, 1]\nlocalizers: [{plugin: odometry}]\n")
                .find("a seed is listed twice"),
            std::string::npos);
  EXPECT_NE(error(world + "seed: [1]\nlocalizers: [{plugin: odometry}]\n")
                .find("'seed': unknown key; did you mean 'seeds'?"),
            std::string::npos);
  EXPECT_NE(error("world: nowhere.yaml\nseeds: [1]\nlocalizers: [{plugin: odometry}]\n")
                .find("nowhere.yaml: no such file"),
            std::string::npos);
  EXPECT_NE(error(world + "seeds: [1]\nlocalizers: [{plugin: odometry}, {plugin: odometry}]\n")
                .find("label 'odometry' used twice"),
            std::string::npos);
}

TEST(Experiment, GridsExpandToEveryCombinationInOrder) {
  const fs::path dir = testing::temp_dir("experiment");
  std::ofstream(dir / "grid.yaml")
      << "world: " << LOCSIM_SOURCE_DIR << "/worlds/demo/demo.yaml\nseeds: [3, 1]\n"
      << "localizers:\n  - plugin: ekf_landmarks\n    label: ekf\n    params: {use_omni: false}\n"
      << "    grid: {sigma_range_m: [0.1, 0.2], gate_chi2: [5, 9]}\n";
  const ExperimentDef e = load_experiment(dir / "grid.yaml");
  ASSERT_EQ(e.localizers.size(), 4u);
  EXPECT_EQ(e.localizers[1].label, "ekf-sigma_range_m=0.1-gate_chi2=9");
  EXPECT_EQ(e.localizers[1].spec(),
            "ekf_landmarks:use_omni=false,sigma_range_m=0.1,gate_chi2=9@ekf-sigma_range_m=0.1-gate_"
            "chi2=9");
  const auto runs = expand_runs(e);
  ASSERT_EQ(runs.size(), 8u);
  EXPECT_EQ(runs[1].id, "ekf-sigma_range_m=0.1-gate_chi2=5/seed-1");
}

TEST(Statistics, MeanConfidenceIntervalAndMedian) {
  const Aggregate a = aggregate({1, 2, 3, 4, 10});
  EXPECT_DOUBLE_EQ(a.mean, 4.0);
  EXPECT_DOUBLE_EQ(a.median, 3.0);
  // s = sqrt(((9 + 4 + 1 + 0 + 36) / 4)) = sqrt(12.5); t(0.975, 4) = 2.776.
  EXPECT_NEAR(a.ci95, 2.776 * std::sqrt(12.5) / std::sqrt(5.0), 1e-9);
  EXPECT_NEAR(student_t_975(40), 2.021, 1e-3);
  EXPECT_NEAR(student_t_975(120), 1.980, 1e-3);
  EXPECT_EQ(aggregate({}).n, 0u);
  EXPECT_DOUBLE_EQ(aggregate({2, 4}).median, 3.0);
}

}  // namespace
}  // namespace locsim
