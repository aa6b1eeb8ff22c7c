// A documented text format anyone can write from their own dataset in a few lines
// (docs/real_data.md, "The generic format"): map.csv, and per robot odometry.csv,
// detections.csv and groundtruth.tum. `locsim import generic`.
#pragma once

#include <filesystem>

#include "sim/producers/import_log.hpp"

namespace locsim {

/// Reads DIR: map.csv (id,x,y) and either one robot's files in DIR itself (robot name "robot") or
/// one sub-folder per robot (named after it, in name order). Throws InputError naming the file,
/// line, column and column name of the first bad value.
ImportedDataset read_generic(const std::filesystem::path& dir);

}  // namespace locsim
