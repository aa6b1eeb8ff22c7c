// Record and replay: a replay gives the filters exactly what the run gave them; a damaged log is
// refused with a clear message.
#include "sim/run/replay.hpp"

#include <gtest/gtest.h>
#include <sys/resource.h>

#include <cstring>
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

/// What the replay says: "accepted", or the InputError's message.
std::string replay_error(const ReplayOptions& options) {
  try {
    replay_log(options);
  } catch (const InputError& e) {
    return e.what();
  }
  return "accepted";
}

std::string replay_error(const fs::path& log, const fs::path& out) {
  return replay_error(replay_options(log, out));
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

// ---- logs made to be wrong (issue 22; the log fuzzer, tests/fuzz/fuzz_log.cpp, found most)

// One robot with encoders and a 5-beam laser, no other sensor.
constexpr const char* kSmallWorld = R"(name: small
walls: [{points: [[-2, -2], [2, -2], [2, 2], [-2, 2]], closed: true}]
robots:
  - name: r
    start: {x: 0, y: 0, theta: 0}
    sensors:
      encoders: {}
      laser: {beams: 5, fov_deg: 90}
)";

nlohmann::ordered_json small_header() {
  return {{"format", "locsim-log"},     {"locsim_version", "test"}, {"seed", 1},
          {"world_file", "small.yaml"}, {"world_dir", "."},         {"world_yaml", kSmallWorld},
          {"scenario_file", nullptr},   {"scenario_yaml", nullptr}, {"duration_s", 5.0}};
}

/// A finished log of `records` under `header`.
fs::path write_log(const fs::path& file, const nlohmann::ordered_json& header,
                   const std::vector<Record>& records = {}) {
  LogWriter writer(file, header);
  for (const Record& record : records) writer.consume(record);
  writer.finish();
  return file;
}

/// Replayed to the odometry filter only (the small world has no camera for the EKF).
std::string odometry_replay_error(const fs::path& log, const fs::path& out) {
  ReplayOptions options = replay_options(log, out);
  options.localizers = {"odometry"};
  return replay_error(options);
}

long peak_rss_mb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024;
}

TEST(Replay, LengthsBeyondTheFileAreRefusedWithoutAllocatingThem) {
  const fs::path dir = testing::temp_dir("lengths");
  const std::string bytes = testing::read_file(write_log(dir / "ok.locsimlog", small_header()));
  const auto with_u32_at = [&](std::size_t at, std::uint32_t value) {
    std::string b = bytes;
    std::memcpy(b.data() + at, &value, 4);
    return b;
  };
  // The header's length (byte 12) claims 1 GiB, the first record's (after the header) 256 MB;
  // each file is a few hundred bytes.
  const std::uint32_t header_length = static_cast<std::uint32_t>(small_header().dump().size());
  const std::size_t record_length_at = 8 + 4 + 4 + header_length + 4 + 1;
  const long before_mb = peak_rss_mb();
  for (const auto& [name, b, problem] :
       {std::tuple{"header", with_u32_at(12, 1u << 30), "truncated in the header"},
        // Replay checks the end record first (the last bytes), which this length now covers:
        // either refusal reads "truncated", neither allocates.
        std::tuple{"record", with_u32_at(record_length_at, 1u << 28), "truncated"}}) {
    const fs::path file = dir / (std::string(name) + ".locsimlog");
    std::ofstream(file, std::ios::binary) << b;
    const std::string error = odometry_replay_error(file, dir / name);
    EXPECT_NE(error.find(problem), std::string::npos) << error;
  }
  EXPECT_LT(peak_rss_mb() - before_mb, 64)
      << "MB more at the peak for files of a few hundred bytes";
}

TEST(Replay, HeaderFieldsOfAnotherTypeOrRangeAreRefused) {
  const fs::path dir = testing::temp_dir("header");
  const auto error_for = [&](const std::string& name, const nlohmann::ordered_json& header) {
    return odometry_replay_error(write_log(dir / (name + ".locsimlog"), header), dir / name);
  };
  // A valid one first: the changes below are what is refused.
  EXPECT_EQ(error_for("valid", small_header()), "accepted");
  auto no_scenario_file = small_header();
  no_scenario_file["scenario_yaml"] = "name: s\n";
  no_scenario_file.erase("scenario_file");
  EXPECT_NE(error_for("no_scenario_file", no_scenario_file).find("scenario_file"),
            std::string::npos);
  for (const nlohmann::ordered_json& seed :
       {nlohmann::ordered_json(-1), nlohmann::ordered_json(1.5), nlohmann::ordered_json(1e300)}) {
    auto header = small_header();
    header["seed"] = seed;
    EXPECT_NE(error_for("seed", header).find("header: seed is not an unsigned integer"),
              std::string::npos)
        << seed;
  }
  for (const double duration_s : {-5.0, 0.0, std::numeric_limits<double>::infinity()}) {
    auto header = small_header();
    header["duration_s"] = duration_s;
    EXPECT_NE(error_for("duration", header).find("header: duration_s is not a positive number"),
              std::string::npos)
        << duration_s;
  }
}

TEST(Replay, RecordsTheWorldCannotHaveProducedAreRefused) {
  const fs::path dir = testing::temp_dir("records");
  Record encoders;
  encoders.type = Record::Type::kReading;
  encoders.reading.kind = SensorKind::kEncoders;
  encoders.reading.data = OdometryReading{};
  Record laser = encoders;
  laser.reading.kind = SensorKind::kLaser;
  laser.reading.data = LaserScan{std::vector<float>(5, 1.0f)};
  Record truth;
  truth.type = Record::Type::kGroundTruth;
  truth.robot = 0;
  Record event;
  event.type = Record::Type::kEvent;
  event.robot = 0;
  event.event.kind = "push";
  // The same, valid, first: each case below changes one thing.
  EXPECT_EQ(odometry_replay_error(
                write_log(dir / "valid.locsimlog", small_header(), {encoders, laser, truth, event}),
                dir / "valid"),
            "accepted");

  Record other_robot = encoders;
  other_robot.reading.robot = 3;
  Record imu = encoders;
  imu.reading.kind = SensorKind::kImu;
  imu.reading.data = ImuReading{};
  Record ultrasonic = encoders;
  ultrasonic.reading.kind = SensorKind::kUltrasonic;
  ultrasonic.reading.data = UltrasonicReading{{BeaconRange{}}};
  Record beams = laser;
  beams.reading.data = LaserScan{std::vector<float>(6, 1.0f)};
  Record other_truth = truth;
  other_truth.robot = 7;
  Record other_event = event;
  other_event.robot = 2;
  for (const auto& [name, record, problem] :
       {std::tuple{"robot", other_robot, "a reading of robot 3 in a world of 1 robots"},
        std::tuple{"imu", imu, "a reading of the imu, which robot 'r' does not have"},
        std::tuple{"ultrasonic", ultrasonic,
                   "a reading of the ultrasonic, which robot 'r' does not have"},
        std::tuple{"beams", beams, "a laser scan of 6 beams; robot 'r's laser has 5"},
        std::tuple{"truth", other_truth, "a true pose of robot 7 in a world of 1 robots"},
        std::tuple{"event", other_event, "an event about robot 2 in a world of 1 robots"}}) {
    SCOPED_TRACE(name);
    const fs::path log =
        write_log(dir / (std::string(name) + ".locsimlog"), small_header(), {encoders, record});
    const std::string error = odometry_replay_error(log, dir / name);
    EXPECT_NE(error.find(std::string(problem) + " (record 2, byte "), std::string::npos) << error;
    EXPECT_NE(error.find(log.string()), std::string::npos) << error;
  }
}

}  // namespace
}  // namespace locsim
