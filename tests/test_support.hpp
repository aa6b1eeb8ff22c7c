// Helpers shared by the tests: worlds from inline YAML, and driving a simulation.
#pragma once

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "sim/common/yaml_node.hpp"
#include "sim/consumers/frame_state.hpp"
#include "sim/producers/simulation.hpp"
#include "sim/scenario/scenario_loader.hpp"
#include "sim/world/world_loader.hpp"

namespace locsim::testing {

// The test binary is not next to build/plugins: tell the plugin search path where ours are.
inline const bool kPluginPathSet = [] {
  setenv("LOCSIM_PLUGIN_PATH", LOCSIM_BUILD_PLUGIN_DIR, 1);
  return true;
}();

inline const std::string kDemo = std::string(LOCSIM_SOURCE_DIR) + "/worlds/demo/demo.yaml";

#ifdef LOCSIM_TEST_PLUGIN_DIR
/// The shared library of one of the test plugins (tests/plugins), e.g. "probe".
inline std::string test_plugin(const std::string& kind) {
  return std::string(LOCSIM_TEST_PLUGIN_DIR) + "/locsim_test_" + kind + ".so";
}
#endif

inline WorldDef world_from_yaml(const std::string& text) {
  return parse_world(YamlNode::load_string(text, "test.yaml"), ".");
}

/// A simulation of `world_yaml`, using its scenario section (or idle defaults).
inline Simulation make_sim(const std::string& world_yaml, std::uint64_t seed = 1) {
  WorldDef world = world_from_yaml(world_yaml);
  ScenarioDef scenario = world.scenario.value_or(ScenarioDef{});
  if (!world.scenario) scenario.duration_s = 1e6;  // the test decides how long to step
  bind_scenario(scenario, world);
  return Simulation(world, scenario, seed);
}

/// Steps `sim` for `seconds`, commanding (v, w) to robot 0 before every step.
inline void drive_for(Simulation& sim, double seconds, double v_mps, double w_radps) {
  const auto steps = static_cast<long>(std::llround(seconds / sim.dt_s()));
  for (long i = 0; i < steps; ++i) {
    sim.robot(0).command(v_mps, w_radps);
    sim.step();
  }
}

inline std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

/// A JSON file's text, in its own key order, without its wall-clock "timing" block (which it
/// must have).
inline std::string json_without_timing(const std::filesystem::path& file) {
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(read_file(file));
  EXPECT_TRUE(j.contains("timing")) << file;
  j.erase("timing");
  return j.dump();
}

/// One localizer's block of a metrics.json (a failure, and an empty object, when it has none).
inline nlohmann::json localizer_entry(const std::filesystem::path& metrics_file,
                                      const std::string& label) {
  const nlohmann::json metrics = nlohmann::json::parse(read_file(metrics_file));
  for (const nlohmann::json& e : metrics["localizers"]) {
    if (e["label"] == label) return e;
  }
  ADD_FAILURE() << "no localizer " << label << " in " << metrics_file;
  return {};
}

/// `text` (a message) holds `part`; says both when not.
inline void expect_contains(const std::string& text, const std::string& part) {
  EXPECT_NE(text.find(part), std::string::npos) << "message: " << text << "\nexpected: " << part;
}

/// A stand-in for the locsim binary that each run executes (SweepOptions::locsim_binary; a Slurm
/// sweep's array tasks run it too): a shell script doing `cases` (a `case "$*" in` body matched
/// against the run's arguments) and handing every other run to the real locsim. It makes a run end
/// in error or crash at run time, after the sweep's checks, whatever locsim and its plugins do:
/// deterministic, and independent of how `run`/`replay` report a plugin's failures.
inline std::filesystem::path write_stand_in(const std::filesystem::path& dir,
                                            const std::string& cases) {
  const std::filesystem::path script = dir / "locsim_stand_in.sh";
  std::ofstream(script) << "#!/bin/sh\ncase \"$*\" in\n"
                        << cases << "esac\nexec " << LOCSIM_BINARY << " \"$@\"\n";
  std::filesystem::permissions(script, std::filesystem::perms::owner_all);
  return script;
}

/// A fresh, empty temporary folder named after the running test and `name`, under a folder of
/// this build's own (named after a hash of its locsim binary's path): the test suites of two
/// builds (the ci and sanitize presets, two clones) may run at once without emptying each
/// other's folders (they did: a sweep test read a results file another build's run had
/// rewritten).
inline std::filesystem::path temp_dir(const std::string& name) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  char build[24];
  std::snprintf(build, sizeof(build), "locsim_tests-%08zx",
                std::hash<std::string>{}(LOCSIM_BINARY)&0xffffffffu);
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / build /
                                    (std::string(info->test_suite_name()) + "." + info->name()) /
                                    name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

/// This process's peak resident memory so far [MB].
inline long peak_rss_mb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024;
}

/// A shell command's exit code and its own peak resident memory [KiB] (output discarded): wait4
/// reports that process's, not the largest of every child this test has had.
struct Measured {
  int exit_code = -1;
  long peak_kb = 0;
};
inline Measured run_measured(const std::string& command_line) {
  const std::string command = "exec " + command_line + " >/dev/null 2>&1 </dev/null";
  Measured measured;
  const pid_t pid = fork();
  if (pid == 0) {
    execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  int status = 0;
  rusage usage{};
  if (pid > 0 && wait4(pid, &status, 0, &usage) == pid) {
    measured.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    measured.peak_kb = usage.ru_maxrss;
  }
  return measured;
}

/// What the `locsim` command did.
struct Outcome {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

/// A shell command line (no standard input; stderr with stdout).
inline Outcome run_command(const std::string& command_line) {
  const std::string command = command_line + " 2>&1 </dev/null";
  FILE* pipe = popen(command.c_str(), "r");
  Outcome outcome;
  if (pipe == nullptr) return outcome;
  char buffer[4096];
  std::size_t n = 0;
  while ((n = std::fread(buffer, 1, sizeof(buffer), pipe)) > 0) outcome.output.append(buffer, n);
  const int status = pclose(pipe);
  outcome.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return outcome;
}

/// `locsim ARGUMENTS` as a user runs it (no standard input).
inline Outcome locsim(const std::string& arguments) {
  return run_command(std::string(LOCSIM_BINARY) + " " + arguments);
}

/// A frame sink that keeps the frames it is given (no renderer needed).
class KeepFrames final : public FrameSink {
 public:
  void start(const WorldDef&) override {}
  void frame(const FrameState& frame) override { kept.push_back(frame); }
  void finish() override {}
  long frames() const override { return static_cast<long>(kept.size()); }
  std::vector<FrameState> kept;
};

}  // namespace locsim::testing
