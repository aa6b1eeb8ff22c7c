#include "sim/common/parallel.hpp"

#include <algorithm>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace locsim {

namespace {

void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
  _mm_pause();
#else
  std::this_thread::yield();
#endif
}

/// Waits until `value` differs from `old`: a short spin first, since a run's loops come one
/// physics step apart (tens of microseconds, less than a futex round trip costs on a VM), then
/// asleep, so that idle threads leave the cores to the localizers' processes.
template <class T>
void wait_for_change(const std::atomic<T>& value, T old) {
  constexpr int kSpins = 2000;  // about 10-50 us of pause instructions
  for (int i = 0; i < kSpins; ++i) {
    if (value.load(std::memory_order_acquire) != old) return;
    cpu_relax();
  }
  while (value.load(std::memory_order_acquire) == old) value.wait(old, std::memory_order_acquire);
}

}  // namespace

int default_thread_count() {
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

ParallelLoop::ParallelLoop(int threads) {
  for (int i = 1; i < threads; ++i) workers_.emplace_back([this] { work(); });
}

ParallelLoop::~ParallelLoop() {
  stopping_ = true;  // published by the release below
  generation_.fetch_add(1, std::memory_order_release);
  generation_.notify_all();
  workers_.clear();  // joins
}

void ParallelLoop::work() {
  std::uint32_t seen = 0;
  for (;;) {
    wait_for_change(generation_, seen);
    seen = generation_.load(std::memory_order_acquire);
    if (stopping_) return;
    run_iterations();
    if (busy_.fetch_sub(1, std::memory_order_acq_rel) == 1) busy_.notify_one();
  }
}

void ParallelLoop::run_iterations() {
  for (;;) {
    const std::size_t first = next_.fetch_add(grain_, std::memory_order_relaxed);
    if (first >= size_) return;
    for (std::size_t i = first; i < std::min(first + grain_, size_); ++i) {
      try {
        (*body_)(i);
      } catch (...) {
        const std::lock_guard lock(error_mutex_);
        if (!error_ || i < error_index_) error_ = std::current_exception(), error_index_ = i;
      }
    }
  }
}

void ParallelLoop::for_each(std::size_t n, const std::function<void(std::size_t)>& body) {
  if (workers_.empty() || n < 2) {
    for (std::size_t i = 0; i < n; ++i) body(i);
    return;
  }
  body_ = &body;
  size_ = n;
  // Runs of neighbouring iterations (whose data tend to be neighbours in memory) per hand-out,
  // about eight per thread: few enough to share cache lines rarely, enough to balance.
  grain_ = std::max<std::size_t>(1, n / (8 * static_cast<std::size_t>(threads())));
  error_ = nullptr;
  next_.store(0, std::memory_order_relaxed);
  const auto workers = static_cast<std::int32_t>(workers_.size());
  busy_.store(workers, std::memory_order_relaxed);
  generation_.fetch_add(1, std::memory_order_release);  // publishes the loop to the workers
  generation_.notify_all();
  run_iterations();
  // Every worker takes part in every loop (one that finds nothing left leaves at once), so the
  // loop is over when all have checked out.
  for (std::int32_t left = busy_.load(std::memory_order_acquire); left != 0;
       left = busy_.load(std::memory_order_acquire)) {
    wait_for_change(busy_, left);
  }
  body_ = nullptr;
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
}

void LoopWayChooser::took(std::int64_t ns) {
  ++loops_;
  shared_loops_ += shared_ ? 1 : 0;
  block_ns_[static_cast<std::size_t>(in_block_)] = ns;
  const std::int64_t other_ns = latest_ns_[shared_ ? 0 : 1];
  const bool counted = in_block_ > 0 || !way_changed_;
  if (probing_ && counted && other_ns >= 0 && ns > kAbortRatio * other_ns) {
    latest_ns_[shared_ ? 1 : 0] = ns;  // far slower: the probe has said enough, and the next
    probe_every_ = std::max(probe_every_, kProbeEveryMax / 8);  // waits long (doubled below)
  } else {
    if (++in_block_ < (probing_ ? kProbe : kBlock)) return;
    const auto first = block_ns_.begin() + (way_changed_ ? 1 : 0),
               end = block_ns_.begin() + in_block_;
    const auto middle = first + (end - first) / 2;
    std::nth_element(first, middle, end);
    latest_ns_[shared_ ? 1 : 0] = *middle;
  }
  in_block_ = 0;
  const bool was_shared = shared_;
  decide();
  way_changed_ = shared_ != was_shared;
}

void LoopWayChooser::decide() {
  if (latest_ns_[1] < 0) {  // after the first block (on the caller's thread): a probe shared out
    probing_ = true;
    shared_ = true;
    return;
  }
  const bool faster_shared = latest_ns_[1] <= latest_ns_[0];
  if (probing_) {
    probing_ = false;
    // The probe found the choice still right: probe half as often; else from the start again.
    probe_every_ =
        faster_shared == !shared_ ? std::min(2 * probe_every_, kProbeEveryMax) : kProbeEvery;
    blocks_until_probe_ = probe_every_;
  } else if (--blocks_until_probe_ <= 0) {
    probing_ = true;
    shared_ = !faster_shared;  // the other way, for kProbe loops
    return;
  }
  shared_ = faster_shared;
}

}  // namespace locsim
