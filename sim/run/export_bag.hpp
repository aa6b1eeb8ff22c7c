// `locsim export LOG --rosbag2 OUT`: a recorded log (a run's --log, an import) as a ROS 2 bag
// (consumers/rosbag_recorder), for ROS tools and localizers: `ros2 bag play`, Foxglove, RViz.
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

#include "sim/consumers/rosbag_recorder.hpp"

namespace locsim {

struct ExportSummary {
  std::uint64_t records = 0;   // of the log
  std::uint64_t messages = 0;  // in the bag
  std::uintmax_t bag_bytes = 0;
};

/// Refuses (InputError) a bag folder OUT that exists, unless `overwrite` and it is a bag folder
/// (metadata.yaml, .mcap and .db3 files only) that holds none of `inputs` (what locsim reads),
/// and one whose parent cannot be a folder. `export` and --rosbag2 of `run` and `replay` check it.
void check_bag_folder(const std::filesystem::path& out, bool overwrite,
                      const std::vector<std::filesystem::path>& inputs);

/// Writes the bag into OUT.partial and renames it OUT at the end: a failed export leaves no bag.
/// OUT must not exist, unless `overwrite` and it is a bag folder (metadata.yaml, .mcap and .db3
/// files only) that does not hold the log. Throws InputError (a bad log, OUT in the way) or
/// std::runtime_error (a write that fails).
ExportSummary export_rosbag2(const std::filesystem::path& log, const std::filesystem::path& out,
                             RosbagRecorderOptions options = {}, bool overwrite = false);

}  // namespace locsim
