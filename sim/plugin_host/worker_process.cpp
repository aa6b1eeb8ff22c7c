#include "sim/plugin_host/worker_process.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <new>
#include <stdexcept>

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

/// Writes all of `data` (blocking). A parent that is gone ends the child.
void write_all(int fd, std::string_view data) {
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
/// The memory parent and child share: which call the child is in, its unsent answers.
struct WorkerProcess::Shared {
  CallState calls;
  ReplyStage stage;
};

WorkerProcess::WorkerProcess(const std::vector<const LocalizerDef*>& defs, std::string label)
    : label_(std::move(label)) {
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
  std::fflush(nullptr);  // else the child would print the parent's buffered output again
  const pid_t parent = ::getpid();
  pid_ = ::fork();
  if (pid_ < 0) {
    const int error = errno;
    ::close(sockets[0]), ::close(sockets[1]);
    ::close(output[0]), ::close(output[1]);
    ::munmap(page, sizeof(Shared));
    throw std::runtime_error(std::string("fork: ") + std::strerror(error));
  }
  if (pid_ == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);  // a parent killed hard takes its workers along
    if (::getppid() != parent) _exit(1);
    std::signal(SIGINT, SIG_IGN);  // Ctrl-C is the parent's to handle; it ends the workers
    // What the plugin prints goes to the parent, which labels and caps it; stdout by lines, so
    // that prints reach the parent in order with stderr's and before a crash.
    ::dup2(output[1], STDOUT_FILENO);
    ::dup2(output[1], STDERR_FILENO);
    std::setvbuf(stdout, nullptr, _IOLBF, 0);
    // Keep stdio and this worker's socket only: another worker's socket held open here would
    // hide that worker's end from the parent.
    const int fd = sockets[1];
    if (fd > 3) ::close_range(3, static_cast<unsigned>(fd - 1), 0);
    ::close_range(static_cast<unsigned>(fd + 1), ~0U, 0);
    child_main(fd, defs, calls_, *stage_);
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
  char chunk[1 << 16];
  while (output_fd_ >= 0) {
    const ssize_t n = ::read(output_fd_, chunk, sizeof(chunk));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
    if (n <= 0) {
      ::close(output_fd_);
      output_fd_ = -1;
      return;
    }
    write_output(output_.add(std::string_view(chunk, static_cast<std::size_t>(n))));
  }
}

WorkerProcess::~WorkerProcess() {
  if (pid_ > 0) {
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
  if (pid_ <= 0) return "ended";
  int status = 0;
  while (true) {
    // While the child runs, what it prints is read: one blocked on a full pipe never ends.
    const pid_t ended = ::waitpid(pid_, &status, output_fd_ >= 0 ? WNOHANG : 0);
    if (ended < 0 && errno == EINTR) continue;
    if (ended != 0) break;
    pollfd readable{output_fd_, POLLIN, 0};
    ::poll(&readable, 1, 10);
    forward_output();
  }
  pid_ = -1;
  forward_output();  // what it printed last
  if (output_.dropped_bytes() > 0) {
    if (!at_line_start_) write_output("\n");
    write_output(output_.dropped_line() + "\n");
    write_output(output_.tail());
  }
  if (!at_line_start_) write_output("\n");
  if (WIFSIGNALED(status)) {
    const int number = WTERMSIG(status);
    if (signal != nullptr) *signal = number;
    return "killed by signal " + std::to_string(number) + " (" + strsignal(number) + ")";
  }
  return "exited with code " + std::to_string(WEXITSTATUS(status));
}

void WorkerProcess::kill_now() {
  if (pid_ > 0) ::kill(pid_, SIGKILL);
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
