// Reading netpbm PGM images (P5 binary and P2 text, 8 or 16 bit), the format ROS map_server maps
// use. Hand-written rather than through OpenCV: linking OpenCV's image codecs into the core
// multiplied the start-up time of every `locsim run` process by 20 (0.11 s vs 5 ms, measured),
// which sweeps of thousands of short runs pay each time.
#pragma once

#include <filesystem>
#include <vector>

namespace locsim {

struct GrayImage {
  int width = 0;
  int height = 0;
  std::vector<unsigned char> pixels;  // row-major from the top row, scaled to 0..255
};

/// Throws InputError naming the file and the problem (not PGM, truncated, bad header).
GrayImage read_pgm(const std::filesystem::path& file);

}  // namespace locsim
