#include "sim/world/pgm.hpp"

#include <cctype>
#include <string>

#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"

namespace locsim {

namespace {

class Reader {
 public:
  Reader(std::string data, std::filesystem::path file)
      : data_(std::move(data)), file_(std::move(file)) {}

  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(SourceLocation{file_.string()}, "", "not a readable PGM image: " + problem);
  }

  /// Skips whitespace and '#' comments.
  void skip_space() {
    while (pos_ < data_.size()) {
      if (data_[pos_] == '#') {
        while (pos_ < data_.size() && data_[pos_] != '\n') ++pos_;
      } else if (std::isspace(static_cast<unsigned char>(data_[pos_]))) {
        ++pos_;
      } else {
        break;
      }
    }
  }

  long number(const char* what) {
    skip_space();
    long value = 0;
    std::size_t digits = 0;
    while (pos_ < data_.size() && std::isdigit(static_cast<unsigned char>(data_[pos_]))) {
      value = value * 10 + (data_[pos_++] - '0');
      if (value > 1'000'000'000) fail(std::string(what) + " too large");
      ++digits;
    }
    if (digits == 0) fail(std::string("expected ") + what);
    return value;
  }

  std::size_t remaining() const { return data_.size() - pos_; }

  std::string_view take(std::size_t n) {
    if (data_.size() - pos_ < n) fail("truncated pixel data");
    const std::string_view out(data_.data() + pos_, n);
    pos_ += n;
    return out;
  }

  void skip_one_space() {
    if (pos_ >= data_.size() || !std::isspace(static_cast<unsigned char>(data_[pos_]))) {
      fail("expected one whitespace character before the pixel data");
    }
    ++pos_;
  }

  const std::string& data() const { return data_; }

 private:
  std::string data_;
  std::filesystem::path file_;
  std::size_t pos_ = 0;
};

}  // namespace

GrayImage read_pgm(const std::filesystem::path& file) {
  const Activity reading("reading the map image " + file.string());
  Reader reader(read_input_file(file, kMaxPgmFileBytes), file);
  if (reader.data().size() < 2 || reader.data()[0] != 'P' ||
      (reader.data()[1] != '5' && reader.data()[1] != '2')) {
    reader.fail("expected the magic number P5 or P2 (map images must be PGM, as map_saver writes)");
  }
  const bool binary = reader.data()[1] == '5';
  reader.take(2);
  GrayImage image;
  image.width = static_cast<int>(reader.number("width"));
  image.height = static_cast<int>(reader.number("height"));
  const long max_value = reader.number("maximum value");
  if (image.width <= 0 || image.height <= 0) reader.fail("width and height must be > 0");
  if (max_value <= 0 || max_value > 65535) reader.fail("maximum value must be in 1..65535");
  // The header is checked against the documented maximum and against the file's own size before
  // any pixel is allocated: 19 bytes must not make us reserve gigabytes.
  const std::size_t count = static_cast<std::size_t>(image.width) * image.height;
  const std::string size = std::to_string(image.width) + " x " + std::to_string(image.height);
  if (count > kMaxMapPixels) {
    reader.fail(size + " pixels; a map has at most " + std::to_string(kMaxMapPixels) +
                " (docs/worlds.md, Limits)");
  }
  const std::size_t bytes_per_pixel = max_value < 256 ? 1 : 2;
  if (binary) reader.skip_one_space();
  // Text pixels take at least a digit and a separator each.
  const std::size_t least_bytes = binary ? count * bytes_per_pixel : 2 * count - 1;
  if (reader.remaining() < least_bytes) {
    reader.fail("truncated pixel data: the header announces " + size + " pixels (at least " +
                std::to_string(least_bytes) + " bytes) and " + std::to_string(reader.remaining()) +
                " bytes follow it");
  }
  image.pixels.resize(count);
  const auto scale = [&](long value) {
    if (value > max_value) reader.fail("pixel value above the maximum value");
    return static_cast<unsigned char>((value * 255 + max_value / 2) / max_value);
  };
  if (binary) {
    const std::string_view raw = reader.take(count * bytes_per_pixel);
    for (std::size_t i = 0; i < count; ++i) {
      const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(raw[k]); };
      const long value = bytes_per_pixel == 1 ? byte(i) : (byte(2 * i) << 8) | byte(2 * i + 1);
      image.pixels[i] = scale(value);
    }
  } else {
    for (std::size_t i = 0; i < count; ++i) image.pixels[i] = scale(reader.number("pixel value"));
  }
  return image;
}

}  // namespace locsim
