// Paper 001's SLAM plugins on the field (worlds/fastslam/field.yaml, one lap, landmarks unknown):
// FastSLAM maps every landmark to centimetres; pruning by negative evidence removes the
// duplicates that association leaves behind when a pose drifts past the gate; the fish swarm's
// directed resampling raises the particle diversity without starving N_eff.
#include <gtest/gtest.h>

#include "run_support.hpp"

namespace locsim {
namespace {

nlohmann::json field_run(std::uint64_t seed) {
  RunOptions options;
  options.world_file = std::filesystem::path(LOCSIM_SOURCE_DIR) / "worlds/fastslam/field.yaml";
  options.seed = seed;
  options.out_dir = testing::temp_dir("fastslam_field") / std::to_string(seed);
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

}  // namespace
}  // namespace locsim
