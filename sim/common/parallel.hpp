// A fork-join loop over a fixed set of threads, for the independent work inside one run (the
// sensors of different robots). Results do not depend on the thread count as long as each
// iteration writes only its own outputs: which thread runs an iteration varies, what it computes
// does not.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

namespace locsim {

/// The threads a run uses when none are asked for: the machine's cores (at least 1).
int default_thread_count();

class ParallelLoop {
 public:
  /// `threads` >= 1 (the caller's included); 1 starts no thread and runs every loop inline.
  explicit ParallelLoop(int threads);
  ~ParallelLoop();
  ParallelLoop(const ParallelLoop&) = delete;
  ParallelLoop& operator=(const ParallelLoop&) = delete;

  int threads() const { return static_cast<int>(workers_.size()) + 1; }

  /// Calls body(i) for every i in [0, n), side by side, and returns when all have returned. When
  /// bodies throw, the lowest i's exception is rethrown, the one a plain loop would meet first,
  /// so the error does not depend on the thread count either (iterations after it may or may not
  /// have run). Not reentrant.
  void for_each(std::size_t n, const std::function<void(std::size_t)>& body);

 private:
  void work();
  void run_iterations();

  std::vector<std::jthread> workers_;
  // One loop at a time: its body and size, the next iteration to hand out, the workers still in
  // it. `generation_` counts loops (and is bumped once more to stop the workers); a worker that
  // sees it change joins the loop.
  const std::function<void(std::size_t)>* body_ = nullptr;
  std::size_t size_ = 0;
  std::size_t grain_ = 1;  // iterations per hand-out
  std::atomic<std::size_t> next_{0};
  std::atomic<std::int32_t> busy_{0};
  std::atomic<std::uint32_t> generation_{0};  // 32 bits: waited on with a futex
  bool stopping_ = false;
  std::mutex error_mutex_;
  std::size_t error_index_ = 0;
  std::exception_ptr error_;
};

/// Whether to share the next loop out or run it on the caller's thread alone, by the wall time
/// each way took lately. On a machine shared with other work a loop waits for a worker that
/// waits for a core, and sharing is slower than one thread (10 robots took 1.95x the wall time
/// of one thread under a load of 5); which is faster changes with the load. Loops run in blocks
/// of kBlock one way, and the way whose latest block took less per loop (the median: a loop the
/// system preempted must not decide) is kept; it starts on the caller's thread, which never
/// loses to one thread, and now and then a probe of kProbe loops runs the other way. The first
/// loop after a change of way is not counted (the workers wake from their sleep, the caches
/// refill). A probe costs most when the other way is much slower (a shared loop waiting
/// milliseconds for a core): a probe loop slower than kAbortRatio times the other way ends the
/// probe at once and puts the next a quarter of kProbeEveryMax blocks away; each probe that
/// confirms the choice doubles the blocks until the next, from kProbeEvery up to kProbeEveryMax.
/// The results never depend on it, only the speed.
class LoopWayChooser {
 public:
  static constexpr int kBlock = 20;
  static constexpr int kProbe = 8;
  static constexpr std::int64_t kProbeEvery = 16;
  static constexpr std::int64_t kProbeEveryMax = 1024;
  static constexpr std::int64_t kAbortRatio = 4;

  /// True: share the next loop out (ParallelLoop::for_each); false: run it inline.
  bool shared() const { return shared_; }
  /// Loops timed, and of those shared out (what the benchmarks report).
  std::int64_t loops() const { return loops_; }
  std::int64_t shared_loops() const { return shared_loops_; }
  /// The wall time the loop just run took [ns].
  void took(std::int64_t ns);

 private:
  void decide();  // the way of the next block, from latest_ns_
  bool shared_ = false;
  bool probing_ = false;  // the current block is a probe of the other way
  bool way_changed_ = true;
  std::int64_t loops_ = 0,
               shared_loops_ = 0;  // the current block's first loop is the first of its way
  int in_block_ = 0;
  std::array<std::int64_t, kBlock> block_ns_{};
  std::int64_t blocks_until_probe_ = kProbeEvery;
  std::int64_t probe_every_ = kProbeEvery;
  // The latest block's time per loop, inline [0] and shared [1]; < 0: not measured yet.
  std::int64_t latest_ns_[2] = {-1, -1};
};

}  // namespace locsim
