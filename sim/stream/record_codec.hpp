// The binary encoding of records: written once here, read once here, for the log file
// (stream/log_file) and for the pipes to localizer worker processes (plugin_host/worker). Layout:
// docs/log_format.md. Little-endian (the hosts we build for: x86-64, arm64).
#pragma once

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <string_view>

#include "sim/stream/record.hpp"

namespace locsim {

/// Appends `value`'s bytes to `out`.
template <class T>
void put(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out.append(bytes, sizeof(T));
}
/// u32 byte count, then the bytes.
void put_string(std::string& out, std::string_view s);

/// A payload too short for what it claims to hold, or of an unknown kind.
class DecodeError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Reads values out of a payload, throwing DecodeError when it is too short.
class ByteReader {
 public:
  explicit ByteReader(std::string_view data) : data_(data) {}
  template <class T>
  T get() {
    if (data_.size() - pos_ < sizeof(T)) throw DecodeError("payload too short");
    T value;
    std::memcpy(&value, data_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return value;
  }
  std::string get_string();
  /// `count` items of `item_bytes` each must still fit (checked before allocating for them).
  void expect(std::size_t count, std::size_t item_bytes) const;
  std::size_t remaining() const { return data_.size() - pos_; }

 private:
  std::string_view data_;
  std::size_t pos_ = 0;
};

/// The version of the encoding (the log format's version): 2 added odometry fields (velocity,
/// no ticks), detections' targets and the range_bearing sensor. Version 1 payloads still decode.
inline constexpr std::uint32_t kRecordFormatVersion = 2;

/// Appends the payload of a reading, ground-truth or event record to `payload` (the end record
/// is the log's own business), in the current version.
void encode_record(const Record& record, std::string& payload);
/// Fills `record` from a payload of type `type` written in `version`. Throws DecodeError.
void decode_record(Record::Type type, std::string_view payload, Record& record,
                   std::uint32_t version = kRecordFormatVersion);

}  // namespace locsim
