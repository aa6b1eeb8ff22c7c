#include "sim/producers/generic_import.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>

#include "sim/common/errors.hpp"
#include "sim/producers/text_table.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

namespace fs = std::filesystem;

namespace {

using Layout = TextTable::Layout;

ImportedRobot read_robot(const fs::path& dir, const std::string& name,
                         const std::set<int>& landmark_ids,
                         const std::vector<std::string>& robot_names) {
  ImportedRobot robot;
  robot.name = name;

  const TextTable odometry(dir / "odometry.csv", Layout::kCsv, {"t"},
                           {"v", "omega", "x", "y", "theta"});
  const int t = odometry.column("t");
  const int v = odometry.column("v"), omega = odometry.column("omega");
  const int x = odometry.column("x"), y = odometry.column("y"), theta = odometry.column("theta");
  const bool velocity = v >= 0 && omega >= 0, pose = x >= 0 && y >= 0 && theta >= 0;
  if ((v >= 0) != (omega >= 0) || (x >= 0) != (y >= 0) || (x >= 0) != (theta >= 0) ||
      (!velocity && !pose)) {
    throw InputError(SourceLocation{odometry.file().string(), odometry.rows().front().line - 1}, "",
                     "the header row must name t,v,omega or t,x,y,theta or both");
  }
  odometry.check_non_decreasing(t);
  for (const auto& row : odometry.rows()) {
    ImportedRobot::Odometry o;
    o.t_s = odometry.number(row, t);
    o.reading.fields = 0;
    if (velocity) {
      o.reading.fields |= kOdometryVelocity;
      o.reading.v_mps = odometry.number(row, v);
      o.reading.omega_radps = odometry.number(row, omega);
    }
    if (pose) {
      o.reading.fields |= kOdometryPose;
      o.reading.odometry = {odometry.number(row, x), odometry.number(row, y),
                            wrap_angle(odometry.number(row, theta))};
    }
    robot.odometry.push_back(o);
  }

  robot.truth = read_tum(dir / "groundtruth.tum");

  if (fs::exists(dir / "detections.csv")) {
    const TextTable detections(dir / "detections.csv", Layout::kCsv,
                               {"t", "id", "range", "bearing"}, {"target"});
    const int dt = detections.column("t"), id = detections.column("id");
    const int range = detections.column("range"), bearing = detections.column("bearing");
    const int target = detections.column("target");
    detections.check_non_decreasing(dt);
    for (const auto& row : detections.rows()) {
      const double t_s = detections.number(row, dt);
      Detection d;
      d.range_m = detections.number(row, range);
      d.bearing_rad = detections.number(row, bearing);
      if (d.range_m < 0.0) detections.fail(row, range, "a negative range");
      if (std::abs(d.bearing_rad) > 2.0 * std::numbers::pi)
        detections.fail(row, bearing, "a bearing beyond +-2 pi (radians expected)");
      const std::string_view kind = target >= 0 ? detections.text(row, target) : "landmark";
      if (kind == "robot") {
        d.target = DetectionTarget::kRobot;
        const long long index =
            detections.whole(row, id, 0, static_cast<long long>(robot_names.size()) - 1);
        d.id = static_cast<int>(index);
        if (robot_names[static_cast<std::size_t>(index)] == name)
          detections.fail(row, id, "a robot cannot detect itself");
      } else if (kind == "landmark" || kind.empty()) {
        d.id =
            static_cast<int>(detections.whole(row, id, -1, static_cast<long long>(kIdRange.max)));
        if (d.id >= 0 && !landmark_ids.contains(d.id))
          detections.fail(row, id, "landmark " + std::to_string(d.id) + " is not in map.csv");
      } else {
        detections.fail(row, target,
                        "target '" + std::string(kind) + "': expected landmark or robot");
      }
      d.truth_id = d.id;
      if (robot.detections.empty() || robot.detections.back().t_s != t_s)
        robot.detections.push_back({t_s, {}});
      robot.detections.back().detections.push_back(d);
    }
  }
  return robot;
}

}  // namespace

ImportedDataset read_generic(const fs::path& dir) {
  if (!fs::is_directory(dir)) {
    throw InputError(SourceLocation{dir.string()}, "",
                     "not a folder (expected map.csv and odometry.csv, groundtruth.tum, "
                     "detections.csv in it or in one sub-folder per robot)");
  }
  ImportedDataset dataset;
  const fs::path absolute = fs::absolute(dir).lexically_normal();
  dataset.name = "imported_" + absolute.filename().string();
  std::set<int> landmark_ids;
  if (fs::exists(dir / "map.csv")) {
    const TextTable map(dir / "map.csv", Layout::kCsv, {"id", "x", "y"});
    for (const auto& row : map.rows()) {
      const int id = static_cast<int>(map.whole(row, 0, 0, static_cast<long long>(kIdRange.max)));
      if (!landmark_ids.insert(id).second) map.fail(row, 0, "landmark id listed twice");
      dataset.landmarks.push_back({id, {map.number(row, 1), map.number(row, 2)}});
    }
  }
  std::vector<std::pair<std::string, fs::path>> robots;
  if (fs::exists(dir / "odometry.csv")) {
    robots.emplace_back("robot", dir);
  } else {
    for (const auto& entry : fs::directory_iterator(dir)) {
      if (entry.is_directory() && fs::exists(entry.path() / "odometry.csv"))
        robots.emplace_back(entry.path().filename().string(), entry.path());
    }
    std::sort(robots.begin(), robots.end());
  }
  if (robots.empty()) {
    throw InputError(SourceLocation{dir.string()}, "",
                     "no odometry.csv in the folder or in any sub-folder");
  }
  std::vector<std::string> names;
  for (const auto& [name, path] : robots) names.push_back(name);
  dataset.source = {{"format", "generic"}, {"path", absolute.string()}, {"robots", names}};
  for (const auto& [name, path] : robots)
    dataset.robots.push_back(read_robot(path, name, landmark_ids, names));
  return dataset;
}

}  // namespace locsim
