// One record stream, two drivers: `run --log` and `replay` of that log wire the same session, so
// on every shipped world, with every built-in localizer that can be created there, they must
// write the same files and the same metrics, in a worker process or in-process alike. The
// convergence options must reach metrics.json in both.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "osmesa_support.hpp"
#include "render/rendered_camera.hpp"
#include "sim/common/errors.hpp"
#include "sim/common/math.hpp"
#include "sim/run/replay.hpp"
#include "sim/run/runner.hpp"
#include "sim/run/session.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;

// Every built-in plugin, with parameters that keep the particle filters small (the test is about
// the stream, not about accuracy; the non-default values also travel through both drivers).
const std::map<std::string, std::string> kBuiltins = {
    {"odometry", "odometry"},
    {"ekf_landmarks", "ekf_landmarks"},
    {"mcl", "mcl:particles=100"},
    {"srl", "srl:particles=100"},
    {"asrl", "asrl:particles=100"},
    {"augmented_mcl", "augmented_mcl:particles=100"},
    {"amcl", "amcl:min_particles=50,max_particles=200"},
    {"omni_kf", "omni_kf"},
    {"ultrasonic_ekf", "ultrasonic_ekf"},
    {"ultrasonic_amcl", "ultrasonic_amcl:min_particles=50,max_particles=200"},
    {"beacon_mcl", "beacon_mcl:particles=100"},
    {"fastslam", "fastslam:particles=5"},
    {"fastslam_afsa", "fastslam_afsa:particles=5"},
    {"pso_pf", "pso_pf:particles=5"},
};

// What some worlds lack, by the plugins that need it: their create fails there, and they are left
// out. (The SLAM filters, meant for `landmarks_known: false` worlds such as fastslam/, are created
// on every world and run there too: they are tested everywhere.)
const std::set<std::string> kNeedLandmarks = {"mcl", "srl", "asrl", "augmented_mcl", "omni_kf"};
const std::set<std::string> kNeedBeacons = {"ultrasonic_ekf", "ultrasonic_amcl", "beacon_mcl"};

struct WorldCase {
  std::string file;                 // under worlds/
  double duration_s;                // long enough for every sensor, and the kidnap if any
  bool kidnapped;                   // a kidnap happens within duration_s
  std::set<std::string> not_there;  // plugins whose create fails on this world
};

// Failure messages name the world, not the struct's bytes.
void PrintTo(const WorldCase& world, std::ostream* out) {
  *out << world.file;
}

std::set<std::string> operator+(std::set<std::string> a, const std::set<std::string>& b) {
  a.insert(b.begin(), b.end());
  return a;
}

const WorldCase kWorlds[] = {
    {"asrl/field.yaml", 4.0, false, kNeedBeacons},
    {"asrl/field_rendered.yaml", 2.0, false, kNeedBeacons},
    // The first kidnap is at 20 s, the robot is put down at 22 s.
    {"demo/demo.yaml", 23.0, true, {}},
    {"demo/four_robots.yaml", 4.0, false, kNeedLandmarks + kNeedBeacons},
    {"fastslam/field.yaml", 5.0, false, kNeedLandmarks + kNeedBeacons},
    {"fastslam/field_noisy.yaml", 5.0, false, kNeedLandmarks + kNeedBeacons},
    // A kidnap to a random pose at 60 s (the kidnap stream, through the log).
    {"maps/office_world.yaml", 60.5, true, kNeedBeacons},
    {"omni/hall.yaml", 4.0, false, kNeedBeacons},
    {"ultrasonic/lab.yaml", 4.0, false, kNeedLandmarks},
    {"ultrasonic/matlab.yaml", 4.0, false, kNeedLandmarks},
    // One of each family of the generated suite (the others are the generator's output too:
    // Generator.TheShippedSuiteIsWhatTheGeneratorDrawsToday).
    {"suite/room_seed1.yaml", 4.0, false, {}},
    {"suite/corridor_seed1.yaml", 4.0, false, {}},
    {"suite/office_seed1.yaml", 4.0, false, {}},
};

// Not a world: the map_server description that maps/office_world.yaml uses.
const char* const kNotAWorld = "maps/office.yaml";

// Non-default values of every option, each different from the others.
ConvergenceCriterion non_default_convergence() {
  ConvergenceCriterion c;
  c.position_m = 0.3;
  c.heading_rad = deg_to_rad(20.0);
  c.hold_samples = 4;
  return c;
}

fs::path worlds_dir() {
  return fs::path(LOCSIM_SOURCE_DIR) / "worlds";
}

using testing::osmesa_imager;

/// Every regular file under `dir`, relative to it, sorted.
std::vector<fs::path> files_under(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file()) out.push_back(fs::relative(entry.path(), dir));
  }
  std::sort(out.begin(), out.end());
  return out;
}

nlohmann::ordered_json parsed_without_timing(const fs::path& file) {
  auto j = nlohmann::ordered_json::parse(testing::read_file(file));
  EXPECT_TRUE(j.contains("timing")) << file;
  j.erase("timing");
  return j;
}

/// `b` holds the same files as `a`: byte for byte, but for the wall-clock "timing" blocks of the
/// JSON files and the producer's own keys of run.json.
void expect_same_folder(const fs::path& a, const fs::path& b) {
  const std::vector<fs::path> files = files_under(a);
  EXPECT_EQ(files, files_under(b)) << a << " and " << b << " hold different files";
  for (const fs::path& file : files) {
    if (!fs::exists(b / file)) continue;
    if (file.filename() == "metrics.json") {
      EXPECT_EQ(parsed_without_timing(a / file).dump(), parsed_without_timing(b / file).dump())
          << file;
    } else if (file.filename() == "run.json") {
      const auto run_a = nlohmann::ordered_json::parse(testing::read_file(a / file));
      const auto run_b = nlohmann::ordered_json::parse(testing::read_file(b / file));
      for (const char* key : {"status", "seed", "localizers", "config"}) {
        ASSERT_TRUE(run_a.contains(key)) << key;
        EXPECT_EQ(run_a[key].dump(), run_b.value(key, nlohmann::ordered_json()).dump())
            << "run.json: " << key;
      }
    } else {
      EXPECT_TRUE(testing::read_file(a / file) == testing::read_file(b / file))
          << file << " differs between " << a << " and " << b;
    }
  }
}

/// The plugins that can be created on `inputs` (in this process, nothing written).
std::set<std::string> creatable(const RunInputs& inputs) {
  std::set<std::string> out;
  for (const auto& [plugin, spec] : kBuiltins) {
    SessionOptions options;
    options.localizers = {spec};
    options.isolate = false;
    try {
      Session session(options, inputs.world, inputs.scenario, 1, nullptr);
      out.insert(plugin);
    } catch (const PluginError&) {
    }
  }
  return out;
}

TEST(Stream, TheBuiltinPluginsAreTheOnesTested) {
  // The build's plugin folder only: the search path also finds the tests' own plugins.
  std::set<std::string> found;
  for (const auto& entry : fs::directory_iterator(LOCSIM_BUILD_PLUGIN_DIR)) {
    const std::string name = entry.path().filename().string();  // locsim_NAME.so
    if (name.starts_with("locsim_") && name.ends_with(".so")) {
      found.insert(name.substr(7, name.size() - 7 - 3));
    }
  }
  // The python plugin is a loader: its scripts are tested in python_plugin_test.cpp (in and out of
  // process a numpy filter agrees to the files' decimals, not always to the last bit).
  EXPECT_EQ(found.erase("python"), 1u);
  std::set<std::string> tested;
  for (const auto& [plugin, spec] : kBuiltins) tested.insert(plugin);
  EXPECT_EQ(found, tested) << "a plugin was added or removed: update kBuiltins";
}

TEST(Stream, EveryShippedWorldIsTested) {
  std::set<std::string> found;
  for (const auto& folder : fs::directory_iterator(worlds_dir())) {
    if (!folder.is_directory()) continue;
    for (const auto& entry : fs::directory_iterator(folder.path())) {
      if (entry.path().extension() != ".yaml") continue;
      found.insert(fs::relative(entry.path(), worlds_dir()).generic_string());
    }
  }
  ASSERT_TRUE(found.erase(kNotAWorld)) << kNotAWorld << " is gone: update kNotAWorld";
  std::erase_if(found, [](const std::string& file) {
    return file.starts_with("suite/") && !file.ends_with("_seed1.yaml");
  });
  EXPECT_THROW(load_run_inputs(worlds_dir() / kNotAWorld, std::nullopt, std::nullopt), InputError);
  std::set<std::string> tested;
  for (const WorldCase& w : kWorlds) tested.insert(w.file);
  EXPECT_EQ(found, tested) << "a world was added or removed: update kWorlds";
}

class RunEqualsReplay : public ::testing::TestWithParam<WorldCase> {};

TEST_P(RunEqualsReplay, SameFilesAndMetricsInAndOutOfProcess) {
  const WorldCase& world = GetParam();
  const fs::path world_file = worlds_dir() / world.file;
  const RunInputs inputs = load_run_inputs(world_file, std::nullopt, world.duration_s);

  // The plugins that apply: those whose create succeeds, and no other than expected, so that a
  // plugin that stops working is not silently left out.
  const std::set<std::string> applies = creatable(inputs);
  std::set<std::string> expected;
  for (const auto& [plugin, spec] : kBuiltins) {
    if (!world.not_there.contains(plugin)) expected.insert(plugin);
  }
  EXPECT_EQ(applies, expected);
  std::vector<std::string> localizers;
  for (const std::string& plugin : applies) localizers.push_back(kBuiltins.at(plugin));

  const fs::path dir = testing::temp_dir("stream");
  RunOptions run;
  run.world_file = world_file;
  run.duration_s = world.duration_s;
  run.seed = 11;
  run.out_dir = dir / "run";
  run.log_file = dir / "run.locsimlog";
  run.localizers = localizers;
  run.convergence = non_default_convergence();
  run.make_landmark_imager = osmesa_imager();
  const RunResult ran = run_simulation(run);
  ASSERT_EQ(ran.status, "completed");
  EXPECT_TRUE(ran.failed_localizers.empty());

  // The run did what the test is for: every sensor fired, the kidnap happened.
  for (const fs::path& file : files_under(run.out_dir)) {
    if (file.parent_path().filename() != "readings" || file.extension() != ".csv") continue;
    const std::string text = testing::read_file(run.out_dir / file);
    EXPECT_GE(std::count(text.begin(), text.end(), '\n'), 3) << file << ": too few readings";
  }
  const std::string events = testing::read_file(run.out_dir / "events.csv");
  EXPECT_EQ(events.find(",kidnap,") != std::string::npos, world.kidnapped) << events;

  // Every localizer's metrics report the criterion they were given.
  const ConvergenceCriterion criterion = non_default_convergence();
  int entries = 0;
  for (const fs::path& file : files_under(run.out_dir)) {
    if (file.filename() != "metrics.json") continue;
    const auto metrics = nlohmann::json::parse(testing::read_file(run.out_dir / file));
    for (const auto& entry : metrics["localizers"]) {
      ++entries;
      const auto& c = entry["convergence"];
      EXPECT_EQ(c["position_m"].get<double>(), criterion.position_m) << entry["label"];
      EXPECT_NEAR(c["heading_deg"].get<double>(), 20.0, 1e-12) << entry["label"];
      EXPECT_EQ(c["hold_samples"].get<int>(), criterion.hold_samples) << entry["label"];
    }
  }
  EXPECT_EQ(entries, static_cast<int>(localizers.size() * inputs.world.robots.size()));

  for (const bool isolate : {true, false}) {
    ReplayOptions replay;
    replay.log_file = *run.log_file;
    replay.out_dir = dir / (isolate ? "replay" : "replay_in_process");
    replay.localizers = localizers;
    replay.convergence = criterion;
    replay.isolate = isolate;
    const ReplayResult replayed = replay_log(replay);
    EXPECT_EQ(replayed.status, "completed");
    EXPECT_DOUBLE_EQ(replayed.replayed_s, world.duration_s);
    SCOPED_TRACE(isolate ? "replay in worker processes" : "replay in-process");
    expect_same_folder(run.out_dir, replay.out_dir);
  }
}

// Test names after the world files: RunEqualsReplay.SameFiles.../demo_demo.
std::string world_case_name(const ::testing::TestParamInfo<WorldCase>& param) {
  std::string name = fs::path(param.param.file).replace_extension().string();
  std::replace(name.begin(), name.end(), '/', '_');
  return name;
}

INSTANTIATE_TEST_SUITE_P(ShippedWorlds, RunEqualsReplay, ::testing::ValuesIn(kWorlds),
                         world_case_name);

}  // namespace
}  // namespace locsim
