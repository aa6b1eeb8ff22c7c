// Importers of real datasets (`locsim import`): small files in MRCLAM's format with exactly known
// truth are imported, and the log is read back as `locsim replay` reads it; every kind of bad
// input is refused naming file, line and column, leaving nothing written.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "sim/common/errors.hpp"
#include "sim/producers/generic_import.hpp"
#include "sim/producers/log_source.hpp"
#include "sim/producers/mrclam_import.hpp"
#include "sim/run/replay.hpp"
#include "test_support.hpp"
#include "tests/noisy_world.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;

constexpr double kT0 = 1248444000.0;  // Unix time of the first Vicon sample
constexpr double kV = 0.2, kW = 0.1;  // robot 1's arc [m/s, rad/s]
const Pose2 kStart1{1.0, 0.0, 0.0};
const Pose2 kPose2{3.0, 1.0, 0.0};  // robot 2 stands still
const Vec2 kLandmark6{4.0, 0.0}, kLandmark7{4.0, 2.0};

Pose2 robot1_at(double t) {
  const double theta = kStart1.theta + kW * t;
  return {kStart1.x + kV / kW * (std::sin(theta) - std::sin(kStart1.theta)),
          kStart1.y - kV / kW * (std::cos(theta) - std::cos(kStart1.theta)), theta};
}

std::pair<double, double> range_bearing(const Pose2& from, const Vec2& to) {
  const double dx = to.x() - from.x, dy = to.y() - from.y;
  return {std::hypot(dx, dy), wrap_angle(std::atan2(dy, dx) - from.theta)};
}

constexpr const char* kHeader =
    "# UTIAS Multi-Robot Cooperative Localization and Mapping Dataset\n"
    "# produced by Keith Leung (keith.leung@robotics.utias.utoronto.ca) 2009\n"
    "# Data Fomat:\n"
    "# columns\n";
constexpr int kHeaderLines = 4;

std::string line(const char* format, auto... values) {
  char text[256];
  std::snprintf(text, sizeof(text), format, values...);
  return text;
}

/// Four seconds of MRCLAM-format data: robot 1 drives an arc past landmarks 6 and 7 and sees
/// robot 2 once and an unknown barcode once; robot 2 stands and sees landmark 6.
fs::path write_dataset(const fs::path& dir) {
  std::ofstream(dir / "Barcodes.dat") << kHeader
                                      << "  1 \t   5 \n  2 \t  14 \n  3 \t  41 \n  4 \t  32 \n"
                                         "  5 \t  23 \n  6 \t  63 \n  7 \t  81 \n";
  std::ofstream(dir / "Landmark_Groundtruth.dat")
      << kHeader
      << "  6 \t 4.0 \t 0.0 \t 0.0001 \t 0.0002 \n  7 \t 4.0 \t 2.0 \t 0.0001 \t 0.0002 \n";
  std::string odometry1 = kHeader, truth1 = kHeader, measurements1 = kHeader;
  for (int i = 1; i <= 200; ++i)  // 50 Hz from 0.02 s
    odometry1 += line("%.3f \t %.3f \t %.3f \n", kT0 + 0.02 * i, kV, kW);
  for (int i = 0; i <= 400; ++i) {  // 100 Hz from 0 s
    const Pose2 p = robot1_at(0.01 * i);
    truth1 += line("%.3f \t %.8f \t %.8f \t %.8f \n", kT0 + 0.01 * i, p.x, p.y, p.theta);
  }
  for (int i = 0; i < 8; ++i) {
    const double t = 0.25 + 0.5 * i;
    for (const auto& [barcode, where] : {std::pair{63, kLandmark6}, {81, kLandmark7}}) {
      const auto [r, b] = range_bearing(robot1_at(t), where);
      measurements1 += line("%.3f \t %d \t %.6f \t %.6f \n", kT0 + t, barcode, r, b);
    }
    if (i == 2) {  // robot 2 (barcode 14), then a misread barcode
      const auto [r, b] = range_bearing(robot1_at(t), kPose2.position());
      measurements1 += line("%.3f \t %d \t %.6f \t %.6f \n", kT0 + t, 14, r, b);
      measurements1 += line("%.3f \t %d \t %.6f \t %.6f \n", kT0 + t, 99, 2.0, 0.1);
    }
  }
  std::ofstream(dir / "Robot1_Odometry.dat") << odometry1;
  std::ofstream(dir / "Robot1_Groundtruth.dat") << truth1;
  std::ofstream(dir / "Robot1_Measurement.dat") << measurements1;
  std::string odometry2 = kHeader, truth2 = kHeader;
  for (int i = 1; i <= 40; ++i) odometry2 += line("%.3f \t 0.000 \t 0.000 \n", kT0 + 0.1 * i);
  for (int i = 1; i <= 40; ++i) {
    truth2 +=
        line("%.3f \t %.8f \t %.8f \t %.8f \n", kT0 + 0.1 * i, kPose2.x, kPose2.y, kPose2.theta);
  }
  const auto [r, b] = range_bearing(kPose2, kLandmark6);
  std::ofstream(dir / "Robot2_Odometry.dat") << odometry2;
  std::ofstream(dir / "Robot2_Groundtruth.dat") << truth2;
  std::ofstream(dir / "Robot2_Measurement.dat")
      << kHeader << line("%.3f \t 63 \t %.6f \t %.6f \n", kT0 + 1.0, r, b);
  return dir;
}

ImportSummary import(const fs::path& dir, const fs::path& out, std::vector<int> robots = {1, 2},
                     ImportWindow window = {}) {
  return write_import(read_mrclam({dir, std::move(robots)}), window, out);
}

std::vector<Record> read_all(LogSource& source) {
  std::vector<Record> records;
  Record record;
  while (source.next(record)) records.push_back(record);
  return records;
}

double time_of(const Record& r) {
  return r.type == Record::Type::kReading ? r.reading.t_s : r.t_s;
}

TEST(MrclamImport, WritesALogReplayReadsWithTheDatasetsReadingsAndTruth) {
  const fs::path dir = write_dataset(testing::temp_dir("data"));
  const fs::path log = testing::temp_dir("out") / "mrclam.locsimlog";
  const ImportSummary summary = import(dir, log);
  EXPECT_EQ(summary.odometry, 240u);
  EXPECT_EQ(summary.ground_truth, 441u);
  EXPECT_EQ(summary.detection_readings, 9u);  // robot 1: 8 instants, robot 2: 1
  EXPECT_EQ(summary.detections, 18u);         // 16 landmarks + robot 2 + robot 2's landmark
  ASSERT_EQ(summary.dropped.size(), 1u);
  EXPECT_EQ(summary.dropped.at("unknown barcode"), 1u);
  EXPECT_EQ(summary.records, 240u + 441u + 9u);

  LogSource source(log);
  const nlohmann::ordered_json& header = source.header();
  EXPECT_EQ(header.at("source").at("format"), "mrclam");
  EXPECT_NEAR(header.at("source").at("t0_unix_s").get<double>(), kT0, 1e-6);
  EXPECT_EQ(header.at("source").at("robots"), nlohmann::ordered_json({1, 2}));
  EXPECT_EQ(header.at("source").at("dropped_detections").at("unknown barcode"), 1);
  const WorldDef& world = source.world();
  ASSERT_EQ(world.landmarks.size(), 2u);
  EXPECT_EQ(world.landmarks[0].id, 6);
  EXPECT_EQ(world.landmarks[1].position_m, kLandmark7);
  ASSERT_EQ(world.robots.size(), 2u);
  EXPECT_EQ(world.robots[0].name, "robot1");
  EXPECT_NEAR(world.robots[0].start.x, kStart1.x, 1e-9);
  EXPECT_NEAR(world.robots[1].start.y, kPose2.y, 1e-9);
  EXPECT_DOUBLE_EQ(world.robots[0].wheel_base_m, 0.258);
  const auto& encoders = world.robots[0].sensors.encoders;
  ASSERT_TRUE(encoders.has_value());
  EXPECT_EQ(encoders->reports, kOdometryVelocity);
  EXPECT_EQ(encoders->common.rate_hz, 50.0);  // the data's 50 Hz
  const auto& camera = world.robots[0].sensors.range_bearing;
  ASSERT_TRUE(camera.has_value());
  EXPECT_TRUE(camera->sees_robots);
  EXPECT_NEAR(source.scenario().duration_s, 4.0, 1e-6);

  const std::vector<Record> records = read_all(source);
  ASSERT_EQ(records.size(), summary.records);
  double max_bearing = 0.0, min_range = 1e9, max_range = 0.0;
  int robot_detections = 0;
  for (std::size_t i = 0; i < records.size(); ++i) {
    const Record& r = records[i];
    if (i > 0) {
      const Record& before = records[i - 1];
      ASSERT_LE(time_of(before), time_of(r)) << i;
      // At equal times the readings come before the true poses.
      if (time_of(before) == time_of(r)) {
        EXPECT_FALSE(before.type == Record::Type::kGroundTruth && r.type == Record::Type::kReading)
            << i;
      }
    }
    if (r.type == Record::Type::kGroundTruth && r.robot == 0) {
      const Pose2 truth = robot1_at(r.t_s);
      EXPECT_NEAR(r.pose.x, truth.x, 1e-6);
      EXPECT_NEAR(r.pose.y, truth.y, 1e-6);
      EXPECT_NEAR(r.pose.theta, truth.theta, 1e-6);
    }
    if (r.type != Record::Type::kReading) continue;
    if (r.reading.kind == SensorKind::kEncoders) {
      const auto& odometry = std::get<OdometryReading>(r.reading.data);
      EXPECT_EQ(odometry.fields, kOdometryVelocity);
      if (r.reading.robot == 0) {
        EXPECT_DOUBLE_EQ(odometry.v_mps, kV);
        EXPECT_DOUBLE_EQ(odometry.omega_radps, kW);
      }
      continue;
    }
    ASSERT_EQ(r.reading.kind, SensorKind::kRangeBearing);
    for (const Detection& d : std::get<RangeBearingReading>(r.reading.data).detections) {
      max_bearing = std::max(max_bearing, std::abs(d.bearing_rad));
      min_range = std::min(min_range, d.range_m);
      max_range = std::max(max_range, d.range_m);
      if (d.target == DetectionTarget::kRobot) {
        ++robot_detections;
        EXPECT_EQ(r.reading.robot, 0);
        EXPECT_EQ(d.id, 1);  // robot 2's index in the world
        EXPECT_NEAR(r.reading.t_s, 1.25, 1e-6);
        const auto [range, bearing] = range_bearing(robot1_at(1.25), kPose2.position());
        EXPECT_NEAR(d.range_m, range, 1e-6);
        EXPECT_NEAR(d.bearing_rad, bearing, 1e-6);
        continue;
      }
      ASSERT_TRUE(d.id == 6 || d.id == 7);
      EXPECT_FALSE(d.color.empty());
      if (r.reading.robot == 0) {
        const auto [range, bearing] =
            range_bearing(robot1_at(r.reading.t_s), d.id == 6 ? kLandmark6 : kLandmark7);
        EXPECT_NEAR(d.range_m, range, 1e-5);
        EXPECT_NEAR(d.bearing_rad, bearing, 1e-5);
      }
    }
  }
  EXPECT_EQ(robot_detections, 1);
  // The sensor's settings are those the data shows: every detection fits them, exactly.
  EXPECT_DOUBLE_EQ(camera->fov_rad, 2.0 * max_bearing);
  EXPECT_DOUBLE_EQ(camera->min_range_m, min_range);
  EXPECT_DOUBLE_EQ(camera->max_range_m, max_range);
}

TEST(MrclamImport, IsDeterministic) {
  const fs::path dir = write_dataset(testing::temp_dir("data"));
  const fs::path out = testing::temp_dir("out");
  import(dir, out / "a.locsimlog");
  import(dir, out / "b.locsimlog");
  const std::string a = testing::read_file(out / "a.locsimlog");
  EXPECT_GT(a.size(), 1000u);
  // The header names the output's folder, the same for both.
  EXPECT_EQ(a, testing::read_file(out / "b.locsimlog"));
}

TEST(MrclamImport, DetectionsOfRobotsNotImportedAreDroppedAndCounted) {
  const fs::path dir = write_dataset(testing::temp_dir("data"));
  const fs::path log = testing::temp_dir("out") / "one.locsimlog";
  const ImportSummary summary = import(dir, log, {1});
  EXPECT_EQ(summary.dropped.at("robot not imported"), 1u);
  EXPECT_EQ(summary.dropped.at("unknown barcode"), 1u);
  EXPECT_EQ(summary.detections, 16u);
  LogSource source(log);
  EXPECT_EQ(source.world().robots.size(), 1u);
  for (const Record& r : read_all(source)) {
    if (r.type == Record::Type::kReading && r.reading.kind == SensorKind::kRangeBearing) {
      for (const Detection& d : std::get<RangeBearingReading>(r.reading.data).detections)
        EXPECT_EQ(d.target, DetectionTarget::kLandmark);
    }
  }
}

TEST(MrclamImport, AWindowStartsTheLogAtItsBeginning) {
  const fs::path dir = write_dataset(testing::temp_dir("data"));
  const fs::path log = testing::temp_dir("out") / "window.locsimlog";
  const ImportSummary summary = import(dir, log, {1, 2}, {2.0, 1.0});
  EXPECT_NEAR(summary.t0_s, kT0 + 2.0, 1e-6);
  EXPECT_EQ(summary.dropped.size(), 0u);  // the unknown barcode is at 1.25 s
  LogSource source(log);
  // Robot 1 starts where it is at 2 s.
  EXPECT_NEAR(source.world().robots[0].start.theta, robot1_at(2.0).theta, 1e-6);
  const std::vector<Record> records = read_all(source);
  ASSERT_FALSE(records.empty());
  EXPECT_NEAR(time_of(records.front()), 0.0, 1e-6);
  EXPECT_LE(time_of(records.back()), 1.0 + 1e-6);
  EXPECT_EQ(summary.ground_truth, 101u + 11u);  // 100 Hz and 10 Hz, both ends included
}

struct BadInput {
  std::string name;
  std::string file;
  int line;  // the data line to replace (1-based, after the header); 0: the whole file
  std::string text;
  std::string expected;  // in the message, after "file:line:"
};

// For the test's name in ctest's listing, instead of the struct's bytes.
void PrintTo(const BadInput& bad, std::ostream* out) {
  *out << bad.name;
}

class MrclamBadInput : public ::testing::TestWithParam<BadInput> {};

TEST_P(MrclamBadInput, IsRefusedNamingFileLineAndColumnAndNothingIsWritten) {
  const BadInput& bad = GetParam();
  const fs::path dir = write_dataset(testing::temp_dir("data"));
  const fs::path file = dir / bad.file;
  std::string content;
  if (bad.line > 0) {
    std::istringstream in(testing::read_file(file));
    std::string l;
    for (int n = 1; std::getline(in, l); ++n)
      content += (n == kHeaderLines + bad.line ? bad.text : l) + "\n";
  } else {
    content = bad.text;
  }
  std::ofstream(file) << content;
  const fs::path out = testing::temp_dir("out");
  const fs::path log = out / "bad.locsimlog";
  std::ofstream(log) << "an earlier file";
  try {
    import(dir, log);
    FAIL() << "accepted";
  } catch (const InputError& e) {
    const std::string where =
        file.string() + (bad.line > 0 ? ":" + std::to_string(kHeaderLines + bad.line) + ":" : "");
    EXPECT_NE(std::string(e.what()).find(where), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(bad.expected), std::string::npos) << e.what();
  }
  EXPECT_EQ(testing::read_file(log), "an earlier file");  // nothing already written is lost
  EXPECT_EQ(std::distance(fs::directory_iterator(out), fs::directory_iterator()), 1);
}

INSTANTIATE_TEST_SUITE_P(
    Cases, MrclamBadInput,
    ::testing::Values(
        BadInput{"TruncatedLine", "Robot1_Odometry.dat", 3, "1248444000.060 \t 0.200",
                 "'angular_velocity': the line has 2 columns"},
        BadInput{"NotANumber", "Robot1_Measurement.dat", 2, "1248444000.250 \t 81 \t abc \t 0.1",
                 "'range': 'abc' is not a number"},
        BadInput{"NaN", "Robot2_Groundtruth.dat", 1, "1248444000.100 \t nan \t 1.0 \t 0.0",
                 "'x': 'nan' is not a finite number"},
        BadInput{"TimeGoesBack", "Robot1_Groundtruth.dat", 5, "1248443999.000 \t 1 \t 0 \t 0",
                 "times must not decrease"},
        BadInput{"BarcodeNotWhole", "Robot1_Measurement.dat", 1,
                 "1248444000.250 \t 6.5 \t 1.0 \t 0.1", "'subject': '6.5' is not a whole number"},
        BadInput{"NegativeRange", "Robot1_Measurement.dat", 1,
                 "1248444000.250 \t 63 \t -1.0 \t 0.1", "'range': -1 m is outside [0, 100000] m"},
        // Finite but beyond a world file's ranges: named at its own line, not downstream.
        BadInput{"HugeViconX", "Robot2_Groundtruth.dat", 1, "1248444000.100 \t 1e30 \t 1.0 \t 0.0",
                 "'x': 1e+30 m is outside [-10000, 10000] m"},
        BadInput{"HugeVelocity", "Robot1_Odometry.dat", 3, "1248444000.060 \t 1e308 \t 0.1",
                 "'forward_velocity': 1e+308 m/s is outside [-1000, 1000] m/s"},
        BadInput{"LandmarkWithoutBarcode", "Landmark_Groundtruth.dat", 2, "  8 \t 1.0 \t 1.0",
                 "subject 8 has no barcode"},
        BadInput{"BarcodeTwice", "Barcodes.dat", 2, "  2 \t   5 ", "barcode listed twice"},
        BadInput{"EmptyFile", "Robot2_Measurement.dat", 0, kHeader, "no data rows"},
        // Times beyond any dataset's, at their own line: not at a generated world's duration.
        BadInput{"HugeTime", "Robot1_Odometry.dat", 200, "1e308 \t 0.1 \t 0.1",
                 "'time': 1e+308 s is outside ["},
        BadInput{"HugeNegativeTime", "Robot1_Odometry.dat", 1, "-1e308 \t 0.1 \t 0.1",
                 "'time': -1e+308 s is outside ["},
        BadInput{"TimeNear1e16", "Robot1_Groundtruth.dat", 401, "1e16 \t 1 \t 0 \t 0",
                 "'time': 1e+16 s is outside ["},
        // Within the range, but 2e7 s after t0: longer than a log can be.
        BadInput{"SpanTooLong", "Robot1_Measurement.dat", 18,
                 line("%.3f \t 63 \t 1.0 \t 0.1", kT0 + 2e7),
                 "'time': time 1268444000 s is 20000000 s after the log's start"},
        // Two different true poses at one instant: the second is named, with the first's line.
        BadInput{"SecondTruePose", "Robot1_Groundtruth.dat", 5,
                 line("%.3f \t 9.0 \t 0.0 \t 0.0", kT0 + 0.03),
                 "'time': robot 'robot1', t = 1248444000.03 s (0.03 s into the log): a second "
                 "true pose"}),
    [](const auto& test) { return test.param.name; });

TEST(MrclamImport, AMissingFileOrFolderIsNamed) {
  const fs::path dir = write_dataset(testing::temp_dir("data"));
  const fs::path log = testing::temp_dir("out") / "x.locsimlog";
  try {
    import(dir, log, {});  // all five: robots 3 to 5 have no files here
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("Robot3_Odometry.dat"), std::string::npos) << e.what();
  }
  EXPECT_THROW(import(dir / "nowhere", log), InputError);
  EXPECT_THROW(import(dir, log, {6}), InputError);
  EXPECT_FALSE(fs::exists(log));
}

TEST(MrclamImport, CommandLineImportsPrintsASummaryAndRefusesBadInputWithExit2) {
  const fs::path dir = write_dataset(testing::temp_dir("data"));
  const fs::path out = testing::temp_dir("out");
  const fs::path log = out / "cli.locsimlog";
  const auto ok =
      testing::locsim("import mrclam " + dir.string() + " --robots 1,2 --out " + log.string());
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("690 records"), std::string::npos) << ok.output;
  EXPECT_NE(ok.output.find("1 unknown barcode"), std::string::npos) << ok.output;
  // An existing log is not replaced without --overwrite.
  const auto again =
      testing::locsim("import mrclam " + dir.string() + " --robots 1,2 --out " + log.string());
  EXPECT_EQ(again.exit_code, 2) << again.output;
  EXPECT_NE(again.output.find("--overwrite"), std::string::npos) << again.output;
  const auto bad_list = testing::locsim("import mrclam " + dir.string() + " --robots 1,x --out " +
                                        (out / "y").string());
  EXPECT_EQ(bad_list.exit_code, 2) << bad_list.output;
  // A missing folder is made (as run --log makes its); a folder or a file in the way is refused.
  const auto nested = testing::locsim("import mrclam " + dir.string() + " --robots 1,2 -q --out " +
                                      (out / "new/sub/n.locsimlog").string());
  EXPECT_EQ(nested.exit_code, 0) << nested.output;
  EXPECT_TRUE(fs::is_regular_file(out / "new/sub/n.locsimlog"));
  for (const fs::path& target : {out / "new", log / "x.locsimlog"}) {
    const auto refused =
        testing::locsim("import mrclam " + dir.string() + " --robots 1,2 --out " + target.string());
    EXPECT_EQ(refused.exit_code, 2) << target << refused.output;
    EXPECT_NE(refused.output.find("--out: "), std::string::npos) << refused.output;
  }
  std::ofstream(dir / "Robot2_Odometry.dat") << kHeader << "1248444000.1 \t 0.1\n";
  const auto bad = testing::locsim("import mrclam " + dir.string() + " --robots 1,2 --out " +
                                   (out / "bad.locsimlog").string());
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("Robot2_Odometry.dat:5:"), std::string::npos) << bad.output;
  EXPECT_FALSE(fs::exists(out / "bad.locsimlog"));
}

TEST(MrclamImport, MemoryStaysWithinItsBytesPerInputLine) {
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
  GTEST_SKIP() << "AddressSanitizer's quarantine keeps freed tables: the peak is not the import's";
#endif
#endif
  // docs/real_data.md states about 100-170 bytes per input line at the peak; 300 is the bound.
  const fs::path dir = write_dataset(testing::temp_dir("data"));
  const fs::path out = testing::temp_dir("out");
  const auto peak_kb = [&](const std::string& name) {
    const testing::Measured m =
        testing::run_measured(std::string(LOCSIM_BINARY) + " import mrclam " + dir.string() +
                              " --robots 1,2 --out " + (out / name).string());
    EXPECT_EQ(m.exit_code, 0);
    return m.peak_kb;
  };
  const long small_kb = peak_kb("small.locsimlog");
  // 400 000 more lines of ground truth (66 minutes at 100 Hz), as a Vicon writes them.
  constexpr int kLines = 400000;
  std::string truth = kHeader;
  for (int i = 0; i < kLines; ++i) {
    truth += line("%.3f \t %.8f \t %.8f \t %.8f \n", kT0 + 0.01 * i, 1.0 + 1e-6 * i, 2.0, 0.5);
  }
  std::ofstream(dir / "Robot1_Groundtruth.dat") << truth;
  const long large_kb = peak_kb("large.locsimlog");
  const double bytes_per_line = static_cast<double>(large_kb - small_kb) * 1024.0 / kLines;
  EXPECT_LT(bytes_per_line, 300.0);
  std::printf("import: %.0f bytes per input line at the peak\n", bytes_per_line);
}

// Every landmark localizer runs on an imported dataset and follows the robot: the dataset's
// odometry is the exact arc, so a filter that integrated the velocities wrongly (or dropped the
// range-bearing detections) would drift from the truth. The Python examples too: a filter written
// in Python replays real data as the C++ ones do.
TEST(MrclamImport, EveryLandmarkLocalizerReplaysAnImport) {
  const fs::path dir = write_dataset(testing::temp_dir("data"));
  const fs::path out = testing::temp_dir("out");
  import(dir, out / "log.locsimlog");
  for (const auto& [spec, name] :
       std::vector<std::pair<std::string, std::string>>{{"ekf_landmarks", "ekf_landmarks"},
                                                        {"mcl", "mcl"},
                                                        {"srl", "srl"},
                                                        {"asrl", "asrl"},
                                                        {"augmented_mcl", "augmented_mcl"},
                                                        {"fastslam", "fastslam"},
                                                        {"python:landmark_pf", "landmark_pf"},
                                                        {"python:landmark_ekf", "landmark_ekf"}}) {
    ReplayOptions options;
    options.log_file = out / "log.locsimlog";
    options.out_dir = out / name;
    options.localizers = {spec};
    const ReplayResult result = replay_log(options);
    EXPECT_EQ(result.status, "completed") << spec;
    EXPECT_TRUE(result.failed_localizers.empty()) << spec;
    EXPECT_NEAR(result.replayed_s, 4.0, 1e-6) << spec;
    const std::string estimates = testing::read_file(out / name / "robot1" / (name + ".tum"));
    EXPECT_GT(estimates.size(), 100u) << spec;
    const nlohmann::json metrics =
        nlohmann::json::parse(testing::read_file(out / name / "robot1" / "metrics.json"));
    EXPECT_EQ(metrics["localizers"][0]["status"], "ok") << spec;
    EXPECT_LT(metrics["localizers"][0]["position_error_m"]["rms"].get<double>(), 0.2) << spec;
  }
}

/// The generic format: two robots as sub-folders, one logging velocity and pose, the other a
/// pose only; a detection of the other robot; an unidentified one (id -1).
TEST(GenericImport, ReadsMapOdometryDetectionsAndTumGroundTruth) {
  const fs::path dir = testing::temp_dir("data");
  std::ofstream(dir / "map.csv") << "id,x,y\n6,4.0,0.0\n7,4.0,2.0\n";
  fs::create_directories(dir / "alpha");
  fs::create_directories(dir / "beta");
  std::string odometry = "t,v,omega,x,y,theta\n", truth = "# t x y z qx qy qz qw\n";
  for (int i = 0; i <= 100; ++i) {
    const double t = 100.0 + 0.02 * i;  // absolute times: shifted by t0
    const Pose2 p = robot1_at(0.02 * i);
    odometry += line("%.2f,%.3f,%.3f,%.8f,%.8f,%.8f\n", t, kV, kW, p.x, p.y, p.theta);
    truth += line("%.2f %.8f %.8f 0 0 0 %.10f %.10f\n", t, p.x, p.y, std::sin(p.theta / 2),
                  std::cos(p.theta / 2));
  }
  std::ofstream(dir / "alpha" / "odometry.csv") << odometry;
  std::ofstream(dir / "alpha" / "groundtruth.tum") << truth;
  const auto [r, b] = range_bearing(robot1_at(1.0), kLandmark6);
  std::ofstream(dir / "alpha" / "detections.csv")
      << "t,id,range,bearing,target\n"
      << line("101.00,6,%.6f,%.6f,landmark\n", r, b) << "101.00,1,2.5,0.1,robot\n"
      << "101.50,-1,3.0,-0.2,landmark\n";
  std::ofstream(dir / "beta" / "odometry.csv") << "t,x,y,theta\n100.5,3,1,0\n101.5,3,1,0\n";
  std::ofstream(dir / "beta" / "groundtruth.tum") << "100.5 3 1 0 0 0 0 1\n101.5 3 1 0 0 0 0 1\n";

  const fs::path log = testing::temp_dir("out") / "generic.locsimlog";
  const ImportSummary summary = write_import(read_generic(dir), {}, log);
  EXPECT_EQ(summary.odometry, 103u);
  EXPECT_EQ(summary.ground_truth, 103u);
  EXPECT_EQ(summary.detection_readings, 2u);
  EXPECT_EQ(summary.detections, 3u);
  EXPECT_DOUBLE_EQ(summary.t0_s, 100.0);
  LogSource source(log);
  EXPECT_EQ(source.header().at("source").at("format"), "generic");
  ASSERT_EQ(source.world().robots.size(), 2u);
  EXPECT_EQ(source.world().robots[0].name, "alpha");
  EXPECT_EQ(source.world().robots[0].sensors.encoders->reports, kOdometryVelocity | kOdometryPose);
  EXPECT_EQ(source.world().robots[1].sensors.encoders->reports, kOdometryPose);
  int robot_seen = 0, unidentified = 0;
  for (const Record& rec : read_all(source)) {
    if (rec.type == Record::Type::kGroundTruth && rec.robot == 0) {
      const Pose2 p = robot1_at(rec.t_s);
      EXPECT_NEAR(rec.pose.x, p.x, 1e-6);
      EXPECT_NEAR(rec.pose.theta, p.theta, 1e-6);  // yaw from the quaternion
    }
    if (rec.type != Record::Type::kReading) continue;
    if (rec.reading.kind == SensorKind::kEncoders && rec.reading.robot == 0) {
      const auto& o = std::get<OdometryReading>(rec.reading.data);
      EXPECT_NEAR(o.odometry.y, robot1_at(rec.reading.t_s).y, 1e-6);
      EXPECT_DOUBLE_EQ(o.v_mps, kV);
    }
    if (rec.reading.kind != SensorKind::kRangeBearing) continue;
    for (const Detection& d : std::get<RangeBearingReading>(rec.reading.data).detections) {
      if (d.target == DetectionTarget::kRobot) {
        ++robot_seen;
        EXPECT_EQ(d.id, 1);
      } else if (d.id == -1) {
        ++unidentified;
        EXPECT_NEAR(rec.reading.t_s, 1.5, 1e-9);
      } else {
        EXPECT_EQ(d.id, 6);
        EXPECT_NEAR(d.range_m, r, 1e-6);
      }
    }
  }
  EXPECT_EQ(robot_seen, 1);
  EXPECT_EQ(unidentified, 1);
}

TEST(GenericImport, BadInputIsRefusedNamingFileLineAndColumn) {
  const auto refused = [](const std::string& file, const std::string& content,
                          const std::string& expected) {
    const fs::path dir = testing::temp_dir("data");
    std::ofstream(dir / "map.csv") << "id,x,y\n6,4.0,0.0\n";
    std::ofstream(dir / "odometry.csv") << "t,v,omega\n0,0.1,0\n1,0.1,0\n";
    std::ofstream(dir / "groundtruth.tum") << "0 0 0 0 0 0 0 1\n1 0.1 0 0 0 0 0 1\n";
    std::ofstream(dir / file) << content;
    try {
      read_generic(dir);
      ADD_FAILURE() << file << " accepted: " << content;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  refused("detections.csv", "t,id,range,bearing\n0.5,9,1.0,0.1\n",
          "detections.csv:2:5: 'id': landmark 9 is not in map.csv");
  refused("detections.csv", "t,id,range\n0.5,6,1.0\n", "lacks column 'bearing'");
  refused("odometry.csv", "t,v\n0,0.1\n", "must name t,v,omega or t,x,y,theta");
  refused("odometry.csv", "t,v,omega\n1,0.1,0\n0,0.1,0\n", "odometry.csv:3:1: 't': time 0");
  refused("odometry.csv", "t,v,omega\n0,0.1,NaN\n", "'omega': 'NaN' is not a finite number");
  refused("odometry.csv", "", "empty file");
  refused("groundtruth.tum", "0 0 0 0 0 0 0.5 0.5\n", "not of unit length");
  refused("map.csv", "id,x,y\n6,1,1\n6,2,2\n", "map.csv:3:1: 'id': landmark id listed twice");
  refused("detections.csv", "t,id,range,bearing,target\n0.5,6,1.0,0.1,wall\n",
          "expected landmark or robot");
  refused("map.csv", "id,x,y,color\n6,1,1,mauve\n", "map.csv:2:7: 'color': unknown colour 'mauve'");
  refused("detections.csv", "t,id,range,bearing,color\n0.5,-1,1.0,0.1,red\n",
          "detections.csv:2:16: 'color': no landmark of colour 'red' in map.csv");
  refused("imu.csv", "t,yaw_rate,accel_x\n0,0.1,0\n", "accel_x or accel_y alone");
  refused("imu.csv", "t,yaw_rate\n0,0.1\n1,nan\n", "imu.csv:3:3: 'yaw_rate'");
  refused("robot.yaml", "radius_m: 0.2\nwheelbase_m: 0.3\n", "robot.yaml:2:1");
  refused("robot.yaml", "range_bearing: {fov_deg: 500}\n", "fov");
}

/// A detector that tells colours, not identities; an IMU; the robot's geometry and camera from
/// robot.yaml.
TEST(GenericImport, ReadsColoursAnImuAndTheRobotsGeometry) {
  const fs::path dir = testing::temp_dir("data");
  std::ofstream(dir / "map.csv") << "x,y,id,color\n4.0,0.0,6,red\n4.0,2.0,7,blue\n5,5,8,red\n";
  std::ofstream(dir / "odometry.csv") << "t,v,omega\n0,0.1,0\n1,0.1,0\n2,0.1,0\n";
  std::ofstream(dir / "groundtruth.tum")
      << "0 0 0 0 0 0 0 1\n1 0.1 0 0 0 0 0 1\n2 0.2 0 0 0 0 0 1\n";
  std::ofstream(dir / "detections.csv") << "t,id,range,bearing,color\n0.5,-1,3.9,0.0,red\n"
                                           "0.5,7,4.4,0.46,blue\n1.5,-1,4.3,0.5,\n";
  std::ofstream(dir / "imu.csv") << "t,yaw_rate,accel_x,accel_y\n0,0.01,0.1,0\n0.5,0.02,0,0\n"
                                    "1.0,-0.01,0,0.05\n";
  std::ofstream(dir / "robot.yaml")
      << "radius_m: 0.25\nwheel_base_m: 0.4\nwheel_radius_m: 0.06\n"
         "range_bearing: {fov_deg: 90, min_range_m: 0.5, max_range_m: 10}\n";
  const fs::path log = testing::temp_dir("out") / "colours.locsimlog";
  const ImportSummary summary = write_import(read_generic(dir), {}, log);
  EXPECT_EQ(summary.imu, 3u);
  LogSource source(log);
  const WorldDef& world = source.world();
  ASSERT_EQ(world.landmarks.size(), 3u);
  EXPECT_EQ(world.landmarks[0].color_name, "red");
  EXPECT_EQ(world.landmarks[1].color_name, "blue");
  const RobotDef& robot = world.robots.at(0);
  EXPECT_DOUBLE_EQ(robot.footprint.radius_m, 0.25);
  EXPECT_DOUBLE_EQ(robot.wheel_base_m, 0.4);
  EXPECT_DOUBLE_EQ(robot.wheel_radius_m, 0.06);
  ASSERT_TRUE(robot.sensors.range_bearing && robot.sensors.imu);
  EXPECT_NEAR(robot.sensors.range_bearing->fov_rad, deg_to_rad(90.0), 1e-12);
  EXPECT_DOUBLE_EQ(robot.sensors.range_bearing->max_range_m, 10.0);
  int by_colour = 0, imu = 0;
  for (const Record& rec : read_all(source)) {
    if (rec.type != Record::Type::kReading) continue;
    if (rec.reading.kind == SensorKind::kImu) {
      const auto& reading = std::get<ImuReading>(rec.reading.data);
      if (imu++ == 0) {
        EXPECT_DOUBLE_EQ(reading.yaw_rate_radps, 0.01);
        EXPECT_DOUBLE_EQ(reading.accel_mps2.x(), 0.1);
      }
    }
    if (rec.reading.kind != SensorKind::kRangeBearing) continue;
    for (const Detection& d : std::get<RangeBearingReading>(rec.reading.data).detections) {
      if (d.id == -1 && d.color == "red") ++by_colour;
      if (d.id == 7) {
        EXPECT_EQ(d.color, "blue");
      }
    }
  }
  EXPECT_EQ(by_colour, 1);
  EXPECT_EQ(imu, 3);
  // A landmark particle filter takes a colour-only detection (the best landmark of its colour).
  const auto replay = testing::locsim("replay " + log.string() + " --out " +
                                      (testing::temp_dir("replay")).string() +
                                      " --localizer mcl --localizer ekf_landmarks -q");
  EXPECT_EQ(replay.exit_code, 0) << replay.output;
}

/// One robot of the generic format (odometry.csv and groundtruth.tum, 3 s) in `dir`.
fs::path write_generic_robot(const fs::path& dir) {
  fs::create_directories(dir);
  std::ofstream(dir / "odometry.csv") << "t,v,omega\n0,0.1,0\n1,0.1,0\n2,0.1,0\n3,0.1,0\n";
  std::ofstream(dir / "groundtruth.tum")
      << "0 0 0 0 0 0 0 1\n1 0.1 0 0 0 0 0 1\n2 0.2 0 0 0 0 0 1\n3 0.3 0 0 0 0 0 1\n";
  return dir;
}

/// The message of the InputError `import` throws (a failure, and "", when it throws none).
template <typename Import>
std::string refusal(Import&& import) {
  try {
    import();
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted";
  return "";
}

/// A symbolic link loop is refused as what it is, naming it: not a raw filesystem_error (exit 1),
/// not "no such file".
TEST(GenericImport, ASymbolicLinkLoopIsRefusedNamingIt) {
  const fs::path dir = testing::temp_dir("data");
  write_generic_robot(dir / "r1");
  const fs::path log = testing::temp_dir("out") / "x.locsimlog";
  const auto import_generic = [&] { write_import(read_generic(dir), {}, log); };
  fs::create_symlink("loop", dir / "loop");  // beside the robots' folders
  testing::expect_contains(refusal(import_generic),
                           (dir / "loop").string() + ": a symbolic link loop");
  fs::remove(dir / "loop");
  fs::create_symlink("map.csv", dir / "map.csv");
  testing::expect_contains(refusal(import_generic),
                           (dir / "map.csv").string() + ": a symbolic link loop");
  fs::remove(dir / "map.csv");
  fs::create_symlink("imu.csv", dir / "r1" / "imu.csv");  // a robot's optional file
  testing::expect_contains(refusal(import_generic),
                           (dir / "r1" / "imu.csv").string() + ": a symbolic link loop");
  fs::remove(dir / "r1" / "imu.csv");
  fs::remove(dir / "r1" / "groundtruth.tum");  // a required one
  fs::create_symlink("groundtruth.tum", dir / "r1" / "groundtruth.tum");
  testing::expect_contains(refusal(import_generic),
                           (dir / "r1" / "groundtruth.tum").string() + ": a symbolic link loop");
  fs::create_symlink("self", dir / "self");  // the dataset's folder itself
  testing::expect_contains(refusal([&] { read_generic(dir / "self"); }),
                           (dir / "self").string() + ": a symbolic link loop");
  EXPECT_FALSE(fs::exists(log));

  const fs::path mrclam = write_dataset(testing::temp_dir("mrclam"));
  fs::remove(mrclam / "Robot2_Odometry.dat");
  fs::create_symlink("Robot2_Odometry.dat", mrclam / "Robot2_Odometry.dat");
  const std::string message = refusal([&] { import(mrclam, log); });
  testing::expect_contains(message,
                           (mrclam / "Robot2_Odometry.dat").string() + ": a symbolic link loop");
  EXPECT_EQ(message.find("no such file"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(log));
  const auto cli = testing::locsim("import generic " + dir.string() + " --out " + log.string());
  EXPECT_EQ(cli.exit_code, 2) << cli.output;
  testing::expect_contains(cli.output, "symbolic link loop");
}

/// A time beyond any dataset's is refused at its line, and so is the first time that makes the
/// log longer than a log can be (not at a generated world's `scenario.duration_s`).
TEST(GenericImport, TimesOutOfRangeOrTooFarApartAreRefusedAtTheirLine) {
  const auto refused = [](const std::string& file, const std::string& content,
                          const std::string& expected) {
    const fs::path dir = write_generic_robot(testing::temp_dir("data"));
    std::ofstream(dir / "map.csv") << "id,x,y\n6,4.0,0.0\n";
    std::ofstream(dir / file) << content;
    const fs::path log = testing::temp_dir("out") / "x.locsimlog";
    testing::expect_contains(refusal([&] { write_import(read_generic(dir), {}, log); }),
                             (dir / file).string() + ":" + expected);
    EXPECT_FALSE(fs::exists(log));
  };
  refused("detections.csv", "t,id,range,bearing\n0.5,6,1.0,0.1\n1e308,6,1.0,0.1\n",
          "3:1: 't': 1e+308 s is outside [");
  refused("odometry.csv", "t,v,omega\n-1e308,0.1,0\n1e308,0.1,0\n",
          "2:1: 't': -1e+308 s is outside [");
  refused("imu.csv", "yaw_rate,t\n0.1,0\n0.1,1e16\n", "3:5: 't': 1e+16 s is outside [");
  refused("groundtruth.tum", "0 0 0 0 0 0 0 1\n1e16 0 0 0 0 0 0 1\n",
          "2:1: 't': 1e+16 s is outside [");
  // Each within the range, but 2e7 s apart: the row that makes the span too long is named.
  refused("odometry.csv", "t,v,omega\n0,0.1,0\n1,0.1,0\n20000001,0.1,0\n30000000,0.1,0\n",
          "4:1: 't': time 20000001 s is 20000001 s after the log's start (0 s: the earliest time "
          "stamp, at ");
  refused("detections.csv", "t,id,range,bearing\n0.5,6,1.0,0.1\n2e7,6,1.0,0.1\n",
          "3:1: 't': time 20000000 s is 20000000 s after");
  // A window of such a dataset that spans less is imported.
  const fs::path dir = write_generic_robot(testing::temp_dir("window"));
  std::ofstream(dir / "odometry.csv") << "t,v,omega\n0,0.1,0\n1,0.1,0\n20000001,0.1,0\n";
  const ImportSummary summary =
      write_import(read_generic(dir), {0.0, 10.0}, testing::temp_dir("out") / "window.locsimlog");
  EXPECT_EQ(summary.odometry, 2u);
}

/// A robot is named after its folder: a folder name that could not name a robot (or would write
/// YAML of its own into the generated world) is refused naming the folder, before anything is
/// written; the world's name, from the dataset's folder, keeps only safe characters.
TEST(GenericImport, RobotFolderNamesThatCannotNameARobotAreRefused) {
  for (const std::string& name :
       {std::string("r1\n    mass_kg: 99999\n    height_m: 7"), std::string("a: b"),
        std::string("has space"), std::string("a\nb: [1"), std::string("r.1"),
        std::string("\"quoted\""), std::string("caf\xc3\xa9"), std::string("bad\xff")}) {
    const fs::path dir = testing::temp_dir("data");
    write_generic_robot(dir / "alpha");
    write_generic_robot(dir / name);
    const fs::path log = testing::temp_dir("out") / "x.locsimlog";
    const std::string message = refusal([&] { write_import(read_generic(dir), {}, log); });
    testing::expect_contains(message, dir.string() + ": the robot folder " + quote_input(name));
    testing::expect_contains(message, "rename the folder");
    EXPECT_FALSE(fs::exists(log)) << name;
  }
  // Names of letters, digits, '_' and '-' are robots' names as they are.
  const fs::path dir = testing::temp_dir("ok");
  write_generic_robot(dir / "Robot_1");
  write_generic_robot(dir / "husky-2");
  const fs::path log = testing::temp_dir("out") / "ok.locsimlog";
  write_import(read_generic(dir), {}, log);
  LogSource source(log);
  ASSERT_EQ(source.world().robots.size(), 2u);
  EXPECT_EQ(source.world().robots[0].name, "Robot_1");
  EXPECT_EQ(source.world().robots[1].name, "husky-2");

  // The dataset's own folder may be named anything: the world's name keeps what is safe.
  const fs::path odd = testing::temp_dir("odd") / "d\"a: b\n  x: [";
  write_generic_robot(odd);
  const ImportSummary summary = write_import(read_generic(odd), {}, log.string() + "2");
  LogSource odd_source(log.string() + "2");
  EXPECT_EQ(odd_source.world().name, "imported_d_a__b___x___");
  EXPECT_EQ(odd_source.world().robots.size(), 1u);
  EXPECT_EQ(summary.header.at("world_file"), "imported_d_a__b___x___.yaml");
  // A folder whose path is not UTF-8 cannot be named in the log's header (JSON): refused.
  const fs::path not_utf8 = testing::temp_dir("odd") / "d\xff";
  write_generic_robot(not_utf8);
  testing::expect_contains(
      refusal([&] { write_import(read_generic(not_utf8), {}, log.string() + "3"); }), "not UTF-8");
  EXPECT_FALSE(fs::exists(log.string() + "3"));
}

TEST(GenericImport, ASecondTruePoseAtOneInstantIsNamedAtItsLine) {
  const fs::path dir = write_generic_robot(testing::temp_dir("data"));
  std::ofstream(dir / "groundtruth.tum")
      << "# t x y z qx qy qz qw\n0 0 0 0 0 0 0 1\n1 0.1 0 0 0 0 0 1\n1 0.5 0 0 0 0 0 1\n";
  const fs::path log = testing::temp_dir("out") / "x.locsimlog";
  testing::expect_contains(
      refusal([&] { write_import(read_generic(dir), {}, log); }),
      (dir / "groundtruth.tum").string() +
          ":4:1: 't': robot 'robot', t = 1 s (1 s into the log): a second true pose");
  testing::expect_contains(refusal([&] { write_import(read_generic(dir), {}, log); }), "(line 3)");
  EXPECT_FALSE(fs::exists(log));
}

/// `--out` naming a file the import reads would replace the dataset's own file with the log:
/// refused before anything is written, however the file is named (a link to it too).
TEST(GenericImport, TheLogMayNotReplaceAFileOfTheDataset) {
  const fs::path dir = write_generic_robot(testing::temp_dir("data") / "r1");
  std::ofstream(dir.parent_path() / "map.csv") << "id,x,y\n6,4.0,0.0\n";
  const std::string odometry = testing::read_file(dir / "odometry.csv");
  fs::create_symlink(dir / "odometry.csv", dir.parent_path() / "link.locsimlog");
  for (const fs::path& out :
       {dir / "odometry.csv", dir / "groundtruth.tum", dir.parent_path() / "map.csv",
        dir.parent_path() / "link.locsimlog", dir / ".." / "r1" / "odometry.csv"}) {
    testing::expect_contains(
        refusal([&] { write_import(read_generic(dir.parent_path()), {}, out); }), "--out: ");
  }
  EXPECT_EQ(testing::read_file(dir / "odometry.csv"), odometry);
  const auto cli = testing::locsim("import generic " + dir.parent_path().string() + " --out " +
                                   (dir / "odometry.csv").string() + " --overwrite");
  EXPECT_EQ(cli.exit_code, 2) << cli.output;
  testing::expect_contains(cli.output, "--out: ");
  EXPECT_EQ(testing::read_file(dir / "odometry.csv"), odometry);
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_NE(entry.path().extension(), ".partial") << entry.path();
  // A file of the dataset's folder that the import does not read may be replaced.
  std::ofstream(dir / "old.locsimlog") << "an earlier log";
  write_import(read_generic(dir.parent_path()), {}, dir / "old.locsimlog");

  const fs::path mrclam = write_dataset(testing::temp_dir("mrclam"));
  const std::string barcodes = testing::read_file(mrclam / "Barcodes.dat");
  for (const char* file : {"Barcodes.dat", "Robot2_Measurement.dat"}) {
    testing::expect_contains(refusal([&] { import(mrclam, mrclam / file); }), "--out: ");
  }
  EXPECT_EQ(testing::read_file(mrclam / "Barcodes.dat"), barcodes);
  // A robot's files that are not imported are not read: not refused.
  import(mrclam, mrclam / "Robot1_Odometry.dat.locsimlog", {2});
}

/// Range-only beacons (a UWB anchor network): beacons.csv, a robot's ranges.csv with receiver
/// indices, and its two receivers from robot.yaml become the world's beacons, the robot's
/// ultrasonic sensor and its readings, a round per time.
TEST(GenericImport, ReadsBeaconsRangesAndTheReceivers) {
  const fs::path dir = testing::temp_dir("data");
  std::ofstream(dir / "beacons.csv") << "id,x,y,z\n3,10,0,2.5\n8,0,10,1\n";
  std::ofstream(dir / "odometry.csv") << "t,x,y,theta\n0,0,0,0\n1,0.1,0,0\n2,0.2,0,0\n";
  std::ofstream(dir / "groundtruth.tum")
      << "0 0 0 0 0 0 0 1\n1 0.1 0 0 0 0 0 1\n2 0.2 0 0 0 0 0 1\n";
  std::ofstream(dir / "ranges.csv")
      << "t,beacon,range,receiver\n0.5,3,10.2,0\n0.5,8,10.1,1\n1.25,8,10.3,0\n";
  std::ofstream(dir / "robot.yaml")
      << "ultrasonic: {receivers: [{position: [0, 0.2], height_m: 0.5}, {position: [0, -0.2]}]}\n";
  const fs::path log = testing::temp_dir("out") / "beacons.locsimlog";
  const ImportSummary summary = write_import(read_generic(dir), {}, log);
  EXPECT_EQ(summary.range_readings, 2u);
  EXPECT_EQ(summary.ranges, 3u);
  testing::expect_contains(describe(summary), "2 range readings with 3 ranges");
  LogSource source(log);
  const WorldDef& world = source.world();
  ASSERT_EQ(world.beacons.size(), 2u);
  EXPECT_EQ(world.beacons[1].id, 8);
  EXPECT_DOUBLE_EQ(world.beacons[0].position_m.x(), 10.0);
  EXPECT_DOUBLE_EQ(world.beacons[0].height_m, 2.5);
  const auto& sensor = world.robots.at(0).sensors.ultrasonic;
  ASSERT_TRUE(sensor.has_value());
  ASSERT_EQ(sensor->receivers.size(), 2u);
  EXPECT_DOUBLE_EQ(sensor->receivers[0].position_m.y(), 0.2);
  EXPECT_DOUBLE_EQ(sensor->receivers[0].height_m, 0.5);
  EXPECT_DOUBLE_EQ(sensor->receivers[1].height_m, 0.0);
  EXPECT_DOUBLE_EQ(sensor->max_range_m, 10.3);  // the longest range the data hold
  std::vector<UltrasonicReading> rounds;
  for (const Record& rec : read_all(source)) {
    if (rec.type == Record::Type::kReading && rec.reading.kind == SensorKind::kUltrasonic)
      rounds.push_back(std::get<UltrasonicReading>(rec.reading.data));
  }
  ASSERT_EQ(rounds.size(), 2u);
  ASSERT_EQ(rounds[0].ranges.size(), 2u);
  EXPECT_EQ(rounds[0].ranges[1].beacon_id, 8);
  EXPECT_EQ(rounds[0].ranges[1].receiver, 1);
  EXPECT_DOUBLE_EQ(rounds[0].ranges[1].range_m, 10.1);
  EXPECT_DOUBLE_EQ(rounds[1].ranges[0].range_m, 10.3);

  const auto refused = [&](const std::string& file, const std::string& content,
                           const std::string& expected) {
    const fs::path bad = testing::temp_dir("bad");
    for (const char* name : {"beacons.csv", "odometry.csv", "groundtruth.tum", "ranges.csv"})
      fs::copy_file(dir / name, bad / name);
    std::ofstream(bad / file) << content;
    testing::expect_contains(refusal([&] { read_generic(bad); }),
                             (bad / file).string() + ":" + expected);
  };
  refused("ranges.csv", "t,beacon,range\n0.5,4,1.0\n",
          "2:5: 'beacon': beacon 4 is not in beacons.csv");
  refused("ranges.csv", "t,beacon,range,receiver\n0.5,3,1.0,1\n", "2:11: 'receiver'");
  refused("ranges.csv", "t,beacon,range\n0.5,3,-1\n", "2:7: 'range'");
  refused("ranges.csv", "t,beacon\n0.5,3\n", "1:1: 'range': the header row lacks column 'range'");
  refused("beacons.csv", "id,x,y\n3,1,1\n3,2,2\n", "3:1: 'id': beacon id listed twice");
  refused("beacons.csv", "id,x,y,z\n3,1,1,-2\n", "2:7: 'z'");
}

/// A robot without an IMU that ranges to one beacon at a time (as a lawnmower to UWB anchors):
/// ultrasonic_ekf and beacon_mcl move by its wheels between ranges and track the pose, heading
/// included, which only the motion shows; told to move by an IMU it has not got, the EKF cannot.
TEST(GenericImport, RangeOnlyBeaconsAndWheelsTrackARobotWithoutAnImu) {
  const fs::path dir = testing::temp_dir("data");
  const std::vector<std::pair<int, Vec2>> beacons = {
      {0, {-15.0, -15.0}}, {1, {15.0, -15.0}}, {2, {15.0, 15.0}}, {3, {-15.0, 15.0}}};
  std::string text = "id,x,y\n";
  for (const auto& [id, p] : beacons) text += line("%d,%.1f,%.1f\n", id, p.x(), p.y());
  std::ofstream(dir / "beacons.csv") << text;
  // A 10 m circle at 0.5 m/s, 120 s; the odometry's distance 2 % long, its turn 1 % short.
  constexpr double kSpeed = 0.5, kRadius = 10.0;
  const auto truth_at = [&](double t) {
    const double a = kSpeed / kRadius * t;
    return Pose2{kRadius * std::sin(a), kRadius * (1.0 - std::cos(a)) - 10.0, a};
  };
  std::string odometry = "t,x,y,theta\n", truth = "# t x y z qx qy qz qw\n",
              ranges = "t,beacon,range\n";
  double x = 0.0, y = 0.0, theta = 0.0;
  std::uint64_t state = 7;  // a small LCG: the test's own noise, the same everywhere
  const auto uniform = [&] {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(state >> 11) / 9007199254740992.0;
  };
  for (int i = 0; i <= 1200; ++i) {
    const double t = 0.1 * i;
    if (i > 0) {
      const double d = 1.02 * kSpeed * 0.1, turn = 0.99 * kSpeed / kRadius * 0.1;
      x += d * std::cos(theta + 0.5 * turn), y += d * std::sin(theta + 0.5 * turn);
      theta += turn;
    }
    odometry += line("%.1f,%.6f,%.6f,%.8f\n", t, x, y, wrap_angle(theta));
    const Pose2 p = truth_at(t);
    truth += line("%.1f %.6f %.6f 0 0 0 %.9f %.9f\n", t, p.x, p.y, std::sin(p.theta / 2),
                  std::cos(p.theta / 2));
    if (i % 3 == 1) {  // one beacon every 0.3 s, in turn, with +-0.1 m of noise
      const auto& [id, b] = beacons[static_cast<std::size_t>(i / 3) % beacons.size()];
      const double r = std::hypot(b.x() - p.x, b.y() - p.y) + 0.2 * (uniform() - 0.5);
      ranges += line("%.1f,%d,%.4f\n", t, id, r);
    }
  }
  std::ofstream(dir / "odometry.csv") << odometry;
  std::ofstream(dir / "groundtruth.tum") << truth;
  std::ofstream(dir / "ranges.csv") << ranges;
  std::ofstream(dir / "robot.yaml") << "wheel_base_m: 0.5\n";
  const fs::path log = testing::temp_dir("out") / "range_only.locsimlog";
  write_import(read_generic(dir), {}, log);
  const fs::path out = testing::temp_dir("replay");
  // k 0.03: the odometry's scale errors are systematic; smaller k is overconfident (k 0.01: the
  // truth in the EKF's ellipse 1 % of the time).
  const std::string noise = ":sigma_range_m=0.06,k_left=0.03,k_right=0.03";
  const auto replay = testing::locsim(
      "replay " + log.string() + " --out " + out.string() + " -q --localizer ultrasonic_ekf" +
      noise + "@wheels --localizer beacon_mcl" + noise +
      " --localizer ultrasonic_ekf:motion=imu,sigma_range_m=0.06@imu"
      " --localizer odometry");
  ASSERT_EQ(replay.exit_code, 0) << replay.output;
  const auto metrics = nlohmann::json::parse(testing::read_file(out / "metrics.json"));
  const auto& imu = metrics["localizers"][2];
  const auto& odometry_only = metrics["localizers"][3];
  // The odometry alone drifts decimetres; the ranges hold the position to centimetres and the
  // motion turns the heading to within a few degrees, honestly.
  EXPECT_GT(odometry_only["position_error_m"]["rms"].get<double>(), 0.5);
  for (const int i : {0, 1}) {
    const auto& filter = metrics["localizers"][i];
    ASSERT_EQ(filter["status"], "ok") << filter["label"];
    EXPECT_LT(filter["position_error_m"]["rms"].get<double>(), 0.1) << filter["label"];
    EXPECT_LT(filter["heading_error_deg"]["rms"].get<double>(), 4.0) << filter["label"];
    EXPECT_GT(filter["consistency"]["inside_95_ellipse"].get<double>(), 0.8) << filter["label"];
  }
  // Without motion the estimate stays where it started.
  EXPECT_GT(imu["position_error_m"]["rms"].get<double>(), 5.0);
}

// ---------------------------------------------------------------------------------------------
// Laser scans and an occupancy map: a simulated run written out in the generic format, as a
// converter of a ROS recording would (its scans as text, its map as map_server files), and
// imported again.

/// The world of the laser tests: the office map, one robot wandering with a 240 deg laser mounted
/// off-centre and turned, odometry that reports its pose, the start known exactly (as an
/// import's).
fs::path write_laser_world(const fs::path& dir) {
  return testing::office_world(
      dir,
      "{encoders: {rate_hz: 50, reports: [pose]}, laser: {rate_hz: 10, fov_deg: 240, beams: 121, "
      "max_range_m: 6, mount: {x: 0.1, y: 0.05, theta_deg: 20}}}",
      30, "  localization: {initial_pose: known, sigma_xy_m: 0, sigma_theta: 0}\n");
}

/// The log's robot-0 records of `kind` (readings) or its true poses.
std::vector<Record> records_of(const fs::path& log, std::optional<SensorKind> kind) {
  LogSource source(log);
  std::vector<Record> out;
  for (const Record& r : read_all(source)) {
    if (kind ? r.type == Record::Type::kReading && r.reading.kind == *kind
             : r.type == Record::Type::kGroundTruth)
      out.push_back(r);
  }
  return out;
}

/// The generic dataset of a simulated log of write_laser_world's: odometry, truth and scans at
/// full precision, the laser described by a LaserScan's first and last angles (the mount's own
/// heading folded into them), the map's image in a sub-folder.
void write_generic_laser_dataset(const fs::path& log, const fs::path& world_dir,
                                 const fs::path& dir) {
  std::string odometry = "t,x,y,theta\n", truth = "# t x y z qx qy qz qw\n", scans = "t,ranges\n";
  for (const Record& r : records_of(log, SensorKind::kEncoders)) {
    const auto& o = std::get<OdometryReading>(r.reading.data).odometry;
    odometry += line("%.17g,%.17g,%.17g,%.17g\n", r.reading.t_s, o.x, o.y, o.theta);
  }
  for (const Record& r : records_of(log, std::nullopt)) {
    truth += line("%.17g %.17g %.17g 0 0 0 %.17g %.17g\n", r.t_s, r.pose.x, r.pose.y,
                  std::sin(r.pose.theta / 2), std::cos(r.pose.theta / 2));
  }
  for (const Record& r : records_of(log, SensorKind::kLaser)) {
    scans += line("%.17g,", r.reading.t_s);
    for (const float range : std::get<LaserScan>(r.reading.data).ranges_m)
      scans += line("%.9g ", static_cast<double>(range));
    scans.back() = '\n';
  }
  std::ofstream(dir / "odometry.csv") << odometry;
  std::ofstream(dir / "groundtruth.tum") << truth;
  std::ofstream(dir / "scans.csv") << scans;
  const double mount_rad = 20.0 * std::numbers::pi / 180.0,
               half_fov = 120.0 * std::numbers::pi / 180.0;
  std::ofstream(dir / "robot.yaml") << line(
      "laser: {angle_min: %.17g, angle_max: %.17g, min_range_m: 0.05, max_range_m: 6, "
      "mount: {x: 0.1, y: 0.05}}\n",
      mount_rad - half_fov, mount_rad + half_fov);
  fs::create_directories(dir / "maps");
  fs::copy_file(world_dir / "office.pgm", dir / "maps" / "office.pgm",
                fs::copy_options::overwrite_existing);
  std::string map = testing::read_file(world_dir / "office.yaml");
  map.replace(map.find("image: office.pgm"), 17, "image: maps/office.pgm");
  std::ofstream(dir / "occupancy.yaml") << map;
}

TEST(GenericImport, LaserScansAndAnOccupancyMapImportAsTheSimulationRecordedThem) {
  const fs::path dir = testing::temp_dir("laser");
  const fs::path world = write_laser_world(dir);
  const fs::path simulated = dir / "simulated.locsimlog";
  const auto run = testing::locsim("run " + world.string() + " --seed 3 --no-variation --out " +
                                   (dir / "run").string() + " -q --log " + simulated.string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const fs::path data = dir / "data";
  fs::create_directories(data);
  write_generic_laser_dataset(simulated, dir, data);
  const fs::path imported = dir / "imported.locsimlog";
  const ImportSummary summary = write_import(read_generic(data), {}, imported);
  EXPECT_NE(describe(summary).find("301 laser scans"), std::string::npos) << describe(summary);

  // The laser as the simulation had it: 121 beams over 240 deg, the mount turned 20 deg.
  const LogSource source(imported);
  ASSERT_TRUE(source.world().map);
  EXPECT_EQ(source.world().map->occupied, LogSource(simulated).world().map->occupied);
  const LaserDef& laser = *source.world().robots.at(0).sensors.laser;
  EXPECT_EQ(laser.beams, 121);
  EXPECT_NEAR(laser.fov_rad, 240.0 * std::numbers::pi / 180.0, 1e-12);
  EXPECT_NEAR(laser.common.mount.theta, 20.0 * std::numbers::pi / 180.0, 1e-12);
  EXPECT_NEAR(laser.common.mount.x, 0.1, 1e-15);
  EXPECT_NEAR(laser.common.mount.y, 0.05, 1e-15);
  EXPECT_EQ(laser.max_range_m, 6.0);
  // Every scan, bit for bit, at its time.
  const std::vector<Record> original = records_of(simulated, SensorKind::kLaser);
  const std::vector<Record> scans = records_of(imported, SensorKind::kLaser);
  ASSERT_EQ(scans.size(), original.size());
  ASSERT_EQ(scans.size(), 301u);  // at 0, 0.1, ... 30 s
  for (std::size_t i = 0; i < scans.size(); ++i) {
    EXPECT_EQ(scans[i].reading.t_s, original[i].reading.t_s);
    ASSERT_EQ(std::get<LaserScan>(scans[i].reading.data).ranges_m,
              std::get<LaserScan>(original[i].reading.data).ranges_m)
        << "scan " << i;
  }

  // AMCL localizes on the import as on the simulation: the same readings and map.
  const auto replay = [&](const fs::path& log, const std::string& name) {
    const fs::path out = dir / name;
    const auto o = testing::locsim("replay " + log.string() + " --out " + out.string() +
                                   " -q --seed 1 --localizer amcl");
    EXPECT_EQ(o.exit_code, 0) << o.output;
    const auto metrics = nlohmann::json::parse(testing::read_file(out / "metrics.json"));
    return metrics["localizers"][0]["position_error_m"]["rms"].get<double>();
  };
  const double simulated_rms = replay(simulated, "replay_simulated");
  const double imported_rms = replay(imported, "replay_imported");
  EXPECT_LT(simulated_rms, 0.15);
  // Equal but for the beams' angles, rebuilt from the scan's first and last (1e-16 rad apart).
  EXPECT_NEAR(imported_rms, simulated_rms, 1e-6);

  // The twin of the import writes the map beside its world (where the world names it) and runs.
  const fs::path twin = dir / "twin" / "twin.yaml";
  const auto made = testing::locsim("twin " + imported.string() + " --out " + twin.string());
  ASSERT_EQ(made.exit_code, 0) << made.output;
  EXPECT_EQ(testing::read_file(dir / "twin" / "maps" / "office.pgm"),
            testing::read_file(dir / "office.pgm"));
  const auto twin_run = testing::locsim("run " + twin.string() + " --duration 5 -q --out " +
                                        (dir / "twin_run").string() + " --localizer amcl");
  EXPECT_EQ(twin_run.exit_code, 0) << twin_run.output;
}

TEST(GenericImport, BadScansAndMapsAreRefusedNamingFileLineAndColumn) {
  const fs::path good = testing::temp_dir("laser_bad_good");
  write_generic_robot(good);
  const auto refused = [&](const std::map<std::string, std::string>& files,
                           const std::string& expected) {
    const fs::path bad = testing::temp_dir("laser_bad");
    fs::copy(good, bad, fs::copy_options::overwrite_existing | fs::copy_options::recursive);
    for (const auto& [name, text] : files) std::ofstream(bad / name) << text;
    const std::string message = refusal([&] { return read_generic(bad); });
    EXPECT_NE(message.find(expected), std::string::npos) << message << "\nexpected: " << expected;
  };
  const std::string laser = "laser: {angle_min: -1, angle_max: 1, max_range_m: 5}\n";
  refused({{"scans.csv", "t,ranges\n0.5,1 2 3\n"}},
          "scans.csv:1: laser scans need the scanner's angles and ranges");
  refused({{"robot.yaml", laser}, {"scans.csv", "t,ranges\n0.5,1 2 3\n0.6,1 2\n"}},
          "scans.csv:3:5: 'ranges': a scan of 2 ranges; the first (line 2) has 3");
  refused({{"robot.yaml", laser}, {"scans.csv", "t,ranges\n0.5,1 2x 3\n"}},
          "scans.csv:2:7: 'ranges': beam 1: '2x' is not a range");
  refused({{"robot.yaml", laser}, {"scans.csv", "t,ranges\n0.5,\n"}},
          "scans.csv:2:5: 'ranges': a scan without ranges");
  refused({{"robot.yaml", "laser: {angle_min: 1, angle_max: 0.5, max_range_m: 5}\n"}},
          "robot.yaml:1:34: 'laser.angle_max': must not be below angle_min");
  refused({{"robot.yaml", "laser: {angle_min: 1, max_range_m: 5}\n"}},
          "'laser': give angle_max or angle_increment");
  std::string seventy = "t,ranges\n0.5,";
  for (int i = 0; i < 70; ++i) seventy += "1 ";
  refused({{"robot.yaml", "laser: {angle_min: 0, angle_increment: 0.1, max_range_m: 5}\n"},
           {"scans.csv", seventy + "\n"}},
          "scans.csv:2:5: 'ranges': 70 beams from angle_min 0 to 6.9 rad span more than a full "
          "turn (");
  refused({{"occupancy.yaml", "image: ../outside.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n"}},
          "occupancy.yaml:1:8: 'image': the image must be a file in the map's folder");
  refused({{"occupancy.yaml", "image: /etc/passwd\nresolution: 0.1\norigin: [0, 0, 0]\n"}},
          "occupancy.yaml:1:8: 'image': the image must be a file in the map's folder");
  {
    // A symbolic link in the folder that leads out of it.
    const fs::path bad = testing::temp_dir("laser_bad_link");
    fs::copy(good, bad, fs::copy_options::overwrite_existing | fs::copy_options::recursive);
    std::ofstream(bad.parent_path() / "secret.pgm") << "P2\n1 1\n255\n0\n";
    fs::create_symlink(bad.parent_path() / "secret.pgm", bad / "map.pgm");
    std::ofstream(bad / "occupancy.yaml") << "image: map.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n";
    const std::string message = refusal([&] { return read_generic(bad); });
    EXPECT_NE(message.find("'image': the image leads out of the map's folder"), std::string::npos)
        << message;
  }
  refused({{"occupancy.yaml", "image: none.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n"}},
          "occupancy.yaml:1:8: 'image'");
}

}  // namespace
}  // namespace locsim
