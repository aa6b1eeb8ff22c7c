#include "sim/producers/mrclam_import.hpp"

#include <algorithm>
#include <map>
#include <numbers>
#include <set>

#include "sim/common/errors.hpp"
#include "sim/producers/text_table.hpp"
#include "sim/stream/record_checks.hpp"

namespace locsim {

namespace fs = std::filesystem;

namespace {

// MRCLAM's robots are iRobot Creates: 258 mm between the wheels, 33 cm body diameter (iRobot
// Create Open Interface manual), wheels of 72 mm diameter. Only drawn and given to filters that
// ask; the dataset's odometry is a velocity, not wheel ticks.
constexpr double kCreateRadiusM = 0.165;
constexpr double kCreateWheelBaseM = 0.258;
constexpr double kCreateWheelRadiusM = 0.036;

using Layout = TextTable::Layout;

/// A stream's source (its times are column 0, "time"), and the file among those the import read.
StreamSource source_of(const TextTable& table, std::vector<fs::path>& files_read) {
  files_read.push_back(table.file());
  return {table.file().string(), table.column_name(0)};
}

SamplePlace place_of(const TextTable& table, const TextTable::Row& row) {
  return {row.line, table.column_in_line(row, 0)};
}

}  // namespace

ImportedDataset read_mrclam(const MrclamImportOptions& options) {
  const fs::path& dir = options.dir;
  if (dataset_file_type(dir) != fs::file_type::directory) {
    throw InputError(SourceLocation{dir.string()}, "",
                     "not a folder (expected an MRCLAM dataset's folder with Barcodes.dat, "
                     "Landmark_Groundtruth.dat and Robot1_Odometry.dat ...)");
  }
  std::vector<int> subjects = options.robots;
  if (subjects.empty()) {
    for (int n = 1; n <= kMrclamRobots; ++n) subjects.push_back(n);
  }
  for (std::size_t i = 0; i < subjects.size(); ++i) {
    if (subjects[i] < 1 || subjects[i] > kMrclamRobots)
      throw InputError("--robots: MRCLAM's robots are subjects 1 to 5, got " +
                       std::to_string(subjects[i]));
    if (std::count(subjects.begin(), subjects.end(), subjects[i]) > 1)
      throw InputError("--robots: robot " + std::to_string(subjects[i]) + " given twice");
  }

  ImportedDataset dataset;
  // barcode -> subject
  const TextTable barcodes(dir / "Barcodes.dat", Layout::kWhitespace, {"subject", "barcode"});
  dataset.files.push_back(barcodes.file());
  std::map<long long, int> subject_of;
  std::set<long long> subjects_seen;
  for (const auto& row : barcodes.rows()) {
    const long long subject = barcodes.whole(row, 0, 1, 1000000);
    const long long barcode = barcodes.whole(row, 1, 0, 1000000);
    if (!subjects_seen.insert(subject).second) barcodes.fail(row, 0, "subject listed twice");
    if (!subject_of.emplace(barcode, static_cast<int>(subject)).second)
      barcodes.fail(row, 1, "barcode listed twice");
  }

  dataset.name = imported_world_name("mrclam_", dir);
  dataset.t0_key = "t0_unix_s";
  dataset.source = {{"format", "mrclam"},
                    {"path", fs::absolute(dir).lexically_normal().string()},
                    {"robots", subjects}};

  const TextTable landmarks(dir / "Landmark_Groundtruth.dat", Layout::kWhitespace,
                            {"subject", "x", "y", "x_sigma", "y_sigma"});
  dataset.files.push_back(landmarks.file());
  std::set<int> landmark_ids;
  for (const auto& row : landmarks.rows()) {
    const int subject = static_cast<int>(landmarks.whole(row, 0, 1, 1000000));
    if (subject <= kMrclamRobots) landmarks.fail(row, 0, "subjects 1-5 are robots, not landmarks");
    if (!subjects_seen.contains(subject)) {
      landmarks.fail(row, 0,
                     "subject " + std::to_string(subject) + " has no barcode in " +
                         (dir / "Barcodes.dat").string());
    }
    if (!landmark_ids.insert(subject).second) landmarks.fail(row, 0, "landmark listed twice");
    dataset.landmarks.push_back({subject,
                                 {landmarks.number(row, 1, kWorldCoordinateRange),
                                  landmarks.number(row, 2, kWorldCoordinateRange)}});
  }

  for (std::size_t index = 0; index < subjects.size(); ++index) {
    const int subject = subjects[index];
    const std::string prefix = "Robot" + std::to_string(subject) + "_";
    ImportedRobot robot;
    robot.name = "robot" + std::to_string(subject);
    robot.radius_m = kCreateRadiusM;
    robot.wheel_base_m = kCreateWheelBaseM;
    robot.wheel_radius_m = kCreateWheelRadiusM;

    const TextTable odometry(dir / (prefix + "Odometry.dat"), Layout::kWhitespace,
                             {"time", "forward_velocity", "angular_velocity"});
    odometry.check_times(0, kDatasetTimeRange);
    robot.odometry_source = source_of(odometry, dataset.files);
    robot.odometry.reserve(odometry.rows().size());
    for (const auto& row : odometry.rows()) {
      ImportedRobot::Odometry o;
      o.t_s = odometry.number(row, 0);
      o.at = place_of(odometry, row);
      o.reading.fields = kOdometryVelocity;  // MRCLAM logs the commanded velocity only
      o.reading.v_mps = odometry.number(row, 1, kReadingSpeedRange);
      o.reading.omega_radps = odometry.number(row, 2, kReadingTurnRateRange);
      robot.odometry.push_back(o);
    }

    const TextTable truth(dir / (prefix + "Groundtruth.dat"), Layout::kWhitespace,
                          {"time", "x", "y", "orientation"});
    truth.check_times(0, kDatasetTimeRange);
    robot.truth_source = source_of(truth, dataset.files);
    robot.truth.reserve(truth.rows().size());
    for (const auto& row : truth.rows()) {
      robot.truth.push_back({truth.number(row, 0),
                             {truth.number(row, 1, kWorldCoordinateRange),
                              truth.number(row, 2, kWorldCoordinateRange),
                              wrap_angle(truth.number(row, 3, kHeadingRange))},
                             place_of(truth, row)});
    }

    const TextTable measurements(dir / (prefix + "Measurement.dat"), Layout::kWhitespace,
                                 {"time", "subject", "range", "bearing"});
    measurements.check_times(0, kDatasetTimeRange);
    robot.detections_source = source_of(measurements, dataset.files);
    for (const auto& row : measurements.rows()) {
      const double t_s = measurements.number(row, 0);
      const long long barcode = measurements.whole(row, 1, 0, 1000000);
      const double range_m = measurements.number(row, 2, kReadingRangeRange);
      const double bearing_rad = measurements.number(row, 3);
      if (range_m < 0.0) measurements.fail(row, 2, "a negative range");
      if (std::abs(bearing_rad) > std::numbers::pi)
        measurements.fail(row, 3, "a bearing beyond +-pi");
      Detection d;
      d.range_m = range_m;
      d.bearing_rad = bearing_rad;
      const auto known = subject_of.find(barcode);
      if (known == subject_of.end()) {
        dataset.dropped.push_back({t_s, "unknown barcode"});  // a misread: the datasets have a few
        continue;
      }
      const int seen = known->second;
      if (seen <= kMrclamRobots) {
        const auto it = std::find(subjects.begin(), subjects.end(), seen);
        if (it == subjects.end()) {
          dataset.dropped.push_back({t_s, "robot not imported"});
          continue;
        }
        if (seen == subject) {
          dataset.dropped.push_back({t_s, "own barcode"});
          continue;
        }
        d.target = DetectionTarget::kRobot;
        d.id = static_cast<int>(it - subjects.begin());
      } else {
        if (!landmark_ids.contains(seen)) {
          dataset.dropped.push_back({t_s, "landmark without a position"});
          continue;
        }
        d.id = seen;
      }
      // The dataset's identification is the best truth there is (no simulator knows better).
      d.truth_id = d.id;
      if (robot.detections.empty() || robot.detections.back().t_s != t_s)
        robot.detections.push_back({t_s, {}, place_of(measurements, row)});
      robot.detections.back().detections.push_back(d);
    }
    dataset.robots.push_back(std::move(robot));
  }
  return dataset;
}

}  // namespace locsim
