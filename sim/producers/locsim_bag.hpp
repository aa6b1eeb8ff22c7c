// A bag `locsim export` wrote, read back as the log it was exported from: the log's header rides
// on /locsim/log_header (the world and scenario, so the same world is rebuilt), and every record
// is rebuilt from the bag's topics (the ROS messages a ROS user sees, and locsim_msgs for what no
// ROS message carries), in the order of the records' numbers (their MCAP sequence). Times come
// back to the nanosecond; an odometry heading through its quaternion to 1e-12 rad; everything
// else (ranges, counts, detections, events) exactly. `locsim import rosbag2` takes this path for
// such a bag (docs/ros.md).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>

namespace locsim {

/// Writes the log rebuilt from `bag` to `out` (through `out`.partial, renamed at the end, and
/// read back as a replay reads it before that). Returns the records written, or nullopt when the
/// bag has no /locsim/log_header (not one locsim wrote). Throws InputError naming the message
/// (file, byte, topic) that cannot be read or rebuilt.
std::optional<std::uint64_t> rebuild_locsim_log(const std::filesystem::path& bag,
                                                const std::filesystem::path& out);

}  // namespace locsim
