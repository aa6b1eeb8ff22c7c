// Base64 (RFC 4648, the standard alphabet, with padding): binary files carried in JSON text (a
// map image in a log's header), which must be valid UTF-8.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace locsim {

std::string base64_encode(std::string_view bytes);
/// The bytes, or nullopt when `text` is not canonical base64 (a character outside the alphabet,
/// a length that is not a multiple of 4, misplaced padding, or padding bits that are not zero).
std::optional<std::string> base64_decode(std::string_view text);

}  // namespace locsim
