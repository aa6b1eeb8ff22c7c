#include "sim/common/range.hpp"

#include "sim/common/format.hpp"
#include "sim/common/math.hpp"

namespace locsim {

namespace {
/// An angle's range ("rad", "rad/s") is shown in degrees ("deg", "deg/s") for a `_deg` key.
bool shown_in_degrees(const Range& range, bool degrees) {
  return degrees && range.unit.starts_with("rad");
}

std::string with_unit(const std::string& number, const Range& range, bool degrees) {
  if (range.unit.empty()) return number;
  if (shown_in_degrees(range, degrees)) return number + " deg" + std::string(range.unit.substr(3));
  return number + " " + std::string(range.unit);
}
}  // namespace

std::string describe(const Range& range, bool degrees) {
  const bool in_degrees = shown_in_degrees(range, degrees);
  const auto bound = [&](double value) {
    return rounded_number(in_degrees ? rad_to_deg(value) : value);
  };
  return with_unit("[" + bound(range.min) + ", " + bound(range.max) + "]", range, degrees);
}

std::string out_of_range(double value, const Range& range, bool degrees) {
  if (range.contains(shown_in_degrees(range, degrees) ? deg_to_rad(value) : value)) return {};
  return with_unit(short_number(value), range, degrees) + " is outside " + describe(range, degrees);
}

}  // namespace locsim
