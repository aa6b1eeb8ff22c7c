// Whole-file reads and writes, every write checked: a file that cannot be written is an error
// naming the path and the system's reason, never a silently short file.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

namespace locsim {

/// The file's bytes. Throws std::runtime_error naming the path and the reason.
std::string read_text(const std::filesystem::path& file);

/// An input file's bytes (a world, scenario, experiment or map). Throws InputError naming the
/// file when it does not exist, is not a regular file (a folder, a FIFO, a device: reading one
/// could block or never end), cannot be read (with the system's reason) or is larger than
/// `max_bytes` (checked before anything is read). Inside an InputSandbox, the sandbox's file.
std::string read_input_file(const std::filesystem::path& file, std::uintmax_t max_bytes);

/// Whether an input file exists (false with `error` set when the system cannot look it up).
/// Inside an InputSandbox: whether the sandbox holds it.
bool input_file_exists(const std::filesystem::path& file, std::error_code& error);
/// What to say of an input file that does not exist: "no such WHAT 'FILE'", or inside an
/// InputSandbox that its owner does not carry it.
std::string missing_input_file(const std::filesystem::path& file, const std::string& what);

/// The files a recorded log carries (a map's YAML and image, a scenario's TUM poses), by the
/// path the loaders ask for them (lexically normal). While a sandbox lives, read_input_file and
/// input_file_exists on its thread see its files and nothing else: a log from someone else is
/// rebuilt from its own bytes, whatever paths it names (absolute, `..`, /proc, /dev). A file it
/// does not hold reads as missing, with a message naming `owner` (the log).
class InputSandbox {
 public:
  InputSandbox(std::map<std::string, std::string> files, std::string owner);
  ~InputSandbox();
  InputSandbox(const InputSandbox&) = delete;
  InputSandbox& operator=(const InputSandbox&) = delete;
  /// The key a file is held under: its path, lexically normal, in generic form.
  static std::string key(const std::filesystem::path& file);

 private:
  friend std::string read_input_file(const std::filesystem::path&, std::uintmax_t);
  friend bool input_file_exists(const std::filesystem::path&, std::error_code&);
  friend std::string missing_input_file(const std::filesystem::path&, const std::string&);
  static std::string not_carried(const InputSandbox& sandbox);
  std::map<std::string, std::string> files_;
  std::string owner_;
  const InputSandbox* outer_;
};

/// Refuses an output folder that cannot be made or written into before anything is written:
/// throws InputError, after `option` (e.g. "--out"), when `dir` exists and is not a folder, or the
/// nearest of its parents that exists is not one (a file given where a folder is meant).
void check_output_folder(const std::filesystem::path& dir, std::string_view option);

/// Makes `dir` and its missing parents; returns the outermost folder it made (remove_all it to
/// undo), empty when `dir` existed. When a folder cannot be made, throws, after `what` (e.g.
/// "cannot write the log x: "): std::runtime_error when the machine is at fault (a full disk, an
/// I/O error), InputError when the path is (a file in the way, /proc, no permission).
std::filesystem::path make_missing_folders(const std::filesystem::path& dir, std::string_view what);

/// An output folder given by `option` (e.g. "--out"), made with its parents: check_output_folder,
/// then make_missing_folders; an empty path is refused. Returns what make_missing_folders does.
std::filesystem::path make_output_folder(const std::filesystem::path& dir, std::string_view option);

/// Writes `content` to `file` (replacing it), through `file`.tmp and a rename: a reader never sees
/// half a file, and a write that fails (a full disk) leaves the old file, or none, and no
/// temporary. Throws, naming the path and the system's reason, std::runtime_error when the
/// machine is at fault (a full disk, a file-size limit, an I/O error: exit 1), InputError when the
/// path is (no such folder, /proc, read-only, not permitted: exit 2).
void write_file(const std::filesystem::path& file, std::string_view content);

/// write_file of several files, all written before any replaces its old version: a failed write
/// leaves every old file (or none) and no temporary.
void write_files(const std::vector<std::pair<std::filesystem::path, std::string_view>>& files);

/// write_file of the JSON text, indented.
void write_json_atomically(const std::filesystem::path& file,
                           const nlohmann::ordered_json& content);

/// A file written as it goes (a run's CSV and TUM files, its log). Writes gather in a buffer of
/// the file's own and go to the system kBufferBytes at a time, or at flush() and close(): a
/// std::ofstream hands every write of 1 KiB or more to the system at once (a laser scan's row was
/// a system call). What goes to the system is checked: a write that fails throws
/// std::runtime_error naming the path (after `what`, e.g. "the log ") and the system's reason.
class OutputFile {
 public:
  static constexpr std::size_t kBufferBytes = 64 << 10;

  /// Creates (or empties) the file. Throws as write_file does when it cannot.
  explicit OutputFile(std::filesystem::path path, std::string what = "");
  /// Hands on what is pending even when not closed (a run that unwinds from an error), as
  /// std::ofstream does; unchecked, as a destructor cannot throw.
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;
  void write(std::string_view text) {
    pending_ += text;
    if (pending_.size() >= kBufferBytes) write_pending();
  }
  /// Hands everything written so far to the system.
  void flush();
  void close();

 private:
  void write_pending();
  void check();
  std::filesystem::path path_;
  std::string what_;
  std::ofstream out_;
  std::string pending_;
};

}  // namespace locsim
