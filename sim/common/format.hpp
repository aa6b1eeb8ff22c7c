// Text formats of the outputs: fixed-precision decimals independent of the C locale (so that the
// same numbers always print the same bytes) and TUM trajectory rows.
#pragma once

#include <string>

namespace locsim {

/// Fixed-precision decimal text, independent of the C locale; never "-0.000". Appends to `out`.
void append_fixed(std::string& out, double value, int decimals);
std::string fixed(double value, int decimals);

/// One TUM row, `t x y 0 0 0 qz qw`, for a planar pose (read unchanged by evo).
void append_tum(std::string& line, double t_s, double x, double y, double theta);

}  // namespace locsim
