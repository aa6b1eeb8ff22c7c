// Nothing written is lost or claimed complete when it is not (issue "Hardening"): every write is
// checked, and a run or replay that cannot write stops with exit 1, a message naming the path and
// the system's reason, and run.json (where it can still be written) saying "failed". /dev/full
// stands in for a full disk: every write to it fails with ENOSPC.
#include <gtest/gtest.h>

#include <algorithm>
#include <nlohmann/json.hpp>

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

}  // namespace
}  // namespace locsim
