// Record and replay: a replay gives the filters exactly what the run gave them; a damaged log is
// refused with a clear message.
#include "sim/run/replay.hpp"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>

#include "sim/run/runner.hpp"
#include "sim/stream/log_file.hpp"
#include "sim/stream/record_codec.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;

/// Records 25 s of the demo (one kidnap) with two filters; returns the log's path.
fs::path record(const fs::path& dir, double duration_s = 25.0) {
  RunOptions options;
  options.world_file = fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml";
  options.duration_s = duration_s;
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
  EXPECT_EQ(testing::json_without_timing(dir / "run/metrics.json"),
            testing::json_without_timing(dir / "replay/metrics.json"));
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
  const long before_mb = testing::peak_rss_mb();
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
  EXPECT_LT(testing::peak_rss_mb() - before_mb, 64)
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
  // Inside a scenario's range of durations, as a world file's (1e308 s replayed before).
  for (const double duration_s : {-5.0, 0.0, 1e308, std::numeric_limits<double>::infinity()}) {
    auto header = small_header();
    header["duration_s"] = duration_s;
    const std::string error = error_for("duration", header);
    EXPECT_NE(error.find(std::isfinite(duration_s) ? "header: duration_s: "
                                                   : "header: duration_s is not a number"),
              std::string::npos)
        << duration_s << ": " << error;
  }
  auto not_ours = small_header();
  not_ours["format"] = "nope";
  EXPECT_NE(error_for("format", not_ours).find("header: 'format' is not \"locsim-log\""),
            std::string::npos);
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

TEST(Replay, RecordsTheirSensorsCannotHaveProducedAreRefused) {
  // Two robots; r's encoders report ticks and velocity, its range_bearing sensor sees robots.
  const std::string world = R"(
walls: [{points: [[-3, -3], [3, -3], [3, 3], [-3, 3]], closed: true}]
robots:
  - name: r
    start: {x: 0, y: 0, theta: 0}
    sensors:
      encoders: {reports: [ticks, velocity]}
      range_bearing: {sees_robots: true}
  - name: s
    start: {x: 1.5, y: 0, theta: 0}
)";
  auto header = small_header();
  header["world_yaml"] = world;
  const fs::path dir = testing::temp_dir("contents");
  Record odometry;
  odometry.type = Record::Type::kReading;
  odometry.reading.kind = SensorKind::kEncoders;
  OdometryReading ticks_velocity;
  ticks_velocity.fields = kOdometryTicks | kOdometryVelocity;
  odometry.reading.data = ticks_velocity;
  Record detections = odometry;
  detections.reading.kind = SensorKind::kRangeBearing;
  Detection robot_s{"", 1, 1.5, 0.0, 1, DetectionTarget::kRobot};
  Detection unidentified{"", -1, 1.5, 0.0, -1, DetectionTarget::kRobot};
  // A landmark's id is the localizer's business (a map may lack it).
  Detection landmark{"red", 12, 2.0, 0.0, 12, DetectionTarget::kLandmark};
  detections.reading.data = RangeBearingReading{{robot_s, unidentified, landmark}};
  EXPECT_EQ(odometry_replay_error(
                write_log(dir / "valid.locsimlog", header, {odometry, detections}), dir / "valid"),
            "accepted");

  Record pose_fields = odometry;
  pose_fields.reading.data = OdometryReading{};  // ticks and pose
  Record itself = detections, beyond = detections, negative = detections;
  robot_s.id = 0;
  itself.reading.data = RangeBearingReading{{robot_s}};
  robot_s.id = 2;
  beyond.reading.data = RangeBearingReading{{robot_s}};
  robot_s.id = -3;
  negative.reading.data = RangeBearingReading{{robot_s}};
  for (const auto& [name, record, problem] :
       {std::tuple{"fields", pose_fields,
                   "an odometry reading with fields ticks, pose; robot 'r's encoders report "
                   "ticks, velocity"},
        std::tuple{"itself", itself,
                   "a detection of robot 0 by robot 'r', which is not another robot of the "
                   "world's 2"},
        std::tuple{"beyond", beyond, "a detection of robot 2 by robot 'r'"},
        std::tuple{"negative", negative, "a detection of robot -3 by robot 'r'"}}) {
    SCOPED_TRACE(name);
    const fs::path log =
        write_log(dir / (std::string(name) + ".locsimlog"), header, {odometry, record});
    const std::string error = odometry_replay_error(log, dir / name);
    EXPECT_NE(error.find(std::string(problem)), std::string::npos) << error;
    EXPECT_NE(error.find("(record 2, byte "), std::string::npos) << error;
  }
}

// ---- Log format versions ----------------------------------------------------------------------

std::uint32_t crc32_of(std::uint8_t type, const std::string& payload) {
  uLong c = crc32(0L, Z_NULL, 0);
  c = crc32(c, &type, 1);
  return static_cast<std::uint32_t>(
      crc32(c, reinterpret_cast<const Bytef*>(payload.data()), static_cast<uInt>(payload.size())));
}

/// A reading's payload as version 1 wrote it (docs/log_format.md): odometry without fields and
/// velocity, detections without targets; the other kinds were as they are.
std::string version_1_payload(const Record& record) {
  std::string out;
  const Reading& r = record.reading;
  const auto detections = [&](const std::vector<Detection>& list) {
    put<std::uint32_t>(out, static_cast<std::uint32_t>(list.size()));
    for (const Detection& d : list) {
      put_string(out, d.color);
      put<std::int32_t>(out, d.id);
      put(out, d.range_m), put(out, d.bearing_rad);
      put<std::int32_t>(out, d.truth_id);
    }
  };
  if (record.type == Record::Type::kReading && r.kind == SensorKind::kEncoders) {
    const auto& d = std::get<OdometryReading>(r.data);
    put(out, r.t_s), put<std::uint16_t>(out, static_cast<std::uint16_t>(r.robot));
    put<std::uint8_t>(out, static_cast<std::uint8_t>(r.kind));
    put(out, d.left_ticks), put(out, d.right_ticks);
    put(out, d.odometry.x), put(out, d.odometry.y), put(out, d.odometry.theta);
  } else if (record.type == Record::Type::kReading && r.kind == SensorKind::kPtzCamera) {
    const auto& d = std::get<PtzReading>(r.data);
    put(out, r.t_s), put<std::uint16_t>(out, static_cast<std::uint16_t>(r.robot));
    put<std::uint8_t>(out, static_cast<std::uint8_t>(r.kind));
    put(out, d.pan_rad), put(out, d.tilt_rad), put(out, d.zoom);
    detections(d.detections);
  } else if (record.type == Record::Type::kReading && r.kind == SensorKind::kOmniCamera) {
    put(out, r.t_s), put<std::uint16_t>(out, static_cast<std::uint16_t>(r.robot));
    put<std::uint8_t>(out, static_cast<std::uint8_t>(r.kind));
    detections(std::get<OmniReading>(r.data).detections);
  } else {
    encode_record(record, out);
  }
  return out;
}

/// The log `v2` written byte by byte as version 1 would have written it.
fs::path as_version_1(const fs::path& v2, const fs::path& v1) {
  LogReader reader(v2);
  EXPECT_EQ(reader.version(), 2u);
  std::string bytes = "LOCSIMLG";
  const std::string text = reader.header().dump();
  put<std::uint32_t>(bytes, 1);
  put<std::uint32_t>(bytes, static_cast<std::uint32_t>(text.size()));
  bytes += text;
  put<std::uint32_t>(bytes, crc32_of(0, text));
  const auto frame = [&](Record::Type type, const std::string& payload) {
    put<std::uint8_t>(bytes, static_cast<std::uint8_t>(type));
    put<std::uint32_t>(bytes, static_cast<std::uint32_t>(payload.size()));
    bytes += payload;
    put<std::uint32_t>(bytes, crc32_of(static_cast<std::uint8_t>(type), payload));
  };
  Record record;
  std::uint64_t count = 0;
  while (reader.next(record)) frame(record.type, version_1_payload(record)), ++count;
  std::string end;
  put<std::uint64_t>(end, count);
  frame(Record::Type::kEnd, end);
  std::ofstream(v1, std::ios::binary) << bytes;
  return v1;
}

TEST(LogFormat, AVersion1LogStillReplaysWithTheSameResults) {
  const fs::path dir = testing::temp_dir("version1");
  const fs::path v2 = record(dir, 8.0);
  const fs::path v1 = as_version_1(v2, dir / "v1.locsimlog");
  // The same records: version 1's odometry is ticks and pose, its detections of landmarks.
  LogReader a(v1), b(v2);
  EXPECT_EQ(a.version(), 1u);
  Record ra, rb;
  std::size_t records = 0, odometry = 0, detections = 0;
  while (b.next(rb)) {
    ASSERT_TRUE(a.next(ra));
    std::string ea, eb;
    encode_record(ra, ea);
    encode_record(rb, eb);
    ASSERT_EQ(ea, eb) << "record " << records;
    ++records;
    if (rb.type != Record::Type::kReading) continue;
    if (rb.reading.kind == SensorKind::kEncoders) ++odometry;
    if (const auto* ptz = std::get_if<PtzReading>(&rb.reading.data))
      detections += ptz->detections.size();
  }
  EXPECT_FALSE(a.next(ra));
  EXPECT_GT(odometry, 100u);
  EXPECT_GT(detections, 10u);
  ReplayOptions options = replay_options(v1, dir / "replay1");
  replay_log(options);
  replay_log(replay_options(v2, dir / "replay2"));
  for (const char* file : {"odometry.tum", "ekf.tum", "groundtruth.tum", "events.csv"}) {
    const std::string replayed = testing::read_file(dir / "replay2" / file);
    if (std::string_view(file) != "events.csv") {  // no event in the first 8 s
      EXPECT_GT(replayed.size(), 100u) << file;
    }
    EXPECT_EQ(testing::read_file(dir / "replay1" / file), replayed) << file;
  }
  EXPECT_EQ(testing::json_without_timing(dir / "replay1/metrics.json"),
            testing::json_without_timing(dir / "replay2/metrics.json"));
}

TEST(LogFormat, Version2RoundTripsEveryNewField) {
  const fs::path dir = testing::temp_dir("version2");
  Record velocity;
  velocity.type = Record::Type::kReading;
  velocity.reading = Reading{1.25, 0, SensorKind::kEncoders,
                             OdometryReading{0, 0, {}, 0.3125, -0.0625, kOdometryVelocity}};
  Record all = velocity;
  all.reading.data = OdometryReading{5, -7, {1.5, -2.5, 0.75}, 0.5, 0.25, kOdometryAllFields};
  Record seen = velocity;
  seen.reading.kind = SensorKind::kRangeBearing;
  seen.reading.data =
      RangeBearingReading{{Detection{"red", 4, 2.5, 0.125, 4, DetectionTarget::kLandmark},
                           Detection{"", 1, 1.75, -0.5, 1, DetectionTarget::kRobot}}};
  Record omni = seen;
  omni.reading.kind = SensorKind::kOmniCamera;
  omni.reading.data = OmniReading{std::get<RangeBearingReading>(seen.reading.data).detections};
  const std::vector<Record> records = {velocity, all, seen, omni};
  LogWriter writer(dir / "new.locsimlog", small_header());
  for (const Record& r : records) writer.consume(r);
  writer.finish();
  LogReader reader(dir / "new.locsimlog");
  EXPECT_EQ(reader.version(), kLogFormatVersion);
  Record back;
  for (const Record& r : records) {
    ASSERT_TRUE(reader.next(back));
    EXPECT_EQ(back.reading.kind, r.reading.kind);
    EXPECT_EQ(back.reading.t_s, r.reading.t_s);
    if (const auto* o = std::get_if<OdometryReading>(&r.reading.data)) {
      const auto& b = std::get<OdometryReading>(back.reading.data);
      EXPECT_EQ(b.fields, o->fields);
      EXPECT_EQ(b.left_ticks, o->left_ticks);
      EXPECT_EQ(b.right_ticks, o->right_ticks);
      EXPECT_EQ(b.odometry.x, o->odometry.x);
      EXPECT_EQ(b.odometry.theta, o->odometry.theta);
      EXPECT_EQ(b.v_mps, o->v_mps);
      EXPECT_EQ(b.omega_radps, o->omega_radps);
    } else {
      const auto list = [](const Record& x) {
        if (const auto* rb = std::get_if<RangeBearingReading>(&x.reading.data))
          return rb->detections;
        return std::get<OmniReading>(x.reading.data).detections;
      };
      const auto want = list(r), got = list(back);
      ASSERT_EQ(got.size(), want.size());
      for (std::size_t i = 0; i < want.size(); ++i) {
        EXPECT_EQ(got[i].color, want[i].color);
        EXPECT_EQ(got[i].id, want[i].id);
        EXPECT_EQ(got[i].range_m, want[i].range_m);
        EXPECT_EQ(got[i].bearing_rad, want[i].bearing_rad);
        EXPECT_EQ(got[i].truth_id, want[i].truth_id);
        EXPECT_EQ(got[i].target, want[i].target);
      }
    }
  }
  EXPECT_FALSE(reader.next(back));
  // What version 2 refuses: no fields, unknown fields or targets; version 1 has no range_bearing.
  std::string payload;
  encode_record(velocity, payload);
  const std::size_t fields_at = 8 + 2 + 1;
  const auto refusal = [](const std::string& bytes, std::uint32_t version) -> std::string {
    Record r;
    try {
      decode_record(Record::Type::kReading, bytes, r, version);
    } catch (const DecodeError& e) {
      return e.what();
    }
    return "decoded";
  };
  for (const std::uint8_t fields : {std::uint8_t{0}, std::uint8_t{8}}) {
    std::string bad = payload;
    bad[fields_at] = static_cast<char>(fields);
    EXPECT_NE(refusal(bad, 2).find("odometry fields"), std::string::npos) << int{fields};
  }
  payload.clear();
  encode_record(seen, payload);
  EXPECT_EQ(refusal(payload, 2), "decoded");
  EXPECT_NE(refusal(payload, 1).find("unknown sensor kind 6"), std::string::npos);
  std::string bad_target = payload;
  bad_target.back() = 2;  // the last detection's target
  EXPECT_NE(refusal(bad_target, 2).find("unknown detection target 2"), std::string::npos);
}

}  // namespace
}  // namespace locsim
