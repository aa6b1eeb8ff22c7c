#include "sim/consumers/frame_capture.hpp"

#include <box2d/box2d.h>

#include <algorithm>
#include <cmath>

#include "sim/sensors/models.hpp"

namespace locsim {

namespace {
const std::vector<Mover> kNoMovers;
}  // namespace

FrameCapture::FrameCapture(FrameSink& sink, const VideoOptions& options, const Simulation& sim,
                           LocalizerHost* host)
    : sink_(sink),
      world_(sim.world_def()),
      host_(host),
      from_stream_(false),
      frame_interval_s_(options.speed / options.fps),
      latest_(sim.robot_count()) {
  for (std::size_t i = 0; i < sim.robot_count(); ++i) {
    latest_[i].pose = latest_[i].floor_pose = sim.robot(i).pose();
  }
  sink_.start(world_);
}

FrameCapture::FrameCapture(FrameSink& sink, const VideoOptions& options, const WorldDef& world,
                           LocalizerHost* host)
    : sink_(sink),
      world_(world),
      host_(host),
      from_stream_(true),
      frame_interval_s_(options.speed / options.fps),
      latest_(world.robots.size()) {
  // Until the first ground truth, each robot where the world starts it.
  for (std::size_t i = 0; i < world.robots.size(); ++i) {
    latest_[i].pose = latest_[i].floor_pose = world.robots[i].start;
  }
  sink_.start(world_);
}

void FrameCapture::consume(const Record& record) {
  if (record.type != Record::Type::kReading) {
    if (from_stream_) consume_truth(record);
    return;
  }
  Latest& latest = latest_[static_cast<std::size_t>(record.reading.robot)];
  std::visit(
      [&](const auto& data) {
        using T = std::decay_t<decltype(data)>;
        // A real base may report only its velocity: no dead-reckoned pose to draw.
        if constexpr (std::is_same_v<T, OdometryReading>) {
          if (data.has(kOdometryPose)) latest.odometry = data.odometry;
        }
        if constexpr (std::is_same_v<T, LaserScan>) latest.laser = data;
        if constexpr (std::is_same_v<T, UltrasonicReading>) latest.ultrasonic = data;
        if constexpr (std::is_same_v<T, PtzReading>) latest.ptz = data;
        if constexpr (std::is_same_v<T, RangeBearingReading>) {
          latest.range_bearing = data;
          latest.range_bearing_t_s = record.reading.t_s;
        }
        if constexpr (std::is_same_v<T, OmniReading>) {
          latest.omni = data;
          latest.omni_t_s = record.reading.t_s;
        }
      },
      record.reading.data);
}

void FrameCapture::consume_truth(const Record& record) {
  if (record.type == Record::Type::kGroundTruth) {
    if (record.robot < 0 || static_cast<std::size_t>(record.robot) >= latest_.size()) return;
    if (!truth_known(record.pose)) return;  // a log without truth draws none
    const auto i = static_cast<std::size_t>(record.robot);
    Latest& latest = latest_[i];
    // No ground truth while a robot is carried: the first after a kidnap is where it landed.
    if (latest.carried) {
      for (KidnapMark& k : kidnaps_) {
        if (k.robot == i && !k.landed) k.to = record.pose, k.landed = true;
      }
    }
    latest.pose = latest.floor_pose = record.pose;
    latest.carried = false;
  } else if (record.type == Record::Type::kEvent && record.event.kind == "kidnap") {
    for (std::size_t i = 0; i < latest_.size(); ++i) {
      if (world_.robots[i].name != record.event.robot) continue;
      Latest& latest = latest_[i];
      ++latest.kidnaps;
      latest.carried = true;
      kidnaps_.push_back({i, record.event.t_s, latest.floor_pose, latest.floor_pose, false});
    }
  }
}

void FrameCapture::after_step(const Simulation& sim) {
  // Kidnaps from the simulation's count (an instant one is never seen carried): picked up at the
  // last pose on the floor, landed where put down.
  for (std::size_t i = 0; i < sim.robot_count(); ++i) {
    Latest& latest = latest_[i];
    const DiffDriveRobot& robot = sim.robot(i);
    const bool carried = robot.carried();
    const int kidnaps = sim.stats(i).kidnaps;
    if (kidnaps != latest.kidnaps) {
      kidnaps_.push_back({i, sim.time_s(), latest.floor_pose, robot.pose(), !carried});
    } else if (!carried && latest.carried) {
      for (KidnapMark& k : kidnaps_) {
        if (k.robot == i && !k.landed) k.to = robot.pose(), k.landed = true;
      }
    }
    latest.pose = robot.pose();
    latest.carried = carried;
    latest.kidnaps = kidnaps;
    if (!carried) latest.floor_pose = robot.pose();
  }
  emit_due(sim.time_s(), &sim);
}

void FrameCapture::advance(double t_s) {
  if (!stream_t_s_) {
    // A stream that starts late (an imported dataset's window) starts its video there, rather
    // than with a burst of frames of its first instant.
    next_frame_ = std::max(0L, static_cast<long>(std::ceil(t_s / frame_interval_s_ - 1e-9)));
  } else if (t_s > *stream_t_s_) {
    emit_due(*stream_t_s_, nullptr);
  }
  stream_t_s_ = t_s;
}

void FrameCapture::end_of_stream() {
  if (stream_t_s_) emit_due(*stream_t_s_, nullptr);
}

void FrameCapture::emit_due(double t_s, const Simulation* sim) {
  while (static_cast<double>(next_frame_) * frame_interval_s_ <= t_s + 1e-9) {
    FrameState frame = capture(t_s, sim);
    frame.t_s = static_cast<double>(next_frame_) * frame_interval_s_;
    sink_.frame(frame);
    ++next_frame_;
  }
}

FrameState FrameCapture::capture(const Simulation& sim) {
  return capture(sim.time_s(), &sim);
}

FrameState FrameCapture::capture(double t_s, const Simulation* sim) {
  FrameState frame;
  frame.t_s = t_s;
  frame.kidnaps = kidnaps_;
  for (std::size_t i = 0; i < latest_.size(); ++i) {
    const RobotDef& def = world_.robots[i];
    const Latest& latest = latest_[i];
    FrameRobot r;
    r.name = def.name;
    r.pose = sim != nullptr ? sim->robot(i).pose() : latest.pose;
    r.carried = sim != nullptr ? sim->robot(i).carried() : latest.carried;
    r.kidnaps = latest.kidnaps;
    r.height_m = def.height_m;
    r.footprint = def.footprint;
    r.odometry = latest.odometry;
    if (latest.laser && def.sensors.laser) {
      const LaserDef& laser = *def.sensors.laser;
      const Pose2& mount = laser.common.mount;
      const Vec2 origin = r.pose.transform(mount.position());
      r.laser_origin_m = origin;
      const int beams = static_cast<int>(latest.laser->ranges_m.size());
      for (int b = 0; b < beams; ++b) {
        const double angle = r.pose.theta + mount.theta + laser_beam_angle(b, beams, laser.fov_rad);
        const double range = latest.laser->ranges_m[static_cast<std::size_t>(b)];
        if (range >= laser.max_range_m) continue;  // max range means nothing was hit
        r.laser_hits_m.push_back(origin + range * Vec2(std::cos(angle), std::sin(angle)));
      }
    }
    if (latest.ultrasonic && def.sensors.ultrasonic) {
      const UltrasonicDef& us = *def.sensors.ultrasonic;
      for (const BeaconRange& range : latest.ultrasonic->ranges) {
        const BeaconDef* beacon = nullptr;
        for (const BeaconDef& b : world_.beacons) {
          if (b.id == range.beacon_id) beacon = &b;
        }
        if (beacon == nullptr || range.receiver < 0 ||
            static_cast<std::size_t>(range.receiver) >= us.receivers.size() ||
            range.truth_status == RangeStatus::kOutOfRange) {
          continue;
        }
        r.ultrasonic.push_back(
            {r.pose.transform(us.receivers[static_cast<std::size_t>(range.receiver)].position_m),
             beacon->position_m, range.truth_status == RangeStatus::kLineOfSight});
      }
    }
    if (def.sensors.ptz_camera) {
      const PtzCameraDef& ptz = *def.sensors.ptz_camera;
      const double pan = latest.ptz ? latest.ptz->pan_rad : 0.0;
      const double zoom = latest.ptz ? latest.ptz->zoom : ptz.zoom;
      FrameRobot::Camera camera;
      const Vec2 at = r.pose.transform(ptz.common.mount.position());
      camera.optical_axis = {at.x(), at.y(), r.pose.theta + ptz.common.mount.theta + pan};
      camera.hfov_rad = 2.0 * std::atan(std::tan(0.5 * ptz.hfov_rad) / zoom);
      camera.max_range_m = ptz.max_range_m;
      const double focal_px = 0.5 * ptz.width_px / std::tan(0.5 * ptz.hfov_rad) * zoom;
      camera.shot = {camera.optical_axis,
                     ptz.height_m,
                     latest.ptz ? latest.ptz->tilt_rad : ptz.tilt_rad,
                     focal_px,
                     ptz.width_px,
                     ptz.height_px};
      if (latest.ptz) {
        for (const Detection& d : latest.ptz->detections) {
          const double bearing = r.pose.theta + d.bearing_rad;
          camera.detections_m.push_back(r.pose.position() +
                                        d.range_m * Vec2(std::cos(bearing), std::sin(bearing)));
        }
      }
      r.camera = camera;
    }
    // The range-bearing sensor's and the omnidirectional camera's detections alike: a line from
    // the robot to where each puts its target.
    const auto sight = [&](const std::vector<Detection>& detections) {
      for (const Detection& d : detections) {
        const double bearing = r.pose.theta + d.bearing_rad;
        r.sightings.push_back(
            {r.pose.position() + d.range_m * Vec2(std::cos(bearing), std::sin(bearing)),
             d.target == DetectionTarget::kRobot});
      }
    };
    const bool range_bearing =
        def.sensors.range_bearing && def.sensors.range_bearing->common.enabled;
    const bool omni = def.sensors.omni_camera && def.sensors.omni_camera->common.enabled;
    r.range_bearing = range_bearing || omni;
    // A reading is drawn until the next is due. A simulated sensor reads at its rate, seeing
    // something or not; a dataset's (MRCLAM's) has readings only when it saw something, and one
    // from seconds ago drawn from where the robot is now would point anywhere.
    const auto fresh = [&](double read_t_s, const SensorCommon& common) {
      return t_s - read_t_s <= 1.0 / common.rate_hz + 1e-9;
    };
    if (latest.range_bearing && range_bearing &&
        fresh(latest.range_bearing_t_s, def.sensors.range_bearing->common)) {
      sight(latest.range_bearing->detections);
    }
    if (latest.omni && omni && fresh(latest.omni_t_s, def.sensors.omni_camera->common)) {
      sight(latest.omni->detections);
    }
    frame.robots.push_back(std::move(r));
  }
  // People and carts: only a simulation knows where they are.
  for (const Mover& mover : sim != nullptr ? sim->world().movers() : kNoMovers) {
    const b2Vec2 p = mover.body->GetPosition();
    frame.movers.push_back({{p.x, p.y, mover.body->GetAngle()},
                            mover.def.footprint,
                            mover.def.kind,
                            mover.def.height_m,
                            mover.def.name});
  }
  if (host_ != nullptr) {
    const std::vector<LocalizerSnapshot> snapshots = host_->snapshot(t_s);
    for (std::size_t k = 0; k < snapshots.size(); ++k) {
      const LocalizerInfo& info = host_->localizers()[k];
      const LocalizerSnapshot& s = snapshots[k];
      const FrameRobot& truth = frame.robots[info.robot];
      FrameLocalizer l;
      l.label = info.label;
      l.robot = info.robot;
      if (s.estimate) {
        l.estimate = Pose2{s.estimate->pose.x, s.estimate->pose.y, s.estimate->pose.theta};
        for (int c = 0; c < 9; ++c) l.covariance(c / 3, c % 3) = s.estimate->covariance[c];
        if (!truth.carried) {
          l.position_error_m =
              std::hypot(l.estimate->x - truth.pose.x, l.estimate->y - truth.pose.y);
          l.heading_error_rad = std::abs(wrap_angle(l.estimate->theta - truth.pose.theta));
        }
      }
      for (const locsim_pose2& p : s.particles) l.particles.push_back({p.x, p.y, p.theta});
      l.weights = s.weights;
      for (const locsim_mapped_landmark& m : s.landmark_map) {
        FrameLocalizer::MappedLandmark& mapped = l.landmark_map.emplace_back();
        mapped.position_m = {m.x, m.y};
        mapped.covariance << m.covariance[0], m.covariance[1], m.covariance[2], m.covariance[3];
      }
      l.failed = s.failed;
      frame.localizers.push_back(std::move(l));
    }
  }
  return frame;
}

}  // namespace locsim
