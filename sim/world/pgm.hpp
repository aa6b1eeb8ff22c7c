// Reading netpbm PGM images (P5 binary and P2 text, 8 or 16 bit), the format ROS map_server maps
// use. Hand-written rather than through OpenCV: linking OpenCV's image codecs into the core
// multiplied the start-up time of every `locsim run` process by 20 (0.11 s vs 5 ms, measured),
// which sweeps of thousands of short runs pay each time.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <vector>

namespace locsim {

struct GrayImage {
  int width = 0;
  int height = 0;
  std::vector<unsigned char> pixels;  // row-major from the top row, scaled to 0..255
};

/// The most pixels a map image may have (e.g. 5792 x 5792, 290 m square at 5 cm), and the
/// largest file read (a text P2 image of that many pixels). The header is checked against both,
/// and against the file's size, before any pixel is allocated.
inline constexpr std::size_t kMaxMapPixels = std::size_t{1} << 25;
inline constexpr std::uintmax_t kMaxPgmFileBytes = std::uintmax_t{256} << 20;

/// Throws InputError naming the file and the problem (not PGM, truncated, bad header).
GrayImage read_pgm(const std::filesystem::path& file);

}  // namespace locsim
