// Reading YAML input with errors a user can act on: every problem names the file, line, column
// and the key's path (e.g. `robots[0].wheel_base_m`). Unknown keys are errors, with a suggestion.
#pragma once

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "sim/common/errors.hpp"
#include "sim/common/math.hpp"

namespace locsim {

/// Constraint on a number read from input.
enum class Check { kAny, kPositive, kNonNegative, kUnitInterval };

/// A YAML node that knows its file and key path. Cheap to copy.
class YamlNode {
 public:
  /// Parses a file. Missing or unreadable files and syntax errors throw InputError.
  static YamlNode load_file(const std::filesystem::path& file);
  /// Parses text; `file_label` names it in messages.
  static YamlNode load_string(const std::string& text, const std::string& file_label);

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

  // ---- scalars (each fails with the expected type when the node is something else)
  double as_double(Check check = Check::kAny) const;
  long long as_int(long long min_value, long long max_value) const;
  bool as_bool() const;
  std::string as_string() const;
  /// `[x, y]`.
  Vec2 as_vec2() const;
  /// A list of `[x, y]` points with at least `min_points`.
  std::vector<Vec2> as_points(std::size_t min_points) const;
  /// `{x, y, theta}` or `{x, y, theta_deg}`.
  Pose2 as_pose() const;

  // ---- optional keys with defaults
  double get_double(std::string_view key, double fallback, Check check = Check::kAny) const;
  long long get_int(std::string_view key, long long fallback, long long min_value,
                    long long max_value) const;
  bool get_bool(std::string_view key, bool fallback) const;
  std::string get_string(std::string_view key, const std::string& fallback) const;
  /// Angle from `key` [rad] or `key_deg` [deg]; both at once is an error.
  double get_angle(std::string_view key, double fallback_rad) const;

  /// Throws InputError at this node.
  [[noreturn]] void fail(const std::string& problem) const;

 private:
  YamlNode(YAML::Node node, std::shared_ptr<const std::string> file, std::string path,
           YAML::Mark mark);
  YamlNode child(const YAML::Node& node, std::string path) const;
  void require_map() const;

  YAML::Node node_;
  std::shared_ptr<const std::string> file_;
  std::string path_;
  YAML::Mark mark_;  // of this node, or of its parent where the node is missing
};

/// Edit distance, for "did you mean" suggestions.
std::size_t edit_distance(std::string_view a, std::string_view b);

}  // namespace locsim
