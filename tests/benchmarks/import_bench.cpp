// `locsim import mrclam` on generated MRCLAM-format files of one robot and 300 s (odometry at
// 67 Hz, Vicon at 100 Hz, 3 barcode readings a second, as the real dataset): parsing, merging and
// writing the log. Counter: dataset lines read per second. And `locsim calibrate` on the imported
// log: reading it, pairing readings with the truth, and the likelihood fits (counter: log records
// per second). And `locsim twin` of it, with that calibration: reading the log, thinning the true
// path, the landmarks in view along it, writing and loading the world (counter: log records per
// second).
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "sim/common/files.hpp"
#include "sim/experiments/twin.hpp"
#include "sim/metrics/calibration.hpp"
#include "sim/producers/mrclam_import.hpp"

namespace {

namespace fs = std::filesystem;

std::size_t write_dataset(const fs::path& dir) {
  constexpr double kT0 = 1248444000.0, kDurationS = 300.0;
  std::size_t lines = 0;
  char text[160];
  std::ofstream(dir / "Barcodes.dat") << "# subject barcode\n1 5\n6 63\n7 81\n";
  std::ofstream(dir / "Landmark_Groundtruth.dat") << "# subject x y sx sy\n6 4 0 0 0\n7 4 2 0 0\n";
  std::ofstream odometry(dir / "Robot1_Odometry.dat"), truth(dir / "Robot1_Groundtruth.dat"),
      measurements(dir / "Robot1_Measurement.dat");
  for (double t = 0.0; t < kDurationS; t += 0.015, ++lines) {
    std::snprintf(text, sizeof(text), "%.3f \t 0.100 \t -0.050 \n", kT0 + t);
    odometry << text;
  }
  for (double t = 0.0; t < kDurationS; t += 0.01, ++lines) {
    std::snprintf(text, sizeof(text), "%.3f \t %.8f \t %.8f \t %.8f \n", kT0 + t, std::cos(t),
                  std::sin(t), std::fmod(t, 3.0));
    truth << text;
  }
  for (double t = 0.1; t < kDurationS; t += 0.33, ++lines) {
    std::snprintf(text, sizeof(text), "%.3f \t %d \t %.3f \t %.3f \n", kT0 + t,
                  lines % 2 == 0 ? 63 : 81, 2.0 + std::sin(t), 0.3 * std::cos(t));
    measurements << text;
  }
  return lines;
}

void BM_ImportMrclam(benchmark::State& state) {
  const fs::path dir = fs::temp_directory_path() / "locsim_bench_import";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::size_t lines = write_dataset(dir);
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        locsim::write_import(locsim::read_mrclam({dir, {1}}), {}, dir / "out.locsimlog"));
  }
  fs::remove_all(dir);
  state.counters["lines_per_s"] = benchmark::Counter(
      static_cast<double>(lines * state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ImportMrclam)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_CalibrateMrclam(benchmark::State& state) {
  const fs::path dir = fs::temp_directory_path() / "locsim_bench_calibrate";
  fs::remove_all(dir);
  fs::create_directories(dir);
  write_dataset(dir);
  const locsim::ImportSummary summary =
      locsim::write_import(locsim::read_mrclam({dir, {1}}), {}, dir / "out.locsimlog");
  for (auto _ : state) {
    benchmark::DoNotOptimize(locsim::calibrate({dir / "out.locsimlog"}, {}).to_yaml());
  }
  fs::remove_all(dir);
  state.counters["records_per_s"] = benchmark::Counter(
      static_cast<double>(summary.records * state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_CalibrateMrclam)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_TwinMrclam(benchmark::State& state) {
  const fs::path dir = fs::temp_directory_path() / "locsim_bench_twin";
  fs::remove_all(dir);
  fs::create_directories(dir);
  write_dataset(dir);
  const locsim::ImportSummary summary =
      locsim::write_import(locsim::read_mrclam({dir, {1}}), {}, dir / "out.locsimlog");
  locsim::write_file(dir / "calibration.yaml",
                     locsim::calibrate({dir / "out.locsimlog"}, {}).to_yaml());
  locsim::TwinOptions options;
  options.log = dir / "out.locsimlog";
  options.calibration = dir / "calibration.yaml";
  for (auto _ : state) {
    benchmark::DoNotOptimize(locsim::write_twin(options, dir / "twin" / "twin.yaml", true));
  }
  fs::remove_all(dir);
  state.counters["records_per_s"] = benchmark::Counter(
      static_cast<double>(summary.records * state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_TwinMrclam)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
