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

TEST(LoopWayChooser, KeepsTheFasterWayAndProbesTheOtherEverLessOften) {
  LoopWayChooser chooser;
  // Each way takes a fixed time per loop; `ways` records the way of each loop.
  std::int64_t shared_ns = 100, inline_ns = 40;
  std::vector<bool> ways;
  const auto run = [&](int loops) {
    for (int i = 0; i < loops; ++i) {
      ways.push_back(chooser.shared());
      chooser.took(chooser.shared() ? shared_ns : inline_ns);
    }
  };
  // Runs of one way: (shared, length), in order.
  const auto runs_of = [](const std::vector<bool>& w) {
    std::vector<std::pair<bool, int>> out;
    for (const bool way : w) {
      if (out.empty() || out.back().first != way) out.push_back({way, 0});
      ++out.back().second;
    }
    return out;
  };
  constexpr int kBlock = LoopWayChooser::kBlock, kProbe = LoopWayChooser::kProbe;
  run(200 * kBlock);
  auto runs = runs_of(ways);
  ASSERT_GE(runs.size(), 4u);
  // On the caller's thread first, which never loses to one thread; then a probe shared out; then
  // on the caller's thread, with probes of kProbe shared loops ever further apart (the choice
  // holds).
  EXPECT_EQ(runs[0], std::make_pair(false, kBlock));
  int last_gap = 0;
  for (std::size_t r = 1; r + 1 < runs.size(); r += 2) {
    EXPECT_EQ(runs[r], std::make_pair(true, kProbe)) << r;
    EXPECT_FALSE(runs[r + 1].first);
    if (r + 2 < runs.size()) {  // a whole gap between two probes
      EXPECT_GE(runs[r + 1].second, last_gap) << r;
      last_gap = runs[r + 1].second;
    }
  }
  EXPECT_GE(last_gap, 4 * LoopWayChooser::kProbeEvery * kBlock);  // doubled at least twice
  EXPECT_LE((runs.size() - 1) / 2, 5u);  // 16 + 32 + 64 + 128 blocks: the probes cost little

  // The load goes away: sharing is faster, found at the next probe and kept from then on, with
  // probes of the other way.
  shared_ns = 20;
  ways.clear();
  run(2000 * kBlock);
  runs = runs_of(ways);
  std::size_t switched = 0;
  while (switched < runs.size() && !(runs[switched].first && runs[switched].second > kProbe))
    ++switched;
  ASSERT_LT(switched, runs.size()) << "never shared again";
  for (std::size_t r = switched + 1; r < runs.size(); ++r) {
    if (!runs[r].first) {
      EXPECT_EQ(runs[r].second, kProbe) << r;
    }
  }
}

TEST(LoopWayChooser, AProbeFarSlowerThanTheChoiceEndsAtItsFirstCountedLoop) {
  // A shared loop that waits milliseconds for a core (a busy machine): each probe costs two
  // loops (the first after the change is not counted), not kProbe.
  LoopWayChooser chooser;
  std::vector<bool> ways;
  for (int i = 0; i < 100 * LoopWayChooser::kBlock; ++i) {
    ways.push_back(chooser.shared());
    chooser.took(chooser.shared() ? 1'000'000 : 40'000);
  }
  int shared = 0, run = 0;
  for (const bool way : ways) {
    run = way ? run + 1 : 0;
    shared += way ? 1 : 0;
    EXPECT_LE(run, 2);
  }
  EXPECT_GE(shared, 2);
  EXPECT_LE(shared, 8);  // the first probe and three or so more, ever further apart
}

}  // namespace
}  // namespace locsim
