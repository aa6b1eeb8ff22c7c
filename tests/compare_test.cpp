// `locsim compare A B --out DIR`: two sweeps' configurations side by side, their rankings and how
// well these agree. Hand-written sweep folders with per-run numbers chosen so that the ranks,
// Kendall's tau, Spearman's rho and the flips are known; bad input exits with 2 naming the folder
// or file and writes nothing; and one comparison of two real sweeps.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "tests/test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;

/// One configuration's runs: position and heading RMS per run; a negative position makes a run
/// that ended in error (no values).
struct Runs {
  std::string config;
  std::vector<double> position_m;
  std::vector<double> heading_deg;
};

/// A sweep folder as `locsim sweep` writes it, as far as `compare` reads it: sweep.json,
/// results.csv (a sweep's columns, the metrics not compared left empty) and summary.md.
fs::path write_sweep(const fs::path& dir, const std::string& experiment,
                     const std::vector<Runs>& configs) {
  fs::create_directories(dir);
  std::ofstream csv(dir / "results.csv");
  csv << "index,id,config,log,seed,status,reason,position_rms_m,position_mean_m,position_max_m,"
         "x_rms_m,y_rms_m,heading_rms_deg,heading_mean_deg,heading_max_deg,converged_s,"
         "converged_steps,time_lost_s,recovery_s,recovery_steps,landmark_error_m\n";
  int index = 0;
  for (const Runs& runs : configs) {
    for (std::size_t k = 0; k < runs.position_m.size(); ++k, ++index) {
      const std::string id = runs.config + "/seed-" + std::to_string(k + 1);
      csv << index << "," << id << "," << runs.config << ",," << k + 1;
      if (runs.position_m[k] < 0) {
        csv << ",error,\"exit code 1: locsim: failure: disk full\",,,,,,,,,,,,,,\n";
      } else {
        csv << ",ok,," << runs.position_m[k] << ",,,,," << runs.heading_deg[k] << ",,,0.0,0,,,,\n";
      }
    }
  }
  std::ofstream(dir / "sweep.json")
      << "{\"experiment\": \"" << experiment << "\", \"file\": \"" << experiment
      << ".yaml\", \"runs\": " << index << ", \"shard\": null}\n";
  std::ofstream(dir / "summary.md") << "(not read by compare)\n";
  return dir;
}

/// "real" and "twin": four configurations in common, one only in each.
///
/// Position RMS, mean ± 95 % CI (t 4.303 x s / sqrt 3) over the ok runs:
///   real: alpha 0.110 ± 0.025 < beta 0.210 ± 0.025 < gamma 0.310 ± 0.025 (and a run in error)
///         < delta 0.410 ± 0.025
///   twin: beta 0.060 ± 0.025 < alpha 0.160 ± 0.025 < delta 0.260 ± 0.025 < gamma 0.300 ± 0.124
/// Two of the six pairs flip: alpha/beta, whose intervals are apart on both sides, and
/// gamma/delta, apart on real but overlapping on twin. Kendall's tau = (4 - 2) / 6 = 0.333;
/// Spearman's rho = 1 - 6 x 4 / (4 x 15) = 0.600 (rank differences 1, 1, 1, 1).
/// Heading RMS ranks the same on real and ties alpha and beta on twin (mean 1.0 both, from
/// different runs): no flip, tau-b = 5 / sqrt(6 x 5) = 0.913, rho = 0.949 on average ranks.
void write_twin_pair(const fs::path& dir) {
  write_sweep(dir / "real", "mrclam",
              {{"alpha", {0.10, 0.11, 0.12}, {0.9, 1.0, 1.1}},
               {"beta", {0.20, 0.21, 0.22}, {1.9, 2.0, 2.1}},
               {"gamma", {0.30, 0.31, 0.32, -1}, {2.9, 3.0, 3.1, 0}},
               {"delta", {0.40, 0.41, 0.42}, {3.9, 4.0, 4.1}},
               {"onlya", {1.0, 1.1}, {5.0, 6.0}}});
  write_sweep(dir / "twin", "twin",
              {{"beta", {0.05, 0.06, 0.07}, {0.8, 1.0, 1.2}},
               {"alpha", {0.15, 0.16, 0.17}, {0.9, 1.0, 1.1}},
               {"delta", {0.25, 0.26, 0.27}, {3.9, 4.0, 4.1}},
               {"gamma", {0.25, 0.30, 0.35}, {2.9, 3.0, 3.1}},
               {"onlyb", {2.0}, {7.0}}});
}

TEST(Compare, RanksTauRhoAndFlipsOfTwoSweeps) {
  const fs::path dir = testing::temp_dir("compare");
  write_twin_pair(dir);
  const fs::path out = dir / "out";
  const testing::Outcome compare =
      testing::locsim("compare " + (dir / "real").string() + " " + (dir / "twin").string() +
                      " --out " + out.string());
  ASSERT_EQ(compare.exit_code, 0) << compare.output;
  const std::string md = testing::read_file(out / "report.md");
  // The summary comes first, after the title.
  EXPECT_EQ(md.find("# Comparison: real and twin\n\nBy mean position RMS, the rankings agree on 4 "
                    "of 6 pairs (Kendall tau 0.333, Spearman rho 0.600); 1 of the 2 flips is "
                    "significant on both sides: alpha/beta.\n"),
            0u)
      << md;
  testing::expect_contains(md,
                           "- Ranking on real: alpha < beta < gamma < delta.\n"
                           "- Ranking on twin: beta < alpha < delta < gamma.\n");
  testing::expect_contains(
      md, "- real: `" + (dir / "real").string() + "`, experiment mrclam (`mrclam.yaml`), 15 runs.");
  testing::expect_contains(md, "4 configurations in common; 2 in only one sweep (onlya, onlyb)");
  // Ranks on each side, the run in error counted in runs but not in the mean, B/A of the means.
  testing::expect_contains(md,
                           "| config | real ok/runs | real position RMS [m] | real median | real "
                           "rank | twin ok/runs | twin position RMS [m] | twin median | twin rank "
                           "| twin/real |\n|---|---|---|---|---|---|---|---|---|---|\n"
                           "| alpha | 3/3 | 0.110 ± 0.025 | 0.110 | 1 | 3/3 | 0.160 ± 0.025 | "
                           "0.160 | 2 | 1.45 |\n"
                           "| beta | 3/3 | 0.210 ± 0.025 | 0.210 | 2 | 3/3 | 0.060 ± 0.025 | 0.060 "
                           "| 1 | 0.29 |\n"
                           "| gamma | 3/4 | 0.310 ± 0.025 | 0.310 | 3 | 3/3 | 0.300 ± 0.124 | "
                           "0.300 | 4 | 0.97 |\n"
                           "| delta | 3/3 | 0.410 ± 0.025 | 0.410 | 4 | 3/3 | 0.260 ± 0.025 | "
                           "0.260 | 3 | 0.63 |\n"
                           "| onlya | 2/2 | 1.050 ± 0.635 | 1.050 | — | — | — | — | — | — |\n"
                           "| onlyb | — | — | — | — | 1/1 | 2.000 | 2.000 | — | — |\n");
  // Each flip in words, with its significance on each side.
  testing::expect_contains(
      md,
      "- on real alpha < beta (0.110 vs 0.210 m, significant); on twin beta < alpha (0.060 vs "
      "0.160 m, significant). Significant on both sides: a disagreement of substance.\n"
      "- on real gamma < delta (0.310 vs 0.410 m, significant); on twin delta < gamma (0.260 vs "
      "0.300 m, within noise: the 95 % intervals overlap). Within noise on twin: not a "
      "disagreement of substance.\n");
  // Heading: alpha and beta tie on twin and share its rank 1.
  testing::expect_contains(md,
                           "| alpha | 1.000 ± 0.248 | 1 | 1.000 ± 0.248 | 1 | 1.00 |\n"
                           "| beta | 2.000 ± 0.248 | 2 | 1.000 ± 0.497 | 1 | 0.50 |\n"
                           "| gamma | 3.000 ± 0.248 | 3 | 3.000 ± 0.248 | 3 | 1.00 |\n");
  testing::expect_contains(md,
                           "By mean heading RMS, the rankings agree on 5 of 6 pairs (Kendall tau "
                           "0.913, Spearman rho 0.949), 1 tied on one side or both; no pair "
                           "flips.");
  testing::expect_contains(md, "](report/compare.png)");
  EXPECT_GT(fs::file_size(out / "report" / "compare.png"), 5000u);

  const std::string csv = testing::read_file(out / "compare.csv");
  testing::expect_contains(
      csv,
      "\nalpha,3,3,0.110000,0.024843,0.110000,1,1.000000,0.248434,1.000000,1,3,3,0.160000,"
      "0.024843,0.160000,2,1.000000,0.248434,1.000000,1,1.454545,1.000000\n");
  testing::expect_contains(csv,
                           "\nonlyb,,,,,,,,,,,1,1,2.000000,,2.000000,,7.000000,,7.000000,,,\n");

  // Again into the same folder, labelled: the earlier comparison is replaced, byte for byte the
  // same but for the names.
  const testing::Outcome labelled =
      testing::locsim("compare " + (dir / "real").string() + " " + (dir / "twin").string() +
                      " --out " + out.string() + " --labels 'MRCLAM,twin world'");
  ASSERT_EQ(labelled.exit_code, 0) << labelled.output;
  const std::string renamed = testing::read_file(out / "report.md");
  testing::expect_contains(renamed, "# Comparison: MRCLAM and twin world\n");
  testing::expect_contains(renamed, "| twin world/MRCLAM |");
  testing::expect_contains(renamed, "on twin world beta < alpha (0.060 vs 0.160 m, significant)");
  EXPECT_EQ(csv, testing::read_file(out / "compare.csv"));
  const testing::Outcome again =
      testing::locsim("compare " + (dir / "real").string() + " " + (dir / "twin").string() +
                      " --out " + out.string());
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_EQ(md, testing::read_file(out / "report.md"));
}

TEST(Compare, BadInputExitsWith2NamingTheFolderAndWritesNothing) {
  const fs::path dir = testing::temp_dir("compare_bad");
  write_twin_pair(dir);
  const std::string real = (dir / "real").string(), out = (dir / "out").string();
  const auto compare = [&](const std::string& b, const std::string& extra = "") {
    const testing::Outcome outcome =
        testing::locsim("compare " + real + " " + b + " --out " + out + extra);
    EXPECT_EQ(outcome.exit_code, 2) << outcome.output;
    EXPECT_FALSE(fs::exists(out)) << outcome.output;
    return outcome.output;
  };

  testing::expect_contains(compare((dir / "missing").string()),
                           "compare: " + (dir / "missing").string() + ": no such folder");
  fs::create_directories(dir / "empty");
  testing::expect_contains(
      compare((dir / "empty").string()),
      "compare: " + (dir / "empty").string() + " is not a sweep folder (no sweep.json;");
  write_sweep(dir / "other", "other", {{"zeta", {0.1}, {1.0}}});
  testing::expect_contains(compare((dir / "other").string()),
                           "compare: " + real + " and " + (dir / "other").string() +
                               " have no configuration in common (" + real +
                               ": alpha, beta, gamma, delta, onlya; " + (dir / "other").string() +
                               ": zeta)");
  // Unreadable CSVs: a value that is not a number, a row cut short, a missing column.
  const fs::path bad = write_sweep(dir / "bad", "bad", {{"alpha", {0.1}, {1.0}}});
  std::ofstream(bad / "results.csv") << "config,status,position_rms_m,heading_rms_deg\n"
                                        "alpha,ok,0.1,1.0\nbeta,ok,n/a,1.0\n";
  testing::expect_contains(compare(bad.string()), "compare: " + (bad / "results.csv").string() +
                                                      ":3: position_rms_m 'n/a' is not a number");
  std::ofstream(bad / "results.csv") << "config,status,position_rms_m,heading_rms_deg\n"
                                        "alpha,ok,0.1\n";
  testing::expect_contains(compare(bad.string()),
                           (bad / "results.csv").string() + ":2: not as many fields as");
  std::ofstream(bad / "results.csv") << "config,status,position_rms_m\nalpha,ok,0.1\n";
  testing::expect_contains(compare(bad.string()),
                           (bad / "results.csv").string() + ":1: no column heading_rms_deg");
  std::ofstream(bad / "sweep.json") << "{\"experiment\": \"bad\"}\n";
  testing::expect_contains(compare(bad.string()),
                           (bad / "sweep.json").string() + ": key 'file' is missing");
  testing::expect_contains(compare((dir / "twin").string(), " --labels onlyone"),
                           "compare: --labels: expected NAME_A,NAME_B, got 'onlyone'");

  // --out a sweep folder: its own report.md would be lost.
  std::ofstream(dir / "twin" / "report.md") << "the twin's report\n";
  const testing::Outcome into_sweep = testing::locsim(
      "compare " + real + " " + (dir / "twin").string() + " --out " + (dir / "twin").string());
  EXPECT_EQ(into_sweep.exit_code, 2) << into_sweep.output;
  testing::expect_contains(into_sweep.output,
                           "--out " + (dir / "twin").string() + ": a sweep folder");
  EXPECT_EQ(testing::read_file(dir / "twin" / "report.md"), "the twin's report\n");
  EXPECT_FALSE(fs::exists(dir / "twin" / "compare.csv"));

  // The command line's own checks.
  const testing::Outcome no_out = testing::locsim("compare " + real + " " + real);
  EXPECT_EQ(no_out.exit_code, 2) << no_out.output;
  testing::expect_contains(no_out.output, "--out is required");
}

TEST(Compare, TwoSweepsOverOtherSeeds) {
  const fs::path dir = testing::temp_dir("compare_sweeps");
  // The sweep tests' experiment (tests/sweep_test.cpp), shorter: three configurations.
  for (const std::string seeds : {"[1, 2]", "[3, 4]"}) {
    const std::string name = seeds == "[1, 2]" ? "first" : "second";
    std::ofstream(dir / (name + ".yaml"))
        << "name: " << name << "\nworld: " << LOCSIM_SOURCE_DIR
        << "/worlds/demo/demo.yaml\nduration_s: 2\nseeds: " << seeds
        << "\ntimeout_s: 60\nlocalizers:\n  - plugin: odometry\n  - plugin: ekf_landmarks\n"
           "    grid: {sigma_bearing_deg: [1, 3]}\n";
    const testing::Outcome sweep = testing::locsim("sweep " + (dir / (name + ".yaml")).string() +
                                                   " --out " + (dir / name).string());
    ASSERT_EQ(sweep.exit_code, 0) << sweep.output;
  }
  const testing::Outcome compare =
      testing::locsim("compare " + (dir / "first").string() + " " + (dir / "second").string() +
                      " --out " + (dir / "out").string());
  ASSERT_EQ(compare.exit_code, 0) << compare.output;
  const std::string md = testing::read_file(dir / "out" / "report.md");
  testing::expect_contains(md, "By mean position RMS, the rankings agree on ");
  testing::expect_contains(md, "3 configurations in common.");
  for (const char* config :
       {"odometry", "ekf_landmarks-sigma_bearing_deg=1", "ekf_landmarks-sigma_bearing_deg=3"}) {
    testing::expect_contains(md, std::string("| ") + config + " | 2/2 | ");
  }
}

}  // namespace
}  // namespace locsim
