// What several locsim subcommands share (common.hpp).
#include "common.hpp"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <system_error>
#include <tuple>
#include <utility>

#include "render/loader.hpp"
#include "sim/common/errors.hpp"

// This file's own helpers: named, not anonymous, because a unity build puts the CLI's files into
// one translation unit.
namespace locsim::cli::common_impl {

std::atomic<bool> interrupted{false};

std::atomic<std::int64_t> first_sigint_ns{0};

std::int64_t monotonic_ns() {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);  // async-signal-safe
  return static_cast<std::int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

/// Ctrl-C asks the run to end cleanly (run.json says "interrupted"). Another Ctrl-C at least a
/// second later ends locsim at once, e.g. when a plugin running inside locsim (--isolation none)
/// hangs; one sooner is the same request again (tools like timeout(1) signal the process and its
/// group, which delivers two at once). C linkage, as sigaction expects; static, as it is this
/// file's alone.
extern "C" {
static void on_sigint(int) {
  const std::int64_t now = monotonic_ns();
  std::int64_t first = 0;
  if (first_sigint_ns.compare_exchange_strong(first, now)) {
    interrupted.store(true);
  } else if (now - first > 1'000'000'000) {
    std::signal(SIGINT, SIG_DFL);
    std::raise(SIGINT);
  }
}
}

/// A bound as a user reads it: "1e+06", "180", "0.001" (CLI11's own ranges print
/// std::to_string of their bounds, 309 digits for the largest double).
std::string short_number(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", value);
  return text;
}

/// --plugin-memory: a size in bytes, or with a binary unit K, M, G or T (also KiB, MiB, ...):
/// "512M" is 512 MiB. A transform: the option then reads the bytes in decimal.
CLI::Validator memory_size() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        std::uint64_t number = 0;
        const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), number);
        std::string unit = text.substr(static_cast<std::size_t>(end - text.data()));
        if (unit.size() == 3 && unit.substr(1) == "iB") unit.resize(1);
        static constexpr std::string_view kUnits = "KMGT";
        const std::size_t power = unit.empty() ? 0 : kUnits.find(unit) + 1;
        if (end == text.data() || error != std::errc() || unit.size() > 1 ||
            (!unit.empty() && power == 0)) {
          return "'" + text + "' is not a size (bytes, or with K, M, G or T: 512M)";
        }
        const int shift = static_cast<int>(10 * power);
        if (power > 0 && number > (std::numeric_limits<std::uint64_t>::max() >> shift))
          return "'" + text + "' is too large";
        text = std::to_string(number << shift);
        return {};
      },
      "SIZE");
}

/// --video-size: WxH, each even (encoders want 4:2:0 chroma) and in [kMinFramePx, kMaxFramePx].
constexpr int kMinFramePx = 64, kMaxFramePx = 8192;
std::optional<std::pair<int, int>> parse_frame_size(const std::string& text) {
  int width = 0, height = 0;
  char tail = 0;
  if (std::sscanf(text.c_str(), "%dx%d%c", &width, &height, &tail) != 2) return std::nullopt;
  return std::pair{width, height};
}
const CLI::Validator kFrameSize(
    [](std::string& text) -> std::string {
      const auto size = parse_frame_size(text);
      if (!size) return "'" + text + "' is not WxH, e.g. 1280x720";
      for (const int px : {size->first, size->second}) {
        if (px < kMinFramePx || px > kMaxFramePx || px % 2 != 0) {
          return "'" + text + "': width and height must be even and in [" +
                 std::to_string(kMinFramePx) + ", " + std::to_string(kMaxFramePx) + "]";
        }
      }
      return {};
    },
    "WxH");

/// The renderer, loaded on first use (it brings OpenGL, OpenCV and FFmpeg along): for --video and
/// --frames, and for PTZ cameras in mode: rendered.
std::shared_ptr<render::RenderModule> renderer() {
  static std::shared_ptr<render::RenderModule> module;
  if (!module) module = render::RenderModule::load();
  return module;
}

}  // namespace locsim::cli::common_impl

namespace locsim::cli {

CLI::Validator number_in(double lo, double hi, bool lo_open) {
  const bool unbounded = hi == std::numeric_limits<double>::max();
  const std::string range = unbounded ? (lo_open ? "> " : ">= ") + common_impl::short_number(lo)
                                      : "in " + std::string(lo_open ? "(" : "[") +
                                            common_impl::short_number(lo) + ", " +
                                            common_impl::short_number(hi) + "]";
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        char* end = nullptr;
        const double value = std::strtod(text.c_str(), &end);
        if (text.empty() || end != text.c_str() + text.size())
          return "'" + text + "' is not a number";
        if (!std::isfinite(value)) return "must be a finite number " + range + ", got " + text;
        if (value < lo || (lo_open && value == lo) || value > hi) {
          return "must be " + range + ", got " + text;
        }
        return {};
      },
      range);
}

CLI::Validator number_above(double lo, double hi) {
  return number_in(lo, hi, true);
}

CLI::Validator whole_number_in(std::int64_t lo, std::uint64_t hi) {
  const std::string range = "in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        const bool negative = text.starts_with('-');
        const std::string digits = negative ? text.substr(1) : text;
        std::uint64_t magnitude = 0;
        const auto [end, error] =
            std::from_chars(digits.data(), digits.data() + digits.size(), magnitude);
        if (digits.empty() || end != digits.data() + digits.size() ||
            (error != std::errc() && error != std::errc::result_out_of_range)) {
          return "'" + text + "' is not a whole number";
        }
        // Compared as magnitudes: lo is at most 0 or a small positive number here.
        const bool below =
            negative ? (magnitude > 0 && (lo >= 0 || magnitude > static_cast<std::uint64_t>(-lo)))
                     : (lo > 0 && magnitude < static_cast<std::uint64_t>(lo));
        if (error == std::errc::result_out_of_range || below || (!negative && magnitude > hi)) {
          return "must be a whole number " + range + ", got " + text;
        }
        // Decimal from here on: CLI11 would read a leading zero as octal.
        text = (negative && magnitude > 0 ? "-" : "") + std::to_string(magnitude);
        return {};
      },
      range);
}

const std::atomic<bool>* catch_sigint() {
  struct sigaction action {};
  action.sa_handler = common_impl::on_sigint;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  return &common_impl::interrupted;
}

LandmarkImagerFactory imager_factory(const std::string& gl_backend) {
  return [gl_backend](const WorldDef& world, const PtzCameraDef& camera) {
    return common_impl::renderer()->make_imager(world, camera, gl_backend);
  };
}

void add_video_options(CLI::App* command, VideoCli& cli, VideoOptions& video) {
  command
      ->add_option("--video", cli.video_file,
                   "Render offscreen into a video (.mp4: H.264, else MPEG-4; .avi, .mkv)")
      ->group("Video");
  command
      ->add_option("--frames", cli.frames_dir, "Also write every frame as a PNG into this folder")
      ->group("Video");
  command->add_option("--video-size", cli.size, "Frame size WxH [px] (default 1280x720)")
      ->check(common_impl::kFrameSize)
      ->group("Video");
  command->add_option("--video-fps", video.fps, "Video frames per second (default 30)")
      ->check(number_above(0.0, 1000.0))
      ->group("Video");
  command
      ->add_option("--video-speed", video.speed,
                   "Seconds of the run (or of the log) per second of video (default 1: real time)")
      ->check(number_above(0.0, 1e6))
      ->group("Video");
  command->add_flag("!--no-particles", video.particles, "Do not draw the particle clouds")
      ->group("Video");
  command
      ->add_flag("!--no-camera-view", video.camera_view,
                 "Do not show the PTZ camera's own view in the video's side panel")
      ->group("Video");
  command->add_option("--gl-backend", video.backend, "Offscreen GL: osmesa (software; the default)")
      ->group("Video");
}

std::shared_ptr<FrameSink> video_recorder(const VideoCli& cli, VideoOptions& video) {
  if (cli.video_file.empty() && cli.frames_dir.empty()) return nullptr;
  std::tie(video.width_px, video.height_px) = *common_impl::parse_frame_size(cli.size);  // checked
  if (!cli.video_file.empty()) video.video_file = cli.video_file;
  if (!cli.frames_dir.empty()) video.frames_dir = cli.frames_dir;
  return common_impl::renderer()->make_recorder(video);
}

void print_video_summary(const FrameSink& recorder, const VideoOptions& video) {
  std::printf("video: %ld frames of %dx%d at %.0f fps%s%s\n", recorder.frames(), video.width_px,
              video.height_px, video.fps,
              video.video_file ? (" -> " + video.video_file->string()).c_str() : "",
              video.frames_dir ? (", PNGs in " + video.frames_dir->string()).c_str() : "");
}

void SessionCli::apply(SessionOptions& session) const {
  session.convergence.heading_rad = deg_to_rad(converged_deg);
  session.isolate = isolation == "process";
}

void add_session_options(CLI::App* command, SessionCli& cli, SessionOptions& session) {
  command->add_option(
      "--localizer", session.localizers,
      "Localizer plugin to run on every robot, NAME[:key=value,...][@label], or one written "
      "in Python, python:FILE.py[:key=value,...][@label] (docs/python.md); repeat for several "
      "(all get the same readings)");
  command->add_option(
      "--params", session.params_file,
      "Parameter file (YAML, e.g. `locsim calibrate`'s): its localizer_params give every "
      "localizer the values of the parameters it declares (a map under a plugin's name: that "
      "plugin's only, first); a --localizer key=value wins over the file");
  command
      ->add_option("--isolation", cli.isolation,
                   "process: each localizer in its own process, so that a crash or hang fails "
                   "it alone (default); none: in locsim's process (for a debugger)")
      ->check(CLI::IsMember({"process", "none"}))
      ->capture_default_str();
  command
      ->add_option("--plugin-timeout", session.plugin_timeout_s,
                   "Longest a single plugin call may take before its localizer is failed "
                   "[s]; 0: no limit (needs --isolation process)")
      ->check(number_in(0.0, 1e6))
      ->capture_default_str();
  command
      ->add_option("--plugin-memory", session.plugin_memory_bytes,
                   "Memory each localizer's process may allocate beyond what it starts with, "
                   "bytes or with K, M, G (512M); past it the plugin's allocations fail and the "
                   "localizer fails saying so; 0: no limit (needs --isolation process)")
      ->transform(common_impl::memory_size())
      ->capture_default_str();
  command->add_flag("!--no-readings", session.readings,
                    "Do not write readings/ (one CSV per sensor)");
  CLI::Option* const bag =
      command->add_option("--rosbag2", session.rosbag2,
                          "Also write the run as a ROS 2 bag folder (MCAP): the topics of "
                          "`locsim export`, and each localizer's estimates "
                          "(/localizers/LABEL/pose) and particles (/localizers/LABEL/particles); "
                          "must not exist (--overwrite replaces a bag folder); docs/ros.md");
  command
      ->add_option("--rosbag2-particles-hz", session.rosbag2_particles_hz,
                   "With --rosbag2: how often the particles are written, per simulated second; "
                   "0: never")
      ->check(number_in(0.0, 1000.0))
      ->needs(bag)
      ->capture_default_str();
  command->add_flag("--overwrite", session.overwrite,
                    "Empty the --out folder first if it holds a run (run.json: completed, "
                    "failed or killed; not one still going on); any other non-empty folder "
                    "is refused");
  command
      ->add_option("--converged-within-m", session.convergence.position_m,
                   "Convergence: position error at most this [m]")
      ->check(number_above(0.0))
      ->capture_default_str();
  command
      ->add_option("--converged-within-deg", cli.converged_deg,
                   "Convergence: heading error at most this [deg]")
      ->check(number_above(0.0, 180.0))
      ->capture_default_str();
  command
      ->add_option("--converged-hold", session.convergence.hold_samples,
                   "Convergence: for this many consecutive ground-truth samples")
      ->transform(whole_number_in(1, 1000000))
      ->capture_default_str();
}

int exit_code(const std::string& status, const std::vector<std::string>& failed_localizers) {
  if (status == "interrupted") return kExitInterrupted;
  if (!failed_localizers.empty()) {
    std::string labels;
    for (const std::string& label : failed_localizers)
      labels += (labels.empty() ? "" : ", ") + label;
    std::fprintf(stderr, "locsim: completed; localizer%s failed: %s (see metrics.json)\n",
                 failed_localizers.size() == 1 ? "" : "s", labels.c_str());
    return kExitLocalizerFailed;
  }
  return kExitOk;
}

std::vector<std::string> comma_names(const std::string& list, const std::string& option) {
  std::vector<std::string> names;
  std::istringstream items(list);
  std::string item;
  while (std::getline(items, item, ',')) {
    if (item.empty()) throw InputError(option + ": an empty name in '" + list + "'");
    names.push_back(item);
  }
  if (names.empty()) throw InputError(option + ": no name given");
  return names;
}

std::vector<std::string> robot_names(const std::string& list) {
  if (list == "all") return {};
  return comma_names(list, "--robots");
}

void exec_report(const std::vector<std::string>& arguments) {
  std::error_code error;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", error);
  const std::filesystem::path candidates[] = {
      exe.parent_path().parent_path() / "share/locsim/report.py",
      std::filesystem::path(LOCSIM_TOOLS_DIR) / "report.py"};
  for (const auto& script : candidates) {
    if (!std::filesystem::exists(script)) continue;
    const std::string python = "/usr/bin/python3";
    std::vector<std::string> args = {python, script.string()};
    args.insert(args.end(), arguments.begin(), arguments.end());
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    std::fflush(stdout);
    execv(python.c_str(), argv.data());
    throw std::runtime_error("cannot run " + python +
                             " (tools/setup installs it): " + std::strerror(errno));
  }
  throw std::runtime_error(
      "report.py not found next to this locsim (share/locsim) nor in the source tree");
}

}  // namespace locsim::cli
