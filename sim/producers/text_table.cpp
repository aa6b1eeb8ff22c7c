#include "sim/producers/text_table.hpp"

#include <charconv>
#include <cmath>
#include <limits>
#include <system_error>

#include "sim/common/files.hpp"
#include "sim/common/format.hpp"

namespace locsim {

namespace {

// A dataset file larger than this is refused before it is read: the importers hold a file's
// text in memory (MRCLAM's largest is 3.4 MB).
constexpr std::uintmax_t kMaxTableBytes = std::uintmax_t{1} << 30;

bool blank(char c) {
  return c == ' ' || c == '\t' || c == '\r';
}

std::string_view trim(std::string_view text) {
  while (!text.empty() && blank(text.front())) text.remove_prefix(1);
  while (!text.empty() && blank(text.back())) text.remove_suffix(1);
  return text;
}

/// What to say of a path the system could not look up.
std::string lookup_problem(const std::error_code& error) {
  if (error == std::errc::too_many_symbolic_link_levels) {
    return "a symbolic link loop (too many levels of symbolic links): the link, or one on its "
           "way, leads back to itself";
  }
  return "cannot be looked up: " + error.message();
}

/// The file's text. A path the system cannot look up (a symbolic link loop) is said to be that:
/// read_input_file would call it missing.
std::string read_table_text(const std::filesystem::path& file) {
  std::error_code error;
  if (!input_file_exists(file, error) && error)
    throw InputError(SourceLocation{file.string()}, "", lookup_problem(error));
  return read_input_file(file, kMaxTableBytes);
}

}  // namespace

std::filesystem::file_type dataset_file_type(const std::filesystem::path& path) {
  std::error_code error;
  const std::filesystem::file_status status = std::filesystem::status(path, error);
  if (error && status.type() != std::filesystem::file_type::not_found)
    throw InputError(SourceLocation{path.string()}, "", lookup_problem(error));
  return status.type();
}

TextTable::TextTable(const std::filesystem::path& file, Layout layout,
                     std::vector<std::string> names, std::vector<std::string> optional)
    : file_(file), text_(read_table_text(file)), names_(std::move(names)) {
  const std::string_view text = text_;
  bool header_seen = layout != Layout::kCsv;
  int line = 0;
  for (std::size_t start = 0; start < text.size();) {
    std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view whole_line = text.substr(start, end - start);
    const std::size_t line_start = start;
    start = end + 1;
    ++line;
    const std::string_view content = trim(whole_line);
    if (content.empty() || content.front() == '#') continue;
    Row row;
    row.line = line;
    row.line_start = static_cast<std::uint32_t>(line_start);
    row.first = static_cast<std::uint32_t>(fields_.size());
    const auto add = [&](std::size_t from, std::size_t to) {
      const std::string_view field = trim(text.substr(from, to - from));
      fields_.push_back({static_cast<std::uint32_t>(field.data() - text.data()),
                         static_cast<std::uint32_t>(field.size())});
      ++row.count;
    };
    const std::size_t line_end = line_start + whole_line.size();
    if (layout == Layout::kWhitespace) {
      std::size_t i = line_start;
      while (i < line_end) {
        while (i < line_end && blank(text[i])) ++i;
        if (i == line_end) break;
        const std::size_t from = i;
        while (i < line_end && !blank(text[i])) ++i;
        add(from, i);
      }
    } else {
      std::size_t from = line_start;
      for (std::size_t i = line_start; i <= line_end; ++i) {
        if (i == line_end || text[i] == ',') {
          add(from, i);
          from = i + 1;
        }
      }
    }
    if (!header_seen) {
      header_seen = true;
      std::vector<std::string> header;
      for (std::size_t i = 0; i < row.count; ++i) header.emplace_back(field_text(row, i));
      fields_.resize(row.first);  // the header's fields are not data
      std::vector<std::string> ordered;
      for (const std::string& name : names_) {
        if (std::find(header.begin(), header.end(), name) == header.end()) {
          std::string columns;
          for (const std::string& n : names_) columns += (columns.empty() ? "" : ",") + n;
          throw InputError(SourceLocation{file_.string(), line, 1}, name,
                           "the header row lacks column '" + name + "' (expected " + columns +
                               ", got " + quote_input(content) + ")");
        }
      }
      // Columns are addressed by name: the header's own order is kept, and names_ becomes it.
      for (const std::string& name : header) {
        const bool known = std::find(names_.begin(), names_.end(), name) != names_.end() ||
                           std::find(optional.begin(), optional.end(), name) != optional.end();
        if (!known) {
          throw InputError(SourceLocation{file_.string(), line, 1}, name,
                           "unknown column " + quote_input(name));
        }
        if (std::find(ordered.begin(), ordered.end(), name) != ordered.end()) {
          throw InputError(SourceLocation{file_.string(), line, 1}, name,
                           "column " + quote_input(name) + " named twice");
        }
        ordered.push_back(name);
      }
      names_ = std::move(ordered);
      continue;
    }
    rows_.push_back(std::move(row));
  }
  if (rows_.empty()) {
    throw InputError(
        SourceLocation{file_.string()}, "",
        layout == Layout::kCsv && !header_seen ? "empty file (no header row)" : "no data rows");
  }
}

int TextTable::column(std::string_view name) const {
  for (std::size_t i = 0; i < names_.size(); ++i) {
    if (names_[i] == name) return static_cast<int>(i);
  }
  return -1;
}

std::string TextTable::column_name(int column) const {
  const bool named = column >= 0 && static_cast<std::size_t>(column) < names_.size();
  return named ? names_[static_cast<std::size_t>(column)] : "";
}

int TextTable::column_in_line(const Row& row, int column) const {
  if (column < 0 || static_cast<std::size_t>(column) >= row.count) return 0;
  return static_cast<int>(fields_[row.first + static_cast<std::size_t>(column)].offset -
                          row.line_start) +
         1;
}

void TextTable::fail(const Row& row, int column, const std::string& problem) const {
  throw InputError(SourceLocation{file_.string(), row.line, column_in_line(row, column)},
                   column_name(column), problem);
}

void TextTable::need(const Row& row, int column) const {
  if (column < 0 || static_cast<std::size_t>(column) >= row.count) {
    fail(row, column,
         "the line has " + std::to_string(row.count) + " columns, expected at least " +
             std::to_string(column + 1) + " (a truncated line?)");
  }
  if (field_text(row, static_cast<std::size_t>(column)).empty()) fail(row, column, "empty value");
}

std::string_view TextTable::text(const Row& row, int column) const {
  if (column < 0 || static_cast<std::size_t>(column) >= row.count) return {};
  return field_text(row, static_cast<std::size_t>(column));
}

double TextTable::number(const Row& row, int column) const {
  need(row, column);
  const std::string_view field = field_text(row, static_cast<std::size_t>(column));
  double value = 0.0;
  const char* begin = field.data();
  if (field.size() > 1 && field.front() == '+') ++begin;  // from_chars refuses a leading '+'
  const auto [end, error] = std::from_chars(begin, field.data() + field.size(), value);
  if (error == std::errc::result_out_of_range || (error == std::errc() && !std::isfinite(value)) ||
      field == "nan" || field == "NaN") {
    fail(row, column, quote_input(field) + " is not a finite number");
  }
  if (error != std::errc() || end != field.data() + field.size()) {
    fail(row, column, quote_input(field) + " is not a number");
  }
  return value;
}

double TextTable::number(const Row& row, int column, const Range& range) const {
  const double value = number(row, column);
  if (const std::string problem = out_of_range(value, range); !problem.empty())
    fail(row, column, problem);
  return value;
}

long long TextTable::whole(const Row& row, int column, long long lo, long long hi) const {
  const double value = number(row, column);
  if (value != std::floor(value) || value < static_cast<double>(lo) ||
      value > static_cast<double>(hi)) {
    fail(row, column,
         quote_input(field_text(row, static_cast<std::size_t>(column))) +
             " is not a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  }
  return static_cast<long long>(value);
}

void TextTable::check_non_decreasing(int column) const {
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  check_times(column, Range{-kInfinity, kInfinity, "s"});
}

void TextTable::check_times(int column, const Range& range) const {
  double previous = -std::numeric_limits<double>::infinity();
  int previous_line = 0;
  for (const Row& row : rows_) {
    const double t = number(row, column);
    if (const std::string problem = out_of_range(t, range); !problem.empty()) {
      fail(row, column,
           problem +
               " (a dataset's times are seconds, absolute such as Unix times or relative; "
               "docs/real_data.md)");
    }
    if (t < previous) {
      fail(row, column,
           "time " + short_number(t) + " is before the previous line's (" + short_number(previous) +
               ", line " + std::to_string(previous_line) + "): times must not decrease");
    }
    previous = t;
    previous_line = row.line;
  }
}

TextTable tum_table(const std::filesystem::path& file) {
  return TextTable(file, TextTable::Layout::kWhitespace,
                   {"t", "x", "y", "z", "qx", "qy", "qz", "qw"});
}

StampedPose tum_pose(const TextTable& table, const TextTable::Row& row) {
  const double qx = table.number(row, 4), qy = table.number(row, 5);
  const double qz = table.number(row, 6), qw = table.number(row, 7);
  if (!(std::abs(std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw) - 1.0) < 1e-3))
    table.fail(row, 7, "the quaternion (qx qy qz qw) is not of unit length");
  const double t_s = table.number(row, 0);
  // The yaw of the rotation (z up): its heading in the plane.
  const double yaw = std::atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz));
  return {t_s,
          {table.number(row, 1, kWorldCoordinateRange), table.number(row, 2, kWorldCoordinateRange),
           yaw}};
}

std::vector<StampedPose> read_tum(const std::filesystem::path& file, bool strictly_increasing) {
  const TextTable table = tum_table(file);
  table.check_non_decreasing(0);
  std::vector<StampedPose> poses;
  poses.reserve(table.rows().size());
  for (const auto& row : table.rows()) {
    const StampedPose pose = tum_pose(table, row);
    if (strictly_increasing && !poses.empty() && !(pose.t_s > poses.back().t_s))
      table.fail(row, 0, "the time repeats the previous line's (times must increase)");
    poses.push_back(pose);
  }
  return poses;
}

}  // namespace locsim
