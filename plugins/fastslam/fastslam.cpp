// fastslam: FastSLAM 1.0 on range-bearing landmark detections, landmarks unknown (paper 001's
// baseline); see fastslam.hpp.
#include "fastslam.hpp"

namespace {

class Fastslam final : public fastslam::FastSlam {
 public:
  explicit Fastslam(const locsim_init& init) : FastSlam(init, fastslam::Mover::kNone) {}
};

constexpr locsim_param_decl kParams[] = {LOCSIM_FASTSLAM_PARAMS};

}  // namespace

LOCSIM_LOCALIZER(
    Fastslam, "fastslam",
    "FastSLAM 1.0 on range-bearing landmark detections, landmarks unknown (paper 001's baseline)",
    kParams)
