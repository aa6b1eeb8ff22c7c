// A table of numbers in a text file, as datasets ship them: whitespace-separated columns
// (MRCLAM's .dat, TUM trajectories) or comma-separated ones with a header row (CSV). Every value
// keeps its line and column, so that a bad one is reported where the user can fix it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "sim/common/errors.hpp"
#include "sim/common/math.hpp"
#include "sim/common/range.hpp"

namespace locsim {

class TextTable {
 public:
  enum class Layout {
    kWhitespace,  // columns separated by spaces and tabs; lines starting with '#' are comments
    kCsv,         // columns separated by commas (spaces around them ignored); a header row first;
                  // lines starting with '#' are comments
  };
  /// A data line: where its fields are in the table's list of fields. 16 bytes, and 8 a field:
  /// a table of millions of lines costs little beside its text (the fields were vectors of their
  /// own, about 170 bytes a line).
  struct Row {
    int line = 0;                  // 1-based
    std::uint32_t line_start = 0;  // byte offset of the line in the text
    std::uint32_t first = 0;       // index of its first field
    std::uint32_t count = 0;       // how many fields it has
  };

  /// Reads the file. `names` are the columns' names for messages (kWhitespace), or the columns a
  /// kCsv header must name (more may follow in `optional`). Throws InputError naming the file
  /// when it cannot be read (saying so of a symbolic link loop, which is not a missing file), is
  /// empty of data, or a header lacks a required column.
  TextTable(const std::filesystem::path& file, Layout layout, std::vector<std::string> names,
            std::vector<std::string> optional = {});

  const std::filesystem::path& file() const { return file_; }
  const std::vector<Row>& rows() const { return rows_; }
  /// The index of a named column, or -1 when the header lacks it (an optional column).
  int column(std::string_view name) const;
  /// The row's value in column `column` as a finite number; InputError (file:line:col and the
  /// column's name) when the row is too short, or the field is not a finite number.
  double number(const Row& row, int column) const;
  /// The same, also within `range` (a world file's range for the quantity: a Vicon x of 1e30 is
  /// refused here, at its line, not downstream).
  double number(const Row& row, int column, const Range& range) const;
  /// A whole number in [lo, hi].
  long long whole(const Row& row, int column, long long lo, long long hi) const;
  /// The field's text ("" when the row is too short and the column optional).
  std::string_view text(const Row& row, int column) const;
  /// The name of column `column` ("" when it has none).
  std::string column_name(int column) const;
  /// The 1-based character column in its line of the row's field `column` (0 when the row lacks
  /// it): where a message points.
  int column_in_line(const Row& row, int column) const;
  /// Throws InputError at the row (and the column, when >= 0).
  [[noreturn]] void fail(const Row& row, int column, const std::string& problem) const;
  /// Checks that column `column` never decreases from row to row (times).
  void check_non_decreasing(int column) const;
  /// The same, and that every row's time is within `range`, in one pass: the first bad row is
  /// named, whichever its fault.
  void check_times(int column, const Range& range) const;

 private:
  void need(const Row& row, int column) const;
  /// Field `i` of `row` (which has it).
  std::string_view field_text(const Row& row, std::size_t i) const {
    const Field& f = fields_[row.first + i];
    return std::string_view(text_).substr(f.offset, f.length);
  }
  struct Field {
    std::uint32_t offset = 0, length = 0;  // in text_ [bytes]
  };
  std::filesystem::path file_;
  std::string text_;
  std::vector<std::string> names_;
  std::vector<Row> rows_;
  std::vector<Field> fields_;
};

/// What a dataset's file or folder is: file_type::not_found when there is none. Throws InputError
/// naming it when the system cannot tell (a symbolic link loop, a folder on its way that cannot be
/// searched): taking that for "no such file", or letting std::filesystem throw, would send the
/// user looking for the wrong problem.
std::filesystem::file_type dataset_file_type(const std::filesystem::path& path);

/// A TUM trajectory file as a table: columns t x y z qx qy qz qw, whitespace-separated, '#'
/// comments (for a reader that needs each pose's line).
TextTable tum_table(const std::filesystem::path& file);
/// A row of tum_table's as a planar pose (z ignored; the heading is the quaternion's yaw).
/// Throws InputError at the line and column of a bad value or a quaternion not of unit length.
StampedPose tum_pose(const TextTable& table, const TextTable::Row& row);

/// A TUM trajectory file (`t x y z qx qy qz qw` per line, '#' comments; z ignored): planar poses,
/// times never decreasing (increasing with `strictly_increasing`). Throws InputError at the line
/// and column of a bad value, a quaternion not of unit length, or a time that goes back.
std::vector<StampedPose> read_tum(const std::filesystem::path& file,
                                  bool strictly_increasing = false);

}  // namespace locsim
