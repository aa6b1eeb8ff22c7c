// {{name}}: a locsim localizer. Start from here: it dead-reckons from the wheel encoders and
// blends in each landmark detection with a fixed gain. Replace it with your filter.
#include <cmath>
#include <locsim/localizer.hpp>
#include <locsim/models.hpp>
#include <optional>
#include <string>
#include <vector>

namespace {

class Filter final : public locsim::sdk::Localizer {
 public:
  explicit Filter(const locsim_init& init)
      : gain_(locsim::sdk::Params(init).number("gain")),
        wheel_base_m_(init.robot->wheel_base_m),
        odometry_(init.robot->wheel_base_m) {
    for (size_t i = 0; i < init.map->landmark_count; ++i)
      landmarks_.push_back(init.map->landmarks[i]);
    pose_ = {init.initial_pose.x, init.initial_pose.y, init.initial_pose.theta};
  }

  void on_odometry(double t_s, const locsim_odometry& odometry) override {
    // Wheel travel from the ticks, or from the odometry pose when the source has no ticks.
    if (const auto step = odometry_.update(t_s, odometry)) {
      pose_ = locsim::sdk::diff_drive_motion(pose_, step->d_left_m, step->d_right_m, wheel_base_m_);
    }
  }

  void on_landmarks(double, const locsim_landmarks& reading) override {
    for (size_t i = 0; i < reading.count; ++i) {
      const locsim_detection& d = reading.detections[i];
      if (d.target != LOCSIM_TARGET_LANDMARK) continue;  // another robot: not on the map
      for (const locsim_landmark& l : landmarks_) {
        if (d.color == nullptr || std::string(d.color) != l.color) continue;
        // Where the detection says the robot is, given this landmark; move part of the way.
        const double heading = pose_(2) + d.bearing_rad;
        const Eigen::Vector2d seen_from(l.x - d.range_m * std::cos(heading),
                                        l.y - d.range_m * std::sin(heading));
        pose_.head<2>() += gain_ * (seen_from - pose_.head<2>());
        break;
      }
    }
  }

  locsim::sdk::Estimate estimate() const override {
    return {{pose_(0), pose_(1), pose_(2)}, Eigen::Matrix3d::Identity() * 0.01};
  }

 private:
  double gain_, wheel_base_m_;
  std::vector<locsim_landmark> landmarks_;
  locsim::sdk::Pose pose_;
  locsim::sdk::OdometryTracker odometry_;
};

constexpr locsim_param_decl kParams[] = {
    {"gain", LOCSIM_PARAM_DOUBLE, 0.1, 0.0, 1.0, nullptr, "share of each landmark fix taken [-]"},
};

}  // namespace

LOCSIM_LOCALIZER(Filter, "{{name}}", "A template localizer: odometry nudged toward landmark fixes",
                 kParams)
