// The UTIAS Multi-Robot Cooperative Localization and Mapping dataset (MRCLAM; Leung et al.,
// IJRR 2011; http://asrl.utias.utoronto.ca/datasets/mrclam/) as a record stream: five iRobot
// Create robots (subjects 1-5) driving among 15 landmarks (subjects 6-20), each logging its
// commanded velocity and the barcodes its camera reads (range, bearing), with Vicon ground truth.
// `locsim import mrclam`; docs/real_data.md.
#pragma once

#include <filesystem>
#include <vector>

#include "sim/producers/import_log.hpp"

namespace locsim {

inline constexpr int kMrclamRobots = 5;  // subjects 1..5 are robots, the others landmarks

struct MrclamImportOptions {
  std::filesystem::path dir;  // holding Barcodes.dat, Landmark_Groundtruth.dat, RobotN_*.dat
  std::vector<int> robots;    // subject numbers (1..5), in the world's order; empty: all five
};

/// Reads the dataset's files. Throws InputError naming the file, line, column and key of the
/// first bad value (a truncated line, a non-number, a time that goes back, an empty file).
/// Detections that cannot be used are dropped and counted by reason: a barcode Barcodes.dat does
/// not list (misreads happen), a robot that is not imported, a landmark without a position.
ImportedDataset read_mrclam(const MrclamImportOptions& options);

}  // namespace locsim
