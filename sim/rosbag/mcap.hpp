// MCAP, the container rosbag2 records into by default (https://mcap.dev/spec): a magic, a header,
// a data section of records (schemas, channels, messages, most of them inside chunks that are
// compressed with zstd or lz4), a summary (copies of the schemas and channels, an index of the
// chunks, statistics) and a footer. Every record is an opcode, a uint64 length and its fields,
// little-endian.
//
// The reader walks the data section in file order, one chunk in memory at a time, checking every
// length against what is left and every CRC the file carries: it needs no summary (a recording
// cut short has none) and reads a file of any size. The writer writes chunked files with message
// indexes, a summary and summary offsets, as the MCAP library rosbag2 uses does.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace locsim {
class OutputFile;
}

namespace locsim::rosbag {

struct McapSchema {
  std::uint16_t id = 0;
  std::string name;      // e.g. "sensor_msgs/msg/LaserScan"
  std::string encoding;  // "ros2msg" for ROS 2's .msg text
  std::string data;
};

struct McapChannel {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;  // 0: no schema
  std::string topic;
  std::string message_encoding;                               // "cdr" for ROS 2
  std::vector<std::pair<std::string, std::string>> metadata;  // e.g. offered_qos_profiles
};

struct McapMessage {
  std::uint16_t channel_id = 0;
  std::uint32_t sequence = 0;
  std::uint64_t log_time_ns = 0;
  std::uint64_t publish_time_ns = 0;
  std::string_view data;  // valid during the callback only
  /// Where the message's record starts: its byte in the file, or, inside a chunk, the chunk's
  /// byte in the file and the record's byte in the decompressed chunk.
  std::uint64_t file_offset = 0;
  std::uint64_t chunk_offset = 0;
  bool in_chunk = false;
};

/// A file that is not valid MCAP; the message names the file, the record's byte and what is wrong.
class McapError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Reads an MCAP file's data section in order.
class McapReader {
 public:
  /// Opens the file and reads its magic and header. Throws McapError.
  explicit McapReader(std::filesystem::path file);
  ~McapReader();
  McapReader(const McapReader&) = delete;
  McapReader& operator=(const McapReader&) = delete;

  const std::string& profile() const { return profile_; }
  const std::string& library() const { return library_; }

  /// Calls `on_message` for every message, in file order, with its channel and the channel's
  /// schema (nullptr for schema 0). Schemas and channels are known from their first record on.
  /// Throws McapError naming the file and byte for a malformed or cut-short file; what was
  /// delivered before stays delivered.
  void read(const std::function<void(const McapChannel&, const McapSchema*, const McapMessage&)>&
                on_message);

  /// Everything read() has seen, by id.
  const std::map<std::uint16_t, McapSchema>& schemas() const { return schemas_; }
  const std::map<std::uint16_t, McapChannel>& channels() const { return channels_; }
  /// Whether read() found the Data End record (a file cut short has none; its messages up to the
  /// cut were delivered and read() threw).
  bool complete() const { return complete_; }

 private:
  struct Source;
  void records(std::string_view where_prefix, std::string_view bytes, std::uint64_t base,
               bool in_chunk, std::uint64_t chunk_at,
               const std::function<void(const McapChannel&, const McapSchema*, const McapMessage&)>&
                   on_message);
  void schema(std::string_view content, const std::string& where);
  void channel(std::string_view content, const std::string& where);
  std::filesystem::path file_;
  std::unique_ptr<Source> source_;
  std::string profile_, library_;
  std::map<std::uint16_t, McapSchema> schemas_;
  std::map<std::uint16_t, McapChannel> channels_;
  bool complete_ = false;
};

enum class McapCompression : std::uint8_t { kNone, kZstd, kLz4 };

struct McapWriterOptions {
  std::string profile = "ros2";
  std::string library = "locsim";
  McapCompression compression = McapCompression::kZstd;
  /// A chunk is closed once its uncompressed records reach this size [bytes] (rosbag2's default
  /// is 768 KiB; Foxglove reads a chunk whole to show one message).
  std::size_t chunk_bytes = 768 << 10;
  /// zstd's level: 1 is fast and within a few per cent of the default's size on sensor data.
  int zstd_level = 1;
  /// Whether to write the chunks', data section's and summary's CRC-32s (0 says "none", as the
  /// MCAP library's noChunkCRC and noSummaryCRC options write).
  bool crcs = true;
};

/// Writes an MCAP file as it goes: schemas and channels are written where first added (and again
/// in the summary), messages gather into chunks. finish() writes the rest; a writer destroyed
/// without it leaves a file with no summary, which readers read as cut short.
class McapWriter {
 public:
  McapWriter(const std::filesystem::path& file, McapWriterOptions options = {});
  ~McapWriter();
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  /// Returns the schema's id (1, 2, ...).
  std::uint16_t add_schema(std::string_view name, std::string_view encoding, std::string_view data);
  /// Returns the channel's id (0, 1, ...).
  std::uint16_t add_channel(std::uint16_t schema_id, std::string_view topic,
                            std::string_view message_encoding,
                            std::vector<std::pair<std::string, std::string>> metadata = {});
  void write(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time_ns,
             std::uint64_t publish_time_ns, std::string_view data);
  /// Closes the last chunk and writes the data end, the summary and the footer. Throws
  /// std::runtime_error when the file cannot be written whole.
  void finish();

  std::uint64_t message_count() const { return message_count_; }

 private:
  void close_chunk();
  void emit(std::string_view bytes);
  std::unique_ptr<OutputFile> out_;
  McapWriterOptions options_;
  std::uint64_t written_ = 0;   // bytes in the file so far
  std::uint32_t data_crc_ = 0;  // of everything written before the data end
  std::vector<McapSchema> schemas_;
  std::vector<McapChannel> channels_;
  std::string chunk_;  // the open chunk's records, uncompressed
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> chunk_index_;
  std::uint64_t chunk_start_ns_ = 0, chunk_end_ns_ = 0;
  std::string chunk_indexes_;  // the summary's Chunk Index records
  std::uint32_t chunk_count_ = 0;
  std::uint64_t message_count_ = 0, start_ns_ = 0, end_ns_ = 0;
  std::map<std::uint16_t, std::uint64_t> channel_counts_;
  bool finished_ = false;
};

}  // namespace locsim::rosbag
