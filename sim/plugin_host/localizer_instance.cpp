#include "sim/plugin_host/localizer_instance.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <sstream>
#include <tuple>

#include "sim/common/errors.hpp"
#include "sim/common/format.hpp"
#include "sim/common/yaml_node.hpp"
#include "sim/sensors/models.hpp"

namespace locsim {

using json = nlohmann::ordered_json;

namespace {

/// Why an estimate's covariance cannot be one (empty when it can): it must be symmetric and
/// positive semidefinite, as a NaN must not be scored (the NEES of metrics.json needs an honest
/// matrix, and a negative variance would make it negative). Both up to 1e-6 of the largest
/// variance: above the rounding a filter's algebra leaves (an EKF's Joseph-form update on a
/// covariance of 1e-14 m^2 was 1e-8 asymmetric), far below anything it means. Never below the
/// smallest normal double: a particle cloud collapsed onto one pose has variances of 0 and, from
/// the products of its tiny deviations, off-diagonal pairs like 0 and -5e-324 (underflow, which
/// has no relative precision; fastslam on an MRCLAM twin failed so).
std::string covariance_problem(const double (&c)[9]) {
  const double tolerance =
      std::max(1e-6 * std::max({std::abs(c[0]), std::abs(c[4]), std::abs(c[8])}),
               std::numeric_limits<double>::min());
  constexpr std::array<std::tuple<int, int, const char*>, 3> kPairs{
      {{1, 3, "(x, y) and (y, x)"},
       {2, 6, "(x, theta) and (theta, x)"},
       {5, 7, "(y, theta) and (theta, y)"}}};
  for (const auto& [a, b, which] : kPairs) {
    if (std::abs(c[a] - c[b]) > tolerance) {
      return std::string("is not symmetric: ") + which + " are " + short_number(c[a]) + " and " +
             short_number(c[b]);
    }
  }
  // Most estimates pass: a Cholesky factorisation of P + tolerance / 2 I (its lower triangle,
  // as the solver reads; a fifth of the solver's cost, which was 2 % of a run) proves it. Where
  // every pivot is positive the lowest eigenvalue is at least -tolerance / 2 less the
  // factorisation's rounding (~1e-15 of the largest variance), so the solver would pass it too;
  // where one is not, or in the underflow range where relative rounding means nothing, the
  // solver decides. Finite entries only (the caller checks).
  if (tolerance > 1e-200) {
    const double shift = 0.5 * tolerance;
    const double d0 = c[0] + shift;
    if (d0 > 0.0) {
      const double l0 = std::sqrt(d0), l10 = c[3] / l0, l20 = c[6] / l0;
      const double d1 = c[4] + shift - l10 * l10;
      if (d1 > 0.0) {
        const double l21 = (c[7] - l20 * l10) / std::sqrt(d1);
        if (c[8] + shift - l20 * l20 - l21 * l21 > 0.0) return {};
      }
    }
  }
  const Eigen::Matrix3d p = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(c);
  const double lowest =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(p, Eigen::EigenvaluesOnly).eigenvalues()(0);
  if (lowest < -tolerance) {
    return "is not positive semidefinite: it has an eigenvalue of " + short_number(lowest);
  }
  return {};
}

bool valid_name(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-' || c == '.' ||
           c == '=';
  });
}
}  // namespace

LocalizerSpec parse_localizer_spec(const std::string& text) {
  LocalizerSpec spec;
  std::string rest = text;
  if (const auto at = rest.rfind('@'); at != std::string::npos) {
    spec.label = rest.substr(at + 1);
    rest = rest.substr(0, at);
    if (!valid_name(spec.label)) {
      throw InputError("--localizer '" + text + "': label '" + spec.label +
                       "' may hold only a-z, 0-9, '_', '-', '.', '=' (it names a file)");
    }
  }
  auto colon = rest.find(':');
  spec.plugin = rest.substr(0, colon);
  if (spec.plugin.empty()) throw InputError("--localizer '" + text + "': no plugin name");
  if (spec.plugin.ends_with(".py")) {
    spec.source = spec.plugin;
    spec.plugin = "python";
  } else if (colon != std::string::npos) {
    const auto next = rest.find(':', colon + 1);
    const std::string field =
        rest.substr(colon + 1, next == std::string::npos ? next : next - colon - 1);
    // A source: any field after `python:` without '=', or a file's path after another loader's
    // name (`probe:gain` stays a parameter given no value).
    const bool names_file = field.find('/') != std::string::npos || field.ends_with(".py");
    if (field.find('=') == std::string::npos && (spec.plugin == "python" || names_file)) {
      spec.source = field;
      if (spec.source.empty())
        throw InputError("--localizer '" + text + "': empty source after '" + spec.plugin + ":'");
      colon = next;
    }
  }
  if (colon != std::string::npos) {
    std::stringstream items(rest.substr(colon + 1));
    std::string item;
    while (std::getline(items, item, ',')) {
      const auto equals = item.find('=');
      if (equals == std::string::npos || equals == 0) {
        throw InputError("--localizer '" + text + "': expected key=value, got '" + item + "'");
      }
      const std::string key = item.substr(0, equals);
      if (equals + 1 == item.size()) {
        // A value left out (a shell variable that was empty) is a mistake, not an empty string.
        throw InputError("--localizer '" + text + "': parameter '" + key + "' has no value");
      }
      for (const auto& [given, value] : spec.params) {
        if (given == key) {
          throw InputError("--localizer '" + text + "': parameter '" + key + "' given twice (" +
                           given + "=" + value + ", " + item + ")");
        }
      }
      spec.params.emplace_back(key, item.substr(equals + 1));
    }
  }
  if (spec.label.empty()) {
    spec.label =
        std::filesystem::path(spec.source.empty() ? spec.plugin : spec.source).stem().string();
    if (spec.label.starts_with("locsim_")) spec.label = spec.label.substr(7);
  }
  return spec;
}

// ---------------------------------------------------------------------------------------------
namespace {
/// "--localizer LABEL: plugin 'NAME' has no parameter 'KEY'; did you mean ...? (parameters: ...)"
std::string undeclared(const locsim_localizer& table, const LocalizerSpec& spec,
                       const std::string& key) {
  std::string best, known;
  std::size_t best_distance = 4;
  for (std::size_t i = 0; i < table.param_count; ++i) {
    const std::string name = table.params[i].name;
    known += (known.empty() ? "" : ", ") + name;
    if (const std::size_t d = edit_distance(key, name); d < best_distance)
      best_distance = d, best = name;
  }
  return "--localizer " + spec.label + ": plugin '" + table.name + "' has no parameter '" + key +
         "'" + (best.empty() ? "" : "; did you mean '" + best + "'?") +
         " (parameters: " + (known.empty() ? "none" : known) + ")";
}

/// A parameter's value as text, and where it came from: the spec (no place) or the params file.
struct GivenValue {
  std::string text;
  std::optional<InputPlace> place;
};
}  // namespace

ParamSet::ParamSet(const locsim_localizer& table, const LocalizerSpec& spec) {
  // Lowest precedence first: each later source replaces what an earlier one gave.
  std::map<std::string, GivenValue> given;
  if (const ParamFile* file = spec.params_file.get()) {
    for (const ParamFileValue& v : file->common) {
      if (declares(table, v.key)) given[v.key] = {v.text, v.place};
    }
    if (const ParamFileSection* section = file->section(table.name)) {
      for (const ParamFileValue& v : section->values) {
        if (!declares(table, v.key)) throw InputError(v.place, undeclared(table, spec, v.key));
        given[v.key] = {v.text, v.place};
      }
    }
  }
  for (const auto& [key, value] : spec.params) {
    if (!declares(table, key)) throw InputError(undeclared(table, spec, key));
    given[key] = {value, std::nullopt};
  }
  for (std::size_t i = 0; i < table.param_count; ++i) {
    const locsim_param_decl& decl = table.params[i];
    locsim_param_value value{decl.name, decl.type, decl.default_number, nullptr};
    if (decl.type == LOCSIM_PARAM_STRING) {
      strings_.push_back(decl.default_string != nullptr ? decl.default_string : "");
    }
    const auto it = given.find(decl.name);
    if (it != given.end()) {
      const std::string& text = it->second.text;
      const auto fail = [&](const std::string& problem) {
        const std::string message =
            "--localizer " + spec.label + ": parameter '" + decl.name + "': " + problem;
        if (it->second.place) throw InputError(*it->second.place, message);
        throw InputError(message);
      };
      switch (decl.type) {
        case LOCSIM_PARAM_DOUBLE:
        case LOCSIM_PARAM_INT: {
          std::size_t used = 0;
          double number = 0.0;
          try {
            number = std::stod(text, &used);
          } catch (const std::exception&) {
            used = 0;
          }
          if (used != text.size() || !std::isfinite(number)) {
            fail("expected a number, got '" + text + "'");
          }
          if (decl.type == LOCSIM_PARAM_INT && number != std::floor(number)) {
            fail("expected an integer, got '" + text + "'");
          }
          if (number < decl.min_number || number > decl.max_number) {
            fail(text + " is outside [" + std::to_string(decl.min_number) + ", " +
                 std::to_string(decl.max_number) + "]");
          }
          value.number = number;
          break;
        }
        case LOCSIM_PARAM_BOOL:
          if (text == "true" || text == "1") {
            value.number = 1.0;
          } else if (text == "false" || text == "0") {
            value.number = 0.0;
          } else {
            fail("expected true or false, got '" + text + "'");
          }
          break;
        case LOCSIM_PARAM_STRING:
          strings_.back() = text;
          break;
        default:
          throw PluginError(std::string("plugin '") + table.name + "' declares parameter '" +
                            decl.name + "' with unknown type " + std::to_string(decl.type));
      }
    }
    if (decl.type == LOCSIM_PARAM_STRING) value.string = strings_.back().c_str();
    values_.push_back(value);
  }
}

json ParamSet::to_json() const {
  json out = json::object();
  for (const locsim_param_value& v : values_) {
    switch (v.type) {
      case LOCSIM_PARAM_INT:
        out[v.name] = static_cast<long long>(v.number);
        break;
      case LOCSIM_PARAM_BOOL:
        out[v.name] = v.number != 0.0;
        break;
      case LOCSIM_PARAM_STRING:
        out[v.name] = v.string;
        break;
      default:
        out[v.name] = v.number;
        break;
    }
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
LocalizerWorld::LocalizerWorld(const WorldDef& world, const RobotDef& robot_def,
                               OccupancyGrid occupancy, const LocalizationDef& localization,
                               RandomStream& initial_rng)
    : grid(std::move(occupancy)) {
  for (const LandmarkDef& l : world.landmarks) {
    colors.push_back(color_label(l));
    landmarks.push_back(
        {l.id, l.position_m.x(), l.position_m.y(), l.radius_m, l.height_m, colors.back().c_str()});
  }
  for (const BeaconDef& b : world.beacons) {
    beacons.push_back({b.id, b.position_m.x(), b.position_m.y(), b.height_m});
  }
  // SLAM: the landmarks' positions are what the filter has to find out.
  map.landmarks = localization.landmarks_known ? landmarks.data() : nullptr;
  map.landmark_count = localization.landmarks_known ? landmarks.size() : 0;
  map.beacons = beacons.data();
  map.beacon_count = beacons.size();
  map.grid = {grid.origin_m.x(), grid.origin_m.y(), grid.resolution_m,
              grid.width,        grid.height,       grid.cells.data()};
  // What the robot believes (the encoders' base, the nominal radius), not the true geometry.
  robot = {believed_wheel_base_m(robot_def), robot_def.wheel_radius_m,
           bounding_radius(robot_def.footprint)};
  initial_pose_known = localization.initial_pose_known;
  if (initial_pose_known) {
    // One guess per robot, shared by all its filters so that they start alike.
    initial_pose = {
        robot_def.start.x + initial_rng.normal(0.0, localization.sigma_xy_m),
        robot_def.start.y + initial_rng.normal(0.0, localization.sigma_xy_m),
        wrap_angle(robot_def.start.theta + initial_rng.normal(0.0, localization.sigma_theta_rad))};
    const double var_xy = std::max(localization.sigma_xy_m * localization.sigma_xy_m, 1e-12);
    const double var_theta =
        std::max(localization.sigma_theta_rad * localization.sigma_theta_rad, 1e-12);
    initial_covariance[0] = initial_covariance[4] = var_xy;
    initial_covariance[8] = var_theta;
  }
}

// ---------------------------------------------------------------------------------------------
ReadingTranslator::ReadingTranslator(const RobotDef& robot)
    : robot_(&robot),
      velocity_odometry_(sdk::Pose(robot.start.x, robot.start.y, robot.start.theta)),
      tick_odometry_(robot.start.x, robot.start.y, robot.start.theta) {
  if (robot.sensors.encoders) {
    meters_per_tick_ =
        2.0 * std::numbers::pi * robot.wheel_radius_m / robot.sensors.encoders->ticks_per_rev;
  }
  if (robot.sensors.laser) {
    const LaserDef& laser = *robot.sensors.laser;
    for (int i = 0; i < laser.beams; ++i) {
      laser_angles_.push_back(static_cast<float>(laser_beam_angle(i, laser.beams, laser.fov_rad)));
    }
  }
  out_.struct_size = sizeof(locsim_reading);
}

locsim_pose2 ReadingTranslator::odometry_pose(double t_s, const OdometryReading& odometry) {
  if (odometry.has(kOdometryPose))
    return {odometry.odometry.x, odometry.odometry.y, odometry.odometry.theta};
  // odom frame = world at t = 0: dead reckoning starts at the robot's start pose.
  if (odometry.has(kOdometryVelocity)) {
    const sdk::Pose& pose = velocity_odometry_.update(t_s, odometry.v_mps, odometry.omega_radps);
    return {pose(0), pose(1), pose(2)};
  }
  if (odometry.has(kOdometryTicks)) {
    // Ticks come from the encoders (meters_per_tick_ is theirs); the wheel base the base
    // believes in, as its own dead reckoning (sensors/models.cpp).
    const double wheel_base_m = believed_wheel_base_m(*robot_);
    if (last_ticks_) {
      tick_odometry_ = sdk::diff_drive_motion(
          tick_odometry_,
          static_cast<double>(odometry.left_ticks - last_ticks_->first) * meters_per_tick_,
          static_cast<double>(odometry.right_ticks - last_ticks_->second) * meters_per_tick_,
          wheel_base_m);
    }
    last_ticks_ = {odometry.left_ticks, odometry.right_ticks};
  }
  return {tick_odometry_(0), tick_odometry_(1), tick_odometry_(2)};
}

const locsim_reading& ReadingTranslator::translate(const Reading& reading) {
  out_.t_s = reading.t_s;
  const SensorsDef& sensors = robot_->sensors;
  std::visit(
      [&](const auto& data) {
        using T = std::decay_t<decltype(data)>;
        if constexpr (std::is_same_v<T, OdometryReading>) {
          out_.kind = LOCSIM_READING_ODOMETRY;
          const bool ticks = data.has(kOdometryTicks);
          out_.data.odometry = {ticks ? data.left_ticks : 0,
                                ticks ? data.right_ticks : 0,
                                ticks ? meters_per_tick_ : 0.0,
                                odometry_pose(reading.t_s, data),
                                data.fields,
                                data.has(kOdometryVelocity) ? data.v_mps : 0.0,
                                data.has(kOdometryVelocity) ? data.omega_radps : 0.0};
        } else if constexpr (std::is_same_v<T, ImuReading>) {
          out_.kind = LOCSIM_READING_IMU;
          out_.data.imu = {data.yaw_rate_radps, data.accel_mps2.x(), data.accel_mps2.y(),
                           sensors.imu->common.reported_mount().theta};
        } else if constexpr (std::is_same_v<T, PtzReading> || std::is_same_v<T, OmniReading> ||
                             std::is_same_v<T, RangeBearingReading>) {
          detections_.clear();
          for (const Detection& d : data.detections) {
            detections_.push_back({d.color.c_str(), d.id, d.range_m, d.bearing_rad,
                                   static_cast<std::int32_t>(d.target)});
          }
          out_.kind = LOCSIM_READING_LANDMARKS;
          const locsim_camera_kind camera = std::is_same_v<T, PtzReading> ? LOCSIM_CAMERA_PTZ
                                            : std::is_same_v<T, OmniReading>
                                                ? LOCSIM_CAMERA_OMNI
                                                : LOCSIM_CAMERA_RANGE_BEARING;
          out_.data.landmarks = {camera, 0.0, detections_.data(), detections_.size()};
          if constexpr (std::is_same_v<T, PtzReading>) out_.data.landmarks.pan_rad = data.pan_rad;
        } else if constexpr (std::is_same_v<T, UltrasonicReading>) {
          ranges_.clear();
          for (const BeaconRange& r : data.ranges) {
            const auto& receiver =
                sensors.ultrasonic->receivers[static_cast<std::size_t>(r.receiver)];
            ranges_.push_back({r.receiver, r.beacon_id, r.range_m, receiver.position_m.x(),
                               receiver.position_m.y(), receiver.height_m});
          }
          out_.kind = LOCSIM_READING_BEACON_RANGES;
          out_.data.beacon_ranges = {ranges_.data(), ranges_.size()};
        } else if constexpr (std::is_same_v<T, LaserScan>) {
          const LaserDef& laser = *sensors.laser;
          const Pose2& mount = laser.common.reported_mount();
          out_.kind = LOCSIM_READING_LASER;
          out_.data.laser = {data.ranges_m.data(), laser_angles_.data(),
                             data.ranges_m.size(), {mount.x, mount.y, mount.theta},
                             laser.min_range_m,    laser.max_range_m};
        }
      },
      reading.data);
  return out_;
}

// ---------------------------------------------------------------------------------------------
namespace {
// ABI version 1's structs where version 2 changed them (plugins/sdk/include/locsim/localizer.h
// before version 2): the odometry without its fields and velocity, the detection without its
// target. The others are unchanged.
struct OdometryV1 {
  std::int64_t left_ticks, right_ticks;
  double meters_per_tick;
  locsim_pose2 odom_pose;
};
struct DetectionV1 {
  const char* color;
  std::int32_t id;
  double range_m;
  double bearing_rad;
};
struct LandmarksV1 {
  std::int32_t camera;
  double pan_rad;
  const DetectionV1* detections;
  std::size_t count;
};
struct ReadingV1 {
  std::uint32_t struct_size;
  std::int32_t kind;
  double t_s;
  union {
    OdometryV1 odometry;
    locsim_imu imu;
    LandmarksV1 landmarks;
    locsim_beacon_ranges beacon_ranges;
    locsim_laser_scan laser;
  } data;
};
// What a version-1 plugin was compiled with (x86-64 and AArch64 LP64 layouts).
static_assert(sizeof(DetectionV1) == 32 && sizeof(OdometryV1) == 48 && sizeof(ReadingV1) == 80);
static_assert(sizeof(ReadingV1) <= sizeof(locsim_reading));

// The tick a version-1 plugin is given when the source has no ticks: small enough that rounding
// to whole ticks loses nothing a filter would notice (0.05 mm at most, as the ticks are rounded
// from the cumulative travel).
constexpr double kAbi1SyntheticTickM = 1e-4;
}  // namespace

/// Version 2's reading as version 1's: detections of other robots withheld (a version-1 plugin
/// would take them for landmarks), odometry without ticks given ticks of kAbi1SyntheticTickM
/// that drive the odometry pose's increments with the nominal wheel base (the inverse of the
/// differential-drive arc, SDK wheel_travel_from_increment), so that a tick-based filter moves.
class LocalizerInstance::Abi1Adapter {
 public:
  explicit Abi1Adapter(double wheel_base_m) : wheel_base_m_(wheel_base_m) {}

  const locsim_reading& adapt(const locsim_reading& reading) {
    out_ = {};
    out_.struct_size = sizeof(ReadingV1);
    out_.kind = reading.kind;
    out_.t_s = reading.t_s;
    switch (reading.kind) {
      case LOCSIM_READING_ODOMETRY:
        out_.data.odometry = odometry(reading.data.odometry);
        break;
      case LOCSIM_READING_LANDMARKS: {
        const locsim_landmarks& in = reading.data.landmarks;
        detections_.clear();
        for (std::size_t i = 0; i < in.count; ++i) {
          const locsim_detection& d = in.detections[i];
          if (d.target != LOCSIM_TARGET_LANDMARK) continue;
          detections_.push_back({d.color, d.id, d.range_m, d.bearing_rad});
        }
        out_.data.landmarks = {in.camera, in.pan_rad, detections_.data(), detections_.size()};
        break;
      }
      case LOCSIM_READING_IMU:
        out_.data.imu = reading.data.imu;
        break;
      case LOCSIM_READING_BEACON_RANGES:
        out_.data.beacon_ranges = reading.data.beacon_ranges;
        break;
      case LOCSIM_READING_LASER:
        out_.data.laser = reading.data.laser;
        break;
      default:
        break;
    }
    // The plugin reads these bytes with version 1's layout, which ReadingV1 reproduces; copied
    // into the type the table's update() takes (no aliasing of unrelated types).
    std::memcpy(&view_, &out_, sizeof(out_));
    return view_;
  }

 private:
  OdometryV1 odometry(const locsim_odometry& in) {
    if ((in.fields & LOCSIM_ODOMETRY_TICKS) != 0)
      return {in.left_ticks, in.right_ticks, in.meters_per_tick, in.odom_pose};
    const sdk::Pose pose(in.odom_pose.x, in.odom_pose.y, in.odom_pose.theta);
    if (last_pose_) {
      const auto [left_m, right_m] =
          sdk::wheel_travel_from_increment(sdk::between(*last_pose_, pose), wheel_base_m_);
      left_m_ += left_m;
      right_m_ += right_m;
    }
    last_pose_ = pose;
    // Rounded from the cumulative travel, so that rounding errors do not add up.
    return {std::llround(left_m_ / kAbi1SyntheticTickM),
            std::llround(right_m_ / kAbi1SyntheticTickM), kAbi1SyntheticTickM, in.odom_pose};
  }

  double wheel_base_m_;
  std::optional<sdk::Pose> last_pose_;
  double left_m_ = 0.0, right_m_ = 0.0;  // synthesised cumulative wheel travel
  std::vector<DetectionV1> detections_;
  ReadingV1 out_{};
  locsim_reading view_{};  // out_'s bytes
};

// ---------------------------------------------------------------------------------------------
const char* plugin_call_name(PluginCall call) {
  switch (call) {
    case PluginCall::kNone:
      return "none";
    case PluginCall::kCreate:
      return "create";
    case PluginCall::kUpdate:
      return "update";
    case PluginCall::kEstimate:
      return "estimate";
    case PluginCall::kParticles:
      return "particles";
    case PluginCall::kDiagnostics:
      return "diagnostics";
    case PluginCall::kLandmarkMap:
      return "landmark_map";
    case PluginCall::kDestroy:
      return "destroy";
  }
  return "?";
}

std::chrono::steady_clock::time_point LocalizerInstance::begin(PluginCall call, double t_s) {
  // The clock only where someone reads it: the cost of updates, a worker's watchdog.
  if (calls_ == nullptr && call != PluginCall::kUpdate) return {};
  const auto now = std::chrono::steady_clock::now();
  if (calls_ != nullptr) {
    calls_->t_s.store(t_s, std::memory_order_relaxed);
    calls_->localizer.store(index_, std::memory_order_relaxed);
    calls_->call.store(static_cast<int>(call), std::memory_order_relaxed);
    // Last, with release: a watchdog that sees the start time sees the rest.
    calls_->started_ns.store(
        std::chrono::duration_cast<std::chrono::nanoseconds>(now.time_since_epoch()).count(),
        std::memory_order_release);
  }
  return now;
}

void LocalizerInstance::end() {
  if (calls_ != nullptr) calls_->started_ns.store(0, std::memory_order_release);
}

LocalizerInstance::LocalizerInstance(std::shared_ptr<const PluginLibrary> library,
                                     std::string label, ParamSet params,
                                     const LocalizerWorld& world, std::uint64_t seed,
                                     CallState* calls, int index)
    : library_(std::move(library)),
      label_(std::move(label)),
      params_(std::move(params)),
      calls_(calls),
      index_(index) {
  if (library_->abi_version() == 1) abi1_ = std::make_unique<Abi1Adapter>(world.robot.wheel_base_m);
  locsim_init init{};
  init.struct_size = sizeof(locsim_init);
  init.params = params_.values().data();
  init.param_count = params_.values().size();
  init.map = &world.map;
  init.robot = &world.robot;
  init.initial_pose_known = world.initial_pose_known ? 1 : 0;
  init.initial_pose = world.initial_pose;
  std::copy(std::begin(world.initial_covariance), std::end(world.initial_covariance),
            init.initial_covariance);
  init.seed = seed;
  error_[0] = '\0';
  begin(PluginCall::kCreate, 0.0);
  instance_ = table().create(&init, error_, sizeof(error_));
  end();
  if (instance_ == nullptr) {
    throw PluginError("localizer '" + label_ + "' (plugin " + table().name + ", " +
                      library_->path().string() +
                      "): create failed: " + (error_[0] != '\0' ? error_ : "no message"));
  }
}

LocalizerInstance::~LocalizerInstance() {
  if (instance_ == nullptr) return;
  begin(PluginCall::kDestroy, 0.0);
  table().destroy(instance_);
  end();
}

void LocalizerInstance::fail(double t_s, const std::string& call, const std::string& message) {
  failure_ = Failure{t_s, call, message};
}

void LocalizerInstance::deliver(const locsim_reading& reading) {
  if (failure_) return;
  // A "step" in the papers is a perception update: what the steps-to-convergence count.
  if (reading.kind == LOCSIM_READING_LANDMARKS || reading.kind == LOCSIM_READING_BEACON_RANGES ||
      reading.kind == LOCSIM_READING_LASER) {
    ++perception_updates_;
  }
  ++updates_;
  error_[0] = '\0';
  const locsim_reading& given = abi1_ ? abi1_->adapt(reading) : reading;
  const auto start = begin(PluginCall::kUpdate, reading.t_s);
  const int status = table().update(instance_, &given, error_, sizeof(error_));
  cost_.add(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  end();
  if (status != 0)
    fail(reading.t_s, "update", error_[0] != '\0' ? error_ : "returned an error without a message");
}

std::optional<locsim_estimate> LocalizerInstance::estimate(double t_s) {
  if (failure_) return std::nullopt;
  locsim_estimate out{};
  error_[0] = '\0';
  begin(PluginCall::kEstimate, t_s);
  const int status = table().estimate(instance_, &out, error_, sizeof(error_));
  end();
  if (status != 0) {
    fail(t_s, "estimate", error_[0] != '\0' ? error_ : "returned an error without a message");
    return std::nullopt;
  }
  bool finite =
      std::isfinite(out.pose.x) && std::isfinite(out.pose.y) && std::isfinite(out.pose.theta);
  for (const double c : out.covariance) finite = finite && std::isfinite(c);
  if (!finite) {
    fail(t_s, "estimate", "returned a non-finite (NaN or inf) pose or covariance");
    return std::nullopt;
  }
  if (const std::string problem = covariance_problem(out.covariance); !problem.empty()) {
    fail(t_s, "estimate", "returned a covariance that " + problem);
    return std::nullopt;
  }
  return out;
}

std::vector<locsim_pose2> LocalizerInstance::particles(double t_s, std::vector<double>* weights) {
  if (weights != nullptr) weights->clear();
  if (failure_ || table().particles == nullptr) return {};
  locsim_particles out{};
  error_[0] = '\0';
  begin(PluginCall::kParticles, t_s);
  const int status = table().particles(instance_, &out, error_, sizeof(error_));
  end();
  if (status != 0) {
    fail(t_s, "particles", error_[0] != '\0' ? error_ : "returned an error without a message");
    return {};
  }
  if (out.count > 0 && out.poses == nullptr) {
    fail(t_s, "particles",
         "returned " + std::to_string(out.count) + " particles and a NULL pointer");
    return {};
  }
  if (weights != nullptr && out.weights != nullptr)
    weights->assign(out.weights, out.weights + out.count);
  return {out.poses, out.poses + out.count};
}

std::vector<std::pair<std::string, double>> LocalizerInstance::diagnostics(double t_s) {
  if (failure_ || table().diagnostics == nullptr) return {};
  locsim_diagnostic out[64];
  std::size_t count = 0;
  error_[0] = '\0';
  begin(PluginCall::kDiagnostics, t_s);
  const int status = table().diagnostics(instance_, out, 64, &count, error_, sizeof(error_));
  end();
  if (status != 0) {
    fail(t_s, "diagnostics", error_[0] != '\0' ? error_ : "returned an error without a message");
    return {};
  }
  std::vector<std::pair<std::string, double>> named;
  for (std::size_t i = 0; i < std::min<std::size_t>(count, 64); ++i)
    named.emplace_back(out[i].name != nullptr ? out[i].name : "?", out[i].value);
  return named;
}

std::vector<locsim_mapped_landmark> LocalizerInstance::landmark_map(double t_s) {
  if (failure_ || table().landmark_map == nullptr) return {};
  locsim_landmark_map out{};
  error_[0] = '\0';
  begin(PluginCall::kLandmarkMap, t_s);
  const int status = table().landmark_map(instance_, &out, error_, sizeof(error_));
  end();
  if (status != 0) {
    fail(t_s, "landmark_map", error_[0] != '\0' ? error_ : "returned an error without a message");
    return {};
  }
  if (out.count == 0) return {};
  if (out.landmarks == nullptr) {
    fail(t_s, "landmark_map",
         "returned " + std::to_string(out.count) + " landmarks and a NULL pointer");
    return {};
  }
  std::vector<locsim_mapped_landmark> landmarks(out.landmarks, out.landmarks + out.count);
  for (const locsim_mapped_landmark& l : landmarks) {
    bool finite = std::isfinite(l.x) && std::isfinite(l.y);
    for (const double c : l.covariance) finite = finite && std::isfinite(c);
    if (!finite) {
      fail(t_s, "landmark_map",
           "returned a non-finite (NaN or inf) position or covariance for landmark " +
               std::to_string(l.id));
      return {};
    }
  }
  return landmarks;
}

}  // namespace locsim
