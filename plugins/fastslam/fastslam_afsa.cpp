// fastslam_afsa: FastSLAM with artificial-fish-swarm moves and directed resampling (paper 001); see
// fastslam.hpp.
#include "fastslam.hpp"

namespace {

class FastslamAfsa final : public fastslam::FastSlam {
 public:
  explicit FastslamAfsa(const locsim_init& init) : FastSlam(init, fastslam::Mover::kFishSwarm) {}
};

constexpr locsim_param_decl kParams[] = {LOCSIM_FASTSLAM_PARAMS, LOCSIM_AFSA_PARAMS};

}  // namespace

LOCSIM_LOCALIZER(FastslamAfsa, "fastslam_afsa",
                 "FastSLAM with artificial-fish-swarm moves and directed resampling (paper 001)",
                 kParams)
