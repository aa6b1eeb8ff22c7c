// libFuzzer target: bytes → a log file (`locsim run --log`) through the reader: the header and
// every record decoded (stream/log_file, stream/record_codec); then through `locsim replay`: the
// log source that rebuilds the world and scenario from the text the header carries, and the
// consumers: the run folder's recorder (ground truth, events, readings), the scorer, and a
// localizer host running the test plugin `test_probe` in this process (so that a reading its
// robot cannot have reaches the translation into the plugin ABI here, not in a worker).
//
// Mutated bytes almost never keep a record's CRC-32 right, which would stop every input at the
// checksum; the custom mutator below recomputes the checksums of most mutants, so that the
// decoders behind them are reached (and leaves some wrong, so the checks are fuzzed too).
//
// Expected outcome: InputError (the log is corrupt or truncated, with the byte and record).
// Anything else is a finding, and so is a replay that opens a file outside the log: a valid map
// is planted in kPlanted, watched with inotify, and any open of it (a header whose world names it,
// by an absolute path or through `..`; tests/fuzz/regressions/log/planted-*) aborts. Run:
// docs/testing.md.
#include <sys/inotify.h>
#include <sys/mman.h>
#include <unistd.h>
#include <zlib.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "sim/common/errors.hpp"
#include "sim/run/replay.hpp"
#include "sim/stream/log_file.hpp"

extern "C" std::size_t LLVMFuzzerMutate(std::uint8_t* data, std::size_t size, std::size_t max_size);

namespace {

// The log's framing (stream/log_file.hpp): "LOCSIMLG", u32 version, u32 header length, header,
// u32 CRC; then records of u8 type, u32 length, payload, u32 CRC.
constexpr std::size_t kHeaderTextAt = 8 + 4 + 4;

std::uint32_t load_u32(const std::uint8_t* p) {
  std::uint32_t v;
  std::memcpy(&v, p, 4);
  return v;
}

void store_crc(std::uint8_t* data, std::size_t at, std::size_t end, std::uint8_t first) {
  uLong c = crc32(0L, Z_NULL, 0);
  c = crc32(c, &first, 1);
  c = crc32(c, data + at, static_cast<uInt>(end - at));
  const auto v = static_cast<std::uint32_t>(c);
  std::memcpy(data + end, &v, 4);
}

// Rewrites the header's and each record's CRC where the lengths hold; stops where they do not.
void fix_checksums(std::uint8_t* data, std::size_t size) {
  if (size < kHeaderTextAt) return;
  const std::size_t header_length = load_u32(data + 12);
  if (header_length > size - kHeaderTextAt || size - kHeaderTextAt - header_length < 4) return;
  store_crc(data, kHeaderTextAt, kHeaderTextAt + header_length, 0);
  std::size_t at = kHeaderTextAt + header_length + 4;
  while (size - at >= 1 + 4) {
    const std::uint8_t type = data[at];
    const std::size_t length = load_u32(data + at + 1);
    const std::size_t payload_at = at + 1 + 4;
    if (length > size - payload_at || size - payload_at - length < 4) return;
    // The CRC covers the type byte, then the payload.
    store_crc(data, payload_at, payload_at + length, type);
    at = payload_at + length + 4;
  }
}

namespace fs = std::filesystem;

// The input as a file the reader can open by name, without touching the disk.
int g_fd = -1;
std::string g_path;
// The replay's run folder, in memory where there is a tmpfs.
fs::path g_out;

// A map a log from someone else might name, and the watch on it.
constexpr const char* kPlanted = "/tmp/locsim-fuzz-planted";
int g_watch_fd = -1;

void plant() {
  // Written only where missing: another fuzz_log process may be watching them already.
  fs::create_directories(kPlanted);
  if (!fs::exists(fs::path(kPlanted) / "map.yaml")) {
    std::ofstream(fs::path(kPlanted) / "map.yaml")
        << "image: map.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n";
  }
  if (!fs::exists(fs::path(kPlanted) / "map.pgm")) {
    std::ofstream(fs::path(kPlanted) / "map.pgm", std::ios::binary) << "P5 4 4 255\n"
                                                                    << std::string(16, '\xff');
  }
  g_watch_fd = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
  if (g_watch_fd < 0 || inotify_add_watch(g_watch_fd, kPlanted, IN_OPEN | IN_ACCESS) < 0) {
    std::perror("fuzz_log: inotify");
    std::abort();
  }
}

void abort_if_planted_file_opened() {
  char events[4096];
  if (read(g_watch_fd, events, sizeof(events)) > 0) {
    std::fprintf(stderr, "fuzz_log: the replay opened a file in %s, outside its log\n", kPlanted);
    std::abort();
  }
}

void remove_out() {
  std::error_code ignored;
  fs::remove_all(g_out, ignored);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  g_fd = memfd_create("fuzz_log", 0);
  if (g_fd < 0) {
    std::perror("memfd_create");
    std::abort();
  }
  g_path = "/proc/self/fd/" + std::to_string(g_fd);
  const fs::path tmp =
      fs::is_directory("/dev/shm") ? fs::path("/dev/shm") : fs::temp_directory_path();
  std::string dir_template = (tmp / "locsim_fuzz_log.XXXXXX").string();
  if (mkdtemp(dir_template.data()) == nullptr) {
    std::perror("mkdtemp");
    std::abort();
  }
  g_out = fs::path(dir_template) / "replay";
  std::atexit(remove_out);
  plant();
  return 0;
}

extern "C" std::size_t LLVMFuzzerCustomMutator(std::uint8_t* data, std::size_t size,
                                               std::size_t max_size, unsigned int seed) {
  size = LLVMFuzzerMutate(data, size, max_size);
  if (seed % 8 != 0) fix_checksums(data, size);
  return size;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (ftruncate(g_fd, 0) != 0 || pwrite(g_fd, data, size, 0) != static_cast<ssize_t>(size)) {
    std::perror("fuzz_log: writing the input");
    std::abort();  // not a finding in locsim: the harness cannot work
  }
  bool header_ok = false;
  try {
    locsim::LogReader reader(g_path);
    header_ok = true;
    locsim::Record record;
    while (reader.next(record)) {
    }
  } catch (const locsim::InputError&) {
  }
  if (header_ok) {
    locsim::ReplayOptions options;
    options.log_file = g_path;
    options.out_dir = g_out;
    options.overwrite = true;
    options.localizers = {LOCSIM_PROBE_PLUGIN};
    options.isolate = false;
    try {
      locsim::replay_log(options);
    } catch (const locsim::InputError&) {
    }
  }
  abort_if_planted_file_opened();
  return 0;
}
