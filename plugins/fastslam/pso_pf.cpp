// pso_pf: FastSLAM with particle-swarm moves before resampling (paper 001's comparison); see
// fastslam.hpp.
#include "fastslam.hpp"

namespace {

class PsoPf final : public fastslam::FastSlam {
 public:
  explicit PsoPf(const locsim_init& init) : FastSlam(init, fastslam::Mover::kParticleSwarm) {}
};

constexpr locsim_param_decl kParams[] = {LOCSIM_FASTSLAM_PARAMS, LOCSIM_PSO_PARAMS};

}  // namespace

LOCSIM_LOCALIZER(PsoPf, "pso_pf",
                 "FastSLAM with particle-swarm moves before resampling (paper 001's comparison)",
                 kParams)
