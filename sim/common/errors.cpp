#include "sim/common/errors.hpp"

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

InputError::InputError(const SourceLocation& where, const std::string& key,
                       const std::string& problem)
    : std::runtime_error(where.str() + ": " + (key.empty() ? std::string() : "'" + key + "': ") +
                         problem) {}

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
