// Output of a process that may print without end (a plugin, a run of a sweep), kept within a
// budget: whole up to `head_bytes`, then only its last `tail_bytes`, with how much was dropped
// between. What it printed first (often the first error) and last (just before it died) stay.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace locsim {

class CappedText {
 public:
  CappedText(std::size_t head_bytes, std::size_t tail_bytes);
  /// Appends `text`; returns the part of it that falls in the head, to pass on at once.
  std::string_view add(std::string_view text);
  std::uint64_t dropped_bytes() const { return dropped_; }
  /// The last bytes past the head (at most tail_bytes), in order; empty while the head is not full.
  std::string tail() const;
  /// Everything kept: the head, then, if anything was dropped, dropped_line() (after
  /// `line_prefix`) on a line of its own, then the tail.
  std::string kept(const std::string& line_prefix = "") const;
  /// The line that stands for what was dropped, e.g. "[...] 123 bytes dropped here [...]".
  std::string dropped_line() const;

 private:
  std::size_t head_bytes_, tail_bytes_;
  std::string head_;
  std::string ring_;         // the tail, as a ring buffer once it is full
  std::size_t ring_at_ = 0;  // where the next byte goes (the oldest byte) once full
  std::uint64_t dropped_ = 0;
};

}  // namespace locsim
