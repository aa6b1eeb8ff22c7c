// A full disk for one file, for tests (LD_PRELOAD): every fopen of a path ending in
// $LOCSIM_TEST_FULL_FILE opens /dev/full instead, so that its writes fail with ENOSPC while every
// other file is written as usual. (A symbolic link to /dev/full in the run folder did this before
// --overwrite emptied the folder.) std::ofstream opens through fopen64.
#include <dlfcn.h>

#include <cstdio>
#include <cstdlib>
#include <string_view>

namespace {

const char* redirect(const char* path) {
  const char* full = std::getenv("LOCSIM_TEST_FULL_FILE");
  if (path == nullptr || full == nullptr || *full == '\0') return path;
  return std::string_view(path).ends_with(full) ? "/dev/full" : path;
}

using Open = FILE* (*)(const char*, const char*);

}  // namespace

extern "C" FILE* fopen64(const char* path, const char* mode) {
  static const auto real = reinterpret_cast<Open>(dlsym(RTLD_NEXT, "fopen64"));
  return real(redirect(path), mode);
}

extern "C" FILE* fopen(const char* path, const char* mode) {
  static const auto real = reinterpret_cast<Open>(dlsym(RTLD_NEXT, "fopen"));
  return real(redirect(path), mode);
}
