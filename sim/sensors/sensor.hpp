// The sensors of a robot: each samples the true state at its own rate, with its own random
// stream, and may be faulted by scenario events (dropout, stuck value, bias step).
#pragma once

#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sim/common/random.hpp"
#include "sim/robot/diff_drive.hpp"
#include "sim/scenario/scenario_def.hpp"
#include "sim/sensors/camera_image.hpp"
#include "sim/sensors/readings.hpp"
#include "sim/sensors/scene_rays.hpp"
#include "sim/sensors/sensor_defs.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

/// What a sensor may look at: the truth.
struct SensorContext {
  double t_s = 0.0;
  double step_s = 0.0;  // physics step [s]
  const DiffDriveRobot& robot;
  const WorldDef& world;
  const SceneRays& rays;
  // Everything that moves, for a camera that renders its image; null unless one does.
  const std::vector<ScenePrism>* moving = nullptr;
  // Every robot of the world, by index (this one included), for a sensor that detects robots;
  // null when none does.
  const std::vector<const DiffDriveRobot*>* robots = nullptr;
};

class Sensor {
 public:
  Sensor(SensorKind kind, const SensorCommon& common, RandomStream rng)
      : kind_(kind), common_(common), rng_(rng) {}
  virtual ~Sensor() = default;

  SensorKind kind() const { return kind_; }
  const SensorCommon& common() const { return common_; }

  /// After every physics step, for sensors that integrate between samples.
  virtual void on_physics_step(const SensorContext&) {}
  /// A reading at a sample time, faults applied; nullopt when nothing comes out.
  std::optional<ReadingData> sample(const SensorContext& context);

  void inject(const SensorFaultDef& fault, double now_s);
  virtual bool supports_bias() const { return true; }
  /// The stream the spells of silence draw from (SensorCommon::outage_fraction > 0).
  void set_outage_stream(RandomStream rng) { outage_rng_ = rng; }

 protected:
  virtual std::optional<ReadingData> measure(const SensorContext& context) = 0;
  virtual void apply_bias(ReadingData& data, double bias) const = 0;
  RandomStream& rng() { return rng_; }

 private:
  struct ActiveFault {
    SensorFaultDef def;
    double until_s;
  };
  SensorKind kind_;
  SensorCommon common_;
  RandomStream rng_;
  /// Whether a spell of silence covers t_s (times never decrease).
  bool silent(double t_s);
  std::vector<ActiveFault> faults_;
  std::optional<ReadingData> last_;
  std::optional<RandomStream> outage_rng_;
  bool out_ = false;                                            // in a spell now
  double switch_s_ = std::numeric_limits<double>::quiet_NaN();  // when that changes next
};

/// Builds the enabled sensors of a robot; each draws from "sensor/ROBOT/KIND" of the run seed.
std::vector<std::unique_ptr<Sensor>> make_sensors(const RobotDef& robot, std::uint64_t seed,
                                                  const PanPolicyDef* pan_policy);

}  // namespace locsim
