#include "sim/rosbag/mcap.hpp"

#include <lz4frame.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <fstream>
#include <limits>

#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"

namespace locsim::rosbag {
namespace {

constexpr std::string_view kMagic("\x89MCAP0\r\n", 8);

enum Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kStatistics = 0x0B,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

/// The largest decompressed chunk locsim reads [bytes]: recorders write chunks of about a MiB; a
/// chunk that claims gigabytes is corrupt, and must not make us allocate them.
constexpr std::uint64_t kMaxChunkBytes = std::uint64_t{1} << 30;

std::uint32_t crc(std::uint32_t running, std::string_view bytes) {
  // zlib's crc32 takes a uInt length: feed it in pieces a uInt holds.
  uLong value = running;
  while (!bytes.empty()) {
    const std::size_t piece = std::min<std::size_t>(bytes.size(), 1u << 30);
    value = crc32(value, reinterpret_cast<const Bytef*>(bytes.data()), static_cast<uInt>(piece));
    bytes.remove_prefix(piece);
  }
  return static_cast<std::uint32_t>(value);
}

/// Reads a record's fields, every read checked against the record's end.
class Fields {
 public:
  Fields(std::string_view content, const std::string& where) : content_(content), where_(where) {}
  template <typename T>
  T number(const char* field) {
    need(sizeof(T), field);
    T value;
    std::memcpy(&value, content_.data() + pos_, sizeof(T));  // MCAP is little-endian, as we are
    pos_ += sizeof(T);
    return value;
  }
  std::string_view bytes32(const char* field) {
    const auto length = number<std::uint32_t>(field);
    need(length, field);
    const std::string_view value = content_.substr(pos_, length);
    pos_ += length;
    return value;
  }
  std::string_view bytes64(const char* field) {
    const auto length = number<std::uint64_t>(field);
    need(length, field);
    const std::string_view value = content_.substr(pos_, static_cast<std::size_t>(length));
    pos_ += static_cast<std::size_t>(length);
    return value;
  }
  std::string string(const char* field) { return std::string(bytes32(field)); }
  std::string_view rest() {
    const std::string_view value = content_.substr(pos_);
    pos_ = content_.size();
    return value;
  }

 private:
  void need(std::uint64_t bytes, const char* field) const {
    if (bytes > content_.size() - pos_) {
      throw McapError(where_ + ": the field " + field + " (" + std::to_string(bytes) +
                      " bytes) runs past the record's end");
    }
  }
  std::string_view content_;
  const std::string& where_;
  std::size_t pos_ = 0;
};

std::string opcode_name(std::uint8_t opcode) {
  static constexpr std::array<const char*, 16> kNames = {
      "invalid",          "header",     "footer",        "schema",         "channel",
      "message",          "chunk",      "message index", "chunk index",    "attachment",
      "attachment index", "statistics", "metadata",      "metadata index", "summary offset",
      "data end"};
  char hex[8];
  std::snprintf(hex, sizeof hex, "0x%02x", opcode);
  return opcode < kNames.size() ? std::string(kNames[opcode]) + ", op " + hex
                                : std::string("private record, op ") + hex;
}

std::string decompress(std::string_view compression, std::string_view in, std::uint64_t size,
                       const std::string& where) {
  if (size > kMaxChunkBytes) {
    throw McapError(where + ": a chunk of " + std::to_string(size) +
                    " bytes decompressed, more than locsim reads (" +
                    std::to_string(kMaxChunkBytes) + ")");
  }
  std::string out(static_cast<std::size_t>(size), '\0');
  if (compression.empty()) {
    if (in.size() != size) {
      throw McapError(where + ": an uncompressed chunk of " + std::to_string(in.size()) +
                      " bytes that says it holds " + std::to_string(size));
    }
    out.assign(in);
  } else if (compression == "zstd") {
    const std::size_t got = ZSTD_decompress(out.data(), out.size(), in.data(), in.size());
    if (ZSTD_isError(got) != 0U) {
      throw McapError(where + ": zstd cannot decompress the chunk: " + ZSTD_getErrorName(got));
    }
    if (got != size) {
      throw McapError(where + ": the chunk decompressed to " + std::to_string(got) +
                      " bytes, not the " + std::to_string(size) + " it says");
    }
  } else if (compression == "lz4") {
    LZ4F_dctx* context = nullptr;
    if (LZ4F_isError(LZ4F_createDecompressionContext(&context, LZ4F_VERSION)) != 0U) {
      throw std::bad_alloc();
    }
    const std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> owner(
        context, LZ4F_freeDecompressionContext);
    std::size_t in_at = 0, out_at = 0;
    while (in_at < in.size()) {
      std::size_t in_bytes = in.size() - in_at, out_bytes = out.size() - out_at;
      const std::size_t hint = LZ4F_decompress(context, out.data() + out_at, &out_bytes,
                                               in.data() + in_at, &in_bytes, nullptr);
      if (LZ4F_isError(hint) != 0U) {
        throw McapError(where + ": lz4 cannot decompress the chunk: " + LZ4F_getErrorName(hint));
      }
      in_at += in_bytes;
      out_at += out_bytes;
      if (hint == 0) break;  // the frame is complete
      if (in_bytes == 0 && out_bytes == 0) {
        throw McapError(where + ": the lz4 chunk decompresses to more than the " +
                        std::to_string(size) + " bytes it says");
      }
    }
    if (out_at != size) {
      throw McapError(where + ": the chunk decompressed to " + std::to_string(out_at) +
                      " bytes, not the " + std::to_string(size) + " it says");
    }
  } else {
    throw McapError(where + ": the chunk is compressed with " + quote_input(compression) +
                    ", which locsim does not read (zstd, lz4 or none)");
  }
  return out;
}

}  // namespace

// ---- reading ------------------------------------------------------------------------------

struct McapReader::Source {
  std::ifstream in;
  std::uint64_t size = 0;
  std::uint64_t at = 0;
  std::uint32_t crc = 0;  // of everything read so far
  void read(std::string& into, std::uint64_t bytes) {
    into.resize(static_cast<std::size_t>(bytes));
    in.read(into.data(), static_cast<std::streamsize>(bytes));
    at += bytes;
    crc = rosbag::crc(crc, into);
  }
};

McapReader::McapReader(std::filesystem::path file)
    : file_(std::move(file)), source_(std::make_unique<Source>()) {
  std::error_code error;
  const std::uintmax_t size = std::filesystem::file_size(file_, error);
  source_->in.open(file_, std::ios::binary);
  if (error || !source_->in) {
    throw McapError(file_.string() + ": cannot be read" +
                    (error ? ": " + error.message() : std::string()));
  }
  source_->size = size;
  std::string bytes;
  if (size < kMagic.size() + 9) {
    throw McapError(file_.string() + ": " + std::to_string(size) +
                    " bytes, too short for an MCAP file");
  }
  source_->read(bytes, kMagic.size());
  if (bytes != kMagic) throw McapError(file_.string() + ": not an MCAP file (no magic at byte 0)");
  source_->read(bytes, 9);
  std::uint64_t length = 0;
  std::memcpy(&length, bytes.data() + 1, 8);
  const std::string where = file_.string() + ": byte 8 (header)";
  if (static_cast<std::uint8_t>(bytes[0]) != kHeader) {
    throw McapError(where + ": the first record is " +
                    opcode_name(static_cast<std::uint8_t>(bytes[0])) + ", not the header");
  }
  if (length > size - source_->at) throw McapError(where + ": runs past the file's end");
  source_->read(bytes, length);
  Fields fields(bytes, where);
  profile_ = fields.string("profile");
  library_ = fields.string("library");
}

McapReader::~McapReader() = default;

void McapReader::schema(std::string_view content, const std::string& where) {
  Fields fields(content, where);
  McapSchema schema;
  schema.id = fields.number<std::uint16_t>("id");
  schema.name = fields.string("name");
  schema.encoding = fields.string("encoding");
  schema.data = std::string(fields.bytes32("data"));
  if (schema.id == 0) throw McapError(where + ": schema id 0 (reserved for no schema)");
  const auto [existing, added] = schemas_.try_emplace(schema.id, schema);
  if (!added &&
      (existing->second.name != schema.name || existing->second.encoding != schema.encoding ||
       existing->second.data != schema.data)) {
    throw McapError(where + ": schema " + std::to_string(schema.id) +
                    " differs from an earlier schema with its id");
  }
}

void McapReader::channel(std::string_view content, const std::string& where) {
  Fields fields(content, where);
  McapChannel channel;
  channel.id = fields.number<std::uint16_t>("id");
  channel.schema_id = fields.number<std::uint16_t>("schema_id");
  channel.topic = fields.string("topic");
  channel.message_encoding = fields.string("message_encoding");
  Fields map(fields.bytes32("metadata"), where);
  for (std::string_view rest = map.rest(); !rest.empty();) {
    Fields pair(rest, where);
    std::string key = pair.string("metadata key");
    std::string value = pair.string("metadata value");
    channel.metadata.emplace_back(std::move(key), std::move(value));
    rest = pair.rest();
  }
  if (channel.schema_id != 0 && !schemas_.contains(channel.schema_id)) {
    throw McapError(where + ": channel " + std::to_string(channel.id) + " (" +
                    quote_input(channel.topic) + ") names schema " +
                    std::to_string(channel.schema_id) + ", which no record before it defines");
  }
  const auto [existing, added] = channels_.try_emplace(channel.id, channel);
  if (!added && (existing->second.topic != channel.topic ||
                 existing->second.schema_id != channel.schema_id)) {
    throw McapError(where + ": channel " + std::to_string(channel.id) +
                    " differs from an earlier channel with its id");
  }
}

void McapReader::records(std::string_view where_prefix, std::string_view bytes, std::uint64_t base,
                         bool in_chunk, std::uint64_t chunk_at,
                         const std::function<void(const McapChannel&, const McapSchema*,
                                                  const McapMessage&)>& on_message) {
  // The records of a chunk: schemas, channels and messages (others are skipped, as the spec asks).
  std::size_t at = 0;
  while (at < bytes.size()) {
    const std::string where = std::string(where_prefix) + std::to_string(base + at);
    if (bytes.size() - at < 9) throw McapError(where + ": a record cut short");
    const auto opcode = static_cast<std::uint8_t>(bytes[at]);
    std::uint64_t length = 0;
    std::memcpy(&length, bytes.data() + at + 1, 8);
    if (length > bytes.size() - at - 9) {
      throw McapError(where + " (" + opcode_name(opcode) + "): " + std::to_string(length) +
                      " bytes run past the chunk's end");
    }
    const std::string_view content = bytes.substr(at + 9, static_cast<std::size_t>(length));
    const std::string here = where + " (" + opcode_name(opcode) + ")";
    if (opcode == 0) throw McapError(here + ": opcode 0 is not a record");
    if (opcode == kSchema) schema(content, here);
    if (opcode == kChannel) channel(content, here);
    if (opcode == kMessage) {
      Fields fields(content, here);
      McapMessage message;
      message.channel_id = fields.number<std::uint16_t>("channel_id");
      message.sequence = fields.number<std::uint32_t>("sequence");
      message.log_time_ns = fields.number<std::uint64_t>("log_time");
      message.publish_time_ns = fields.number<std::uint64_t>("publish_time");
      message.data = fields.rest();
      message.in_chunk = in_chunk;
      message.file_offset = in_chunk ? chunk_at : base + at;
      message.chunk_offset = in_chunk ? at : 0;
      const auto channel = channels_.find(message.channel_id);
      if (channel == channels_.end()) {
        throw McapError(here + ": a message on channel " + std::to_string(message.channel_id) +
                        ", which no record before it defines");
      }
      const auto schema = schemas_.find(channel->second.schema_id);
      on_message(channel->second, schema == schemas_.end() ? nullptr : &schema->second, message);
    }
    at += 9 + static_cast<std::size_t>(length);
  }
}

void McapReader::read(const std::function<void(const McapChannel&, const McapSchema*,
                                               const McapMessage&)>& on_message) {
  Source& source = *source_;
  std::string head, content;
  while (true) {
    const std::uint64_t record_at = source.at;
    const std::string where = file_.string() + ": byte " + std::to_string(record_at);
    if (source.size - source.at < 9) {
      throw McapError(where +
                      ": the file ends before its data end record (a recording cut "
                      "short: the messages before were read)");
    }
    const std::uint32_t crc_before = source.crc;
    source.read(head, 9);
    const auto opcode = static_cast<std::uint8_t>(head[0]);
    std::uint64_t length = 0;
    std::memcpy(&length, head.data() + 1, 8);
    const std::string here = where + " (" + opcode_name(opcode) + ")";
    if (opcode == 0) throw McapError(here + ": opcode 0 is not a record");
    if (length > source.size - source.at) {
      throw McapError(here + ": " + std::to_string(length) +
                      " bytes run past the file's end (a recording cut short?)");
    }
    if (opcode == kDataEnd) {
      source.read(content, length);
      Fields fields(content, here);
      const auto expected = fields.number<std::uint32_t>("data_section_crc");
      if (expected != 0 && expected != crc_before) {
        throw McapError(here + ": the data section's CRC does not match: the file is corrupt");
      }
      complete_ = true;
      return;
    }
    if (opcode == kFooter) {
      // A data section ended without its data end record: malformed, but everything was read.
      complete_ = true;
      return;
    }
    source.read(content, length);
    if (!source.in) throw McapError(here + ": cannot be read");
    if (opcode == kSchema) schema(content, here);
    if (opcode == kChannel) channel(content, here);
    if (opcode == kChunk) {
      Fields fields(content, here);
      fields.number<std::uint64_t>("message_start_time");
      fields.number<std::uint64_t>("message_end_time");
      const auto size = fields.number<std::uint64_t>("uncompressed_size");
      const auto expected_crc = fields.number<std::uint32_t>("uncompressed_crc");
      const std::string compression = fields.string("compression");
      const std::string_view compressed = fields.bytes64("records");
      const std::string decompressed = decompress(compression, compressed, size, here);
      if (expected_crc != 0 && crc(0, decompressed) != expected_crc) {
        throw McapError(here + ": the chunk's CRC does not match: the file is corrupt");
      }
      records(where + " (chunk): its record at byte ", decompressed, 0, true, record_at,
              on_message);
    } else if (opcode == kMessage) {
      // A message outside a chunk: the same parsing as a chunk's, on a record of its own.
      const std::string whole = head + content;
      records(file_.string() + ": byte ", whole, record_at, false, 0, on_message);
    }
  }
}

// ---- writing ------------------------------------------------------------------------------

namespace {

void put_string(std::string& out, std::string_view text) {
  const auto length = static_cast<std::uint32_t>(text.size());
  out.append(reinterpret_cast<const char*>(&length), 4).append(text);
}
template <typename T>
void put(std::string& out, T value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof(T));
}
/// Opcode, length, content.
void put_record(std::string& out, std::uint8_t opcode, std::string_view content) {
  put(out, opcode);
  put(out, static_cast<std::uint64_t>(content.size()));
  out.append(content);
}

std::string schema_record(const McapSchema& schema) {
  std::string content;
  put(content, schema.id);
  put_string(content, schema.name);
  put_string(content, schema.encoding);
  put_string(content, schema.data);
  std::string record;
  put_record(record, kSchema, content);
  return record;
}

std::string channel_record(const McapChannel& channel) {
  std::string content, map;
  put(content, channel.id);
  put(content, channel.schema_id);
  put_string(content, channel.topic);
  put_string(content, channel.message_encoding);
  for (const auto& [key, value] : channel.metadata) {
    put_string(map, key);
    put_string(map, value);
  }
  put_string(content, map);
  std::string record;
  put_record(record, kChannel, content);
  return record;
}

std::string compress(McapCompression compression, std::string_view in, int zstd_level) {
  std::string out;
  if (compression == McapCompression::kZstd) {
    out.resize(ZSTD_compressBound(in.size()));
    const std::size_t size =
        ZSTD_compress(out.data(), out.size(), in.data(), in.size(), zstd_level);
    if (ZSTD_isError(size) != 0U) {
      throw std::runtime_error(std::string("zstd cannot compress a chunk: ") +
                               ZSTD_getErrorName(size));
    }
    out.resize(size);
  } else {
    LZ4F_preferences_t preferences{};
    preferences.frameInfo.contentSize = in.size();
    out.resize(LZ4F_compressFrameBound(in.size(), &preferences));
    const std::size_t size =
        LZ4F_compressFrame(out.data(), out.size(), in.data(), in.size(), &preferences);
    if (LZ4F_isError(size) != 0U) {
      throw std::runtime_error(std::string("lz4 cannot compress a chunk: ") +
                               LZ4F_getErrorName(size));
    }
    out.resize(size);
  }
  return out;
}

}  // namespace

McapWriter::McapWriter(const std::filesystem::path& file, McapWriterOptions options)
    : out_(std::make_unique<OutputFile>(file, "the bag ")), options_(std::move(options)) {
  std::string header, content;
  header.append(kMagic);
  put_string(content, options_.profile);
  put_string(content, options_.library);
  put_record(header, kHeader, content);
  emit(header);
}

McapWriter::~McapWriter() = default;

void McapWriter::emit(std::string_view bytes) {
  out_->write(bytes);
  data_crc_ = crc(data_crc_, bytes);
  written_ += bytes.size();
}

std::uint16_t McapWriter::add_schema(std::string_view name, std::string_view encoding,
                                     std::string_view data) {
  if (schemas_.size() >= std::numeric_limits<std::uint16_t>::max()) {
    throw std::length_error("MCAP: more than 65535 schemas");
  }
  McapSchema schema;
  schema.id = static_cast<std::uint16_t>(schemas_.size() + 1);
  schema.name = std::string(name);
  schema.encoding = std::string(encoding);
  schema.data = std::string(data);
  emit(schema_record(schema));
  schemas_.push_back(std::move(schema));
  return schemas_.back().id;
}

std::uint16_t McapWriter::add_channel(std::uint16_t schema_id, std::string_view topic,
                                      std::string_view message_encoding,
                                      std::vector<std::pair<std::string, std::string>> metadata) {
  if (channels_.size() >= std::numeric_limits<std::uint16_t>::max()) {
    throw std::length_error("MCAP: more than 65535 channels");
  }
  if (schema_id > schemas_.size()) {
    throw std::invalid_argument("MCAP: channel " + std::string(topic) + " names schema " +
                                std::to_string(schema_id) + ", not added");
  }
  McapChannel channel;
  channel.id = static_cast<std::uint16_t>(channels_.size());
  channel.schema_id = schema_id;
  channel.topic = std::string(topic);
  channel.message_encoding = std::string(message_encoding);
  channel.metadata = std::move(metadata);
  emit(channel_record(channel));
  channels_.push_back(std::move(channel));
  return channels_.back().id;
}

void McapWriter::write(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time_ns,
                       std::uint64_t publish_time_ns, std::string_view data) {
  if (channel_id >= channels_.size()) {
    throw std::invalid_argument("MCAP: a message on channel " + std::to_string(channel_id) +
                                ", not added");
  }
  if (chunk_.empty()) {
    chunk_start_ns_ = log_time_ns;
    chunk_end_ns_ = log_time_ns;
  }
  chunk_index_[channel_id].emplace_back(log_time_ns, chunk_.size());
  put(chunk_, kMessage);
  put(chunk_, static_cast<std::uint64_t>(2 + 4 + 8 + 8 + data.size()));
  put(chunk_, channel_id);
  put(chunk_, sequence);
  put(chunk_, log_time_ns);
  put(chunk_, publish_time_ns);
  chunk_.append(data);
  chunk_start_ns_ = std::min(chunk_start_ns_, log_time_ns);
  chunk_end_ns_ = std::max(chunk_end_ns_, log_time_ns);
  if (message_count_ == 0) start_ns_ = end_ns_ = log_time_ns;
  start_ns_ = std::min(start_ns_, log_time_ns);
  end_ns_ = std::max(end_ns_, log_time_ns);
  ++message_count_;
  ++channel_counts_[channel_id];
  if (chunk_.size() >= options_.chunk_bytes) close_chunk();
}

void McapWriter::close_chunk() {
  if (chunk_.empty()) return;
  const std::string_view compression = options_.compression == McapCompression::kZstd  ? "zstd"
                                       : options_.compression == McapCompression::kLz4 ? "lz4"
                                                                                       : "";
  const std::string compressed = options_.compression == McapCompression::kNone
                                     ? std::string()
                                     : compress(options_.compression, chunk_, options_.zstd_level);
  const std::string_view records = options_.compression == McapCompression::kNone
                                       ? std::string_view(chunk_)
                                       : std::string_view(compressed);
  std::string chunk;
  put(chunk, chunk_start_ns_);
  put(chunk, chunk_end_ns_);
  put(chunk, static_cast<std::uint64_t>(chunk_.size()));
  put(chunk, options_.crcs ? crc(0, chunk_) : std::uint32_t{0});
  put_string(chunk, compression);
  put(chunk, static_cast<std::uint64_t>(records.size()));
  chunk.append(records);
  std::string record;
  put_record(record, kChunk, chunk);
  const std::uint64_t chunk_at = written_;
  emit(record);
  const std::uint64_t chunk_length = record.size();

  // One message index per channel in the chunk, right after it.
  std::string offsets;
  const std::uint64_t indexes_at = written_;
  for (const auto& [channel, entries] : chunk_index_) {
    put(offsets, channel);
    put(offsets, written_);
    std::string content, array;
    put(content, channel);
    for (const auto& [time_ns, offset] : entries) {
      put(array, time_ns);
      put(array, offset);
    }
    put_string(content, array);
    std::string index;
    put_record(index, kMessageIndex, content);
    emit(index);
  }

  std::string entry;
  put(entry, chunk_start_ns_);
  put(entry, chunk_end_ns_);
  put(entry, chunk_at);
  put(entry, chunk_length);
  put_string(entry, offsets);
  put(entry, written_ - indexes_at);
  put_string(entry, compression);
  put(entry, static_cast<std::uint64_t>(records.size()));
  put(entry, static_cast<std::uint64_t>(chunk_.size()));
  put_record(chunk_indexes_, kChunkIndex, entry);
  ++chunk_count_;
  chunk_.clear();
  chunk_index_.clear();
}

void McapWriter::finish() {
  if (finished_) return;
  close_chunk();
  std::string data_end;
  put(data_end, options_.crcs ? data_crc_ : std::uint32_t{0});
  std::string record;
  put_record(record, kDataEnd, data_end);
  emit(record);

  // The summary: groups by opcode, each located by a summary offset record.
  const std::uint64_t summary_at = written_;
  std::string summary, offsets;
  const auto group = [&](std::uint8_t opcode, const std::string& records) {
    if (records.empty()) return;
    put(offsets, opcode);
    put(offsets, summary_at + summary.size());
    put(offsets, static_cast<std::uint64_t>(records.size()));
    summary += records;
  };
  std::string schemas, channels, statistics, content, counts;
  for (const McapSchema& schema : schemas_) schemas += schema_record(schema);
  for (const McapChannel& channel : channels_) channels += channel_record(channel);
  put(content, message_count_);
  put(content, static_cast<std::uint16_t>(schemas_.size()));
  put(content, static_cast<std::uint32_t>(channels_.size()));
  put(content, std::uint32_t{0});  // attachments
  put(content, std::uint32_t{0});  // metadata
  put(content, chunk_count_);
  put(content, message_count_ == 0 ? std::uint64_t{0} : start_ns_);
  put(content, message_count_ == 0 ? std::uint64_t{0} : end_ns_);
  for (const auto& [channel, count] : channel_counts_) {
    put(counts, channel);
    put(counts, count);
  }
  put_string(content, counts);
  put_record(statistics, kStatistics, content);
  group(kSchema, schemas);
  group(kChannel, channels);
  group(kStatistics, statistics);
  group(kChunkIndex, chunk_indexes_);
  std::string offset_records;
  for (std::size_t at = 0; at < offsets.size(); at += 17) {
    put_record(offset_records, kSummaryOffset, std::string_view(offsets).substr(at, 17));
  }
  const std::uint64_t offsets_at = summary_at + summary.size();
  std::string tail = summary + offset_records;
  std::string footer;
  put(footer, summary.empty() ? std::uint64_t{0} : summary_at);
  put(footer, offset_records.empty() ? std::uint64_t{0} : offsets_at);
  // The summary's CRC runs from its start through the footer's summary_offset_start.
  std::string footer_record;
  put_record(footer_record, kFooter, footer + std::string(4, '\0'));
  const std::uint32_t summary_crc =
      options_.crcs ? crc(0, tail + footer_record.substr(0, footer_record.size() - 4)) : 0;
  std::memcpy(footer_record.data() + footer_record.size() - 4, &summary_crc, 4);
  emit(tail + footer_record);
  emit(kMagic);
  out_->close();
  finished_ = true;
}

}  // namespace locsim::rosbag
