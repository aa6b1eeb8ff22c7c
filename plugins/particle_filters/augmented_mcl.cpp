// augmented_mcl: MCL with Thrun's w_slow / w_fast random injection (the recovery nav2 AMCL has).
#include "landmark_pf.hpp"

namespace {
class AugmentedMcl final : public locsim::particle_filters::LandmarkParticleFilter {
 public:
  explicit AugmentedMcl(const locsim_init& init)
      : LandmarkParticleFilter(init, locsim::particle_filters::Recovery::kAugmented) {}
};
constexpr locsim_param_decl kParams[] = {LOCSIM_LANDMARK_PF_PARAMS,
                                         {"alpha_slow", LOCSIM_PARAM_DOUBLE, 0.001, 0, 1, nullptr,
                                          "long-term likelihood average rate [-]"},
                                         {"alpha_fast", LOCSIM_PARAM_DOUBLE, 0.1, 0, 1, nullptr,
                                          "short-term likelihood average rate [-]"}};
}  // namespace

LOCSIM_LOCALIZER(AugmentedMcl, "augmented_mcl", "MCL with w_slow/w_fast random injection (Thrun)",
                 kParams)
