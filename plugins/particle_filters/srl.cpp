// srl: sensor resetting localization (Lenser and Veloso 2000): ns = n max(0, 1 - p~ / threshold).
#include "landmark_pf.hpp"

namespace {
class Srl final : public locsim::particle_filters::LandmarkParticleFilter {
 public:
  explicit Srl(const locsim_init& init)
      : LandmarkParticleFilter(init, locsim::particle_filters::Recovery::kSensorResetting) {}
};
constexpr locsim_param_decl kParams[] = {
    LOCSIM_LANDMARK_PF_PARAMS,
    {"threshold", LOCSIM_PARAM_DOUBLE, 0.1, 1e-300, 1, nullptr,
     "mean likelihood (1 = a perfect match) below which samples are reset, whatever the number "
     "of detections [-]"}};
}  // namespace

LOCSIM_LOCALIZER(Srl, "srl", "Sensor resetting localization (fixed threshold)", kParams)
