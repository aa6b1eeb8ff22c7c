#include "sim/producers/simulation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <iterator>
#include <limits>
#include <optional>

#include "sim/common/errors.hpp"
#include "sim/sensors/models.hpp"

namespace locsim {

std::string format_pose(const Pose2& pose) {
  return "(" + fixed(pose.x, 4) + "," + fixed(pose.y, 4) + "," + fixed(pose.theta, 4) + ")";
}

Simulation::Simulation(WorldDef world, ScenarioDef scenario, std::uint64_t seed,
                       const LandmarkImagerFactory& make_imager)
    : world_def_(std::move(world)),
      scenario_(std::move(scenario)),
      seed_(seed),
      dt_s_(1.0 / world_def_.physics.step_hz),
      end_step_(std::llround(scenario_.duration_s * world_def_.physics.step_hz)),
      collision_quiet_steps_(std::llround(kCollisionQuietS * world_def_.physics.step_hz)),
      world_(std::make_unique<PhysicsWorld>(world_def_)) {
  for (std::size_t i = 0; i < world_def_.robots.size(); ++i) {
    const RobotDef& def = world_def_.robots[i];
    RobotSlot slot;
    slot.robot = std::make_unique<DiffDriveRobot>(def, *world_, static_cast<int>(i));
    if (!world_->is_free(slot.robot->shape(), def.start, slot.robot->body())) {
      throw InputError(def.where, def.key_path.empty() ? "start" : def.key_path + ".start",
                       "robot '" + def.name + "' starts in collision at " + format_pose(def.start) +
                           " (overlaps a wall, shape, mover or another robot)");
    }
    slot.kidnap_rng = make_stream(seed, "kidnap/" + def.name);
    if (def.command_response.wanders())
      slot.robot->seed_response(make_stream(seed, "response/" + def.name));
    if (def.side_slip.wander_k > 0.0)
      slot.robot->seed_side_slip(make_stream(seed, "slip/" + def.name));
    slot.last_position = def.start.position();
    // A robot the scenario does not drive keeps whatever command its owner last gave it.
    for (const DriveDef& d : scenario_.drives) {
      if (d.robot == def.name)
        slot.driver = make_driver(d, make_stream(seed, "driver/" + def.name));
    }
    robot_views_.push_back(slot.robot.get());
    robots_.push_back(std::move(slot));
  }
  for (const EventDef& event : scenario_.events) {
    event_steps_.push_back(std::llround(event.at_s * world_def_.physics.step_hz));
    kidnap_fallbacks_.push_back(check_kidnap(event));
  }

  // Sensors: the static geometry is copied once into the grid the rays traverse; everything that
  // moves is looked up in Box2D at each query.
  static_rays_ = std::make_unique<StaticRaycaster>(StaticRaycaster::from_world(*world_));
  std::vector<DynamicOccluder> dynamics;
  for (const Mover& mover : world_->movers()) {
    dynamics.push_back({mover.body, mover.def.height_m, bounding_radius(mover.def.footprint)});
  }
  for (const RobotSlot& slot : robots_) {
    dynamics.push_back({slot.robot->body(), slot.robot->def().height_m,
                        bounding_radius(slot.robot->def().footprint)});
  }
  rays_ = std::make_unique<SceneRays>(*static_rays_, std::move(dynamics));
  for (RobotSlot& slot : robots_) {
    const PanPolicyDef* policy = nullptr;
    for (const PanPolicyDef& p : scenario_.pan_policies) {
      if (p.robot == slot.robot->name()) policy = &p;
    }
    slot.sensors = make_sensors(slot.robot->def(), seed, policy);
    for (const auto& sensor : slot.sensors) {
      auto* ptz = dynamic_cast<PtzCameraSensor*>(sensor.get());
      if (ptz == nullptr || ptz->def().mode != PtzCameraDef::Mode::kRendered) continue;
      if (!make_imager) {
        throw RenderError("robot '" + slot.robot->name() +
                          "': ptz_camera mode: rendered needs the renderer, which this program "
                          "does not load (`locsim run` and `locsim experiment` do)");
      }
      ptz->set_imager(make_imager(world_def_, ptz->def()));
      renders_images_ = true;
    }
    for (const auto& sensor : slot.sensors) {
      slot.sensor_strides.push_back(
          std::llround(world_def_.physics.step_hz / sensor->common().rate_hz));
      if (std::find(sample_strides_.begin(), sample_strides_.end(), slot.sensor_strides.back()) ==
          sample_strides_.end())
        sample_strides_.push_back(slot.sensor_strides.back());
    }
  }
  fire_due_events();  // those at t = 0
  run_sensors(false);
}

void Simulation::refresh_moving_prisms() {
  moving_prisms_.clear();
  for (const Mover& mover : world_->movers()) {
    const b2Vec2 p = mover.body->GetPosition();
    moving_prisms_.push_back({mover.def.name, mover.def.kind,
                              Pose2{p.x, p.y, mover.body->GetAngle()}, mover.def.footprint,
                              mover.def.height_m});
  }
  for (const RobotSlot& slot : robots_) {
    if (slot.robot->carried()) continue;  // in the air, above the cameras
    moving_prisms_.push_back({slot.robot->name(), "robot", slot.robot->pose(),
                              slot.robot->def().footprint, slot.robot->def().height_m});
  }
}

void Simulation::use_threads(int threads) {
  parallel_.reset();
  choosers_.clear();
  choose_way_ = false;
  if (threads == 0) {
    threads = default_thread_count();
    choose_way_ = true;
  }
  if (threads > 1 && robots_.size() > 1 && !renders_images_) {
    parallel_ = std::make_unique<ParallelLoop>(std::min(threads, static_cast<int>(robots_.size())));
    robot_readings_.resize(robots_.size());
  }
}

double Simulation::shared_share() const {
  std::int64_t loops = 0, shared = 0;
  for (const auto& [kind, chooser] : choosers_)
    loops += chooser.loops(), shared += chooser.shared_loops();
  if (loops == 0) return std::numeric_limits<double>::quiet_NaN();
  return static_cast<double>(shared) / static_cast<double>(loops);
}

void Simulation::run_robot_sensors(std::size_t i, bool physics_stepped, std::vector<Reading>& out) {
  RobotSlot& slot = robots_[i];
  SensorContext context{time_s(), dt_s_, *slot.robot, world_def_, *rays_};
  context.robots = &robot_views_;
  if (renders_images_) context.moving = &moving_prisms_;
  for (std::size_t k = 0; k < slot.sensors.size(); ++k) {
    Sensor& sensor = *slot.sensors[k];
    if (physics_stepped) sensor.on_physics_step(context);
    if (step_index_ % slot.sensor_strides[k] != 0) continue;
    if (std::optional<ReadingData> data = sensor.sample(context)) {
      out.push_back(Reading{time_s(), static_cast<int>(i), sensor.kind(), std::move(*data)});
    }
  }
}

void Simulation::run_sensors(bool physics_stepped) {
  if (renders_images_ && !robots_.empty()) refresh_moving_prisms();
  // Most steps only integrate (encoders, IMU between samples): too little work to share.
  const bool samples = std::any_of(sample_strides_.begin(), sample_strides_.end(),
                                   [&](std::int64_t s) { return step_index_ % s == 0; });
  // Sampling sensors cast rays; nothing moves until they are done (between physics steps).
  std::optional<SceneRays::Indexed> indexed;
  if (samples) indexed.emplace(*rays_);
  if (!parallel_ || !samples) {
    for (std::size_t i = 0; i < robots_.size(); ++i)
      run_robot_sensors(i, physics_stepped, readings_);
    return;
  }
  LoopWayChooser* chooser = nullptr;
  if (choose_way_) {
    std::uint64_t kind = 0;
    for (std::size_t k = 0; k < sample_strides_.size() && k < 64; ++k)
      kind |= step_index_ % sample_strides_[k] == 0 ? std::uint64_t{1} << k : 0;
    chooser = &choosers_[kind];
  }
  const bool shared = chooser == nullptr || chooser->shared();
  const auto start = chooser != nullptr ? std::chrono::steady_clock::now()
                                        : std::chrono::steady_clock::time_point();
  if (!shared) {
    for (std::size_t i = 0; i < robots_.size(); ++i)
      run_robot_sensors(i, physics_stepped, readings_);
  } else {
    // Each robot's sensors read the world and write only their own state and readings.
    parallel_->for_each(robots_.size(), [&](std::size_t i) {
      robot_readings_[i].clear();
      run_robot_sensors(i, physics_stepped, robot_readings_[i]);
    });
    for (std::vector<Reading>& own : robot_readings_) {
      std::move(own.begin(), own.end(), std::back_inserter(readings_));
      own.clear();
    }
  }
  if (chooser != nullptr) {
    chooser->took(std::chrono::duration_cast<std::chrono::nanoseconds>(
                      std::chrono::steady_clock::now() - start)
                      .count());
  }
}

std::vector<Reading> Simulation::take_readings() {
  std::vector<Reading> out;
  out.swap(readings_);
  return out;
}

Simulation::~Simulation() = default;

void Simulation::log(std::string kind, std::string robot, std::string details) {
  events_.push_back(
      SimEvent{step_index_, time_s(), std::move(kind), std::move(robot), std::move(details)});
}

std::vector<SimEvent> Simulation::take_events() {
  std::vector<SimEvent> out;
  out.swap(events_);
  return out;
}

Simulation::RobotSlot& Simulation::slot_of(const std::string& robot) {
  for (RobotSlot& slot : robots_) {
    if (slot.robot->name() == robot) return slot;
  }
  throw std::logic_error("unbound robot name '" + robot + "'");  // bind_scenario prevents this
}

std::string Simulation::body_name(const BodyTag& tag) const {
  switch (tag.kind) {
    case BodyKind::kStatic:
      return "static";
    case BodyKind::kRobot:
      return robots_[tag.index].robot->name();
    case BodyKind::kMover:
      return world_->movers()[tag.index].def.name;
  }
  return "?";
}

namespace {
/// The poses a search for a free pose tries after its random draws: a kLattice x kLattice grid of
/// positions over [lo, hi], row by row, each at kHeadings headings; `visit` returns true to stop.
constexpr int kLattice = 128;
constexpr int kHeadings = 8;
template <class Visit>
bool scan_lattice(const Vec2& lo, const Vec2& hi, Visit visit) {
  for (int row = 0; row < kLattice; ++row) {
    for (int col = 0; col < kLattice; ++col) {
      const Vec2 at =
          lo + (hi - lo).cwiseProduct(Vec2{(col + 0.5) / kLattice, (row + 0.5) / kLattice});
      for (int k = 0; k < kHeadings; ++k) {
        if (visit(Pose2{at.x(), at.y(), wrap_angle(2.0 * std::numbers::pi * k / kHeadings)})) {
          return true;
        }
      }
    }
  }
  return false;
}
}  // namespace

std::optional<Pose2> Simulation::check_kidnap(const EventDef& event) const {
  if (event.kind != EventDef::Kind::kKidnap) return std::nullopt;
  const DiffDriveRobot* robot = nullptr;
  for (const RobotSlot& slot : robots_) {
    if (slot.robot->name() == event.robot) robot = slot.robot.get();
  }
  if (robot == nullptr) return std::nullopt;  // bind_scenario names every robot
  // A put-down inside static geometry would have Box2D push the robot out to either side of a
  // wall, outside the room as likely as in; movers and robots move, so only walls count here.
  if (event.to) {
    if (!world_->is_free_of_static(robot->shape(), *event.to)) {
      throw InputError(event.where, event.key_path + ".to",
                       "robot '" + robot->name() + "' would be put down at " +
                           format_pose(*event.to) +
                           " overlapping a wall, shape or map cell; choose a free pose");
    }
    return std::nullopt;
  }
  // A random target needs a free pose to exist: looked for now, by a search that is the same for
  // every seed (draws of a stream of its own, then a lattice), not when the run is half done.
  const Vec2 lo = event.random_min_m.value_or(world_->bounds_min());
  const Vec2 hi = event.random_max_m.value_or(world_->bounds_max());
  RandomStream rng = make_stream(0, "kidnap-check/" + robot->name());
  for (int attempt = 0; attempt < 1000; ++attempt) {
    const Pose2 pose{rng.uniform(lo.x(), hi.x()), rng.uniform(lo.y(), hi.y()),
                     rng.uniform(-std::numbers::pi, std::numbers::pi)};
    if (world_->is_free_of_static(robot->shape(), pose)) return pose;
  }
  std::optional<Pose2> found;
  scan_lattice(lo, hi, [&](const Pose2& pose) {
    if (world_->is_free_of_static(robot->shape(), pose)) found = pose;
    return found.has_value();
  });
  if (!found) {
    throw InputError(event.where, event.key_path + (event.random_min_m ? ".within" : ".to"),
                     "robot '" + robot->name() + "' fits nowhere in x " + short_number(lo.x()) +
                         ".." + short_number(hi.x()) + " m, y " + short_number(lo.y()) + ".." +
                         short_number(hi.y()) +
                         " m: every pose tried overlaps a wall, shape or map cell");
  }
  return found;
}

Pose2 Simulation::random_free_pose(RobotSlot& slot, const EventDef& event) {
  const Vec2 lo = event.random_min_m.value_or(world_->bounds_min());
  const Vec2 hi = event.random_max_m.value_or(world_->bounds_max());
  for (int attempt = 0; attempt < 10000; ++attempt) {
    const Pose2 pose{slot.kidnap_rng.uniform(lo.x(), hi.x()),
                     slot.kidnap_rng.uniform(lo.y(), hi.y()),
                     slot.kidnap_rng.uniform(-std::numbers::pi, std::numbers::pi)};
    if (world_->is_free(slot.robot->shape(), pose, slot.robot->body())) return pose;
  }
  // Rare (a region nearly filled, or people and robots standing on what is free): the lattice,
  // else the pose the load-time check found clear of walls, where contacts push the robot free.
  std::optional<Pose2> found;
  scan_lattice(lo, hi, [&](const Pose2& pose) {
    if (world_->is_free(slot.robot->shape(), pose, slot.robot->body())) found = pose;
    return found.has_value();
  });
  if (found) return *found;
  const std::size_t index = static_cast<std::size_t>(&event - scenario_.events.data());
  return kidnap_fallbacks_.at(index).value();
}

void Simulation::put_down(RobotSlot& slot) {
  const EventDef& event = *slot.pending_kidnap;
  const Pose2 target = event.to ? *event.to : random_free_pose(slot, event);
  slot.robot->put_down(target);
  slot.last_position = target.position();
  slot.put_down_step.reset();
  slot.pending_kidnap = nullptr;
  log("put_down", slot.robot->name(), "to=" + format_pose(target));
}

void Simulation::fire(const EventDef& event) {
  switch (event.kind) {
    case EventDef::Kind::kKidnap: {
      RobotSlot& slot = slot_of(event.robot);
      if (slot.robot->carried()) break;  // already in the air: the later kidnap is moot
      const Pose2 from = slot.robot->pose();
      slot.robot->lift();
      slot.pending_kidnap = &event;
      ++slot.stats.kidnaps;
      log("kidnap", event.robot,
          "from=" + format_pose(from) + " carry_s=" + fixed(event.carry_s, 3) +
              " to=" + (event.to ? format_pose(*event.to) : std::string("random")));
      slot.put_down_step = step_index_ + std::llround(event.carry_s / dt_s_);
      if (*slot.put_down_step <= step_index_) put_down(slot);
      break;
    }
    case EventDef::Kind::kPush:
      slot_of(event.robot).robot->push(event.impulse_ns, event.angular_impulse_nms);
      log("push", event.robot,
          "impulse_ns=(" + fixed(event.impulse_ns.x(), 3) + "," + fixed(event.impulse_ns.y(), 3) +
              ") angular_impulse_nms=" + fixed(event.angular_impulse_nms, 3));
      break;
    case EventDef::Kind::kFriction:
      world_->floor().set(event.region, event.friction);
      log("friction", "", "region=" + event.region + " friction=" + fixed(event.friction, 3));
      break;
    case EventDef::Kind::kObstacle:
      for (Mover& mover : world_->movers()) {
        if (mover.def.name == event.obstacle) mover.moving = event.start_moving;
      }
      log(event.start_moving ? "obstacle_start" : "obstacle_stop", "", "name=" + event.obstacle);
      break;
    case EventDef::Kind::kSensorFault: {
      RobotSlot& slot = slot_of(event.robot);
      for (const auto& sensor : slot.sensors) {
        if (event.sensor == sensor_name(sensor->kind())) sensor->inject(event.fault, time_s());
      }
      const char* modes[] = {"dropout", "stuck", "bias"};
      log("sensor_fault", event.robot,
          "sensor=" + event.sensor + " mode=" + modes[static_cast<int>(event.fault.mode)] +
              " duration_s=" + fixed(event.fault.duration_s, 3) +
              " bias=" + fixed(event.fault.bias, 6));
      break;
    }
    case EventDef::Kind::kEnd:
      done_ = true;
      break;
  }
}

void Simulation::fire_due_events() {
  for (RobotSlot& slot : robots_) {
    if (slot.put_down_step && *slot.put_down_step <= step_index_) put_down(slot);
  }
  while (next_event_ < scenario_.events.size() && event_steps_[next_event_] <= step_index_) {
    fire(scenario_.events[next_event_++]);
  }
  if (step_index_ >= end_step_) done_ = true;
  if (done_) log("end", "", "t_s=" + fixed(time_s(), 4));
}

void Simulation::step() {
  if (done_) return;
  const double t = time_s();
  for (RobotSlot& slot : robots_) {
    if (slot.robot->carried() || !slot.driver) continue;
    const VelocityCommand command = slot.driver->update(t, *slot.robot, *world_);
    slot.robot->command(command.v_mps, command.w_radps);
  }
  world_->drive_movers(dt_s_);
  for (RobotSlot& slot : robots_) slot.robot->apply_drive(dt_s_, world_->floor());
  world_->step(dt_s_);
  ++step_index_;

  for (RobotSlot& slot : robots_) {
    DiffDriveRobot& robot = *slot.robot;
    if (robot.carried()) continue;
    const Vec2 position = robot.pose().position();
    slot.stats.ground_distance_m += (position - slot.last_position).norm();
    slot.last_position = position;
    slot.stats.wheel_distance_left_m +=
        std::abs(robot.left().speed_radps) * robot.left().radius_m * dt_s_;
    slot.stats.wheel_distance_right_m +=
        std::abs(robot.right().speed_radps) * robot.right().radius_m * dt_s_;
    if (robot.left().slipping || robot.right().slipping) slot.stats.slip_time_s += dt_s_;
  }
  for (const ContactChange& change : world_->take_contact_changes()) {
    for (const auto& [self, other] :
         {std::pair{change.a, change.b}, std::pair{change.b, change.a}}) {
      if (self.kind != BodyKind::kRobot) continue;
      RobotSlot& slot = robots_[self.index];
      Touch& touch = slot.touching[encode_tag(other)];
      if (change.begin) {
        // A body resting against another makes and breaks contact every few steps; only a
        // contact after kCollisionQuietS of no touching counts as a new collision.
        if (touch.count++ == 0 && step_index_ - touch.last_touch_step > collision_quiet_steps_) {
          ++slot.stats.collisions;
          log("collision", slot.robot->name(),
              "with=" + body_name(other) + " at=" + format_pose(slot.robot->pose()));
        }
      } else if (touch.count > 0) {
        --touch.count;
      }
      touch.last_touch_step = step_index_;
    }
  }
  fire_due_events();
  run_sensors(true);
}

std::uint64_t Simulation::state_hash() const {
  std::uint64_t hash = 0xcbf29ce484222325ULL;
  const auto mix = [&hash](double value) {
    unsigned char bytes[sizeof(double)];
    std::memcpy(bytes, &value, sizeof(double));
    for (const unsigned char byte : bytes) {
      hash ^= byte;
      hash *= 0x100000001b3ULL;
    }
  };
  mix(static_cast<double>(step_index_));
  for (const RobotSlot& slot : robots_) {
    const b2Body* body = slot.robot->body();
    mix(body->GetPosition().x), mix(body->GetPosition().y), mix(body->GetAngle());
    mix(body->GetLinearVelocity().x), mix(body->GetLinearVelocity().y);
    mix(body->GetAngularVelocity());
    mix(slot.robot->left().angle_rad), mix(slot.robot->right().angle_rad);
  }
  for (const Mover& mover : world_->movers()) {
    mix(mover.body->GetPosition().x), mix(mover.body->GetPosition().y);
  }
  return hash;
}

}  // namespace locsim
