#include "sim/common/capped_text.hpp"

#include <algorithm>

namespace locsim {

CappedText::CappedText(std::size_t head_bytes, std::size_t tail_bytes)
    : head_bytes_(head_bytes), tail_bytes_(tail_bytes) {}

std::string_view CappedText::add(std::string_view text) {
  const std::size_t to_head = std::min(text.size(), head_bytes_ - head_.size());
  const std::size_t head_start = head_.size();
  head_.append(text.substr(0, to_head));
  text.remove_prefix(to_head);
  for (const char c : text) {
    if (ring_.size() < tail_bytes_) {
      ring_ += c;
      continue;
    }
    if (tail_bytes_ == 0) {
      ++dropped_;
      continue;
    }
    ring_[ring_at_] = c;  // overwrites the oldest byte: it is dropped
    ring_at_ = (ring_at_ + 1) % tail_bytes_;
    ++dropped_;
  }
  return std::string_view(head_).substr(head_start, to_head);
}

std::string CappedText::tail() const {
  return ring_.substr(ring_at_) + ring_.substr(0, ring_at_);
}

std::string CappedText::dropped_line() const {
  return "[... " + std::to_string(dropped_) + " bytes of output dropped here: the first " +
         std::to_string(head_bytes_) + " and the last " + std::to_string(tail_bytes_) +
         " are kept ...]";
}

std::string CappedText::kept(const std::string& line_prefix) const {
  std::string out = head_;
  if (dropped_ > 0) {
    if (!out.empty() && out.back() != '\n') out += '\n';
    out += line_prefix + dropped_line() + '\n';
  }
  return out + tail();
}

}  // namespace locsim
