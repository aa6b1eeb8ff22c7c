// A 40-run sweep of the demo world end to end (20 seeds x odometry and the EKF, 60 s each, every
// sensor on), at 1 and 2 jobs: parallel efficiency = time(1 job) / (2 x time(2 jobs)), target
// >= 90 % on 2 cores.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <fstream>

#include "sim/experiments/sweep.hpp"

namespace {

namespace fs = std::filesystem;

void BM_DemoSweep40Runs(benchmark::State& state) {
  const fs::path dir = fs::temp_directory_path() / "locsim_bench_sweep";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "experiment.yaml")
      << "world: " << LOCSIM_SOURCE_DIR << "/worlds/demo/demo.yaml\n"
      << "seeds: {from: 1, to: 20}\n"
      << "localizers: [{plugin: odometry}, {plugin: ekf_landmarks}]\n";
  int round = 0;
  for (auto _ : state) {
    locsim::SweepOptions options;
    options.experiment_file = dir / "experiment.yaml";
    options.out_dir = dir / ("out" + std::to_string(round++));
    options.jobs = static_cast<int>(state.range(0));
    options.locsim_binary = LOCSIM_BINARY;
    benchmark::DoNotOptimize(locsim::run_sweep(options));
  }
  fs::remove_all(dir);
  state.counters["runs_per_s"] = benchmark::Counter(40.0 * static_cast<double>(state.iterations()),
                                                    benchmark::Counter::kIsRate);
}
BENCHMARK(BM_DemoSweep40Runs)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kSecond)
    ->UseRealTime()
    ->Iterations(2);

}  // namespace

#include "sim/run/replay.hpp"
#include "sim/run/runner.hpp"

namespace {

/// The demo world's 60 s with the landmark EKF: simulated (every sensor, all logs written) vs
/// replayed from its recording as a sweep does (no readings/ written again). The ratio is what a
/// sweep over filter parameters saves per run. `isolate`: the EKF in its own process (the
/// default) or in locsim's; the difference is what isolation costs a run.
void BM_DemoEkf(benchmark::State& state) {
  const bool replay = state.range(0) == 1;
  const bool isolate = state.range(1) == 1;
  const fs::path dir = fs::temp_directory_path() / "locsim_bench_replay";
  fs::remove_all(dir);
  fs::create_directories(dir);  // the log is opened before the run makes its folder
  locsim::RunOptions run;
  run.world_file = fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml";
  run.out_dir = dir / "run";
  run.overwrite = true;
  run.localizers = {LOCSIM_BUILD_PLUGIN_DIR "/locsim_ekf_landmarks.so"};
  run.log_file = dir / "demo.locsimlog";
  run.isolate = isolate;
  locsim::run_simulation(run);
  for (auto _ : state) {
    if (replay) {
      locsim::ReplayOptions options;
      options.log_file = *run.log_file;
      options.out_dir = dir / "replay";
      options.overwrite = true;
      options.localizers = run.localizers;
      options.isolate = isolate;
      options.readings = false;
      benchmark::DoNotOptimize(locsim::replay_log(options));
    } else {
      benchmark::DoNotOptimize(locsim::run_simulation(run));
    }
  }
  fs::remove_all(dir);
  state.counters["real_time_factor"] = benchmark::Counter(
      60.0 * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_DemoEkf)
    ->ArgNames({"replay", "isolate"})
    ->ArgsProduct({{0, 1}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

#include "sim/metrics/error_metrics.hpp"

namespace {

/// What scoring one estimate costs, without a covariance (`consistency` 0) and with one (1: the
/// NEES and 95 % ellipse test, two Cholesky factorisations): the scorer runs it once per
/// localizer per ground-truth sample (50 Hz in the demo).
void BM_ScoreEstimate(benchmark::State& state) {
  const bool consistency = state.range(0) == 1;
  locsim::ErrorAccumulator accumulator;
  locsim::ErrorSample sample{0.0, 0.03, -0.02, 0.01, 0, std::nullopt};
  if (consistency) {
    sample.covariance =
        std::array<double, 9>{0.04, 0.01, 0.002, 0.01, 0.09, -0.003, 0.002, -0.003, 0.01};
  }
  for (auto _ : state) {
    sample.t_s += 0.02;
    accumulator.add(sample);
  }
  benchmark::DoNotOptimize(accumulator.summary());
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ScoreEstimate)->ArgName("consistency")->Arg(0)->Arg(1);

}  // namespace
