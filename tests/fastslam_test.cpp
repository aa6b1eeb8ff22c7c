// Paper 001's SLAM plugins on the field (worlds/fastslam/field.yaml, one lap, landmarks unknown):
// FastSLAM maps every landmark to centimetres; pruning by negative evidence removes the
// duplicates that association leaves behind when a pose drifts past the gate; the fish swarm's
// directed resampling raises the particle diversity without starving N_eff.
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "run_support.hpp"
#include "sim/world/generator.hpp"

namespace locsim {
namespace {

nlohmann::json field_run(std::uint64_t seed) {
  RunOptions options;
  options.world_file = std::filesystem::path(LOCSIM_SOURCE_DIR) / "worlds/fastslam/field.yaml";
  options.seed = seed;
  options.out_dir = testing::temp_dir("fastslam_field") / std::to_string(seed);
  options.params_file =
      std::filesystem::path(LOCSIM_SOURCE_DIR) / "worlds/fastslam/presets/paper001.yaml";
  options.localizers = {"fastslam:sigma_cross_m=0.01@fastslam",
                        "fastslam:sigma_cross_m=0.01,prune_after_misses=0@unpruned",
                        "fastslam_afsa:sigma_cross_m=0.01@afsa"};
  return testing::run_metrics(options);
}

TEST(FastSlam, MapsTheFieldPrunesDuplicatesAndTheFishSwarmKeepsN_eff) {
  double spurious = 0.0, spurious_unpruned = 0.0, position_m = 0.0, map_m = 0.0;
  for (std::uint64_t seed = 1; seed <= 2; ++seed) {
    const auto metrics = field_run(seed);
    const auto& fastslam = metrics["localizers"][0];
    const auto& unpruned = metrics["localizers"][1];
    const auto& afsa = metrics["localizers"][2];
    for (const auto* filter : {&fastslam, &unpruned, &afsa}) {
      ASSERT_EQ((*filter)["status"], "ok") << (*filter)["label"];
      // Centimetres after a 120 m lap whose odometry ends metres off: 2-3 cm on the declared
      // wheels; on the wheels seeds 1-6 draw, 1-11 cm (a systematic odometry error, which the
      // motion model does not know, bends the map), so the bound is on the mean of two seeds.
      EXPECT_LT((*filter)["position_error_m"]["rms"].get<double>(), 0.15) << (*filter)["label"];
      position_m += (*filter)["position_error_m"]["rms"].get<double>() / 6.0;
      const auto& map = (*filter)["landmark_map"];
      EXPECT_EQ(map["missed"].get<int>(), 0) << (*filter)["label"];
      EXPECT_EQ(map["matched"].get<int>(), map["observed"].get<int>()) << (*filter)["label"];
      EXPECT_LT(map["error_m"]["rms"].get<double>(), 0.15) << (*filter)["label"];
      map_m += map["error_m"]["rms"].get<double>() / 6.0;
    }
    spurious += fastslam["landmark_map"]["spurious"].get<double>();
    spurious_unpruned += unpruned["landmark_map"]["spurious"].get<double>();
    // Directed resampling scatters the lighter half around the board particle: more diverse
    // particles, and (with the board predicted by the means after their camera updates) as
    // effective as plain resampling's copies. Predicted from a stale mean, the copies lagged one
    // frame's travel and N_eff fell to 60 % of FastSLAM's.
    const auto& f = fastslam["diagnostics"];
    const auto& a = afsa["diagnostics"];
    EXPECT_GT(a["mean_diversity"].get<double>(), 1.5 * f["mean_diversity"].get<double>());
    EXPECT_GT(a["mean_n_eff"].get<double>(), 0.85 * f["mean_n_eff"].get<double>());
  }
  // A pose a few centimetres off puts a 1 cm landmark outside the gate: a duplicate. Without
  // negative evidence they stay (13-18 per lap here); with it most go (4-7 left).
  EXPECT_LT(position_m, 0.06);  // the three filters over both seeds
  EXPECT_LT(map_m, 0.06);
  EXPECT_GT(spurious_unpruned, 20.0);
  EXPECT_LT(spurious, 0.5 * spurious_unpruned);
}

TEST(FastSlam, MapsAGeneratedRoomOnTheDefaultOmnidirectionalCamera) {
  // A generated room (not the paper's field; no people, no kidnap) with the simulator's default
  // omni camera: 0.25 m of noise along the ray, 0.08 m across it, 6 m range. The defaults weigh
  // its detections by that noise and map the landmarks it saw, their shape to centimetres (their
  // placement is the start guess's: 0.2 m and 1.3 degrees off). With paper 001's settings
  // (worlds/fastslam/presets/paper001.yaml: weighed as its 1 cm / 0.1 degree sensor out to 15 m,
  // the wheels' odometry alone), a landmark's detections fell outside each other's gates and most
  // were mapped again and again, then pruned. Over six seeds, as one seed's map is a few draws:
  // on seeds 1-6 (two random engines) the defaults matched 5-6 of the 6 landmarks seen, with 0-2
  // duplicates, 0.01-0.11 m aligned; the paper's settings 0-4.
  GeneratorDef def;
  def.family = "room";
  def.seed = 44;
  def.people = 0;
  def.kidnaps = 0;
  int observed = 0, matched = 0, spurious = 0, paper_matched = 0;
  std::vector<double> aligned_m, placed_m;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const auto metrics = testing::run_metrics(testing::generated_run(
        "fastslam_room", def, seed, 120.0,
        {"fastslam", "fastslam:omni_as_range_bearing=true,max_range_m=15,use_gyro=false@paper"}));
    ASSERT_EQ(metrics["localizers"][0]["status"], "ok") << seed;
    const auto& fastslam = metrics["localizers"][0]["landmark_map"];
    observed += fastslam["observed"].get<int>();
    matched += fastslam["matched"].get<int>();
    spurious += fastslam["spurious"].get<int>();
    aligned_m.push_back(fastslam["error_aligned_m"]["rms"].get<double>());
    placed_m.push_back(fastslam["error_m"]["rms"].get<double>());
    paper_matched += metrics["localizers"][1]["landmark_map"]["matched"].get<int>();
  }
  EXPECT_GE(matched, 0.85 * observed);  // 33 of 36
  EXPECT_LE(spurious, 9);               // 4-5 over the six runs
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + 3, v.end());
    return v[3];
  };
  EXPECT_LT(median(aligned_m), 0.08);  // 0.05-0.06
  EXPECT_LT(median(placed_m), 0.6);    // 0.48-0.49: the start guess is off
  EXPECT_LE(paper_matched, matched / 2);
}

}  // namespace
}  // namespace locsim
