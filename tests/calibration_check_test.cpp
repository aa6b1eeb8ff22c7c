// `locsim calibrate` over several recordings: each calibrated alone, the spread of every value,
// and the transfer check (every recording replayed with every recording's calibration) that
// flags a calibration describing one recording rather than the robot, naming what moves it.
#include "sim/experiments/calibration_check.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "sim/common/files.hpp"
#include "sim/metrics/calibration.hpp"
#include "sim/plugin_host/param_file.hpp"
#include "sim/run/runner.hpp"
#include "tests/noisy_world.hpp"
#include "tests/test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;

/// The noisy world, shorter, its camera's range biased by `range_bias_m` at zero range.
std::string world_with_bias(const std::string& range_bias_m) {
  std::string world = testing::noisy_world(0.0);
  const auto replace = [&](const std::string& from, const std::string& to) {
    const std::size_t at = world.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) world.replace(at, from.size(), to);
  };
  replace("range_bias_m: 0.1\n", "range_bias_m: " + range_bias_m + "\n");
  replace("duration_s: 300", "duration_s: 120");
  return world;
}

fs::path record_log(const fs::path& dir, const std::string& name, const std::string& world_text,
                    std::uint64_t seed) {
  std::ofstream(dir / (name + ".yaml")) << world_text;
  RunOptions options;
  options.world_file = dir / (name + ".yaml");
  options.seed = seed;
  options.out_dir = dir / (name + "_run");
  options.readings = false;
  options.log_file = dir / (name + ".locsimlog");
  run_simulation(options);
  return *options.log_file;
}

const nlohmann::json* transfer_cell(const nlohmann::json& calibration, const std::string& from,
                                    const std::string& on) {
  for (const nlohmann::json& c : calibration["transfer"]["cells"]) {
    if (c["from"] == from && c["on"] == on) return &c;
  }
  return nullptr;
}

TEST(CalibrationCheck, ACameraBiasOfOneRecordingIsFlaggedAndNamedWhenItMovesTheFilter) {
  const fs::path dir = testing::temp_dir("calibration_check");
  // Two recordings of "one robot" whose camera changed between them: a range bias of 0.1 m, then
  // 0.6 m. Each recording's calibration takes its own bias out; the other's leaves 0.5 m in.
  const fs::path low = record_log(dir, "low", world_with_bias("0.1"), 3);
  const fs::path high = record_log(dir, "high", world_with_bias("0.6"), 4);
  const testing::Outcome out =
      testing::locsim("calibrate " + low.string() + " " + high.string() + " --out " +
                      (dir / "cal").string() + " --check ekf_landmarks --jobs 2");
  ASSERT_EQ(out.exit_code, 0) << out.output;
  EXPECT_NE(out.output.find("flagged"), std::string::npos) << out.output;
  const nlohmann::json result = nlohmann::json::parse(read_text(dir / "cal" / "calibration.json"));
  // Each recording calibrated alone, beside the pooled calibration.
  ASSERT_EQ(result["recordings"].size(), 2u);
  for (const char* name : {"low", "high"}) {
    EXPECT_TRUE(fs::exists(dir / "cal" / "recordings" / name / "calibration.yaml")) << name;
  }
  // The spread names the bias: about 0.5 m apart around a pooled value between them.
  bool bias_seen = false;
  for (const nlohmann::json& p : result["spread"]) {
    if (p["key"] != "range_bias_m" || !p["plugin"].is_null()) continue;
    bias_seen = true;
    EXPECT_EQ(p["group"], "detection bias");
    EXPECT_NEAR(p["max"].get<double>() - p["min"].get<double>(), 0.5, 0.1);
    EXPECT_GT(p["relative_spread"].get<double>(), 0.25);
  }
  EXPECT_TRUE(bias_seen);
  // Either recording's calibration on the other moves the EKF by far more than 25 %, and the
  // bias alone does most of it.
  for (const auto& [from, on] : {std::pair{"low", "high"}, std::pair{"high", "low"}}) {
    SCOPED_TRACE(std::string(from) + " on " + on);
    const nlohmann::json* c = transfer_cell(result, from, on);
    ASSERT_NE(c, nullptr);
    EXPECT_TRUE((*c)["flagged"].get<bool>());
    EXPECT_GT((*c)["change"].get<double>(), 0.25);
    ASSERT_FALSE((*c)["groups"].empty());
    EXPECT_EQ((*c)["groups"][0]["group"], "detection bias");
    EXPECT_GT((*c)["groups"][0]["change"].get<double>(), 0.25);
  }
  // One seed: no interval to judge the change by.
  EXPECT_TRUE((*transfer_cell(result, "low", "high"))["change_ci95"].is_null());
  // Its own calibration is the reference: unflagged, no change.
  const nlohmann::json* own = transfer_cell(result, "low", "low");
  ASSERT_NE(own, nullptr);
  EXPECT_FALSE((*own)["flagged"].get<bool>());
  EXPECT_EQ((*own)["change"].get<double>(), 0.0);
  // The file a user takes says so at its top, and still reads as a parameter file.
  const std::string yaml = read_text(dir / "cal" / "calibration.yaml");
  EXPECT_NE(yaml.find("# Flagged:"), std::string::npos);
  EXPECT_LT(yaml.find("# Flagged:"), yaml.find("localizer_params:"));
  const ParamFile pooled = load_param_file(dir / "cal" / "calibration.yaml");
  // Every value calibrate writes belongs to a group the check can swap.
  for (const ParamFileValue& v : pooled.common)
    EXPECT_FALSE(parameter_group(v.key).empty()) << v.key;
  for (const ParamFileSection& s : pooled.sections) {
    for (const ParamFileValue& v : s.values)
      EXPECT_FALSE(parameter_group(v.key).empty()) << s.plugin << "." << v.key;
  }
  // The sweeps are left for `locsim report` and `locsim sweep --resume`.
  EXPECT_TRUE(fs::exists(dir / "cal" / "transfer" / "runs" / "results.csv"));
  EXPECT_TRUE(fs::exists(dir / "cal" / "transfer" / "groups" / "high" / "experiment.yaml"));

  // `locsim report` tables it.
  const testing::Outcome report = testing::locsim("report " + (dir / "cal").string());
  ASSERT_EQ(report.exit_code, 0) << report.output;
  const std::string report_md = read_text(dir / "cal" / "report.md");
  EXPECT_NE(report_md.find("## Across 2 recordings"), std::string::npos) << report_md;
  EXPECT_NE(report_md.find("| low | 0."), std::string::npos) << report_md;
  EXPECT_NE(report_md.find("detection bias +"), std::string::npos) << report_md;

  // A second run refuses to replace what the first wrote, then replaces it all with --overwrite.
  const testing::Outcome again =
      testing::locsim("calibrate " + low.string() + " " + high.string() + " --out " +
                      (dir / "cal").string() + " --check none");
  EXPECT_EQ(again.exit_code, 2) << again.output;
  const testing::Outcome replaced =
      testing::locsim("calibrate " + low.string() + " " + high.string() + " --out " +
                      (dir / "cal").string() + " --check none --overwrite");
  ASSERT_EQ(replaced.exit_code, 0) << replaced.output;
  EXPECT_FALSE(fs::exists(dir / "cal" / "transfer"));
  const nlohmann::json spread_only =
      nlohmann::json::parse(read_text(dir / "cal" / "calibration.json"));
  EXPECT_TRUE(spread_only.contains("spread"));
  EXPECT_FALSE(spread_only.contains("transfer"));
}

TEST(CalibrationCheck, TwoRecordingsOfOneRobotTransferWithoutAFlag) {
  const fs::path dir = testing::temp_dir("calibration_check_same");
  const std::string world = world_with_bias("0.1");
  const fs::path a = record_log(dir, "a", world, 5);
  const fs::path b = record_log(dir, "b", world, 6);
  const testing::Outcome out =
      testing::locsim("calibrate " + a.string() + " " + b.string() + " --out " +
                      (dir / "cal").string() + " --check-seeds 2 -q");
  ASSERT_EQ(out.exit_code, 0) << out.output;
  const nlohmann::json result = nlohmann::json::parse(read_text(dir / "cal" / "calibration.json"));
  EXPECT_TRUE(result["transfer"]["flags"].empty()) << result["transfer"]["flags"].dump(2);
  for (const nlohmann::json& c : result["transfer"]["cells"]) {
    ASSERT_TRUE(c["change"].is_number()) << c.dump();
    EXPECT_LT(std::abs(c["change"].get<double>()), 0.25) << c.dump();
    // Two seeds give the change an interval; the EKF's seed draws only its initial guess near
    // the known start, so paired seed by seed the change hardly varies.
    ASSERT_TRUE(c["change_ci95"].is_number()) << c.dump();
    EXPECT_GE(c["change_ci95"].get<double>(), 0.0) << c.dump();
    EXPECT_LT(c["change_ci95"].get<double>(), 0.1) << c.dump();
    EXPECT_FALSE(c["uncertain"].get<bool>());
  }
  EXPECT_EQ(read_text(dir / "cal" / "calibration.yaml").find("# Flagged:"), std::string::npos);
}

TEST(CalibrationCheck, RefusesLogsOfOneNameAndBadLocalizerNamesBeforeWriting) {
  const fs::path dir = testing::temp_dir("calibration_check_bad");
  const std::string world = world_with_bias("0.1");
  fs::create_directories(dir / "x");
  const fs::path a = record_log(dir, "a", world, 5);
  fs::copy_file(a, dir / "x" / "a.locsimlog");
  testing::Outcome out =
      testing::locsim("calibrate " + a.string() + " " + (dir / "x" / "a.locsimlog").string() +
                      " --out " + (dir / "cal").string());
  EXPECT_EQ(out.exit_code, 2) << out.output;
  EXPECT_NE(out.output.find("rename one"), std::string::npos) << out.output;
  EXPECT_FALSE(fs::exists(dir / "cal" / "recordings"));
  const fs::path b = record_log(dir, "b", world, 6);
  out = testing::locsim("calibrate " + a.string() + " " + b.string() + " --out " +
                        (dir / "cal2").string() + " --check 'Ekf Landmarks'");
  EXPECT_EQ(out.exit_code, 2) << out.output;
  EXPECT_NE(out.output.find("--check"), std::string::npos) << out.output;
  out = testing::locsim("calibrate " + a.string() + " " + b.string() + " --out " +
                        (dir / "cal2").string() + " --check ekf_landmarks,,mcl");
  EXPECT_EQ(out.exit_code, 2) << out.output;
  EXPECT_NE(out.output.find("--check: an empty name"), std::string::npos) << out.output;
  // "all" is no plugin: refused as one, not taken for every localizer or none.
  out = testing::locsim("calibrate " + a.string() + " " + b.string() + " --out " +
                        (dir / "cal2").string() + " --check all");
  EXPECT_EQ(out.exit_code, 3) << out.output;
  EXPECT_FALSE(fs::exists(dir / "cal2"));
}

TEST(ParamFileText, ReadsBackAsWrittenAndASectionReplacesACommonValue) {
  const fs::path dir = testing::temp_dir("param_file_text");
  write_file(dir / "p.yaml", param_file_text({{"k_left", "0.03"},
                                              {"range_model", "depth"},
                                              {"bias", "-0.5"},
                                              {"odd", "a: b # c"},
                                              {"nothing", "null"},
                                              {"dash", "-"}},
                                             {"a comment"}));
  const ParamFile file = load_param_file(dir / "p.yaml");
  ASSERT_EQ(file.common.size(), 6u);
  EXPECT_EQ(file.common[0].text, "0.03");
  EXPECT_EQ(file.common[1].text, "depth");
  EXPECT_EQ(file.common[2].text, "-0.5");
  EXPECT_EQ(file.common[3].text, "a: b # c");
  EXPECT_EQ(file.common[4].text, "null");
  EXPECT_EQ(file.common[5].text, "-");
  write_file(dir / "s.yaml", "localizer_params:\n  a: 1\n  b: 2\n  srl: {b: 3, c: 4}\n");
  const std::vector<ParamFileValue> srl = values_for(load_param_file(dir / "s.yaml"), "srl");
  ASSERT_EQ(srl.size(), 3u);
  EXPECT_EQ(srl[0].text, "1");
  EXPECT_EQ(srl[1].key, "b");
  EXPECT_EQ(srl[1].text, "3");
  EXPECT_EQ(srl[2].key, "c");
  EXPECT_EQ(values_for(load_param_file(dir / "s.yaml"), "mcl").size(), 2u);
}

}  // namespace
}  // namespace locsim
