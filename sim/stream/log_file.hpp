// One file holding a record stream (sensor readings, ground truth, events) and what is needed to
// rebuild its world, so that localizers can be run on it again without simulating
// (`locsim run --log`, `locsim replay`). The writer is a consumer of the stream; the reader
// feeds a producer (producers/log_source).
//
// Format (little-endian), version 2 (version 1 logs are still read):
//   "LOCSIMLG", u32 version, u32 header length, header (JSON text), u32 CRC-32 of a zero byte
//   followed by the header;
//   then records: u8 type, u32 payload length, payload, u32 CRC-32 of type and payload;
//   the last record is the end record (type 255, payload: u64 number of records before it).
// Record payloads: stream/record_codec and docs/log_format.md.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "sim/common/files.hpp"
#include "sim/stream/record.hpp"
#include "sim/stream/record_codec.hpp"

namespace locsim {

inline constexpr std::uint32_t kLogFormatVersion = kRecordFormatVersion;
inline constexpr std::uint32_t kOldestLogFormatVersion = 1;

class LogWriter final : public RecordConsumer {
 public:
  /// Every write is checked (as it goes to the system: a full buffer, a flush, the end): a log
  /// that cannot be written whole throws std::runtime_error naming the file and the system's
  /// reason, so that no run that lost part of its log says it completed.
  LogWriter(const std::filesystem::path& file, const nlohmann::ordered_json& header);
  void consume(const Record& record) override;
  void flush() override;
  /// Writes the end record and closes; a log without it reads as truncated.
  void finish();

 private:
  void write_frame(Record::Type type);
  OutputFile out_;
  std::string payload_, frame_;
  std::uint64_t records_ = 0;
};

class LogReader {
 public:
  /// Opens and checks the header. Throws InputError naming the file and what is wrong.
  explicit LogReader(const std::filesystem::path& file);
  const nlohmann::ordered_json& header() const { return header_; }
  const std::filesystem::path& file() const { return file_; }
  /// The format version the file was written in.
  std::uint32_t version() const { return version_; }
  /// The next record; false after the end record. Throws InputError on a corrupt or truncated log.
  bool next(Record& record);
  /// Checks, by reading the file's last bytes only, that it ends with an end record: a log whose
  /// recording was cut short is refused before anything is replayed. Throws InputError.
  void check_end();
  /// Throws InputError naming the file, `problem`, and the number and offset of the record last
  /// read (for checks of a record's contents, producers/log_source).
  [[noreturn]] void reject(const std::string& problem) const;

 private:
  [[noreturn]] void fail(const std::string& problem) const;
  /// Reads `n` bytes into `out`, allocating no more than what the file holds (plus a chunk), so
  /// that a corrupt length cannot ask for gigabytes. False when the file ends first.
  bool read_bytes(std::string& out, std::size_t n);
  std::filesystem::path file_;
  std::ifstream in_;
  nlohmann::ordered_json header_;
  std::uint64_t records_ = 0;
  std::uint32_t version_ = 0;
  std::uint64_t offset_ = 0;       // of the next record [byte]
  std::uint64_t last_offset_ = 0;  // of the record last read [byte]
  std::string payload_;
};

}  // namespace locsim
