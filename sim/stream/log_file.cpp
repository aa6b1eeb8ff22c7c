#include "sim/stream/log_file.hpp"

#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "sim/common/errors.hpp"
#include "sim/stream/record_codec.hpp"

namespace locsim {

namespace {

constexpr char kMagic[8] = {'L', 'O', 'C', 'S', 'I', 'M', 'L', 'G'};

std::uint32_t crc(std::uint8_t type, const std::string& payload) {
  uLong c = crc32(0L, Z_NULL, 0);
  c = crc32(c, &type, 1);
  return static_cast<std::uint32_t>(
      crc32(c, reinterpret_cast<const Bytef*>(payload.data()), static_cast<uInt>(payload.size())));
}

}  // namespace

LogWriter::LogWriter(const std::filesystem::path& file, const nlohmann::ordered_json& header)
    : out_(file, "the log ") {
  const std::string text = header.dump();
  out_.write(std::string_view(kMagic, sizeof(kMagic)));
  std::string head;
  put<std::uint32_t>(head, kLogFormatVersion);
  put<std::uint32_t>(head, static_cast<std::uint32_t>(text.size()));
  head += text;
  put<std::uint32_t>(head, crc(0, text));
  out_.write(head);
  flush();
}

void LogWriter::flush() {
  out_.flush();
}

void LogWriter::write_frame(Record::Type type) {
  frame_.clear();
  put<std::uint8_t>(frame_, static_cast<std::uint8_t>(type));
  put<std::uint32_t>(frame_, static_cast<std::uint32_t>(payload_.size()));
  frame_ += payload_;
  put<std::uint32_t>(frame_, crc(static_cast<std::uint8_t>(type), payload_));
  out_.write(frame_);
  ++records_;
}

void LogWriter::consume(const Record& record) {
  payload_.clear();
  encode_record(record, payload_);
  write_frame(record.type);
}

void LogWriter::finish() {
  payload_.clear();
  put<std::uint64_t>(payload_, records_);
  write_frame(Record::Type::kEnd);
  out_.close();
}

// ---------------------------------------------------------------------------------------------
LogReader::LogReader(const std::filesystem::path& file) : file_(file), in_(file, std::ios::binary) {
  if (!in_) {
    throw InputError(SourceLocation{file.string()}, "",
                     std::filesystem::exists(file) ? "cannot read the file" : "no such file");
  }
  char magic[8] = {};
  in_.read(magic, sizeof(magic));
  if (!in_ || std::memcmp(magic, kMagic, sizeof(magic)) != 0)
    fail("not a locsim log (no LOCSIMLG signature)");
  std::uint32_t version = 0, length = 0, checksum = 0;
  in_.read(reinterpret_cast<char*>(&version), 4);
  if (!in_) fail("truncated in the header");
  if (version < kOldestLogFormatVersion || version > kLogFormatVersion) {
    fail("log format version " + std::to_string(version) + "; this locsim reads versions " +
         std::to_string(kOldestLogFormatVersion) + " to " + std::to_string(kLogFormatVersion));
  }
  version_ = version;
  in_.read(reinterpret_cast<char*>(&length), 4);
  if (!in_ || length > (1u << 30)) fail("truncated or corrupt header");
  std::string text;
  if (!read_bytes(text, length)) fail("truncated in the header");
  in_.read(reinterpret_cast<char*>(&checksum), 4);
  if (!in_) fail("truncated in the header");
  if (checksum != crc(0, text)) fail("header checksum mismatch: the file is corrupt");
  offset_ = sizeof(kMagic) + 4 + 4 + length + 4;
  try {
    header_ = nlohmann::ordered_json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // Where, not nlohmann's text: that quotes the header's bytes (anything a stranger wrote).
    fail("the header is not valid JSON (at its byte " + std::to_string(e.byte) + ")");
  } catch (const nlohmann::json::exception&) {
    fail("the header is not valid JSON");
  }
}

void LogReader::check_end() {
  // type, length, the u64 count and the CRC: the end record's 17 bytes.
  constexpr std::uint64_t kEndBytes = 1 + 4 + 8 + 4;
  const std::uint64_t size = std::filesystem::file_size(file_);
  std::string tail(kEndBytes, '\0');
  if (size >= offset_ + kEndBytes) {
    in_.seekg(static_cast<std::streamoff>(size - kEndBytes));
    in_.read(tail.data(), static_cast<std::streamsize>(kEndBytes));
  }
  const bool read = in_ && size >= offset_ + kEndBytes;
  in_.clear();
  in_.seekg(static_cast<std::streamoff>(offset_));
  const auto type = static_cast<std::uint8_t>(tail[0]);
  std::uint32_t length = 0, checksum = 0;
  std::memcpy(&length, tail.data() + 1, 4);
  std::memcpy(&checksum, tail.data() + 1 + 4 + 8, 4);
  if (!read || static_cast<Record::Type>(type) != Record::Type::kEnd || length != 8 ||
      checksum != crc(type, tail.substr(1 + 4, 8))) {
    fail(
        "truncated: the file does not end with an end record (was the run that wrote it cut "
        "short?)");
  }
}

void LogReader::fail(const std::string& problem) const {
  throw InputError(SourceLocation{file_.string()}, "", problem);
}

void LogReader::reject(const std::string& problem) const {
  fail(problem + " (record " + std::to_string(records_) + ", byte " + std::to_string(last_offset_) +
       ")");
}

bool LogReader::read_bytes(std::string& out, std::size_t n) {
  // In chunks: the string grows only as far as the file really goes.
  constexpr std::size_t kChunk = std::size_t{1} << 20;
  out.clear();
  while (out.size() < n) {
    const std::size_t done = out.size();
    const std::size_t chunk = std::min(kChunk, n - done);
    out.resize(done + chunk);
    in_.read(out.data() + done, static_cast<std::streamsize>(chunk));
    if (!in_) return false;
  }
  return true;
}

bool LogReader::next(Record& record) {
  const std::uint64_t offset = offset_;  // tracked by hand: tellg() is a syscall per record
  const auto where = [&] {
    return " (record " + std::to_string(records_ + 1) + ", byte " + std::to_string(offset) + ")";
  };
  std::uint8_t type = 0;
  std::uint32_t length = 0, checksum = 0;
  in_.read(reinterpret_cast<char*>(&type), 1);
  if (!in_)
    fail("truncated after " + std::to_string(records_) +
         " records: no end record (was the run cut short?)");
  in_.read(reinterpret_cast<char*>(&length), 4);
  if (!in_ || length > (1u << 28)) fail("truncated or corrupt record length" + where());
  if (!read_bytes(payload_, length)) fail("truncated in a record" + where());
  in_.read(reinterpret_cast<char*>(&checksum), 4);
  if (!in_) fail("truncated in a record" + where());
  last_offset_ = offset;
  offset_ += 1 + 4 + length + 4;
  if (checksum != crc(type, payload_)) fail("checksum mismatch: the file is corrupt" + where());
  if (static_cast<Record::Type>(type) == Record::Type::kEnd) {
    ByteReader in(payload_);
    std::uint64_t counted = 0;
    try {
      counted = in.get<std::uint64_t>();
    } catch (const DecodeError&) {
      fail("record shorter than its contents" + where());
    }
    if (counted != records_) fail("the end record counts other records than the file holds");
    record.type = Record::Type::kEnd;
    return false;
  }
  try {
    decode_record(static_cast<Record::Type>(type), payload_, record, version_);
  } catch (const DecodeError& e) {
    const std::string what = e.what();
    fail((what == "payload too short" ? std::string("record shorter than its contents") : what) +
         where());
  }
  ++records_;
  return true;
}

}  // namespace locsim
