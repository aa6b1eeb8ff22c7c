// Nothing written is lost or claimed complete when it is not (issue "Hardening"): every write is
// checked, and a run or replay that cannot write stops with exit 1, a message naming the path and
// the system's reason, and run.json (where it can still be written) saying "failed"; the files
// the failure cut are removed. run.json is a run folder's first file ("running"), so a folder
// left by a failed or killed run is one --overwrite replaces. /dev/full stands in for a full
// disk: every write to it fails with ENOSPC; `ulimit -f` for a disk that fills at that size.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <stdexcept>

#include "sim/common/files.hpp"
#include "sim/consumers/run_recorder.hpp"
#include "sim/run/output_budget.hpp"
#include "sim/run/runner.hpp"
#include "sim/run/session.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using testing::locsim;

using testing::kDemo;

void expect_failed_for_a_full_disk(const testing::Outcome& o, const fs::path& run_json,
                                   const std::string& path) {
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_NE(o.output.find("cannot write"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find(path), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("No space left on device"), std::string::npos) << o.output;
  const json run = json::parse(testing::read_file(run_json));
  EXPECT_EQ(run["status"], "failed");
  EXPECT_NE(run["error"].get<std::string>().find(path), std::string::npos);
}

TEST(WritesAreChecked, AnOutputFileHoldsEveryWriteInOrderWhateverItsSize) {
  // Rows of a few bytes to several buffers' worth (a laser row is 1-2 KiB, past which
  // std::ofstream no longer buffers): after each flush the file is everything written so far.
  const fs::path file = testing::temp_dir("output_file") / "rows.csv";
  std::mt19937 engine(5);
  std::string expected;
  OutputFile out(file);
  for (int row = 0; row < 400; ++row) {
    const std::size_t length = row % 50 == 7
                                   ? 3 * OutputFile::kBufferBytes / 2
                                   : std::uniform_int_distribution<std::size_t>(0, 3000)(engine);
    std::string text(length, static_cast<char>('a' + row % 26));
    text += '\n';
    out.write(text);
    expected += text;
    if (row % 97 == 0) {
      out.flush();
      EXPECT_EQ(testing::read_file(file), expected) << "row " << row;
    }
  }
  out.close();
  EXPECT_EQ(testing::read_file(file), expected);
}

TEST(WritesAreChecked, AnOutputFileThatFillsUpThrowsWithItsPathOnceItsBufferIsFull) {
  OutputFile out("/dev/full", "the log ");
  const std::string row(1000, 'x');
  try {
    for (std::size_t written = 0; written <= OutputFile::kBufferBytes; written += row.size())
      out.write(row);
    FAIL() << "a full buffer went to a full disk without an error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "cannot write the log /dev/full: No space left on device");
  }
}

TEST(WritesAreChecked, ALogOntoAFullDiskFailsTheRun) {
  // The log's header is written before the run folder is made: a log that cannot be written at
  // all fails the run with nothing made. (One that fills up later fails it as the ground truth
  // does below.)
  const fs::path out = testing::temp_dir("full") / "out";
  const testing::Outcome o =
      locsim("run " + kDemo + " --duration 5 -q --log /dev/full --out " + out.string());
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_NE(o.output.find("cannot write the log /dev/full: No space left on device"),
            std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(out));
}

TEST(WritesAreChecked, AFullDiskUnderTheRunFolderFailsRunAndReplayAndKeepsTheOtherFiles) {
  const fs::path dir = testing::temp_dir("full");
  ASSERT_EQ(locsim("run " + kDemo + " --duration 5 -q --out " + (dir / "ok").string() + " --log " +
                   (dir / "run.log").string())
                .exit_code,
            0);
  for (const std::string& command :
       {"run " + kDemo + " --duration 5", "replay " + (dir / "run.log").string()}) {
    SCOPED_TRACE(command);
    const fs::path out = dir / (command.starts_with("run") ? "run" : "replay");
    // The ground truth goes to a disk that is full; everything else to one that is not.
    const testing::Outcome o =
        // Under AddressSanitizer, a library preloaded before its runtime is allowed explicitly.
        testing::run_command(
            "ASAN_OPTIONS=${ASAN_OPTIONS:+$ASAN_OPTIONS:}verify_asan_link_order=0"
            " LD_PRELOAD=" +
            std::string(LOCSIM_TEST_FULL_DISK) + " LOCSIM_TEST_FULL_FILE=/groundtruth.tum " +
            LOCSIM_BINARY + " " + command + " -q --localizer odometry --out " + out.string());
    expect_failed_for_a_full_disk(o, out / "run.json", (out / "groundtruth.tum").string());
    // It stopped at the first failed write (a flush, or the close at the end); the other outputs
    // are whole up to there: the localizer's estimates and its metrics agree, row for sample.
    const std::string estimates = testing::read_file(out / "odometry.tum");
    const json metrics = json::parse(testing::read_file(out / "metrics.json"));
    const long samples = metrics["localizers"][0]["samples"].get<long>();
    EXPECT_GT(samples, 0);
    EXPECT_LE(samples, 5 * 50 + 1);
    EXPECT_EQ(std::count(estimates.begin(), estimates.end(), '\n'), 1 + samples);
    EXPECT_EQ(estimates.back(), '\n');
  }
}

/// Every file in `dir` (recursively), relative to it.
std::vector<fs::path> files_in(const fs::path& dir) {
  std::vector<fs::path> files;
  if (!fs::exists(dir)) return files;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file()) files.push_back(fs::relative(entry.path(), dir));
  }
  return files;
}

/// `command` (arguments of locsim) with files limited to `kib` KiB: a write past it fails with
/// EFBIG (SIGXFSZ ignored), as on a disk that fills up at that size.
testing::Outcome locsim_with_file_limit(int kib, const std::string& command) {
  // /bin/sh is dash, whose `ulimit -f` counts 512-byte blocks (bash's counts KiB).
  return testing::run_command("trap '' XFSZ; ulimit -f " + std::to_string(2 * kib) + "; " +
                              LOCSIM_BINARY + " " + command);
}

TEST(WritesAreChecked, AFileCutByAFullDiskIsNeverLeftBehind) {
  // A generated world cut at 4 KiB still loaded, its drive and kidnaps gone (issue 49); run.json
  // and metrics.json left their .tmp files. Each file is now whole, or absent, with no .tmp.
  const fs::path dir = testing::temp_dir("cut");
  ASSERT_EQ(locsim("generate office --seeds 1-3 -q --out " + (dir / "whole").string()).exit_code,
            0);
  const testing::Outcome generated =
      locsim_with_file_limit(4, "generate office --seeds 1-3 -q --out " + (dir / "cut").string());
  EXPECT_EQ(generated.exit_code, 1) << generated.output;
  for (const fs::path& file : files_in(dir / "cut")) {
    EXPECT_TRUE(fs::exists(dir / "whole" / file)) << file << " is not a world it generates";
    EXPECT_EQ(testing::read_file(dir / "cut" / file), testing::read_file(dir / "whole" / file))
        << file;
  }
  // A run whose small files fit and whose metrics.json does not (the laser's readings are
  // buffered and cut too, which the run reports; what matters here is no half-written JSON).
  const testing::Outcome run = locsim_with_file_limit(
      8, "run " + kDemo + " --duration 2 -q --no-readings --localizer odometry --out " +
             (dir / "run").string());
  EXPECT_NE(run.exit_code, 0) << run.output;
  for (const fs::path& file : files_in(dir / "run")) {
    EXPECT_NE(file.extension(), ".tmp") << file;
    if (file.extension() == ".json") {
      EXPECT_TRUE(json::accept(testing::read_file(dir / "run" / file))) << file;
    }
  }
}

TEST(WritesAreChecked, APairOfFilesIsReplacedWholeOrNotAtAll) {
  // calibrate writes calibration.json and calibration.yaml: a new .json beside an old .yaml (the
  // second write failed) would describe another calibration than the file a twin reads.
  const fs::path dir = testing::temp_dir("pair");
  write_files({{dir / "a.json", "old a"}, {dir / "b.yaml", "old b"}});
  EXPECT_THROW(write_files({{dir / "a.json", "new a"}, {dir / "missing" / "b.yaml", "new b"}}),
               std::runtime_error);
  EXPECT_EQ(testing::read_file(dir / "a.json"), "old a");
  EXPECT_EQ(testing::read_file(dir / "b.yaml"), "old b");
  EXPECT_EQ(files_in(dir).size(), 2u) << "a temporary left behind";
  write_files({{dir / "a.json", "new a"}, {dir / "b.yaml", "new b"}});
  EXPECT_EQ(testing::read_file(dir / "a.json"), "new a");
  EXPECT_EQ(testing::read_file(dir / "b.yaml"), "new b");
}

// ---- how a run that fails or is killed ends (issue "Hardening", audit B) ---------------------

/// `command` (arguments of locsim) with every open of a file whose path ends in `suffix` going to
/// /dev/full (tests/full_disk_preload.cpp): its writes fail with ENOSPC.
testing::Outcome locsim_with_full_file(const std::string& suffix, const std::string& command) {
  // Under AddressSanitizer, a library preloaded before its runtime is allowed explicitly.
  return testing::run_command(
      "ASAN_OPTIONS=${ASAN_OPTIONS:+$ASAN_OPTIONS:}verify_asan_link_order=0"
      " LD_PRELOAD=" +
      std::string(LOCSIM_TEST_FULL_DISK) + " LOCSIM_TEST_FULL_FILE=" + suffix + " " +
      LOCSIM_BINARY + " " + command);
}

json run_json_of(const fs::path& dir) {
  return json::parse(testing::read_file(dir / "run.json"));
}

TEST(FailedRuns, AFileCutByAFailedWriteIsRemovedAndTheMessageNamesIt) {
  // Under a 24 KiB file-size limit, run.json (15 KiB) and every file but the laser's readings fit;
  // laser.csv (34 KiB) is cut at 24 KiB, mid-row. Before: it stayed so, beside a run.json that
  // did not say which file was cut, and read as a whole, shorter scan file.
  const fs::path dir = testing::temp_dir("cut");
  ASSERT_EQ(locsim("run " + kDemo + " --duration 2 -q --out " + (dir / "whole").string() +
                   " --log " + (dir / "run.locsimlog").string())
                .exit_code,
            0);
  for (const std::string& command :
       {"run " + kDemo + " --duration 2", "replay " + (dir / "run.locsimlog").string()}) {
    SCOPED_TRACE(command);
    const fs::path out = dir / (command.starts_with("run") ? "run" : "replay");
    const std::string arguments = command + " -q --localizer odometry --out " + out.string();
    const testing::Outcome o = locsim_with_file_limit(24, arguments);
    const std::string laser = (out / "readings" / "laser.csv").string();
    EXPECT_EQ(o.exit_code, 1) << o.output;
    EXPECT_NE(o.output.find("cannot write " + laser + ": File too large"), std::string::npos)
        << o.output;
    const json run = run_json_of(out);
    EXPECT_EQ(run["status"], "failed");
    EXPECT_NE(run["error"].get<std::string>().find(laser), std::string::npos) << run["error"];
    EXPECT_EQ(run["removed_files"], json::array({"readings/laser.csv"}));
    EXPECT_FALSE(fs::exists(laser));
    // What is left is whole: every row ends, nothing half-written, no temporary.
    for (const fs::path& file : files_in(out)) {
      EXPECT_NE(file.extension(), ".tmp") << file;
      const std::string text = testing::read_file(out / file);
      if (file.extension() == ".tum" || file.extension() == ".csv") {
        ASSERT_FALSE(text.empty()) << file;
        EXPECT_EQ(text.back(), '\n') << file << " ends mid-row";
      }
      if (file.extension() == ".json") {
        EXPECT_TRUE(json::accept(text)) << file;
      }
    }
    // The metrics up to the failure are kept: the estimates and metrics agree, row for sample.
    const std::string estimates = testing::read_file(out / "odometry.tum");
    const long samples =
        json::parse(testing::read_file(out / "metrics.json"))["localizers"][0]["samples"];
    EXPECT_EQ(std::count(estimates.begin(), estimates.end(), '\n'), 1 + samples);
    // The folder is a run folder: --overwrite replaces it.
    const testing::Outcome again = locsim(arguments + " --overwrite");
    ASSERT_EQ(again.exit_code, 0) << again.output;
    EXPECT_EQ(run_json_of(out)["status"], "completed");
    EXPECT_TRUE(fs::exists(laser));
  }
}

TEST(FailedRuns, ARunWhoseRunJsonCannotBeWrittenLeavesNoFolderBehind) {
  // run.json is the first file: a disk that cannot take it fails the run before anything else
  // is written, naming it, and leaves no folder. Before: the run went to its end, its run.json
  // failed last, and the folder it left (every other file, no run.json) was refused by
  // --overwrite ("holds no run.json").
  const fs::path dir = testing::temp_dir("no_run_json");
  const fs::path out = dir / "run";
  const std::string arguments =
      "run " + kDemo + " --duration 2 -q --localizer odometry --out " + out.string();
  const testing::Outcome o = locsim_with_full_file("/run.json.tmp", arguments);
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_NE(
      o.output.find("cannot write " + (out / "run.json").string() + ": No space left on device"),
      std::string::npos)
      << o.output;
  EXPECT_TRUE(!fs::exists(out) || fs::exists(out / "run.json")) << "a folder that is no run's";
  EXPECT_FALSE(fs::exists(out));
  const testing::Outcome again = locsim(arguments + " --overwrite");
  EXPECT_EQ(again.exit_code, 0) << again.output;
}

TEST(FailedRuns, AFolderLeftByAKilledRunSaysRunningAndIsReplacedByOverwrite) {
  // A run killed hard (SIGKILL, out of memory) cannot say how it ended: its run.json, written
  // first, says "running". Before: it had none until the end, and --overwrite refused the folder.
  const fs::path dir = testing::temp_dir("killed");
  const fs::path out = dir / "run";
  const std::string run = std::string(LOCSIM_BINARY) + " run " + kDemo +
                          " --duration 600 --realtime -q --out " + out.string() + " --log " +
                          (dir / "run.locsimlog").string();
  // Killed once its ground truth has reached the disk (the first flush, after 0.2 s).
  const testing::Outcome killed = testing::run_command(
      "{ " + run + " >" + (dir / "output.txt").string() + " 2>&1 & pid=$!; for i in $(seq 1 200);" +
      " do [ -s " + (out / "groundtruth.tum").string() + " ] && break; sleep 0.05; done; " +
      "sleep 0.3; kill -9 $pid; wait $pid; }");
  EXPECT_EQ(killed.exit_code, 128 + 9) << killed.output;
  ASSERT_TRUE(fs::exists(out / "run.json"));
  const json before = run_json_of(out);
  EXPECT_EQ(before["status"], "running");
  EXPECT_EQ(before["robots"][0]["folder"], ".");
  EXPECT_TRUE(before.contains("config"));
  EXPECT_FALSE(held_by_a_run(out / "run.json")) << "the killed run's lock outlived it";
  const testing::Outcome again =
      locsim("run " + kDemo + " --duration 1 -q --overwrite --out " + out.string() + " --log " +
             (dir / "run.locsimlog").string());
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_EQ(run_json_of(out)["status"], "completed");
}

TEST(FailedRuns, OverwriteRefusesTheFolderOfARunStillGoingOn) {
  // A run holds its run.json locked while it runs: a second command with --overwrite must not
  // empty the folder under it.
  const fs::path dir = testing::temp_dir("live");
  const fs::path out = dir / "run";
  const std::string run = std::string(LOCSIM_BINARY) + " run " + kDemo +
                          " --duration 600 --realtime -q --out " + out.string();
  const testing::Outcome o = testing::run_command(
      "{ " + run + " >" + (dir / "output.txt").string() + " 2>&1 & pid=$!; for i in $(seq 1 200);" +
      " do [ -s " + (out / "groundtruth.tum").string() + " ] && break; sleep 0.05; done; " +
      LOCSIM_BINARY + " run " + kDemo + " --duration 1 -q --overwrite --out " + out.string() +
      "; rc=$?; kill -9 $pid; wait $pid; exit $rc; }");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find("still going on"), std::string::npos) << o.output;
  EXPECT_EQ(run_json_of(out)["status"], "running");  // the killed run's, untouched
}

TEST(FailedRuns, ARunJsonThatCannotBeRewrittenSaysFailedInPlace) {
  // At the end a full disk may have no room for the new run.json beside the old one: the old
  // one's "running" becomes "failed" in its own bytes, so the folder does not read as a live run.
  const fs::path dir = testing::temp_dir("in_place") / "run";
  const RunInputs inputs = load_run_inputs(kDemo, std::nullopt, 1.0);
  SessionOptions options;
  options.readings = false;
  Session session(options, inputs.world, inputs.scenario, 1, nullptr);
  nlohmann::ordered_json start = {{"locsim_version", "test"}, {"status", "running"}, {"seed", 1}};
  session.open(dir, start.dump(2) + '\n');
  EXPECT_TRUE(held_by_a_run(dir / "run.json"));
  // Where the new run.json's temporary goes, a folder: it cannot be written.
  fs::create_directories(dir / "run.json.tmp" / "in_the_way");
  RunEnd end;
  session.write_run_json({{"locsim_version", "test"}, {"status", "completed"}, {"seed", 1}}, end);
  EXPECT_EQ(end.status, "failed");
  EXPECT_NE(end.error.find("run.json"), std::string::npos) << end.error;
  const json run = run_json_of(dir);
  EXPECT_EQ(run["status"], "failed");
  EXPECT_EQ(run["seed"], 1);
}

TEST(OutputBudget, NotEnoughFreeDiskSpaceIsTheMachinesStateNotBadInput) {
  // Before: exit 2, blamed on the world's laser key, though the world is fine for a larger disk.
  const fs::path dir = testing::temp_dir("free_space");
  std::ofstream(dir / "fast_laser.yaml")
      << "name: w\nphysics: {step_hz: 10000}\nrobots:\n  - name: r\n    start: {x: 0, y: 0, "
         "theta: 0}\n    sensors: {laser: {beams: 100000, rate_hz: 10000}}\n";
  const fs::path out = dir / "fast";
  const testing::Outcome o =
      locsim("run " + (dir / "fast_laser.yaml").string() +
             " --duration 60 -q --max-output-gib 1000000 --out " + out.string());
  EXPECT_EQ(o.exit_code, 1) << o.output;
  testing::expect_contains(o.output, "not enough free disk space");
  testing::expect_contains(o.output, "the run folder '" + out.string() + "'");
  testing::expect_contains(o.output, "free on the disk of");
  EXPECT_EQ(o.output.find("robots[0].sensors.laser"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(out));
}

TEST(OutputBudget, CountsTheVideoAndRunJson) {
  const RunInputs inputs = load_run_inputs(kDemo, std::nullopt, 2.0);
  OutputPlan plan;
  plan.localizers = 1;
  const OutputEstimate without = estimate_run_output(inputs.world, inputs.scenario, plan);
  EXPECT_EQ(without.video_bytes, 0.0);
  VideoOptions video;  // 1280x720 at 30 fps: 61 frames of 2 s
  video.video_file = "v.mp4";
  plan.video = &video;
  plan.run_json_bytes = 1e6;
  const OutputEstimate with = estimate_run_output(inputs.world, inputs.scenario, plan);
  // The demo's 2 s video measured 365 143 bytes (H.264); the bound holds MPEG-4's rate too.
  EXPECT_GT(with.video_bytes, 3.0 * 365143.0);
  EXPECT_LT(with.video_bytes, 8e6);
  EXPECT_NEAR(with.total_bytes - without.total_bytes, with.video_bytes + 2e6, 1.0);
  EXPECT_NEAR(with.folder_bytes - without.folder_bytes, 2e6, 1.0);  // run.json, twice
  // json_text_bytes bounds the text, escapes included.
  const nlohmann::ordered_json header = {{"yaml", "a: \"b\"\n\tc\x01"}, {"n", 1.5}, {"l", {1, 2}}};
  EXPECT_GE(json_text_bytes(header), static_cast<double>(header.dump().size()));
}

TEST(OutputBudget, ARunJsonOfManyPathPointsCountsAgainstTheBound) {
  // run.json holds the world resolved, every mover's path point: 20 movers sharing a 5000-point
  // path (a YAML alias) make it some 6 MiB. Before: left out of the estimate, and written.
  const fs::path dir = testing::temp_dir("run_json");
  std::string yaml = "name: w\nmovers:\n  - {name: m0, path: &p [";
  for (int i = 0; i < 5000; ++i)
    yaml += (i ? ", [" : "[") + std::to_string(1 + 8 * (i % 2)) + ", 0.5]";
  yaml += "]}\n";
  for (int i = 1; i < 20; ++i) yaml += "  - {name: m" + std::to_string(i) + ", path: *p}\n";
  yaml += "robots: [{name: r, start: {x: 0.5, y: 7.8, theta: 0}}]\n";
  std::ofstream(dir / "w.yaml") << yaml;
  const testing::Outcome o =
      locsim("run " + (dir / "w.yaml").string() +
             " --duration 0.1 -q --max-output-gib 0.001 --out " + (dir / "out").string());
  EXPECT_EQ(o.exit_code, 2) << o.output;
  testing::expect_contains(o.output, "w.yaml: ");
  testing::expect_contains(o.output, "run.json");
  testing::expect_contains(o.output, "--max-output-gib");
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(OutputsApart, ALogThatIsTheRunFolderOrHoldsItIsRefusedBeforeAnythingIsWritten) {
  // Before: exit 1, "filesystem error: cannot create directories: Not a directory", and the log's
  // 4 KiB left where the folder was to be.
  const fs::path dir = testing::temp_dir("apart");
  const fs::path d = dir / "D";
  for (const auto& [arguments, says] :
       {std::pair{"--out " + d.string() + " --log " + d.string(),
                  "--log: '" + d.string() + "' is the run folder (--out) too"},
        std::pair{"--out " + (d / "run").string() + " --log " + d.string(),
                  "--log: '" + d.string() + "' would be a file, but --out"}}) {
    SCOPED_TRACE(arguments);
    const testing::Outcome o = locsim("run " + kDemo + " --duration 1 -q " + arguments);
    EXPECT_EQ(o.exit_code, 2) << o.output;
    testing::expect_contains(o.output, says);
    EXPECT_FALSE(fs::exists(d));
  }
  // The same with the folder there, empty: it stays so.
  fs::create_directories(d);
  const testing::Outcome o =
      locsim("run " + kDemo + " --duration 1 -q --out " + d.string() + " --log " + d.string());
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_TRUE(fs::is_directory(d));
  EXPECT_TRUE(fs::is_empty(d));
}

}  // namespace
}  // namespace locsim
