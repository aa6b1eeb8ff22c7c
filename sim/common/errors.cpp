#include "sim/common/errors.hpp"

#include <algorithm>
#include <exception>
#include <vector>

namespace locsim {

std::string SourceLocation::str() const {
  std::string out = file.empty() ? std::string("<input>") : file;
  if (line > 0) {
    out += ':' + std::to_string(line);
    if (column > 0) out += ':' + std::to_string(column);
  }
  return out;
}

namespace {

/// The length of the UTF-8 sequence at `text[i]` that is neither a control character nor a C1
/// control, or 0 when the byte there must be escaped.
std::size_t safe_sequence(std::string_view text, std::size_t i, bool keep_newlines) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char c = byte(i);
  if (c < 0x20) return keep_newlines && (c == '\n' || c == '\t') ? 1 : 0;
  if (c < 0x7f) return 1;
  if (c == 0x7f) return 0;
  std::size_t length = 0;
  unsigned char low = 0x80, high = 0xbf;  // the second byte's range (no overlongs, surrogates)
  if (c >= 0xc2 && c <= 0xdf) {
    length = 2;
    if (c == 0xc2) low = 0xa0;  // U+0080..U+009F are the C1 controls
  } else if (c >= 0xe0 && c <= 0xef) {
    length = 3;
    if (c == 0xe0) low = 0xa0;
    if (c == 0xed) high = 0x9f;
  } else if (c >= 0xf0 && c <= 0xf4) {
    length = 4;
    if (c == 0xf0) low = 0x90;
    if (c == 0xf4) high = 0x8f;
  } else {
    return 0;
  }
  if (i + length > text.size()) return 0;
  if (byte(i + 1) < low || byte(i + 1) > high) return 0;
  for (std::size_t k = 2; k < length; ++k) {
    if (byte(i + k) < 0x80 || byte(i + k) > 0xbf) return 0;
  }
  return length;
}

/// `text` with what must not reach a terminal as \xNN, stopping before `max_bytes` of output;
/// `used` says how many input bytes that took.
std::string escape(std::string_view text, std::size_t max_bytes, bool keep_newlines,
                   std::size_t& used) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  std::size_t i = 0;
  while (i < text.size()) {
    const std::size_t n = safe_sequence(text, i, keep_newlines);
    if (out.size() + (n > 0 ? n : 4) > max_bytes) break;
    if (n > 0) {
      out.append(text.substr(i, n));
      i += n;
    } else {
      const auto c = static_cast<unsigned char>(text[i++]);
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
  }
  used = i;
  return out;
}

}  // namespace

std::string quote_input(std::string_view text, std::size_t max_bytes) {
  std::size_t used = 0;
  std::string out = "'" + escape(text, max_bytes, false, used) + "'";
  if (used < text.size()) out += " (and " + std::to_string(text.size() - used) + " bytes more)";
  return out;
}

std::string printable(std::string_view message, std::size_t max_bytes) {
  std::size_t used = 0;
  if (std::string whole = escape(message, max_bytes, true, used); used == message.size())
    return whole;
  const std::size_t half = max_bytes / 2;
  std::string out = escape(message, half, true, used);
  // Too long: the start (file, line, key) and the end (often the reason), the middle cut.
  const std::size_t tail_from = std::max(used, message.size() - half / 4);
  std::size_t tail_used = 0;
  const std::string tail = escape(message.substr(tail_from), half, true, tail_used);
  return out + " [... " + std::to_string(tail_from - used) + " bytes cut ...] " + tail;
}

InputError::InputError(const SourceLocation& where, const std::string& key,
                       const std::string& problem)
    : std::runtime_error(printable(where.str() + ": " +
                                   (key.empty() ? std::string() : "'" + key + "': ") + problem)) {}

namespace {
thread_local std::vector<std::string> t_stages;
thread_local std::string t_failed;
}  // namespace

Activity::Activity(std::string what) : uncaught_at_start_(std::uncaught_exceptions()) {
  t_failed.clear();
  t_stages.push_back(std::move(what));
}

Activity::~Activity() {
  if (std::uncaught_exceptions() > uncaught_at_start_) {
    // The innermost scope an exception leaves records the whole chain; the outer ones keep it.
    if (t_failed.empty()) {
      for (const std::string& s : t_stages) t_failed += (t_failed.empty() ? "" : ": ") + s;
    }
  } else {
    t_failed.clear();  // an exception that was caught inside is no longer the story
  }
  t_stages.pop_back();
}

std::string Activity::failed() {
  return t_failed;
}

}  // namespace locsim
