#include "sim/stream/record_codec.hpp"

#include <type_traits>
#include <variant>

namespace locsim {

void put_string(std::string& out, std::string_view s) {
  put<std::uint32_t>(out, static_cast<std::uint32_t>(s.size()));
  out += s;
}

std::string ByteReader::get_string() {
  const auto n = get<std::uint32_t>();
  if (data_.size() - pos_ < n) throw DecodeError("payload too short");
  std::string s(data_.substr(pos_, n));
  pos_ += n;
  return s;
}

void ByteReader::expect(std::size_t count, std::size_t item_bytes) const {
  // Checked before allocating: a corrupt count must not ask for gigabytes.
  if (item_bytes != 0 && count > (data_.size() - pos_) / item_bytes)
    throw DecodeError("payload too short");
}

namespace {

void put_detections(std::string& out, const std::vector<Detection>& detections) {
  put<std::uint32_t>(out, static_cast<std::uint32_t>(detections.size()));
  for (const Detection& d : detections) {
    put_string(out, d.color);
    put<std::int32_t>(out, d.id);
    put(out, d.range_m);
    put(out, d.bearing_rad);
    put<std::int32_t>(out, d.truth_id);
    put<std::uint8_t>(out, static_cast<std::uint8_t>(d.target));
  }
}

std::vector<Detection> get_detections(ByteReader& in, std::uint32_t version) {
  const auto count = in.get<std::uint32_t>();
  in.expect(count, 4 + 4 + 8 + 8 + 4 + (version >= 2 ? 1 : 0));
  std::vector<Detection> out(count);
  for (Detection& d : out) {
    d.color = in.get_string();
    d.id = in.get<std::int32_t>();
    d.range_m = in.get<double>();
    d.bearing_rad = in.get<double>();
    d.truth_id = in.get<std::int32_t>();
    if (version >= 2) {
      const auto target = in.get<std::uint8_t>();
      if (target > static_cast<std::uint8_t>(DetectionTarget::kRobot))
        throw DecodeError("unknown detection target " + std::to_string(target));
      d.target = static_cast<DetectionTarget>(target);
    }
  }
  return out;
}

void encode_reading(const Reading& r, std::string& out) {
  put(out, r.t_s);
  put<std::uint16_t>(out, static_cast<std::uint16_t>(r.robot));
  put<std::uint8_t>(out, static_cast<std::uint8_t>(r.kind));
  std::visit(
      [&](const auto& d) {
        using T = std::decay_t<decltype(d)>;
        if constexpr (std::is_same_v<T, OdometryReading>) {
          put<std::uint8_t>(out, d.fields);
          put(out, d.left_ticks), put(out, d.right_ticks);
          put(out, d.odometry.x), put(out, d.odometry.y), put(out, d.odometry.theta);
          put(out, d.v_mps), put(out, d.omega_radps);
        } else if constexpr (std::is_same_v<T, ImuReading>) {
          put(out, d.yaw_rate_radps), put(out, d.accel_mps2.x()), put(out, d.accel_mps2.y());
        } else if constexpr (std::is_same_v<T, PtzReading>) {
          put(out, d.pan_rad), put(out, d.tilt_rad), put(out, d.zoom);
          put_detections(out, d.detections);
        } else if constexpr (std::is_same_v<T, OmniReading> ||
                             std::is_same_v<T, RangeBearingReading>) {
          put_detections(out, d.detections);
        } else if constexpr (std::is_same_v<T, UltrasonicReading>) {
          put<std::uint32_t>(out, static_cast<std::uint32_t>(d.ranges.size()));
          for (const BeaconRange& b : d.ranges) {
            put<std::int32_t>(out, b.receiver), put<std::int32_t>(out, b.beacon_id);
            put(out, b.range_m), put<std::uint8_t>(out, static_cast<std::uint8_t>(b.truth_status));
          }
        } else if constexpr (std::is_same_v<T, LaserScan>) {
          put<std::uint32_t>(out, static_cast<std::uint32_t>(d.ranges_m.size()));
          out.append(reinterpret_cast<const char*>(d.ranges_m.data()),
                     d.ranges_m.size() * sizeof(float));
        }
      },
      r.data);
}

void decode_reading(ByteReader& in, Reading& r, std::uint32_t version) {
  r.t_s = in.get<double>();
  r.robot = in.get<std::uint16_t>();
  const auto kind = in.get<std::uint8_t>();
  r.kind = static_cast<SensorKind>(kind);
  switch (r.kind) {
    case SensorKind::kEncoders: {
      OdometryReading d;
      if (version >= 2) {
        d.fields = in.get<std::uint8_t>();
        if (d.fields == 0 || (d.fields & ~kOdometryAllFields) != 0)
          throw DecodeError("odometry fields " + std::to_string(d.fields) +
                            " are not a subset of " + std::to_string(kOdometryAllFields));
      }
      d.left_ticks = in.get<std::int64_t>(), d.right_ticks = in.get<std::int64_t>();
      d.odometry.x = in.get<double>(), d.odometry.y = in.get<double>(),
      d.odometry.theta = in.get<double>();
      if (version >= 2) d.v_mps = in.get<double>(), d.omega_radps = in.get<double>();
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
      d.detections = get_detections(in, version);
      r.data = std::move(d);
      break;
    }
    case SensorKind::kOmniCamera:
      r.data = OmniReading{get_detections(in, version)};
      break;
    case SensorKind::kRangeBearing:
      if (version < 2) throw DecodeError("unknown sensor kind " + std::to_string(kind));
      r.data = RangeBearingReading{get_detections(in, version)};
      break;
    case SensorKind::kUltrasonic: {
      UltrasonicReading d;
      const auto count = in.get<std::uint32_t>();
      in.expect(count, 4 + 4 + 8 + 1);
      d.ranges.resize(count);
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
      const auto count = in.get<std::uint32_t>();
      in.expect(count, sizeof(float));
      d.ranges_m.resize(count);
      for (float& v : d.ranges_m) v = in.get<float>();
      r.data = std::move(d);
      break;
    }
    default:
      throw DecodeError("unknown sensor kind " + std::to_string(kind));
  }
}

}  // namespace

void encode_record(const Record& record, std::string& payload) {
  switch (record.type) {
    case Record::Type::kReading:
      encode_reading(record.reading, payload);
      break;
    case Record::Type::kGroundTruth:
      put(payload, record.t_s);
      put<std::uint16_t>(payload, static_cast<std::uint16_t>(record.robot));
      put(payload, record.pose.x), put(payload, record.pose.y), put(payload, record.pose.theta);
      break;
    case Record::Type::kEvent:
      put(payload, record.event.t_s);
      put<std::int64_t>(payload, record.event.step);
      put<std::int32_t>(payload, record.robot);
      put_string(payload, record.event.kind);
      put_string(payload, record.event.robot);
      put_string(payload, record.event.details);
      break;
    case Record::Type::kEnd:
      break;
  }
}

void decode_record(Record::Type type, std::string_view payload, Record& record,
                   std::uint32_t version) {
  ByteReader in(payload);
  record.type = type;
  switch (type) {
    case Record::Type::kReading:
      decode_reading(in, record.reading, version);
      record.robot = record.reading.robot;
      break;
    case Record::Type::kGroundTruth:
      record.t_s = in.get<double>();
      record.robot = in.get<std::uint16_t>();
      record.pose.x = in.get<double>(), record.pose.y = in.get<double>(),
      record.pose.theta = in.get<double>();
      break;
    case Record::Type::kEvent:
      record.event.t_s = in.get<double>();
      record.event.step = in.get<std::int64_t>();
      record.robot = in.get<std::int32_t>();
      record.event.kind = in.get_string();
      record.event.robot = in.get_string();
      record.event.details = in.get_string();
      break;
    default:
      throw DecodeError("unknown record type " + std::to_string(static_cast<int>(type)));
  }
}

}  // namespace locsim
