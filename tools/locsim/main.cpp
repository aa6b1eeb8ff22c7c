// The locsim command line. Exit codes: 0 ok, 1 failure, 2 bad input, 130 interrupted.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <charconv>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <iostream>
#include <limits>
#include <optional>
#include <sstream>

#include "plugin_template.hpp"
#include "render/loader.hpp"
#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/experiments/sweep.hpp"
#include "sim/experiments/twin.hpp"
#include "sim/metrics/calibration.hpp"
#include "sim/plugin_host/localizer_instance.hpp"
#include "sim/plugin_host/plugin_library.hpp"
#include "sim/producers/generic_import.hpp"
#include "sim/producers/mrclam_import.hpp"
#include "sim/producers/simulation.hpp"
#include "sim/run/replay.hpp"
#include "sim/run/runner.hpp"
#include "sim/run/session.hpp"
#include "sim/world/generator.hpp"

namespace {

std::atomic<bool> g_interrupted{false};

std::atomic<std::int64_t> g_first_sigint_ns{0};

std::int64_t monotonic_ns() {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);  // async-signal-safe
  return static_cast<std::int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

/// Ctrl-C asks the run to end cleanly (run.json says "interrupted"). Another Ctrl-C at least a
/// second later ends locsim at once, e.g. when a plugin running inside locsim (--isolation none)
/// hangs; one sooner is the same request again (tools like timeout(1) signal the process and its
/// group, which delivers two at once).
extern "C" void on_sigint(int) {
  const std::int64_t now = monotonic_ns();
  std::int64_t first = 0;
  if (g_first_sigint_ns.compare_exchange_strong(first, now)) {
    g_interrupted.store(true);
  } else if (now - first > 1'000'000'000) {
    std::signal(SIGINT, SIG_DFL);
    std::raise(SIGINT);
  }
}

void catch_sigint() {
  struct sigaction action {};
  action.sa_handler = on_sigint;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
}

constexpr const char* kExitCodes = R"(Exit codes:
  0    success
  1    failure not caused by the input (I/O error, a full disk, too little free space for the
       run's estimated files, internal error); run.json says "failed" and why, cut files removed
  2    bad input: command line, world, scenario or map file (the message names file:line:col and key),
       or a localizer parameter the plugin does not declare or accept
  3    a localizer plugin not found, not a locsim plugin, of another ABI version, with unresolved
       symbols, or whose create call failed (the message says which and where it looked)
  4    --video/--frames: the renderer cannot be loaded, no GL context, or a video or frame file
       cannot be opened or written (frames written before stay; the video is closed and plays,
       unless its own writing failed: then it is removed)
  5    run or replay completed, but a localizer failed (crashed, hung past --plugin-timeout,
       ran out of --plugin-memory, broke locsim's protocol, returned an error or NaN): every
       other localizer's files and metrics are written, and
       metrics.json says which failed, in which call, at what simulated time and why
  130  interrupted (Ctrl-C); the run folder keeps what was written, run.json says "interrupted";
       another Ctrl-C a second or more later ends locsim at once)";

/// A bound as a user reads it: "1e+06", "180", "0.001" (CLI11's own ranges print
/// std::to_string of their bounds, 309 digits for the largest double).
std::string short_number(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", value);
  return text;
}

/// A finite number in [lo, hi] (lo excluded when `lo_open`). CLI11's range checks compare, and
/// every comparison with NaN is false: NaN and the infinities are refused first.
CLI::Validator number_in(double lo, double hi, bool lo_open = false) {
  const bool unbounded = hi == std::numeric_limits<double>::max();
  const std::string range = unbounded ? (lo_open ? "> " : ">= ") + short_number(lo)
                                      : "in " + std::string(lo_open ? "(" : "[") +
                                            short_number(lo) + ", " + short_number(hi) + "]";
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

/// A finite number > lo (and at most hi).
CLI::Validator number_above(double lo, double hi = std::numeric_limits<double>::max()) {
  return number_in(lo, hi, true);
}

/// A whole number in [lo, hi], in decimal digits. CLI11 alone reads "-1" into an unsigned option
/// as 2^64 - 1, a number too large as the largest one, and "010" as octal 8. A transform (a
/// check's changes are dropped): the option then reads the number in decimal.
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
std::shared_ptr<locsim::render::RenderModule> renderer() {
  static std::shared_ptr<locsim::render::RenderModule> module;
  if (!module) module = locsim::render::RenderModule::load();
  return module;
}

locsim::LandmarkImagerFactory imager_factory(const std::string& gl_backend) {
  return [gl_backend](const locsim::WorldDef& world, const locsim::PtzCameraDef& camera) {
    return renderer()->make_imager(world, camera, gl_backend);
  };
}

/// The video options, as `run` and `replay` both take them: the files as given, the rest parsed
/// into `video`.
struct VideoCli {
  std::string video_file, frames_dir, size = "1280x720";
};
void add_video_options(CLI::App* command, VideoCli& cli, locsim::VideoOptions& video) {
  command
      ->add_option("--video", cli.video_file,
                   "Render offscreen into a video (.mp4: H.264, else MPEG-4; .avi, .mkv)")
      ->group("Video");
  command
      ->add_option("--frames", cli.frames_dir, "Also write every frame as a PNG into this folder")
      ->group("Video");
  command->add_option("--video-size", cli.size, "Frame size WxH [px] (default 1280x720)")
      ->check(kFrameSize)
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

/// The renderer's recorder for --video/--frames (null when neither is given); completes `video`.
std::shared_ptr<locsim::FrameSink> video_recorder(const VideoCli& cli,
                                                  locsim::VideoOptions& video) {
  if (cli.video_file.empty() && cli.frames_dir.empty()) return nullptr;
  std::tie(video.width_px, video.height_px) = *parse_frame_size(cli.size);  // checked
  if (!cli.video_file.empty()) video.video_file = cli.video_file;
  if (!cli.frames_dir.empty()) video.frames_dir = cli.frames_dir;
  return renderer()->make_recorder(video);
}

void print_video_summary(const locsim::FrameSink& recorder, const locsim::VideoOptions& video) {
  std::printf("video: %ld frames of %dx%d at %.0f fps%s%s\n", recorder.frames(), video.width_px,
              video.height_px, video.fps,
              video.video_file ? (" -> " + video.video_file->string()).c_str() : "",
              video.frames_dir ? (", PNGs in " + video.frames_dir->string()).c_str() : "");
}

int validate(const std::string& world, const std::optional<std::string>& scenario) {
  const locsim::RunInputs inputs = locsim::load_run_inputs(
      world, scenario ? std::optional<std::filesystem::path>(*scenario) : std::nullopt,
      std::nullopt);
  // Building the world checks what only the physics can: robots starting in collision.
  const locsim::Simulation sim(inputs.world, inputs.scenario, 1, imager_factory("osmesa"));
  std::printf(
      "%s: ok (%zu robot%s, %d static fixtures, %zu movers, %zu landmarks, %zu beacons, "
      "scenario '%s' %.1f s, %zu events)\n",
      world.c_str(), sim.robot_count(), sim.robot_count() == 1 ? "" : "s",
      sim.world().static_fixture_count(), inputs.world.movers.size(), inputs.world.landmarks.size(),
      inputs.world.beacons.size(), inputs.scenario.name.c_str(), inputs.scenario.duration_s,
      inputs.scenario.events.size());
  return locsim::kExitOk;
}

const char* type_name(int type) {
  switch (type) {
    case LOCSIM_PARAM_DOUBLE:
      return "double";
    case LOCSIM_PARAM_INT:
      return "int";
    case LOCSIM_PARAM_BOOL:
      return "bool";
    case LOCSIM_PARAM_STRING:
      return "string";
  }
  return "?";
}

/// `locsim plugins`: every plugin found, loaded, with its parameters; failures reported each.
int list_plugins() {
  std::printf(
      "Search path (LOCSIM_PLUGIN_PATH, then the build's and the install's plugin folders):\n");
  for (const auto& folder : locsim::plugin_search_path()) std::printf("  %s\n", folder.c_str());
  const auto files = locsim::list_plugin_files();
  if (files.empty()) std::printf("\nNo plugins found.\n");
  int failures = 0;
  const auto show = [&](const std::filesystem::path& file, const std::filesystem::path& source,
                        const std::string& prefix) {
    try {
      const locsim::PluginLibrary library(file, source);
      const locsim_localizer& t = library.table();
      std::printf("\n%s%s  %s\n  %s\n", prefix.c_str(), t.name, t.description,
                  (source.empty() ? file : source).c_str());
      for (std::size_t i = 0; i < t.param_count; ++i) {
        const locsim_param_decl& p = t.params[i];
        std::printf("    %-20s %-6s ", p.name, type_name(p.type));
        if (p.type == LOCSIM_PARAM_STRING) {
          std::printf("default '%s'", p.default_string != nullptr ? p.default_string : "");
        } else if (p.type == LOCSIM_PARAM_BOOL) {
          std::printf("default %s", p.default_number != 0.0 ? "true" : "false");
        } else {
          std::printf("default %g in [%g, %g]", p.default_number, p.min_number, p.max_number);
        }
        std::printf("  %s\n", p.doc != nullptr ? p.doc : "");
      }
    } catch (const locsim::PluginError& e) {
      ++failures;
      std::printf("\n(failed) %s\n  %s\n", (source.empty() ? file : source).c_str(), e.what());
    }
  };
  std::optional<std::filesystem::path> python;
  for (const auto& file : files) {
    show(file, {}, "");
    if (file.filename() == "locsim_python.so") python = file;
  }
  // The scripts the python plugin runs by name (`--localizer python:NAME`).
  if (python) {
    for (const auto& script : locsim::list_source_files()) show(*python, script, "python:");
  }
  return failures > 0 ? locsim::kExitPlugin : locsim::kExitOk;
}

/// `locsim new-plugin NAME DIR`: a buildable out-of-tree skeleton.
int new_plugin(const std::string& name, const std::filesystem::path& dir) {
  const bool valid = !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
  }) && !(name[0] >= '0' && name[0] <= '9');
  // A C identifier, and short enough for the file name (255 bytes) with room to spare.
  if (!valid || name.size() > 64) {
    throw locsim::InputError("new-plugin: name " + locsim::quote_input(name) +
                             " must be [a-z_][a-z0-9_]*, at most 64 characters");
  }
  if (std::filesystem::exists(dir) && !std::filesystem::is_empty(dir)) {
    throw locsim::InputError("new-plugin: folder '" + dir.string() + "' exists and is not empty");
  }
  const auto fill = [&](std::string text) {
    for (std::size_t at = text.find("{{name}}"); at != std::string::npos;
         at = text.find("{{name}}", at)) {
      text.replace(at, 8, name);
    }
    return text;
  };
  const std::filesystem::path made = locsim::make_output_folder(dir, "new-plugin");
  const std::string cmake = fill(locsim::cli::kTemplateCMakeLists),
                    source = fill(locsim::cli::kTemplateSource);
  try {
    locsim::write_files({{dir / "CMakeLists.txt", cmake}, {dir / (name + ".cpp"), source}});
  } catch (...) {
    std::error_code ignored;
    if (!made.empty()) std::filesystem::remove_all(made, ignored);
    throw;
  }
  std::printf(
      "wrote %s/CMakeLists.txt and %s/%s.cpp\nbuild: cmake -S %s -B %s/build "
      "-DCMAKE_PREFIX_PATH=<locsim prefix> && cmake --build %s/build\n",
      dir.c_str(), dir.c_str(), name.c_str(), dir.c_str(), dir.c_str(), dir.c_str());
  return locsim::kExitOk;
}

/// A finished run's exit code: interrupted, a localizer failed, or all well.
int exit_code(const std::string& status, const std::vector<std::string>& failed_localizers) {
  if (status == "interrupted") return locsim::kExitInterrupted;
  if (!failed_localizers.empty()) {
    std::string labels;
    for (const std::string& label : failed_localizers)
      labels += (labels.empty() ? "" : ", ") + label;
    std::fprintf(stderr, "locsim: completed; localizer%s failed: %s (see metrics.json)\n",
                 failed_localizers.size() == 1 ? "" : "s", labels.c_str());
    return locsim::kExitLocalizerFailed;
  }
  return locsim::kExitOk;
}

double rad_to_deg_default() {
  return locsim::rad_to_deg(locsim::ConvergenceCriterion{}.heading_rad);
}

/// `--robots a,b` of calibrate and twin: the names; empty for "all".
std::vector<std::string> robot_names(const std::string& list) {
  std::vector<std::string> names;
  if (list == "all") return names;
  std::istringstream items(list);
  std::string item;
  while (std::getline(items, item, ',')) {
    if (item.empty()) throw locsim::InputError("--robots: an empty name in '" + list + "'");
    names.push_back(item);
  }
  if (names.empty()) throw locsim::InputError("--robots: no robot given");
  return names;
}

/// `locsim report DIR` and `locsim compare`: tools/report.py (installed to share/locsim) with
/// `arguments`, run with Debian's Python (it has matplotlib; a virtualenv's python3 may not).
int report(const std::vector<std::string>& arguments) {
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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"locsim: a simulator for mobile-robot localization research"};
  app.footer(kExitCodes);
  app.set_version_flag("--version", locsim::locsim_version());
  app.require_subcommand(1);

  locsim::RunOptions options;
  std::string world_file;
  std::optional<std::string> scenario_file;
  std::string out_dir;
  bool quiet = false;
  CLI::App* run = app.add_subcommand("run", "Simulate a world and write a run folder");
  run->add_option("world", world_file, "World file (YAML)")->required();
  run->add_option("--scenario", scenario_file,
                  "Scenario file (YAML); default: the world's own 'scenario:' section");
  run->add_option("--seed", options.seed, "Run seed; every random stream derives from it")
      ->transform(whole_number_in(0, std::numeric_limits<std::uint64_t>::max()))
      ->capture_default_str();
  // The scenario's own range for duration_s (one place for it: scenario_def.hpp).
  run->add_option("--duration", options.duration_s, "Simulated seconds (overrides the scenario)")
      ->check(number_in(locsim::ScenarioDef::kDurationRange.min,
                        locsim::ScenarioDef::kDurationRange.max));
  run->add_flag("--no-variation", options.no_variation,
                "Run the world as declared: no per-seed variation, whatever its `variation:` "
                "(docs/worlds.md#variation)");
  run->add_option("--out", out_dir, "Output folder (default: a new folder under runs/)");
  run->add_flag("--realtime", options.realtime, "Pace the simulation to the wall clock");
  run->add_option("--threads", options.threads,
                  "Threads for the sensors of different robots; the outputs are the same for "
                  "any count (0: one per core)")
      ->transform(whole_number_in(0, 256))
      ->capture_default_str();
  run->add_flag("-q,--quiet", quiet, "No progress line and no summary");
  std::string log_file;
  run->add_option("--log", log_file,
                  "Also record the sensor stream, ground truth and events into one log file, for "
                  "`locsim replay` (its folder is made when missing, as --out's is)");
  double max_output_gib = static_cast<double>(locsim::kDefaultMaxOutputBytes) / (1 << 30);
  run->add_option("--max-output-gib", max_output_gib,
                  "Refuse (exit 2) a run whose files (readings, log, video, estimates) are "
                  "estimated to exceed this many GiB; one they would not fit on the disk is "
                  "refused too (exit 1). Both before it starts")
      ->check(CLI::Range(0.001, 1e6))
      ->capture_default_str();
  VideoCli run_video;
  add_video_options(run, run_video, options.video_options);
  run->footer(
      "Writes run.json (resolved configuration, seed, version, timing), groundtruth.tum (true\n"
      "pose, TUM format), events.csv (every scenario event), readings/ (one CSV per sensor), and\n"
      "per localizer LABEL.tum and its part of metrics.json. With several robots each has its own\n"
      "sub-folder.\n\n" +
      std::string(kExitCodes));

  std::string validate_world;
  std::optional<std::string> validate_scenario;
  double converged_deg = rad_to_deg_default();
  std::string isolation = "process";
  // What `run` and `replay` share: the localizers and how they are run and judged.
  const auto add_session_options = [&](CLI::App* command, locsim::SessionOptions& session) {
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
        ->add_option("--isolation", isolation,
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
        ->transform(memory_size())
        ->capture_default_str();
    command->add_flag("!--no-readings", session.readings,
                      "Do not write readings/ (one CSV per sensor)");
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
        ->add_option("--converged-within-deg", converged_deg,
                     "Convergence: heading error at most this [deg]")
        ->check(number_above(0.0, 180.0))
        ->capture_default_str();
    command
        ->add_option("--converged-hold", session.convergence.hold_samples,
                     "Convergence: for this many consecutive ground-truth samples")
        ->transform(whole_number_in(1, 1000000))
        ->capture_default_str();
  };
  add_session_options(run, options);

  CLI::App* check = app.add_subcommand("validate", "Check a world (and scenario) without running");
  check->add_option("world", validate_world, "World file (YAML)")->required();
  check->add_option("--scenario", validate_scenario, "Scenario file (YAML)");

  CLI::App* plugins =
      app.add_subcommand("plugins", "List the localizer plugins found, with their parameters");
  std::string plugin_name, plugin_dir;
  CLI::App* new_plugin_cmd =
      app.add_subcommand("new-plugin", "Write a buildable out-of-tree localizer skeleton");
  new_plugin_cmd->add_option("name", plugin_name, "Plugin name, [a-z_][a-z0-9_]*")->required();
  new_plugin_cmd->add_option("dir", plugin_dir, "Folder to create")->required();

  locsim::SweepOptions sweep_options;
  std::string shard;
  CLI::App* sweep =
      app.add_subcommand("sweep",
                         "Run an experiment: every localizer configuration on every seed (or on "
                         "every recorded log, once per seed: `logs:`, docs/experiments.md)");
  sweep->add_option("experiment", sweep_options.experiment_file, "Experiment file (YAML)")
      ->required();
  sweep->add_option("--out", sweep_options.out_dir, "Sweep folder")->required();
  sweep->add_option("-j,--jobs", sweep_options.jobs, "Runs at a time, each its own process")
      ->transform(whole_number_in(1, 4096))
      ->capture_default_str();
  CLI::Option* resume_flag = sweep->add_flag(
      "--resume", sweep_options.resume,
      "Finish a sweep in --out: keep its ok and failed runs, run the others (not run "
      "yet, error, crashed, timeout)");
  sweep
      ->add_flag("--retry-failed", sweep_options.retry_failed,
                 "With --resume: run the failed runs again too")
      ->needs(resume_flag);
  sweep->add_option("--shard", shard,
                    "K/N: run only the K-th of N deterministic slices (merge them after)");
  sweep->footer(
      "Checks first: every plugin is found and loaded and every configuration's parameters are\n"
      "checked as `locsim run` does, before anything is simulated or the folder is made.\n"
      "Writes results.jsonl (a line per finished run, flushed at once), then results.csv and\n"
      "summary.csv/summary.md (sorted and free of wall-clock figures: identical for any --jobs,\n"
      "--shard or --resume). Statuses: ok; failed (the localizer failed: a result); crashed and\n"
      "timeout (its process was killed by a signal or after timeout_s); error (locsim could not\n"
      "produce a result: the reason is the run's whole error output, its log.txt has the rest).\n"
      "--resume runs error, crashed and timeout runs again (and failed ones with --retry-failed);\n"
      "their new result replaces the old one. One sweep at a time writes a folder: it holds\n"
      "DIR/sweep.lock (flock) while it runs; a sweep killed hard holds nothing.\n\n"
      "Exit codes:\n"
      "  0    every run has a result (ok, failed, crashed or timeout)\n"
      "  1    some run ended in error (the last line says how many; results.csv says why), or a\n"
      "       failure not caused by the input\n"
      "  2    bad input: experiment file, world, scenario, command line, or a parameter a plugin\n"
      "       does not declare or accept (the message names the file:line:col and key); --out\n"
      "       in use by another live sweep (the message names its pid); a corrupt sweep.json or\n"
      "       results.jsonl on --resume (file:line)\n"
      "  3    a plugin not found or not loadable (the message names where the experiment gives "
      "it)\n"
      "  130  interrupted (Ctrl-C); --resume finishes it");
  locsim::ReplayOptions replay_options;
  std::string replay_out;
  CLI::App* replay = app.add_subcommand(
      "replay", "Run localizers on a recorded log (run --log), without simulating");
  replay->add_option("log", replay_options.log_file, "Log file written by `locsim run --log`")
      ->required();
  replay->add_option("--out", replay_out, "Output folder")->required();
  bool replay_quiet = false;
  replay->add_flag("-q,--quiet", replay_quiet, "No summary line");
  replay
      ->add_option("--seed", replay_options.seed,
                   "Seed the localizers' random streams (their seeds, the initial guess) derive "
                   "from; default: the log's own, so that a replay of a run repeats its estimates "
                   "exactly. Another seed varies the particle filters, not the deterministic ones")
      ->transform(whole_number_in(0, std::numeric_limits<std::uint64_t>::max()));
  std::string replay_robots = "all";
  replay->add_option("--robots", replay_robots,
                     "Replay only these robots, by name, as robot1,robot3 (the log as if it held "
                     "only them); or all");
  add_session_options(replay, replay_options);
  VideoCli replay_video;
  add_video_options(replay, replay_video, replay_options.video_options);
  std::string import_format, import_source, import_out, import_robots = "all";
  locsim::ImportWindow import_window;
  double import_duration_s = 0.0;
  bool import_overwrite = false, import_quiet = false;
  CLI::App* import_cmd = app.add_subcommand(
      "import", "Turn a real dataset into a log that `locsim replay` runs (docs/real_data.md)");
  import_cmd->add_option("format", import_format, "mrclam or generic")
      ->required()
      ->check(CLI::IsMember({"mrclam", "generic"}));
  import_cmd->add_option("source", import_source, "The dataset's folder")->required();
  import_cmd->add_option("--out", import_out, "The log file to write (.locsimlog)")->required();
  import_cmd->add_option("--robots", import_robots,
                         "mrclam: the robots to import, as 1,3 (subjects 1-5), or all");
  import_cmd
      ->add_option("--from", import_window.from_s,
                   "Start this many seconds after the dataset's first time stamp")
      ->check(number_in(0.0, 1e7));
  CLI::Option* import_duration =
      import_cmd->add_option("--duration", import_duration_s, "Import this many seconds")
          ->check(number_above(0.0, 1e7));
  import_cmd->add_flag("--overwrite", import_overwrite, "Replace an existing log file");
  import_cmd->add_flag("-q,--quiet", import_quiet, "No summary line");
  std::vector<std::string> calibrate_logs;
  std::string calibrate_out, calibrate_robots = "all";
  locsim::CalibrationOptions calibration;
  bool calibrate_overwrite = false, calibrate_quiet = false;
  CLI::App* calibrate_cmd = app.add_subcommand(
      "calibrate",
      "Measure odometry and detection noise in logs with ground truth; write a parameter file "
      "for the localizers (--params) and sensor settings for a world (docs/real_data.md)");
  calibrate_cmd->add_option("logs", calibrate_logs, "Logs (run --log, or locsim import)")
      ->required();
  calibrate_cmd
      ->add_option("--out", calibrate_out,
                   "Folder for calibration.yaml and calibration.json (`locsim report` plots them)")
      ->required();
  calibrate_cmd->add_option("--robots", calibrate_robots,
                            "The robots to use, by name, as robot1,robot3; or all");
  calibrate_cmd
      ->add_option("--outlier-sigmas", calibration.outlier_sigmas,
                   "A detection this many robust standard deviations off is false [-]")
      ->check(number_in(locsim::CalibrationOptions::kMinOutlierSigmas,
                        locsim::CalibrationOptions::kMaxOutlierSigmas))
      ->capture_default_str();
  calibrate_cmd
      ->add_option("--range-bins", calibration.range_bins,
                   "At most this many range bins for the detection noise [-]")
      ->check(CLI::Range(std::size_t{1}, locsim::CalibrationOptions::kMaxRangeBins))
      ->capture_default_str();
  calibrate_cmd->add_flag("--overwrite", calibrate_overwrite,
                          "Replace calibration.yaml and calibration.json in --out");
  calibrate_cmd->add_flag("-q,--quiet", calibrate_quiet, "No summary");
  locsim::TwinOptions twin_options;
  std::string twin_log, twin_out, twin_calibration, twin_robots = "all";
  bool twin_overwrite = false, twin_quiet = false, twin_keep_camera_rate = false;
  CLI::App* twin_cmd = app.add_subcommand(
      "twin",
      "Write a simulated twin of a log: its world, each robot driven along its true path, the "
      "calibrated sensor noise (docs/real_data.md)");
  twin_cmd->add_option("log", twin_log, "A log with ground truth (locsim import, run --log)")
      ->required();
  twin_cmd
      ->add_option("--out", twin_out,
                   "The world file to write (WORLD.yaml; the paths go beside it as "
                   "WORLD_ROBOT.tum)")
      ->required();
  twin_cmd->add_option("--calibration", twin_calibration,
                       "A calibration.yaml (locsim calibrate): its sensors: for every robot");
  twin_cmd->add_option("--robots", twin_robots,
                       "The robots to keep, by name, as robot1,robot3; or all");
  twin_cmd
      ->add_option("--pose-rate-hz", twin_options.pose_rate_hz,
                   "Samples of each true path per second [Hz]")
      ->check(number_in(locsim::TwinOptions::kPoseRateRange.min,
                        locsim::TwinOptions::kPoseRateRange.max))
      ->capture_default_str();
  twin_cmd->add_flag("--keep-camera-rate", twin_keep_camera_rate,
                     "Keep the range_bearing camera's rate and misses (do not match the log's "
                     "detections per second)");
  twin_cmd->add_flag("--overwrite", twin_overwrite, "Replace the world and path files");
  twin_cmd->add_flag("-q,--quiet", twin_quiet, "No summary");
  locsim::GeneratorDef generate_def;
  std::string generate_out, generate_seeds = "1", generate_landing = "alternate";
  bool generate_overwrite = false, generate_quiet = false, generate_no_beacons = false;
  CLI::App* generate_cmd =
      app.add_subcommand("generate",
                         "Write generated worlds: a family (room, corridor, office) drawn from "
                         "each seed and a few knobs, "
                         "with a drive loop and kidnaps (docs/worlds.md#generated-worlds)");
  generate_cmd->add_option("family", generate_def.family, "room, corridor or office")
      ->required()
      ->check(CLI::IsMember(locsim::generator_families()));
  generate_cmd->add_option("--out", generate_out, "Folder for FAMILY_seedN.yaml")->required();
  generate_cmd->add_option("--seeds", generate_seeds, "A seed N, or a range A-B (one world each)")
      ->capture_default_str();
  const auto count_option = [&](const char* name, int& value, const char* what) {
    generate_cmd->add_option(name, value, what)->transform(whole_number_in(0, 100));
  };
  generate_cmd
      ->add_option(
          "--length", generate_def.length_m,
          "Room: x extent (default drawn in 8-20); corridor: length (20-40); office: 16-30 [m]")
      ->check(
          number_in(locsim::GeneratorDef::kSizeRange.min, locsim::GeneratorDef::kSizeRange.max));
  generate_cmd
      ->add_option(
          "--width", generate_def.width_m,
          "Room: y extent (default drawn in 6-12); corridor: width (2-3); office: 9-14 [m]")
      ->check(
          number_in(locsim::GeneratorDef::kSizeRange.min, locsim::GeneratorDef::kSizeRange.max));
  count_option(
      "--landmarks", generate_def.landmarks,
      "Landmarks (default: room 4-8 along the walls, corridor 3, office one per 1-2 rooms + 2)");
  generate_cmd->add_flag("--landmarks-anywhere", generate_def.landmarks_anywhere,
                         "Room: landmarks standing free, not along the walls");
  count_option("--obstacles", generate_def.obstacles,
               "Pillars and cabinets (default: room 2-5, corridor 2-4, office 3-8)");
  count_option("--people", generate_def.people, "People walking (default 1-3)");
  count_option("--slippery", generate_def.slippery, "Slippery floor patches on the path (0-2)");
  generate_cmd->add_flag("--no-beacons", generate_no_beacons, "No ultrasonic beacons");
  count_option("--kidnaps", generate_def.kidnaps, "Kidnaps (default 2)");
  generate_cmd->add_flag("--quick-kidnaps", generate_def.quick_kidnaps,
                         "The second kidnap 3-6 s after the first lands");
  generate_cmd
      ->add_option("--landing", generate_landing,
                   "Where kidnaps land: alternate (in view, blind, ...), in_view, blind, any")
      ->check(CLI::IsMember({"alternate", "in_view", "blind", "any"}))
      ->capture_default_str();
  generate_cmd->add_option("--duration", generate_def.duration_s, "Scenario length [s]")
      ->check(number_in(locsim::GeneratorDef::kDurationRange.min,
                        locsim::GeneratorDef::kDurationRange.max))
      ->capture_default_str();
  generate_cmd->add_flag("--overwrite", generate_overwrite, "Replace existing world files");
  generate_cmd->add_flag("-q,--quiet", generate_quiet, "No list of the files written");
  std::string report_dir;
  CLI::App* report_cmd =
      app.add_subcommand("report", "Write DIR/report.md with plots for a sweep or run folder");
  report_cmd->add_option("dir", report_dir, "Sweep, run or calibration folder")->required();
  report_cmd->footer(
      "Exit codes:\n"
      "  0    DIR/report.md and DIR/report/*.png written\n"
      "  1    they cannot be written (a read-only folder, a full disk): the message names the\n"
      "       file and the reason; a report.md of before is left whole\n"
      "  2    DIR is not a sweep, run or calibration folder, or a file in it cannot be read");
  std::string compare_a, compare_b, compare_out;
  std::optional<std::string> compare_labels;
  CLI::App* compare_cmd = app.add_subcommand(
      "compare",
      "Write DIR/report.md comparing two sweeps: each configuration's error on both, the two "
      "rankings and whether they agree (docs/experiments.md)");
  compare_cmd->add_option("A", compare_a, "First sweep folder (e.g. over recorded logs)")
      ->required();
  compare_cmd->add_option("B", compare_b, "Second sweep folder (e.g. over a simulated twin)")
      ->required();
  compare_cmd
      ->add_option("--out", compare_out,
                   "Folder for report.md, compare.csv and report/compare.png (not a sweep folder)")
      ->required();
  compare_cmd->add_option("--labels", compare_labels,
                          "The two sweeps' names in the report, as NAME_A,NAME_B (default: the "
                          "folders' base names)");
  std::string merge_out;
  std::vector<std::string> merge_parts;
  CLI::App* merge = app.add_subcommand("merge", "Join the folders of sharded sweeps");
  merge->add_option("out", merge_out, "New folder for the joined sweep")->required();
  merge->add_option("parts", merge_parts, "Shard folders")->required();
  merge->footer(
      "Exit codes:\n"
      "  0    joined (a warning when runs are missing: a shard not given or not finished)\n"
      "  1    a failure not caused by the input (an I/O error)\n"
      "  2    nothing written: a folder not a sweep's, a corrupt sweep.json or results.jsonl\n"
      "       (file:line), shards of other inputs, a folder given twice or a run in two shards,\n"
      "       a shard a live sweep still writes, or OUT not empty");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    // One line with the prefix every other error has, so a script's grep finds it.
    std::fprintf(stderr, "locsim: error: %s (see --help)\n", locsim::printable(e.what()).c_str());
    return locsim::kExitBadInput;
  }

  try {
    if (*check) return validate(validate_world, validate_scenario);
    if (*plugins) return list_plugins();
    if (*report_cmd) return report({report_dir});
    if (*compare_cmd) {
      std::vector<std::string> arguments = {"--compare", compare_a, compare_b, "--out",
                                            compare_out};
      if (compare_labels) {
        arguments.push_back("--labels");
        arguments.push_back(*compare_labels);
      }
      return report(arguments);
    }
    if (*import_cmd) {
      if (*import_duration) import_window.duration_s = import_duration_s;
      if (import_out.empty()) throw locsim::InputError("--out: the path is empty");
      std::error_code out_error;
      const std::filesystem::file_status out_status =
          std::filesystem::status(import_out, out_error);
      if (out_error && out_status.type() != std::filesystem::file_type::not_found) {
        throw locsim::InputError("--out: " + import_out +
                                 " cannot be looked up: " + out_error.message());
      }
      if (std::filesystem::is_directory(out_status)) {
        throw locsim::InputError("--out: " + import_out + " is a folder; name the log file");
      }
      locsim::check_output_folder(std::filesystem::path(import_out).parent_path(), "--out");
      if (std::filesystem::exists(out_status) && !import_overwrite) {
        throw locsim::InputError("--out: " + import_out +
                                 " exists (pass --overwrite to replace it)");
      }
      if (import_format == "generic" && import_robots != "all") {
        throw locsim::InputError(
            "--robots: for mrclam only (a generic dataset's robots are its "
            "sub-folders)");
      }
      locsim::MrclamImportOptions mrclam;
      mrclam.dir = import_source;
      if (import_robots != "all") {
        std::istringstream list(import_robots);
        std::string item;
        while (std::getline(list, item, ',')) {
          int subject = 0;
          const auto [end, error] =
              std::from_chars(item.data(), item.data() + item.size(), subject);
          if (item.empty() || error != std::errc() || end != item.data() + item.size()) {
            throw locsim::InputError("--robots: expected robot numbers as 1,3 or all, got '" +
                                     import_robots + "'");
          }
          mrclam.robots.push_back(subject);
        }
        if (mrclam.robots.empty()) throw locsim::InputError("--robots: no robot given");
      }
      const locsim::ImportSummary summary =
          locsim::write_import(import_format == "generic" ? locsim::read_generic(import_source)
                                                          : locsim::read_mrclam(mrclam),
                               import_window, import_out);
      if (!import_quiet) {
        std::printf("%s: %s -> %s\n", import_source.c_str(), locsim::describe(summary).c_str(),
                    import_out.c_str());
      }
      return locsim::kExitOk;
    }
    if (*calibrate_cmd) {
      calibration.robots = robot_names(calibrate_robots);
      const std::filesystem::path out(calibrate_out);
      if (out.empty()) throw locsim::InputError("--out: the path is empty");
      locsim::check_output_folder(out, "--out");
      for (const char* name : {"calibration.yaml", "calibration.json"}) {
        if (std::filesystem::exists(out / name) && !calibrate_overwrite) {
          throw locsim::InputError("--out: " + (out / name).string() +
                                   " exists (pass --overwrite to replace it)");
        }
      }
      std::vector<std::filesystem::path> logs(calibrate_logs.begin(), calibrate_logs.end());
      const locsim::Calibration result = locsim::calibrate(logs, calibration);
      locsim::make_output_folder(out, "--out");
      // The pair together: a failed write leaves neither half of a new pair beside an old one.
      const std::string json_text = result.to_json().dump(2) + '\n', yaml_text = result.to_yaml();
      locsim::write_files(
          {{out / "calibration.json", json_text}, {out / "calibration.yaml", yaml_text}});
      if (!calibrate_quiet) std::printf("%s", locsim::describe(result).c_str());
      return locsim::kExitOk;
    }
    if (*generate_cmd) {
      std::uint64_t first = 0, last = 0;
      {
        const std::string& text = generate_seeds;
        const auto dash = text.find('-');
        const auto parse = [&](std::string_view part, std::uint64_t& out) {
          const auto [end, ec] = std::from_chars(part.data(), part.data() + part.size(), out);
          return ec == std::errc() && end == part.data() + part.size() && !part.empty();
        };
        const bool ok = dash == std::string::npos
                            ? parse(text, first) && (last = first, true)
                            : parse(std::string_view(text).substr(0, dash), first) &&
                                  parse(std::string_view(text).substr(dash + 1), last);
        if (!ok || last < first || last - first >= 10000)
          throw locsim::InputError(
              "--seeds: expected N or A-B (A <= B, at most 10000 seeds), got '" + text + "'");
      }
      generate_def.beacons = !generate_no_beacons;
      generate_def.landing = *locsim::landing_from_name(generate_landing);  // CLI checked it
      const std::filesystem::path out(generate_out);
      if (out.empty()) throw locsim::InputError("--out: the path is empty");
      locsim::check_output_folder(out, "--out");
      // Every world first, then the files: a knob that fails fails before anything is written.
      std::vector<std::pair<std::filesystem::path, locsim::GeneratedWorld>> worlds;
      for (std::uint64_t seed = first;; ++seed) {
        generate_def.seed = seed;
        const std::filesystem::path file =
            out / (generate_def.family + "_seed" + std::to_string(seed) + ".yaml");
        if (!generate_overwrite && std::filesystem::exists(file))
          throw locsim::InputError("--out: " + file.string() +
                                   " exists (pass --overwrite to replace it)");
        worlds.emplace_back(file, locsim::generate_world(generate_def));
        if (seed == last) break;
      }
      locsim::make_output_folder(out, "--out");
      for (const auto& [file, world] : worlds) {
        locsim::write_file(file, world.yaml);
        if (!generate_quiet) {
          std::printf("%s\n", file.c_str());
          for (const std::string& note : world.notes) std::printf("  note: %s\n", note.c_str());
        }
      }
      return locsim::kExitOk;
    }
    if (*twin_cmd) {
      twin_options.log = twin_log;
      if (!twin_calibration.empty()) twin_options.calibration = twin_calibration;
      twin_options.robots = robot_names(twin_robots);
      twin_options.match_detections = !twin_keep_camera_rate;
      const locsim::Twin twin = locsim::write_twin(twin_options, twin_out, twin_overwrite);
      if (!twin_quiet) std::printf("%s", locsim::describe(twin).c_str());
      return locsim::kExitOk;
    }
    if (*replay) {
      replay_options.out_dir = replay_out;
      replay_options.robots = robot_names(replay_robots);
      replay_options.convergence.heading_rad = locsim::deg_to_rad(converged_deg);
      replay_options.isolate = isolation == "process";
      const std::shared_ptr<locsim::FrameSink> recorder =
          video_recorder(replay_video, replay_options.video_options);
      replay_options.video = recorder.get();
      catch_sigint();
      const locsim::ReplayResult r = locsim::replay_log(replay_options, &g_interrupted);
      if (recorder && !replay_quiet) print_video_summary(*recorder, replay_options.video_options);
      if (!replay_quiet) {
        std::printf("%s: %s, replayed %.1f s (%zu records) in %.3f s -> %s\n",
                    replay_options.log_file.c_str(), r.status.c_str(), r.replayed_s, r.records,
                    r.wall_s, replay_out.c_str());
      }
      return exit_code(r.status, r.failed_localizers);
    }
    if (*sweep) {
      if (!shard.empty()) {
        int k = 0, n = 0;
        char slash = 0;
        std::istringstream text(shard);
        if (!(text >> k >> slash >> n) || slash != '/' || !text.eof()) {
          throw locsim::InputError("--shard: expected K/N, got '" + shard + "'");
        }
        sweep_options.shard = std::pair{k, n};
      }
      sweep_options.progress_bar = isatty(STDERR_FILENO);
      catch_sigint();
      const locsim::SweepSummary s = locsim::run_sweep(sweep_options, &g_interrupted);
      const std::string retried =
          s.retried > 0 ? ", " + std::to_string(s.retried) + " run again" : "";
      std::printf("%s: %zu runs (%zu done before%s), %zu not ok%s -> %s\n",
                  sweep_options.experiment_file.c_str(), s.total, s.skipped, retried.c_str(),
                  s.not_ok, s.interrupted ? ", interrupted (--resume finishes it)" : "",
                  sweep_options.out_dir.c_str());
      if (s.interrupted) return locsim::kExitInterrupted;
      if (s.errors > 0) {
        std::fflush(stdout);
        std::fprintf(stderr,
                     "locsim sweep: %zu run%s ended in error (locsim could not produce a result); "
                     "the reasons are in %s (column reason) and each such run's log.txt; fix the "
                     "cause and pass --resume to run them again\n",
                     s.errors, s.errors == 1 ? "" : "s",
                     (sweep_options.out_dir / "results.csv").c_str());
        return locsim::kExitFailure;
      }
      return locsim::kExitOk;
    }
    if (*merge) {
      std::vector<std::filesystem::path> parts(merge_parts.begin(), merge_parts.end());
      locsim::merge_sweeps(merge_out, parts);
      std::printf("merged %zu folders into %s\n", parts.size(), merge_out.c_str());
      return locsim::kExitOk;
    }
    if (*new_plugin_cmd) return new_plugin(plugin_name, plugin_dir);

    options.convergence.heading_rad = locsim::deg_to_rad(converged_deg);
    options.isolate = isolation == "process";
    options.world_file = world_file;
    if (run->count("--log") > 0 && log_file.empty())
      throw locsim::InputError("--log: the path is empty");
    if (!log_file.empty()) {
      // Made by the run when missing (as --out is), after the inputs are checked.
      locsim::check_output_folder(std::filesystem::path(log_file).parent_path(), "--log");
      options.log_file = log_file;
    }
    options.max_output_bytes = static_cast<std::uint64_t>(max_output_gib * (1 << 30));
    if (scenario_file) options.scenario_file = *scenario_file;
    options.out_dir = out_dir;
    options.progress = !quiet && isatty(STDERR_FILENO);
    options.make_landmark_imager = imager_factory(options.video_options.backend);
    const std::shared_ptr<locsim::FrameSink> recorder =
        video_recorder(run_video, options.video_options);
    options.video = recorder.get();
    catch_sigint();
    const locsim::RunResult result = locsim::run_simulation(options, &g_interrupted);
    if (recorder && !quiet) print_video_summary(*recorder, options.video_options);
    if (!quiet) {
      std::printf("%s: %s, %.1f s simulated in %.2f s (%.0fx real time) -> %s\n",
                  world_file.c_str(), result.status.c_str(), result.simulated_s, result.wall_s,
                  result.wall_s > 0 ? result.simulated_s / result.wall_s : 0.0,
                  result.out_dir.c_str());
    }
    return exit_code(result.status, result.failed_localizers);
  } catch (const locsim::PluginError& e) {
    std::fprintf(stderr, "locsim: plugin error: %s\n", e.what());
    return locsim::kExitPlugin;
  } catch (const locsim::RenderError& e) {
    std::fprintf(stderr, "locsim: render error: %s\n", locsim::printable(e.what()).c_str());
    return locsim::kExitRender;
  } catch (const locsim::InputError& e) {
    std::fprintf(stderr, "locsim: error: %s\n", e.what());
    return locsim::kExitBadInput;
  } catch (const std::bad_alloc&) {
    // The inputs' bounds are meant to make this unreachable; if not, say what was being built.
    const std::string stage = locsim::Activity::failed();
    std::fprintf(stderr, "locsim: failure: out of memory%s\n",
                 stage.empty() ? "" : (" while " + stage).c_str());
    return locsim::kExitFailure;
  } catch (const std::exception& e) {
    // Not one of ours (their messages are made printable already): it may quote anything.
    std::fprintf(stderr, "locsim: failure: %s\n", locsim::printable(e.what()).c_str());
    return locsim::kExitFailure;
  }
}
