// One file holding a run's sensor stream, ground truth and events, so that localizers can be run
// on it again without simulating (`locsim record`, `locsim replay`).
//
// Format (little-endian), version 1:
//   "LOCSIMLG", u32 version, u32 header length, header (JSON text), u32 CRC-32 of the header;
//   then records: u8 type, u32 payload length, payload, u32 CRC-32 of type and payload;
//   the last record is the end record (type 255, payload: u64 number of records before it).
// Record payloads: docs/log_format.md.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "sim/run/simulation.hpp"
#include "sim/sensors/readings.hpp"

namespace locsim {

inline constexpr std::uint32_t kLogFormatVersion = 1;

struct LogRecord {
  enum class Type : std::uint8_t { kReading = 1, kGroundTruth = 2, kEvent = 3, kEnd = 255 };
  Type type = Type::kEnd;
  Reading reading;   // kReading
  double t_s = 0.0;  // kGroundTruth
  int robot = -1;    // kGroundTruth, kEvent (-1: not about one robot)
  Pose2 pose;        // kGroundTruth
  SimEvent event;    // kEvent
};

class LogWriter {
 public:
  LogWriter(const std::filesystem::path& file, const nlohmann::ordered_json& header);
  void reading(const Reading& reading);
  void groundtruth(double t_s, int robot, const Pose2& pose);
  void event(const SimEvent& event, int robot);
  /// Writes the end record and closes; a log without it reads as truncated.
  void finish();
  void flush() { out_.flush(); }

 private:
  void record(LogRecord::Type type);
  std::ofstream out_;
  std::string payload_;
  std::uint64_t records_ = 0;
};

class LogReader {
 public:
  /// Opens and checks the header. Throws InputError naming the file and what is wrong.
  explicit LogReader(const std::filesystem::path& file);
  const nlohmann::ordered_json& header() const { return header_; }
  /// The next record; false after the end record. Throws InputError on a corrupt or truncated log.
  bool next(LogRecord& record);

 private:
  [[noreturn]] void fail(const std::string& problem) const;
  std::filesystem::path file_;
  std::ifstream in_;
  nlohmann::ordered_json header_;
  std::uint64_t records_ = 0;
  std::uint64_t offset_ = 0;  // of the next record [byte]
  std::string payload_;
};

}  // namespace locsim
