// Localizers written in Python (plugins/python, docs/python.md) are plugins like any other: the
// numpy particle filter runs in `run`, `replay` and a sweep beside the C++ filters with the same
// results every time and in either isolation mode; a script that raises, returns NaN or imports
// something missing fails alone with its file and line in metrics.json; a bad script is refused
// before the run with its file and line; parameters are declared, checked and documented.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "sim/common/errors.hpp"
#include "sim/plugin_host/localizer_instance.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using testing::kDemo;
using testing::locsim;
using testing::Outcome;

const std::string kScripts = std::string(LOCSIM_SOURCE_DIR) + "/tests/python_plugins/";

TEST(PythonPlugin, SpecNamesTheScript) {
  const LocalizerSpec a = parse_localizer_spec("python:filters/my_pf.py:particles=500@pf");
  EXPECT_EQ(a.plugin, "python");
  EXPECT_EQ(a.source, "filters/my_pf.py");
  ASSERT_EQ(a.params.size(), 1u);
  EXPECT_EQ(a.params[0].first, "particles");
  EXPECT_EQ(a.label, "pf");
  const LocalizerSpec b = parse_localizer_spec("filters/my_pf.py:particles=500");
  EXPECT_EQ(b.plugin, "python");
  EXPECT_EQ(b.source, "filters/my_pf.py");
  EXPECT_EQ(b.label, "my_pf");
  const LocalizerSpec c = parse_localizer_spec("python:landmark_pf");
  EXPECT_EQ(c.source, "landmark_pf");
  EXPECT_EQ(c.label, "landmark_pf");
  EXPECT_TRUE(c.params.empty());
  // Without a field lacking '=', it is a plugin's parameters as before; another plugin's field
  // without '=' is a source only when it names a file.
  const LocalizerSpec d = parse_localizer_spec("mcl:particles=10");
  EXPECT_TRUE(d.source.empty());
  EXPECT_EQ(d.label, "mcl");
  EXPECT_THROW(parse_localizer_spec("mcl:particles"), InputError);
  EXPECT_EQ(parse_localizer_spec("loader:dir/f.lua").source, "dir/f.lua");
}

TEST(PythonPlugin, NumpyParticleFilterRunsReplaysAndRepeats) {
  const fs::path dir = testing::temp_dir("python_plugin");
  const std::string common =
      " --duration 10 --seed 2 -q --localizer ekf_landmarks --localizer "
      "python:landmark_pf:particles=500";
  ASSERT_EQ(locsim("run " + kDemo + common + " --out " + (dir / "a").string() + " --log " +
                   (dir / "a.log").string())
                .exit_code,
            0);
  ASSERT_EQ(locsim("run " + kDemo + common + " --out " + (dir / "a2").string()).exit_code, 0);
  ASSERT_EQ(
      locsim("run " + kDemo + common + " --isolation none --out " + (dir / "b").string()).exit_code,
      0);
  const Outcome replay =
      locsim("replay " + (dir / "a.log").string() + " -q --localizer ekf_landmarks --localizer " +
             "python:landmark_pf:particles=500 --out " + (dir / "r").string());
  ASSERT_EQ(replay.exit_code, 0) << replay.output;
  const std::string estimate = testing::read_file(dir / "a/landmark_pf.tum");
  EXPECT_GT(estimate.size(), 10000u);
  EXPECT_EQ(estimate, testing::read_file(dir / "b/landmark_pf.tum"));
  EXPECT_EQ(estimate, testing::read_file(dir / "r/landmark_pf.tum"));
  // A rerun is byte-identical. In locsim's process rather than a worker the estimates agree to the
  // files' 6 decimals, not always to the last bit: numpy's SIMD sums round by the data's alignment.
  EXPECT_EQ(testing::json_without_timing(dir / "a/metrics.json"),
            testing::json_without_timing(dir / "a2/metrics.json"));
  const json pf = testing::localizer_entry(dir / "a/metrics.json", "landmark_pf");
  EXPECT_EQ(pf["status"], "ok");
  EXPECT_EQ(pf["plugin"], "landmark_pf");
  EXPECT_EQ(pf["params"]["particles"], 500);
  EXPECT_LT(pf["position_error_m"]["rms"].get<double>(), 0.5);  // it tracks: odometry drifts more
  EXPECT_EQ(pf["readings"], json::array({"odometry", "landmarks"}));
}

TEST(PythonPlugin, RaisingNanAndMissingImportFailAloneWithFileAndLine) {
  const fs::path dir = testing::temp_dir("python_plugin_failures");
  const std::string common = " --duration 4 --seed 3 -q --localizer ekf_landmarks";
  ASSERT_EQ(locsim("run " + kDemo + common + " --out " + (dir / "clean").string()).exit_code, 0);
  for (const char* isolation : {"process", "none"}) {
    SCOPED_TRACE(isolation);
    const fs::path out = dir / isolation;
    const Outcome run =
        locsim("run " + kDemo + common + " --isolation " + isolation + " --localizer " + kScripts +
               "py_raises.py --localizer " + kScripts + "py_nan.py --localizer " + kScripts +
               "py_missing_import.py --out " + out.string());
    EXPECT_EQ(run.exit_code, 5) << run.output;
    EXPECT_EQ(testing::read_file(dir / "clean/ekf_landmarks.tum"),
              testing::read_file(out / "ekf_landmarks.tum"));
    const json raises = testing::localizer_entry(out / "metrics.json", "py_raises");
    EXPECT_EQ(raises["status"], "failed");
    EXPECT_EQ(raises["failure"]["call"], "update");
    testing::expect_contains(
        raises["failure"]["message"],
        "ValueError: a deliberate failure at 1.1 s (py_raises.py:12 in on_landmarks)");
    const json nan = testing::localizer_entry(out / "metrics.json", "py_nan");
    EXPECT_EQ(nan["failure"]["call"], "estimate");
    testing::expect_contains(nan["failure"]["message"], "not finite (py_nan.py:19 in estimate)");
    EXPECT_NEAR(nan["failure"]["t_s"].get<double>(), 1.02, 1e-9);
    const json missing = testing::localizer_entry(out / "metrics.json", "py_missing_import");
    EXPECT_EQ(missing["status"], "failed");
    EXPECT_DOUBLE_EQ(missing["failure"]["t_s"].get<double>(), 0.0);
    testing::expect_contains(missing["failure"]["message"],
                             "ModuleNotFoundError: No module named 'locsim_no_such_module' "
                             "(py_missing_import.py:3 in <module>)");
  }
}

TEST(PythonPlugin, BadScriptsAreRefusedBeforeTheRun) {
  const fs::path dir = testing::temp_dir("python_plugin_bad");
  const fs::path syntax = dir / "syntax.py", none = dir / "no_class.py";
  {
    std::ofstream(syntax)
        << "import locsim\n\nclass A(locsim.Localizer):\n    def estimate(self)\n";
    std::ofstream(none) << "import locsim\n";
  }
  const Outcome a =
      locsim("run " + kDemo + " --duration 1 -q --localizer python:" + syntax.string() + " --out " +
             (dir / "a").string());
  EXPECT_EQ(a.exit_code, 3);
  testing::expect_contains(a.output, syntax.string() + ":4: SyntaxError");
  const Outcome b = locsim("run " + kDemo + " --duration 1 -q --localizer " + none.string() +
                           " --out " + (dir / "b").string());
  EXPECT_EQ(b.exit_code, 3);
  testing::expect_contains(b.output, "defines 0 classes derived from locsim.Localizer");
  const Outcome c =
      locsim("run " + kDemo + " --duration 1 -q --localizer python:landmark_pf:particle=5" +
             " --out " + (dir / "c").string());
  EXPECT_EQ(c.exit_code, 2);
  testing::expect_contains(c.output, "has no parameter 'particle'; did you mean 'particles'?");
  const Outcome d = locsim("run " + kDemo + " --duration 1 -q --localizer python:no_such_script" +
                           " --out " + (dir / "d").string());
  EXPECT_EQ(d.exit_code, 3);
  testing::expect_contains(d.output, "no localizer source 'no_such_script' (no_such_script.py)");
  const Outcome e =
      locsim("run " + kDemo + " --duration 1 -q --localizer odometry:" + syntax.string() +
             " --out " + (dir / "e").string());
  EXPECT_EQ(e.exit_code, 3);
  testing::expect_contains(e.output, "runs no source files");
}

TEST(PythonPlugin, SweepRunsTheScriptBesideCppFilters) {
  const fs::path dir = testing::temp_dir("python_plugin_sweep");
  fs::create_directories(dir / "filters");
  fs::copy_file(std::string(LOCSIM_SOURCE_DIR) + "/plugins/python/landmark_pf.py",
                dir / "filters/my_pf.py");
  std::ofstream(dir / "exp.yaml") << "name: py\nworld: " << kDemo
                                  << "\nduration_s: 5\nseeds: {from: 1, to: 2}\nlocalizers:\n"
                                     "  - plugin: ekf_landmarks\n"
                                     "  - plugin: python:filters/my_pf.py\n"
                                     "    grid: {particles: [200, 400]}\n";
  for (const char* out : {"s1", "s2"}) {
    const Outcome sweep =
        locsim("sweep " + (dir / "exp.yaml").string() + " --jobs 2 --out " + (dir / out).string());
    ASSERT_EQ(sweep.exit_code, 0) << sweep.output;
  }
  const std::string results = testing::read_file(dir / "s1/results.csv");
  testing::expect_contains(results, "my_pf-particles=400/seed-2");
  EXPECT_EQ(results.find(",failed,"), std::string::npos) << results;
  EXPECT_EQ(testing::read_file(dir / "s1/summary.csv"), testing::read_file(dir / "s2/summary.csv"));
  EXPECT_EQ(testing::read_file(dir / "s1/runs/my_pf-particles=200/seed-1/my_pf-particles=200.tum"),
            testing::read_file(dir / "s2/runs/my_pf-particles=200/seed-1/my_pf-particles=200.tum"));
}

}  // namespace
}  // namespace locsim
