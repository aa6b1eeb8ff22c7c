// What several locsim subcommands share: option checks, the options of `run` and `replay`, Ctrl-C,
// exit codes. One definition each, so that the commands cannot drift apart.
#pragma once

#include <CLI/CLI.hpp>
#include <atomic>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "sim/common/math.hpp"
#include "sim/consumers/frame_state.hpp"
#include "sim/run/session.hpp"
#include "sim/sensors/camera_image.hpp"

namespace locsim::cli {

/// The footer of `locsim --help` and `locsim run --help`.
inline constexpr const char* kExitCodes = R"(Exit codes:
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

/// A finite number in [lo, hi] (lo excluded when `lo_open`). CLI11's range checks compare, and
/// every comparison with NaN is false: NaN and the infinities are refused first.
CLI::Validator number_in(double lo, double hi, bool lo_open = false);

/// A finite number > lo (and at most hi).
CLI::Validator number_above(double lo, double hi = std::numeric_limits<double>::max());

/// A whole number in [lo, hi], in decimal digits. CLI11 alone reads "-1" into an unsigned option
/// as 2^64 - 1, a number too large as the largest one, and "010" as octal 8. A transform (a
/// check's changes are dropped): the option then reads the number in decimal.
CLI::Validator whole_number_in(std::int64_t lo, std::uint64_t hi);

/// Installs the Ctrl-C handler (common.cpp: the first asks the run to end cleanly, another a
/// second later ends locsim); returns the flag it raises, for the run to poll.
const std::atomic<bool>* catch_sigint();

/// PTZ cameras in mode: rendered take their pictures through the renderer (loaded on first use).
LandmarkImagerFactory imager_factory(const std::string& gl_backend);

/// The video options, as `run` and `replay` both take them: the files as given, the rest parsed
/// into `video`.
struct VideoCli {
  std::string video_file, frames_dir, size = "1280x720";
};
void add_video_options(CLI::App* command, VideoCli& cli, VideoOptions& video);

/// The renderer's recorder for --video/--frames (null when neither is given); completes `video`.
std::shared_ptr<FrameSink> video_recorder(const VideoCli& cli, VideoOptions& video);

void print_video_summary(const FrameSink& recorder, const VideoOptions& video);

/// What `run` and `replay` share: the localizers and how they are run and judged. Two options are
/// read in another form than SessionOptions holds (a name, degrees); `apply` sets them there.
struct SessionCli {
  std::string isolation = "process";
  double converged_deg = rad_to_deg(ConvergenceCriterion{}.heading_rad);
  void apply(SessionOptions& session) const;
};
void add_session_options(CLI::App* command, SessionCli& cli, SessionOptions& session);

/// A finished run's (or replay's) exit code: interrupted, a localizer failed, or all well.
int exit_code(const std::string& status, const std::vector<std::string>& failed_localizers);

/// An option's comma-separated names ("a,b"); InputError naming `option` for an empty name or
/// none at all.
std::vector<std::string> comma_names(const std::string& list, const std::string& option);

/// `--robots a,b` of replay, calibrate and twin: the names; empty for "all".
std::vector<std::string> robot_names(const std::string& list);

/// `locsim report DIR` and `locsim compare`: replaces locsim with tools/report.py (installed to
/// share/locsim) given `arguments`, run with Debian's Python (it has matplotlib; a virtualenv's
/// python3 may not). Throws when it cannot.
[[noreturn]] void exec_report(const std::vector<std::string>& arguments);

}  // namespace locsim::cli
