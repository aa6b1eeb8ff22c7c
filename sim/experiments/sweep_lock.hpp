// Who writes a sweep folder: one locsim at a time, by an flock(2) on DIR/sweep.lock.
#pragma once

#include <filesystem>
#include <string>

namespace locsim {

/// Who holds `dir`'s lock as its file says ("locsim sweep (pid 123)"), or "" when no one does;
/// without taking it.
std::string lock_holder(const std::filesystem::path& dir);

/// Whether `dir` holds anything but its lock file and the entry named `kept` (when not empty).
bool holds_files(const std::filesystem::path& dir, const std::string& kept = "");

/// One locsim at a time writes a sweep folder: a sweep (or --resume) holds an exclusive flock(2)
/// on DIR/sweep.lock from before it reads DIR until it ends, and merge on the folder it makes.
/// The kernel drops the lock when its holder dies, however it dies: a sweep killed with SIGKILL
/// leaves its lock file, held by no one, and the next --resume takes it. (A pid file alone
/// would have to guess whether its pid still is that sweep.) The file names its holder for the
/// message of whoever finds it held.
class FolderLock {
 public:
  /// Takes `dir`'s lock for `command` ("sweep" or "merge"), making the folder when missing.
  /// Throws InputError, after `option`, naming the folder and the holder when another process
  /// holds it; nothing is written then.
  FolderLock(const std::filesystem::path& dir, const std::string& command,
             const std::string& option);
  ~FolderLock() { release(); }
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;

 private:
  /// Removes the file while still holding it (see the constructor), then a folder the lock made
  /// that nothing was written into (a refused sweep leaves nothing).
  void release();

  std::filesystem::path dir_, file_;
  int fd_ = -1;
  bool made_dir_ = false;
};

}  // namespace locsim
