// Localizer parameter files (`--params FILE`, an experiment's `params_file:`): what wins over
// what, the warnings and errors a user sees (with the file's line and key), and the values
// arriving in metrics.json through run, replay and a sweep.
#include "sim/plugin_host/param_file.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "sim/experiments/experiment.hpp"
#include "sim/experiments/sweep.hpp"
#include "sim/plugin_host/localizer_instance.hpp"
#include "sim/plugin_host/plugin_library.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

using testing::kDemo;

using testing::test_plugin;

fs::path write(const fs::path& file, const std::string& text) {
  std::ofstream(file) << text;
  return file;
}

// Both test plugins declare `count` (test_probe in [1, 100], default 10; test_slam_map in
// [0, 1000], default 1000); only test_probe declares gain, verbose and mode, only test_slam_map
// offset_x and offset_y (default 0.4).
const std::string kCalibration =
    "# as `locsim calibrate` writes it: other top-level keys are its own\n"
    "sensors: {range_bearing: {sigma_range_m: 0.1}}\n"
    "localizer_params:\n"
    "  gain: 0.25\n"
    "  count: 20\n"
    "  mode: slow\n"
    "  test_probe:\n"
    "    count: 30\n"
    "  test_slam_map:\n"
    "    offset_x: 1.5\n";

/// The message of the InputError that `f` throws, or "accepted".
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "accepted";
}

TEST(ParamFile, SpecWinsOverThePluginsSectionOverCommonValuesOverDefaults) {
  const fs::path file = write(testing::temp_dir("params") / "calibration.yaml", kCalibration);
  const auto params = std::make_shared<const ParamFile>(load_param_file(file));
  const PluginLibrary probe(test_plugin("probe")), slam(test_plugin("slam_map"));

  LocalizerSpec spec = parse_localizer_spec("probe:mode=medium");
  spec.params_file = params;
  const json probe_values = ParamSet(probe.table(), spec).to_json();
  EXPECT_EQ(probe_values["mode"], "medium");  // the spec, over the common value
  EXPECT_EQ(probe_values["count"], 30);       // the plugin's section, over the common value
  EXPECT_EQ(probe_values["gain"], 0.25);      // a common value, over the default 0.5
  EXPECT_EQ(probe_values["verbose"], false);  // the default

  spec = parse_localizer_spec("slam");
  spec.params_file = params;
  const json slam_values = ParamSet(slam.table(), spec).to_json();
  EXPECT_EQ(slam_values["count"], 20);         // common; test_probe's section is not its own
  EXPECT_EQ(slam_values["offset_x"], 1.5);     // its section
  EXPECT_EQ(slam_values["offset_y"], 0.4);     // the default
  EXPECT_FALSE(slam_values.contains("gain"));  // a common value it does not declare: not its

  // Without the file, the defaults.
  EXPECT_EQ(ParamSet(probe.table(), parse_localizer_spec("probe")).to_json()["count"], 10);

  // Used by the two plugins, nothing is left over; either one alone leaves the other's keys,
  // which are another plugin's (a file written for several filters, as calibrate's): no warning.
  EXPECT_TRUE(param_file_warnings(*params, {&probe.table(), &slam.table()}).empty());
  EXPECT_TRUE(param_file_warnings(*params, {&slam.table()}).empty());
  EXPECT_TRUE(param_file_warnings(*params, {&probe.table()}).empty());

  // A key no plugin found declares (a misspelt name) is named, with its line.
  const fs::path typo = write(testing::temp_dir("params") / "typo.yaml",
                              "localizer_params:\n  gain: 0.25\n  gian: 0.3\n  test_probe:\n"
                              "    count: 30\n  test_prboe:\n    count: 1\n");
  const ParamFile typos = load_param_file(typo);
  const auto warnings = param_file_warnings(typos, {&probe.table()});
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_EQ(warnings[0], typo.string() +
                             ":3:9: 'localizer_params.gian' is declared by no plugin found "
                             "(this run's: test_probe; `locsim plugins` lists them all): ignored");
  testing::expect_contains(warnings[1], "'localizer_params.test_prboe' names no plugin found");
}

TEST(ParamFile, BadFilesAreRefusedWithTheirLineAndKey) {
  const fs::path dir = testing::temp_dir("params");
  const auto load_error = [&](const std::string& text) {
    const fs::path file = write(dir / "p.yaml", text);
    return error_of([&] { load_param_file(file); });
  };
  const std::string p = (dir / "p.yaml").string();
  testing::expect_contains(load_error("- 1\n- 2\n"),
                           p + ":1:1: expected a map with a 'localizer_params' key");
  testing::expect_contains(load_error("alpha1: 0.1\n"),
                           p + ":1:1: missing required key 'localizer_params'");
  testing::expect_contains(load_error("localizer_params: [1, 2]\n"),
                           p + ":1:19: 'localizer_params': expected a map of parameter values");
  testing::expect_contains(load_error("localizer_params:\n  gain: [1, 2]\n"),
                           p + ":2:9: 'localizer_params.gain': expected a number, true/false or a "
                               "string, as on the command line, got a list or a map");
  testing::expect_contains(load_error("localizer_params:\n  gain:\n"),
                           "'localizer_params.gain': no value");
  testing::expect_contains(load_error("localizer_params:\n  mcl: {alpha1: {a: 1}}\n"),
                           "'localizer_params.mcl.alpha1': expected a number");
  testing::expect_contains(load_error("localizer_params:\n  gain: 1\n  gain: 2\n"),
                           p + ":3:3: 'localizer_params.gain': key given twice");
  testing::expect_contains(load_error("localizer_params: {gain: [1\n"), p + ":");
  testing::expect_contains(error_of([&] { load_param_file(dir / "none.yaml"); }),
                           (dir / "none.yaml").string() + ": no such file");

  // Values are checked as the command line's are, at their place in the file.
  const PluginLibrary probe(test_plugin("probe"));
  const auto value_error = [&](const std::string& text) {
    LocalizerSpec spec = parse_localizer_spec("probe@p1");
    spec.params_file =
        std::make_shared<const ParamFile>(load_param_file(write(dir / "v.yaml", text)));
    return error_of([&] { ParamSet(probe.table(), spec); });
  };
  const std::string v = (dir / "v.yaml").string();
  EXPECT_EQ(value_error("localizer_params:\n  gain: 2\n"),
            v + ":2:9: 'localizer_params.gain': --localizer p1: parameter 'gain': 2 is outside "
                "[0.000000, 1.000000]");
  EXPECT_EQ(value_error("localizer_params:\n  count: 2.5\n"),
            v + ":2:10: 'localizer_params.count': --localizer p1: parameter 'count': expected an "
                "integer, got '2.5'");
  EXPECT_EQ(value_error("localizer_params:\n  test_probe: {verbose: yes}\n"),
            v + ":2:25: 'localizer_params.test_probe.verbose': --localizer p1: parameter "
                "'verbose': expected true or false, got 'yes'");
  // A key of the plugin's own section that it does not declare is a mistake, named.
  EXPECT_EQ(value_error("localizer_params:\n  test_probe:\n    gian: 0.1\n"),
            v + ":3:11: 'localizer_params.test_probe.gian': --localizer p1: plugin 'test_probe' "
                "has no parameter 'gian'; did you mean 'gain'? (parameters: gain, count, "
                "verbose, mode)");
  // A bad value the spec replaces is not used, so not checked.
  LocalizerSpec spec = parse_localizer_spec("probe:gain=0.1");
  spec.params_file = std::make_shared<const ParamFile>(
      load_param_file(write(dir / "w.yaml", "localizer_params: {gain: 2}\n")));
  EXPECT_EQ(ParamSet(probe.table(), spec).to_json()["gain"], 0.1);
}

/// `locsim ARGUMENTS` with the test plugins in the search path, so that they go by their names.
testing::Outcome locsim_with_test_plugins(const std::string& arguments) {
  return testing::run_command("LOCSIM_PLUGIN_PATH=" + std::string(LOCSIM_TEST_PLUGIN_DIR) + " " +
                              LOCSIM_BINARY + " " + arguments);
}

/// metrics.json's parameters of its only localizer.
json params_in(const fs::path& run) {
  return json::parse(testing::read_file(run / "metrics.json"))["localizers"][0]["params"];
}

TEST(ParamFile, RunAndReplayApplyItAndRecordItInRunJson) {
  const fs::path dir = testing::temp_dir("params");
  const fs::path file = write(dir / "calibration.yaml", kCalibration);
  const std::string probe = "test_probe:mode=medium";
  const testing::Outcome run = locsim_with_test_plugins(
      "run " + kDemo + " --duration 0.5 -q --out " + (dir / "run").string() + " --log " +
      (dir / "run.locsimlog").string() + " --localizer " + probe + " --params " + file.string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const json expected = {{"gain", 0.25}, {"count", 30}, {"verbose", false}, {"mode", "medium"}};
  EXPECT_EQ(params_in(dir / "run"), expected);
  EXPECT_EQ(json::parse(testing::read_file(dir / "run/run.json"))["params_file"], file.string());
  // test_slam_map's section: a plugin found, not run here, so no warning.
  EXPECT_EQ(run.output.find("warning"), std::string::npos) << run.output;

  const testing::Outcome replay = locsim_with_test_plugins(
      "replay " + (dir / "run.locsimlog").string() + " -q --out " + (dir / "replay").string() +
      " --localizer test_probe:count=5 --params " + file.string());
  ASSERT_EQ(replay.exit_code, 0) << replay.output;
  EXPECT_EQ(params_in(dir / "replay"),
            json({{"gain", 0.25}, {"count", 5}, {"verbose", false}, {"mode", "slow"}}));
  EXPECT_EQ(json::parse(testing::read_file(dir / "replay/run.json"))["params_file"], file.string());

  // Without --params: the defaults, and no params_file in run.json.
  const testing::Outcome plain =
      testing::locsim("replay " + (dir / "run.locsimlog").string() + " -q --out " +
                      (dir / "plain").string() + " --localizer " + test_plugin("probe"));
  ASSERT_EQ(plain.exit_code, 0) << plain.output;
  EXPECT_EQ(params_in(dir / "plain")["gain"], 0.5);
  EXPECT_FALSE(json::parse(testing::read_file(dir / "plain/run.json")).contains("params_file"));
}

TEST(ParamFile, AKeyNoPluginDeclaresWarnsOnceAndAPluginsUnknownKeyFailsTheRun) {
  const fs::path dir = testing::temp_dir("params");
  const fs::path file = write(dir / "p.yaml",
                              "localizer_params:\n  gian: 0.1\n  k_left: 0.002\n"
                              "  ekf_landmarks: {sigma_range_m: 0.2}\n  mlc: {alpha1: 0.1}\n");
  // Two localizers given the file: still one warning per key.
  const testing::Outcome run =
      testing::locsim("run " + kDemo + " --duration 0.2 -q --out " + (dir / "run").string() +
                      " --localizer " + test_plugin("probe") + " --localizer " +
                      test_plugin("probe") + "@second --params " + file.string());
  EXPECT_EQ(run.exit_code, 0) << run.output;
  const std::string gian = "locsim: warning: " + file.string() +
                           ":2:9: 'localizer_params.gian' is declared by no plugin found "
                           "(this run's: test_probe; `locsim plugins` lists them all): ignored";
  EXPECT_NE(run.output.find(gian), std::string::npos) << run.output;
  EXPECT_EQ(run.output.find(gian), run.output.rfind(gian)) << run.output;
  // ekf_landmarks' key (a plugin of the build, not run here): another plugin's, so no warning.
  EXPECT_EQ(run.output.find("'localizer_params.k_left'"), std::string::npos) << run.output;
  // ekf_landmarks is a plugin of the build (not run here: quiet); mlc is no plugin at all.
  EXPECT_EQ(run.output.find("localizer_params.ekf_landmarks"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find(file.string() + ":5:8: 'localizer_params.mlc' names no plugin found"),
            std::string::npos)
      << run.output;
  EXPECT_EQ(params_in(dir / "run")["gain"], 0.5);

  // An unknown key in the section of a plugin that runs: exit 2, nothing written.
  write(file, "localizer_params:\n  test_probe:\n    gain: 0.1\n    gian: 0.1\n");
  const testing::Outcome bad =
      testing::locsim("run " + kDemo + " --duration 0.2 -q --out " + (dir / "bad").string() +
                      " --localizer " + test_plugin("probe") + " --params " + file.string());
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  testing::expect_contains(bad.output, "locsim: error: " + file.string() +
                                           ":4:11: 'localizer_params.test_probe.gian': "
                                           "--localizer test_probe: plugin 'test_probe' has no "
                                           "parameter 'gian'; did you mean 'gain'?");
  EXPECT_FALSE(fs::exists(dir / "bad"));
  const testing::Outcome missing =
      testing::locsim("run " + kDemo + " --duration 0.2 -q --out " + (dir / "missing").string() +
                      " --params " + (dir / "none.yaml").string());
  EXPECT_EQ(missing.exit_code, 2) << missing.output;
  testing::expect_contains(missing.output, (dir / "none.yaml").string() + ": no such file");
}

TEST(ParamFile, AnExperimentsParamsFileReachesItsRunsAndItsFingerprint) {
  const fs::path dir = testing::temp_dir("params");
  write(dir / "common.yaml", "localizer_params:\n  gain: 0.25\n  count: 20\n  gian: 1\n");
  write(dir / "own.yaml", "localizer_params:\n  test_probe: {gain: 0.75}\n");
  const fs::path experiment =
      write(dir / "experiment.yaml",
            "name: params\nworld: " + kDemo +
                "\nduration_s: 0.5\nseeds: [1]\nparams_file: common.yaml\nlocalizers:\n"
                "  - plugin: " +
                test_plugin("probe") +
                "\n    label: common\n"
                "    params: {count: 3}\n"
                "  - plugin: " +
                test_plugin("probe") +
                "\n    label: own\n"
                "    params_file: own.yaml\n");
  SweepOptions options;
  options.experiment_file = experiment;
  options.out_dir = dir / "out";
  options.locsim_binary = LOCSIM_BINARY;
  ::testing::internal::CaptureStderr();
  const SweepSummary summary = run_sweep(options);
  const std::string warnings = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(summary.not_ok, 0u);
  // Once for the sweep, before it runs (each run's log.txt says it again for its localizer).
  const std::string gian = "locsim sweep: warning: " + (dir / "common.yaml").string() +
                           ":4:9: 'localizer_params.gian' is declared by no plugin found "
                           "(this run's: test_probe; `locsim plugins` lists them all): ignored";
  EXPECT_EQ(warnings.find(gian), 0u) << warnings;
  EXPECT_EQ(warnings.find(gian, 1), std::string::npos) << warnings;
  // The entry's params over the experiment's file; an entry's own file instead of it.
  const json common = params_in(dir / "out/runs/common/seed-1");
  EXPECT_EQ(common["gain"], 0.25);
  EXPECT_EQ(common["count"], 3);
  const json own = params_in(dir / "out/runs/own/seed-1");
  EXPECT_EQ(own["gain"], 0.75);
  EXPECT_EQ(own["count"], 10);
  const json files =
      json::parse(testing::read_file(dir / "out/sweep.json"))["fingerprint"]["files"];
  EXPECT_TRUE(files.contains("common.yaml") && files.contains("own.yaml")) << files.dump();

  // A changed params file is a changed input: --resume refuses to mix the results.
  write(dir / "own.yaml", "localizer_params:\n  test_probe: {gain: 0.8}\n");
  options.resume = true;
  testing::expect_contains(error_of([&] { run_sweep(options); }), "file own.yaml changed");

  // A bad value in a params file fails the sweep before anything runs, named in that file.
  write(dir / "own.yaml", "localizer_params:\n  test_probe: {gain: 2}\n");
  options.resume = false;
  options.out_dir = dir / "out2";
  testing::expect_contains(error_of([&] { run_sweep(options); }),
                           (dir / "own.yaml").string() +
                               ":2:22: 'localizer_params.test_probe.gain': --localizer own: "
                               "parameter 'gain': 2 is outside");
  EXPECT_FALSE(fs::exists(dir / "out2"));
  // A params file that is not there is named where the experiment gives it.
  write(experiment, "world: " + kDemo + "\nseeds: [1]\nlocalizers:\n  - plugin: " +
                        test_plugin("probe") + "\n    params_file: nowhere.yaml\n");
  testing::expect_contains(
      error_of([&] { load_experiment(experiment); }),
      experiment.string() + ":5:18: 'localizers[0].params_file': no such file");
}

}  // namespace
}  // namespace locsim
