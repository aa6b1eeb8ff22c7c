// Outputs are whole, or refused before they exist (issue "Hardening"): --overwrite starts from an
// empty folder (and empties only a run folder); what a plugin prints is labelled and capped; bad
// numbers on the command line are refused with a short message; a truncated log, a bad video
// size and an unwritable --log or --video are refused before the run folder is made.
#include <gtest/gtest.h>

#include <algorithm>
#include <nlohmann/json.hpp>

#include "sim/common/capped_text.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using testing::locsim;
using testing::Outcome;

using testing::kDemo;

using testing::test_plugin;

TEST(Overwrite, StartsFromAnEmptyFolder) {
  const fs::path out = testing::temp_dir("overwrite") / "out";
  ASSERT_EQ(
      locsim("run " + kDemo + " --duration 1 -q --localizer odometry@first --out " + out.string())
          .exit_code,
      0);
  ASSERT_TRUE(fs::exists(out / "first.tum"));
  ASSERT_TRUE(fs::exists(out / "readings"));
  const Outcome o = locsim("run " + kDemo +
                           " --duration 1 -q --no-readings --localizer odometry@second "
                           "--overwrite --out " +
                           out.string());
  ASSERT_EQ(o.exit_code, 0) << o.output;
  EXPECT_TRUE(fs::exists(out / "second.tum"));
  EXPECT_FALSE(fs::exists(out / "first.tum"));
  EXPECT_FALSE(fs::exists(out / "readings"));
}

TEST(Overwrite, KeepsTheLogItWritesIntoTheFolder) {
  const fs::path out = testing::temp_dir("overwrite") / "out";
  ASSERT_EQ(locsim("run " + kDemo + " --duration 1 -q --out " + out.string()).exit_code, 0);
  const Outcome o = locsim("run " + kDemo + " --duration 1 -q --overwrite --log " +
                           (out / "run.locsimlog").string() + " --out " + out.string());
  ASSERT_EQ(o.exit_code, 0) << o.output;
  EXPECT_EQ(locsim("replay " + (out / "run.locsimlog").string() + " -q --out " +
                   (out.parent_path() / "replay").string())
                .exit_code,
            0);
}

TEST(Overwrite, RefusesAFolderThatIsNotARunFolderAndTouchesNothing) {
  const fs::path dir = testing::temp_dir("overwrite") / "thesis";
  fs::create_directories(dir);
  std::ofstream(dir / "chapter1.tex") << "precious";
  const Outcome o = locsim("run " + kDemo + " --duration 1 -q --overwrite --out " + dir.string());
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find("holds no run.json"), std::string::npos) << o.output;
  EXPECT_EQ(testing::read_file(dir / "chapter1.tex"), "precious");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
}

TEST(CappedText, KeepsTheHeadAndTheTailAndCountsWhatWasDropped) {
  CappedText text(4, 3);
  EXPECT_EQ(text.add("ab"), "ab");
  EXPECT_EQ(text.add("cdefg"), "cd");
  EXPECT_EQ(text.dropped_bytes(), 0u);
  EXPECT_EQ(text.add("hijk"), "");
  EXPECT_EQ(text.dropped_bytes(), 4u);  // e, f, g, h
  EXPECT_EQ(text.tail(), "ijk");
  EXPECT_EQ(text.kept(),
            "abcd\n[... 4 bytes of output dropped here: the first 4 and the last 3 are kept "
            "...]\nijk");
  EXPECT_EQ(CappedText(10, 10).kept(), "");
}

TEST(PluginOutput, IsLabelledInOrderAndCappedPerLocalizer) {
  const fs::path out = testing::temp_dir("output") / "out";
  const Outcome o = locsim("run " + kDemo + " --duration 2 -q --localizer " +
                           test_plugin("chatty") + " --out " + out.string());
  ASSERT_EQ(o.exit_code, 0) << o.output.substr(0, 2000);
  EXPECT_NE(o.output.find("[test_chatty] reading 1 at t = "), std::string::npos);
  EXPECT_NE(o.output.find("[test_chatty] stderr: reading 1\n[test_chatty] reading 2 at t"),
            std::string::npos);
  // 3 MiB printed at one second: the first MiB and the last 64 KiB pass, with the count between.
  EXPECT_LT(o.output.size(), (1u << 20) * 12 / 10 + (64u << 10) * 12 / 10);
  EXPECT_NE(o.output.find("bytes of output dropped here"), std::string::npos);
  EXPECT_NE(o.output.find("[test_chatty] after the flood"), std::string::npos);
  const std::string tail = o.output.substr(o.output.size() - 1000);
  EXPECT_NE(tail.find("[test_chatty] reading"), std::string::npos);  // the last prints, at the end
  EXPECT_TRUE(fs::exists(out / "metrics.json"));
  EXPECT_EQ(json::parse(testing::read_file(out / "run.json"))["status"], "completed");
}

TEST(PluginOutput, AnExitInLocsimsOwnProcessIsNoSuccess) {
  // Isolated, exit() fails the localizer alone (Isolation.*); in locsim's own process it ends
  // locsim, which then says so and exits 1 rather than with the plugin's 0.
  const fs::path out = testing::temp_dir("exit") / "out";
  const Outcome o = locsim("run " + kDemo + " --duration 2 -q --isolation none --localizer " +
                           test_plugin("exits") + " --out " + out.string());
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_NE(o.output.find("a localizer plugin called exit() in its update call at t = 1.000 s"),
            std::string::npos)
      << o.output;
}

/// A command refused on its command line: exit 2, a short message naming what is wrong.
void expect_refused(const std::string& arguments, const std::string& says) {
  SCOPED_TRACE(arguments);
  const fs::path out = testing::temp_dir("refused") / "out";
  const Outcome o = locsim(arguments + " --out " + out.string());
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find(says), std::string::npos) << o.output;
  EXPECT_LT(o.output.find_first_of('\n'), 200u) << o.output;  // no 309-digit bound
  EXPECT_FALSE(fs::exists(out));
}

TEST(CliNumbers, OutOfRangeNumbersAreRefusedShortly) {
  const std::string run = "run " + kDemo + " --duration 1 -q ";
  expect_refused(run + "--seed -1", "--seed: must be a whole number in [0, 18446744073709551615]");
  expect_refused(run + "--seed 18446744073709551616", "got 18446744073709551616");
  expect_refused(run + "--seed 1e3", "'1e3' is not a whole number");
  expect_refused(run + "--converged-within-m -1", "--converged-within-m: must be > 0, got -1");
  expect_refused(run + "--converged-within-m inf", "must be a finite number > 0");
  expect_refused(run + "--converged-within-deg nan", "must be a finite number in (0, 180]");
  expect_refused(run + "--converged-hold 0", "must be a whole number in [1, 1000000], got 0");
  expect_refused(run + "--plugin-timeout -1", "must be in [0, 1e+06], got -1");
  expect_refused(run + "--video /tmp/x.mp4 --video-fps 0", "must be in (0, 1000], got 0");
  // A string parameter left empty (as an unset shell variable leaves it) is a mistake too.
  expect_refused(run + "--localizer " + test_plugin("probe") + ":mode=",
                 "--localizer '" + test_plugin("probe") + ":mode=': parameter 'mode' has no value");
  expect_refused("sweep " + kDemo + " -j 0", "--jobs: must be a whole number in [1, 4096], got 0");
}

TEST(CliNumbers, ASeedIsReadInDecimal) {
  const fs::path out = testing::temp_dir("seed") / "out";
  ASSERT_EQ(
      locsim("run " + kDemo + " --duration 0.1 -q --seed 010 --out " + out.string()).exit_code, 0);
  EXPECT_EQ(json::parse(testing::read_file(out / "run.json"))["seed"], 10);
}

TEST(NothingHalfWritten, ABadVideoSizeIsRefusedBeforeAnythingIsMade) {
  const fs::path dir = testing::temp_dir("video");
  for (const std::string size : {"0x0", "1281x720", "640x", "100000x100000"}) {
    expect_refused("run " + kDemo + " --duration 1 -q --video " + (dir / "v.mp4").string() +
                       " --video-size " + size,
                   "--video-size: '" + size + "'");
  }
  EXPECT_FALSE(fs::exists(dir / "v.mp4"));
}

TEST(NothingHalfWritten, AnUnwritableLogIsRefusedBeforeTheRunFolderIsMade) {
  // A missing folder is made (as --out's is); one that cannot be made (in /proc) is refused.
  const fs::path out = testing::temp_dir("log") / "out";
  const Outcome o =
      locsim("run " + kDemo + " --duration 1 -q --log /proc/locsim-none/run.locsimlog --out " +
             out.string());
  // A path no folder can be made at is the command line's fault (exit 2), not the machine's.
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find("cannot write the log /proc/locsim-none/run.locsimlog: cannot make the "
                          "folder '/proc/locsim-none'"),
            std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(out));
}

TEST(NothingHalfWritten, AnUnwritableVideoExitsWith4BeforeTheRunFolderIsMade) {
  const fs::path out = testing::temp_dir("video") / "out";
  const Outcome o = locsim("run " + kDemo +
                           " --duration 1 -q --video-size 320x240 --video /proc/locsim/v.mp4 "
                           "--out " +
                           out.string());
  EXPECT_EQ(o.exit_code, 4) << o.output;
  EXPECT_NE(o.output.find("/proc/locsim/v.mp4"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(out));
}

TEST(NothingHalfWritten, ATruncatedLogIsRefusedBeforeTheReplayFolderIsMade) {
  const fs::path dir = testing::temp_dir("truncated");
  ASSERT_EQ(locsim("run " + kDemo + " --duration 2 -q --out " + (dir / "run").string() + " --log " +
                   (dir / "run.locsimlog").string())
                .exit_code,
            0);
  const std::string bytes = testing::read_file(dir / "run.locsimlog");
  std::ofstream(dir / "cut.locsimlog", std::ios::binary) << bytes.substr(0, bytes.size() - 100);
  const Outcome o = locsim("replay " + (dir / "cut.locsimlog").string() +
                           " -q --localizer odometry --out " + (dir / "replay").string());
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find("cut.locsimlog: truncated"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(dir / "replay"));

  // Corruption inside the log is found where the replay reaches it: run.json says failed and
  // why, and what was written up to there is whole (estimates and metrics agree).
  std::string corrupt = bytes;
  corrupt[corrupt.size() * 2 / 3] = static_cast<char>(corrupt[corrupt.size() * 2 / 3] ^ 0x5a);
  std::ofstream(dir / "corrupt.locsimlog", std::ios::binary) << corrupt;
  const fs::path out = dir / "corrupt";
  const Outcome c = locsim("replay " + (dir / "corrupt.locsimlog").string() +
                           " -q --localizer odometry --out " + out.string());
  EXPECT_EQ(c.exit_code, 2) << c.output;
  const json run = json::parse(testing::read_file(out / "run.json"));
  EXPECT_EQ(run["status"], "failed");
  EXPECT_NE(run["error"].get<std::string>().find("corrupt.locsimlog"), std::string::npos);
  const std::string estimates = testing::read_file(out / "odometry.tum");
  const long samples =
      json::parse(testing::read_file(out / "metrics.json"))["localizers"][0]["samples"];
  EXPECT_EQ(std::count(estimates.begin(), estimates.end(), '\n'), 1 + samples);
}

}  // namespace
}  // namespace locsim
