// amcl: adaptive Monte Carlo localization on the laser as a plugin; the filter (likelihood field,
// KLD sampling, AMCL's parameter names) is in amcl_filter.hpp.
#include <locsim/localizer.hpp>

#include "amcl_filter.hpp"

namespace {

namespace sdk = locsim::sdk;

class Amcl final : public sdk::Localizer {
 public:
  explicit Amcl(const locsim_init& init) : filter_(sdk::Params(init), init, init.seed) {}

  void on_odometry(double t_s, const locsim_odometry& odometry) override {
    filter_.on_odometry(t_s, odometry);
  }
  void on_imu(double t_s, const locsim_imu& imu) override { filter_.on_imu(t_s, imu); }
  void on_laser(double t_s, const locsim_laser_scan& scan) override { filter_.on_laser(t_s, scan); }
  sdk::Estimate estimate() const override { return filter_.estimate(); }
  void particles(std::vector<locsim_pose2>& poses, std::vector<double>& weights) const override {
    filter_.particles(poses, weights);
  }
  std::vector<std::pair<std::string, double>> diagnostics() const override {
    return filter_.diagnostics();
  }

 private:
  amcl::AmclFilter filter_;
};

}  // namespace

LOCSIM_LOCALIZER(Amcl, "amcl",
                 "Adaptive Monte Carlo localization on the laser: likelihood field, KLD sampling",
                 amcl::kAmclParams)
