// The landmark particle filters (first implementation, issue 6): plain MCL never recovers from a
// kidnapping; adaptive sensor resetting does in most seeds. Tuning to the paper's figures is
// issue 6's remaining work; these tests pin the behaviour that must not regress.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "sim/run/runner.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;

TEST(ParticleFilters, AsrlRecoversFromAKidnapWhereMclCannot) {
  int mcl_recovered = 0, asrl_recovered = 0;
  double worst_tracking = 0.0;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    RunOptions options;
    options.world_file = fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml";
    options.duration_s = 38.0;  // the kidnap at 20 s (carried 2 s), 16 s to recover, before 40 s
    options.seed = seed;
    options.out_dir = testing::temp_dir("pf") / ("seed" + std::to_string(seed));
    options.localizers = {"mcl:use_omni=true", "asrl:use_omni=true,p_t=0.3"};
    run_simulation(options);
    const auto metrics =
        nlohmann::json::parse(testing::read_file(options.out_dir / "metrics.json"));
    for (const auto& l : metrics["localizers"]) {
      ASSERT_EQ(l["status"], "ok");
      ASSERT_EQ(l["segments"].size(), 2u);
      const bool recovered = !l["segments"][1]["recovery_s"].is_null();
      (l["label"] == "mcl" ? mcl_recovered : asrl_recovered) += recovered ? 1 : 0;
      worst_tracking =
          std::max(worst_tracking, l["segments"][0]["position_error_m"]["rms"].get<double>());
      EXPECT_GT(l["diagnostics_mean"]["n_eff"].get<double>(), 10.0);
    }
  }
  EXPECT_EQ(mcl_recovered, 0);
  EXPECT_GE(asrl_recovered, 4);
  EXPECT_LT(worst_tracking, 0.3);  // both track before the kidnap
}

}  // namespace
}  // namespace locsim
