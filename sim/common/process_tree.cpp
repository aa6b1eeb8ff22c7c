#include "sim/common/process_tree.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstring>

namespace locsim {

namespace {

/// The number `text` spells in decimal up to `end` (a character that is not a digit), or -1.
long parse_number(const char* text, const char** end) {
  long value = 0;
  const char* c = text;
  for (; *c >= '0' && *c <= '9'; ++c) value = value * 10 + (*c - '0');
  *end = c;
  return c == text ? -1 : value;
}

}  // namespace

std::size_t list_children(std::span<pid_t> out, std::span<const pid_t> spare) {
  const pid_t self = ::getpid();
  const int proc = ::open("/proc", O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (proc < 0) return 0;
  std::size_t found = 0;
  alignas(8) char entries[8192];
  while (found < out.size()) {
    const ssize_t n = ::getdents64(proc, entries, sizeof(entries));
    if (n <= 0) break;
    for (ssize_t at = 0; at < n && found < out.size();) {
      const auto* entry = reinterpret_cast<const dirent64*>(entries + at);
      at += entry->d_reclen;
      const char* end = nullptr;
      const long pid = parse_number(entry->d_name, &end);
      if (pid <= 0 || *end != '\0' || std::strlen(entry->d_name) > 20) continue;
      if (std::find(spare.begin(), spare.end(), static_cast<pid_t>(pid)) != spare.end()) continue;
      char path[48] = "/proc/";
      std::strcat(path, entry->d_name);
      std::strcat(path, "/stat");
      const int stat = ::open(path, O_RDONLY | O_CLOEXEC);
      if (stat < 0) continue;
      char text[512];
      const ssize_t got = ::read(stat, text, sizeof(text) - 1);
      ::close(stat);
      if (got <= 0) continue;
      text[got] = '\0';
      // "pid (comm) S ppid ...": comm may hold anything, ')' too, so from the last ')'.
      const char* close = std::strrchr(text, ')');
      if (close == nullptr || close[1] != ' ' || close[2] == '\0' || close[3] != ' ') continue;
      if (parse_number(close + 4, &end) == self) out[found++] = static_cast<pid_t>(pid);
    }
  }
  ::close(proc);
  return found;
}

void end_children(std::span<const pid_t> spare) {
  pid_t children[256];
  while (true) {
    const std::size_t count = list_children(children, spare);
    if (count == 0) return;
    for (std::size_t k = 0; k < count; ++k) ::kill(children[k], SIGKILL);
    // Once one is reaped, its own children are this process's (it is their subreaper).
    for (std::size_t k = 0; k < count; ++k) {
      while (::waitpid(children[k], nullptr, 0) < 0 && errno == EINTR) {
      }
    }
  }
}

}  // namespace locsim
