// Text formats of the outputs: fixed-precision decimals independent of the C locale (so that the
// same numbers always print the same bytes) and TUM trajectory rows.
#pragma once

#include <string>

namespace locsim {

/// Fixed-precision decimal text, independent of the C locale; never "-0.000". Appends to `out`.
void append_fixed(std::string& out, double value, int decimals);
/// The same text by std::to_chars' exact fixed format (slower): append_fixed's reference.
void append_fixed_exact(std::string& out, double value, int decimals);
std::string fixed(double value, int decimals);

/// A number for a message, short and exact: the shortest text that reads back as `value`
/// ("1e+38", "0.05", "10000"), never hundreds of digits.
std::string short_number(double value);

/// A number rounded to `significant` digits for a message ("0.0174533", "5.72958e+07"); whole
/// numbers exactly ("170", "10000000").
std::string rounded_number(double value, int significant = 6);

/// One TUM row, `t x y 0 0 0 qz qw`, for a planar pose (read unchanged by evo).
void append_tum(std::string& line, double t_s, double x, double y, double theta);

}  // namespace locsim
