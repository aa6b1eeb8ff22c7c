// mcl: plain Monte Carlo localization on landmark detections; no recovery from a kidnapping.
#include "landmark_pf.hpp"

namespace {
class Mcl final : public locsim::particle_filters::LandmarkParticleFilter {
 public:
  explicit Mcl(const locsim_init& init)
      : LandmarkParticleFilter(init, locsim::particle_filters::Recovery::kNone) {}
};
constexpr locsim_param_decl kParams[] = {LOCSIM_LANDMARK_PF_PARAMS};
}  // namespace

LOCSIM_LOCALIZER(Mcl, "mcl", "Monte Carlo localization on landmark detections (no resetting)",
                 kParams)
