// One run: the physics world, its robots and movers, driven by a scenario on a fixed-step
// simulated clock. Deterministic: the same world, scenario and seed give the same states.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sim/common/format.hpp"
#include "sim/common/parallel.hpp"
#include "sim/common/random.hpp"
#include "sim/robot/diff_drive.hpp"
#include "sim/scenario/drivers.hpp"
#include "sim/scenario/scenario_def.hpp"
#include "sim/sensors/readings.hpp"
#include "sim/sensors/scene_rays.hpp"
#include "sim/sensors/sensor.hpp"
#include "sim/stream/record.hpp"
#include "sim/world/physics_world.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

/// Running totals per robot, for run.json and tests.
struct RobotStats {
  double ground_distance_m = 0.0;      // path length of the body on the floor (not while carried)
  double wheel_distance_left_m = 0.0;  // |rotation| x true radius, summed
  double wheel_distance_right_m = 0.0;
  double slip_time_s = 0.0;  // time with a wheel at its friction limit
  int collisions = 0;        // contacts begun after 0.5 s without touching that body
  int kidnaps = 0;
};

class Simulation {
 public:
  /// `world` and `scenario` must have been checked (bind_scenario). Throws InputError when a
  /// robot starts in collision, or a kidnap has nowhere to put its robot down.
  /// `make_imager` renders the images of PTZ cameras in mode: rendered (none: such a camera
  /// throws RenderError at construction).
  Simulation(WorldDef world, ScenarioDef scenario, std::uint64_t seed,
             const LandmarkImagerFactory& make_imager = {});
  ~Simulation();

  /// Advances one physics step, then applies the scenario events due at the new time, so that
  /// the state at time t includes every event scheduled at or before t.
  void step();
  bool done() const { return done_; }
  /// Samples the sensors of different robots on `threads` threads (the caller's included) from
  /// the next step on: the same readings, in the same order, for any count. 0: one per core,
  /// each sensor round shared out or run on the caller's thread alone, whichever has lately been
  /// faster (LoopWayChooser: on a busy machine, one thread can be). A world with one robot, or a
  /// camera that renders its images (one GL context), stays on the caller's thread.
  void use_threads(int threads);
  /// With use_threads(0): the share of the sensor rounds shared out so far (NaN: none timed).
  double shared_share() const;

  std::int64_t step_index() const { return step_index_; }
  double time_s() const { return static_cast<double>(step_index_) * dt_s_; }
  double dt_s() const { return dt_s_; }
  std::int64_t end_step() const { return end_step_; }
  std::uint64_t seed() const { return seed_; }

  const WorldDef& world_def() const { return world_def_; }
  const ScenarioDef& scenario() const { return scenario_; }
  PhysicsWorld& world() { return *world_; }
  const PhysicsWorld& world() const { return *world_; }
  std::size_t robot_count() const { return robots_.size(); }
  DiffDriveRobot& robot(std::size_t i) { return *robots_[i].robot; }
  const DiffDriveRobot& robot(std::size_t i) const { return *robots_[i].robot; }
  const RobotStats& stats(std::size_t i) const { return robots_[i].stats; }

  /// Events since the last call, in order.
  std::vector<SimEvent> take_events();
  /// Sensor readings since the last call, in time order (robots, then sensors, in file order).
  std::vector<Reading> take_readings();
  /// The enabled sensors of robot `i`.
  const std::vector<std::unique_ptr<Sensor>>& sensors(std::size_t i) const {
    return robots_[i].sensors;
  }
  const SceneRays& rays() const { return *rays_; }
  /// FNV-1a hash of every body's state and every wheel's rotation: equal hashes, equal runs.
  std::uint64_t state_hash() const;

 private:
  struct Touch {
    int count = 0;  // touching fixture pairs with one other body
    std::int64_t last_touch_step = -1'000'000;
  };
  struct RobotSlot {
    std::unique_ptr<DiffDriveRobot> robot;
    std::unique_ptr<Driver> driver;  // null: commanded from outside (robot(i).command)
    RandomStream kidnap_rng{0};
    std::optional<std::int64_t> put_down_step;  // while carried
    const EventDef* pending_kidnap = nullptr;
    Vec2 last_position{0.0, 0.0};
    RobotStats stats;
    std::map<std::uintptr_t, Touch> touching;  // by the other body's tag
    std::vector<std::unique_ptr<Sensor>> sensors;
    std::vector<std::int64_t> sensor_strides;  // physics steps per sample
  };
  static constexpr double kCollisionQuietS = 0.5;  // see step() [s]

  void fire_due_events();
  void run_sensors(bool physics_stepped);
  void run_robot_sensors(std::size_t robot, bool physics_stepped, std::vector<Reading>& out);
  void refresh_moving_prisms();
  void fire(const EventDef& event);
  void put_down(RobotSlot& slot);
  Pose2 random_free_pose(RobotSlot& slot, const EventDef& event);
  /// Throws InputError when a kidnap's target overlaps static geometry, or its random region has
  /// no pose where the robot fits; for a random one, returns a pose clear of static geometry.
  std::optional<Pose2> check_kidnap(const EventDef& event) const;
  RobotSlot& slot_of(const std::string& robot);
  std::string body_name(const BodyTag& tag) const;
  void log(std::string kind, std::string robot, std::string details);

  WorldDef world_def_;
  ScenarioDef scenario_;
  std::uint64_t seed_;
  double dt_s_;
  std::int64_t step_index_ = 0;
  std::int64_t end_step_;
  std::int64_t collision_quiet_steps_;
  std::size_t next_event_ = 0;
  std::vector<std::int64_t> event_steps_;
  std::vector<std::optional<Pose2>> kidnap_fallbacks_;  // by event, see check_kidnap
  bool done_ = false;
  std::unique_ptr<PhysicsWorld> world_;
  std::vector<RobotSlot> robots_;
  std::vector<const DiffDriveRobot*> robot_views_;  // robots_' robots, for sensors seeing robots
  std::vector<SimEvent> events_;
  std::unique_ptr<StaticRaycaster> static_rays_;
  std::unique_ptr<SceneRays> rays_;
  bool renders_images_ = false;            // a camera in mode: rendered
  std::vector<ScenePrism> moving_prisms_;  // refreshed for each sensor round when it does
  std::vector<Reading> readings_;
  // Sensors on several threads (use_threads): each robot's readings of a step, merged in robot
  // order; the sample periods of every sensor, to wake the threads only on steps that sample.
  std::unique_ptr<ParallelLoop> parallel_;
  // use_threads(0): each kind of sensor round (which sensor rates sample in it, a bit per
  // sample_strides_ entry) shared out when that has been faster for that kind: a round of
  // encoders alone costs less than waking a thread, one with laser scans gains from sharing.
  bool choose_way_ = false;
  std::map<std::uint64_t, LoopWayChooser> choosers_;
  std::vector<std::vector<Reading>> robot_readings_;
  std::vector<std::int64_t> sample_strides_;
};

/// "(x,y,theta)" with four decimals, for events and messages.
std::string format_pose(const Pose2& pose);

}  // namespace locsim
