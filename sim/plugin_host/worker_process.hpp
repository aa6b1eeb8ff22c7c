// A localizer worker: a child process (fork, no exec) that runs an InstanceRunner on the records
// its parent sends, so that a plugin that crashes, aborts, calls exit() or hangs takes down only
// its own process. The parent sends framed records over a Unix socket, in batches; the child
// answers each true pose with an estimate sample, snapshots on request (video frames) and its
// final state at the end. Which call it is in, and since when, it keeps in a page of memory shared
// with the parent, whose watchdog kills a call that outlasts --plugin-timeout.
//
// The child's answers gather in memory shared with the parent (ReplyStage) and go out in one
// write before the child waits for more records: one system call per batch, where one per sample
// (a sample per true pose, 50 a simulated second per localizer) was most of what isolating a
// filter cost. A child that dies (a crash, exit(), the watchdog) leaves its unsent answers there,
// and the parent takes them after the last byte of the socket: what arrives is what the filter
// computed before it died, whatever the timing.
//
// Whatever a plugin starts ends with its worker. The worker is not the parent's child but a
// grandchild: between them a keeper (a fork that runs no plugin code) is the subreaper of the
// worker's whole tree, so that a process the plugin forks, daemonises (double fork, setsid) or
// leaves ignoring SIGTERM stays its descendant. When the worker ends (its final answer, a crash,
// the watchdog, Ctrl-C, locsim's end or death) the keeper kills the worker's process group and
// every process left in its tree, level by level, and ends only when none is left; the parent
// waits for the keeper, never for a pipe a stray process might hold. A process the plugin forks
// loses the protocol (the socket becomes /dev/null and the shared memory its own, at fork), so
// that a copy of the worker that returns from the plugin answers nothing twice.
//
// The protocol socket is the worker's descriptor protocol_fd() (the highest below 1024 that the
// descriptor limit allows), close-on-exec, where a plugin does not write by accident; a frame
// that is not locsim's (an unknown type, an implausible length, a payload that does not decode,
// an estimate for a time it was not given) fails the localizer with what it sent, keeping what
// came before.
//
// The child's stdout and stderr go to a pipe that the parent reads whenever it waits for its
// workers, and forwards to its own stderr, each line prefixed with "[LABEL] ": a plugin's prints
// arrive in order and labelled, without blocking the plugin, and without end no more: after the
// first kOutputHeadBytes only the last kOutputTailBytes are kept, printed when the worker ends
// after a line saying how much was dropped. The parent reads a bounded amount each time, so a
// process that prints without pause cannot keep it reading.
//
// Frames, both ways: u8 type, u32 payload length, payload (stream/record_codec for records).
#pragma once

#include <sys/socket.h>
#include <sys/types.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "sim/common/capped_text.hpp"
#include "sim/plugin_host/instance_runner.hpp"

namespace locsim {

/// How much of what a localizer's process prints is forwarded: the first and the last bytes.
inline constexpr std::size_t kOutputHeadBytes = 1 << 20, kOutputTailBytes = 64 << 10;

/// The child's answers not yet sent, in memory shared with the parent (see above). Both counters
/// are bytes of the child-to-parent stream: what was sent before data[0], and how much of data
/// holds whole frames (a frame is counted only once it is all there).
struct ReplyStage {
  static constexpr std::size_t kCapacity = 64 << 10;  // a larger answer is sent at once [bytes]
  std::atomic<std::uint64_t> base{0};
  std::atomic<std::uint64_t> used{0};
  char data[kCapacity];
};
static_assert(std::atomic<std::uint64_t>::is_always_lock_free, "shared between processes");

/// How a localizer's process is run.
struct WorkerLimits {
  /// --plugin-memory: memory the worker may allocate beyond what it starts with (RLIMIT_DATA);
  /// 0: no limit [bytes]
  std::uint64_t memory_bytes = 0;
};

class WorkerProcess {
 public:
  /// Forks the keeper, which forks the worker, which creates `defs`' instances and says whether
  /// that worked (`wait_ready` reads the answer). The parent's stdio is flushed first. `label`
  /// prefixes the lines the child prints.
  WorkerProcess(const std::vector<const LocalizerDef*>& defs, std::string label,
                const WorkerLimits& limits = {});
  ~WorkerProcess();  // kills the worker's tree if it still runs
  WorkerProcess(const WorkerProcess&) = delete;
  WorkerProcess& operator=(const WorkerProcess&) = delete;

  int fd() const { return fd_; }
  /// The read end of the child's stdout and stderr; -1 once it is closed.
  int output_fd() const { return output_fd_; }
  /// Reads what the child printed, without blocking and at most a few MiB (a process that prints
  /// without pause cannot keep the parent here), and forwards it (within the cap).
  void forward_output();
  bool alive() const { return fd_ >= 0; }
  const std::vector<std::size_t>& indices() const { return indices_; }
  bool serves_robot(std::size_t robot) const { return robot < robots_.size() && robots_[robot]; }

  /// Queues a frame (type and payload) for the child.
  void queue(std::uint8_t type, std::string_view payload);
  std::size_t pending_bytes() const { return out_.size() - out_sent_; }
  /// Sends what the socket takes now, without blocking. False when the child is gone.
  bool send_some();

  /// Reads what arrived (at most a few hundred KiB, so that the parent's memory stays small
  /// whatever the backlog), without blocking, and hands each complete message to
  /// `handle(type, payload)`. Returns false once the child has closed its end (it ended or died;
  /// see `reap`), after handing over the answers it staged and never sent, or once what it sent
  /// is not the protocol (`reject`; then the worker has been killed and nothing more is handed
  /// over).
  template <class Handle>
  bool receive_some(Handle&& handle);
  /// What the worker sent is not the protocol: `what` says how. Kills it; `receive_some` hands
  /// over nothing more. The first reason is kept.
  void reject(std::string what);
  /// Why what the worker sent was rejected (empty: it was not).
  const std::string& rejected() const { return rejected_; }
  /// Bytes received from the worker that were not handed over (from the first bad frame on).
  std::size_t unread_bytes() const { return in_.size(); }

  /// After the socket closed: waits for the keeper (the worker and everything it started have
  /// ended then), forwarding what the worker printed meanwhile, then the kept tail, and says how
  /// the worker ended ("killed by signal 11 (Segmentation fault)", "exited with code 0"); the
  /// signal, if one ended it.
  std::string reap(std::optional<int>* signal = nullptr);
  /// Kills the worker and its whole tree now (SIGKILL), e.g. after a timeout or on Ctrl-C.
  void kill_now();
  /// locsim killed it (kill_now), rather than it ending by itself or being killed by another.
  bool killed_by_locsim() const { return killed_by_locsim_; }
  /// An allocation failed in the worker while it had a memory limit (its operator new's handler
  /// saw it).
  bool out_of_memory() const;
  const WorkerLimits& limits() const { return limits_; }

  /// The call the child is in, if any: which, since when (steady clock), at what simulated time,
  /// for which localizer.
  struct Call {
    bool in_call = false;  // else: the last call it made, which has returned
    PluginCall call = PluginCall::kNone;
    std::chrono::steady_clock::time_point started;
    double t_s = 0.0;
    int localizer = -1;
  };
  std::optional<Call> current_call() const;
  /// The call it is in or last made (after it died: the one it died in, if `in_call`).
  Call last_call() const;

  bool timed_out = false;  // killed by the watchdog
  bool ready = false;      // its instances were created
  bool finished = false;   // it sent its final state

 private:
  void write_output(std::string_view text);
  pid_t keeper_ = -1;
  int fd_ = -1;
  int output_fd_ = -1;
  std::string label_;
  WorkerLimits limits_;
  CappedText output_{kOutputHeadBytes, kOutputTailBytes};
  bool at_line_start_ = true;
  bool killed_by_locsim_ = false;
  std::string rejected_;
  struct Shared;
  Shared* shared_ = nullptr;     // mapped shared with the child
  CallState* calls_ = nullptr;   // in shared_
  ReplyStage* stage_ = nullptr;  // in shared_
  std::uint64_t received_ = 0;   // bytes read from the socket
  std::vector<std::size_t> indices_;
  std::vector<bool> robots_;
  std::string out_;
  std::size_t out_sent_ = 0;
  std::string in_;
};

/// The worker's descriptor of the protocol socket: the highest below 1024 its descriptor limit
/// allows (1023 as a rule), far from the low numbers a plugin's own files get.
int protocol_fd();

/// Message types. Parent to child: the record types (1, 2, 3), then:
inline constexpr std::uint8_t kWorkerSnapshotRequest = 10;  // f64 t
inline constexpr std::uint8_t kWorkerFinish = 11;           // f64 t_end
/// Child to parent:
inline constexpr std::uint8_t kWorkerReady = 30;         // (empty)
inline constexpr std::uint8_t kWorkerCreateFailed = 31;  // str message
inline constexpr std::uint8_t kWorkerSample = 32;        // EstimateSample
inline constexpr std::uint8_t kWorkerFailure = 33;       // LocalizerFailure
inline constexpr std::uint8_t kWorkerSnapshot = 34;      // u32 n, n LocalizerSnapshot
inline constexpr std::uint8_t kWorkerFinal = 35;         // u32 n, n LocalizerFinal

/// The longest payload a frame of `type` from the worker may have; -1 for a type that is not one
/// the worker sends. (A snapshot carries a particle cloud; 1 GiB is far above any real one.)
constexpr std::int64_t max_reply_bytes(std::uint8_t type) {
  switch (type) {
    case kWorkerReady:
      return 0;
    case kWorkerCreateFailed:
    case kWorkerSample:
    case kWorkerFailure:
      return 64 << 20;
    case kWorkerSnapshot:
    case kWorkerFinal:
      return 1 << 30;
    default:
      return -1;
  }
}

/// Complete frames at the front of `buffer`, handed to `handle(type, payload)`, which returns
/// whether to go on; consumed bytes are removed (a frame `handle` stopped at stays). When
/// `check` is set, a frame whose type is not one the worker sends or whose length is beyond that
/// type's stops the reading before it is handed over: `check` is called with its type and length.
template <class Handle, class Check>
void take_frames(std::string& buffer, Handle&& handle, Check&& check) {
  constexpr std::size_t kHeader = 1 + 4;
  std::size_t pos = 0;
  while (buffer.size() - pos >= kHeader) {
    std::uint32_t length = 0;
    std::memcpy(&length, buffer.data() + pos + 1, 4);
    const auto type = static_cast<std::uint8_t>(buffer[pos]);
    if (!check(type, length)) break;
    if (buffer.size() - pos - kHeader < length) break;
    if (!handle(type, std::string_view(buffer).substr(pos + kHeader, length))) break;
    pos += kHeader + length;
  }
  buffer.erase(0, pos);
}

/// The same for frames from a trusted sender (the parent's records): each is handed over.
template <class Handle>
void take_frames(std::string& buffer, Handle&& handle) {
  take_frames(
      buffer,
      [&](std::uint8_t type, std::string_view payload) {
        handle(type, payload);
        return true;
      },
      [](std::uint8_t, std::uint32_t) { return true; });
}

template <class Handle>
bool WorkerProcess::receive_some(Handle&& handle) {
  if (!alive()) return false;
  if (!rejected_.empty()) return false;
  const auto check = [&](std::uint8_t type, std::uint32_t length) {
    const std::int64_t most = max_reply_bytes(type);
    if (most >= 0 && length <= most) return true;
    reject(most < 0 ? "a frame of type " + std::to_string(type) + ", a type it never sends"
                    : "a frame of type " + std::to_string(type) + " of " + std::to_string(length) +
                          " bytes, longer than any of its type");
    return false;
  };
  const auto give = [&](std::uint8_t type, std::string_view payload) {
    handle(type, payload);
    return rejected_.empty();  // what follows a frame the host rejected is not read either
  };
  char chunk[1 << 16];
  for (int round = 0; round < 4; ++round) {
    const ssize_t n = ::recv(fd_, chunk, sizeof(chunk), MSG_DONTWAIT);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return true;
    if (n <= 0) {  // 0: closed; ECONNRESET and the like: gone
      // The child has ended: what it staged is final. Its part not already received continues
      // the stream (a child killed while it sent them has sent some of them).
      const std::uint64_t used = stage_->used.load(std::memory_order_acquire);
      const std::uint64_t base = stage_->base.load(std::memory_order_acquire);
      if (rejected_.empty() && received_ >= base && received_ < base + used) {
        in_.append(stage_->data + (received_ - base), base + used - received_);
        take_frames(in_, give, check);
      }
      return false;
    }
    received_ += static_cast<std::uint64_t>(n);
    in_.append(chunk, static_cast<std::size_t>(n));
    take_frames(in_, give, check);
    if (!rejected_.empty()) return false;
  }
  return true;
}

EstimateSample decode_sample(std::string_view payload);
LocalizerFailure decode_failure(std::string_view payload);
std::vector<LocalizerSnapshot> decode_snapshots(std::string_view payload);
std::vector<LocalizerFinal> decode_finals(std::string_view payload);

}  // namespace locsim
