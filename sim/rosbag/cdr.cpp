#include "sim/rosbag/cdr.hpp"

#include <limits>

namespace locsim::rosbag {

CdrReader::CdrReader(std::string_view data) : data_(data) {
  if (data.size() < 4) {
    throw CdrError("the message is " + std::to_string(data.size()) +
                   " bytes, shorter than CDR's 4-byte header");
  }
  // Byte 1 is the representation: 0 plain CDR big-endian, 1 little-endian. The parameter-list
  // (2, 3) and XCDR2 forms are what DDS uses for mutable types, never what rmw writes for a topic.
  if (data[0] != 0 || (data[1] != 0 && data[1] != 1)) {
    throw CdrError(
        "byte 0: encapsulation 0x" + std::to_string(static_cast<unsigned char>(data[0])) + "/" +
        std::to_string(static_cast<unsigned char>(data[1])) + " is not plain CDR (0/0 or 0/1)");
  }
  little_endian_ = data[1] == 1;
  swap_ = little_endian_ != (std::endian::native == std::endian::little);
}

void CdrReader::align(std::size_t size) {
  const std::size_t misaligned = (pos_ - 4) % size;
  if (misaligned != 0) {
    // Padding at the very end of a message is not written, so it may be missing only there.
    pos_ = std::min(data_.size(), pos_ + (size - misaligned));
  }
}

void CdrReader::need(std::size_t bytes, const char* what) const {
  if (bytes > data_.size() - pos_) {
    throw CdrError("byte " + std::to_string(pos_) + ": " + what + " of " + std::to_string(bytes) +
                   " bytes runs past the message's end (" + std::to_string(data_.size()) +
                   " bytes)");
  }
}

std::string CdrReader::read_string() {
  const std::uint32_t length = read<std::uint32_t>();
  need(length, "a string");
  if (length == 0) return {};  // some writers send an empty string as length 0, no NUL
  std::string text(data_.substr(pos_, length - 1));
  pos_ += length;
  // The NUL is part of the format; a string whose last byte is not one is taken as it is (Fast
  // DDS and Cyclone agree on it; a few hand-written bags do not).
  if (const std::size_t nul = text.find('\0'); nul != std::string::npos) text.resize(nul);
  return text;
}

std::uint32_t CdrReader::read_count(std::size_t min_element_bytes) {
  const std::size_t at = pos_;
  const std::uint32_t count = read<std::uint32_t>();
  if (min_element_bytes > 0 && count > remaining() / min_element_bytes) {
    throw CdrError("byte " + std::to_string(at) + ": a sequence of " + std::to_string(count) +
                   " elements cannot fit in the " + std::to_string(remaining()) + " bytes left");
  }
  return count;
}

void CdrWriter::write_string(std::string_view text) {
  write_count(text.size() + 1);
  out_.append(text);
  out_.push_back('\0');
}

void CdrWriter::write_count(std::size_t count) {
  if (count > std::numeric_limits<std::uint32_t>::max()) {
    throw std::length_error("CDR: a sequence of " + std::to_string(count) +
                            " elements is longer than a uint32 counts");
  }
  write(static_cast<std::uint32_t>(count));
}

}  // namespace locsim::rosbag
