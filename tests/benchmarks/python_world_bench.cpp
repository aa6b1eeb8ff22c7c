// locsim.World from Python (python/ext/world_module.cpp) measured as a notebook uses it: an
// embedded python3 imports the built module _locsim_world and steps the demo world with every
// sensor, converting each reading to a dict of numpy arrays. Counters: real_time_factor (simulated
// seconds per wall second) and readings_per_s. Its own program: the embedded interpreter is
// started here, where locsim_bench loads the python plugin, which starts its own.
#include <benchmark/benchmark.h>
#include <pybind11/embed.h>

#include <string>

namespace py = pybind11;

namespace {

/// `chunk_s` of simulated time per call (run_until then readings(), or step() and readings()
/// after every step when `chunk_s` is 0).
void BM_PythonWorld(benchmark::State& state, double chunk_s) {
  py::module_::import("sys").attr("path").attr("insert")(0, LOCSIM_PYTHON_EXTENSION_DIR);
  const py::module_ module = py::module_::import("_locsim_world");
  const std::string world_file = std::string(LOCSIM_SOURCE_DIR) + "/worlds/demo/demo.yaml";
  double simulated_s = 0.0;
  std::size_t readings = 0;
  for (auto _ : state) {
    state.PauseTiming();
    py::object world = module.attr("World")(world_file, 1, py::none(), 60.0, true);
    const double dt_s = world.attr("dt_s").cast<double>();
    state.ResumeTiming();
    if (chunk_s > 0.0) {
      for (double t_s = chunk_s; t_s <= 10.0 + 1e-9; t_s += chunk_s) {
        world.attr("run_until")(t_s);
        readings += py::len(world.attr("readings")());
      }
    } else {
      const auto steps = static_cast<long>(10.0 / dt_s + 0.5);
      for (long i = 0; i < steps; ++i) {
        world.attr("step")();
        readings += py::len(world.attr("readings")());
      }
    }
    simulated_s += 10.0;
  }
  state.counters["real_time_factor"] = benchmark::Counter(simulated_s, benchmark::Counter::kIsRate);
  state.counters["readings_per_s"] =
      benchmark::Counter(static_cast<double>(readings), benchmark::Counter::kIsRate);
}
BENCHMARK_CAPTURE(BM_PythonWorld, demo_run_until_1s, 1.0)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_PythonWorld, demo_step_by_step, 0.0)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  const py::scoped_interpreter python;
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
