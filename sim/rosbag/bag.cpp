#include "sim/rosbag/bag.hpp"

#include <sqlite3.h>
#include <zstd.h>

#include <algorithm>
#include <array>
#include <fstream>
#include <map>
#include <memory>

#include "sim/common/errors.hpp"
#include "sim/common/range.hpp"
#include "sim/common/yaml_node.hpp"
#include "sim/rosbag/cdr.hpp"
#include "sim/rosbag/mcap.hpp"

namespace fs = std::filesystem;

namespace locsim::rosbag {
namespace {

enum class FileKind { kMcap, kSqlite, kRos1, kOther };

FileKind file_kind(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::array<char, 16> head{};
  in.read(head.data(), head.size());
  const std::string_view bytes(head.data(), static_cast<std::size_t>(in.gcount()));
  if (bytes.starts_with(std::string_view("\x89MCAP0\r\n", 8))) return FileKind::kMcap;
  if (bytes == std::string_view("SQLite format 3\0", 16)) return FileKind::kSqlite;
  if (bytes.starts_with("#ROSBAG")) return FileKind::kRos1;
  return FileKind::kOther;
}

[[noreturn]] void not_a_bag_file(const fs::path& file, FileKind kind) {
  if (kind == FileKind::kRos1) {
    throw InputError(file.string() +
                     ": a ROS 1 bag; locsim reads ROS 2 bags (rosbag2: MCAP or SQLite). The "
                     "`rosbags` Python package converts one: rosbags-convert --src " +
                     file.filename().string() + " --dst folder");
  }
  throw InputError(file.string() +
                   ": neither an MCAP nor an SQLite file (a rosbag2 folder, "
                   "its metadata.yaml's folder, or one of its .mcap or .db3 files)");
}

/// A file named by metadata.yaml, if it lies inside the bag's folder (after links are followed).
fs::path file_in_bag(const fs::path& folder, const std::string& relative, const YamlNode& at) {
  const fs::path given(relative);
  if (relative.empty() || given.is_absolute() || given.has_root_name() ||
      given.has_root_directory()) {
    at.fail(quote_input(relative) + " is not a path relative to the bag's folder");
  }
  for (const fs::path& part : given) {
    if (part == "..") at.fail(quote_input(relative) + " leaves the bag's folder ('..')");
  }
  std::error_code error;
  const fs::path root = fs::canonical(folder, error);
  if (error) at.fail("the bag's folder cannot be resolved: " + error.message());
  // Early rosbag2 wrote the paths relative to the folder's parent, with the folder's name first.
  fs::path file = folder / given;
  if (!fs::exists(file, error) && given.begin() != given.end() &&
      *given.begin() == folder.filename()) {
    file = folder.parent_path() / given;
  }
  const fs::path resolved = fs::weakly_canonical(file, error);
  const auto [root_end, unused] =
      std::mismatch(root.begin(), root.end(), resolved.begin(), resolved.end());
  if (error || root_end != root.end()) {
    at.fail(quote_input(relative) + " resolves outside the bag's folder (a link out of it?)");
  }
  if (!fs::is_regular_file(resolved, error)) {
    at.fail(quote_input(relative) + ": no such file in the bag's folder");
  }
  return resolved;
}

/// An SQLite URI for a path: '%', '?' and '#' and anything not printable escaped.
std::string sqlite_uri(const fs::path& file) {
  std::string uri = "file:";
  for (const char c : file.string()) {
    const auto byte = static_cast<unsigned char>(c);
    if (c == '%' || c == '?' || c == '#' || byte < 0x21 || byte > 0x7e) {
      char hex[4];
      std::snprintf(hex, sizeof hex, "%%%02X", byte);
      uri += hex;
    } else {
      uri += c;
    }
  }
  // immutable: no lock, no journal or WAL read or made beside it; mode=ro: never written.
  return uri + "?mode=ro&immutable=1";
}

struct SqliteCloser {
  void operator()(sqlite3* db) const { sqlite3_close(db); }
};
struct StatementCloser {
  void operator()(sqlite3_stmt* statement) const { sqlite3_finalize(statement); }
};
using Sqlite = std::unique_ptr<sqlite3, SqliteCloser>;
using Statement = std::unique_ptr<sqlite3_stmt, StatementCloser>;

Sqlite open_sqlite(const fs::path& file) {
  sqlite3* db = nullptr;
  const int status = sqlite3_open_v2(sqlite_uri(file).c_str(), &db,
                                     SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr);
  Sqlite owner(db);
  if (status != SQLITE_OK) {
    throw InputError(file.string() + ": SQLite cannot open it: " +
                     (db != nullptr ? sqlite3_errmsg(db) : sqlite3_errstr(status)));
  }
  // A stranger's file: no SQL from its schema runs functions with side effects.
  sqlite3_db_config(db, SQLITE_DBCONFIG_DEFENSIVE, 1, nullptr);
  sqlite3_db_config(db, SQLITE_DBCONFIG_TRUSTED_SCHEMA, 0, nullptr);
  return owner;
}

Statement prepare(sqlite3* db, const fs::path& file, const char* sql) {
  sqlite3_stmt* statement = nullptr;
  if (sqlite3_prepare_v2(db, sql, -1, &statement, nullptr) != SQLITE_OK) {
    throw InputError(file.string() + ": not a rosbag2 SQLite file: " + sqlite3_errmsg(db));
  }
  return Statement(statement);
}

std::string column_text(sqlite3_stmt* statement, int column) {
  const unsigned char* text = sqlite3_column_text(statement, column);
  return text == nullptr
             ? std::string()
             : std::string(reinterpret_cast<const char*>(text),
                           static_cast<std::size_t>(sqlite3_column_bytes(statement, column)));
}

/// The tables (not views) of a rosbag2 SQLite file, and the columns of its topics table.
std::map<std::string, std::vector<std::string>> sqlite_tables(sqlite3* db, const fs::path& file) {
  std::map<std::string, std::vector<std::string>> tables;
  const Statement list = prepare(db, file, "SELECT name FROM sqlite_master WHERE type = 'table'");
  int status = 0;
  while ((status = sqlite3_step(list.get())) == SQLITE_ROW) tables[column_text(list.get(), 0)];
  if (status != SQLITE_DONE) {
    throw InputError(file.string() + ": SQLite cannot read it: " + sqlite3_errmsg(db));
  }
  for (const char* needed : {"topics", "messages"}) {
    if (!tables.contains(needed)) {
      throw InputError(file.string() + ": an SQLite file without a '" + needed +
                       "' table is not a rosbag2 bag");
    }
  }
  const Statement columns = prepare(db, file, "SELECT name FROM pragma_table_info('topics')");
  while (sqlite3_step(columns.get()) == SQLITE_ROW) {
    tables["topics"].push_back(column_text(columns.get(), 0));
  }
  return tables;
}

}  // namespace

std::string BagMessage::where() const {
  const std::string name = file != nullptr ? file->string() : std::string("the bag");
  if (sqlite) return name + ": row " + std::to_string(offset);
  if (in_chunk) {
    return name + ": byte " + std::to_string(offset) + " (chunk), its record at byte " +
           std::to_string(chunk_offset);
  }
  return name + ": byte " + std::to_string(offset);
}

BagReader::BagReader(const fs::path& bag) : path_(bag) {
  std::error_code error;
  const fs::file_status status = fs::status(bag, error);
  if (error || !fs::exists(status)) {
    throw InputError(bag.string() + ": no such bag (a rosbag2 folder, or an .mcap or .db3 file)");
  }
  if (!fs::is_directory(status)) {
    const FileKind kind = file_kind(bag);
    if (kind != FileKind::kMcap && kind != FileKind::kSqlite) not_a_bag_file(bag, kind);
    storage_ = kind == FileKind::kMcap ? "mcap" : "sqlite3";
    files_.push_back(bag);
  } else {
    const fs::path metadata = bag / "metadata.yaml";
    if (!fs::exists(metadata, error)) {
      throw InputError(bag.string() +
                       ": a folder without metadata.yaml (`ros2 bag reindex` writes one), or "
                       "name one of its .mcap or .db3 files");
    }
    const YamlNode root = YamlNode::load_file(metadata);
    const YamlNode info = root["rosbag2_bagfile_information"];
    storage_ = info["storage_identifier"].as_string();
    if (storage_ != "mcap" && storage_ != "sqlite3") {
      info["storage_identifier"].fail(quote_input(storage_) +
                                      " is not a storage locsim reads (mcap, sqlite3)");
    }
    const std::string mode = info.get_string("compression_mode", "");
    const std::string format = info.get_string("compression_format", "");
    if (!mode.empty() && mode != "NONE" && mode != "none") {
      if (mode == "MESSAGE" || mode == "message") {
        if (format != "zstd") {
          info["compression_format"].fail(quote_input(format) +
                                          ": locsim reads messages compressed with zstd only");
        }
        compression_ = format;
      } else {
        info["compression_mode"].fail(
            quote_input(mode) +
            ": files compressed whole are not read; `ros2 bag decompress` (or zstd -d on each "
            "file, then edit metadata.yaml) makes a bag locsim reads");
      }
    }
    for (const YamlNode& item : info["relative_file_paths"].items()) {
      files_.push_back(file_in_bag(bag, item.as_string(), item));
    }
    if (const auto topics = info.find("topics_with_message_count")) {
      for (const YamlNode& entry : topics->items()) {
        const YamlNode topic = entry["topic_metadata"];
        BagTopic t;
        t.name = topic["name"].as_string();
        t.type = topic["type"].as_string();
        t.serialization_format = topic.get_string("serialization_format", "cdr");
        if (const auto qos = topic.find("offered_qos_profiles"); qos && qos->is_scalar()) {
          t.offered_qos_profiles = qos->as_string();
        }
        t.message_count =
            static_cast<std::uint64_t>(entry.get_int("message_count", 0, Range{0.0, 1e18, ""}));
        topics_.push_back(std::move(t));
      }
    }
  }
  // SQLite files list their topics and, since Iron, their definitions up front.
  for (const fs::path& file : files_) {
    if (file_kind(file) != FileKind::kSqlite) continue;
    const Sqlite db = open_sqlite(file);
    const auto tables = sqlite_tables(db.get(), file);
    const auto& columns = tables.at("topics");
    const bool has_qos =
        std::find(columns.begin(), columns.end(), "offered_qos_profiles") != columns.end();
    const Statement topics = prepare(
        db.get(), file,
        has_qos ? "SELECT name, type, serialization_format, offered_qos_profiles FROM topics"
                : "SELECT name, type, serialization_format FROM topics");
    while (sqlite3_step(topics.get()) == SQLITE_ROW) {
      BagTopic& topic =
          topics_[topic_index(column_text(topics.get(), 0), column_text(topics.get(), 1),
                              column_text(topics.get(), 2))];
      if (has_qos && topic.offered_qos_profiles.empty()) {
        topic.offered_qos_profiles = column_text(topics.get(), 3);
      }
    }
    if (tables.contains("message_definitions")) {
      const Statement definitions = prepare(
          db.get(), file,
          "SELECT topic_type, encoding, encoded_message_definition FROM message_definitions");
      while (sqlite3_step(definitions.get()) == SQLITE_ROW) {
        const std::string type = column_text(definitions.get(), 0);
        for (BagTopic& topic : topics_) {
          if (topic.type == type && topic.definition.empty()) {
            topic.definition_encoding = column_text(definitions.get(), 1);
            topic.definition = column_text(definitions.get(), 2);
          }
        }
      }
    }
  }
}

std::size_t BagReader::topic_index(const std::string& name, const std::string& type,
                                   const std::string& format) {
  for (std::size_t i = 0; i < topics_.size(); ++i) {
    if (topics_[i].name == name && (topics_[i].type == type || type.empty())) return i;
  }
  BagTopic topic;
  topic.name = name;
  topic.type = type;
  topic.serialization_format = format;
  topics_.push_back(std::move(topic));
  return topics_.size() - 1;
}

void BagReader::read(const std::function<void(const BagTopic&, const BagMessage&)>& on_message) {
  // Counted as read: metadata.yaml's counts are what the recorder meant, the files what it wrote.
  for (BagTopic& topic : topics_) topic.message_count = 0;
  for (const fs::path& file : files_) {
    const FileKind kind = file_kind(file);
    if (kind == FileKind::kMcap) {
      read_mcap(file, on_message);
    } else if (kind == FileKind::kSqlite) {
      read_sqlite(file, on_message);
    } else {
      not_a_bag_file(file, kind);
    }
  }
}

namespace {

/// A message of a bag recorded with compression_mode MESSAGE: each message a zstd frame.
std::string_view decompress_message(std::string_view data, std::string& buffer,
                                    const BagMessage& message) {
  const unsigned long long size = ZSTD_getFrameContentSize(data.data(), data.size());
  // A message decompresses to less than a gigabyte; a frame that says more is corrupt.
  if (size == ZSTD_CONTENTSIZE_ERROR || size == ZSTD_CONTENTSIZE_UNKNOWN || size > (1ull << 30)) {
    throw InputError(message.where() + ": the message is not a zstd frame with its size");
  }
  buffer.resize(static_cast<std::size_t>(size));
  const std::size_t got = ZSTD_decompress(buffer.data(), buffer.size(), data.data(), data.size());
  if (ZSTD_isError(got) != 0U || got != size) {
    throw InputError(message.where() + ": zstd cannot decompress the message");
  }
  return buffer;
}

}  // namespace

void BagReader::read_mcap(
    const fs::path& file,
    const std::function<void(const BagTopic&, const BagMessage&)>& on_message) {
  std::string buffer;
  try {
    McapReader reader(file);
    std::map<std::uint16_t, std::size_t> topic_of_channel;
    reader.read(
        [&](const McapChannel& channel, const McapSchema* schema, const McapMessage& record) {
          auto found = topic_of_channel.find(channel.id);
          if (found == topic_of_channel.end()) {
            const std::size_t index = topic_index(
                channel.topic, schema != nullptr ? schema->name : "", channel.message_encoding);
            BagTopic& topic = topics_[index];
            if (topic.type.empty() && schema != nullptr) topic.type = schema->name;
            if (topic.definition.empty() && schema != nullptr) {
              topic.definition = schema->data;
              topic.definition_encoding = schema->encoding;
            }
            for (const auto& [key, value] : channel.metadata) {
              if (key == "offered_qos_profiles" && topic.offered_qos_profiles.empty()) {
                topic.offered_qos_profiles = value;
              }
            }
            found = topic_of_channel.emplace(channel.id, index).first;
          }
          BagTopic& topic = topics_[found->second];
          ++topic.message_count;
          BagMessage message;
          message.log_time_ns = record.log_time_ns;
          message.sequence = record.sequence;
          message.data = record.data;
          message.file = &file;
          message.offset = record.file_offset;
          message.chunk_offset = record.chunk_offset;
          message.in_chunk = record.in_chunk;
          if (!compression_.empty())
            message.data = decompress_message(record.data, buffer, message);
          on_message(topic, message);
        });
  } catch (const McapError& e) {
    throw InputError(e.what());
  }
}

void BagReader::read_sqlite(
    const fs::path& file,
    const std::function<void(const BagTopic&, const BagMessage&)>& on_message) {
  const Sqlite db = open_sqlite(file);
  sqlite_tables(db.get(), file);
  std::map<std::int64_t, std::size_t> topic_of_id;
  const Statement topics = prepare(db.get(), file, "SELECT id, name, type FROM topics");
  while (sqlite3_step(topics.get()) == SQLITE_ROW) {
    topic_of_id[sqlite3_column_int64(topics.get(), 0)] =
        topic_index(column_text(topics.get(), 1), column_text(topics.get(), 2), "cdr");
  }
  const Statement messages = prepare(
      db.get(), file, "SELECT id, topic_id, timestamp, data FROM messages ORDER BY timestamp, id");
  std::string buffer;
  int status = 0;
  while ((status = sqlite3_step(messages.get())) == SQLITE_ROW) {
    BagMessage message;
    message.file = &file;
    message.sqlite = true;
    message.offset = static_cast<std::uint64_t>(sqlite3_column_int64(messages.get(), 0));
    const std::int64_t topic_id = sqlite3_column_int64(messages.get(), 1);
    const std::int64_t time_ns = sqlite3_column_int64(messages.get(), 2);
    const auto topic = topic_of_id.find(topic_id);
    if (topic == topic_of_id.end()) {
      throw InputError(message.where() + ": topic id " + std::to_string(topic_id) +
                       " is not in the topics table");
    }
    if (time_ns < 0) {
      throw InputError(message.where() + ": time stamp " + std::to_string(time_ns) +
                       " ns is before 1970");
    }
    message.log_time_ns = static_cast<std::uint64_t>(time_ns);
    const void* blob = sqlite3_column_blob(messages.get(), 3);
    message.data =
        std::string_view(static_cast<const char*>(blob),
                         static_cast<std::size_t>(sqlite3_column_bytes(messages.get(), 3)));
    if (!compression_.empty()) message.data = decompress_message(message.data, buffer, message);
    ++topics_[topic->second].message_count;
    on_message(topics_[topic->second], message);
  }
  if (status != SQLITE_DONE) {
    throw InputError(file.string() +
                     ": SQLite cannot read its messages: " + sqlite3_errmsg(db.get()));
  }
}

}  // namespace locsim::rosbag
