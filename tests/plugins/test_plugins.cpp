// Plugins that misbehave on purpose, one per failure the host must survive or report, plus a
// no-op (host overhead), a hashing one (every filter sees the same readings), a fake SLAM filter
// with a known landmark map and one built for ABI version 1, and one whose `how` picks a way to
// escape or break its process (fork, daemonise, flood, write onto locsim's socket, take all
// memory). Each is built from this file with LOCSIM_TEST_PLUGIN set to its kind.
#include <fcntl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <locsim/localizer.hpp>
#include <locsim/models.hpp>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace {

/// Counts readings, hashes their kinds, times and payload sizes.
class Probe : public locsim::sdk::Localizer {
 public:
  explicit Probe(const locsim_init& init) : pose_{init.initial_pose} {}
  void update(const locsim_reading& r) override {
    ++readings_;
    mix(static_cast<std::uint64_t>(r.kind));
    std::uint64_t t;
    std::memcpy(&t, &r.t_s, sizeof t);
    mix(t);
    if (r.kind == LOCSIM_READING_LASER) {
      for (size_t i = 0; i < r.data.laser.count; ++i) {
        std::uint32_t bits;
        std::memcpy(&bits, &r.data.laser.ranges[i], sizeof bits);
        mix(bits);
      }
    }
    if (r.kind == LOCSIM_READING_ODOMETRY)
      mix(static_cast<std::uint64_t>(r.data.odometry.left_ticks));
    on_reading(r);
  }
  virtual void on_reading(const locsim_reading&) {}
  locsim::sdk::Estimate estimate() const override { return {pose_, Eigen::Matrix3d::Identity()}; }
  std::vector<std::pair<std::string, double>> diagnostics() const override {
    return {{"readings", static_cast<double>(readings_)},
            {"hash", static_cast<double>(hash_ >> 12)}};
  }

 protected:
  void mix(std::uint64_t v) {
    hash_ ^= v;
    hash_ *= 0x100000001b3ULL;
  }
  locsim_pose2 pose_;
  long readings_ = 0;
  std::uint64_t hash_ = 0xcbf29ce484222325ULL;
};

#if defined(LOCSIM_TEST_THROWS)
class Plugin final : public Probe {
 public:
  using Probe::Probe;
  void on_reading(const locsim_reading& r) override {
    if (r.t_s >= 1.0) throw std::runtime_error("deliberate failure at one second");
  }
};
#elif defined(LOCSIM_TEST_NAN)
/// From two seconds on, an estimate that is not one: by `mode`, a NaN position (the default,
/// "fast"), a covariance that is not symmetric ("asymmetric") or one with a negative variance
/// ("negative"), or whose x and y are correlated a little more than perfectly, an eigenvalue of
/// -3e-6 ("beyond_tolerance": negative beyond the host's tolerance of 1e-6 of the largest
/// variance); or one that is: a particle cloud collapsed onto one pose ("collapsed": zero
/// variances, an off-diagonal pair of 0 and the smallest subnormal, as rounding leaves it), an
/// eigenvalue of -8e-7 ("within_tolerance": rounding, as the host takes it).
class Plugin final : public Probe {
 public:
  explicit Plugin(const locsim_init& init)
      : Probe(init), mode_(locsim::sdk::Params(init).string("mode")) {}
  void on_reading(const locsim_reading& r) override { t_ = r.t_s; }
  locsim::sdk::Estimate estimate() const override {
    locsim::sdk::Estimate e{pose_, Eigen::Matrix3d::Identity()};
    if (t_ < 2.0) return e;
    if (mode_ == "asymmetric") {
      e.covariance(0, 1) = 0.5;
    } else if (mode_ == "negative") {
      e.covariance(2, 2) = -0.01;
    } else if (mode_ == "beyond_tolerance" || mode_ == "within_tolerance") {
      e.covariance(0, 1) = e.covariance(1, 0) =
          mode_ == "beyond_tolerance" ? 1.0 + 3e-6 : 1.0 + 8e-7;
    } else if (mode_ == "collapsed") {
      e.covariance.setZero();
      e.covariance(0, 2) = -std::numeric_limits<double>::denorm_min();
    } else {
      e.pose.x = std::numeric_limits<double>::quiet_NaN();
    }
    return e;
  }

 private:
  std::string mode_;
  double t_ = 0.0;
};
#elif defined(LOCSIM_TEST_CREATE_FAILS)
class Plugin final : public Probe {
 public:
  explicit Plugin(const locsim_init& init) : Probe(init) {
    throw std::invalid_argument("needs a map with at least 100 landmarks");
  }
};
#elif defined(LOCSIM_TEST_SEGFAULT)
class Plugin final : public Probe {
 public:
  using Probe::Probe;
  void on_reading(const locsim_reading& r) override {
    if (r.t_s >= 1.0) std::raise(SIGSEGV);  // as a wild pointer would
  }
};
#elif defined(LOCSIM_TEST_EXITS)
class Plugin final : public Probe {
 public:
  using Probe::Probe;
  void on_reading(const locsim_reading& r) override {
    if (r.t_s >= 1.0) std::exit(0);  // as a library that "handles" an error by exiting would
  }
};
#elif defined(LOCSIM_TEST_ABORTS)
class Plugin final : public Probe {
 public:
  using Probe::Probe;
  void on_reading(const locsim_reading& r) override {
    if (r.t_s >= 1.0) std::abort();  // as a failed assert() would
  }
};
#elif defined(LOCSIM_TEST_HANG)
class Plugin final : public Probe {
 public:
  using Probe::Probe;
  void on_reading(const locsim_reading& r) override {
    while (r.t_s >= 1.0) std::this_thread::sleep_for(std::chrono::seconds(1));  // never returns
  }
};
#elif defined(LOCSIM_TEST_SLOW)
/// Healthy but slow: every reading takes 20 ms, so records queue up and it is nearly always in a
/// call, a new one as soon as the last returns.
class Plugin final : public Probe {
 public:
  using Probe::Probe;
  void on_reading(const locsim_reading&) override {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
};
#elif defined(LOCSIM_TEST_SLAM_MAP)
/// A fake SLAM filter whose landmark map is the known map's first `count` landmarks shifted by
/// (`offset_x`, `offset_y`), the one at index `skip` left out, optionally one far from every
/// landmark (`spurious`); ids 100 + index (999 for the spurious one), covariance
/// [[0.01, 0.002], [0.002, 0.02]]. `fail`: "none", "throw" or "nan" (from landmark_map). Its
/// diagnostics say what map it was given.
class Plugin final : public Probe {
 public:
  explicit Plugin(const locsim_init& init)
      : Probe(init),
        map_count_(static_cast<double>(init.map->landmark_count)),
        map_null_(init.map->landmarks == nullptr ? 1.0 : 0.0) {
    const locsim::sdk::Params params(init);
    const double dx = params.number("offset_x"), dy = params.number("offset_y");
    const auto count = static_cast<std::size_t>(params.integer("count"));
    const long long skip = params.integer("skip");
    fail_ = params.string("fail");
    for (std::size_t i = 0; i < std::min(count, init.map->landmark_count); ++i) {
      if (static_cast<long long>(i) == skip) continue;
      const locsim_landmark& l = init.map->landmarks[i];
      map_.push_back(
          {100 + static_cast<std::int32_t>(i), l.x + dx, l.y + dy, {0.01, 0.002, 0.002, 0.02}});
    }
    if (params.flag("spurious") && init.map->landmark_count > 0) {
      const locsim_landmark& l = init.map->landmarks[0];
      map_.push_back({999, l.x + 10.0, l.y + 10.0, {0.01, 0.0, 0.0, 0.01}});
    }
  }
  void landmark_map(std::vector<locsim_mapped_landmark>& landmarks) const override {
    if (fail_ == "throw") throw std::runtime_error("deliberate landmark map failure");
    landmarks = map_;
    if (fail_ == "nan" && !landmarks.empty())
      landmarks.back().y = std::numeric_limits<double>::quiet_NaN();
  }
  std::vector<std::pair<std::string, double>> diagnostics() const override {
    return {{"map_landmarks", map_count_}, {"map_landmarks_null", map_null_}};
  }

 private:
  double map_count_, map_null_;
  std::string fail_;
  std::vector<locsim_mapped_landmark> map_;
};
#elif defined(LOCSIM_TEST_CHATTY)
/// Prints as a plugin being debugged does, on stdout and stderr: a line per reading, and at one
/// second a flood of 3 MiB, then one more line (what the cap keeps last).
class Plugin final : public Probe {
 public:
  using Probe::Probe;
  void on_reading(const locsim_reading& r) override {
    std::printf("reading %ld at t = %.3f\n", readings_, r.t_s);
    if (readings_ % 10 == 1) std::fprintf(stderr, "stderr: reading %ld\n", readings_);
    if (r.t_s >= 1.0 && !flooded_) {
      flooded_ = true;
      const std::string line(1023, 'x');
      for (int i = 0; i < 3 * 1024; ++i) std::printf("%s\n", line.c_str());
      std::printf("after the flood\n");
    }
  }

 private:
  bool flooded_ = false;
};
#elif defined(LOCSIM_TEST_ABI1)
// A plugin built for ABI version 1: it reads the readings through version 1's structs, written
// out here as that SDK declared them (no odometry fields or velocity, no detection target), and
// dead-reckons from the ticks as a version-1 filter did. Its estimate is that dead reckoning;
// its diagnostics say what it was given last.
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
  size_t count;
};
struct ReadingV1 {
  std::uint32_t struct_size;
  std::int32_t kind;
  double t_s;
  union {
    OdometryV1 odometry;
    LandmarksV1 landmarks;
  } data;
};

class Plugin final : public Probe {
 public:
  explicit Plugin(const locsim_init& init)
      : Probe(init),
        wheel_base_m_(init.robot->wheel_base_m),
        x_(init.initial_pose.x, init.initial_pose.y, init.initial_pose.theta) {}
  void on_reading(const locsim_reading& given) override {
    ReadingV1 r;  // the bytes as a version-1 plugin reads them
    std::memcpy(&r, &given, sizeof(r));
    struct_size_ = r.struct_size;
    if (r.kind == LOCSIM_READING_ODOMETRY) {
      const OdometryV1& o = r.data.odometry;
      if (odometry_readings_++ > 0) {
        x_ = locsim::sdk::diff_drive_motion(
            x_, static_cast<double>(o.left_ticks - left_) * o.meters_per_tick,
            static_cast<double>(o.right_ticks - right_) * o.meters_per_tick, wheel_base_m_);
      }
      left_ = o.left_ticks;
      right_ = o.right_ticks;
      meters_per_tick_ = o.meters_per_tick;
      odom_ = o.odom_pose;
    } else if (r.kind == LOCSIM_READING_LANDMARKS) {
      const LandmarksV1& l = r.data.landmarks;
      camera_ = l.camera;
      detections_ = static_cast<double>(l.count);
      ids_ = ranges_ = 0.0;
      for (size_t i = 0; i < l.count; ++i) {
        ids_ += l.detections[i].id;
        ranges_ += l.detections[i].range_m;
      }
    }
  }
  locsim::sdk::Estimate estimate() const override {
    return {{x_(0), x_(1), x_(2)}, Eigen::Matrix3d::Identity()};
  }
  std::vector<std::pair<std::string, double>> diagnostics() const override {
    return {{"struct_size", struct_size_},
            {"left_ticks", static_cast<double>(left_)},
            {"right_ticks", static_cast<double>(right_)},
            {"meters_per_tick", meters_per_tick_},
            {"odom_x", odom_.x},
            {"odom_y", odom_.y},
            {"odom_theta", odom_.theta},
            {"camera", camera_},
            {"detections", detections_},
            {"detection_ids", ids_},
            {"detection_ranges", ranges_}};
  }

 private:
  double wheel_base_m_;
  locsim::sdk::Pose x_;
  long odometry_readings_ = 0;
  std::int64_t left_ = 0, right_ = 0;
  double meters_per_tick_ = 0.0, struct_size_ = 0.0, camera_ = -1.0, detections_ = 0.0, ids_ = 0.0,
         ranges_ = 0.0;
  locsim_pose2 odom_{};
};
#elif defined(LOCSIM_TEST_ESCAPES)
/// At its first reading at or after `at_s` (one second), does what `how` says, each a way for a
/// plugin's processes to outlive locsim or to break its protocol, and writes the pid of the process
/// that must not outlive the run to `pid_file`:
/// - fork_returns: forks, and the child returns from the call into locsim's worker as a copy of it
/// - keep_child: forks a child that ignores SIGTERM and sleeps for good
/// - daemon: a daemon: double fork and setsid, ignoring SIGTERM, sleeping for good
/// - flood: forks a child that ignores SIGTERM and SIGPIPE and writes to stderr without pause
/// - hang_with_child, crash_with_child: keep_child, then the call hangs, or segfaults
/// - garbage: writes bytes that are not locsim's protocol onto the socket it finds among its
///   descriptors (as a plugin that writes to a stale descriptor would), then goes on
/// - hog: allocates (and touches) 16 MiB after 16 MiB without end; only under a data limit
///   (--plugin-memory), else it throws at once rather than take the machine's memory
/// - sigkill: SIGKILL to itself, as the system's out-of-memory killer would send
/// - none: nothing
class Plugin final : public Probe {
 public:
  explicit Plugin(const locsim_init& init)
      : Probe(init),
        how_(locsim::sdk::Params(init).string("how")),
        pid_file_(locsim::sdk::Params(init).string("pid_file")),
        at_s_(locsim::sdk::Params(init).number("at_s")) {}
  void on_reading(const locsim_reading& r) override {
    if (r.t_s < at_s_ || done_) return;
    done_ = true;
    // Each pid is written by a process the plugin's call waits for (not by the child itself,
    // which the run may end before it writes): the file is there when the call returns.
    if (how_ == "fork_returns") {
      if (const pid_t child = ::fork(); child > 0) write_pid(child);  // the child returns too
    } else if (how_ == "keep_child" || how_ == "hang_with_child" || how_ == "crash_with_child") {
      const pid_t child = ::fork();
      if (child == 0) sleep_for_good();
      write_pid(child);
      if (how_ == "hang_with_child") {
        while (true) std::this_thread::sleep_for(std::chrono::seconds(1));
      }
      if (how_ == "crash_with_child") std::raise(SIGSEGV);
    } else if (how_ == "daemon") {
      const pid_t middle = ::fork();
      if (middle == 0) {
        ::setsid();
        const pid_t daemon = ::fork();
        if (daemon == 0) sleep_for_good();
        write_pid(daemon);
        _exit(0);
      }
      ::waitpid(middle, nullptr, 0);
    } else if (how_ == "flood") {
      const pid_t child = ::fork();
      if (child > 0) write_pid(child);
      if (child == 0) {
        std::signal(SIGTERM, SIG_IGN);
        std::signal(SIGPIPE, SIG_IGN);
        const std::string line = std::string(200, 'f') + "\n";
        while (true) {
          if (::write(STDERR_FILENO, line.data(), line.size()) < 0) ::usleep(100);
        }
      }
    } else if (how_ == "garbage") {
      static constexpr char kGarbage[] = "this is not locsim's protocol\n";
      for (int fd = 3; fd < 4096; ++fd) {
        struct stat info {};
        if (::fstat(fd, &info) == 0 && S_ISSOCK(info.st_mode)) {
          if (::write(fd, kGarbage, sizeof(kGarbage) - 1) < 0) std::perror("write");
        }
      }
    } else if (how_ == "hog") {
      rlimit data{};
      ::getrlimit(RLIMIT_DATA, &data);
      if (data.rlim_cur == RLIM_INFINITY) throw std::runtime_error("hog needs --plugin-memory");
      while (true) {
        hoard_.push_back(std::make_unique<char[]>(16 << 20));
        std::memset(hoard_.back().get(), 1, 16 << 20);
      }
    } else if (how_ == "sigkill") {
      std::raise(SIGKILL);
    }
  }

 private:
  void write_pid(pid_t pid) const {
    if (pid_file_.empty() || pid <= 0) return;
    const std::string text = std::to_string(pid) + "\n";
    const int fd = ::open(pid_file_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd >= 0) {
      if (::write(fd, text.data(), text.size()) < 0) std::perror("write");
      ::close(fd);
    }
  }
  [[noreturn]] static void sleep_for_good() {
    std::signal(SIGTERM, SIG_IGN);
    while (true) ::pause();
  }
  std::string how_, pid_file_;
  double at_s_;
  bool done_ = false;
  std::vector<std::unique_ptr<char[]>> hoard_;
};
#elif defined(LOCSIM_TEST_NOOP)
/// Does nothing at all: what is measured is the host.
class Plugin final : public locsim::sdk::Localizer {
 public:
  explicit Plugin(const locsim_init&) {}
  void update(const locsim_reading&) override {}
  locsim::sdk::Estimate estimate() const override { return {}; }
};
#else
using Plugin = Probe;
#endif

#if defined(LOCSIM_TEST_SLAM_MAP)
constexpr locsim_param_decl kParams[] = {
    {"offset_x", LOCSIM_PARAM_DOUBLE, 0.3, -10.0, 10.0, nullptr, "shift of every landmark [m]"},
    {"offset_y", LOCSIM_PARAM_DOUBLE, 0.4, -10.0, 10.0, nullptr, "shift of every landmark [m]"},
    {"count", LOCSIM_PARAM_INT, 1000, 0, 1000, nullptr, "map's landmarks considered [-]"},
    {"skip", LOCSIM_PARAM_INT, -1, -1, 1000, nullptr, "index left out (-1: none) [-]"},
    {"spurious", LOCSIM_PARAM_BOOL, 0, 0, 1, nullptr, "add one landmark 14 m from the first"},
    {"fail", LOCSIM_PARAM_STRING, 0, 0, 0, "none", "none, throw or nan"},
};
#elif defined(LOCSIM_TEST_ESCAPES)
constexpr locsim_param_decl kParams[] = {
    {"how", LOCSIM_PARAM_STRING, 0, 0, 0, "none", "what to do at one second (see the class)"},
    {"pid_file", LOCSIM_PARAM_STRING, 0, 0, 0, "", "where to write the pid that must not outlive"},
    {"at_s", LOCSIM_PARAM_DOUBLE, 1.0, 0.0, 1e6, nullptr, "when to do it [s]"},
};
#else
constexpr locsim_param_decl kParams[] = {
    {"gain", LOCSIM_PARAM_DOUBLE, 0.5, 0.0, 1.0, nullptr, "unused [-]"},
    {"count", LOCSIM_PARAM_INT, 10, 1, 100, nullptr, "unused [-]"},
    {"verbose", LOCSIM_PARAM_BOOL, 0, 0, 1, nullptr, "unused"},
    {"mode", LOCSIM_PARAM_STRING, 0, 0, 0, "fast", "unused"},
};
#endif

}  // namespace

#if defined(LOCSIM_TEST_BAD_ABI) || defined(LOCSIM_TEST_BAD_SIZE) || defined(LOCSIM_TEST_ABI1)
// A table from another SDK: the host must refuse it with both versions / sizes, or (ABI1) serve
// it with the structs of its version (its table is version 2's: without `readings`).
extern "C" LOCSIM_EXPORT const locsim_localizer* locsim_localizer_entry(uint32_t) {
  static locsim_localizer table =
      locsim::sdk::detail::make_table<Plugin>(LOCSIM_TEST_NAME, "bad", kParams, 4);
#if defined(LOCSIM_TEST_BAD_ABI)
  table.abi_version = 99;
#elif defined(LOCSIM_TEST_ABI1)
  table.abi_version = 1;
  table.struct_size = offsetof(locsim_localizer, readings);  // version 1's table ends there
#else
  table.struct_size = 24;
#endif
  return &table;
}
#elif defined(LOCSIM_TEST_NO_ENTRY)
extern "C" LOCSIM_EXPORT int locsim_something_else() {
  return 42;
}
#else
#if defined(LOCSIM_TEST_UNRESOLVED)
// An exported pointer to a function defined nowhere: its relocation must be resolved at load time.
extern "C" void locsim_function_nobody_defines();
extern "C" {
LOCSIM_EXPORT void (*locsim_unresolved_reference)() = &locsim_function_nobody_defines;
}
#endif
LOCSIM_LOCALIZER(Plugin, LOCSIM_TEST_NAME, "a test plugin", kParams)
#endif
