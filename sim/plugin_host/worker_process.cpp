#include "sim/plugin_host/worker_process.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <new>
#include <stdexcept>

#include "sim/common/process_tree.hpp"
#include "sim/stream/record_codec.hpp"

namespace locsim {

namespace {

void put_frame(std::string& out, std::uint8_t type, std::string_view payload) {
  put<std::uint8_t>(out, type);
  put<std::uint32_t>(out, static_cast<std::uint32_t>(payload.size()));
  out += payload;
}

void put_pose(std::string& out, double x, double y, double theta) {
  put(out, x), put(out, y), put(out, theta);
}

void put_landmarks(std::string& out, const std::vector<locsim_mapped_landmark>& landmarks) {
  put<std::uint32_t>(out, static_cast<std::uint32_t>(landmarks.size()));
  for (const locsim_mapped_landmark& l : landmarks) {
    put<std::int32_t>(out, l.id);
    put(out, l.x), put(out, l.y);
    for (const double c : l.covariance) put(out, c);
  }
}

std::vector<locsim_mapped_landmark> get_landmarks(ByteReader& in) {
  const auto count = in.get<std::uint32_t>();
  in.expect(count, 4 + 6 * 8);
  std::vector<locsim_mapped_landmark> out(count);
  for (locsim_mapped_landmark& l : out) {
    l.id = in.get<std::int32_t>();
    l.x = in.get<double>(), l.y = in.get<double>();
    for (double& c : l.covariance) c = in.get<double>();
  }
  return out;
}

std::string encode_sample(const EstimateSample& s) {
  std::string out;
  put<std::uint32_t>(out, static_cast<std::uint32_t>(s.localizer));
  put(out, s.t_s);
  put_pose(out, s.truth.x, s.truth.y, s.truth.theta);
  put_pose(out, s.pose.x, s.pose.y, s.pose.theta);
  for (const double c : s.covariance) put(out, c);
  put<std::int64_t>(out, s.perception_updates);
  put<std::uint32_t>(out, static_cast<std::uint32_t>(s.diagnostics.size()));
  for (const auto& [name, value] : s.diagnostics) put_string(out, name), put(out, value);
  return out;
}

std::string encode_failure(const LocalizerFailure& f) {
  std::string out;
  put<std::uint32_t>(out, static_cast<std::uint32_t>(f.localizer));
  put(out, f.t_s);
  put_string(out, f.call);
  put_string(out, f.message);
  return out;
}

std::string encode_snapshots(const std::vector<LocalizerSnapshot>& snapshots) {
  std::string out;
  put<std::uint32_t>(out, static_cast<std::uint32_t>(snapshots.size()));
  for (const LocalizerSnapshot& s : snapshots) {
    put<std::uint8_t>(out, s.failed ? 1 : 0);
    put<std::uint8_t>(out, s.estimate ? 1 : 0);
    if (s.estimate) {
      put_pose(out, s.estimate->pose.x, s.estimate->pose.y, s.estimate->pose.theta);
      for (const double c : s.estimate->covariance) put(out, c);
    }
    put<std::uint32_t>(out, static_cast<std::uint32_t>(s.particles.size()));
    for (const locsim_pose2& p : s.particles) put_pose(out, p.x, p.y, p.theta);
    put<std::uint32_t>(out, static_cast<std::uint32_t>(s.weights.size()));
    for (const double w : s.weights) put(out, w);
    put_landmarks(out, s.landmark_map);
  }
  return out;
}

std::string encode_finals(const std::vector<LocalizerFinal>& finals) {
  std::string out;
  put<std::uint32_t>(out, static_cast<std::uint32_t>(finals.size()));
  for (const LocalizerFinal& f : finals) {
    put<std::uint8_t>(out, f.known ? 1 : 0);
    put<std::int64_t>(out, f.updates);
    put<std::int64_t>(out, f.perception_updates);
    put<std::uint64_t>(out, f.cost.calls);
    put(out, f.cost.mean_us), put(out, f.cost.p99_us), put(out, f.cost.max_us);
    put_landmarks(out, f.landmark_map);
  }
  return out;
}

// The worker's own process (set once it starts), and whether this process is a copy of it that
// the plugin forked: the protocol is not the copy's (see WorkerProcess::WorkerProcess).
pid_t g_worker_pid = 0;
int g_protocol_fd = -1;
void* g_shared = nullptr;
std::size_t g_shared_bytes = 0;
std::atomic<int>* g_out_of_memory = nullptr;
volatile std::sig_atomic_t g_forked_copy = 0;

/// In every process forked from the worker (pthread_atfork): the protocol socket becomes
/// /dev/null and the shared memory this process's own, so that a copy of the worker answers
/// nothing in its name and a child that outlives it holds nothing that keeps its end from
/// being seen. Only system calls: it runs in the child of a fork.
void leave_the_protocol() {
  if (g_worker_pid == 0 || ::getpid() == g_worker_pid || g_forked_copy) return;
  g_forked_copy = 1;
  const int null_fd = ::open("/dev/null", O_RDWR | O_CLOEXEC);
  if (null_fd >= 0) {
    ::dup3(null_fd, g_protocol_fd, O_CLOEXEC);
    ::close(null_fd);
  } else {
    ::close(g_protocol_fd);
  }
  ::mmap(g_shared, g_shared_bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_FIXED,
         -1, 0);
}

/// A process the plugin forked has come back from the plugin into the worker's code (the plugin
/// neither exited nor exec'd in it): it must not act as the worker, so it ends here.
void end_if_forked_copy() {
  if (!g_forked_copy) return;
  std::fprintf(stderr,
               "locsim: process %d, forked by the plugin, returned from the plugin into locsim's "
               "worker; it is ended (a process a plugin forks must exit or exec)\n",
               static_cast<int>(::getpid()));
  std::fflush(nullptr);
  _exit(0);
}

/// operator new's handler while the worker has a memory limit: says that an allocation failed
/// (the parent's message names the limit), then fails it as usual.
void on_allocation_failure() {
  if (g_out_of_memory != nullptr) g_out_of_memory->store(1, std::memory_order_release);
  throw std::bad_alloc();
}

/// This process's data size (VmData: what RLIMIT_DATA limits) [bytes]; 0 if unknown.
std::uint64_t data_bytes() {
  std::FILE* status = std::fopen("/proc/self/status", "r");
  if (status == nullptr) return 0;
  char line[256];
  std::uint64_t kib = 0;
  while (std::fgets(line, sizeof(line), status) != nullptr) {
    if (std::sscanf(line, "VmData: %lu kB", &kib) == 1) break;
  }
  std::fclose(status);
  return kib * 1024;
}

/// Writes all of `data` (blocking). A parent that is gone ends the child.
void write_all(int fd, std::string_view data) {
  end_if_forked_copy();
  while (!data.empty()) {
    const ssize_t n = ::send(fd, data.data(), data.size(), MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      std::fflush(nullptr);
      _exit(0);
    }
    data.remove_prefix(static_cast<std::size_t>(n));
  }
}

/// The child's answers, staged in the shared ReplyStage and sent by flush(): the child flushes
/// before it waits for records, so the parent has every answer to what it sent once the child
/// has read all of it; one the child had when it died the parent takes from the stage.
class ReplyWriter final : public EstimateConsumer {
 public:
  ReplyWriter(int fd, ReplyStage& stage) : fd_(fd), stage_(stage) {}
  void estimate(const EstimateSample& sample) override {
    send(kWorkerSample, encode_sample(sample));
  }
  void failure(const LocalizerFailure& failure) override {
    send(kWorkerFailure, encode_failure(failure));
  }
  void send(std::uint8_t type, std::string_view payload) {
    end_if_forked_copy();
    frame_.clear();
    put_frame(frame_, type, payload);
    std::uint64_t used = stage_.used.load(std::memory_order_relaxed);
    if (used + frame_.size() > ReplyStage::kCapacity) flush(), used = 0;
    if (frame_.size() > ReplyStage::kCapacity) {  // a large snapshot: straight to the socket
      write_all(fd_, frame_);
      stage_.base.fetch_add(frame_.size(), std::memory_order_release);
      return;
    }
    std::memcpy(stage_.data + used, frame_.data(), frame_.size());
    stage_.used.store(used + frame_.size(), std::memory_order_release);  // whole frames only
  }
  void flush() {
    const std::uint64_t used = stage_.used.load(std::memory_order_relaxed);
    if (used == 0) return;
    write_all(fd_, std::string_view(stage_.data, used));
    // Emptied before the base moves: a death between the two loses nothing and repeats nothing.
    stage_.used.store(0, std::memory_order_release);
    stage_.base.fetch_add(used, std::memory_order_release);
  }

 private:
  int fd_;
  ReplyStage& stage_;
  std::string frame_;
};

[[noreturn]] void child_main(int fd, const std::vector<const LocalizerDef*>& defs, CallState* calls,
                             ReplyStage& stage) {
  ReplyWriter reply(fd, stage);
  std::unique_ptr<InstanceRunner> runner;
  try {
    runner = std::make_unique<InstanceRunner>(defs, calls);
  } catch (const std::exception& e) {
    std::string payload;
    put_string(payload, e.what());
    reply.send(kWorkerCreateFailed, payload);
    reply.flush();
    std::fflush(nullptr);
    _exit(0);
  }
  reply.send(kWorkerReady, "");
  std::string in;
  std::vector<char> chunk(1 << 16);
  Record record;
  bool done = false;
  while (!done) {
    reply.flush();  // every answer to what was read, before waiting for more
    end_if_forked_copy();
    const ssize_t n = ::read(fd, chunk.data(), chunk.size());
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;  // the parent is gone: nothing more to do
    in.append(chunk.data(), static_cast<std::size_t>(n));
    take_frames(in, [&](std::uint8_t type, std::string_view payload) {
      if (done) return;
      if (type == kWorkerSnapshotRequest || type == kWorkerFinish) {
        ByteReader args(payload);
        const double t_s = args.get<double>();
        if (type == kWorkerSnapshotRequest) {
          reply.send(kWorkerSnapshot, encode_snapshots(runner->snapshot(t_s, reply)));
        } else {
          reply.send(kWorkerFinal, encode_finals(runner->finish(t_s, reply)));
          done = true;
        }
        return;
      }
      decode_record(static_cast<Record::Type>(type), payload, record);
      runner->consume(record, reply);
    });
  }
  reply.flush();
  // No destructors, no atexit handlers: they belong to the parent's copy of this process.
  std::fflush(nullptr);
  _exit(0);
}

}  // namespace

EstimateSample decode_sample(std::string_view payload) {
  ByteReader in(payload);
  EstimateSample s;
  s.localizer = in.get<std::uint32_t>();
  s.t_s = in.get<double>();
  s.truth = {in.get<double>(), in.get<double>(), in.get<double>()};
  s.pose = {in.get<double>(), in.get<double>(), in.get<double>()};
  for (double& c : s.covariance) c = in.get<double>();
  s.perception_updates = static_cast<long>(in.get<std::int64_t>());
  const auto count = in.get<std::uint32_t>();
  in.expect(count, 4 + 8);
  for (std::uint32_t i = 0; i < count; ++i) {
    std::string name = in.get_string();
    s.diagnostics.emplace_back(std::move(name), in.get<double>());
  }
  return s;
}

LocalizerFailure decode_failure(std::string_view payload) {
  ByteReader in(payload);
  LocalizerFailure f;
  f.localizer = in.get<std::uint32_t>();
  f.t_s = in.get<double>();
  f.call = in.get_string();
  f.message = in.get_string();
  return f;
}

std::vector<LocalizerSnapshot> decode_snapshots(std::string_view payload) {
  ByteReader in(payload);
  const auto count = in.get<std::uint32_t>();
  in.expect(count, 2);
  std::vector<LocalizerSnapshot> out(count);
  for (LocalizerSnapshot& s : out) {
    s.failed = in.get<std::uint8_t>() != 0;
    if (in.get<std::uint8_t>() != 0) {
      locsim_estimate e{};
      e.pose = {in.get<double>(), in.get<double>(), in.get<double>()};
      for (double& c : e.covariance) c = in.get<double>();
      s.estimate = e;
    }
    const auto particles = in.get<std::uint32_t>();
    in.expect(particles, 3 * 8);
    s.particles.resize(particles);
    for (locsim_pose2& p : s.particles) p = {in.get<double>(), in.get<double>(), in.get<double>()};
    const auto weights = in.get<std::uint32_t>();
    in.expect(weights, 8);
    s.weights.resize(weights);
    for (double& w : s.weights) w = in.get<double>();
    s.landmark_map = get_landmarks(in);
  }
  return out;
}

std::vector<LocalizerFinal> decode_finals(std::string_view payload) {
  ByteReader in(payload);
  const auto count = in.get<std::uint32_t>();
  in.expect(count, 1 + 6 * 8);
  std::vector<LocalizerFinal> out(count);
  for (LocalizerFinal& f : out) {
    f.known = in.get<std::uint8_t>() != 0;
    f.updates = static_cast<long>(in.get<std::int64_t>());
    f.perception_updates = static_cast<long>(in.get<std::int64_t>());
    f.cost.calls = in.get<std::uint64_t>();
    f.cost.mean_us = in.get<double>(), f.cost.p99_us = in.get<double>(),
    f.cost.max_us = in.get<double>();
    f.landmark_map = get_landmarks(in);
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
/// The memory parent, keeper and worker share: which call the worker is in, its unsent answers,
/// its process and how it ended.
struct WorkerProcess::Shared {
  CallState calls;
  std::atomic<pid_t> worker_pid{0};   // until the keeper reaps it
  std::atomic<int> worker_status{0};  // as waitpid says it, once worker_ended
  std::atomic<int> worker_ended{0};   // the keeper saw the worker end
  std::atomic<int> out_of_memory{0};  // an allocation failed under --plugin-memory
  ReplyStage stage;
};

int protocol_fd() {
  rlimit files{};
  if (::getrlimit(RLIMIT_NOFILE, &files) != 0 || files.rlim_cur >= 1024) return 1023;
  return static_cast<int>(std::max<rlim_t>(files.rlim_cur, 16) - 1);
}

namespace {

volatile std::sig_atomic_t g_keeper_told_to_end = 0;
extern "C" void keeper_on_term(int) {
  g_keeper_told_to_end = 1;
}
extern "C" void keeper_on_child(int) {}  // wakes sigsuspend (SIG_DFL would discard SIGCHLD)

/// The keeper, after the worker ended or was told to end: kills the worker's process group and
/// every process left in its tree (each reparented to the keeper, its subreaper, when its own
/// parent dies), level by level, until the keeper has no child left.
void end_the_tree(pid_t worker) {
  ::kill(-worker, SIGKILL);  // what the worker forked and that kept its group (ESRCH: none)
  end_children();
}

}  // namespace

WorkerProcess::WorkerProcess(const std::vector<const LocalizerDef*>& defs, std::string label,
                             const WorkerLimits& limits)
    : label_(std::move(label)), limits_(limits) {
  for (const LocalizerDef* def : defs) {
    indices_.push_back(def->index);
    if (robots_.size() <= def->info.robot) robots_.resize(def->info.robot + 1, false);
    robots_[def->info.robot] = true;
  }
  int sockets[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sockets) != 0)
    throw std::runtime_error(std::string("socketpair: ") + std::strerror(errno));
  void* page =
      ::mmap(nullptr, sizeof(Shared), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  if (page == MAP_FAILED) {
    ::close(sockets[0]), ::close(sockets[1]);
    throw std::runtime_error(std::string("mmap: ") + std::strerror(errno));
  }
  int output[2];
  if (::pipe2(output, O_CLOEXEC) != 0) {
    const int error = errno;
    ::close(sockets[0]), ::close(sockets[1]);
    ::munmap(page, sizeof(Shared));
    throw std::runtime_error(std::string("pipe: ") + std::strerror(error));
  }
  // A larger pipe: a plugin that prints a lot between two of the parent's reads rarely waits.
  ::fcntl(output[1], F_SETPIPE_SZ, 1 << 20);
  shared_ = new (page) Shared();
  calls_ = &shared_->calls;
  stage_ = &shared_->stage;
  // Larger socket buffers let the simulation run further ahead of a slow filter before it waits.
  const int bytes = 1 << 20;
  ::setsockopt(sockets[0], SOL_SOCKET, SO_SNDBUF, &bytes, sizeof(bytes));
  ::setsockopt(sockets[1], SOL_SOCKET, SO_RCVBUF, &bytes, sizeof(bytes));
  const int protocol = protocol_fd();
  std::fflush(nullptr);  // else the child would print the parent's buffered output again
  const pid_t parent = ::getpid();
  keeper_ = ::fork();
  if (keeper_ < 0) {
    const int error = errno;
    ::close(sockets[0]), ::close(sockets[1]);
    ::close(output[0]), ::close(output[1]);
    ::munmap(page, sizeof(Shared));
    throw std::runtime_error(std::string("fork: ") + std::strerror(error));
  }
  if (keeper_ == 0) {
    // The keeper. SIGTERM (from the parent, or as its death signal) and SIGCHLD are waited for in
    // sigsuspend only, so that neither can slip in between a check and the wait.
    sigset_t waited, before;
    sigemptyset(&waited);
    sigaddset(&waited, SIGTERM);
    sigaddset(&waited, SIGCHLD);
    ::sigprocmask(SIG_BLOCK, &waited, &before);
    struct sigaction on_term {
    }, on_child{};
    on_term.sa_handler = keeper_on_term;
    on_child.sa_handler = keeper_on_child;
    ::sigaction(SIGTERM, &on_term, nullptr);
    ::sigaction(SIGCHLD, &on_child, nullptr);
    std::signal(SIGINT, SIG_IGN);  // Ctrl-C is the parent's to handle; it ends the workers
    // A parent that dies, even killed hard, has the keeper end the tree.
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() != parent) g_keeper_told_to_end = 1;
    // Every orphan of the tree comes here rather than to init, whatever it does (setsid too).
    ::prctl(PR_SET_CHILD_SUBREAPER, 1);
    ::setpgid(0, 0);  // not the parent's group: a kill of that group leaves it to end the tree
    const pid_t keeper = ::getpid();
    const pid_t worker = ::fork();
    if (worker == 0) {
      struct sigaction standard {};
      standard.sa_handler = SIG_DFL;
      ::sigaction(SIGTERM, &standard, nullptr);
      ::sigaction(SIGCHLD, &standard, nullptr);
      ::sigprocmask(SIG_SETMASK, &before, nullptr);
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (::getppid() != keeper) _exit(1);
      // Its own process group: one signal to it ends what it forked too (and a plugin's
      // kill(0, ...) stays in it).
      ::setpgid(0, 0);
      g_worker_pid = ::getpid();
      shared_->worker_pid.store(g_worker_pid, std::memory_order_release);
      // No terminal input: outside the terminal's foreground group, a read would stop it.
      if (const int null_fd = ::open("/dev/null", O_RDONLY); null_fd >= 0) {
        ::dup2(null_fd, STDIN_FILENO);
        if (null_fd != STDIN_FILENO) ::close(null_fd);
      }
      // What the plugin prints goes to the parent, which labels and caps it; stdout by lines, so
      // that prints reach the parent in order with stderr's and before a crash.
      ::dup2(output[1], STDOUT_FILENO);
      ::dup2(output[1], STDERR_FILENO);
      std::setvbuf(stdout, nullptr, _IOLBF, 0);
      // The protocol far from the descriptors a plugin's files get; close-on-exec, so that a
      // program the plugin runs does not hold it.
      if (sockets[1] != protocol && ::dup3(sockets[1], protocol, O_CLOEXEC) < 0) _exit(1);
      // Keep stdio and this worker's socket only: another worker's socket held open here would
      // hide that worker's end from the parent.
      ::close_range(3, static_cast<unsigned>(protocol - 1), 0);
      ::close_range(static_cast<unsigned>(protocol + 1), ~0U, 0);
      g_protocol_fd = protocol;
      g_shared = shared_;
      g_shared_bytes = sizeof(Shared);
      ::pthread_atfork(nullptr, nullptr, leave_the_protocol);
      if (limits_.memory_bytes > 0) {
        // What it has now is the simulator's, copied at fork; the plugin may add its limit.
        rlimit data{};
        ::getrlimit(RLIMIT_DATA, &data);
        const std::uint64_t wanted = data_bytes() + limits_.memory_bytes;
        if (data.rlim_max == RLIM_INFINITY || wanted < data.rlim_max) data.rlim_max = wanted;
        data.rlim_cur = data.rlim_max;
        ::setrlimit(RLIMIT_DATA, &data);
        g_out_of_memory = &shared_->out_of_memory;
        std::set_new_handler(on_allocation_failure);
      }
      child_main(protocol, defs, calls_, *stage_);
    }
    // The keeper holds nothing of the worker's: its socket and pipe end when the tree does.
    ::close_range(0, ~0U, 0);
    if (worker < 0) _exit(1);
    shared_->worker_pid.store(worker, std::memory_order_release);
    sigset_t wait_mask = before;
    sigdelset(&wait_mask, SIGTERM);
    sigdelset(&wait_mask, SIGCHLD);
    int status = 0;
    bool ended = false;
    while (!ended) {
      siginfo_t info{};
      if (::waitid(P_ALL, 0, &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid != 0) {
        // Forgotten before it is reaped: the parent never signals a number reused since.
        if (info.si_pid == worker) shared_->worker_pid.store(0, std::memory_order_release);
        int any = 0;
        ::waitpid(info.si_pid, &any, 0);
        if (info.si_pid == worker) status = any, ended = true;
        continue;  // else an orphan of the tree that ended
      }
      if (g_keeper_told_to_end) {
        ::kill(worker, SIGKILL);
        shared_->worker_pid.store(0, std::memory_order_release);
        while (::waitpid(worker, &status, 0) < 0 && errno == EINTR) {
        }
        ended = true;
        break;
      }
      ::sigsuspend(&wait_mask);
    }
    shared_->worker_status.store(status, std::memory_order_relaxed);
    shared_->worker_ended.store(1, std::memory_order_release);
    end_the_tree(worker);
    _exit(0);
  }
  ::close(sockets[1]);
  ::close(output[1]);
  ::fcntl(output[0], F_SETFL, O_NONBLOCK);
  fd_ = sockets[0];
  output_fd_ = output[0];
}

void WorkerProcess::write_output(std::string_view text) {
  std::string lines;
  for (const char c : text) {
    if (at_line_start_) lines += "[" + label_ + "] ";
    lines += c;
    at_line_start_ = c == '\n';
  }
  std::fwrite(lines.data(), 1, lines.size(), stderr);
}

void WorkerProcess::forward_output() {
  // At most this much per call: a process printing without pause must not keep the parent here.
  constexpr int kChunks = 16;
  char chunk[1 << 16];
  for (int round = 0; round < kChunks && output_fd_ >= 0;) {
    const ssize_t n = ::read(output_fd_, chunk, sizeof(chunk));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
    if (n <= 0) {
      ::close(output_fd_);
      output_fd_ = -1;
      return;
    }
    write_output(output_.add(std::string_view(chunk, static_cast<std::size_t>(n))));
    ++round;
  }
}

WorkerProcess::~WorkerProcess() {
  if (keeper_ > 0) {
    if (alive()) kill_now();
    reap();
  }
  if (output_fd_ >= 0) ::close(output_fd_);
  if (shared_ != nullptr) ::munmap(shared_, sizeof(Shared));
}

void WorkerProcess::queue(std::uint8_t type, std::string_view payload) {
  if (out_sent_ > 0 && out_sent_ == out_.size()) out_.clear(), out_sent_ = 0;
  put_frame(out_, type, payload);
}

bool WorkerProcess::send_some() {
  if (!alive()) return false;
  while (out_sent_ < out_.size()) {
    const ssize_t n =
        ::send(fd_, out_.data() + out_sent_, out_.size() - out_sent_, MSG_DONTWAIT | MSG_NOSIGNAL);
    if (n > 0) {
      out_sent_ += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
    return false;  // EPIPE, ECONNRESET: the child is gone
  }
  if (out_sent_ == out_.size()) {
    out_.clear();
    out_sent_ = 0;
  } else if (out_sent_ > (1u << 20)) {
    out_.erase(0, out_sent_);
    out_sent_ = 0;
  }
  return true;
}

std::string WorkerProcess::reap(std::optional<int>* signal) {
  if (fd_ >= 0) ::close(fd_), fd_ = -1;
  if (keeper_ <= 0) return "ended";
  int keeper_status = 0;
  // A worker ends at once when its socket has closed (it ended, or its parent ended it); one
  // that has not within this long closed the socket itself and is ended here.
  constexpr auto kEnding = std::chrono::seconds(5);
  const auto waiting_since = std::chrono::steady_clock::now();
  while (true) {
    // While the tree ends, what it prints is read: one blocked on a full pipe never ends (the
    // keeper kills it, but the worker may still be on its way out).
    const pid_t ended = ::waitpid(keeper_, &keeper_status, WNOHANG);
    if (ended < 0 && errno == EINTR) continue;
    if (ended != 0) break;
    if (!killed_by_locsim_ && std::chrono::steady_clock::now() - waiting_since > kEnding)
      kill_now();
    pollfd readable{output_fd_, POLLIN, 0};
    ::poll(&readable, output_fd_ >= 0 ? 1 : 0, 10);
    forward_output();
  }
  keeper_ = -1;
  // Nothing of the tree is left: what the pipe holds is all there is. Read without waiting, and
  // boundedly (should anything outside the tree hold the pipe, it is not waited for).
  for (int round = 0; round < 4 && output_fd_ >= 0; ++round) forward_output();
  if (output_fd_ >= 0) ::close(output_fd_), output_fd_ = -1;
  if (output_.dropped_bytes() > 0) {
    if (!at_line_start_) write_output("\n");
    write_output(output_.dropped_line() + "\n");
    write_output(output_.tail());
  }
  if (!at_line_start_) write_output("\n");
  if (shared_->worker_ended.load(std::memory_order_acquire) == 0) {
    // The keeper itself died before the worker did (only a deliberate kill does that).
    return WIFSIGNALED(keeper_status) ? "lost: its keeper process was killed by signal " +
                                            std::to_string(WTERMSIG(keeper_status))
                                      : "lost: its keeper process could not start it";
  }
  const int status = shared_->worker_status.load(std::memory_order_relaxed);
  if (WIFSIGNALED(status)) {
    const int number = WTERMSIG(status);
    if (signal != nullptr) *signal = number;
    return "killed by signal " + std::to_string(number) + " (" + strsignal(number) + ")";
  }
  return "exited with code " + std::to_string(WEXITSTATUS(status));
}

void WorkerProcess::kill_now() {
  if (keeper_ <= 0) return;
  killed_by_locsim_ = true;
  // The worker at once (the watchdog's verdict must not wait), then the keeper ends the rest.
  if (const pid_t worker = shared_->worker_pid.load(std::memory_order_acquire); worker > 0)
    ::kill(worker, SIGKILL);
  ::kill(keeper_, SIGTERM);
}

void WorkerProcess::reject(std::string what) {
  if (!rejected_.empty()) return;
  rejected_ = std::move(what);
  kill_now();
}

bool WorkerProcess::out_of_memory() const {
  return shared_->out_of_memory.load(std::memory_order_acquire) != 0;
}

std::optional<WorkerProcess::Call> WorkerProcess::current_call() const {
  Call call = last_call();
  if (!call.in_call) return std::nullopt;
  return call;
}

WorkerProcess::Call WorkerProcess::last_call() const {
  Call call;
  const std::int64_t started = calls_->started_ns.load(std::memory_order_acquire);
  call.in_call = started != 0;
  call.started = std::chrono::steady_clock::time_point(std::chrono::nanoseconds(started));
  call.call = static_cast<PluginCall>(calls_->call.load(std::memory_order_relaxed));
  call.t_s = calls_->t_s.load(std::memory_order_relaxed);
  call.localizer = calls_->localizer.load(std::memory_order_relaxed);
  return call;
}

}  // namespace locsim
