// Input from someone else (a log, a dataset) reads nothing outside itself and cannot flood or
// steer the terminal through a message; a command never destroys what it reads (issue 49).
#include <gtest/gtest.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "sim/common/base64.hpp"
#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/producers/text_table.hpp"
#include "sim/run/replay.hpp"
#include "sim/run/runner.hpp"
#include "sim/stream/log_file.hpp"
#include "sim/world/world_budget.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;
using testing::expect_contains;

// ---- messages -------------------------------------------------------------------------------

TEST(UntrustedText, QuotedEscapesWhatATerminalWouldObeyAndKeepsUtf8) {
  EXPECT_EQ(quote_input("plain"), "'plain'");
  EXPECT_EQ(quote_input("\x1b[2Jwiped"), "'\\x1b[2Jwiped'");
  EXPECT_EQ(quote_input("a\nb\tc\x7f"), "'a\\x0ab\\x09c\\x7f'");
  EXPECT_EQ(quote_input("Stra\xc3\x9f"
                        "e \xe2\x82\xac"),
            "'Stra\xc3\x9f"
            "e \xe2\x82\xac'");
  // A C1 control (U+009B, CSI on some terminals), a lone continuation byte, an overlong encoding
  // and a sequence cut short.
  EXPECT_EQ(quote_input("\xc2\x9b"
                        "1m"),
            "'\\xc2\\x9b1m'");
  EXPECT_EQ(quote_input("\x80"), "'\\x80'");
  EXPECT_EQ(quote_input("\xc0\xaf"), "'\\xc0\\xaf'");
  EXPECT_EQ(quote_input("\xe2\x82"), "'\\xe2\\x82'");
  EXPECT_EQ(quote_input(std::string(1000, 'x'), 10), "'xxxxxxxxxx' (and 990 bytes more)");
}

TEST(UntrustedText, AHugeMessageIsCutInTheMiddleKeepingWhereAndWhy) {
  const std::string middle(50 << 20, 'y');
  const std::string message = "data.csv:3:1: " + middle + " is not a number";
  const std::string shown = printable(message);
  EXPECT_LE(shown.size(), kMaxMessageBytes + 64);
  EXPECT_EQ(shown.rfind("data.csv:3:1: ", 0), 0u);
  EXPECT_TRUE(shown.ends_with(" is not a number")) << shown.substr(shown.size() - 80);
  expect_contains(shown, "bytes cut");
  // Every error type passes its message through it.
  EXPECT_LE(std::string(InputError(message).what()).size(), kMaxMessageBytes + 64);
  EXPECT_EQ(std::string(PluginError("x\x1b]0;owned\x07").what()), "x\\x1b]0;owned\\x07");
  EXPECT_EQ(printable("line 1\nline 2\ttab"), "line 1\nline 2\ttab");
}

TEST(UntrustedText, ADatasetsFieldReachesTheMessageEscapedAndCut) {
  const fs::path dir = testing::temp_dir("tum");
  // A TUM file whose first field is 1 MB long and carries escape sequences.
  const std::string field = "\x1b[31m" + std::string(1 << 20, '9') + "\x1b]0;title\x07";
  std::ofstream(dir / "truth.tum") << field << " 0 0 0 0 0 0 1\n";
  try {
    read_tum(dir / "truth.tum");
    FAIL() << "accepted";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_LT(message.size(), 1024u) << "the field is quoted in part only";
    EXPECT_EQ(message.find('\x1b'), std::string::npos);
    expect_contains(message, "truth.tum:1:1");
    expect_contains(message, "'\\x1b[31m999");
    expect_contains(message, "bytes more) is not a number");
  }
}

TEST(UntrustedText, AYamlValueReachesTheMessageEscaped) {
  try {
    testing::world_from_yaml("name: w\nphysics: {step_hz: \"\\e[2J\\e[H\"}\n");
    FAIL() << "accepted";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.find('\x1b'), std::string::npos) << message;
    expect_contains(message, "'\\x1b[2J\\x1b[H'");
  }
}

TEST(Base64, RoundTripsEveryLengthAndRefusesWhatIsNotCanonical) {
  std::string bytes;
  for (int n = 0; n < 300; ++n) {
    ASSERT_EQ(base64_decode(base64_encode(bytes)), bytes) << n;
    bytes += static_cast<char>((n * 37 + 11) & 255);
  }
  EXPECT_EQ(base64_encode("foobar"), "Zm9vYmFy");
  EXPECT_EQ(base64_encode("fo"), "Zm8=");
  EXPECT_EQ(base64_encode("f"), "Zg==");
  for (const char* bad : {"Zg=", "Zg=a", "Z===", "====", "Zh==", "Zm9=", "Zm 8", "Zm8\n"})
    EXPECT_FALSE(base64_decode(bad)) << bad;
}

TEST(InputFiles, AFifoOrADeviceIsRefusedInsteadOfBlocking) {
  const fs::path dir = testing::temp_dir("fifo");
  ASSERT_EQ(::mkfifo((dir / "world.yaml").c_str(), 0600), 0);
  for (const fs::path& file : {dir / "world.yaml", fs::path("/dev/zero")}) {
    try {
      read_input_file(file, 1 << 20);
      FAIL() << file;
    } catch (const InputError& e) {
      expect_contains(e.what(), "is not a regular file");
    }
  }
}

// ---- limits that hold --------------------------------------------------------------------

TEST(Limits, ASmallWorldThatWouldNeedGigabytesIsRefusedBeforeItIsBuilt) {
  // 2000 movers sharing one 40 000-point path through a YAML alias: 400 KB of text, each mover
  // its own copy (it took 3.8 GB to validate); 1600 robots with 100 000-beam lasers.
  std::string movers = "name: w\nmovers:\n  - {name: m0, path: &p [";
  for (int i = 0; i < 40000; ++i) movers += (i ? ", [" : "[") + std::to_string(i * 0.02) + ", 0]";
  movers += "]}\n";
  for (int i = 1; i < 2000; ++i) movers += "  - {name: m" + std::to_string(i) + ", path: *p}\n";
  movers += "robots: [{name: r, start: {x: 0, y: 5, theta: 0}}]\n";
  std::string lasers = "name: w\nrobots:\n";
  for (int i = 0; i < 1600; ++i) {
    lasers += "  - {name: r" + std::to_string(i) + ", start: {x: " + std::to_string(i) +
              ", y: 0, theta: 0}, sensors: {laser: {beams: 100000}}}\n";
  }
  const long before_mb = testing::peak_rss_mb();
  for (const auto& [yaml, key] : {std::pair{movers, "'movers'"}, std::pair{lasers, "robots["}}) {
    try {
      testing::world_from_yaml(yaml);
      FAIL() << key << " accepted";
    } catch (const InputError& e) {
      expect_contains(e.what(), key);
      expect_contains(e.what(), "a world may need at most 1 GiB");
    }
  }
  EXPECT_LT(testing::peak_rss_mb() - before_mb, 1024) << "MB more at the peak, to refuse them";
}

TEST(Limits, AMoversPathCostsARunNoMoreThanTheBudgetCounts) {
  // The budget counts kPathPointBytes a point before a world is built; a run's peak (the walker's
  // tables, run.json's copy of the world) must stay under it, or a world the check passes can
  // still need gigabytes (700 movers sharing a 10 000-point path took 2.2 GB against 448 MB).
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
  GTEST_SKIP() << "AddressSanitizer's quarantine keeps freed memory: the peak is not the run's";
#endif
#endif
  const fs::path dir = testing::temp_dir("movers");
  const auto world = [&](int movers, int points) {
    std::string yaml = "name: w\nmovers:\n  - {name: m0, path: &p [";
    for (int i = 0; i < points; ++i)
      yaml += (i ? ", [" : "[") + std::to_string(1 + 8 * (i % 2)) + ", 0.5]";
    yaml += "]}\n";
    for (int i = 1; i < movers; ++i) yaml += "  - {name: m" + std::to_string(i) + ", path: *p}\n";
    yaml += "robots: [{name: r, start: {x: 0.5, y: 7.8, theta: 0}}]\n";
    const fs::path file = dir / ("w" + std::to_string(movers) + ".yaml");
    std::ofstream(file) << yaml;
    return file;
  };
  const auto peak_kb = [&](const fs::path& file) {
    const testing::Measured m = testing::run_measured(
        std::string(LOCSIM_BINARY) + " run " + file.string() + " --duration 0.1 -q --no-readings " +
        "--localizer odometry --out " + (dir / file.stem()).string());
    EXPECT_EQ(m.exit_code, 0) << file;
    return m.peak_kb;
  };
  constexpr int kMovers = 100, kPoints = 5000;
  const long small_kb = peak_kb(world(1, 2));
  const long large_kb = peak_kb(world(kMovers, kPoints));
  const double bytes_per_point =
      static_cast<double>(large_kb - small_kb) * 1024.0 / (kMovers * kPoints);
  EXPECT_LT(bytes_per_point, static_cast<double>(kPathPointBytes));
  std::printf("a run: %.0f bytes per mover's path point at the peak\n", bytes_per_point);
}

TEST(Limits, ARunThatWouldFillTheDiskIsRefusedBeforeItStarts) {
  const fs::path dir = testing::temp_dir("output");
  std::ofstream(dir / "fast_laser.yaml")
      << "name: w\nphysics: {step_hz: 10000}\nrobots:\n  - name: r\n    start: {x: 0, y: 0, "
         "theta: 0}\n    sensors: {laser: {beams: 100000, rate_hz: 10000}}\n";
  const testing::Outcome fast =
      testing::locsim("run " + (dir / "fast_laser.yaml").string() + " --duration 60 -q --out " +
                      (dir / "fast").string());
  EXPECT_EQ(fast.exit_code, 2) << fast.output;
  expect_contains(fast.output, "fast_laser.yaml:");
  expect_contains(fast.output, "robots[0].sensors.laser");
  expect_contains(fast.output, "--max-output-gib");
  EXPECT_FALSE(fs::exists(dir / "fast"));
  // Allowed past the bound, it is still more than any disk here holds.
  const testing::Outcome allowed = testing::locsim(
      "run " + (dir / "fast_laser.yaml").string() +
      " --duration 60 -q --max-output-gib 1000000 --out " + (dir / "fast").string());
  EXPECT_EQ(allowed.exit_code, 1) << allowed.output;  // the disk's state: not the input's fault
  expect_contains(allowed.output, "free on the disk of");
  const testing::Outcome long_run = testing::locsim(
      "run " + testing::kDemo + " --duration 1e7 -q --out " + (dir / "long").string());
  EXPECT_EQ(long_run.exit_code, 2) << long_run.output;
  expect_contains(long_run.output, "the run would write about");
  EXPECT_FALSE(fs::exists(dir / "long"));
}

// ---- a replay reads nothing but its log ----------------------------------------------------

constexpr const char* kSecret = "SECRET-7f3a-do-not-read";

/// A world whose map is `map` (a path as written in the world file).
std::string world_with_map(const std::string& map) {
  return "name: w\nmap: " + map +
         "\nrobots:\n  - name: r\n    start: {x: 1, y: 1, theta: 0}\n    sensors: {encoders: {}}\n";
}

nlohmann::ordered_json header_of(const std::string& world_yaml, const fs::path& world_dir) {
  return {{"format", "locsim-log"},   {"locsim_version", "test"}, {"seed", 1},
          {"world_file", "w.yaml"},   {"world_dir", world_dir},   {"world_yaml", world_yaml},
          {"scenario_file", nullptr}, {"scenario_yaml", nullptr}, {"duration_s", 1.0}};
}

/// What a replay of `log` to the odometry filter says: "accepted", or the error's message.
std::string odometry_replay(const fs::path& log, const fs::path& out) {
  ReplayOptions options;
  options.log_file = log;
  options.out_dir = out;
  options.localizers = {"odometry"};
  try {
    replay_log(options);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "accepted";
}

TEST(ReplayReadsOnlyItsLog, AMapNamedAnyWayOutsideTheLogIsRefusedUnread) {
  const fs::path dir = testing::temp_dir("secret");
  // A valid map beside a secret: a replay that read the disk would run on it, or quote it.
  fs::create_directories(dir / "planted" / "deep");
  std::ofstream(dir / "planted" / "secret.yaml")
      << "image: " << kSecret << ".pgm\nresolution: 0.1\norigin: [0, 0, 0]\n";
  std::ofstream(dir / "planted" / "map.yaml")
      << "image: map.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n";
  std::ofstream(dir / "planted" / "map.pgm", std::ios::binary) << "P5 4 4 255\n"
                                                               << std::string(16, '\xff');
  const fs::path world_dir = dir / "planted" / "deep";
  for (const auto& [name, map] :
       {std::pair{"absolute", (dir / "planted" / "secret.yaml").string()},
        std::pair{"absolute_valid", (dir / "planted" / "map.yaml").string()},
        std::pair{"dotdot", std::string("../secret.yaml")},
        std::pair{"dotdot_valid", std::string("../map.yaml")},
        std::pair{"proc", std::string("/proc/self/cmdline")},
        std::pair{"stdin", std::string("/dev/stdin")}}) {
    SCOPED_TRACE(name);
    const fs::path log = dir / (std::string(name) + ".locsimlog");
    {
      LogWriter writer(log, header_of(world_with_map(map), world_dir));
      writer.finish();
    }
    const std::string error = odometry_replay(log, dir / (std::string(name) + "_out"));
    expect_contains(error, "not carried by the log");
    EXPECT_EQ(error.find(kSecret), std::string::npos) << error;
    EXPECT_FALSE(fs::exists(dir / (std::string(name) + "_out")));
  }
  // A map the header carries under a path that resolves outside its folder is still only the
  // carried bytes: the file planted there is not read.
  auto header = header_of(world_with_map("../secret.yaml"), world_dir);
  header["files"] = {{(dir / "planted" / "secret.yaml").string(),
                      base64_encode("image: carried.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n")},
                     {(dir / "planted" / "carried.pgm").string(),
                      base64_encode("P5 4 4 255\n" + std::string(16, '\xff'))}};
  const fs::path carried = dir / "carried.locsimlog";
  {
    LogWriter writer(carried, header);
    writer.finish();
  }
  EXPECT_EQ(odometry_replay(carried, dir / "carried_out"), "accepted");
  for (const auto& [field, value] : {std::pair{"files", nlohmann::ordered_json("x")},
                                     std::pair{"files", nlohmann::ordered_json({{"a", 1}})},
                                     std::pair{"files", nlohmann::ordered_json({{"a", "Zg="}})}}) {
    auto bad = header;
    bad[field] = value;
    const fs::path log = dir / "bad_files.locsimlog";
    {
      LogWriter writer(log, bad);
      writer.finish();
    }
    expect_contains(odometry_replay(log, dir / "bad_out"), "header: files");
  }
}

TEST(ReplayReadsOnlyItsLog, AHeaderFieldMissingOrOfAnotherTypeIsNamed) {
  const fs::path dir = testing::temp_dir("header_fields");
  const std::string world =
      "name: w\nrobots:\n  - name: r\n    start: {x: 1, y: 1, theta: 0}\n"
      "    sensors: {encoders: {}}\n";
  for (const auto& [field, value, problem] :
       {std::tuple{"world_yaml", nlohmann::ordered_json(12), "'world_yaml' is not a string"},
        std::tuple{"world_yaml", nlohmann::ordered_json(nullptr), "'world_yaml' is not a string"},
        std::tuple{"world_dir", nlohmann::ordered_json::array(), "'world_dir' is not a string"},
        std::tuple{"scenario_yaml", nlohmann::ordered_json(3), "'scenario_yaml' is not a string"},
        std::tuple{"seed", nlohmann::ordered_json("7"), "seed is not an unsigned integer"}}) {
    SCOPED_TRACE(field);
    auto header = header_of(world, dir);
    header[field] = value;
    const fs::path log = dir / "bad.locsimlog";
    {
      LogWriter writer(log, header);
      writer.finish();
    }
    const std::string error = odometry_replay(log, dir / "out");
    expect_contains(error, problem);
    EXPECT_EQ(error.find("json.exception"), std::string::npos) << error;
  }
  auto header = header_of(world, dir);
  header.erase("duration_s");
  const fs::path log = dir / "missing.locsimlog";
  {
    LogWriter writer(log, header);
    writer.finish();
  }
  expect_contains(odometry_replay(log, dir / "out"), "lacks the field 'duration_s'");
}

TEST(ReplayReadsOnlyItsLog, ALogCarriesItsMapAndReplaysWithoutTheWorldsFolder) {
  const fs::path dir = testing::temp_dir("carried");
  // The office map world, copied so that its folder can be removed after the recording.
  fs::copy(fs::path(LOCSIM_SOURCE_DIR) / "worlds/maps", dir / "maps");
  RunOptions run;
  run.world_file = dir / "maps" / "office_world.yaml";
  run.duration_s = 3.0;
  run.out_dir = dir / "run";
  run.localizers = {"odometry"};
  run.log_file = dir / "office.locsimlog";
  run_simulation(run);
  fs::remove_all(dir / "maps");
  ReplayOptions replay;
  replay.log_file = *run.log_file;
  replay.out_dir = dir / "replay";
  replay.localizers = {"odometry"};
  replay_log(replay);
  for (const char* file : {"groundtruth.tum", "odometry.tum", "events.csv"}) {
    EXPECT_EQ(testing::read_file(dir / "run" / file), testing::read_file(dir / "replay" / file))
        << file;
  }
}

TEST(ReplayReadsOnlyItsLog, RecordsOutOfAWorldFilesRangesOrOutOfOrderAreRefused) {
  const fs::path dir = testing::temp_dir("ranges");
  const std::string world =
      "name: w\nrobots:\n  - name: r\n    start: {x: 1, y: 1, theta: 0}\n"
      "    sensors: {encoders: {}}\n";
  const auto truth = [](double t_s, Pose2 pose) {
    Record r;
    r.type = Record::Type::kGroundTruth;
    r.t_s = t_s;
    r.robot = 0;
    r.pose = pose;
    return r;
  };
  Record odometry;
  odometry.type = Record::Type::kReading;
  odometry.reading.t_s = 0.5;
  odometry.reading.kind = SensorKind::kEncoders;
  odometry.reading.data =
      OdometryReading{.odometry = {std::numeric_limits<double>::infinity(), 0, 0}};
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Record ok = truth(0.0, {1, 1, 0});
  // Events as no simulation writes them: events.csv would get a row split by the kind's comma
  // and newline, a terminal the ESC sequences.
  const auto event = [](std::string kind, std::string details) {
    Record r;
    r.type = Record::Type::kEvent;
    r.event = {.step = 1,
               .t_s = 0.5,
               .kind = std::move(kind),
               .robot = "r",
               .details = std::move(details)};
    return r;
  };
  for (const auto& [name, records, problem] :
       {std::tuple{"nan_time", std::vector{ok, truth(nan, {1, 1, 0})}, "its time: nan"},
        std::tuple{"far", std::vector{ok, truth(1.0, {1e30, 1, 0})}, "a true pose's x: 1e+30 m"},
        std::tuple{"backward", std::vector{ok, truth(1.0, {1, 1, 0}), truth(0.5, {1, 1, 0})},
                   "its time 0.5 s is before the previous record's 1 s"},
        std::tuple{"conflict", std::vector{ok, truth(1.0, {1, 1, 0}), truth(1.0, {2, 1, 0})},
                   "a second true pose of robot 0 at 1 s"},
        std::tuple{"odometry", std::vector{ok, odometry}, "an odometry pose's x: inf m"},
        std::tuple{"event_kind", std::vector{ok, event("a,b\nc\"d", "")},
                   "an event of unknown kind"},
        std::tuple{"event_escape", std::vector{ok, event("push", std::string(3, '\x1b') + "[2J")},
                   "an event's details"},
        std::tuple{"event_huge", std::vector{ok, event("push", std::string(60000, 'x'))},
                   "an event's details of 60000 bytes"},
        std::tuple{"event_ok", std::vector{ok, event("push", "force_n=1")}, "accepted"},
        std::tuple{"duplicate", std::vector{ok, truth(1.0, {1, 1, 0}), truth(1.0, {1, 1, 0})},
                   "accepted"}}) {
    SCOPED_TRACE(name);
    const fs::path log = dir / (std::string(name) + ".locsimlog");
    {
      LogWriter writer(log, header_of(world, dir));
      for (const Record& record : records) writer.consume(record);
      writer.finish();
    }
    const std::string error = odometry_replay(log, dir / (std::string(name) + "_out"));
    expect_contains(error, problem);
    if (std::string(problem) != "accepted") {
      expect_contains(error, "(record " + std::to_string(records.size()) + ", byte ");
    }
  }
}

// ---- a command never destroys what it reads --------------------------------------------------

/// Records `duration_s` of the demo into the folder `out` and the log `log`.
RunOptions record_demo(double duration_s, const fs::path& out, const fs::path& log) {
  RunOptions run;
  run.world_file = testing::kDemo;
  run.duration_s = duration_s;
  run.out_dir = out;
  run.log_file = log;
  fs::create_directories(out);
  run_simulation(run);
  return run;
}

TEST(InputsSurvive, ReplayOverwritingTheFolderItsLogIsInKeepsTheLog) {
  const fs::path dir = testing::temp_dir("keep");
  const RunOptions run = record_demo(2.0, dir / "R", dir / "R" / "rec.locsimlog");
  const std::string recorded = testing::read_file(*run.log_file);
  // A Python filter and a params file in the folder too.
  fs::copy_file(fs::path(LOCSIM_SOURCE_DIR) / "tests/python_plugins/py_noop.py",
                dir / "R" / "mine.py");
  std::ofstream(dir / "R" / "params.yaml") << "localizer_params: {}\n";
  for (int round = 0; round < 2; ++round) {
    ReplayOptions replay;
    replay.log_file = *run.log_file;
    replay.out_dir = dir / "R";
    replay.overwrite = true;
    replay.params_file = dir / "R" / "params.yaml";
    replay.localizers = {"odometry", "python:" + (dir / "R" / "mine.py").string()};
    replay_log(replay);
    EXPECT_EQ(testing::read_file(*run.log_file), recorded) << round;
    EXPECT_TRUE(fs::exists(dir / "R" / "mine.py"));
    EXPECT_TRUE(fs::exists(dir / "R" / "params.yaml"));
    EXPECT_TRUE(fs::exists(dir / "R" / "odometry.tum"));
  }
}

TEST(InputsSurvive, AnInputWhosePathCannotBeResolvedIsKeptByItsName) {
  // A log read through /proc/self/fd/N of a memfd: the link names a file no path reaches, so
  // resolving it fails; --overwrite must still run (the fuzzer replays this way).
  const fs::path dir = testing::temp_dir("memfd");
  const RunOptions run = record_demo(1.0, dir / "R", dir / "rec.locsimlog");
  const std::string recorded = testing::read_file(*run.log_file);
  const int fd = memfd_create("locsim_test_log", 0);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(write(fd, recorded.data(), recorded.size()), static_cast<ssize_t>(recorded.size()));
  for (int round = 0; round < 2; ++round) {
    ReplayOptions replay;
    replay.log_file = "/proc/self/fd/" + std::to_string(fd);
    replay.out_dir = dir / "M";
    replay.overwrite = true;
    replay.localizers = {"odometry"};
    EXPECT_NO_THROW(replay_log(replay)) << round;
    EXPECT_TRUE(fs::exists(dir / "M" / "odometry.tum")) << round;
  }
  close(fd);
}

TEST(InputsSurvive, AnInputWhereTheRunWritesOrAnOutputOntoAnInputIsRefused) {
  const fs::path dir = testing::temp_dir("refuse");
  const RunOptions run = record_demo(1.0, dir / "R", dir / "rec.locsimlog");
  // --params at a name the run writes (its own metrics.json) would be overwritten.
  std::ofstream(dir / "R" / "metrics.json") << "{}\n";
  const std::string metrics = testing::read_file(dir / "R" / "metrics.json");
  ReplayOptions replay;
  replay.log_file = *run.log_file;
  replay.out_dir = dir / "R";
  replay.overwrite = true;
  replay.params_file = dir / "R" / "metrics.json";
  replay.localizers = {"odometry"};
  try {
    replay_log(replay);
    FAIL() << "accepted";
  } catch (const InputError& e) {
    expect_contains(e.what(), "where the run writes a file of that name");
  }
  EXPECT_EQ(testing::read_file(dir / "R" / "metrics.json"), metrics);
  EXPECT_TRUE(fs::exists(dir / "R" / "events.csv")) << "nothing emptied";

  // --log onto the world file, through another name (a symbolic link).
  fs::copy_file(testing::kDemo, dir / "world.yaml");
  fs::create_symlink(dir / "world.yaml", dir / "link.yaml");
  const std::string world = testing::read_file(dir / "world.yaml");
  RunOptions onto;
  onto.world_file = dir / "world.yaml";
  onto.duration_s = 1.0;
  onto.out_dir = dir / "S";
  onto.log_file = dir / "link.yaml";
  try {
    run_simulation(onto);
    FAIL() << "accepted";
  } catch (const InputError& e) {
    expect_contains(e.what(), "--log: ");
    expect_contains(e.what(), "which this command reads");
  }
  EXPECT_EQ(testing::read_file(dir / "world.yaml"), world);
  EXPECT_FALSE(fs::exists(dir / "S"));
}

}  // namespace
}  // namespace locsim
