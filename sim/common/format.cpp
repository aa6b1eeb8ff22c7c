#include "sim/common/format.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <string_view>

namespace locsim {

void append_fixed_exact(std::string& out, double value, int decimals) {
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

namespace {
constexpr std::array<double, 18> kPowersOf10 = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,
                                                1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                                1e12, 1e13, 1e14, 1e15, 1e16, 1e17};

}  // namespace

void append_fixed(std::string& out, double value, int decimals) {
  // The outputs' hot path (a quarter of a run's CPU went to to_chars' exact fixed format): scale
  // to a whole count of the last digit and print that integer with the point put in. The scaled
  // product is within half an ulp of the exact one, so away from a rounding tie it rounds to the
  // same integer as the exact value does; ties and near-ties (within a few ulps), values too large
  // for exact integers, NaN and infinities take the exact path. Byte-identical to it (a test
  // compares millions of values).
  if (decimals >= 0 && decimals < static_cast<int>(kPowersOf10.size())) {
    const double magnitude = std::abs(value * kPowersOf10[static_cast<std::size_t>(decimals)]);
    if (magnitude < 0x1p52) {  // false for NaN and infinities too
      const double whole = std::floor(magnitude);
      const double fraction = magnitude - whole;  // exact
      if (std::abs(fraction - 0.5) > magnitude * 0x1p-50) {
        const auto count = static_cast<std::uint64_t>(whole) + (fraction > 0.5 ? 1u : 0u);
        // The digits right-aligned in zeros (so that at least one precedes the point), then the
        // point moved in: one append of the finished text.
        std::array<char, 48> text{};
        text.fill('0');
        char* const digits_end = text.data() + text.size() - 1;
        char* const digits = digits_end - 20;
        char* const end = std::to_chars(digits, digits_end, count).ptr;
        const auto length = static_cast<int>(end - digits);
        char* first = digits - std::max(0, decimals + 1 - length);
        if (decimals > 0) {  // shift the integer part left by one and put the point in its place
          char* const point = end - decimals;
          std::copy(first, point, first - 1);
          *(point - 1) = '.';
          --first;
        }
        if (value < 0.0 && count != 0) *--first = '-';
        out.append(first, static_cast<std::size_t>(end - first));
        return;
      }
    }
  }
  append_fixed_exact(out, value, decimals);
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
