// Generated worlds (issue 19): families of worlds drawn from a seed and a few knobs, so that a
// filter is judged on worlds nobody tuned it for. Each is an ordinary world file with its
// scenario (a drive loop and kidnaps), written as YAML and checked by the world loader before it
// is returned. Every quantity is drawn from its own stream, make_stream(seed,
// "generate/<what>"): the same seed and knobs give the same file, byte for byte.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "sim/common/range.hpp"

namespace locsim {

/// Where a kidnapped robot lands: with a landmark in the camera's view (straight ahead, within
/// its range and field of view, line of sight clear), with none, or either.
enum class KidnapLanding { kAlternate, kInView, kBlind, kAny };

/// A count knob: unset (drawn in the family's range), a number, or a range drawn per seed
/// (`--people 5-20`: a crowd of 5 to 20, each seed its own).
struct CountKnob {
  int min = -1, max = -1;  // -1: the family's range [-]
  CountKnob() = default;
  CountKnob(int count) : min(count), max(count) {}  // NOLINT(google-explicit-constructor)
  CountKnob(int lo, int hi) : min(lo), max(hi) {}
  bool given() const { return min >= 0; }
  bool operator==(const CountKnob&) const = default;
  /// "N" or "A-B", as the command line takes it.
  std::string text() const;
  /// Reads "N" or "A-B" (0 <= A <= B <= 100); InputError naming `option` otherwise.
  static CountKnob parse(std::string_view text, std::string_view option);
};

/// The knobs of `locsim generate`. A negative count or a zero size means "drawn for the family"
/// (the ranges in each comment). docs/worlds.md#generated-worlds.
struct GeneratorDef {
  std::string family = "room";  // room | corridor
  std::uint64_t seed = 1;
  double length_m = 0.0;  // room: 8-20 m (x); corridor: 20-40 m [m]
  double width_m = 0.0;   // room: 6-12 m (y); corridor: 2-3 m [m]
  static constexpr Range kSizeRange{1.5, 200.0, "m"};
  CountKnob landmarks;              // room: 4-8 along the walls; corridor: 3 [-]
  bool landmarks_anywhere = false;  // true: free-standing in the room, not along the walls
  CountKnob obstacles;              // pillars and cabinets: room 2-5, corridor 2-4 [-]
  CountKnob people;                 // walking across the room or along the corridor: 1-3 [-]
  CountKnob slippery;               // low-friction floor patches on the drive path: 0-2 [-]
  bool beacons = true;              // ultrasonic beacons: the room's corners, every 8 m of corridor
  bool imu = true;                  // false: the robot has no IMU (wheels alone tell its turns)
  int kidnaps = 2;                  // kidnap events [-]
  bool quick_kidnaps = false;       // the second kidnap 3-6 s after the first lands
  KidnapLanding landing = KidnapLanding::kAlternate;  // first in view, then blind, ...
  double duration_s = 120.0;                          // [s]
  static constexpr Range kDurationRange{10.0, 1e6, "s"};
  static constexpr Range kCountRange{0.0, 100.0, ""};
};

/// The --landing names: alternate, in_view, blind, any.
std::string_view landing_name(KidnapLanding landing);
std::optional<KidnapLanding> landing_from_name(std::string_view name);

/// The `locsim generate` command that draws `def`'s world: the family, the seed and every knob
/// that differs from its default (a generated file's header, so that the file says how to make it
/// again).
std::string generate_command(const GeneratorDef& def);

struct GeneratedWorld {
  std::string yaml;                // the world file, scenario included
  std::vector<std::string> notes;  // what could not be had as asked (also in the file's header)
};

/// Draws a world of `def.family` from `def.seed`. Throws InputError for an unknown family or a
/// knob out of range; a drawn world the loader refuses is an internal error (std::logic_error).
GeneratedWorld generate_world(const GeneratorDef& def);

/// The families generate_world knows.
const std::vector<std::string>& generator_families();

}  // namespace locsim
