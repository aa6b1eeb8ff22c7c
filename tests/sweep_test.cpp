// Sweeps: identical results whatever the jobs, shards or interruptions; crashes and hangs fail
// their run only; bad experiment files are reported where they are wrong.
#include "sim/experiments/sweep.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>
#include <tuple>

#include "sim/experiments/experiment.hpp"
#include "sim/experiments/statistics.hpp"
#include "sim/experiments/suite_tables.hpp"
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
                   std::optional<std::pair<int, int>> shard = std::nullopt,
                   const fs::path& binary = LOCSIM_BINARY, bool retry_failed = false) {
  SweepOptions options;
  options.experiment_file = experiment;
  options.out_dir = out;
  options.jobs = jobs;
  options.resume = resume;
  options.retry_failed = retry_failed;
  options.shard = shard;
  options.locsim_binary = binary;
  return run_sweep(options);
}

/// A short experiment on the demo world: `localizers` (the YAML list's items), `seeds`, 1.5 s per
/// run (the misbehaving test plugins act at one second).
fs::path write_short_experiment(const fs::path& dir, const std::string& localizers,
                                const std::string& seeds = "[1]") {
  const fs::path file = dir / "experiment.yaml";
  std::ofstream(file) << "name: short\nworld: " << LOCSIM_SOURCE_DIR
                      << "/worlds/demo/demo.yaml\nduration_s: 1.5\nseeds: " << seeds
                      << "\ntimeout_s: 60\nlocalizers:\n"
                      << localizers;
  return file;
}

using testing::test_plugin;
using testing::write_stand_in;

TEST(Sweep, VariationNoneRunsEverySeedOnTheDeclaredWorld) {
  // Seeds vary the world by default (each its own ground truth); `variation: none` in the
  // experiment runs every seed on the world as declared (the same ground truth), and a log
  // experiment refuses the key (a log holds its world).
  const fs::path dir = testing::temp_dir("sweep-variation");
  for (const bool none : {false, true}) {
    const fs::path sub = dir / (none ? "none" : "varied");
    fs::create_directories(sub);
    std::ofstream(sub / "experiment.yaml")
        << "name: v\nworld: " << LOCSIM_SOURCE_DIR << "/worlds/demo/demo.yaml\nduration_s: 1.5\n"
        << (none ? "variation: none\n" : "")
        << "seeds: {from: 1, to: 2}\nlocalizers:\n  - plugin: odometry\n";
    const SweepSummary s = sweep(sub / "experiment.yaml", sub / "out", 2);
    ASSERT_EQ(s.not_ok, 0u);
    const std::string one = testing::read_file(sub / "out/logs/seed-1/groundtruth.tum");
    const std::string two = testing::read_file(sub / "out/logs/seed-2/groundtruth.tum");
    if (none) {
      EXPECT_EQ(one, two);
    } else {
      EXPECT_NE(one, two);
    }
  }
  std::ofstream(dir / "logs.yaml") << "name: l\nlogs: [x.locsimlog]\nvariation: none\n"
                                   << "localizers:\n  - plugin: odometry\n";
  try {
    load_experiment(dir / "logs.yaml");
    FAIL() << "variation with logs was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("variation"), std::string::npos) << e.what();
  }
}

struct TimedOutcome {
  int exit_code = -1;
  std::string output;  // stdout, then stderr
  double seconds = 0.0;
};

/// `locsim ARGUMENTS` as a user runs it.
TimedOutcome locsim(const std::string& arguments, const fs::path& dir) {
  const fs::path out = dir / "stdout.txt", err = dir / "stderr.txt";
  const auto start = std::chrono::steady_clock::now();
  const int status = std::system((std::string(LOCSIM_BINARY) + " " + arguments + " >" +
                                  out.string() + " 2>" + err.string() + " </dev/null")
                                     .c_str());
  TimedOutcome outcome;
  outcome.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  outcome.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  outcome.output = testing::read_file(out) + testing::read_file(err);
  return outcome;
}

/// The message `locsim run` gives for `--localizer SPEC` (after "locsim: ...error: ").
std::string run_message(const std::string& spec, const fs::path& dir) {
  const TimedOutcome run = locsim("run " + std::string(LOCSIM_SOURCE_DIR) +
                                      "/worlds/demo/demo.yaml --duration 0.1 --out " +
                                      (dir / "run").string() + " --localizer '" + spec + "'",
                                  dir);
  EXPECT_NE(run.exit_code, 0) << run.output;
  const std::size_t colon = run.output.find("error: ");
  return colon == std::string::npos ? run.output : run.output.substr(colon + 7);
}

std::vector<nlohmann::json> jsonl(const fs::path& file) {
  std::vector<nlohmann::json> lines;
  std::istringstream text(testing::read_file(file));
  for (std::string line; std::getline(text, line);) lines.push_back(nlohmann::json::parse(line));
  return lines;
}

nlohmann::json result_of_run(const fs::path& out, const std::string& id) {
  for (const nlohmann::json& r : jsonl(out / "results.jsonl")) {
    if (r["id"] == id) return r;
  }
  return nullptr;
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
  // With every run's folder, as the whole sweep's (what `locsim report` draws from): its
  // metrics.json, and its trajectories byte for byte (metrics.json also holds timings).
  std::size_t runs = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir / "whole/runs")) {
    const fs::path relative = fs::relative(entry.path(), dir / "whole");
    if (entry.path().filename() == "metrics.json") {
      ++runs;
      EXPECT_TRUE(fs::exists(dir / "merged" / relative)) << relative;
    } else if (entry.path().extension() == ".tum") {
      EXPECT_EQ(testing::read_file(dir / "merged" / relative), testing::read_file(entry.path()))
          << relative;
    }
  }
  EXPECT_EQ(runs, 9u);
  // Another experiment's folder cannot be merged in.
  const fs::path other_dir = dir / "other_experiment";
  fs::create_directories(other_dir);
  sweep(write_experiment(other_dir, 1), other_dir / "out", 1);
  EXPECT_THROW(merge_sweeps(dir / "bad", {dir / "a", other_dir / "out"}), InputError);
}

/// The office world (a ROS map: YAML and PGM) copied to `dir`, and an experiment on it with a
/// scenario file and a plugin copied there too, 0.3 s per run: every kind of input a fingerprint
/// covers, each a file the test can change.
fs::path write_map_experiment(const fs::path& dir) {
  for (const char* file : {"office_world.yaml", "office.yaml", "office.pgm"}) {
    fs::copy_file(fs::path(LOCSIM_SOURCE_DIR) / "worlds/maps" / file, dir / file);
  }
  fs::copy_file(test_plugin("probe"), dir / "locsim_probe_copy.so");
  std::ofstream(dir / "scenario.yaml") << "name: still\nduration_s: 0.3\n";
  const fs::path file = dir / "experiment.yaml";
  std::ofstream(file) << "name: map\nworld: office_world.yaml\nscenario: scenario.yaml\n"
                         "seeds: [1, 2]\nlocalizers:\n  - plugin: "
                      << (dir / "locsim_probe_copy.so").string() << "\n    label: probe\n";
  return file;
}

/// The message of a refused resume of `out`, after which nothing in `out` may have changed.
std::string refused_resume(const fs::path& experiment, const fs::path& out) {
  const std::string before =
      testing::read_file(out / "results.jsonl") + testing::read_file(out / "sweep.json");
  std::string message = "accepted";
  try {
    sweep(experiment, out, 1, true);
  } catch (const InputError& e) {
    message = e.what();
  }
  EXPECT_EQ(testing::read_file(out / "results.jsonl") + testing::read_file(out / "sweep.json"),
            before);
  return message;
}

TEST(Fingerprint, ResumeRefusesAChangedWorldMapScenarioOrPluginAndSaysWhich) {
  const fs::path dir = testing::temp_dir("fingerprint");
  const fs::path experiment = write_map_experiment(dir);
  const fs::path out = dir / "out";
  ASSERT_EQ(sweep(experiment, out, 1).total, 2u);
  EXPECT_EQ(refused_resume(experiment, out), "accepted");  // nothing changed: nothing to run
  // Each file changed in a way that still loads: a comment, a pixel 0 -> 1 (still occupied).
  const auto change = [&](const char* file) {
    const std::string original = testing::read_file(dir / file);
    std::string changed = original;
    if (fs::path(file).extension() == ".pgm") {
      changed.back() = static_cast<char>(changed.back() == 0 ? 1 : changed.back() - 1);
    } else {
      changed += "# a comment\n";
    }
    std::ofstream(dir / file, std::ios::binary | std::ios::trunc) << changed;
    const std::string message = refused_resume(experiment, out);
    EXPECT_NE(message.find(std::string("file ") + file + " changed"), std::string::npos) << message;
    EXPECT_NE(message.find("holds a sweep of other inputs"), std::string::npos) << message;
    std::ofstream(dir / file, std::ios::binary | std::ios::trunc) << original;
  };
  for (const char* file :
       {"office_world.yaml", "office.yaml", "office.pgm", "scenario.yaml", "experiment.yaml"}) {
    change(file);
  }
  std::ofstream(dir / "locsim_probe_copy.so", std::ios::binary | std::ios::app) << '\0';
  const std::string plugin = refused_resume(experiment, out);
  EXPECT_NE(plugin.find("plugin " + (dir / "locsim_probe_copy.so").string() + " changed"),
            std::string::npos)
      << plugin;
}

TEST(Fingerprint, MergeRefusesShardsOfOtherInputsAndWritesNothing) {
  const fs::path dir = testing::temp_dir("fingerprint");
  const fs::path experiment = write_map_experiment(dir);
  sweep(experiment, dir / "a", 1, false, std::pair{1, 2});
  std::string pgm = testing::read_file(dir / "office.pgm");
  pgm.back() = static_cast<char>(pgm.back() == 0 ? 1 : pgm.back() - 1);
  std::ofstream(dir / "office.pgm", std::ios::binary | std::ios::trunc) << pgm;
  sweep(experiment, dir / "b", 1, false, std::pair{2, 2});
  try {
    merge_sweeps(dir / "merged", {dir / "a", dir / "b"});
    ADD_FAILURE() << "merged";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("file office.pgm changed"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "merged"));
}

TEST(Fingerprint, AFolderOfAnOlderLocsimIsRefusedWithTheReason) {
  const fs::path dir = testing::temp_dir("fingerprint");
  const fs::path experiment = write_map_experiment(dir);
  const fs::path out = dir / "out";
  sweep(experiment, out, 1);
  // Before: the fingerprint was a hash of the experiment file alone.
  nlohmann::ordered_json header =
      nlohmann::ordered_json::parse(testing::read_file(out / "sweep.json"));
  header["fingerprint"] = "0123456789abcdef";
  std::ofstream(out / "sweep.json") << header.dump(2) << '\n';
  EXPECT_NE(refused_resume(experiment, out).find("made by an older locsim"), std::string::npos);
  EXPECT_THROW(merge_sweeps(dir / "merged", {out}), InputError);
  EXPECT_FALSE(fs::exists(dir / "merged"));
}

TEST(Sweep, ARunsLogHoldsWhatItsPluginPrintedLabelled) {
  const fs::path dir = testing::temp_dir("sweep");
  const fs::path experiment =
      write_short_experiment(dir, "  - plugin: " + test_plugin("chatty") + "\n    label: chatty\n");
  sweep(experiment, dir / "out", 1);
  const std::string log = testing::read_file(dir / "out/runs/chatty/seed-1/log.txt");
  EXPECT_NE(log.find("[chatty] reading 1 at t = "), std::string::npos) << log.substr(0, 1000);
  EXPECT_NE(log.find("bytes of output dropped here"), std::string::npos);
  EXPECT_LT(log.size(), 2u << 20);
}

TEST(Sweep, ARunsLogIsCappedWhateverItsProcessPrints) {
  const fs::path dir = testing::temp_dir("sweep");
  const fs::path experiment = write_short_experiment(dir, "  - plugin: odometry\n");
  // 8 MB on stdout before the run itself (as a plugin printing in --isolation none would).
  const fs::path stand_in =
      write_stand_in(dir, std::string("  *replay*) yes 'noise noise noise' | head -c 8000000; ") +
                              LOCSIM_BINARY + " \"$@\"; exit $? ;;\n");
  const SweepSummary summary = sweep(experiment, dir / "out", 1, false, std::nullopt, stand_in);
  EXPECT_EQ(summary.not_ok, 0u);
  const fs::path log = dir / "out/runs/odometry/seed-1/log.txt";
  EXPECT_LT(fs::file_size(log), (2u << 20) + (256u << 10) + 200u);
  EXPECT_GT(fs::file_size(log), 2u << 20);
  EXPECT_NE(testing::read_file(log).find("bytes of output dropped here"), std::string::npos);
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
  // The replay runs each localizer in its own process: the segfault fails the localizer, with
  // the call, the simulated time and the signal, and its errors up to then are scored.
  // (The empty column after the configuration is `log`: this sweep is over seeds, not logs.)
  EXPECT_NE(results.find("locsim_test_segfault/seed-1,locsim_test_segfault,,1,failed,update at "
                         "t = 1.000 s: its process was killed by signal 11 (Segmentation fault)"),
            std::string::npos)
      << results;
  EXPECT_NE(results.find("locsim_test_hang/seed-1,locsim_test_hang,,1,timeout,"), std::string::npos)
      << results;
  EXPECT_NE(results.find("odometry/seed-1,odometry,,1,ok,"), std::string::npos);
}

TEST(Sweep, NothingARunsPluginsStartOutlivesTheSweep) {
  // A daemon (double fork, setsid, SIGTERM ignored) in a run that ends as it should, and a child
  // ignoring SIGTERM in a run the sweep kills at its timeout (its plugin hangs): the sweep
  // reaps what each run leaves, however it ended.
  const fs::path dir = testing::temp_dir("sweep");
  const fs::path experiment = dir / "experiment.yaml";
  const auto escape = [&](const std::string& how) {
    return "  - plugin: " + test_plugin("escapes") + "\n    label: " + how +
           "\n    params: {how: " + how + ", pid_file: " + (dir / (how + ".pid")).string() + "}\n";
  };
  std::ofstream(experiment) << "name: escapes\nworld: " << LOCSIM_SOURCE_DIR
                            << "/worlds/demo/demo.yaml\nduration_s: 2\nseeds: [1]\ntimeout_s: 10"
                            << "\nlocalizers:\n"
                            << escape("daemon") << escape("hang_with_child");
  const SweepSummary summary = sweep(experiment, dir / "out", 2);
  EXPECT_EQ(summary.total, 2u);
  const std::string results = testing::read_file(dir / "out/results.csv");
  EXPECT_NE(results.find("daemon/seed-1,daemon,,1,ok,"), std::string::npos) << results;
  EXPECT_NE(results.find("hang_with_child/seed-1,hang_with_child,,1,timeout,"), std::string::npos)
      << results;
  for (const char* how : {"daemon", "hang_with_child"}) {
    std::ifstream in(dir / (std::string(how) + ".pid"));
    long pid = 0;
    in >> pid;
    ASSERT_GT(pid, 0) << how;
    // Its end may be under way as the sweep returns; far less than this on a loaded machine.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (::kill(static_cast<pid_t>(pid), 0) == 0 && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    const bool ended = ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH;
    EXPECT_TRUE(ended) << how << ": process " << pid << " outlived the sweep";
    if (!ended) ::kill(static_cast<pid_t>(pid), SIGKILL);
  }
}

TEST(Sweep, AnUnknownPluginExitsWith3AtOnceAndLeavesNoFolder) {
  const fs::path dir = testing::temp_dir("sweep");
  const fs::path experiment = write_short_experiment(
      dir, "  - plugin: odometry\n  - plugin: odometri\n", "{from: 1, to: 3}");
  const TimedOutcome outcome =
      locsim("sweep " + experiment.string() + " --out " + (dir / "out").string(), dir);
  EXPECT_EQ(outcome.exit_code, 3) << outcome.output;
  EXPECT_LT(outcome.seconds, 1.0) << "simulated before checking?";
  EXPECT_FALSE(fs::exists(dir / "out"));
  // run's own words, after where the experiment file names the plugin.
  EXPECT_NE(outcome.output.find("locsim: plugin error: " + experiment.string() +
                                ":8:13: 'localizers[1].plugin': " + run_message("odometri", dir)),
            std::string::npos)
      << outcome.output;
}

TEST(Sweep, AParameterOneGridPointRejectsExitsWith2BeforeSimulating) {
  const fs::path dir = testing::temp_dir("sweep");
  // gain is declared in [0, 1]: the second grid point is out of range.
  const fs::path experiment =
      write_short_experiment(dir, "  - plugin: odometry\n  - plugin: " + test_plugin("probe") +
                                      "\n    label: probe\n    grid: {gain: [0.5, 2]}\n");
  const TimedOutcome outcome =
      locsim("sweep " + experiment.string() + " --out " + (dir / "out").string(), dir);
  EXPECT_EQ(outcome.exit_code, 2) << outcome.output;
  EXPECT_FALSE(fs::exists(dir / "out"));
  const std::string expected = experiment.string() + ":10:24: 'localizers[1].grid.gain[1]': " +
                               run_message(test_plugin("probe") + ":gain=2@probe-gain=2", dir);
  EXPECT_NE(outcome.output.find("locsim: error: " + expected), std::string::npos) << outcome.output;

  // A parameter the plugin does not declare, in the library call too: nothing is written.
  const fs::path unknown = write_short_experiment(
      dir, "  - plugin: " + test_plugin("probe") + "\n    label: probe\n    params: {gian: 1}\n");
  try {
    sweep(unknown, dir / "out2", 1);
    ADD_FAILURE() << "accepted an unknown parameter";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(
                  ":9:20: 'localizers[0].params.gian': --localizer probe: plugin 'test_probe' has "
                  "no parameter 'gian'; did you mean 'gain'?"),
              std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "out2"));
}

TEST(Sweep, ARunInErrorKeepsItsWholeReasonAndTheReportLinksItsLog) {
  const fs::path dir = testing::temp_dir("sweep");
  const fs::path experiment = write_short_experiment(
      dir, "  - plugin: odometry\n  - plugin: " + test_plugin("noop") + "\n");
  // The odometry run prints, then fails with a message of three lines; the noop run with a
  // message longer than the reason keeps.
  const fs::path stand_in = write_stand_in(
      dir,
      "  *runs/odometry/*) echo 'odometry: starting'\n"
      "    printf 'locsim: error: the first line\\n  the second, indented\\nlocsim: error: the "
      "third\\n' >&2; exit 2 ;;\n"
      "  *runs/locsim_test_noop/*) printf 'locsim: failure: ' >&2; head -c 10000 /dev/zero | tr "
      "'\\0' x >&2; exit 1 ;;\n");
  const SweepSummary summary = sweep(experiment, dir / "out", 1, false, std::nullopt, stand_in);
  EXPECT_EQ(summary.errors, 2u);
  const nlohmann::json odometry = result_of_run(dir / "out", "odometry/seed-1");
  EXPECT_EQ(odometry["status"], "error");
  EXPECT_EQ(odometry["reason"],
            "exit code 2: locsim: error: the first line\n  the second, indented\nlocsim: error: "
            "the third");
  EXPECT_EQ(odometry["log"], "runs/odometry/seed-1/log.txt");
  const std::string long_reason = result_of_run(dir / "out", "locsim_test_noop/seed-1")["reason"];
  EXPECT_LT(long_reason.size(), 4300u);
  EXPECT_NE(long_reason.find("more bytes cut; all in log.txt]"), std::string::npos);
  const std::string csv = testing::read_file(dir / "out/results.csv");
  EXPECT_NE(csv.find(",error,\"exit code 2: locsim: error: the first line the second, indented "
                     "locsim: error: the third\","),
            std::string::npos)
      << csv;
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 3) << "a reason broke its row";

  const TimedOutcome report = locsim("report " + (dir / "out").string(), dir);
  EXPECT_EQ(report.exit_code, 0) << report.output;
  const std::string markdown = testing::read_file(dir / "out/report.md");
  EXPECT_NE(markdown.find("| odometry/seed-1 | error | exit code 2: locsim: error: the first line "
                          "the second, indented locsim: error: the third | "
                          "[log.txt](runs/odometry/seed-1/log.txt) |"),
            std::string::npos)
      << markdown;
}

TEST(Sweep, ResumeRunsErroredAndCrashedRunsAgainAndKeepsOneResultPerRun) {
  const fs::path dir = testing::temp_dir("sweep");
  const fs::path experiment = write_short_experiment(
      dir, "  - plugin: odometry\n  - plugin: " + test_plugin("probe") + "\n", "[1, 2]");
  const fs::path stand_in =
      write_stand_in(dir,
                     "  *runs/odometry/seed-1*) echo 'locsim: failure: disk full' >&2; exit 1 ;;\n"
                     "  *runs/locsim_test_probe/seed-2*) kill -SEGV $$ ;;\n");
  const SweepSummary first = sweep(experiment, dir / "out", 2, false, std::nullopt, stand_in);
  EXPECT_EQ(first.errors, 1u);
  EXPECT_EQ(first.not_ok, 2u);
  EXPECT_EQ(result_of_run(dir / "out", "locsim_test_probe/seed-2")["status"], "crashed");

  // The cause fixed (the real locsim), a resume runs those two again, and only those.
  const SweepSummary resumed = sweep(experiment, dir / "out", 2, true);
  EXPECT_EQ(resumed.skipped, 2u);
  EXPECT_EQ(resumed.retried, 2u);
  EXPECT_EQ(resumed.ran, 2u);
  EXPECT_EQ(resumed.not_ok, 0u);
  const std::vector<nlohmann::json> results = jsonl(dir / "out/results.jsonl");
  ASSERT_EQ(results.size(), 4u);
  std::set<std::string> ids;
  for (const nlohmann::json& r : results) {
    ids.insert(r["id"].get<std::string>());
    EXPECT_EQ(r["status"], "ok") << r.dump();
  }
  EXPECT_EQ(ids.size(), 4u);
  // The same tables as a sweep that never failed.
  sweep(experiment, dir / "clean", 2);
  EXPECT_EQ(testing::read_file(dir / "out/results.csv"),
            testing::read_file(dir / "clean/results.csv"));
}

TEST(Sweep, ResumeKeepsFailedRunsAndRetryFailedRunsThemAgain) {
  const fs::path dir = testing::temp_dir("sweep");
  // test_throws fails at one second: the localizer's own failure, a result.
  const fs::path experiment = write_short_experiment(
      dir, "  - plugin: odometry\n  - plugin: " + test_plugin("throws") + "\n");
  const SweepSummary first = sweep(experiment, dir / "out", 2);
  EXPECT_EQ(first.errors, 0u);
  EXPECT_EQ(result_of_run(dir / "out", "locsim_test_throws/seed-1")["status"], "failed");
  EXPECT_EQ(sweep(experiment, dir / "out", 2, true).ran, 0u);

  const std::string resume = "sweep " + experiment.string() + " --out " + (dir / "out").string();
  EXPECT_EQ(locsim(resume + " --retry-failed", dir).exit_code, 2)
      << "--retry-failed needs --resume";
  const TimedOutcome retried = locsim(resume + " --resume --retry-failed", dir);
  EXPECT_EQ(retried.exit_code, 0) << retried.output;
  EXPECT_NE(retried.output.find("2 runs (1 done before, 1 run again), 1 not ok"), std::string::npos)
      << retried.output;
  const std::vector<nlohmann::json> results = jsonl(dir / "out/results.jsonl");
  EXPECT_EQ(results.size(), 2u);
  EXPECT_EQ(result_of_run(dir / "out", "locsim_test_throws/seed-1")["status"], "failed");
}

TEST(Sweep, ARunInErrorMakesTheSweepExitWith1AndSayWhere) {
  const fs::path dir = testing::temp_dir("sweep");
  // test_create_fails loads and takes its parameters (the checks pass), but its create call,
  // which needs the world, fails in the run: locsim cannot produce a result.
  const fs::path experiment = write_short_experiment(
      dir, "  - plugin: odometry\n  - plugin: " + test_plugin("create_fails") + "\n");
  const fs::path out = dir / "out";
  const TimedOutcome outcome =
      locsim("sweep " + experiment.string() + " --out " + out.string(), dir);
  EXPECT_EQ(outcome.exit_code, 1) << outcome.output;
  const std::string last_line =
      outcome.output.substr(outcome.output.rfind('\n', outcome.output.size() - 2) + 1);
  EXPECT_NE(last_line.find("1 run ended in error"), std::string::npos) << outcome.output;
  EXPECT_NE(last_line.find((out / "results.csv").string()), std::string::npos) << outcome.output;
  EXPECT_NE(testing::read_file(out / "results.csv").find("needs a map with at least 100 landmarks"),
            std::string::npos);
  EXPECT_EQ(result_of_run(out, "odometry/seed-1")["status"], "ok");
}

// Issue 49: one locsim at a time writes a sweep folder (DIR/sweep.lock, flock(2)); merge refuses
// corrupt, repeated or live shards. Each through the command line, as a user meets it.

/// `locsim ARGUMENTS` started in the background, its stdout and stderr into `output`.
pid_t start_locsim(const std::vector<std::string>& arguments, const fs::path& output) {
  const pid_t pid = fork();
  if (pid == 0) {
    const int fd = ::open(output.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(fd, STDOUT_FILENO);
    dup2(fd, STDERR_FILENO);
    std::vector<char*> argv{const_cast<char*>(LOCSIM_BINARY)};
    for (const std::string& a : arguments) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(LOCSIM_BINARY, argv.data());
    _exit(127);
  }
  return pid;
}

int exit_code_of(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/// Every file under `dir` with its size, to tell whether anything was written.
std::string file_listing(const fs::path& dir) {
  std::set<std::string> entries;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    entries.insert(fs::relative(entry.path(), dir).string() + " " +
                   (entry.is_regular_file() ? std::to_string(entry.file_size()) : "dir"));
  }
  std::string out;
  for (const std::string& e : entries) out += e + "\n";
  return out;
}

TEST(SweepLock, OfTwoSweepsOrTwoResumesStartedIntoOneFolderAtOnceOneRunsTheOtherExitsWith2) {
  // Before: both ran, and both failed (exit 1) with `error` rows, each run's folder emptied by
  // the other's run of it.
  const fs::path dir = testing::temp_dir("sweep-lock");
  const fs::path experiment = write_short_experiment(dir, "  - plugin: odometry\n", "[1, 2]");
  const fs::path out = dir / "out";
  const auto race = [&](std::vector<std::string> arguments) {
    arguments.insert(arguments.begin(), {"sweep", experiment.string(), "--out", out.string()});
    const pid_t a = start_locsim(arguments, dir / "a.txt");
    const pid_t b = start_locsim(arguments, dir / "b.txt");
    const int code_a = exit_code_of(a), code_b = exit_code_of(b);
    const std::string output_a = testing::read_file(dir / "a.txt");
    const std::string output_b = testing::read_file(dir / "b.txt");
    SCOPED_TRACE(output_a + "\n---\n" + output_b);
    // One ran them; the other was refused at once, naming the one that holds the folder (or,
    // had the first ended before it began, found the sweep done or nothing to run).
    EXPECT_TRUE(code_a == 0 || code_b == 0);
    for (const auto& [code, output, other] :
         {std::tuple{code_a, output_a, b}, std::tuple{code_b, output_b, a}}) {
      EXPECT_TRUE(code == 0 || code == 2) << code;
      if (code == 2 && output.find("already holds a sweep") == std::string::npos) {
        testing::expect_contains(output, "--out: '" + out.string() +
                                             "' is in use by locsim sweep (pid " +
                                             std::to_string(other) + ")");
      }
    }
    const std::vector<nlohmann::json> results = jsonl(out / "results.jsonl");
    EXPECT_EQ(results.size(), 2u);
    for (const nlohmann::json& r : results) EXPECT_EQ(r["status"], "ok") << r.dump();
    EXPECT_FALSE(fs::exists(out / "sweep.lock"));
  };
  race({});
  // Every result gone, as if the sweep had been killed at once: two resumes at once.
  std::ofstream(out / "results.jsonl", std::ios::trunc).flush();
  race({"--resume"});
}

TEST(SweepLock, ALiveSweepsFolderIsRefusedAtOnceNamingItsPidAndAKilledOnesIsResumed) {
  const fs::path dir = testing::temp_dir("sweep-lock");
  const fs::path experiment = write_short_experiment(dir, "  - plugin: odometry\n", "[1, 2]");
  const fs::path out = dir / "out";
  // The holder: a sweep whose every run hangs, until it is killed.
  const fs::path hangs = write_stand_in(dir, "  *) exec sleep 300 ;;\n");
  const pid_t holder = fork();
  ASSERT_GE(holder, 0);
  if (holder == 0) {
    try {
      sweep(experiment, out, 1, false, std::nullopt, hangs);
    } catch (...) {
    }
    _exit(0);
  }
  // Killed at the end of the test, however it ends (its hanging runs die with it).
  struct Holder {
    pid_t pid;
    void kill_now() {
      if (pid <= 0) return;
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
      pid = -1;
    }
    ~Holder() { kill_now(); }
  } guard{holder};
  // It holds the folder, and its first run (a seed's recording) has started: nothing more is
  // written until that ends (it hangs).
  const std::string holder_line = std::to_string(holder) + " sweep\n";
  const auto started = [&] {
    return testing::read_file(out / "sweep.lock") == holder_line &&
           fs::is_directory(out / "logs") && !fs::is_empty(out / "logs");
  };
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < deadline && !started()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(started());
  const std::string before = file_listing(out);
  const std::string held =
      "'" + out.string() + "' is in use by locsim sweep (pid " + std::to_string(holder) + ")";
  for (const std::string& command :
       {"sweep " + experiment.string() + " --out " + out.string(),
        "sweep " + experiment.string() + " --out " + out.string() + " --resume",
        "sweep " + experiment.string() + " --out " + out.string() + " --resume --jobs 2",
        "merge " + (dir / "merged").string() + " " + out.string()}) {
    SCOPED_TRACE(command);
    const TimedOutcome o = locsim(command, dir);
    EXPECT_EQ(o.exit_code, 2) << o.output;
    testing::expect_contains(o.output, held);
    EXPECT_LT(o.seconds, 20.0) << "not at once";
  }
  EXPECT_EQ(file_listing(out), before);
  EXPECT_FALSE(fs::exists(dir / "merged"));
  // Killed hard, it leaves its lock file behind, held by no one: a resume takes it.
  guard.kill_now();
  EXPECT_TRUE(fs::exists(out / "sweep.lock"));
  const SweepSummary resumed = sweep(experiment, out, 1, true);
  EXPECT_EQ(resumed.ran, 2u);
  EXPECT_EQ(resumed.not_ok, 0u);
  EXPECT_FALSE(fs::exists(out / "sweep.lock"));
}

/// Odometry on seeds 1-4 swept as two shards, DIR/a (runs 0 and 2: seeds 1 and 3) and DIR/b.
fs::path write_two_shards(const fs::path& dir) {
  const fs::path experiment =
      write_short_experiment(dir, "  - plugin: odometry\n", "{from: 1, to: 4}");
  EXPECT_EQ(sweep(experiment, dir / "a", 2, false, std::pair{1, 2}).not_ok, 0u);
  EXPECT_EQ(sweep(experiment, dir / "b", 2, false, std::pair{2, 2}).not_ok, 0u);
  return experiment;
}

TEST(Merge, ABrokenResultLineExitsWith2NamingFileAndLineAndOnlyACutShortLastLineIsDropped) {
  const fs::path dir = testing::temp_dir("merge");
  const fs::path experiment = write_two_shards(dir);
  const fs::path results = dir / "a/results.jsonl";
  const std::string whole = testing::read_file(results);
  const std::size_t first_end = whole.find('\n');
  ASSERT_NE(first_end, std::string::npos);
  // The first of two lines cut in half, its line break kept: no kill does that. Before: merge
  // dropped it and every result after it, with a warning only.
  const std::string first = whole.substr(0, first_end), second = whole.substr(first_end + 1);
  std::ofstream(results, std::ios::binary | std::ios::trunc)
      << first.substr(0, first.size() / 2) << '\n'
      << second;
  const std::string merge =
      "merge " + (dir / "m").string() + " " + (dir / "a").string() + " " + (dir / "b").string();
  TimedOutcome o = locsim(merge, dir);
  EXPECT_EQ(o.exit_code, 2) << o.output;
  testing::expect_contains(o.output, results.string() + ":1: not a run's result");
  EXPECT_LT(o.output.size(), 600u) << "the line is quoted cut";
  EXPECT_FALSE(fs::exists(dir / "m"));
  // --resume reads it as merge does, and leaves it as it is.
  const std::string corrupt = testing::read_file(results);
  o = locsim("sweep " + experiment.string() + " --shard 1/2 --resume --out " + (dir / "a").string(),
             dir);
  EXPECT_EQ(o.exit_code, 2) << o.output;
  testing::expect_contains(o.output, results.string() + ":1: not a run's result");
  EXPECT_EQ(testing::read_file(results), corrupt);

  // The last line cut short, without its line break (a kill while writing it): that run has no
  // result. merge joins the others and says runs are missing; a resume runs it again.
  std::ofstream(results, std::ios::binary | std::ios::trunc) << first << '\n'
                                                             << second.substr(0, second.size() / 2);
  o = locsim(merge, dir);
  EXPECT_EQ(o.exit_code, 0) << o.output;
  testing::expect_contains(o.output, "3 of 4 runs present");
  EXPECT_EQ(jsonl(dir / "m/results.jsonl").size(), 3u);
  EXPECT_EQ(sweep(experiment, dir / "a", 1, true, std::pair{1, 2}).ran, 1u);
  EXPECT_EQ(jsonl(results).size(), 2u);
  o = locsim(
      "merge " + (dir / "m2").string() + " " + (dir / "a").string() + " " + (dir / "b").string(),
      dir);
  EXPECT_EQ(o.exit_code, 0) << o.output;
  EXPECT_EQ(o.output.find("warning"), std::string::npos) << o.output;
  EXPECT_EQ(jsonl(dir / "m2/results.jsonl").size(), 4u);
}

TEST(Merge, AFullDiskLeavesNoHalfMergedFolderAndTheSameCommandThenWorks) {
  // Before: exit 1 naming two folders, a folder of cut logs and CSVs that the next merge refused
  // as not empty.
  const fs::path dir = testing::temp_dir("merge_full");
  write_two_shards(dir);
  const std::string merge =
      "merge " + (dir / "m").string() + " " + (dir / "a").string() + " " + (dir / "b").string();
  // A file-size limit of 8 KiB (16 of dash's 512-byte blocks) fails the first write past it with
  // EFBIG, as a full disk would.
  const testing::Outcome full = testing::run_command("trap '' XFSZ; ulimit -f 16; " +
                                                     std::string(LOCSIM_BINARY) + " " + merge);
  EXPECT_EQ(full.exit_code, 1) << full.output;
  testing::expect_contains(full.output, "locsim: failure: cannot write " + (dir / "m").string());
  EXPECT_TRUE(!fs::exists(dir / "m") || fs::is_empty(dir / "m"));
  const TimedOutcome again = locsim(merge, dir);
  EXPECT_EQ(again.exit_code, 0) << again.output;
  EXPECT_EQ(jsonl(dir / "m/results.jsonl").size(), 4u);
}

TEST(Merge, TheSameShardTwiceOrARunInTwoShardsExitsWith2NamingBoth) {
  // Before: merged, exit 0, with the runs of the first.
  const fs::path dir = testing::temp_dir("merge");
  write_two_shards(dir);
  fs::copy(dir / "a", dir / "a_copy", fs::copy_options::recursive);
  const std::string a = (dir / "a").string(), b = (dir / "b").string();
  TimedOutcome o = locsim("merge " + (dir / "m").string() + " " + a + " " + b + " " + a, dir);
  EXPECT_EQ(o.exit_code, 2) << o.output;
  testing::expect_contains(o.output, "'" + a + "' and '" + a + "' are the same folder");
  o = locsim("merge " + (dir / "m").string() + " " + a + " " + b + " " + (dir / "a_copy").string(),
             dir);
  EXPECT_EQ(o.exit_code, 2) << o.output;
  // The first of a's runs in its results.jsonl: seed 1 or 3, whichever ended first.
  testing::expect_contains(o.output, "merge: run 'odometry/seed-");
  testing::expect_contains(o.output,
                           "' is in both '" + a + "' and '" + (dir / "a_copy").string() + "'");
  EXPECT_FALSE(fs::exists(dir / "m"));
}

TEST(Merge, ACorruptSweepJsonExitsWith2NamingTheFileLineAndKey) {
  // Before: exit 1 with nlohmann's parse error, naming no file.
  const fs::path dir = testing::temp_dir("merge");
  write_two_shards(dir);
  const fs::path file = dir / "b/sweep.json";
  const std::string header = testing::read_file(file);
  const std::string merge =
      "merge " + (dir / "m").string() + " " + (dir / "a").string() + " " + (dir / "b").string();
  // Cut short on its third line.
  const std::size_t third = header.find('\n', header.find('\n') + 1) + 1;
  std::ofstream(file, std::ios::trunc) << header.substr(0, third + 5);
  TimedOutcome o = locsim(merge, dir);
  EXPECT_EQ(o.exit_code, 2) << o.output;
  testing::expect_contains(o.output, file.string() + ":3:");
  testing::expect_contains(o.output, "not valid JSON");
  EXPECT_EQ(o.output.find("json.exception"), std::string::npos) << o.output;
  // Valid JSON, a key of the wrong kind.
  nlohmann::ordered_json parsed = nlohmann::ordered_json::parse(header);
  parsed["runs"] = "four";
  std::ofstream(file, std::ios::trunc) << parsed.dump(2);
  o = locsim(merge, dir);
  EXPECT_EQ(o.exit_code, 2) << o.output;
  testing::expect_contains(o.output, file.string() + ": 'runs': missing, or not a whole number");
  EXPECT_FALSE(fs::exists(dir / "m"));
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
  // A file the experiment names and that is not there: at the key that names it.
  EXPECT_NE(error("world: nowhere.yaml\nseeds: [1]\nlocalizers: [{plugin: odometry}]\n")
                .find("bad.yaml:1:8: 'world': no such file '"),
            std::string::npos);
  EXPECT_NE(error(world + "scenario: .\nseeds: [1]\nlocalizers: [{plugin: odometry}]\n")
                .find("bad.yaml:2:11: 'scenario': '"),
            std::string::npos);
  EXPECT_NE(error(world + "seeds: [1]\nlocalizers: [{plugin: odometry}, {plugin: odometry}]\n")
                .find("label 'odometry' used twice"),
            std::string::npos);
  // Grids multiply: nine axes of ten values are 10^9 configurations, refused before any is made
  // (before: std::bad_alloc with no file or key).
  std::string axes;
  for (const char axis : std::string("abcdefghi")) {
    axes += std::string(axes.empty() ? "" : ", ") + axis + ": [0, 1, 2, 3, 4, 5, 6, 7, 8, 9]";
  }
  EXPECT_NE(
      error(world + "seeds: [1]\nlocalizers:\n  - plugin: odometry\n    grid: {" + axes + "}\n")
          .find("bad.yaml:4:5: 'localizers[0]': the grids make 1000000000 configurations; an "
                "experiment has at most 100000"),
      std::string::npos);
  EXPECT_NE(
      error(world + "seeds: {from: 1, to: 20}\nlocalizers:\n  - plugin: odometry\n    grid: "
                    "{a: [0, 1, 2, 3, 4, 5, 6, 7, 8, 9], b: [0, 1, 2, 3, 4, 5, 6, 7, 8, 9], c: "
                    "[0, 1, 2, 3, 4, 5, 6, 7, 8, 9], d: [0, 1, 2, 3, 4, 5, 6, 7, 8, 9], e: [0, "
                    "1, 2, 3, 4, 5, 6, 7, 8, 9]}\n")
          .find("100000 configurations on 20 seeds make 2000000 runs"),
      std::string::npos);
  EXPECT_NE(error(world + "seeds: [1]\nlocalizers: [{plugin: odometry}]\ntimeout_s: 1e300\n")
                .find("bad.yaml:4:12: 'timeout_s': 1e+300 s is outside [0.01, 10000000] s"),
            std::string::npos);
  // Several robots in the world: every run would end without a result (a folder per robot).
  EXPECT_NE(error(std::string("world: ") + LOCSIM_SOURCE_DIR +
                  "/tests/data/every_key/world.yaml\nseeds: [1]\nlocalizers: [{plugin: "
                  "odometry}]\n")
                .find("bad.yaml:1:8: 'world': the world has 3 robots; an experiment scores one "
                      "robot per run"),
            std::string::npos);
  // Grid values the plugin might never see: run keeps one value per parameter.
  EXPECT_NE(error(world + "seeds: [1]\nlocalizers: [{plugin: ekf_landmarks, params: {gate_chi2: "
                          "5}, grid: {gate_chi2: [5, 9]}}]\n")
                .find("'localizers[0].grid.gate_chi2': also given in params"),
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

TEST(Sweep, ASuiteOfWorldsRunsAsOneSweepTabledByFamily) {
  // Three generated worlds in two families: each world's seed is recorded once and replayed to
  // every configuration; runs and results name the world and its family; summary_by_family.csv
  // has each configuration on each family and on all.
  const fs::path dir = testing::temp_dir("sweep-suite");
  for (const char* family : {"room", "corridor"}) {
    const std::string command = std::string(LOCSIM_BINARY) + " generate " + family + " --seeds 1-" +
                                (family == std::string("room") ? "2" : "1") + " --out " +
                                (dir / "suite").string() + " > /dev/null";
    ASSERT_EQ(std::system(command.c_str()), 0) << command;
  }
  std::ofstream(dir / "experiment.yaml")
      << "name: suite\nworlds:\n  - {family: rooms, files: suite/room_*.yaml}\n"
      << "  - {family: corridors, files: [suite/corridor_seed1.yaml]}\n"
      << "duration_s: 3\nseeds: [1, 2]\nlocalizers:\n  - plugin: odometry\n"
      << "  - {plugin: ekf_landmarks, label: ekf}\n";
  const ExperimentDef e = load_experiment(dir / "experiment.yaml");
  ASSERT_EQ(e.worlds.size(), 3u);
  EXPECT_EQ(e.worlds[0].stem, "room_seed1");
  EXPECT_EQ(e.worlds[2].family, "corridors");
  const auto runs = expand_runs(e);
  ASSERT_EQ(runs.size(), 12u);
  EXPECT_EQ(runs[3].id, "odometry/room_seed2/seed-2");
  EXPECT_EQ(runs[6].id, "ekf/room_seed1/seed-1");

  const SweepSummary s = sweep(dir / "experiment.yaml", dir / "out", 2);
  EXPECT_EQ(s.not_ok, 0u);
  for (const char* world : {"room_seed1", "room_seed2", "corridor_seed1"}) {
    for (const char* seed : {"seed-1", "seed-2"}) {
      EXPECT_TRUE(fs::exists(dir / "out/logs" / world / (std::string(seed) + ".locsimlog")));
      EXPECT_TRUE(fs::exists(dir / "out/runs/ekf" / world / seed / "metrics.json"));
    }
  }
  // Each world's own ground truth: two worlds differ, and so do two seeds of one.
  const auto truth = [&](const std::string& world, const std::string& seed) {
    return testing::read_file(dir / "out/logs" / world / seed / "groundtruth.tum");
  };
  EXPECT_NE(truth("room_seed1", "seed-1"), truth("room_seed2", "seed-1"));
  EXPECT_NE(truth("room_seed1", "seed-1"), truth("room_seed1", "seed-2"));
  const nlohmann::json r = result_of_run(dir / "out", "ekf/corridor_seed1/seed-2");
  EXPECT_EQ(r["world"], "corridor_seed1");
  EXPECT_EQ(r["family"], "corridors");

  const std::string table = testing::read_file(dir / "out/summary_by_family.csv");
  std::vector<std::string> rows;
  std::istringstream lines(table);
  for (std::string line; std::getline(lines, line);) {
    std::size_t end = 0;  // after the fourth field: config, family, worlds, runs
    for (int field = 0; field < 4 && end != std::string::npos; ++field)
      end = line.find(',', end + (field > 0 ? 1 : 0));
    rows.push_back(line.substr(0, end));
  }
  ASSERT_EQ(rows.size(), 7u) << table;
  EXPECT_EQ(rows[1], "odometry,rooms,2,4");
  EXPECT_EQ(rows[2], "odometry,corridors,1,2");
  EXPECT_EQ(rows[3], "odometry,all,3,6");
  EXPECT_EQ(rows[6], "ekf,all,3,6");
  EXPECT_NE(testing::read_file(dir / "out/summary.md").find("### Per world family"),
            std::string::npos);
  // An experiment of one world has no family table.
  std::ofstream(dir / "one.yaml") << "worlds: [suite/room_seed1.yaml]\nduration_s: 1\nseeds: [1]\n"
                                  << "localizers: [{plugin: odometry}]\n";
  EXPECT_EQ(expand_runs(load_experiment(dir / "one.yaml")).front().id,
            "odometry/room_seed1/seed-1");
}

TEST(Sweep, TheHeldBackPartIsTabledBesideThePartTheDefaultsWereChosenOn) {
  // Synthetic results: "pf" recovers 3 of 4 kidnaps where chosen and 1 of 4 held back, jumps in
  // one held-back run, and its truth lies in its ellipse while converged 0.9 of the time chosen
  // and 0.85 held back (5 points: not called out); "slam" maps 8 of 10 seen landmarks chosen and
  // 5 of 10 held back, spurious 2 of 10 and 2 of 7.
  using ojson = nlohmann::ordered_json;
  const auto segment = [](bool recovered, std::size_t jumps, double inside) {
    return ojson{{"carried_m", 3.0},
                 {"turned_deg", 40.0},
                 {"recoverable", true},
                 {"recovery_s", recovered ? ojson(2.0) : ojson(nullptr)},
                 {"tracking",
                  {{"samples", 100},
                   {"position_rms_m", 0.1},
                   {"consistency_samples", 100},
                   {"inside_95_ellipse", inside}}},
                 {"jumps", {{"count", jumps}, {"first_s", nullptr}}}};
  };
  const auto run = [&](const std::string& config, std::size_t index, bool held_back,
                       std::vector<ojson> segments, ojson map = nullptr) {
    ojson metrics = {{"convergence", {{"position_m", 0.25}, {"heading_deg", 10.0}}},
                     {"segments", segments}};
    if (!map.is_null()) metrics["landmark_map"] = map;
    ojson r = {{"index", index},
               {"config", config},
               {"world", "w" + std::to_string(index)},
               {"family", held_back ? "crowd" : "room"},
               {"status", "ok"},
               {"metrics", metrics}};
    if (held_back) r["held_back"] = true;
    return r;
  };
  // A run's first segment has no kidnap before it: not a recovery to count.
  std::vector<ojson> results = {
      run("pf", 0, false, {segment(true, 0, 0.9), segment(true, 0, 0.9), segment(true, 0, 0.9)}),
      run("pf", 1, false, {segment(true, 0, 0.9), segment(true, 0, 0.9), segment(false, 0, 0.9)}),
      run("pf", 2, true, {segment(true, 0, 0.85), segment(true, 0, 0.85), segment(false, 1, 0.85)}),
      run("pf", 3, true,
          {segment(true, 0, 0.85), segment(false, 0, 0.85), segment(false, 0, 0.85)}),
      run("slam", 4, false, {segment(true, 0, 0.9)},
          {{"observed", 10}, {"aligned_within", 8}, {"mapped", 10}, {"spurious", 2}}),
      run("slam", 5, true, {segment(true, 0, 0.9)},
          {{"observed", 10}, {"aligned_within", 5}, {"mapped", 7}, {"spurious", 2}})};
  const fs::path dir = testing::temp_dir("part-tables");
  std::ostringstream md;
  write_part_tables(dir, results, {"pf", "slam"}, md);
  const std::string csv = testing::read_file(dir / "summary_by_part.csv");
  EXPECT_NE(csv.find("\npf,chosen_on,2,2,2,4,3,0.7500,0,0,0.9000,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\npf,held_back,2,2,2,4,1,0.2500,1,1,0.8500,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\nslam,held_back,1,1,1,0,0,,0,0,0.9000,0.100000,10,5,0.5000,7,2,0.2857\n"),
            std::string::npos)
      << csv;
  const std::string text = md.str();
  EXPECT_NE(text.find("### Chosen on and held back"), std::string::npos) << text;
  EXPECT_NE(text.find("- **pf**: kidnaps recovered 25 % held back against 75 % chosen on (50 "
                      "points lower)."),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("- **pf**: runs with a jump while tracking 50 % held back against 0 % "
                      "chosen on (50 points higher)."),
            std::string::npos)
      << text;
  EXPECT_EQ(text.find("- **pf**: truth in the 95 % ellipse"), std::string::npos) << text;
  EXPECT_NE(text.find("- **slam**: landmarks mapped 50 % held back against 80 % chosen on (30 "
                      "points lower)."),
            std::string::npos)
      << text;
  EXPECT_EQ(text.find("- **slam**: spurious"), std::string::npos) << text;  // 29 % vs 20 %
  // Nothing held back: no section, no file.
  for (ojson& r : results) r.erase("held_back");
  const fs::path none = testing::temp_dir("part-tables-none");
  std::ostringstream nothing;
  write_part_tables(none, results, {"pf", "slam"}, nothing);
  EXPECT_TRUE(nothing.str().empty());
  EXPECT_FALSE(fs::exists(none / "summary_by_part.csv"));
}

TEST(Experiment, ASuitesWorldsAreCheckedWhereTheExperimentNamesThem) {
  const fs::path dir = testing::temp_dir("experiment-suite");
  fs::create_directories(dir / "a");
  const fs::path every_key = fs::path(LOCSIM_SOURCE_DIR) / "tests/data/every_key";
  fs::copy_file(every_key / "world.yaml", dir / "a/w.yaml");  // three robots
  for (const char* map : {"map.yaml", "map.pgm"}) fs::copy_file(every_key / map, dir / "a" / map);
  const auto error = [&](const std::string& worlds) {
    std::ofstream(dir / "bad.yaml") << worlds << "seeds: [1]\nlocalizers: [{plugin: odometry}]\n";
    try {
      load_experiment(dir / "bad.yaml");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  const std::string demo = std::string(LOCSIM_SOURCE_DIR) + "/worlds/demo/demo.yaml";
  EXPECT_NE(error("worlds: [{family: f, files: nothing_*.yaml}]\n")
                .find("bad.yaml:1:29: 'worlds[0].files': no world file matches '"),
            std::string::npos);
  EXPECT_NE(error("world: " + demo + "\nworlds: [" + demo + "]\n")
                .find("'worlds': give world (one) or worlds (a list), not both"),
            std::string::npos);
  EXPECT_NE(error("worlds: [{family: 'a b', files: " + demo + "}]\n")
                .find("'worlds[0].family': a family name may hold only"),
            std::string::npos);
  EXPECT_NE(error("worlds: [" + demo + ", {family: f, files: [" + demo + "]}]\n")
                .find("'worlds[1].files[0]': the file name 'demo' is also that of"),
            std::string::npos);
  EXPECT_NE(error("worlds: []\n").find("'worlds': give at least one world"), std::string::npos);
  EXPECT_NE(error("worlds: [{family: f, files: " + demo + ", held_back: maybe}]\n")
                .find("'worlds[0].held_back'"),
            std::string::npos);
  // A world of several robots among them: named as the entry that brought it in.
  EXPECT_NE(error("worlds: [" + demo + ", {family: f, files: a/w*.yaml}]\n").find("bad.yaml:1:"),
            std::string::npos);
  EXPECT_NE(error("worlds: [" + demo + ", {family: f, files: a/w*.yaml}]\n")
                .find("'worlds[1].files': the world '"),
            std::string::npos);
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
