#include "sim/common/errors.hpp"

namespace locsim {

std::string SourceLocation::str() const {
  std::string out = file.empty() ? std::string("<input>") : file;
  if (line > 0) {
    out += ':' + std::to_string(line);
    if (column > 0) out += ':' + std::to_string(column);
  }
  return out;
}

InputError::InputError(const SourceLocation& where, const std::string& key,
                       const std::string& problem)
    : std::runtime_error(where.str() + ": " + (key.empty() ? std::string() : "'" + key + "': ") +
                         problem) {}

}  // namespace locsim
