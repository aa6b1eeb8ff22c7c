// Nothing written is lost or claimed complete when it is not (issue "Hardening"): every write is
// checked, and a run or replay that cannot write stops with exit 1, a message naming the path and
// the system's reason, and run.json (where it can still be written) saying "failed". /dev/full
// stands in for a full disk: every write to it fails with ENOSPC.
#include <gtest/gtest.h>

#include <algorithm>
#include <nlohmann/json.hpp>
#include <random>
#include <stdexcept>

#include "sim/common/files.hpp"
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
  return testing::run_command("trap '' XFSZ; ulimit -f " + std::to_string(kib) + "; " +
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

}  // namespace
}  // namespace locsim
