#include "sim/run/run_log.hpp"

#include <zlib.h>

#include <cstring>

#include "sim/common/errors.hpp"

namespace locsim {

namespace {

constexpr char kMagic[8] = {'L', 'O', 'C', 'S', 'I', 'M', 'L', 'G'};

template <class T>
void put(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // the host is little-endian (x86-64, arm64)
  out.append(bytes, sizeof(T));
}
void put_string(std::string& out, const std::string& s) {
  put<std::uint32_t>(out, static_cast<std::uint32_t>(s.size()));
  out += s;
}

std::uint32_t crc(std::uint8_t type, const std::string& payload) {
  uLong c = crc32(0L, Z_NULL, 0);
  c = crc32(c, &type, 1);
  return static_cast<std::uint32_t>(
      crc32(c, reinterpret_cast<const Bytef*>(payload.data()), static_cast<uInt>(payload.size())));
}

/// Reads values out of a payload, failing cleanly when it is too short.
class Cursor {
 public:
  explicit Cursor(const std::string& data) : data_(data) {}
  template <class T>
  T get() {
    if (data_.size() - pos_ < sizeof(T)) throw std::out_of_range("payload too short");
    T value;
    std::memcpy(&value, data_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return value;
  }
  std::string get_string() {
    const auto n = get<std::uint32_t>();
    if (data_.size() - pos_ < n) throw std::out_of_range("payload too short");
    std::string s = data_.substr(pos_, n);
    pos_ += n;
    return s;
  }

 private:
  const std::string& data_;
  std::size_t pos_ = 0;
};

void put_detections(std::string& out, const std::vector<Detection>& detections) {
  put<std::uint32_t>(out, static_cast<std::uint32_t>(detections.size()));
  for (const Detection& d : detections) {
    put_string(out, d.color);
    put<std::int32_t>(out, d.id);
    put(out, d.range_m);
    put(out, d.bearing_rad);
    put<std::int32_t>(out, d.truth_id);
  }
}
std::vector<Detection> get_detections(Cursor& in) {
  std::vector<Detection> out(in.get<std::uint32_t>());
  for (Detection& d : out) {
    d.color = in.get_string();
    d.id = in.get<std::int32_t>();
    d.range_m = in.get<double>();
    d.bearing_rad = in.get<double>();
    d.truth_id = in.get<std::int32_t>();
  }
  return out;
}

}  // namespace

LogWriter::LogWriter(const std::filesystem::path& file, const nlohmann::ordered_json& header)
    : out_(file, std::ios::binary | std::ios::trunc) {
  if (!out_) throw std::runtime_error("cannot write " + file.string());
  const std::string text = header.dump();
  out_.write(kMagic, sizeof(kMagic));
  std::string head;
  put<std::uint32_t>(head, kLogFormatVersion);
  put<std::uint32_t>(head, static_cast<std::uint32_t>(text.size()));
  head += text;
  put<std::uint32_t>(head, crc(0, text));
  out_ << head;
}

void LogWriter::record(LogRecord::Type type) {
  std::string frame;
  put<std::uint8_t>(frame, static_cast<std::uint8_t>(type));
  put<std::uint32_t>(frame, static_cast<std::uint32_t>(payload_.size()));
  frame += payload_;
  put<std::uint32_t>(frame, crc(static_cast<std::uint8_t>(type), payload_));
  out_ << frame;
  ++records_;
}

void LogWriter::reading(const Reading& r) {
  payload_.clear();
  put(payload_, r.t_s);
  put<std::uint16_t>(payload_, static_cast<std::uint16_t>(r.robot));
  put<std::uint8_t>(payload_, static_cast<std::uint8_t>(r.kind));
  std::visit(
      [&](const auto& d) {
        using T = std::decay_t<decltype(d)>;
        if constexpr (std::is_same_v<T, EncoderReading>) {
          put(payload_, d.left_ticks), put(payload_, d.right_ticks);
          put(payload_, d.odometry.x), put(payload_, d.odometry.y), put(payload_, d.odometry.theta);
        } else if constexpr (std::is_same_v<T, ImuReading>) {
          put(payload_, d.yaw_rate_radps), put(payload_, d.accel_mps2.x()),
              put(payload_, d.accel_mps2.y());
        } else if constexpr (std::is_same_v<T, PtzReading>) {
          put(payload_, d.pan_rad), put(payload_, d.tilt_rad), put(payload_, d.zoom);
          put_detections(payload_, d.detections);
        } else if constexpr (std::is_same_v<T, OmniReading>) {
          put_detections(payload_, d.detections);
        } else if constexpr (std::is_same_v<T, UltrasonicReading>) {
          put<std::uint32_t>(payload_, static_cast<std::uint32_t>(d.ranges.size()));
          for (const BeaconRange& b : d.ranges) {
            put<std::int32_t>(payload_, b.receiver), put<std::int32_t>(payload_, b.beacon_id);
            put(payload_, b.range_m),
                put<std::uint8_t>(payload_, static_cast<std::uint8_t>(b.truth_status));
          }
        } else if constexpr (std::is_same_v<T, LaserScan>) {
          put<std::uint32_t>(payload_, static_cast<std::uint32_t>(d.ranges_m.size()));
          payload_.append(reinterpret_cast<const char*>(d.ranges_m.data()),
                          d.ranges_m.size() * sizeof(float));
        }
      },
      r.data);
  record(LogRecord::Type::kReading);
}

void LogWriter::groundtruth(double t_s, int robot, const Pose2& pose) {
  payload_.clear();
  put(payload_, t_s);
  put<std::uint16_t>(payload_, static_cast<std::uint16_t>(robot));
  put(payload_, pose.x), put(payload_, pose.y), put(payload_, pose.theta);
  record(LogRecord::Type::kGroundTruth);
}

void LogWriter::event(const SimEvent& event, int robot) {
  payload_.clear();
  put(payload_, event.t_s);
  put<std::int64_t>(payload_, event.step);
  put<std::int32_t>(payload_, robot);
  put_string(payload_, event.kind);
  put_string(payload_, event.robot);
  put_string(payload_, event.details);
  record(LogRecord::Type::kEvent);
}

void LogWriter::finish() {
  payload_.clear();
  put<std::uint64_t>(payload_, records_);
  record(LogRecord::Type::kEnd);
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
  if (version != kLogFormatVersion) {
    fail("log format version " + std::to_string(version) + "; this locsim reads version " +
         std::to_string(kLogFormatVersion));
  }
  in_.read(reinterpret_cast<char*>(&length), 4);
  if (!in_ || length > (1u << 30)) fail("truncated or corrupt header");
  std::string text(length, '\0');
  in_.read(text.data(), length);
  in_.read(reinterpret_cast<char*>(&checksum), 4);
  if (!in_) fail("truncated in the header");
  if (checksum != crc(0, text)) fail("header checksum mismatch: the file is corrupt");
  offset_ = sizeof(kMagic) + 4 + 4 + length + 4;
  try {
    header_ = nlohmann::ordered_json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    fail(std::string("unreadable header: ") + e.what());
  }
}

void LogReader::fail(const std::string& problem) const {
  throw InputError(SourceLocation{file_.string()}, "", problem);
}

bool LogReader::next(LogRecord& record) {
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
  payload_.resize(length);
  in_.read(payload_.data(), length);
  in_.read(reinterpret_cast<char*>(&checksum), 4);
  if (!in_) fail("truncated in a record" + where());
  offset_ += 1 + 4 + length + 4;
  if (checksum != crc(type, payload_)) fail("checksum mismatch: the file is corrupt" + where());
  try {
    Cursor in(payload_);
    record.type = static_cast<LogRecord::Type>(type);
    switch (record.type) {
      case LogRecord::Type::kEnd:
        if (in.get<std::uint64_t>() != records_)
          fail("the end record counts other records than the file holds");
        return false;
      case LogRecord::Type::kGroundTruth:
        record.t_s = in.get<double>();
        record.robot = in.get<std::uint16_t>();
        record.pose.x = in.get<double>(), record.pose.y = in.get<double>(),
        record.pose.theta = in.get<double>();
        break;
      case LogRecord::Type::kEvent:
        record.event.t_s = in.get<double>();
        record.event.step = in.get<std::int64_t>();
        record.robot = in.get<std::int32_t>();
        record.event.kind = in.get_string();
        record.event.robot = in.get_string();
        record.event.details = in.get_string();
        break;
      case LogRecord::Type::kReading: {
        Reading& r = record.reading;
        r.t_s = in.get<double>();
        r.robot = in.get<std::uint16_t>();
        r.kind = static_cast<SensorKind>(in.get<std::uint8_t>());
        switch (r.kind) {
          case SensorKind::kEncoders: {
            EncoderReading d;
            d.left_ticks = in.get<std::int64_t>(), d.right_ticks = in.get<std::int64_t>();
            d.odometry.x = in.get<double>(), d.odometry.y = in.get<double>(),
            d.odometry.theta = in.get<double>();
            r.data = d;
            break;
          }
          case SensorKind::kImu: {
            ImuReading d;
            d.yaw_rate_radps = in.get<double>();
            d.accel_mps2.x() = in.get<double>(), d.accel_mps2.y() = in.get<double>();
            r.data = d;
            break;
          }
          case SensorKind::kPtzCamera: {
            PtzReading d;
            d.pan_rad = in.get<double>(), d.tilt_rad = in.get<double>(), d.zoom = in.get<double>();
            d.detections = get_detections(in);
            r.data = std::move(d);
            break;
          }
          case SensorKind::kOmniCamera:
            r.data = OmniReading{get_detections(in)};
            break;
          case SensorKind::kUltrasonic: {
            UltrasonicReading d;
            d.ranges.resize(in.get<std::uint32_t>());
            for (BeaconRange& b : d.ranges) {
              b.receiver = in.get<std::int32_t>(), b.beacon_id = in.get<std::int32_t>();
              b.range_m = in.get<double>();
              b.truth_status = static_cast<RangeStatus>(in.get<std::uint8_t>());
            }
            r.data = std::move(d);
            break;
          }
          case SensorKind::kLaser: {
            LaserScan d;
            d.ranges_m.resize(in.get<std::uint32_t>());
            for (float& v : d.ranges_m) v = in.get<float>();
            r.data = std::move(d);
            break;
          }
          default:
            fail("unknown sensor kind " + std::to_string(static_cast<int>(r.kind)) + where());
        }
        break;
      }
      default:
        fail("unknown record type " + std::to_string(type) + where());
    }
  } catch (const std::out_of_range&) {
    fail("record shorter than its contents" + where());
  }
  ++records_;
  return true;
}

}  // namespace locsim
