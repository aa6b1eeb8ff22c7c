// The fork-join loop behind --threads: every iteration runs once per loop, loop after loop, and
// errors come out as they would on one thread.
#include "sim/common/parallel.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <string>
#include <vector>

namespace locsim {
namespace {

TEST(ParallelLoop, RunsEveryIterationOncePerLoop) {
  for (const int threads : {1, 2, 3, 8}) {
    ParallelLoop loop(threads);
    EXPECT_EQ(loop.threads(), threads);
    std::vector<int> runs(1000, 0);
    for (int round = 0; round < 200; ++round) {
      // Sizes below, at and above the thread count, and zero.
      const std::size_t n = static_cast<std::size_t>((round * 37) % 1001);
      loop.for_each(n, [&](std::size_t i) { ++runs[i]; });
      for (std::size_t i = 0; i < runs.size(); ++i) {
        ASSERT_EQ(runs[i], i < n ? 1 : 0) << threads << " threads, loop of " << n << ", " << i;
        runs[i] = 0;
      }
    }
  }
}

TEST(ParallelLoop, UsesItsThreads) {
  ParallelLoop loop(2);
  // Two iterations that each wait for the other to start: done only if they run side by side.
  std::atomic<int> started{0};
  loop.for_each(2, [&](std::size_t) {
    started.fetch_add(1);
    while (started.load() < 2) {
    }
  });
  EXPECT_EQ(started.load(), 2);
}

TEST(ParallelLoop, RethrowsTheLowestIterationsErrorAfterRunningAll) {
  for (const int threads : {1, 4}) {
    ParallelLoop loop(threads);
    std::atomic<int> ran{0};
    try {
      loop.for_each(100, [&](std::size_t i) {
        ran.fetch_add(1);
        if (i == 17 || i == 42 || i == 99)
          throw std::runtime_error("failed at " + std::to_string(i));
      });
      ADD_FAILURE() << "no exception";
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()), "failed at 17");
    }
    // On one thread the loop is a plain loop and stops at the error; on several, the other
    // threads' iterations go on.
    if (threads == 1)
      EXPECT_EQ(ran.load(), 18);
    else
      EXPECT_GE(ran.load(), 18);
    // The loop is usable after an error.
    ran = 0;
    loop.for_each(10, [&](std::size_t) { ran.fetch_add(1); });
    EXPECT_EQ(ran.load(), 10);
  }
}

}  // namespace
}  // namespace locsim
