// augmented_mcl: MCL with Thrun's w_slow / w_fast random injection (the recovery nav2 AMCL has).
#include "landmark_pf.hpp"

namespace {
class AugmentedMcl final : public locsim::particle_filters::LandmarkParticleFilter {
 public:
  explicit AugmentedMcl(const locsim_init& init)
      : LandmarkParticleFilter(init, locsim::particle_filters::Recovery::kAugmented) {}
};
constexpr locsim_param_decl kParams[] = {
    LOCSIM_LANDMARK_PF_PARAMS,
    {"alpha_slow", LOCSIM_PARAM_DOUBLE, 0.001, 0, 1, nullptr,
     "long-term likelihood average rate [-]"},
    {"alpha_fast", LOCSIM_PARAM_DOUBLE, 0.1, 0, 1, nullptr,
     "short-term likelihood average rate [-]"},
    {"injection_level", LOCSIM_PARAM_DOUBLE, 1.0, 1e-6, 1, nullptr,
     "inject 1 - w_fast / (level w_slow) of the particles "
     "(1: Thrun; locsim calibrate measures it) [-]"},
    // sensors by default: in a room of tens of square metres uniform guesses almost never fit a
    // detection (docs/reports/suite: 14 of 144 kidnaps recovered with uniform, 53 with sensors).
    {"injection", LOCSIM_PARAM_STRING, 0, 0, 0, "sensors",
     "where injected particles come from: sensors, poses that fit the step's detections (as srl "
     "resets), or uniform over the free space (Thrun)"}};
}  // namespace

LOCSIM_LOCALIZER(AugmentedMcl, "augmented_mcl", "MCL with w_slow/w_fast random injection (Thrun)",
                 kParams)
