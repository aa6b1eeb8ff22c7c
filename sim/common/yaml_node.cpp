#include "sim/common/yaml_node.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "sim/common/files.hpp"

namespace locsim {

namespace {
std::string join_path(const std::string& parent, std::string_view key) {
  return parent.empty() ? std::string(key) : parent + "." + std::string(key);
}

RangeObserver g_range_observer = nullptr;

std::string describe(const YAML::Node& node) {
  if (!node || node.IsNull()) return "nothing";
  if (node.IsMap()) return "a map";
  if (node.IsSequence()) return "a list";
  return quote_input(node.Scalar());
}
}  // namespace

YamlNode::YamlNode(YAML::Node node, std::shared_ptr<const std::string> file, std::string path,
                   YAML::Mark mark)
    : node_(std::move(node)), file_(std::move(file)), path_(std::move(path)), mark_(mark) {}

YamlNode YamlNode::load_string(const std::string& text, const std::string& file_label) {
  auto file = std::make_shared<const std::string>(file_label);
  try {
    YAML::Node root = YAML::Load(text);
    return YamlNode(root, file, "", root.Mark());
  } catch (const YAML::ParserException& e) {
    throw InputError(SourceLocation{file_label, e.mark.line + 1, e.mark.column + 1}, "",
                     "YAML syntax error: " + e.msg);
  }
}

YamlNode YamlNode::load_file(const std::filesystem::path& file) {
  return load_string(read_input_file(file, kMaxYamlFileBytes), file.string());
}

YamlNode& YamlNode::operator=(const YamlNode& other) {
  node_.reset(other.node_);
  file_ = other.file_;
  path_ = other.path_;
  mark_ = other.mark_;
  return *this;
}

SourceLocation YamlNode::where() const {
  const YAML::Mark mark = (node_ && !node_.Mark().is_null()) ? node_.Mark() : mark_;
  if (mark.is_null()) return SourceLocation{*file_};
  return SourceLocation{*file_, mark.line + 1, mark.column + 1};
}

void YamlNode::fail(const std::string& problem) const {
  throw InputError(where(), path_, problem);
}

YamlNode YamlNode::child(const YAML::Node& node, std::string path) const {
  return YamlNode(node, file_, std::move(path), mark_);
}

void YamlNode::require_map() const {
  if (!node_.IsMap()) fail("expected a map of keys, got " + describe(node_));
}

void YamlNode::allow_keys(std::initializer_list<std::string_view> allowed) const {
  allow_keys(std::vector<std::string_view>(allowed));
}

void YamlNode::allow_keys(const std::vector<std::string_view>& allowed) const {
  require_map();
  std::set<std::string> seen;
  for (const auto& entry : node_) {
    const std::string key = entry.first.Scalar();
    const YamlNode key_node(entry.first, file_, join_path(path_, key), mark_);
    if (!seen.insert(key).second) key_node.fail("key given twice");
    if (std::find(allowed.begin(), allowed.end(), key) != allowed.end()) continue;
    std::string best;
    std::size_t best_distance = 4;  // suggest only near misses
    std::string known;
    for (const std::string_view candidate : allowed) {
      const std::size_t d = edit_distance(key, candidate);
      if (d < best_distance) best_distance = d, best = candidate;
      known += (known.empty() ? "" : ", ") + std::string(candidate);
    }
    key_node.fail("unknown key" + (best.empty() ? "" : "; did you mean '" + best + "'?") +
                  " (known keys: " + known + ")");
  }
}

bool YamlNode::has(std::string_view key) const {
  return node_.IsMap() && node_[std::string(key)].IsDefined();
}

std::optional<YamlNode> YamlNode::find(std::string_view key) const {
  require_map();
  const YAML::Node value = node_[std::string(key)];
  if (!value.IsDefined()) return std::nullopt;
  return child(value, join_path(path_, key));
}

YamlNode YamlNode::operator[](std::string_view key) const {
  auto value = find(key);
  if (!value) fail("missing required key '" + std::string(key) + "'");
  return *value;
}

std::vector<std::pair<std::string, YamlNode>> YamlNode::entries() const {
  require_map();
  std::vector<std::pair<std::string, YamlNode>> out;
  std::set<std::string> seen;
  for (const auto& entry : node_) {
    const std::string key = entry.first.Scalar();
    if (!seen.insert(key).second) {
      YamlNode(entry.first, file_, join_path(path_, key), mark_).fail("key given twice");
    }
    out.emplace_back(key, child(entry.second, join_path(path_, key)));
  }
  return out;
}

std::vector<YamlNode> YamlNode::items() const {
  if (!node_.IsSequence()) fail("expected a list, got " + describe(node_));
  std::vector<YamlNode> out;
  out.reserve(node_.size());
  for (std::size_t i = 0; i < node_.size(); ++i) {
    out.push_back(child(node_[i], path_ + "[" + std::to_string(i) + "]"));
  }
  return out;
}

RangeObserver YamlNode::observe_ranges(RangeObserver observer) {
  const RangeObserver previous = g_range_observer;
  g_range_observer = observer;
  return previous;
}

void YamlNode::observe(const std::string& key_path, const Range& range, bool degrees, bool angle,
                       bool integer, bool present) const {
  if (g_range_observer != nullptr) {
    g_range_observer(RangeUse{*file_, key_path, range, degrees, angle, integer, present});
  }
}

double YamlNode::number(const Range& range, bool degrees, bool angle) const {
  observe(path_, range, degrees, angle, false, true);
  if (!node_.IsScalar()) fail("expected a number, got " + describe(node_));
  double value = 0.0;
  try {
    value = node_.as<double>();
  } catch (const YAML::Exception&) {
    fail("expected a number, got " + describe(node_));
  }
  if (!std::isfinite(value)) fail("expected a finite number, got " + describe(node_));
  if (const std::string problem = out_of_range(value, range, degrees); !problem.empty()) {
    fail(problem);
  }
  return value;
}

double YamlNode::as_double(const Range& range) const {
  return number(range, false, false);
}

long long YamlNode::as_int(const Range& range) const {
  observe(path_, range, false, false, true, true);
  if (!node_.IsScalar()) fail("expected an integer, got " + describe(node_));
  long long value = 0;
  try {
    value = node_.as<long long>();
  } catch (const YAML::Exception&) {
    // A whole number too large for 64 bits is out of range, not "not an integer".
    double number = 0.0;
    if (YAML::convert<double>::decode(node_, number) && number == std::trunc(number) &&
        !out_of_range(number, range).empty()) {
      fail(out_of_range(number, range));
    }
    fail("expected an integer, got " + describe(node_));
  }
  if (const std::string problem = out_of_range(static_cast<double>(value), range);
      !problem.empty()) {
    fail(problem);
  }
  return value;
}

bool YamlNode::as_bool() const {
  if (!node_.IsScalar()) fail("expected true or false, got " + describe(node_));
  try {
    return node_.as<bool>();
  } catch (const YAML::Exception&) {
    fail("expected true or false, got " + describe(node_));
  }
}

std::string YamlNode::as_string() const {
  if (!node_.IsScalar()) fail("expected a string, got " + describe(node_));
  return node_.Scalar();
}

Vec2 YamlNode::as_vec2(const Range& range) const {
  if (!node_.IsSequence() || node_.size() != 2) {
    fail("expected a point [x, y], got " + describe(node_));
  }
  const auto xy = items();
  return {xy[0].as_double(range), xy[1].as_double(range)};
}

std::vector<Vec2> YamlNode::as_points(std::size_t min_points, const Range& range) const {
  std::vector<Vec2> points;
  for (const YamlNode& item : items()) points.push_back(item.as_vec2(range));
  if (points.size() < min_points) {
    fail("expected at least " + std::to_string(min_points) + " points [x, y], got " +
         std::to_string(points.size()));
  }
  return points;
}

Pose2 YamlNode::as_pose(const Range& range) const {
  allow_keys({"x", "y", "theta", "theta_deg"});
  return Pose2{(*this)["x"].as_double(range), (*this)["y"].as_double(range),
               get_heading("theta", 0.0)};
}

double YamlNode::get_double(std::string_view key, double fallback, const Range& range) const {
  const auto value = find(key);
  if (!value) observe(join_path(path_, key), range, false, false, false, false);
  return value ? value->as_double(range) : fallback;
}

long long YamlNode::get_int(std::string_view key, long long fallback, const Range& range) const {
  const auto value = find(key);
  if (!value) observe(join_path(path_, key), range, false, false, true, false);
  return value ? value->as_int(range) : fallback;
}

bool YamlNode::get_bool(std::string_view key, bool fallback) const {
  const auto value = find(key);
  return value ? value->as_bool() : fallback;
}

std::string YamlNode::get_string(std::string_view key, const std::string& fallback) const {
  const auto value = find(key);
  return value ? value->as_string() : fallback;
}

double YamlNode::get_angle(std::string_view key, double fallback_rad, const Range& range) const {
  const std::string deg_key = std::string(key) + "_deg";
  const auto rad = find(key);
  const auto deg = find(deg_key);
  if (rad && deg)
    deg->fail("give either '" + std::string(key) + "' [rad] or '" + deg_key + "' [deg], not both");
  if (rad) return rad->number(range, false, true);
  if (deg) return deg_to_rad(deg->number(range, true, true));
  observe(join_path(path_, key), range, false, true, false, false);
  return fallback_rad;
}

double YamlNode::get_heading(std::string_view key, double fallback_rad) const {
  return wrap_angle(get_angle(key, fallback_rad, kHeadingRange));
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

}  // namespace locsim
