// Writing outputs: the decimal text of every number a run writes (TUM rows, reading CSVs).
// Issue 21's target: output writing at least 2x cheaper, byte-identical. BM_FormatFixed compares
// the fast fixed format with the exact one (std::to_chars) on a TUM row's kind of values.
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "sim/common/format.hpp"
#include "sim/common/random.hpp"

namespace {

using namespace locsim;

void BM_FormatFixed(benchmark::State& state, bool fast) {
  RandomStream rng = make_stream(1, "bench/format");
  std::vector<double> values;
  for (int i = 0; i < 4096; ++i) values.push_back(rng.uniform(-20.0, 20.0));
  const int decimals[] = {4, 6, 6, 9};
  std::string out;
  std::size_t formatted = 0;
  for (auto _ : state) {
    out.clear();
    for (std::size_t i = 0; i < values.size(); ++i) {
      if (fast) {
        append_fixed(out, values[i], decimals[i % 4]);
      } else {
        append_fixed_exact(out, values[i], decimals[i % 4]);
      }
      out += ' ';
    }
    formatted += values.size();
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["values_per_s"] =
      benchmark::Counter(static_cast<double>(formatted), benchmark::Counter::kIsRate);
}
BENCHMARK_CAPTURE(BM_FormatFixed, fast, true)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_FormatFixed, exact_to_chars, false)->Unit(benchmark::kMicrosecond);

}  // namespace
