// Error types and the exit codes the CLI maps them to (documented in `locsim --help`).
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>

namespace locsim {

enum ExitCode : int {
  kExitOk = 0,
  kExitFailure = 1,          // anything not caused by the user's input
  kExitBadInput = 2,         // bad command line, or a world/scenario/map file that cannot be used
  kExitPlugin = 3,           // a localizer plugin cannot be found, loaded or created
  kExitRender = 4,           // the renderer cannot be loaded, or a video or frame cannot be written
  kExitLocalizerFailed = 5,  // the run completed, but a localizer failed (metrics.json says how)
  kExitInterrupted = 130,    // SIGINT; the run folder holds everything written so far
};

/// The longest message an error carries [bytes]: a 50 MB line of someone's dataset must not
/// become a 50 MB message.
inline constexpr std::size_t kMaxMessageBytes = 8 << 10;

/// Untrusted text (a field of a dataset, a name in a log's header, a value from a YAML file)
/// fit to stand in a message: in single quotes, with control characters, C1 controls and bytes
/// that are not UTF-8 written as \xNN (an escape sequence must not reach the terminal), cut
/// after `max_bytes` with how many bytes were left out.
std::string quote_input(std::string_view text, std::size_t max_bytes = 120);

/// A whole message fit for a terminal or a log line: escaped as quote_input() does, but newlines
/// and tabs kept, and no longer than `max_bytes`: past that its middle is cut, keeping its start
/// (the file and line) and its end. InputError and PluginError pass their messages through it.
std::string printable(std::string_view message, std::size_t max_bytes = kMaxMessageBytes);

/// Where in a file something was found. Line and column are 1-based; 0 means unknown.
struct SourceLocation {
  std::string file;
  int line = 0;
  int column = 0;

  /// "file:line:col", or less where less is known.
  std::string str() const;
};

/// A value's place in an input file, so that a problem found after loading (a world that does
/// not fit in memory, a plugin that rejects a parameter) is reported where the user can fix it.
struct InputPlace {
  SourceLocation where;
  std::string key;  // e.g. "localizers[1].grid.gain[0]"
};

/// The user's input cannot be used. The message names the file, line, column and key.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(printable(message)) {}
  InputError(const SourceLocation& where, const std::string& key, const std::string& problem);
  InputError(const InputPlace& place, const std::string& problem)
      : InputError(place.where, place.key, problem) {}
};

/// A localizer plugin cannot be used: not found, not a plugin, wrong ABI, unresolved symbols,
/// or its create call failed. The message names the plugin and the file.
class PluginError : public std::runtime_error {
 public:
  explicit PluginError(const std::string& message) : std::runtime_error(printable(message)) {}
};

/// The renderer (render/, loaded at run time for --video and --frames) cannot be loaded, its GL
/// context cannot be made, or a video or frame file cannot be opened or written.
/// Header-only, unlike the others: the render module (a shared library loaded at run time, not
/// linked with the core) throws it; the CLI makes its message printable where it prints it.
class RenderError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What locsim is doing, for the message of an error that cannot say what it was building
/// (std::bad_alloc): an Activity names a stage for its scope; scopes nest. The bounds on every
/// input are meant to make such errors unreachable; this is the message if one is not.
class Activity {
 public:
  explicit Activity(std::string what);
  ~Activity();
  Activity(const Activity&) = delete;
  Activity& operator=(const Activity&) = delete;

  /// The stages an exception left last, innermost last ("running x.yaml: building the world"),
  /// or "" when none.
  static std::string failed();

 private:
  int uncaught_at_start_;
};

/// Ctrl-C reached a wait (for a plugin's process, say): the run ends as "interrupted".
class Interrupted : public std::runtime_error {
 public:
  Interrupted() : std::runtime_error("interrupted") {}
};

}  // namespace locsim
