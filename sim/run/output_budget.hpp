// The bytes a run will write, estimated from its world and options before it starts, so that a
// run that would fill the disk (a 100 000-beam laser at 10 kHz writes 1 GB in 19 s; a
// `duration_s: 1e7`) is refused at once, naming what makes it large, instead of failing hours
// later with a full disk. Everything a run writes is counted, where it goes: the run folder
// (ground truth, estimates, readings/, events.csv, metrics.json, run.json twice: when the folder
// is made and when the run ends, both for a moment), the --log, the --video and --frames.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "sim/common/errors.hpp"
#include "sim/consumers/frame_state.hpp"
#include "sim/scenario/scenario_def.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

/// The most a run writes unless --max-output-gib says otherwise. [bytes]
inline constexpr std::uint64_t kDefaultMaxOutputBytes = std::uint64_t{16} << 30;

/// A video frame's bytes are counted as this many bits a pixel: H.264 at CRF 23 writes about 0.05
/// for the demo's frames (5.8 KiB a 1280x720 frame, key frames included), MPEG-4 aims at 0.15.
inline constexpr double kVideoBitsPerPixel = 0.2;
/// Once per video, for its container and its first key frame (27 KiB for the demo's). [bits/px]
inline constexpr double kVideoFirstFrameBitsPerPixel = 2.0;
/// A --frames PNG (fast zlib level): 1.4 bits a pixel for the demo's frames. [bits/px]
inline constexpr double kPngBitsPerPixel = 4.0;

/// What a run writes besides what its world and scenario decide.
struct OutputPlan {
  bool readings = true;         // readings/ (one CSV per sensor)
  std::size_t localizers = 0;   // estimate files (LABEL.tum) per robot
  bool log = false;             // --log: the record stream again
  double log_header_bytes = 0;  // its header (the world's and scenario's files), with --log
  double run_json_bytes = 0;    // run.json as written when the folder is made
  /// --video and/or --frames (null: neither): the frames' count and size.
  const VideoOptions* video = nullptr;
};

/// What a run will write: its total, where it goes, and the largest single part with what
/// decides it: a place in the world file, or (empty key) a command-line option.
struct OutputEstimate {
  double total_bytes = 0.0;
  double folder_bytes = 0.0;  // into the run folder
  double log_bytes = 0.0;     // into --log
  double video_bytes = 0.0;   // into --video
  double frames_bytes = 0.0;  // into --frames
  double largest_bytes = 0.0;
  InputPlace largest_place;  // where.file empty: decided by `largest_option`
  std::string largest_option;
  std::string largest_what;
};

/// The outputs of `world` run through `scenario` with `plan`. Upper estimates of each row's text
/// and record, and of each video frame (the bounds above).
OutputEstimate estimate_run_output(const WorldDef& world, const ScenarioDef& scenario,
                                   const OutputPlan& plan);

/// An upper bound on the length of `value.dump()` (no indentation), without making the text: a
/// log header carrying a map image's base64 is not copied to be measured.
double json_text_bytes(const nlohmann::ordered_json& value);

/// Where a run writes: its folder, and the files and folders named on the command line.
struct OutputPaths {
  std::filesystem::path out_dir;
  std::optional<std::filesystem::path> log_file;
  std::optional<std::filesystem::path> video_file;
  std::optional<std::filesystem::path> frames_dir;
  /// What --overwrite frees on the run folder's disk: the previous run's files. [bytes]
  double out_dir_freed_bytes = 0.0;
};

/// Throws InputError when the estimate exceeds `max_bytes` (a bound the user sets): naming the
/// largest part's place or option, and --max-output-gib. Throws std::runtime_error (exit 1: the
/// machine's state, not the input) when what goes onto one disk exceeds that disk's free space,
/// naming the folder and files, the estimate and the free space.
void check_run_output(const OutputEstimate& estimate, std::uint64_t max_bytes,
                      const OutputPaths& paths);

}  // namespace locsim
