#include "sim/common/files.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "sim/common/errors.hpp"

namespace locsim {

namespace fs = std::filesystem;

std::string read_text(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + file.string() + ": " + std::strerror(errno));
  std::ostringstream content;
  content << in.rdbuf();
  return content.str();
}

namespace {
thread_local const InputSandbox* t_sandbox = nullptr;
}  // namespace

InputSandbox::InputSandbox(std::map<std::string, std::string> files, std::string owner)
    : files_(std::move(files)), owner_(std::move(owner)), outer_(t_sandbox) {
  t_sandbox = this;
}

InputSandbox::~InputSandbox() {
  t_sandbox = outer_;
}

std::string InputSandbox::key(const fs::path& file) {
  return file.lexically_normal().generic_string();
}

bool input_file_exists(const fs::path& file, std::error_code& error) {
  error.clear();
  if (t_sandbox != nullptr) return t_sandbox->files_.contains(InputSandbox::key(file));
  return fs::exists(file, error);
}

std::string InputSandbox::not_carried(const InputSandbox& sandbox) {
  return "not carried by " + sandbox.owner_ +
         " (a replay reads nothing but its log; record the log again with this locsim to carry "
         "the files its world names)";
}

std::string missing_input_file(const fs::path& file, const std::string& what) {
  if (t_sandbox != nullptr)
    return "the " + what + " '" + file.string() + "' is " + InputSandbox::not_carried(*t_sandbox);
  return "no such " + what + " '" + file.string() + "'";
}

std::string read_input_file(const fs::path& file, std::uintmax_t max_bytes) {
  const SourceLocation where{file.string()};
  if (t_sandbox != nullptr) {
    const auto found = t_sandbox->files_.find(InputSandbox::key(file));
    if (found == t_sandbox->files_.end())
      throw InputError(where, "", InputSandbox::not_carried(*t_sandbox));
    if (found->second.size() > max_bytes) {
      throw InputError(where, "",
                       "carried with " + std::to_string(found->second.size()) + " bytes; at most " +
                           std::to_string(max_bytes) + " are read");
    }
    return found->second;
  }
  std::error_code error;
  const fs::file_status status = fs::status(file, error);
  if (error && error.value() == ELOOP)
    throw InputError(where, "", "a symbolic link loop (too many levels of symbolic links)");
  if (error && status.type() != fs::file_type::not_found)
    throw InputError(where, "", "cannot be looked up: " + error.message());
  if (!fs::exists(status)) throw InputError(where, "", "no such file");
  if (fs::is_directory(status)) throw InputError(where, "", "is a directory, not a file");
  if (!fs::is_regular_file(status)) {
    throw InputError(where, "",
                     "is not a regular file (a FIFO, a socket or a device), which locsim does not "
                     "read");
  }
  std::ifstream in(file, std::ios::binary);
  if (!in)
    throw InputError(where, "", std::string("cannot read the file: ") + std::strerror(errno));
  const std::uintmax_t size = fs::file_size(file, error);
  if (!error && size > max_bytes) {
    throw InputError(where, "",
                     "the file has " + std::to_string(size) + " bytes; at most " +
                         std::to_string(max_bytes) + " are read (docs/worlds.md, Limits)");
  }
  // Read at most one byte past the limit: a file that grows stops there.
  std::string content;
  char buffer[65536];
  while (in && content.size() <= max_bytes) {
    in.read(buffer, sizeof(buffer));
    content.append(buffer, static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad()) {
    throw InputError(where, "", std::string("cannot read the file: ") + std::strerror(errno));
  }
  if (content.size() > max_bytes) {
    throw InputError(where, "",
                     "more than " + std::to_string(max_bytes) +
                         " bytes; at most that many are read (docs/worlds.md, Limits)");
  }
  return content;
}

void check_output_folder(const fs::path& dir, std::string_view option) {
  for (fs::path at = dir; !at.empty(); at = at.parent_path()) {
    std::error_code error;
    const fs::file_status status = fs::status(at, error);
    if (fs::exists(status)) {
      if (fs::is_directory(status)) return;
      throw InputError(std::string(option) + ": '" + dir.string() + "' " +
                       (at == dir ? std::string("exists and is not a folder")
                                  : "cannot be made: '" + at.string() + "' is not a folder"));
    }
    if (at == at.parent_path()) return;  // the root
  }
}

namespace {

/// Whether a failed write's `error` (an errno) is the machine's state, exit 1: a full disk, a
/// file-size limit, an I/O error. Any other (no such folder, /proc, read-only, not permitted, a
/// name too long) is the path the user gave, exit 2.
bool machine_fault(int error) {
  return error == ENOSPC || error == EDQUOT || error == EIO || error == EFBIG || error == ENOMEM ||
         error == EMFILE || error == ENFILE;
}

[[noreturn]] void fail_to_write(const std::string& message, int error) {
  if (machine_fault(error)) throw std::runtime_error(message);
  throw InputError(message);
}

}  // namespace

fs::path make_missing_folders(const fs::path& dir, std::string_view what) {
  fs::path made;
  for (fs::path at = dir; !at.empty() && !fs::exists(at); at = at.parent_path()) {
    made = at;
    if (at == at.parent_path()) break;
  }
  if (made.empty()) return made;
  std::error_code error;
  fs::create_directories(dir, error);
  if (error) {
    std::error_code ignored;
    fs::remove_all(made, ignored);
    fail_to_write(
        std::string(what) + "cannot make the folder '" + dir.string() + "': " + error.message(),
        error.value());
  }
  return made;
}

fs::path make_output_folder(const fs::path& dir, std::string_view option) {
  if (dir.empty()) throw InputError(std::string(option) + ": the path is empty");
  check_output_folder(dir, option);
  return make_missing_folders(dir, std::string(option) + ": ");
}

namespace {

/// Writes `content` to `file`.tmp; false (the temporary removed, errno's reason in `reason`) when
/// it could not be written whole.
bool write_temporary(const fs::path& file, std::string_view content, int& error) {
  const fs::path temporary = file.string() + ".tmp";
  std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
  if (out) out.write(content.data(), static_cast<std::streamsize>(content.size()));
  if (out) out.close();
  if (out) return true;
  error = errno;
  std::error_code ignored;
  fs::remove(temporary, ignored);
  return false;
}

}  // namespace

void write_file(const fs::path& file, std::string_view content) {
  write_files({{file, content}});
}

void write_files(const std::vector<std::pair<fs::path, std::string_view>>& files) {
  // Through a temporary file beside each and a rename: a full disk, a file-size limit or a kill
  // leaves the old files or the new ones, never a cut one (a world cut at 4 KiB still loaded), and
  // no temporary. Every file is written before any is renamed, so a pair (calibration.yaml and
  // its .json) is never left half old, half new by a failed write.
  int error = 0;
  for (std::size_t i = 0; i < files.size(); ++i) {
    if (write_temporary(files[i].first, files[i].second, error)) continue;
    for (std::size_t k = 0; k < i; ++k) {
      std::error_code ignored;
      fs::remove(files[k].first.string() + ".tmp", ignored);
    }
    fail_to_write("cannot write " + files[i].first.string() + ": " + std::strerror(error), error);
  }
  for (std::size_t i = 0; i < files.size(); ++i) {
    std::error_code renamed;
    fs::rename(files[i].first.string() + ".tmp", files[i].first, renamed);
    if (!renamed) continue;
    for (std::size_t k = i; k < files.size(); ++k) {
      std::error_code ignored;
      fs::remove(files[k].first.string() + ".tmp", ignored);
    }
    throw std::runtime_error("cannot write " + files[i].first.string() + ": " + renamed.message());
  }
}

void write_json_atomically(const fs::path& file, const nlohmann::ordered_json& content) {
  write_file(file, content.dump(2) + '\n');
}

OutputFile::OutputFile(fs::path path, std::string what)
    : path_(std::move(path)),
      what_(std::move(what)),
      out_(path_, std::ios::binary | std::ios::trunc) {
  if (!out_) {
    const int error = errno;
    fail_to_write("cannot write " + what_ + path_.string() + ": " + std::strerror(error), error);
  }
  pending_.reserve(kBufferBytes);
}

OutputFile::~OutputFile() {
  if (!pending_.empty() && out_.is_open())
    out_.write(pending_.data(), static_cast<std::streamsize>(pending_.size()));
}

void OutputFile::check() {
  if (!out_)
    throw std::runtime_error("cannot write " + what_ + path_.string() + ": " +
                             std::strerror(errno));
}

void OutputFile::write_pending() {
  out_.write(pending_.data(), static_cast<std::streamsize>(pending_.size()));
  pending_.clear();
  check();
}

void OutputFile::flush() {
  write_pending();
  out_.flush();
  check();
}

void OutputFile::close() {
  write_pending();
  out_.close();
  check();
}

}  // namespace locsim
