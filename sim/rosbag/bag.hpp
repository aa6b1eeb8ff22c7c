// A rosbag2 recording as `ros2 bag record` leaves it: a folder with metadata.yaml and its files
// (MCAP or SQLite), or one such file alone. Reads the topics and their messages in each file's
// order; decoding them is message_definition's.
//
// Untrusted input: a bag reads nothing outside itself. metadata.yaml's file paths must name files
// inside the bag's folder (no absolute paths, no '..', no link out of it); SQLite files are opened
// read-only and immutable (no journal or WAL file beside them is read or made) and only as tables.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace locsim::rosbag {

struct BagTopic {
  std::string name;                  // "/scan"
  std::string type;                  // "sensor_msgs/msg/LaserScan"
  std::string serialization_format;  // "cdr"
  std::string offered_qos_profiles;  // YAML, as rosbag2 stores it; empty when the bag has none
  std::string definition;            // the type's definition as the bag carries it, or empty
  std::string definition_encoding;   // "ros2msg", "ros2idl", or empty
  std::uint64_t message_count = 0;   // what metadata.yaml says, or read() counted
};

struct BagMessage {
  std::uint64_t log_time_ns = 0;
  std::uint32_t sequence = 0;  // MCAP's (the writer's counter); 0 in SQLite
  std::string_view data;       // the serialized message, valid during the callback only
  /// Where it is, for messages about it: "file.mcap: byte 1234 (chunk), its record at byte 56"
  /// or "file.db3: row 17".
  std::string where() const;
  // where() is made from these only when asked (most messages are never described).
  const std::filesystem::path* file = nullptr;
  std::uint64_t offset = 0;        // MCAP: the record's (or its chunk's) byte; SQLite: the row id
  std::uint64_t chunk_offset = 0;  // MCAP, in a chunk: the record's byte in the chunk
  bool in_chunk = false;
  bool sqlite = false;
};

class BagReader {
 public:
  /// Opens a bag folder (metadata.yaml and the files it lists), an .mcap or a .db3 file. Throws
  /// InputError naming the file and what is wrong.
  explicit BagReader(const std::filesystem::path& bag);

  const std::filesystem::path& path() const { return path_; }
  /// "mcap" or "sqlite3".
  const std::string& storage() const { return storage_; }
  const std::vector<std::filesystem::path>& files() const { return files_; }
  /// The topics: from metadata.yaml or the SQLite files when opened, from an MCAP file's
  /// channels as read() meets them (and with their definitions then).
  const std::vector<BagTopic>& topics() const { return topics_; }

  /// Calls `on_message` for every message of every file, in the files' order (each file's own
  /// order: MCAP's as written, SQLite's by time). Throws InputError (naming the file and the
  /// byte or row) for a malformed file; messages delivered before stay delivered.
  void read(const std::function<void(const BagTopic&, const BagMessage&)>& on_message);

 private:
  std::size_t topic_index(const std::string& name, const std::string& type,
                          const std::string& format);
  void read_mcap(const std::filesystem::path& file,
                 const std::function<void(const BagTopic&, const BagMessage&)>& on_message);
  void read_sqlite(const std::filesystem::path& file,
                   const std::function<void(const BagTopic&, const BagMessage&)>& on_message);
  std::filesystem::path path_;
  std::string storage_;
  std::string compression_;  // metadata.yaml's compression_format with mode "message": "zstd"
  std::vector<std::filesystem::path> files_;
  std::vector<BagTopic> topics_;
};

}  // namespace locsim::rosbag
