// libFuzzer target: bytes → a world file (and, after a `#@scenario` line, a scenario file) through
// the loaders `locsim run` and `validate` use, then the simulation built from them and stepped for
// its first few tenths of a second, every record of those steps through the log's binary codec.
//
// Besides libFuzzer's own byte-level mutations, a third of the mutants get one number of the text
// replaced by a value at the edge of what a double or an integer can hold (the mutation the
// boundary-value pass of issue 22 found most problems with; byte edits rarely make 1e300 out of
// 10).
//
// Expected outcomes: InputError (bad input, reported with file, line and key), and RenderError for
// a PTZ camera in mode: rendered (no renderer is loaded here). Anything else is a finding: a
// sanitizer report, an abort or assertion (Box2D's included), an uncaught exception (bad_alloc),
// an allocation over -malloc_limit_mb, or a hang past -timeout. Run: docs/testing.md.
#include <unistd.h>

#include <array>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>

#include "sim/common/errors.hpp"
#include "sim/producers/simulation.hpp"
#include "sim/producers/simulation_source.hpp"
#include "sim/run/runner.hpp"
#include "sim/stream/record_codec.hpp"
#include "sim/world/occupancy.hpp"
#include "sim/world/physics_world.hpp"

namespace fs = std::filesystem;

namespace {

// A comment in YAML, so that a world file with or without it stays a world file.
constexpr std::string_view kScenarioMarker = "\n#@scenario\n";
// Simulated time stepped per input, and at most this many steps whatever step_hz says.
constexpr double kStepFor_s = 0.3;
constexpr std::int64_t kMaxSteps = 300;

// clang-format off
constexpr std::array<std::string_view, 24> kEdgeValues = {
    "0", "-0", "-1", "0.5", "1e-300", "-1e-300", "5e-324", "1e-40", "1e38", "-1e38", "1e10",
    "1e17", "1e300", "-1e300", "1.7976931348623157e308", "2147483648", "-2147483649",
    "4294967297", "9223372036854775807", "18446744073709551616", ".nan", ".inf", "-.inf", "1e6"};
// clang-format on

// Replaces the `pick`-th number (mod their count) of data[0, size) with an edge value; returns
// the new size, or nothing when there is no number or the result would not fit.
std::optional<std::size_t> replace_a_number(std::uint8_t* data, std::size_t size,
                                            std::size_t max_size, unsigned int pick) {
  const auto is_start = [&](std::size_t i) {
    const bool digit = std::isdigit(data[i]) != 0;
    const bool signed_digit =
        (data[i] == '-' || data[i] == '+') && i + 1 < size && std::isdigit(data[i + 1]) != 0;
    const bool inside = i > 0 && (std::isalnum(data[i - 1]) != 0 || data[i - 1] == '.' ||
                                  data[i - 1] == '_' || data[i - 1] == '-');
    return (digit || signed_digit) && !inside;
  };
  const auto end_of = [&](std::size_t i) {
    ++i;
    while (i < size &&
           (std::isdigit(data[i]) != 0 || data[i] == '.' || data[i] == 'e' || data[i] == 'E' ||
            ((data[i] == '-' || data[i] == '+') && (data[i - 1] == 'e' || data[i - 1] == 'E')))) {
      ++i;
    }
    return i;
  };
  std::size_t count = 0;
  for (std::size_t i = 0; i < size; i = is_start(i) ? end_of(i) : i + 1) count += is_start(i);
  if (count == 0) return std::nullopt;
  std::size_t target = pick % count;
  for (std::size_t i = 0; i < size; i = is_start(i) ? end_of(i) : i + 1) {
    if (!is_start(i) || target-- != 0) continue;
    const std::size_t end = end_of(i);
    const std::string_view value = kEdgeValues[(pick / count) % kEdgeValues.size()];
    const std::size_t new_size = size - (end - i) + value.size();
    if (new_size > max_size) return std::nullopt;
    std::memmove(data + i + value.size(), data + end, size - end);
    std::memcpy(data + i, value.data(), value.size());
    return new_size;
  }
  return std::nullopt;
}

// The folder the inputs are written to, with the shipped map's files beside them so that
// `map: office.yaml` (worlds/maps/office_world.yaml, a seed) resolves as it does in its folder.
fs::path g_dir;

void remove_dir() {
  std::error_code ignored;
  fs::remove_all(g_dir, ignored);
}

void write(const fs::path& file, std::string_view text) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  if (!out.flush()) {
    std::perror(file.c_str());
    std::abort();  // not a finding in locsim: the harness cannot work
  }
}

// Every record a run would log, encoded, decoded and encoded again: the two encodings must agree.
class CodecRoundTrip final : public locsim::RecordConsumer {
 public:
  void consume(const locsim::Record& record) override {
    first_.clear();
    locsim::encode_record(record, first_);
    locsim::decode_record(record.type, first_, decoded_);
    second_.clear();
    locsim::encode_record(decoded_, second_);
    if (first_ != second_) {
      std::fprintf(stderr, "record codec: a decoded record encodes differently (type %d)\n",
                   static_cast<int>(record.type));
      std::abort();
    }
  }

 private:
  std::string first_, second_;
  locsim::Record decoded_;
};

}  // namespace

extern "C" std::size_t LLVMFuzzerMutate(std::uint8_t* data, std::size_t size, std::size_t max_size);

extern "C" std::size_t LLVMFuzzerCustomMutator(std::uint8_t* data, std::size_t size,
                                               std::size_t max_size, unsigned int seed) {
  if (seed % 3 == 0) {
    if (const auto new_size = replace_a_number(data, size, max_size, seed / 3)) return *new_size;
  }
  return LLVMFuzzerMutate(data, size, max_size);
}

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  std::string dir_template = (fs::temp_directory_path() / "locsim_fuzz_world.XXXXXX").string();
  if (mkdtemp(dir_template.data()) == nullptr) {
    std::perror("mkdtemp");
    std::abort();
  }
  g_dir = dir_template;
  std::atexit(remove_dir);
  const fs::path maps = fs::path(LOCSIM_SOURCE_DIR) / "worlds" / "maps";
  for (const char* name : {"office.yaml", "office.pgm"}) {
    fs::create_symlink(maps / name, g_dir / name);
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const std::size_t marker = input.find(kScenarioMarker);
  const fs::path world_file = g_dir / "world.yaml";
  const fs::path scenario_file = g_dir / "scenario.yaml";
  write(world_file, input.substr(0, marker));
  std::optional<fs::path> scenario;
  if (marker != std::string_view::npos) {
    write(scenario_file, input.substr(marker + kScenarioMarker.size()));
    scenario = scenario_file;
  }
  try {
    const locsim::RunInputs inputs = locsim::load_run_inputs(world_file, scenario, std::nullopt);
    // What a run with localizers builds besides the simulation: the static world's grid.
    const locsim::PhysicsWorld static_world(inputs.world);
    const locsim::OccupancyGrid grid = locsim::rasterize_static_world(
        static_world, inputs.scenario.localization.grid_resolution_m);
    locsim::Simulation sim(inputs.world, inputs.scenario, 1);
    locsim::SimulationSource source(sim);
    CodecRoundTrip codec;
    source.emit(codec);
    for (std::int64_t step = 0; !sim.done() && step < kMaxSteps && sim.time_s() < kStepFor_s;
         ++step) {
      sim.step();
      source.emit(codec);
    }
  } catch (const locsim::InputError&) {
  } catch (const locsim::RenderError&) {
  }
  return 0;
}
