// The localizer host: a consumer of the record stream that runs every localizer of every robot
// on it and emits their estimates (stream/estimates). By default each localizer runs in its own
// worker process (plugin_host/worker_process): a plugin that segfaults, aborts, calls exit() or
// hangs past --plugin-timeout fails alone, with the signal or reason and the simulated time, and
// the simulation and the other localizers go on; the workers also put a second core to work.
// With isolation off they run in this process (a debugger sees them; a crash is everyone's).
#pragma once

#include <atomic>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "sim/plugin_host/instance_runner.hpp"
#include "sim/plugin_host/worker_process.hpp"
#include "sim/scenario/scenario_def.hpp"
#include "sim/stream/estimates.hpp"
#include "sim/stream/record.hpp"
#include "sim/world/occupancy.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

struct HostOptions {
  bool isolate = true;             // each localizer in its own process
  double plugin_timeout_s = 60.0;  // longest a single plugin call may take [s]; 0: no limit
  /// --plugin-memory: what each localizer's process may allocate beyond what it starts with
  /// [bytes]; 0: no limit (isolation only)
  std::uint64_t plugin_memory_bytes = 0;
  const std::atomic<bool>* interrupt = nullptr;  // waits end with Interrupted when it turns true
};

class LocalizerHost final : public RecordConsumer, private EstimateConsumer {
 public:
  /// Resolves every spec's plugin and checks its parameters (InputError, exit 2; PluginError,
  /// exit 3; what of a params file no localizer declares is a warning on stderr), then creates each
  /// localizer of each robot (PluginError when a create fails or crashes). Nothing is written
  /// before this returns.
  LocalizerHost(const std::vector<LocalizerSpec>& specs, const WorldDef& world,
                const LocalizationDef& localization, const OccupancyGrid& grid,
                std::uint64_t run_seed, const HostOptions& options = {});
  ~LocalizerHost() override;

  /// Every localizer, robot by robot, each robot's in the order of the specs.
  const std::vector<LocalizerInfo>& localizers() const { return infos_; }
  /// Where the estimates and failures go (in each localizer's own order).
  void add_output(EstimateConsumer& consumer) { outputs_.push_back(&consumer); }

  void consume(const Record& record) override;
  /// Sends what is queued and takes in what came back (and runs the watchdog).
  void flush() override;
  /// Each localizer's state after every record so far (for video frames), in `localizers()`
  /// order; a failed one has `failed` set.
  std::vector<LocalizerSnapshot> snapshot(double t_s);
  /// The end of the stream at `t_end_s`: waits until every localizer has taken in every record,
  /// then asks for final maps and counts, in `localizers()` order.
  std::vector<LocalizerFinal> finish(double t_end_s);
  /// Ctrl-C: ends every worker, each as soon as it is out of its call (250 ms at most; one still
  /// in a call then fails as interrupted); what they sent stays with the consumers.
  void abort();
  bool failed(std::size_t localizer) const { return failed_[localizer]; }

 private:
  void estimate(const EstimateSample& sample) override;
  void failure(const LocalizerFailure& failure) override;
  /// Services every worker (sending, receiving, the watchdog) until `done()`; throws Interrupted.
  template <class Done>
  void pump_until(Done&& done);
  void dispatch(std::size_t worker, std::uint8_t type, std::string_view payload);
  /// Its socket closed: reaps it and, unless it had finished, fails its localizers with how it
  /// ended (signal, exit, timeout) and the call and time it was in.
  void lost(WorkerProcess& worker);
  /// A failure's message with what locsim knows of its cause: the memory limit it ran into.
  std::string with_memory_cause(const WorkerProcess& worker, std::string message) const;
  std::size_t slot_of(const WorkerProcess& worker) const;

  HostOptions options_;
  std::vector<std::unique_ptr<LocalizerWorld>> worlds_;  // by robot
  std::vector<LocalizerDef> defs_;
  std::vector<LocalizerInfo> infos_;
  std::vector<EstimateConsumer*> outputs_;
  std::vector<bool> failed_;
  std::unique_ptr<InstanceRunner> runner_;  // isolation off
  CallState in_process_calls_;              // isolation off: the call in progress, for exit()
  std::vector<std::unique_ptr<WorkerProcess>> workers_;
  std::vector<std::string> create_errors_;                 // by worker
  std::vector<std::vector<LocalizerSnapshot>> snapshots_;  // by worker, while asked
  std::vector<std::vector<LocalizerFinal>> finals_;        // by worker
  std::vector<bool> snapshot_ready_;
  // By worker: the times of the true poses sent to it and not yet answered, each to be answered
  // by one estimate of that time (while its localizer has not failed).
  std::vector<std::deque<double>> expected_;
  std::string payload_;
};

}  // namespace locsim
