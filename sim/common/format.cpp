#include "sim/common/format.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <string_view>

namespace locsim {

void append_fixed(std::string& out, double value, int decimals) {
  std::array<char, 64> buffer{};
  if (value == 0.0) value = 0.0;  // no "-0.000"
  auto [end, error] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value,
                                    std::chars_format::fixed, decimals);
  if (error != std::errc()) {
    out += "nan";
    return;
  }
  // Negative values that round to zero would print as "-0.000".
  std::string_view text(buffer.data(), end - buffer.data());
  if (text.front() == '-' && text.find_first_not_of("-0.") == std::string_view::npos) {
    text.remove_prefix(1);
  }
  out += text;
}

std::string fixed(double value, int decimals) {
  std::string out;
  append_fixed(out, value, decimals);
  return out;
}

std::string short_number(double value) {
  std::array<char, 64> buffer{};
  const auto [end, error] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  return error == std::errc() ? std::string(buffer.data(), end) : std::string("nan");
}

std::string rounded_number(double value, int significant) {
  std::array<char, 64> buffer{};
  if (value == 0.0) value = 0.0;  // no "-0"
  // Whole numbers (range limits such as 10000000 or 2^62) exactly, digit for digit.
  if (std::abs(value) < 9.3e18 && value == std::trunc(value)) {
    return std::to_string(static_cast<long long>(value));
  }
  const auto [end, error] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value,
                                          std::chars_format::general, significant);
  return error == std::errc() ? std::string(buffer.data(), end) : std::string("nan");
}

void append_tum(std::string& line, double t_s, double x, double y, double theta) {
  append_fixed(line, t_s, 4);
  line += ' ';
  append_fixed(line, x, 6);
  line += ' ';
  append_fixed(line, y, 6);
  line += " 0 0 0 ";
  append_fixed(line, std::sin(0.5 * theta), 9);
  line += ' ';
  append_fixed(line, std::cos(0.5 * theta), 9);
  line += '\n';
}

}  // namespace locsim
