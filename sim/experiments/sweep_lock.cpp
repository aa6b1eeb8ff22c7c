#include "sim/experiments/sweep_lock.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <thread>

#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"

namespace locsim {

namespace fs = std::filesystem;

namespace {

/// The file whose flock(2) says who writes a sweep folder (docs/experiments.md).
constexpr const char* kLockFile = "sweep.lock";

/// Who holds the lock file `file` as it says ("locsim sweep (pid 123)"). The holder writes it
/// just after taking the lock: a reader that comes in between waits for it a little.
std::string holder_of(const fs::path& file) {
  for (int attempt = 0; attempt < 20; ++attempt) {
    std::ifstream in(file);
    long pid = 0;
    std::string command;
    if (in >> pid >> command && pid > 0 && (command == "sweep" || command == "merge"))
      return "locsim " + command + " (pid " + std::to_string(pid) + ")";
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return "another locsim (pid unknown)";
}

}  // namespace

std::string lock_holder(const fs::path& dir) {
  const int fd = ::open((dir / kLockFile).c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return {};  // a live holder always has the file
  const bool held = ::flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);  // drops the shared lock, when taken
  return held ? holder_of(dir / kLockFile) : std::string();
}

bool holds_files(const fs::path& dir, const std::string& kept) {
  if (!fs::is_directory(dir)) return false;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir)) {
    const fs::path name = entry.path().filename();
    if (name != kLockFile && (kept.empty() || name != kept)) return true;
  }
  return false;
}

FolderLock::FolderLock(const fs::path& dir, const std::string& command, const std::string& option)
    : dir_(dir), file_(dir / kLockFile) {
  made_dir_ = !make_output_folder(dir, option).empty();
  for (;;) {
    fd_ = ::open(file_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0)
      throw std::runtime_error("cannot open " + file_.string() + ": " + std::strerror(errno));
    if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      const int error = errno;
      ::close(fd_);
      fd_ = -1;
      if (error != EWOULDBLOCK)
        throw std::runtime_error("cannot lock " + file_.string() + ": " + std::strerror(error));
      throw InputError(option + ": '" + dir.string() + "' is in use by " + holder_of(file_) +
                       ": one locsim at a time writes a sweep folder; wait for it to end (a "
                       "sweep that was killed holds nothing: --resume then finishes it)");
    }
    // Its holder may have removed the file (ending) between the open and the lock: this lock
    // is then on a file nobody else finds. The one at the path is the lock.
    struct stat held {
    }, named{};
    if (::fstat(fd_, &held) == 0 && ::stat(file_.c_str(), &named) == 0 &&
        held.st_dev == named.st_dev && held.st_ino == named.st_ino) {
      break;
    }
    ::close(fd_);
    fd_ = -1;
  }
  const std::string holder = std::to_string(::getpid()) + " " + command + "\n";
  if (::ftruncate(fd_, 0) != 0 ||
      ::pwrite(fd_, holder.data(), holder.size(), 0) != static_cast<ssize_t>(holder.size())) {
    const std::string reason = std::strerror(errno);
    release();
    throw std::runtime_error("cannot write " + file_.string() + ": " + reason);
  }
}

void FolderLock::release() {
  if (fd_ < 0) return;
  ::unlink(file_.c_str());
  ::close(fd_);
  fd_ = -1;
  std::error_code ignored;
  if (made_dir_) fs::remove(dir_, ignored);  // only when empty
}

}  // namespace locsim
