// A fork-join loop over a fixed set of threads, for the independent work inside one run (the
// sensors of different robots). Results do not depend on the thread count as long as each
// iteration writes only its own outputs: which thread runs an iteration varies, what it computes
// does not.
#pragma once

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

}  // namespace locsim
