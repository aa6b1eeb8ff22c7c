// Reading YAML input with errors a user can act on: every problem names the file, line, column
// and the key's path (e.g. `robots[0].wheel_base_m`). Unknown keys are errors, with a suggestion.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "sim/common/errors.hpp"
#include "sim/common/math.hpp"
#include "sim/common/range.hpp"

namespace locsim {

/// A number read from a file, as told to a RangeObserver.
struct RangeUse {
  const std::string& file;
  const std::string& key_path;  // e.g. "robots[0].mass_kg"
  const Range& range;
  bool degrees = false;  // read from a `_deg` key: the range applies after conversion to radians
  bool angle = false;    // an angle, given as `key` [rad] or `key_deg` [deg]
  bool integer = false;  // read as an integer
  bool present = true;   // false: an optional key that is absent (its default applies)
};
/// Told of every number read, and of every optional number key looked for and absent. For tests
/// and listings; nullptr (the default) tells no one.
using RangeObserver = void (*)(const RangeUse& use);

/// The largest YAML file read (world, scenario, experiment, map.yaml): some 15 000 shapes.
/// yaml-cpp's tree takes up to 300 times the text (a list of one-digit numbers; measured), so this
/// keeps the parse within about 300 MB. Static geometry larger than this belongs in a map image.
/// [bytes]
inline constexpr std::uintmax_t kMaxYamlFileBytes = 1u << 20;

/// A YAML node that knows its file and key path. Cheap to copy.
class YamlNode {
 public:
  /// Parses a file. Missing or unreadable files and syntax errors throw InputError.
  static YamlNode load_file(const std::filesystem::path& file);
  /// Parses text; `file_label` names it in messages.
  static YamlNode load_string(const std::string& text, const std::string& file_label);

  YamlNode(const YamlNode&) = default;
  /// Rebinds to `other`'s node. (YAML::Node's own assignment writes `other`'s value into the
  /// document where this node points, which would silently edit the file's tree.)
  YamlNode& operator=(const YamlNode& other);

  const std::string& path() const { return path_; }
  const std::string& file() const { return *file_; }
  SourceLocation where() const;

  bool is_map() const { return node_.IsMap(); }
  bool is_sequence() const { return node_.IsSequence(); }
  bool is_scalar() const { return node_.IsScalar(); }
  bool is_null() const { return !node_ || node_.IsNull(); }

  // ---- maps
  /// Fails unless this is a map whose keys are all in `allowed` and none is repeated.
  void allow_keys(std::initializer_list<std::string_view> allowed) const;
  void allow_keys(const std::vector<std::string_view>& allowed) const;
  bool has(std::string_view key) const;
  /// A required key; fails with "missing required key" when absent.
  YamlNode operator[](std::string_view key) const;
  std::optional<YamlNode> find(std::string_view key) const;

  /// A map's entries in file order (fails unless this is a map).
  std::vector<std::pair<std::string, YamlNode>> entries() const;

  // ---- sequences
  /// The items of a sequence; fails unless this is a sequence.
  std::vector<YamlNode> items() const;
  /// How many items a list has (0 for anything else), without reading them: what a loader counts
  /// against the memory budget before it builds them.
  std::size_t size() const { return node_.IsSequence() ? node_.size() : 0; }

  // ---- scalars (each fails with the expected type when the node is something else). Every
  // number is read with its range: a finite value outside it fails with the value, the range and
  // the unit, e.g. "1e+38 kg is outside [0.01, 100000] kg".
  double as_double(const Range& range) const;
  /// An integer (no fraction, no exponent) within `range`.
  long long as_int(const Range& range) const;
  bool as_bool() const;
  std::string as_string() const;
  /// `[x, y]`, each within `range`.
  Vec2 as_vec2(const Range& range) const;
  /// A list of `[x, y]` points, each within `range`, at least `min_points` of them.
  std::vector<Vec2> as_points(std::size_t min_points, const Range& range) const;
  /// `{x, y, theta}` or `{x, y, theta_deg}`: x and y within `range`, the heading as get_heading.
  Pose2 as_pose(const Range& range) const;

  // ---- optional keys with defaults (the fallback is not checked: defaults are in range)
  double get_double(std::string_view key, double fallback, const Range& range) const;
  long long get_int(std::string_view key, long long fallback, const Range& range) const;
  bool get_bool(std::string_view key, bool fallback) const;
  std::string get_string(std::string_view key, const std::string& fallback) const;
  /// Angle from `key` [rad] or `key_deg` [deg] within `range` (given in rad); both at once is
  /// an error.
  double get_angle(std::string_view key, double fallback_rad, const Range& range) const;
  /// A heading (orientation) from `key` or `key_deg`: any angle within kHeadingRange, wrapped
  /// to (-pi, pi] (values already inside are kept bit for bit).
  double get_heading(std::string_view key, double fallback_rad) const;

  /// Where this node is, for messages raised later (after loading).
  InputPlace place() const { return InputPlace{where(), path_}; }
  /// Sets the observer told of every number read (see RangeObserver); returns the previous one.
  static RangeObserver observe_ranges(RangeObserver observer);

  /// Throws InputError at this node.
  [[noreturn]] void fail(const std::string& problem) const;

 private:
  YamlNode(YAML::Node node, std::shared_ptr<const std::string> file, std::string path,
           YAML::Mark mark);
  YamlNode child(const YAML::Node& node, std::string path) const;
  void require_map() const;
  double number(const Range& range, bool degrees, bool angle) const;
  void observe(const std::string& key_path, const Range& range, bool degrees, bool angle,
               bool integer, bool present) const;

  YAML::Node node_;
  std::shared_ptr<const std::string> file_;
  std::string path_;
  YAML::Mark mark_;  // of this node, or of its parent where the node is missing
};

/// Edit distance, for "did you mean" suggestions.
std::size_t edit_distance(std::string_view a, std::string_view b);

}  // namespace locsim
