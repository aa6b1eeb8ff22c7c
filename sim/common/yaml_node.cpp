#include "sim/common/yaml_node.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

namespace locsim {

namespace {
std::string join_path(const std::string& parent, std::string_view key) {
  return parent.empty() ? std::string(key) : parent + "." + std::string(key);
}

std::string describe(const YAML::Node& node) {
  if (!node || node.IsNull()) return "nothing";
  if (node.IsMap()) return "a map";
  if (node.IsSequence()) return "a list";
  return "'" + node.Scalar() + "'";
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
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    throw InputError(SourceLocation{file.string()}, "",
                     std::filesystem::exists(file) ? "cannot read the file" : "no such file");
  }
  std::ostringstream text;
  text << in.rdbuf();
  return load_string(text.str(), file.string());
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

double YamlNode::as_double(Check check) const {
  if (!node_.IsScalar()) fail("expected a number, got " + describe(node_));
  double value = 0.0;
  try {
    value = node_.as<double>();
  } catch (const YAML::Exception&) {
    fail("expected a number, got " + describe(node_));
  }
  if (!std::isfinite(value)) fail("expected a finite number, got " + describe(node_));
  switch (check) {
    case Check::kAny:
      break;
    case Check::kPositive:
      if (!(value > 0.0)) fail("must be > 0, got " + node_.Scalar());
      break;
    case Check::kNonNegative:
      if (value < 0.0) fail("must be >= 0, got " + node_.Scalar());
      break;
    case Check::kUnitInterval:
      if (value < 0.0 || value > 1.0) fail("must be in [0, 1], got " + node_.Scalar());
      break;
  }
  return value;
}

long long YamlNode::as_int(long long min_value, long long max_value) const {
  if (!node_.IsScalar()) fail("expected an integer, got " + describe(node_));
  long long value = 0;
  try {
    value = node_.as<long long>();
  } catch (const YAML::Exception&) {
    fail("expected an integer, got " + describe(node_));
  }
  if (value < min_value || value > max_value) {
    fail("must be in [" + std::to_string(min_value) + ", " + std::to_string(max_value) + "], got " +
         node_.Scalar());
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

Vec2 YamlNode::as_vec2() const {
  if (!node_.IsSequence() || node_.size() != 2) {
    fail("expected a point [x, y], got " + describe(node_));
  }
  const auto xy = items();
  return {xy[0].as_double(), xy[1].as_double()};
}

std::vector<Vec2> YamlNode::as_points(std::size_t min_points) const {
  std::vector<Vec2> points;
  for (const YamlNode& item : items()) points.push_back(item.as_vec2());
  if (points.size() < min_points) {
    fail("expected at least " + std::to_string(min_points) + " points [x, y], got " +
         std::to_string(points.size()));
  }
  return points;
}

Pose2 YamlNode::as_pose() const {
  allow_keys({"x", "y", "theta", "theta_deg"});
  return Pose2{(*this)["x"].as_double(), (*this)["y"].as_double(), get_angle("theta", 0.0)};
}

double YamlNode::get_double(std::string_view key, double fallback, Check check) const {
  const auto value = find(key);
  return value ? value->as_double(check) : fallback;
}

long long YamlNode::get_int(std::string_view key, long long fallback, long long min_value,
                            long long max_value) const {
  const auto value = find(key);
  return value ? value->as_int(min_value, max_value) : fallback;
}

bool YamlNode::get_bool(std::string_view key, bool fallback) const {
  const auto value = find(key);
  return value ? value->as_bool() : fallback;
}

std::string YamlNode::get_string(std::string_view key, const std::string& fallback) const {
  const auto value = find(key);
  return value ? value->as_string() : fallback;
}

double YamlNode::get_angle(std::string_view key, double fallback_rad) const {
  const std::string deg_key = std::string(key) + "_deg";
  const auto rad = find(key);
  const auto deg = find(deg_key);
  if (rad && deg)
    deg->fail("give either '" + std::string(key) + "' [rad] or '" + deg_key + "' [deg], not both");
  if (rad) return rad->as_double();
  if (deg) return deg_to_rad(deg->as_double());
  return fallback_rad;
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
