// A recorded log (`locsim run --log`) as a producer of the record stream: its records as they
// were recorded, and the world and scenario it was recorded in, rebuilt from the text its header
// carries.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "sim/scenario/scenario_def.hpp"
#include "sim/stream/log_file.hpp"
#include "sim/stream/record_checks.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

class LogSource {
 public:
  /// Opens the log and rebuilds its world. Throws InputError naming the file and the problem.
  /// With `robots` (names), the log as if it held only those robots, in the world's order: the
  /// others' readings, true poses and events are skipped, and detections of them dropped (the
  /// kept robots' detections of robots renumbered). Empty: every robot.
  explicit LogSource(const std::filesystem::path& file,
                     const std::vector<std::string>& robots = {});
  const WorldDef& world() const { return view_ ? *view_ : world_; }
  const ScenarioDef& scenario() const { return scenario_; }
  std::uint64_t seed() const { return seed_; }
  const nlohmann::ordered_json& header() const { return reader_.header(); }
  /// The next record; false after the last. Throws InputError on a corrupt or truncated log, and
  /// on a record its world cannot have produced (another robot's, a sensor the robot lacks, a
  /// laser scan of another beam count, odometry fields its encoders do not report, a detection
  /// of a robot that is not another robot of the world, a value out of a world file's ranges, a
  /// time that goes back, two true poses of a robot at one instant), which the consumers could
  /// not take.
  bool next(Record& record);

 private:
  void check(const Record& record) const;
  /// What a reading of a sensor the robot has may hold: odometry fields as its encoders report,
  /// receivers and beams it has, detected robots that are other robots of the world.
  void check_contents(const Record& record, const RobotDef& robot) const;
  /// Renumbers a checked record for the view; false when it is not in it.
  bool to_view(Record& record) const;
  LogReader reader_;
  StreamOrderCheck order_;
  WorldDef world_;                // as recorded: the records are checked against it
  std::optional<WorldDef> view_;  // with the robots asked for only
  std::vector<int> view_index_;   // recorded robot index -> the view's, or -1
  ScenarioDef scenario_;
  std::uint64_t seed_ = 0;
};

}  // namespace locsim
