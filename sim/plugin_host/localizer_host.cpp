#include "sim/plugin_host/localizer_host.hpp"

#include <poll.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <set>
#include <thread>

#include "sim/common/errors.hpp"
#include "sim/common/format.hpp"
#include "sim/stream/record_codec.hpp"

namespace locsim {

namespace {
// Records queued for a worker are sent once this many bytes wait: few system calls per reading,
// and the worker's memory for them stays small.
constexpr std::size_t kBatchBytes = 64 * 1024;

// With isolation off, a plugin that calls exit() ends locsim itself: without this it would end
// with the plugin's exit code (0 for exit(0)) and no run.json, a run that looks like it
// succeeded. The call in progress, if any, of the host running plugins in this process.
std::atomic<const CallState*> g_in_process_calls{nullptr};

extern "C" void on_exit_in_plugin_call() {
  const CallState* calls = g_in_process_calls.load();
  if (calls == nullptr || calls->started_ns.load() == 0) return;
  const auto call = static_cast<PluginCall>(calls->call.load());
  std::fprintf(stderr,
               "locsim: failure: a localizer plugin called exit() in its %s call at t = %.3f s "
               "(--isolation none, so it ended locsim): the run is incomplete, with no run.json; "
               "run it with --isolation process to contain it\n",
               plugin_call_name(call), calls->t_s.load());
  std::fflush(nullptr);
  _exit(kExitFailure);
}
}  // namespace

LocalizerHost::LocalizerHost(const std::vector<LocalizerSpec>& specs, const WorldDef& world,
                             const LocalizationDef& localization, const OccupancyGrid& grid,
                             std::uint64_t run_seed, const HostOptions& options)
    : options_(options) {
  // Every plugin resolved and every parameter checked before anything is created.
  struct Resolved {
    std::shared_ptr<const PluginLibrary> library;
    std::string params_json;
  };
  std::vector<Resolved> resolved;
  PluginCache libraries;
  for (std::size_t k = 0; k < specs.size(); ++k) {
    const LocalizerSpec& spec = specs[k];
    for (std::size_t j = 0; j < k; ++j) {
      if (specs[j].label == spec.label) {
        throw InputError("--localizer: label '" + spec.label +
                         "' used twice; give one with @label");
      }
    }
    const auto library = libraries.load(spec.plugin, spec.source);
    const ParamSet params(library->table(), spec);
    resolved.push_back({library, params.to_json().dump()});
  }
  // A params file's value that none of the localizers it is given to declares: said once.
  std::set<const ParamFile*> warned;
  for (const LocalizerSpec& spec : specs) {
    const ParamFile* file = spec.params_file.get();
    if (file == nullptr || !warned.insert(file).second) continue;
    std::vector<const locsim_localizer*> tables;
    for (std::size_t k = 0; k < specs.size(); ++k) {
      if (specs[k].params_file.get() == file) tables.push_back(&resolved[k].library->table());
    }
    for (const std::string& warning : param_file_warnings(*file, tables))
      std::fprintf(stderr, "locsim: warning: %s\n", warning.c_str());
  }
  for (const RobotDef& robot : world.robots) {
    // One initial guess per robot, shared by all its filters so that they start alike.
    RandomStream initial_rng = make_stream(run_seed, "localization/" + robot.name);
    worlds_.push_back(
        std::make_unique<LocalizerWorld>(world, robot, grid, localization, initial_rng));
  }
  for (std::size_t r = 0; r < world.robots.size(); ++r) {
    const RobotDef& robot = world.robots[r];
    for (std::size_t k = 0; k < specs.size(); ++k) {
      LocalizerDef def;
      def.index = defs_.size();
      def.info = {r,
                  robot.name,
                  specs[k].label,
                  resolved[k].library->table().name,
                  resolved[k].library->definition().string(),
                  resolved[k].params_json,
                  resolved[k].library->readings()};
      def.spec = specs[k];
      def.library = resolved[k].library;
      def.robot = &robot;
      def.world = worlds_[r].get();
      def.seed = derive_seed(run_seed, "localizer/" + robot.name + "/" + specs[k].label);
      infos_.push_back(def.info);
      defs_.push_back(std::move(def));
    }
  }
  failed_.assign(defs_.size(), false);
  if (defs_.empty()) return;
  if (!options_.isolate) {
    std::vector<const LocalizerDef*> all;
    for (const LocalizerDef& def : defs_) all.push_back(&def);
    static const bool registered = std::atexit(on_exit_in_plugin_call) == 0;
    (void)registered;
    g_in_process_calls.store(&in_process_calls_);
    runner_ = std::make_unique<InstanceRunner>(all, &in_process_calls_);
    return;
  }
  // One process per localizer: a failure costs nobody else anything.
  for (const LocalizerDef& def : defs_) {
    const std::string label =
        world.robots.size() > 1 ? def.info.robot_name + "/" + def.info.label : def.info.label;
    workers_.push_back(std::make_unique<WorkerProcess>(
        std::vector<const LocalizerDef*>{&def}, label,
        WorkerLimits{.memory_bytes = options_.plugin_memory_bytes}));
  }
  create_errors_.assign(workers_.size(), "");
  snapshots_.assign(workers_.size(), {});
  finals_.assign(workers_.size(), {});
  snapshot_ready_.assign(workers_.size(), false);
  expected_.assign(workers_.size(), {});
  pump_until([&] {
    return std::all_of(workers_.begin(), workers_.end(),
                       [](const auto& w) { return w->ready || !w->alive(); });
  });
  for (std::size_t w = 0; w < workers_.size(); ++w) {
    if (!create_errors_[w].empty()) throw PluginError(create_errors_[w]);
  }
}

LocalizerHost::~LocalizerHost() {
  // Workers still running are killed and reaped by their destructors.
  const CallState* mine = &in_process_calls_;
  g_in_process_calls.compare_exchange_strong(mine, nullptr);
}

void LocalizerHost::estimate(const EstimateSample& sample) {
  for (EstimateConsumer* out : outputs_) out->estimate(sample);
}

void LocalizerHost::failure(const LocalizerFailure& f) {
  if (failed_[f.localizer]) return;
  failed_[f.localizer] = true;
  for (std::size_t w = 0; w < workers_.size(); ++w) {
    const auto& indices = workers_[w]->indices();
    if (std::find(indices.begin(), indices.end(), f.localizer) != indices.end())
      expected_[w].clear();  // nothing of it follows a failure
  }
  for (EstimateConsumer* out : outputs_) out->failure(f);
}

void LocalizerHost::consume(const Record& record) {
  if (defs_.empty()) return;
  if (runner_) {
    runner_->consume(record, *this);
    return;
  }
  // Workers need readings and true poses only; each gets its robot's.
  if (record.type != Record::Type::kReading && record.type != Record::Type::kGroundTruth) return;
  const int robot = record.type == Record::Type::kReading ? record.reading.robot : record.robot;
  payload_.clear();
  encode_record(record, payload_);
  bool full = false;
  for (std::size_t w = 0; w < workers_.size(); ++w) {
    WorkerProcess* worker = workers_[w].get();
    if (!worker->alive() || robot < 0 || !worker->serves_robot(static_cast<std::size_t>(robot)))
      continue;
    worker->queue(static_cast<std::uint8_t>(record.type), payload_);
    if (record.type == Record::Type::kGroundTruth && !failed_[worker->indices().front()])
      expected_[w].push_back(record.t_s);
    full = full || worker->pending_bytes() >= kBatchBytes;
  }
  if (full) flush();
}

void LocalizerHost::flush() {
  if (runner_ || workers_.empty()) return;
  pump_until([&] {
    return std::all_of(workers_.begin(), workers_.end(),
                       [](const auto& w) { return !w->alive() || w->pending_bytes() == 0; });
  });
}

template <class Done>
void LocalizerHost::pump_until(Done&& done) {
  std::vector<pollfd> fds;
  while (true) {
    for (std::size_t w = 0; w < workers_.size(); ++w) {
      WorkerProcess& worker = *workers_[w];
      if (!worker.alive()) continue;
      worker.forward_output();  // else a plugin that prints may wait on a full pipe
      worker.send_some();       // a child that is gone shows as the end of its socket below
      const bool open = worker.receive_some(
          [&](std::uint8_t type, std::string_view payload) { dispatch(w, type, payload); });
      if (!open) lost(worker);
    }
    if (done()) return;
    const auto now = std::chrono::steady_clock::now();
    auto wake = now + std::chrono::milliseconds(50);  // Ctrl-C is noticed within this
    if (options_.plugin_timeout_s > 0.0) {
      const auto limit = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
          std::chrono::duration<double>(options_.plugin_timeout_s));
      for (const auto& worker : workers_) {
        if (!worker->alive() || worker->timed_out) continue;
        const auto call = worker->current_call();
        if (!call) continue;
        if (now - call->started >= limit) {
          worker->timed_out = true;
          worker->kill_now();  // its end of the socket closes; lost() reports it
        } else {
          wake = std::min(wake, call->started + limit);
        }
      }
    }
    if (options_.interrupt != nullptr && options_.interrupt->load()) throw Interrupted();
    fds.clear();
    for (const auto& worker : workers_) {
      if (!worker->alive()) continue;
      fds.push_back({worker->fd(),
                     static_cast<short>(POLLIN | (worker->pending_bytes() > 0 ? POLLOUT : 0)), 0});
      if (worker->output_fd() >= 0) fds.push_back({worker->output_fd(), POLLIN, 0});
    }
    const auto wait_ms = std::chrono::ceil<std::chrono::milliseconds>(wake - now).count();
    ::poll(fds.data(), fds.size(), static_cast<int>(std::max<long>(wait_ms, 1)));
  }
}

void LocalizerHost::dispatch(std::size_t w, std::uint8_t type, std::string_view payload) {
  WorkerProcess& worker = *workers_[w];
  // A worker runs one localizer; whatever names another is not its answer.
  const std::size_t index = worker.indices().front();
  try {
    switch (type) {
      case kWorkerReady:
        worker.ready = true;
        break;
      case kWorkerCreateFailed: {
        ByteReader in(payload);
        create_errors_[w] = in.get_string();
        break;
      }
      case kWorkerSample: {
        const EstimateSample sample = decode_sample(payload);
        std::deque<double>& expected = expected_[w];
        // One estimate per true pose it was sent, in order: a second answer to one (from a
        // copy of the worker that the plugin forked) or one to a time never sent is not its.
        if (sample.localizer != index || expected.empty() || expected.front() != sample.t_s) {
          worker.reject("an estimate for t = " + fixed(sample.t_s, 3) + " s" +
                        (sample.localizer != index ? " of another localizer" : "") +
                        (expected.empty() ? ", which it was not asked for"
                                          : ", where the next true pose it was sent is at t = " +
                                                fixed(expected.front(), 3) + " s") +
                        " (a second answer, from a process the plugin forked?)");
          return;
        }
        expected.pop_front();
        estimate(sample);
        break;
      }
      case kWorkerFailure: {
        LocalizerFailure f = decode_failure(payload);
        if (f.localizer != index) {
          worker.reject("a failure of another localizer");
          return;
        }
        f.message = with_memory_cause(worker, std::move(f.message));
        failure(f);
        break;
      }
      case kWorkerSnapshot:
        snapshots_[w] = decode_snapshots(payload);
        snapshot_ready_[w] = true;
        break;
      case kWorkerFinal:
        finals_[w] = decode_finals(payload);
        worker.finished = true;
        break;
      default:  // WorkerProcess hands over the types it knows only
        throw std::logic_error("localizer worker sent message type " + std::to_string(type));
    }
  } catch (const DecodeError& e) {
    worker.reject("a frame of type " + std::to_string(type) + " whose " +
                  std::to_string(payload.size()) + " bytes do not decode (" + e.what() + ")");
  }
}

std::string LocalizerHost::with_memory_cause(const WorkerProcess& worker,
                                             std::string message) const {
  const std::uint64_t limit = worker.limits().memory_bytes;
  if (limit == 0) return message;
  // operator new's handler saw an allocation fail; a C library (CPython's) returns NULL
  // instead, which its own error names.
  const bool allocation_failed = worker.out_of_memory() ||
                                 message.find("bad_alloc") != std::string::npos ||
                                 message.find("MemoryError") != std::string::npos;
  if (!allocation_failed) return message;
  return "ran out of its memory limit of " + fixed(static_cast<double>(limit) / (1 << 20), 0) +
         " MiB (--plugin-memory): " + message;
}

std::size_t LocalizerHost::slot_of(const WorkerProcess& worker) const {
  for (std::size_t w = 0; w < workers_.size(); ++w) {
    if (workers_[w].get() == &worker) return w;
  }
  throw std::logic_error("unknown localizer worker");
}

void LocalizerHost::lost(WorkerProcess& worker) {
  const WorkerProcess::Call call = worker.last_call();
  std::optional<int> signal;
  const std::string how = worker.reap(&signal);
  if (worker.finished && worker.rejected().empty()) return;  // it said all, then ended as it should
  // What ended it, as the user needs to hear it.
  std::string message;
  if (!worker.rejected().empty()) {
    message = "sent what is not locsim's protocol: " + worker.rejected() + "; " +
              std::to_string(worker.unread_bytes()) +
              " bytes from there on (did the plugin write to descriptor " +
              std::to_string(protocol_fd()) +
              ", locsim's?); its process was killed, what it sent before is kept";
  } else if (worker.timed_out) {
    message = "did not return within the plugin timeout of " + fixed(options_.plugin_timeout_s, 1) +
              " s; its process was killed";
  } else if (signal && *signal == SIGKILL && !worker.killed_by_locsim()) {
    message = "its process was " + how +
              ", not sent by locsim: most likely the system's out-of-memory killer (see dmesg; "
              "--plugin-memory gives each localizer a limit of its own)";
  } else if (signal) {
    message = "its process was " + how;
  } else {
    message = "its process " + how + " (did the plugin call exit()?)";
  }
  message = with_memory_cause(worker, std::move(message));
  if (!worker.ready) {
    std::string& error = create_errors_[slot_of(worker)];
    if (!error.empty()) return;  // it said why before it ended
    const LocalizerInfo& info = defs_[worker.indices().front()].info;
    error = "localizer '" + info.label + "' (plugin " + info.plugin + ", " + info.plugin_file +
            "): create " +
            (worker.timed_out ? "did not return within the plugin timeout of " +
                                    fixed(options_.plugin_timeout_s, 1) + " s"
                              : "crashed: " + message);
    return;
  }
  for (const std::size_t index : worker.indices()) {
    if (failed_[index]) continue;
    LocalizerFailure f;
    f.localizer = index;
    // The call it died in (or, dying between calls, none after the last it made).
    const bool in_call =
        call.in_call && (call.localizer < 0 || static_cast<std::size_t>(call.localizer) == index);
    f.call = in_call ? plugin_call_name(call.call) : "none";
    f.t_s = call.t_s;
    f.message = message;
    if (worker.rejected().empty()) {
      if (worker.timed_out)
        f.timeout_s = options_.plugin_timeout_s;
      else
        f.signal = signal;
    }
    failure(f);
  }
}

std::vector<LocalizerSnapshot> LocalizerHost::snapshot(double t_s) {
  if (runner_) return runner_->snapshot(t_s, *this);
  std::vector<LocalizerSnapshot> out(defs_.size());
  if (workers_.empty()) return out;
  std::string args;
  put(args, t_s);
  for (std::size_t w = 0; w < workers_.size(); ++w) {
    snapshot_ready_[w] = false;
    if (workers_[w]->alive()) workers_[w]->queue(kWorkerSnapshotRequest, args);
  }
  pump_until([&] {
    for (std::size_t w = 0; w < workers_.size(); ++w) {
      if (workers_[w]->alive() && !snapshot_ready_[w]) return false;
    }
    return true;
  });
  for (std::size_t w = 0; w < workers_.size(); ++w) {
    const auto& indices = workers_[w]->indices();
    for (std::size_t k = 0; k < indices.size(); ++k) {
      if (snapshot_ready_[w] && k < snapshots_[w].size()) {
        out[indices[k]] = std::move(snapshots_[w][k]);
      } else {
        out[indices[k]].failed = true;
      }
    }
  }
  return out;
}

std::vector<LocalizerFinal> LocalizerHost::finish(double t_end_s) {
  if (runner_) return runner_->finish(t_end_s, *this);
  std::vector<LocalizerFinal> out(defs_.size());
  std::string args;
  put(args, t_end_s);
  for (const auto& worker : workers_) {
    if (worker->alive()) worker->queue(kWorkerFinish, args);
  }
  pump_until([&] {
    return std::all_of(workers_.begin(), workers_.end(),
                       [](const auto& w) { return w->finished || !w->alive(); });
  });
  for (std::size_t w = 0; w < workers_.size(); ++w) {
    const auto& indices = workers_[w]->indices();
    for (std::size_t k = 0; k < indices.size() && k < finals_[w].size(); ++k)
      out[indices[k]] = std::move(finals_[w][k]);
    if (workers_[w]->alive()) workers_[w]->reap();  // it ends by itself after its final word
  }
  return out;
}

void LocalizerHost::abort() {
  // A worker still inside the call it was in at Ctrl-C a moment later is the one the user may
  // have pressed it for: it says so. One that was merely busy with the last records sent (any
  // worker is, most of the time) gets this long to leave that call and ends as it was, status ok,
  // even if it has started on the next queued record meanwhile.
  constexpr auto kGrace = std::chrono::milliseconds(250);
  const auto pressed = std::chrono::steady_clock::now();
  struct Busy {
    WorkerProcess* worker;
    std::chrono::steady_clock::time_point call_started;  // of the call it was in at Ctrl-C
  };
  std::vector<Busy> busy;
  for (const auto& worker : workers_) {
    if (!worker->alive()) continue;
    const auto call = worker->current_call();
    if (call) {
      busy.push_back({worker.get(), call->started});
    } else {
      worker->kill_now();  // between calls: ended before it can start another
      worker->reap();
    }
  }
  const auto still_in_that_call = [](const Busy& b) {
    const auto call = b.worker->current_call();
    return b.worker->alive() && call && call->started == b.call_started;
  };
  while (true) {
    std::erase_if(busy, [&](const Busy& b) {
      if (still_in_that_call(b)) return false;
      b.worker->kill_now();  // it left that call: what it was doing at Ctrl-C is done
      b.worker->reap();
      return true;
    });
    if (busy.empty() || std::chrono::steady_clock::now() - pressed >= kGrace) break;
    for (const Busy& b : busy) {
      // What it sends meanwhile reaches the outputs; a full socket must not keep it in a call.
      b.worker->forward_output();
      const std::size_t w = slot_of(*b.worker);
      if (!b.worker->receive_some(
              [&](std::uint8_t type, std::string_view payload) { dispatch(w, type, payload); }))
        lost(*b.worker);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  const auto now = std::chrono::steady_clock::now();
  for (const Busy& b : busy) {
    if (const auto call = b.worker->current_call(); call && call->localizer >= 0) {
      LocalizerFailure f;
      f.localizer = static_cast<std::size_t>(call->localizer);
      f.t_s = call->t_s;
      f.call = plugin_call_name(call->call);
      f.message = "interrupted while in this call for " +
                  fixed(std::chrono::duration<double>(now - call->started).count(), 1) + " s";
      f.interrupted = true;
      failure(f);
    }
    b.worker->kill_now();
    b.worker->reap();
  }
}

}  // namespace locsim
