// ROS 2's wire format: the plain CDR (OMG XCDR version 1) that rmw implementations write and
// rosbag2 stores. A message is a 4-byte encapsulation header (0x00, 0x00 big-endian or 0x01
// little-endian, then two option bytes) and the fields in order, each primitive aligned to its own
// size (at most 8) counted from the end of the header. Strings are a uint32 length counting a
// terminating NUL, then the bytes and the NUL; sequences a uint32 count, then the elements; fixed
// arrays the elements alone.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>

namespace locsim::rosbag {

/// A message that is not valid CDR (cut short, a length past its end, an unknown encapsulation).
/// The message names the byte where reading stopped; the bag reader adds the topic and time.
class CdrError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Reads one serialized message, a view of its bytes (they must outlive the reader). Every read
/// checks the bytes are there: a bad length or a message
/// cut short throws CdrError, never reads past `data`.
class CdrReader {
 public:
  explicit CdrReader(std::string_view data);

  template <typename T>
  T read() {
    static_assert(std::is_arithmetic_v<T>);
    align(sizeof(T));
    need(sizeof(T), "a number");
    T value;
    std::memcpy(&value, data_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    if constexpr (sizeof(T) > 1) {
      if (swap_) value = byteswap(value);
    }
    return value;
  }
  /// Reads `count` numbers of a fixed array or a sequence into `out` (converted to double).
  template <typename T>
  void read_numbers(std::size_t count, double* out) {
    if (count == 0) return;
    align(sizeof(T));
    need(count * sizeof(T), "an array");
    for (std::size_t i = 0; i < count; ++i) out[i] = static_cast<double>(read<T>());
  }
  std::string read_string();
  /// A sequence's element count, refused when even elements of `min_element_bytes` each cannot fit
  /// in what is left (a corrupt count must not make the caller allocate gigabytes).
  std::uint32_t read_count(std::size_t min_element_bytes);
  /// Bytes read so far, the header included.
  std::size_t offset() const { return pos_; }
  std::size_t remaining() const { return data_.size() - pos_; }
  bool little_endian() const { return little_endian_; }

 private:
  template <typename T>
  static T byteswap(T value) {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
    std::memcpy(&value, bytes, sizeof(T));
    return value;
  }
  void align(std::size_t size);
  void need(std::size_t bytes, const char* what) const;
  std::string_view data_;
  std::size_t pos_ = 4;
  bool little_endian_ = true;
  bool swap_ = false;
};

/// Writes one message, little-endian (as every rmw on x86 and ARM does).
class CdrWriter {
 public:
  CdrWriter() { out_.assign("\x00\x01\x00\x00", 4); }

  template <typename T>
  void write(T value) {
    static_assert(std::is_arithmetic_v<T>);
    static_assert(std::endian::native == std::endian::little, "CdrWriter writes little-endian");
    align(sizeof(T));
    out_.append(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  void write_string(std::string_view text);
  void write_count(std::size_t count);
  /// Starts again with an empty message (keeps the buffer's memory).
  void clear() { out_.resize(4); }
  const std::string& bytes() const { return out_; }

 private:
  void align(std::size_t size) {
    const std::size_t misaligned = (out_.size() - 4) % size;
    if (misaligned != 0) out_.append(size - misaligned, '\0');
  }
  std::string out_;
};

}  // namespace locsim::rosbag
