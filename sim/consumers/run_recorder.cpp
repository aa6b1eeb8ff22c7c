#include "sim/consumers/run_recorder.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <string_view>
#include <type_traits>
#include <variant>

#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/common/format.hpp"
#include "sim/consumers/config_json.hpp"
#include "sim/sensors/models.hpp"

namespace locsim {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

namespace {

/// The same file: by identity where both exist (hard links, symbolic links), else by the
/// resolved path.
bool same_file(const fs::path& a, const fs::path& b) {
  std::error_code error_a, error_b;
  if (fs::equivalent(a, b, error_a)) return true;
  const fs::path resolved_a = fs::weakly_canonical(a, error_a);
  const fs::path resolved_b = fs::weakly_canonical(b, error_b);
  return !error_a && !error_b && resolved_a == resolved_b;
}

/// `path` with its links resolved where it can be; otherwise (a link to a deleted file, as
/// /proc/self/fd/N of a memfd is) lexically absolute. Never throws.
fs::path resolved(const fs::path& path) {
  std::error_code error;
  fs::path result = fs::weakly_canonical(path, error);
  if (!error) return result;
  result = fs::absolute(path, error);
  return error ? path.lexically_normal() : result.lexically_normal();
}

/// `path` resolved, relative to the resolved `root`; empty when it lies outside it.
fs::path inside(const fs::path& root, const fs::path& path) {
  std::error_code error;
  const fs::path r = fs::weakly_canonical(root, error);
  const fs::path p = fs::weakly_canonical(path, error);
  if (error) return {};
  const auto [end, _] = std::mismatch(r.begin(), r.end(), p.begin(), p.end());
  if (end != r.end()) return {};
  return p.lexically_relative(r);
}

/// Whether a run writes a file of its own at `relative` (to its folder), whatever its robots and
/// localizers are called: the recorder's, the scorer's and the driver's files.
bool run_writes(const fs::path& relative) {
  const std::string name = relative.filename().string();
  for (const fs::path& part : relative) {
    if (part == "readings") return true;
  }
  return name == "run.json" || name == "metrics.json" || name == "events.csv" ||
         relative.extension() == ".tum" || name.ends_with("_map.csv");
}

/// `path` absolute, its links resolved where it can be, without a trailing separator.
fs::path clean(const fs::path& path) {
  std::error_code error;
  const fs::path absolute = fs::absolute(path, error);
  fs::path normal = resolved(error ? path : absolute);
  if (!normal.has_filename() && normal.has_parent_path() && normal != normal.root_path())
    normal = normal.parent_path();
  return normal;
}

/// Whether `inner` is `outer` or lies inside it (both clean).
bool at_or_under(const fs::path& outer, const fs::path& inner) {
  return std::mismatch(outer.begin(), outer.end(), inner.begin(), inner.end()).first == outer.end();
}

/// Whether `file` is a run.json that locsim wrote: every one begins with its version (an earlier
/// locsim's too), whatever its status. Reads its first bytes only.
bool locsim_run_json(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  char head[64] = {};
  in.read(head, sizeof(head));
  const std::string_view text(head, static_cast<std::size_t>(in.gcount()));
  std::size_t at = 0;
  const auto skip_space = [&] {
    while (at < text.size() &&
           (text[at] == ' ' || text[at] == '\n' || text[at] == '\r' || text[at] == '\t'))
      ++at;
  };
  skip_space();
  if (at >= text.size() || text[at] != '{') return false;
  ++at;
  skip_space();
  return text.substr(at).starts_with("\"locsim_version\"");
}

}  // namespace

bool held_by_a_run(const fs::path& run_json) {
  const int fd = ::open(run_json.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool held = ::flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);
  return held;
}

void RunFolder::check(const fs::path& root, bool overwrite, const std::vector<fs::path>& inputs) {
  if (fs::exists(root) && !fs::is_directory(root)) {
    throw InputError("--out: '" + root.string() + "' exists and is not a folder");
  }
  if (!fs::exists(root) || fs::is_empty(root)) return;
  if (!overwrite) {
    throw InputError("--out: folder '" + root.string() +
                     "' is not empty; choose another or pass --overwrite");
  }
  if (!fs::exists(root / "run.json")) {
    // A run killed while it wrote its first run.json leaves that alone, as run.json.tmp.
    const bool begun = std::distance(fs::directory_iterator(root), fs::directory_iterator()) == 1 &&
                       locsim_run_json(root / "run.json.tmp");
    if (begun) return;
    throw InputError("--out: folder '" + root.string() +
                     "' is not empty and holds no run.json: --overwrite empties only a run "
                     "folder; choose another folder");
  }
  if (held_by_a_run(root / "run.json")) {
    throw InputError("--out: folder '" + root.string() +
                     "' is the folder of a run still going on (its run.json is locked): wait "
                     "for it to end, or choose another folder");
  }
  if (!locsim_run_json(root / "run.json")) {
    throw InputError("--out: folder '" + root.string() +
                     "' holds a run.json that is not locsim's (a JSON object beginning with "
                     "\"locsim_version\"): --overwrite empties only a run folder; choose another "
                     "folder");
  }
  for (const fs::path& input : inputs) {
    const fs::path relative = inside(root, input);
    if (!relative.empty() && relative != "." && run_writes(relative)) {
      throw InputError("--out: '" + input.string() + "', which this command reads, lies in '" +
                       root.string() +
                       "' where the run writes a file of that name: move it "
                       "out of the folder or choose another --out");
    }
  }
}

void RunFolder::check_outputs(const std::vector<std::pair<std::string, fs::path>>& outputs,
                              const std::vector<fs::path>& inputs) {
  for (const auto& [option, output] : outputs) {
    for (const fs::path& input : inputs) {
      if (same_file(output, input)) {
        throw InputError(option + ": '" + output.string() + "' is '" + input.string() +
                         "', which this command reads: writing it would destroy it");
      }
    }
  }
}

void RunFolder::check_apart(const fs::path& root, const std::vector<Output>& outputs) {
  std::vector<Output> all{Output{"--out", root, true}};
  all.insert(all.end(), outputs.begin(), outputs.end());
  for (std::size_t i = 1; i < all.size(); ++i) {
    const Output& file = all[i];
    if (file.folder) continue;
    const fs::path outer = clean(file.path);
    for (std::size_t k = 0; k < all.size(); ++k) {
      if (k == i) continue;
      const Output& other = all[k];
      const fs::path inner = clean(other.path);
      if (!at_or_under(outer, inner)) continue;
      if (inner == outer && other.option == "--out") {
        throw InputError(
            file.option + ": '" + file.path.string() +
            "' is the run folder (--out) too: name a file of its own, e.g. '" +
            (file.path / (file.option == "--log" ? "run.locsimlog" : "run.mp4")).string() + "'");
      }
      if (inner == outer) {
        throw InputError(file.option + ": '" + file.path.string() + "' is " + other.option +
                         "'s path too: name a file of its own");
      }
      throw InputError(file.option + ": '" + file.path.string() + "' would be a file, but " +
                       other.option + " '" + other.path.string() +
                       "' lies inside it: a file cannot hold a folder");
    }
    std::error_code error;
    if (fs::is_directory(file.path, error)) {
      throw InputError(file.option + ": '" + file.path.string() +
                       "' is a folder; name the file to write");
    }
    // Inside the run folder, not where the run writes a file of its own (`--log D/run.json`).
    const fs::path folder = clean(root);
    if (at_or_under(folder, outer) && run_writes(outer.lexically_relative(folder))) {
      throw InputError(file.option + ": '" + file.path.string() + "' lies in '" + root.string() +
                       "' where the run writes a file of that name: name another file");
    }
  }
}

fs::path RunFolder::robot_folder(const WorldDef& world, std::size_t robot) {
  return world.robots.size() == 1 ? fs::path(".") : fs::path(world.robots[robot].name);
}

RunFolder RunFolder::make(const fs::path& root, const WorldDef& world, std::string_view run_json) {
  // run.json first: from here on the folder is known as a run folder (--overwrite replaces one
  // left by a run that is killed or fails), and only run.json and what a run writes are in it.
  const fs::path made = make_missing_folders(root, "--out: ");
  try {
    write_file(root / "run.json", run_json);
  } catch (...) {
    std::error_code ignored;
    if (!made.empty()) fs::remove_all(made, ignored);
    throw;
  }
  RunFolder folder{root, {}};
  for (std::size_t i = 0; i < world.robots.size(); ++i) {
    folder.robot_dirs.push_back(world.robots.size() == 1 ? root : root / robot_folder(world, i));
  }
  return folder;
}

void RunFolder::prepare(bool overwrite, const std::vector<fs::path>& keep) const {
  if (overwrite) {
    // An entry is kept when it is a kept file or a folder holding one (--frames inside --out).
    const auto kept = [&](const fs::path& entry) {
      if (entry.filename() == "run.json") return true;  // this run's, written by make()
      const fs::path candidate = resolved(entry);
      return std::any_of(keep.begin(), keep.end(), [&](const fs::path& file) {
        const fs::path target = resolved(file);
        return std::mismatch(candidate.begin(), candidate.end(), target.begin(), target.end())
                   .first == candidate.end();
      });
    };
    for (const fs::directory_entry& entry : fs::directory_iterator(root)) {
      // remove_all removes a symbolic link itself, never what it points to.
      if (!kept(entry.path())) fs::remove_all(entry.path());
    }
  }
  for (const fs::path& dir : robot_dirs) make_missing_folders(dir, "--out: ");
}

RunRecorder::File::File(fs::path path) : path_(std::move(path)), out_(path_) {}

void RunRecorder::File::flush() {
  if (cut_) return;
  try {
    out_.flush();
  } catch (...) {
    cut_ = true;
    throw;
  }
}

void RunRecorder::File::close() {
  try {
    out_.close();
  } catch (...) {
    if (cut_) return;  // reported when it was cut
    cut_ = true;
    throw;
  }
}

template <typename Visit>
void RunRecorder::for_each_file(Visit visit) {
  for (auto& file : groundtruth_) visit(*file);
  for (auto& file : estimates_) visit(*file);
  for (auto& robot : readings_) {
    for (auto& file : robot) {
      if (file) visit(*file);
    }
  }
  if (events_) visit(*events_);
}

RunRecorder::RunRecorder(const RunFolder& folder, const WorldDef& world,
                         const std::vector<LocalizerInfo>& localizers, bool readings)
    : root_(folder.root) {
  std::vector<fs::path> made;  // the readings/ folders, to remove when a file cannot be opened
  try {
    for (std::size_t i = 0; i < world.robots.size(); ++i) {
      const fs::path& dir = folder.robot_dirs[i];
      auto& file = groundtruth_.emplace_back(std::make_unique<File>(dir / "groundtruth.tum"));
      file->write("# timestamp tx ty tz qx qy qz qw  (true pose of robot '" + world.robots[i].name +
                  "', TUM format, z = 0)\n");
    }
    readings_.resize(world.robots.size());
    reports_velocity_.assign(world.robots.size(), false);
    // The world as JSON once, not once per robot (a 100-robot fleet spent most of its start there).
    const json world_json = readings ? to_json(world) : json();
    for (std::size_t i = 0; readings && i < world.robots.size(); ++i) {
      const SensorsDef& sensors = world.robots[i].sensors;
      const auto enabled = [&](SensorKind kind) { return sensor_enabled(sensors, kind); };
      if (std::none_of(kSensorKinds.begin(), kSensorKinds.end(), enabled)) continue;
      const json& config = world_json.at("robots").at(i).at("sensors");
      const fs::path dir = folder.robot_dirs[i] / "readings";
      if (!fs::exists(dir)) made.push_back(dir);
      fs::create_directories(dir);
      // By SensorKind. The odometry's velocity columns only when the encoders report it: the
      // readings/ of every other world stay as they were.
      reports_velocity_[i] =
          enabled(SensorKind::kEncoders) && (sensors.encoders->reports & kOdometryVelocity) != 0;
      const std::string headers[] = {
          std::string("t_s,left_ticks,right_ticks,odom_x_m,odom_y_m,odom_theta_rad") +
              (reports_velocity_[i] ? ",v_mps,omega_radps" : ""),
          "t_s,yaw_rate_radps,accel_x_mps2,accel_y_mps2",
          "t_s,pan_rad,tilt_rad,zoom,detections,color,id,range_m,bearing_rad,truth_id",
          "t_s,detections,color,id,range_m,bearing_rad,truth_id",
          "t_s,receiver,beacon_id,range_m,truth_status",
          "t_s,ranges_m",
          "t_s,detections,color,id,range_m,bearing_rad,truth_id,target",
      };
      static_assert(std::size(headers) == kSensorKinds.size());
      for (const SensorKind kind : kSensorKinds) {
        if (!enabled(kind)) continue;
        const auto k = static_cast<std::size_t>(kind);
        readings_[i][k] = std::make_unique<File>(dir / (std::string(sensor_name(kind)) + ".csv"));
        readings_[i][k]->write(headers[k] + '\n');
      }
      json described = config;
      if (described.contains("laser")) {
        const LaserDef& laser = *sensors.laser;
        json angles = json::array();
        for (int b = 0; b < laser.beams; ++b)
          angles.push_back(laser_beam_angle(b, laser.beams, laser.fov_rad));
        described["laser"]["beam_angles_rad"] = angles;
      }
      write_file(dir / "sensors.json", described.dump(2) + '\n');
    }
    for (const LocalizerInfo& l : localizers) {
      auto& file = estimates_.emplace_back(
          std::make_unique<File>(folder.robot_dirs[l.robot] / (l.label + ".tum")));
      file->write("# timestamp tx ty tz qx qy qz qw  (estimate of localizer '" + l.label +
                  "', plugin " + l.plugin + ", TUM format)\n");
    }
    events_ = std::make_unique<File>(folder.root / "events.csv");
    events_->write("t_s,kind,robot,details\n");
  } catch (...) {
    // Nothing of a recorder that could not start is left: the files it opened (headers only),
    // then its empty folders. The run's failure says why.
    std::error_code ignored;
    for_each_file([&](File& file) {
      try {
        file.close();
      } catch (...) {
      }
      fs::remove(file.path(), ignored);
    });
    for (const fs::path& dir : made) {
      fs::remove(dir / "sensors.json", ignored);
      fs::remove(dir, ignored);
    }
    throw;
  }
}

void RunRecorder::write_reading(const Reading& reading) {
  const auto& file =
      readings_[static_cast<std::size_t>(reading.robot)][static_cast<std::size_t>(reading.kind)];
  if (!file) return;
  line_.clear();
  const auto number = [&](double value, int decimals) {
    line_ += ',';
    append_fixed(line_, value, decimals);
  };
  const auto start_row = [&] { append_fixed(line_, reading.t_s, 4); };
  std::visit(
      [&](const auto& data) {
        using T = std::decay_t<decltype(data)>;
        if constexpr (std::is_same_v<T, OdometryReading>) {
          start_row();
          line_ += ',' + std::to_string(data.left_ticks) + ',' + std::to_string(data.right_ticks);
          number(data.odometry.x, 6);
          number(data.odometry.y, 6);
          number(data.odometry.theta, 6);
          if (reports_velocity_[static_cast<std::size_t>(reading.robot)]) {
            number(data.v_mps, 6);
            number(data.omega_radps, 6);
          }
          line_ += '\n';
        } else if constexpr (std::is_same_v<T, ImuReading>) {
          start_row();
          number(data.yaw_rate_radps, 6);
          number(data.accel_mps2.x(), 5);
          number(data.accel_mps2.y(), 5);
          line_ += '\n';
        } else if constexpr (std::is_same_v<T, PtzReading> || std::is_same_v<T, OmniReading> ||
                             std::is_same_v<T, RangeBearingReading>) {
          // Only the range_bearing sensor's file says what each detection is of (the cameras'
          // files keep their columns).
          constexpr bool kTargets = std::is_same_v<T, RangeBearingReading>;
          std::string prefix;
          append_fixed(prefix, reading.t_s, 4);
          if constexpr (std::is_same_v<T, PtzReading>) {
            prefix += ',';
            append_fixed(prefix, data.pan_rad, 6);
            prefix += ',';
            append_fixed(prefix, data.tilt_rad, 6);
            prefix += ',';
            append_fixed(prefix, data.zoom, 3);
          }
          prefix += ',' + std::to_string(data.detections.size());
          if (data.detections.empty()) line_ += prefix + (kTargets ? ",,,,,,\n" : ",,,,,\n");
          for (const Detection& d : data.detections) {
            line_ += prefix + ',' + d.color + ',' + std::to_string(d.id);
            number(d.range_m, 4);
            number(d.bearing_rad, 6);
            line_ += ',' + std::to_string(d.truth_id);
            if constexpr (kTargets) line_ += ',' + std::string(detection_target_name(d.target));
            line_ += '\n';
          }
        } else if constexpr (std::is_same_v<T, UltrasonicReading>) {
          for (const BeaconRange& r : data.ranges) {
            start_row();
            line_ += ',' + std::to_string(r.receiver) + ',' + std::to_string(r.beacon_id);
            number(r.range_m, 4);
            line_ += ',';
            line_ += range_status_name(r.truth_status);
            line_ += '\n';
          }
        } else if constexpr (std::is_same_v<T, LaserScan>) {
          start_row();
          line_ += ',';
          for (std::size_t b = 0; b < data.ranges_m.size(); ++b) {
            if (b > 0) line_ += ' ';
            append_fixed(line_, data.ranges_m[b], 3);
          }
          line_ += '\n';
        }
      },
      reading.data);
  file->write(line_);
}

void RunRecorder::consume(const Record& record) {
  switch (record.type) {
    case Record::Type::kReading:
      write_reading(record.reading);
      break;
    case Record::Type::kEvent:
      line_.clear();
      append_fixed(line_, record.event.t_s, 4);
      line_ += ',' + record.event.kind + ',' + record.event.robot + ",\"" + record.event.details +
               "\"\n";
      events_->write(line_);
      break;
    case Record::Type::kGroundTruth:
      if (record.robot < 0 || static_cast<std::size_t>(record.robot) >= groundtruth_.size()) break;
      if (!truth_known(record.pose)) break;  // a sampling instant of a log without truth
      line_.clear();
      append_tum(line_, record.t_s, record.pose.x, record.pose.y, record.pose.theta);
      groundtruth_[static_cast<std::size_t>(record.robot)]->write(line_);
      break;
    case Record::Type::kEnd:
      break;
  }
}

void RunRecorder::estimate(const EstimateSample& sample) {
  line_.clear();
  append_tum(line_, sample.t_s, sample.pose.x, sample.pose.y, sample.pose.theta);
  estimates_[sample.localizer]->write(line_);
}

void RunRecorder::flush() {
  for_each_file([](File& file) { file.flush(); });
}

void RunRecorder::close() {
  std::exception_ptr first;
  for_each_file([&](File& file) {
    try {
      file.close();
    } catch (...) {
      if (!first) first = std::current_exception();
    }
  });
  if (first) std::rethrow_exception(first);
}

std::vector<std::string> RunRecorder::remove_cut() {
  std::vector<std::string> removed;
  for_each_file([&](File& file) {
    if (!file.cut()) return;
    std::error_code error;
    if (fs::remove(file.path(), error))
      removed.push_back(file.path().lexically_relative(root_).generic_string());
  });
  return removed;
}

}  // namespace locsim
