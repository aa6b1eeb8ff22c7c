// FastSLAM 1.0 on range-bearing landmark detections (paper 001, SPEC section 3), and the two
// ways paper 001 compares of moving the particles before resampling:
//  - fastslam: plain FastSLAM (Montemerlo et al. 2002): particles sample the odometry motion;
//    each carries one EKF per landmark it has seen; detections are associated by nearest
//    neighbour (Mahalanobis) with a gate beyond which they start a new landmark; weights are the
//    innovations' likelihoods; low-variance resampling when N_eff / N falls below a threshold.
//  - fastslam_afsa: the paper's method: after the motion prediction the particles move by the
//    artificial fish swarm (sdk::afsa_move) on the fitness f = sum exp(-1/2 nu^T R^-1 nu) over
//    the associated detections, then the landmark EKFs update; directed resampling refills the
//    lighter half from the bulletin board (the best particle of the previous step, predicted by
//    the weighted mean's motion, plus noise).
//  - pso_pf: the comparison: particles moved by particle swarm optimisation on the same fitness.
// The estimate is the weighted mean pose; the landmark map is the heaviest particle's.
#pragma once

#include <Eigen/Dense>
#include <locsim/localizer.hpp>
#include <locsim/models.hpp>
#include <locsim/particle_filter.hpp>
#include <locsim/particles.hpp>
#include <locsim/slam.hpp>
#include <locsim/swarm.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace fastslam {

namespace sdk = locsim::sdk;

enum class Mover { kNone, kFishSwarm, kParticleSwarm };

// clang-format off
#define LOCSIM_FASTSLAM_PARAMS                                                                     \
  {"particles", LOCSIM_PARAM_INT, 10, 1, 100000, nullptr, "number of particles (paper 001: 10) [-]"}, \
  {"alpha1", LOCSIM_PARAM_DOUBLE, 0.05, 0, 10, nullptr, "rotation noise from rotation [-]"},       \
  {"alpha2", LOCSIM_PARAM_DOUBLE, 0.05, 0, 10, nullptr, "rotation noise from translation [rad/m]"}, \
  {"alpha3", LOCSIM_PARAM_DOUBLE, 0.01, 0, 10, nullptr, "translation noise from translation [-]"},  \
  {"alpha4", LOCSIM_PARAM_DOUBLE, 0.05, 0, 10, nullptr, "translation noise from rotation [m/rad]"}, \
  {"sigma_range_m", LOCSIM_PARAM_DOUBLE, 0.01, 1e-6, 100, nullptr,                                 \
   "range noise of a detection (paper 001: 0.01) [m]"},                                            \
  {"sigma_bearing_deg", LOCSIM_PARAM_DOUBLE, 0.1, 1e-6, 180, nullptr,                              \
   "bearing noise of a detection (paper 001: 0.1) [deg]"},                                         \
  {"sigma_cross_m", LOCSIM_PARAM_DOUBLE, 0.0, 0, 100, nullptr,                                     \
   "noise across the ray in metres (a camera's sigma_minor): adds sigma_cross / range to the "    \
   "bearing's [m]"},                                                                              \
  LOCSIM_OMNI_NOISE_PARAMS,                                                                        \
  LOCSIM_GYRO_PARAMS,                                                                              \
  {"omni_as_range_bearing", LOCSIM_PARAM_BOOL, 0, 0, 1, nullptr,                                  \
   "weigh the omnidirectional camera's detections by sigma_range_m, sigma_bearing_deg and "       \
   "sigma_cross_m, as paper 001's sensor, not by its own noise along and across the ray"},        \
  {"new_landmark_chi2", LOCSIM_PARAM_DOUBLE, 13.8, 0.1, 1e6, nullptr,                              \
   "squared Mahalanobis distance beyond which a detection starts a new landmark (13.8: 99.9 %) [-]"}, \
  {"use_ids", LOCSIM_PARAM_BOOL, 0, 0, 1, nullptr,                                                 \
   "associate by the camera's landmark ids when it reports them, not by nearest neighbour"},       \
  {"resample_threshold", LOCSIM_PARAM_DOUBLE, 0.5, 0, 1, nullptr,                                  \
   "resample when N_eff / N falls below this [-]"},                                                \
  {"map_min_observations", LOCSIM_PARAM_INT, 2, 1, 1000000, nullptr,                              \
   "landmarks seen fewer times are left out of the reported map [-]"},                             \
  {"max_range_m", LOCSIM_PARAM_DOUBLE, 6.0, 0.01, 1e6, nullptr,                                    \
   "the omnidirectional camera's range (its default: 6): a mapped landmark predicted within it "  \
   "should be detected [m]"},                                                                     \
  {"prune_after_misses", LOCSIM_PARAM_INT, 10, 0, 1000000, nullptr,                                \
   "a landmark predicted well inside the range (90 %) of the omnidirectional camera and not "      \
   "detected in this many frames in a row is deleted from the particle's map; 0: never [-]"},      \
  {"diversity_cell_m", LOCSIM_PARAM_DOUBLE, 0.01, 1e-6, 100, nullptr,                              \
   "cell of the particle-diversity measure in x and y [m]"},                                       \
  {"diversity_cell_deg", LOCSIM_PARAM_DOUBLE, 0.1, 1e-6, 180, nullptr,                             \
   "cell of the particle-diversity measure in heading [deg]"},                                     \
  {"use_omni", LOCSIM_PARAM_BOOL, 1, 0, 1, nullptr, "use the omnidirectional camera's detections"}, \
  {"use_ptz", LOCSIM_PARAM_BOOL, 0, 0, 1, nullptr, "use the PTZ camera's detections"},             \
  {"use_range_bearing", LOCSIM_PARAM_BOOL, 1, 0, 1, nullptr,                                      \
   "use the range-bearing sensor's detections (no negative evidence: its field of view is "       \
   "limited)"}

#define LOCSIM_AFSA_PARAMS                                                                         \
  {"visual_m", LOCSIM_PARAM_DOUBLE, 0.05, 1e-6, 100, nullptr, "Visual: how far a fish sees [m]"},   \
  {"step_m", LOCSIM_PARAM_DOUBLE, 0.02, 1e-6, 100, nullptr, "Step: the longest move [m]"},         \
  {"crowding", LOCSIM_PARAM_DOUBLE, 0.6, 0, 100, nullptr, "crowding factor delta [-]"},            \
  {"iterations", LOCSIM_PARAM_INT, 3, 0, 1000, nullptr, "fish swarm rounds per step [-]"},         \
  {"prey_tries", LOCSIM_PARAM_INT, 3, 1, 1000, nullptr, "points tried by prey before a random step [-]"}, \
  {"heading_scale_m", LOCSIM_PARAM_DOUBLE, 0.0, 0, 1e6, nullptr,                                  \
   "metres per radian when heading enters distances and steps; 0: the frame's mean detection "    \
   "range, which a heading error moves the predicted detections by [m/rad]"},                      \
  {"board_noise_from_cloud", LOCSIM_PARAM_BOOL, 1, 0, 1, nullptr,                                  \
   "noise v on particles drawn from the bulletin board: the particle cloud's own weighted "       \
   "covariance (1) or the fixed board_sigma_m and board_sigma_deg (0)"},                           \
  {"board_sigma_m", LOCSIM_PARAM_DOUBLE, 0.02, 0, 100, nullptr,                                    \
   "fixed noise v on particles drawn from the bulletin board, position [m]"},                      \
  {"board_sigma_deg", LOCSIM_PARAM_DOUBLE, 0.2, 0, 180, nullptr,                                   \
   "fixed noise v on particles drawn from the bulletin board, heading [deg]"}

#define LOCSIM_PSO_PARAMS                                                                          \
  {"inertia", LOCSIM_PARAM_DOUBLE, 0.7, 0, 10, nullptr, "w: velocity kept [-]"},                   \
  {"cognitive", LOCSIM_PARAM_DOUBLE, 1.5, 0, 10, nullptr, "c1: pull to the particle's best [-]"},  \
  {"social", LOCSIM_PARAM_DOUBLE, 1.5, 0, 10, nullptr, "c2: pull to the swarm's best [-]"},        \
  {"iterations", LOCSIM_PARAM_INT, 3, 0, 1000, nullptr, "swarm iterations per step [-]"},          \
  {"max_speed_m", LOCSIM_PARAM_DOUBLE, 0.1, 1e-6, 100, nullptr, "longest move per iteration [m]"}, \
  {"heading_scale_m", LOCSIM_PARAM_DOUBLE, 0.0, 0, 1e6, nullptr,                                  \
   "metres per radian when heading enters distances; 0: the frame's mean detection range [m/rad]"}
// clang-format on

struct MapLandmark {
  sdk::LandmarkEstimate estimate;
  int id = -1;     // the camera's id (use_ids), else -1
  int misses = 0;  // omni frames in a row it was in range and not detected
};

/// A particle's map: what it carries beside its pose (in the skeleton's ParticleSet).
using LandmarkMap = std::vector<MapLandmark>;

class FastSlam : public sdk::Localizer {
 public:
  FastSlam(const locsim_init& init, Mover mover) : FastSlam(init, sdk::Params(init), mover) {}

  void on_odometry(double t_s, const locsim_odometry& odometry) override;
  void on_imu(double t_s, const locsim_imu& imu) override { pf_.odometry().observe_imu(t_s, imu); }
  void on_landmarks(double t_s, const locsim_landmarks& reading) override;
  sdk::Estimate estimate() const override;
  void particles(std::vector<locsim_pose2>& poses, std::vector<double>& weights) const override;
  std::vector<std::pair<std::string, double>> diagnostics() const override;
  void landmark_map(std::vector<locsim_mapped_landmark>& landmarks) const override;

 private:
  struct Match {
    int landmark = -1;  // -1: a new landmark
    Eigen::Vector2d z;  // (range, bearing)
    Eigen::Matrix2d r;
  };

  FastSlam(const locsim_init& init, const sdk::Params& params, Mover mover);
  /// R of a detection at `range` by `camera`: diagonal in (range, bearing).
  Eigen::Matrix2d noise(int32_t camera, double range) const;
  /// `reading` without its detections of other robots (itself when it has none).
  const locsim_landmarks& landmarks_only(const locsim_landmarks& reading);
  void associate(const sdk::Pose& pose, const LandmarkMap& map, const locsim_landmarks& reading,
                 std::vector<Match>& matches) const;
  double fitness(const LandmarkMap& map, const std::vector<Match>& matches,
                 const sdk::Pose& pose) const;
  void prune(LandmarkMap& map, const sdk::Pose& pose, const std::vector<Match>& matches) const;
  void resample();

  Mover mover_;
  sdk::ParticleFilter pf_;
  std::vector<LandmarkMap> maps_;  // particle i's map; reordered with the particles
  sdk::OdometryNoise motion_;
  double sigma_range_, sigma_bearing_, sigma_cross_, new_landmark_chi2_, resample_threshold_;
  sdk::DetectionNoise omni_noise_;  // the omnidirectional camera's (omni_sigma_*)
  bool omni_as_range_bearing_ = false;
  bool use_ids_, use_omni_, use_ptz_, use_range_bearing_;
  std::vector<locsim_detection> landmark_detections_;  // landmarks_only's storage
  locsim_landmarks landmarks_view_{};
  int map_min_observations_, prune_after_misses_;
  double max_range_m_;
  double diversity_cell_m_, diversity_cell_rad_;
  sdk::AfsaDef afsa_;
  sdk::PsoDef pso_;
  double heading_scale_m_ = 0.0;  // 0: per frame, the mean detection range
  bool board_noise_from_cloud_ = true;
  double board_sigma_m_ = 0.0, board_sigma_rad_ = 0.0;
  struct Board {
    sdk::Pose pose;   // the heaviest particle of the last camera update
    LandmarkMap map;  // and its map
    sdk::Pose mean;   // the weighted mean pose of that update
  };
  std::optional<Board> board_;
  sdk::Pose mean_ = sdk::Pose::Zero();
  Eigen::Matrix3d covariance_ = Eigen::Matrix3d::Identity();
  std::optional<sdk::Pose> last_odom_;  // pf_.odometry().now() at the last reading
  double last_slip_rad_ = 0.0;          // and its slip_rad()
  long steps_ = 0, resamples_ = 0, evaluations_ = 0;
  double n_eff_sum_ = 0.0, diversity_sum_ = 0.0;
};

}  // namespace fastslam
