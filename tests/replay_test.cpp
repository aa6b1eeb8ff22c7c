// Record and replay: a replay gives the filters exactly what the run gave them; a damaged log is
// refused with a clear message.
#include "sim/run/replay.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "sim/run/runner.hpp"
#include "sim/stream/log_file.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;

std::string without_timing(const fs::path& file) {
  auto j = nlohmann::ordered_json::parse(testing::read_file(file));
  j.erase("timing");
  return j.dump();
}

/// Records 12 s of the demo (one kidnap) with two filters; returns the log's path.
fs::path record(const fs::path& dir) {
  RunOptions options;
  options.world_file = fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml";
  options.duration_s = 25.0;
  options.seed = 4;
  options.out_dir = dir / "run";
  options.localizers = {"odometry", "ekf_landmarks:sigma_bearing_deg=2@ekf"};
  options.log_file = dir / "demo.locsimlog";
  run_simulation(options);
  return *options.log_file;
}

ReplayOptions replay_options(const fs::path& log, const fs::path& out) {
  ReplayOptions options;
  options.log_file = log;
  options.out_dir = out;
  options.localizers = {"odometry", "ekf_landmarks:sigma_bearing_deg=2@ekf"};
  return options;
}

TEST(Replay, GivesTheFiltersExactlyWhatTheRunGaveThem) {
  const fs::path dir = testing::temp_dir("replay");
  const fs::path log = record(dir);
  const ReplayResult result = replay_log(replay_options(log, dir / "replay"));
  EXPECT_DOUBLE_EQ(result.replayed_s, 25.0);
  for (const char* file : {"odometry.tum", "ekf.tum", "groundtruth.tum", "events.csv"}) {
    const std::string original = testing::read_file(dir / "run" / file);
    EXPECT_GT(original.size(), 100u) << file;
    EXPECT_EQ(original, testing::read_file(dir / "replay" / file)) << file;
  }
  EXPECT_EQ(without_timing(dir / "run/metrics.json"), without_timing(dir / "replay/metrics.json"));
  // Other parameters on the same log: a different estimate from the same readings.
  ReplayOptions other = replay_options(log, dir / "other");
  other.localizers = {"ekf_landmarks:sigma_bearing_deg=6@ekf"};
  replay_log(other);
  EXPECT_NE(testing::read_file(dir / "run/ekf.tum"), testing::read_file(dir / "other/ekf.tum"));
}

std::string replay_error(const fs::path& log, const fs::path& out) {
  try {
    replay_log(replay_options(log, out));
  } catch (const InputError& e) {
    return e.what();
  }
  return "accepted";
}

TEST(Replay, CorruptTruncatedAndForeignFilesAreRefusedClearly) {
  const fs::path dir = testing::temp_dir("replay");
  const fs::path log = record(dir);
  std::string bytes = testing::read_file(log);

  std::string corrupt = bytes;
  corrupt[corrupt.size() / 2] = static_cast<char>(corrupt[corrupt.size() / 2] ^ 0x5a);
  std::ofstream(dir / "corrupt.locsimlog", std::ios::binary) << corrupt;
  const std::string corrupt_error = replay_error(dir / "corrupt.locsimlog", dir / "out1");
  EXPECT_NE(corrupt_error.find("corrupt.locsimlog: "), std::string::npos) << corrupt_error;
  EXPECT_TRUE(corrupt_error.find("checksum mismatch") != std::string::npos ||
              corrupt_error.find("corrupt record length") != std::string::npos)
      << corrupt_error;

  std::ofstream(dir / "short.locsimlog", std::ios::binary)
      << bytes.substr(0, bytes.size() * 7 / 10);
  const std::string short_error = replay_error(dir / "short.locsimlog", dir / "out2");
  EXPECT_NE(short_error.find("truncated"), std::string::npos) << short_error;

  std::ofstream(dir / "text.locsimlog") << "hello";
  EXPECT_NE(replay_error(dir / "text.locsimlog", dir / "out3").find("not a locsim log"),
            std::string::npos);
  EXPECT_NE(replay_error(dir / "missing.locsimlog", dir / "out4").find("no such file"),
            std::string::npos);

  std::string header = bytes;
  header[20] = static_cast<char>(header[20] ^ 1);  // inside the JSON header
  std::ofstream(dir / "header.locsimlog", std::ios::binary) << header;
  EXPECT_NE(replay_error(dir / "header.locsimlog", dir / "out5").find("header checksum mismatch"),
            std::string::npos);
}

TEST(Replay, AnInterruptedRecordingReadsAsTruncated) {
  const fs::path dir = testing::temp_dir("replay");
  const fs::path log = dir / "cut.locsimlog";
  {
    LogWriter writer(log, {{"format", "locsim-log"}});
    Record truth;
    truth.type = Record::Type::kGroundTruth;
    truth.robot = 0;
    truth.pose = Pose2{1, 2, 3};
    writer.consume(truth);
  }  // no finish(): as a run killed mid-way leaves it
  LogReader reader(log);
  Record got;
  EXPECT_TRUE(reader.next(got));
  EXPECT_EQ(got.pose, (Pose2{1, 2, 3}));
  try {
    reader.next(got);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("truncated after 1 records: no end record"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace locsim
