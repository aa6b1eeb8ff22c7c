// asrl: adaptive sensor resetting localization (paper 004): ns = n max(0, 1 - p~ / (mu p_t^(2m))),
// m the number of detections in the step, so the threshold follows how much was seen.
#include "landmark_pf.hpp"

namespace {
class Asrl final : public locsim::particle_filters::LandmarkParticleFilter {
 public:
  explicit Asrl(const locsim_init& init)
      : LandmarkParticleFilter(init, locsim::particle_filters::Recovery::kAdaptiveSensorResetting) {
  }
};
constexpr locsim_param_decl kParams[] = {
    LOCSIM_LANDMARK_PF_PARAMS,
    {"mu", LOCSIM_PARAM_DOUBLE, 1.0, 1e-12, 1e12, nullptr, "tuning factor mu of eq. 1 [-]"},
    {"p_t", LOCSIM_PARAM_DOUBLE, 0.3, 1e-12, 1, nullptr,
     "per-component likelihood threshold p_t of eq. 1, each component scaled to 1 at a perfect "
     "match: larger resets sooner [-]"}};
}  // namespace

LOCSIM_LOCALIZER(Asrl, "asrl", "Adaptive sensor resetting localization (paper 004)", kParams)
