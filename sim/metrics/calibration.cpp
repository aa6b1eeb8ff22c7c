#include "sim/metrics/calibration.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <locsim/models.hpp>
#include <locsim/particles.hpp>
#include <map>
#include <numbers>
#include <numeric>
#include <set>
#include <string_view>
#include <utility>

#include "sim/common/errors.hpp"
#include "sim/common/format.hpp"
#include "sim/common/math.hpp"
#include "sim/common/minimize.hpp"
#include "sim/plugin_host/localizer_instance.hpp"
#include "sim/producers/log_source.hpp"
#include "sim/sensors/models.hpp"
#include "sim/sensors/scene_rays.hpp"
#include "sim/world/physics_world.hpp"

namespace locsim {

using json = nlohmann::ordered_json;

namespace {

// Truth and timing noise the models cannot represent, added to every fitted covariance so that
// a step with no motion has a finite likelihood: 10 micrometres, 10 microradians. Far below any
// odometry noise worth modelling, and below Vicon's millimetre (which the fits then count as
// odometry noise: conservative).
constexpr double kFloorVariance = 1e-10;

/// A robot's true path: samples in time order, broken where it was kidnapped or put down, or
/// where the samples stop for longer than a few sampling periods (carried, or a gap in the data).
class TruthTrack {
 public:
  void add(double t_s, const Pose2& pose) {
    t_.push_back(t_s);
    pose_.push_back(pose);
  }
  void cut(double t_s) { cuts_.push_back(t_s); }

  /// Marks the breaks; called once all samples are in.
  void finish() {
    std::vector<double> periods;
    for (std::size_t i = 1; i < t_.size(); ++i) periods.push_back(t_[i] - t_[i - 1]);
    double max_gap_s = std::numeric_limits<double>::infinity();
    if (!periods.empty()) {
      std::nth_element(periods.begin(), periods.begin() + periods.size() / 2, periods.end());
      median_period_s_ = periods[periods.size() / 2];
      max_gap_s = 5.0 * median_period_s_;
    }
    std::sort(cuts_.begin(), cuts_.end());
    breaks_.assign(t_.size(), 0);
    for (std::size_t i = 1; i < t_.size(); ++i) {
      const auto cut = std::upper_bound(cuts_.begin(), cuts_.end(), t_[i - 1]);
      const bool broken = t_[i] - t_[i - 1] > max_gap_s || (cut != cuts_.end() && *cut <= t_[i]);
      breaks_[i] = breaks_[i - 1] + (broken ? 1 : 0);
    }
  }
  bool empty() const { return t_.empty(); }
  std::size_t size() const { return t_.size(); }
  double time(std::size_t i) const { return t_[i]; }
  const Pose2& pose(std::size_t i) const { return pose_[i]; }
  /// True when samples i - 1 and i lie in one unbroken piece (after finish(); i >= 1).
  bool joined(std::size_t i) const { return breaks_[i] == breaks_[i - 1]; }
  /// The first and last sample's times (after finish(); not empty).
  std::pair<double, double> span() const { return {t_.front(), t_.back()}; }
  double median_period_s() const { return median_period_s_; }  // 0 before finish()

  /// The pose at t, interpolated between its neighbours; none outside the samples or in a break.
  std::optional<sdk::Pose> at(double t_s) const {
    const std::size_t i =
        static_cast<std::size_t>(std::lower_bound(t_.begin(), t_.end(), t_s) - t_.begin());
    if (i == t_.size()) return std::nullopt;
    if (t_[i] == t_s) return sdk::Pose(pose_[i].x, pose_[i].y, pose_[i].theta);
    if (i == 0 || breaks_[i] != breaks_[i - 1]) return std::nullopt;
    const double u = (t_s - t_[i - 1]) / (t_[i] - t_[i - 1]);
    const Pose2& a = pose_[i - 1];
    const Pose2& b = pose_[i];
    return sdk::Pose(a.x + u * (b.x - a.x), a.y + u * (b.y - a.y),
                     sdk::wrap(a.theta + u * sdk::wrap(b.theta - a.theta)));
  }
  /// True when [a, b] lies within one unbroken piece.
  bool continuous(double a_s, double b_s) const {
    const auto first = std::lower_bound(t_.begin(), t_.end(), a_s);
    const auto last = std::lower_bound(t_.begin(), t_.end(), b_s);
    if (first == t_.end() || last == t_.end()) return false;
    const std::size_t i = static_cast<std::size_t>(first - t_.begin());
    const std::size_t j = static_cast<std::size_t>(last - t_.begin());
    if (t_[i] != a_s && i == 0) return false;  // before the first sample
    return breaks_[j] == breaks_[t_[i] == a_s ? i : i - 1];
  }

 private:
  std::vector<double> t_;
  std::vector<Pose2> pose_;
  std::vector<double> cuts_;
  std::vector<std::size_t> breaks_;  // breaks between samples 0..i
  double median_period_s_ = 0.0;
};

/// The truth's velocity at t (along its heading [m/s], and its turn rate [rad/s]) by central
/// differences over +-h_s, and its pose there; none where the truth is not known on both sides.
std::optional<std::pair<double, double>> true_velocity(const TruthTrack& truth, double t_s,
                                                       double h_s, sdk::Pose& pose) {
  const auto before = truth.at(t_s - h_s), now = truth.at(t_s), after = truth.at(t_s + h_s);
  if (!before || !now || !after || !truth.continuous(t_s - h_s, t_s + h_s)) return std::nullopt;
  pose = *now;
  const double c = std::cos(pose(2)), s = std::sin(pose(2));
  return std::pair{
      (c * ((*after)(0) - (*before)(0)) + s * ((*after)(1) - (*before)(1))) / (2.0 * h_s),
      sdk::wrap((*after)(2) - (*before)(2)) / (2.0 * h_s)};
}

/// The half-width of those differences: at least one truth period, so that a coarse truth is
/// differenced across its samples rather than along one interpolated segment. [s]
double difference_half_width_s(const TruthTrack& truth) {
  return std::max(0.06, truth.median_period_s());
}

/// The truth collect_motion compares the odometry against: the true path or, given a command
/// response, the path the command would have traced (the truth run backwards through the
/// response: the pose dead_time_s later, moved on by each channel's time constant times its
/// velocity, so that an interval's increment is the integral of what the command must have
/// been; the gain is left to the odometry).
struct TruthView {
  const TruthTrack& track;
  const CommandResponseFit* response = nullptr;
  // The velocities that move the pose on are differences over +-this: wider than the fit's, as
  // the time constants multiply their noise (a Vicon heading's 0.5 deg over +-0.06 s, times
  // 0.2 s, would pass for 1 deg of odometry error per interval). [s]
  static constexpr double kAheadHalfWidthS = 0.12;
  double ahead_half_width_s() const {
    return std::max(kAheadHalfWidthS, difference_half_width_s(track));
  }

  std::optional<sdk::Pose> at(double t_s) const {
    if (response == nullptr) return track.at(t_s);
    sdk::Pose now;
    const auto velocity =
        true_velocity(track, t_s + response->dead_time_s, ahead_half_width_s(), now);
    if (!velocity) return std::nullopt;
    const double ahead_m = response->time_constant_v_s * velocity->first;
    return sdk::Pose(now(0) + ahead_m * std::cos(now(2)), now(1) + ahead_m * std::sin(now(2)),
                     sdk::wrap(now(2) + response->time_constant_omega_s * velocity->second));
  }
  bool continuous(double a_s, double b_s) const {
    if (response == nullptr) return track.continuous(a_s, b_s);
    const double h_s = ahead_half_width_s();
    return track.continuous(a_s + response->dead_time_s - h_s, b_s + response->dead_time_s + h_s);
  }
};

const std::vector<Detection>* detections_of(const ReadingData& data) {
  if (const auto* r = std::get_if<RangeBearingReading>(&data)) return &r->detections;
  if (const auto* r = std::get_if<PtzReading>(&data)) return &r->detections;
  if (const auto* r = std::get_if<OmniReading>(&data)) return &r->detections;
  return nullptr;
}

/// One perception-step interval: the odometry's increment and the truth's.
struct MotionSample {
  sdk::OdometryDelta measured;
  Eigen::Vector3d local_error;  // measured - true increment in the start's frame
  Eigen::Vector3d wheel_error;  // wheel-model prediction from the true start - true end
  Eigen::Matrix3d wheel_p_left, wheel_p_right;  // its covariance per unit k_left^2, k_right^2
  Eigen::Matrix3d wheel_p_cross;                // and per unit k_correlation k_left k_right
  double dt_s = 0.0;
  bool has_velocity = false;
  double v_mps = 0.0, omega_radps = 0.0;             // measured, time-weighted mean
  double true_v_mps = 0.0, true_omega_radps = 0.0;   // of the true increment
  double rolled_left_m = 0.0, rolled_right_m = 0.0;  // each wheel's travel, |d| summed
  std::size_t track = 0;                             // the robot (of a log) it is of
  double t_end_s = 0.0;                              // of the interval's last odometry reading
  sdk::Pose true_start = sdk::Pose::Zero(), true_end = sdk::Pose::Zero();  // world frame
};

struct Residual {
  double range_m = 0.0;      // true
  double bearing_rad = 0.0;  // true, from the robot's x axis
  double range_error_m = 0.0;
  double bearing_error_rad = 0.0;
  std::size_t landmark = 0;  // index in its world
  bool inlier = true;
  double t_s = 0.0;       // of its reading
  std::size_t track = 0;  // which robot of which log: one target's detections form a sequence
  double true_heading_rad = 0.0;  // the robot's, in the world
};

/// A reading of a camera with a field of view: what it should have seen and where its
/// detections' residuals are.
struct Visibility {
  std::size_t first = 0, count = 0;     // into CameraData::residuals
  std::vector<LandmarkInView> visible;  // what it should have seen
  std::size_t track = 0;
  bool empty = false;  // the reading reported nothing at all
};

struct CameraData {
  std::size_t readings = 0, detections = 0, unmatched = 0;
  std::vector<Residual> residuals;
  std::vector<Visibility> visibility;  // range_bearing only
  // Readings with detections of landmarks on the map (a particle filter's steps): their
  // residuals, [first, first + count).
  std::vector<std::pair<std::size_t, std::size_t>> steps;
  // The span of the measured values (of landmarks' detections), over which a false one falls.
  double min_range_m = std::numeric_limits<double>::infinity(), max_range_m = 0.0;
  double max_abs_bearing_rad = 0.0;
};

/// One range to a beacon against the true slant range from its receiver.
struct RangeSample {
  double true_m, error_m;  // measured - true [m]
  int beacon;
  double t_s;
  std::size_t track;
  bool inlier = true;
};

struct RangingData {
  std::vector<RangeSample> samples;
  std::size_t readings = 0, receiver_readings = 0;
  std::set<int> beacons;  // on the maps
  // Each robot's readings with a range to a beacon on the map, truth or not: their times [s].
  std::map<std::size_t, std::vector<double>> reading_times_s;  // by track
};

/// One laser beam against the range the map gives at the true pose (infinite: nothing mapped
/// within the maximum range).
struct BeamSample {
  float measured_m, mapped_m;
};

struct LaserData {
  std::vector<BeamSample> beams;
  std::size_t scans = 0;
  double max_range_m = 0.0;  // the first robot's; every laser's must be the same
};

/// A stretch of a robot's truth in cells of `cell_s`: each one's landmarks in view and whether any
/// landmark was detected in it.
struct CameraCells {
  double cell_s = 0.0;
  std::vector<std::pair<double, bool>> cells;
  std::vector<std::vector<double>> in_view_ranges_m;  // each cell's landmarks in view [m]

  /// The same cells with each landmark in view counted as its share e^(-r / decay_m) of a near
  /// one's chance of being detected.
  CameraCells weighted(double decay_m) const {
    CameraCells out = *this;
    for (std::size_t k = 0; k < cells.size(); ++k) {
      double in_view = 0.0;
      for (const double r : in_view_ranges_m[k]) in_view += std::exp(-r / decay_m);
      out.cells[k].first = in_view;
    }
    return out;
  }
};

struct Pooled {
  std::vector<MotionSample> motion;
  std::map<SensorKind, CameraData> cameras;
  RangingData ranging;
  LaserData laser;
  std::size_t tracks = 0;                 // robots collected so far
  std::vector<std::string> track_names;   // each track's robot
  std::vector<CameraCells> camera_cells;  // range_bearing only: per stretch of a robot's truth
};

struct RobotLog {
  RobotDef def;  // a copy: the fits run once every log has been read
  TruthTrack truth;
  std::vector<std::pair<double, locsim_odometry>> odometry;
  struct Seen {
    double t_s;
    SensorKind kind;
    std::vector<Detection> detections;
  };
  std::vector<Seen> seen;
  struct Round {
    double t_s;
    std::vector<BeaconRange> ranges;
  };
  std::vector<Round> rounds;  // ranges to beacons
  struct Scan {
    double t_s;
    std::vector<float> ranges_m;  // every `stride`-th beam of the scan, from the first
  };
  std::vector<Scan> scans;
  std::size_t scan_stride = 1;
  std::vector<double> steps;  // times of the perception steps (perception_steps)
};

/// The landmark a detection is of: its id's, else the nearest (to where the detection puts it,
/// seen from the true pose) of its colour; none when it is not on the map.
std::optional<std::size_t> landmark_of(const Detection& d, const WorldDef& world,
                                       const sdk::Pose& pose) {
  std::optional<std::size_t> best;
  double best_m2 = std::numeric_limits<double>::infinity();
  const double a = pose(2) + d.bearing_rad;
  const double px = pose(0) + d.range_m * std::cos(a), py = pose(1) + d.range_m * std::sin(a);
  for (std::size_t i = 0; i < world.landmarks.size(); ++i) {
    const LandmarkDef& l = world.landmarks[i];
    if (d.id >= 0 ? l.id != d.id : color_label(l) != d.color) continue;
    const double m2 = std::pow(l.position_m.x() - px, 2) + std::pow(l.position_m.y() - py, 2);
    if (m2 < best_m2) best_m2 = m2, best = i;
  }
  return best;
}

bool counts_as_step(const RobotLog::Seen& seen, const WorldDef& world) {
  for (const Detection& d : seen.detections) {
    if (d.target != DetectionTarget::kLandmark) continue;
    for (const LandmarkDef& l : world.landmarks) {
      if (d.id >= 0 ? l.id == d.id : color_label(l) == d.color) return true;
    }
  }
  return false;
}

/// The times of the readings with a detection of a landmark on the map (a landmark particle
/// filter's steps), increasing; without any, those of the readings with a range to a beacon on
/// the map (range-only data: a beacon filter's steps).
std::vector<double> perception_steps(const RobotLog& robot, const WorldDef& world) {
  std::vector<double> steps;
  for (const RobotLog::Seen& seen : robot.seen) {
    if (counts_as_step(seen, world) && (steps.empty() || seen.t_s > steps.back()))
      steps.push_back(seen.t_s);
  }
  if (!steps.empty()) return steps;
  for (const RobotLog::Round& round : robot.rounds) {
    const bool ranged = std::any_of(round.ranges.begin(), round.ranges.end(), [&](const auto& r) {
      return std::isfinite(r.range_m) &&
             std::any_of(world.beacons.begin(), world.beacons.end(),
                         [&](const BeaconDef& b) { return b.id == r.beacon_id; });
    });
    if (ranged && (steps.empty() || round.t_s > steps.back())) steps.push_back(round.t_s);
  }
  if (!steps.empty()) return steps;
  // A laser localizer's steps are its scans.
  for (const RobotLog::Scan& scan : robot.scans)
    if (steps.empty() || scan.t_s > steps.back()) steps.push_back(scan.t_s);
  return steps;
}

/// The odometry's increments between consecutive perception steps against the truth's;
/// `odometry` is the robot's, or what a model makes of it.
void collect_motion(const RobotLog& robot,
                    const std::vector<std::pair<double, locsim_odometry>>& odometry,
                    const TruthView& truth, std::vector<MotionSample>& out,
                    std::size_t stride = 1) {
  const std::vector<double>& steps = robot.steps;
  // The odometry a filter has at time t: the latest reading at or before it.
  const auto latest = [&](double t_s) -> std::optional<std::size_t> {
    const auto it = std::upper_bound(odometry.begin(), odometry.end(), t_s,
                                     [](double t, const auto& o) { return t < o.first; });
    if (it == odometry.begin()) return std::nullopt;
    return static_cast<std::size_t>(it - odometry.begin()) - 1;
  };
  const double wheel_base_m = believed_wheel_base_m(robot.def);  // what ekf_landmarks is told
  for (std::size_t k = stride; k < steps.size(); k += stride) {
    const auto ia = latest(steps[k - stride]), ib = latest(steps[k]);
    if (!ia || !ib || *ib <= *ia) continue;
    const double ta = odometry[*ia].first, tb = odometry[*ib].first;
    if (!truth.continuous(ta, tb)) continue;
    const auto true_a = truth.at(ta), true_b = truth.at(tb);
    if (!true_a || !true_b) continue;
    const auto pose_of = [](const locsim_odometry& o) {
      return sdk::Pose(o.odom_pose.x, o.odom_pose.y, o.odom_pose.theta);
    };
    MotionSample s;
    s.dt_s = tb - ta;
    s.t_end_s = tb;
    s.true_start = *true_a;
    s.true_end = *true_b;
    const sdk::Pose odom_a = pose_of(odometry[*ia].second), odom_b = pose_of(odometry[*ib].second);
    s.measured = sdk::decompose(odom_a, odom_b);
    s.local_error = sdk::between(odom_a, odom_b) - sdk::between(*true_a, *true_b);
    s.local_error(2) = sdk::wrap(s.local_error(2));
    // The wheel model: predicted from the true start through every odometry step, as
    // ekf_landmarks does; the covariance is linear in k_left^2 and k_right^2 (F does not depend
    // on them), so one prediction per wheel with k = 1 gives it for any k.
    sdk::OdometryTracker tracker(wheel_base_m);
    tracker.update(ta, odometry[*ia].second);
    sdk::Pose x = *true_a, x_right = *true_a, x_both = *true_a;
    s.wheel_p_left.setZero();
    s.wheel_p_right.setZero();
    Eigen::Matrix3d both = Eigen::Matrix3d::Zero();  // k 1 on both wheels, correlation 1
    double v_integral = 0.0, omega_integral = 0.0;
    s.has_velocity = (odometry[*ia].second.fields & LOCSIM_ODOMETRY_VELOCITY) != 0;
    for (std::size_t i = *ia + 1; i <= *ib; ++i) {
      const auto step = tracker.update(odometry[i].first, odometry[i].second);
      if (step) {
        sdk::predict_by_wheels(x, s.wheel_p_left, step->d_left_m, step->d_right_m, wheel_base_m,
                               1.0, 0.0);
        sdk::predict_by_wheels(x_right, s.wheel_p_right, step->d_left_m, step->d_right_m,
                               wheel_base_m, 0.0, 1.0);
        sdk::predict_by_wheels(x_both, both, step->d_left_m, step->d_right_m, wheel_base_m, 1.0,
                               1.0, 0.0, 1.0);
        s.rolled_left_m += std::abs(step->d_left_m);
        s.rolled_right_m += std::abs(step->d_right_m);
      }
      const locsim_odometry& held = odometry[i - 1].second;
      const double dt_s = odometry[i].first - odometry[i - 1].first;
      v_integral += held.v_mps * dt_s;
      omega_integral += held.omega_radps * dt_s;
      s.has_velocity = s.has_velocity && (held.fields & LOCSIM_ODOMETRY_VELOCITY) != 0;
    }
    // Linear in Q, F the same for all three: what the correlation adds.
    s.wheel_p_cross = both - s.wheel_p_left - s.wheel_p_right;
    s.wheel_error = x - *true_b;
    s.wheel_error(2) = sdk::wrap(s.wheel_error(2));
    if (s.has_velocity && s.dt_s > 0.0) {
      s.v_mps = v_integral / s.dt_s;
      s.omega_radps = omega_integral / s.dt_s;
      const sdk::Pose d = sdk::between(*true_a, *true_b);
      // The arc through the true increment: its chord and turn give v and omega.
      const double chord = std::hypot(d(0), d(1)) * (d(0) < 0.0 ? -1.0 : 1.0);
      s.true_omega_radps = d(2) / s.dt_s;
      s.true_v_mps = chord / sdk::sinc(0.5 * d(2)) / s.dt_s;
    }
    out.push_back(s);
  }
}

}  // namespace

std::vector<LandmarkInView> landmarks_in_view(const WorldDef& world, const StaticRaycaster& walls,
                                              const RangeBearingDef& sensor, const Pose2& pose) {
  std::vector<LandmarkInView> visible;
  const Vec2 origin = pose.transform(sensor.common.mount.position());
  const double heading = pose.theta + sensor.common.mount.theta;
  for (std::size_t i = 0; i < world.landmarks.size(); ++i) {
    const LandmarkDef& l = world.landmarks[i];
    const Vec2 offset = l.position_m - origin;
    const double range = offset.norm();
    if (range < sensor.min_range_m || range > sensor.max_range_m || range < 1e-6) continue;
    const double bearing = wrap_angle(std::atan2(offset.y(), offset.x()) - heading);
    if (std::abs(bearing) > 0.5 * sensor.fov_rad) continue;
    if (walls.cast(origin, offset / range, range - l.radius_m) < range - l.radius_m - 1e-6)
      continue;
    visible.push_back({i, range});
  }
  return visible;
}

namespace {

double median(std::vector<double> v);

/// The robot's true path in cells of CameraSilences::kFramesPerCell of its camera's frames (a
/// stretch ends where the truth does): the landmarks in view at each cell's middle, and whether
/// any landmark was detected in it. None with fewer than two readings with a detection.
void collect_camera_cells(const RobotLog& robot, const WorldDef& world,
                          const StaticRaycaster& walls, const RangeBearingDef& sensor,
                          std::vector<CameraCells>& out) {
  std::vector<double> detection_times;
  for (const RobotLog::Seen& seen : robot.seen) {
    if (seen.kind != SensorKind::kRangeBearing) continue;
    if (std::any_of(seen.detections.begin(), seen.detections.end(),
                    [](const Detection& d) { return d.target == DetectionTarget::kLandmark; }))
      detection_times.push_back(seen.t_s);
  }
  std::sort(detection_times.begin(), detection_times.end());
  detection_times.erase(std::unique(detection_times.begin(), detection_times.end()),
                        detection_times.end());
  if (detection_times.size() < 2) return;
  std::vector<double> intervals(detection_times.size() - 1);
  for (std::size_t k = 1; k < detection_times.size(); ++k)
    intervals[k - 1] = detection_times[k] - detection_times[k - 1];
  const double cell_s = CameraSilences::kFramesPerCell * median(intervals);
  if (!(cell_s > 0.0)) return;
  const auto [from_s, to_s] = robot.truth.span();
  CameraCells stretch{cell_s, {}, {}};
  const auto close = [&] {
    if (!stretch.cells.empty()) out.push_back(std::move(stretch));
    stretch = CameraCells{cell_s, {}, {}};
  };
  const auto cells = static_cast<std::size_t>(std::floor((to_s - from_s) / cell_s));
  for (std::size_t k = 0; k < cells; ++k) {
    const double t = from_s + static_cast<double>(k) * cell_s;
    const auto pose = robot.truth.at(t + 0.5 * cell_s);
    if (!pose || !robot.truth.continuous(t, t + cell_s)) {
      close();
      continue;
    }
    std::vector<double> ranges_m;
    for (const LandmarkInView& l :
         landmarks_in_view(world, walls, sensor, Pose2{(*pose)(0), (*pose)(1), (*pose)(2)}))
      ranges_m.push_back(l.range_m);
    const auto first = std::lower_bound(detection_times.begin(), detection_times.end(), t);
    stretch.cells.emplace_back(static_cast<double>(ranges_m.size()),
                               first != detection_times.end() && *first < t + cell_s);
    stretch.in_view_ranges_m.push_back(std::move(ranges_m));
  }
  close();
}

void collect_detections(const RobotLog& robot, const WorldDef& world, const StaticRaycaster& walls,
                        Pooled& pooled) {
  const std::optional<RangeBearingDef>& fov_sensor = robot.def.sensors.range_bearing;
  const std::size_t track = pooled.tracks++;
  pooled.track_names.push_back(robot.def.name);
  if (fov_sensor) collect_camera_cells(robot, world, walls, *fov_sensor, pooled.camera_cells);
  for (const RobotLog::Seen& seen : robot.seen) {
    const auto pose = robot.truth.at(seen.t_s);
    if (!pose) continue;
    CameraData& camera = pooled.cameras[seen.kind];
    ++camera.readings;
    Visibility visibility;
    visibility.first = camera.residuals.size();
    for (const Detection& d : seen.detections) {
      if (d.target != DetectionTarget::kLandmark) continue;
      ++camera.detections;
      camera.min_range_m = std::min(camera.min_range_m, d.range_m);
      camera.max_range_m = std::max(camera.max_range_m, d.range_m);
      camera.max_abs_bearing_rad = std::max(camera.max_abs_bearing_rad, std::abs(d.bearing_rad));
      const auto landmark = landmark_of(d, world, *pose);
      if (!landmark) {
        ++camera.unmatched;
        continue;
      }
      const LandmarkDef& l = world.landmarks[*landmark];
      const Eigen::Vector2d predicted =
          sdk::range_bearing(*pose, Eigen::Vector2d(l.position_m.x(), l.position_m.y()));
      camera.residuals.push_back({predicted(0), predicted(1), d.range_m - predicted(0),
                                  sdk::wrap(d.bearing_rad - predicted(1)), *landmark, true,
                                  seen.t_s, track, (*pose)(2)});
    }
    visibility.count = camera.residuals.size() - visibility.first;
    if (visibility.count > 0) camera.steps.emplace_back(visibility.first, visibility.count);
    if (seen.kind == SensorKind::kRangeBearing && fov_sensor) {
      visibility.track = track;
      visibility.empty = seen.detections.empty();
      visibility.visible =
          landmarks_in_view(world, walls, *fov_sensor, Pose2{(*pose)(0), (*pose)(1), (*pose)(2)});
      camera.visibility.push_back(std::move(visibility));
    }
  }
}

/// Each finite range to a beacon on the map, at a time with a true pose, against the true slant
/// range from its receiver (the true pose, the receiver's mount and height, the beacon's height).
void collect_ranges(const RobotLog& robot, const WorldDef& world, std::size_t track,
                    RangingData& data) {
  const std::optional<UltrasonicDef>& sensor = robot.def.sensors.ultrasonic;
  if (!sensor) return;
  for (const BeaconDef& b : world.beacons) data.beacons.insert(b.id);
  for (const RobotLog::Round& round : robot.rounds) {
    const bool ranged = std::any_of(round.ranges.begin(), round.ranges.end(), [&](const auto& r) {
      return std::isfinite(r.range_m) &&
             std::any_of(world.beacons.begin(), world.beacons.end(),
                         [&](const BeaconDef& b) { return b.id == r.beacon_id; });
    });
    if (ranged) data.reading_times_s[track].push_back(round.t_s);
    const auto pose = robot.truth.at(round.t_s);
    if (!pose) continue;
    ++data.readings;
    std::set<int> receivers;
    for (const BeaconRange& r : round.ranges) {
      const auto beacon = std::find_if(world.beacons.begin(), world.beacons.end(),
                                       [&](const BeaconDef& b) { return b.id == r.beacon_id; });
      if (!std::isfinite(r.range_m) || beacon == world.beacons.end() || r.receiver < 0 ||
          static_cast<std::size_t>(r.receiver) >= sensor->receivers.size())
        continue;
      const UltrasonicDef::Receiver& receiver =
          sensor->receivers[static_cast<std::size_t>(r.receiver)];
      const sdk::BeaconRangeModel model = sdk::beacon_range(
          *pose, Eigen::Vector2d(receiver.position_m.x(), receiver.position_m.y()),
          Eigen::Vector2d(beacon->position_m.x(), beacon->position_m.y()),
          beacon->height_m - receiver.height_m);
      data.samples.push_back(
          {model.range_m, r.range_m - model.range_m, r.beacon_id, round.t_s, track});
      receivers.insert(r.receiver);
    }
    data.receiver_readings += receivers.size();
  }
}

/// Each kept beam of each scan at a time with a true pose, against the range the static geometry
/// (walls, shapes, the map's cells) gives along it from the laser's true pose.
void collect_beams(const RobotLog& robot, const StaticRaycaster& walls, LaserData& data) {
  const std::optional<LaserDef>& laser = robot.def.sensors.laser;
  if (!laser || robot.scans.empty()) return;
  if (data.max_range_m == 0.0) data.max_range_m = laser->max_range_m;
  if (laser->max_range_m != data.max_range_m) {
    throw InputError("calibrate: robot '" + robot.def.name + "''s laser reaches " +
                     short_number(laser->max_range_m) + " m, another's " +
                     short_number(data.max_range_m) +
                     " m: calibrate lasers of one maximum range together");
  }
  for (const RobotLog::Scan& scan : robot.scans) {
    const auto pose = robot.truth.at(scan.t_s);
    if (!pose) continue;
    ++data.scans;
    const Pose2& m = laser->common.mount;
    const double c = std::cos((*pose)(2)), s = std::sin((*pose)(2));
    const Vec2 origin((*pose)(0) + c * m.x - s * m.y, (*pose)(1) + s * m.x + c * m.y);
    for (std::size_t k = 0; k < scan.ranges_m.size(); ++k) {
      const int beam = static_cast<int>(k * robot.scan_stride);
      const double angle =
          (*pose)(2) + m.theta + laser_beam_angle(beam, laser->beams, laser->fov_rad);
      const double mapped =
          walls.cast(origin, Vec2(std::cos(angle), std::sin(angle)), laser->max_range_m);
      data.beams.push_back({scan.ranges_m[k], static_cast<float>(mapped)});
    }
  }
}

// ---- fits ------------------------------------------------------------------------------------

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

/// Least squares line (a constant when x does not vary).
LineFit fit_line(const std::vector<double>& x, const std::vector<double>& y) {
  const double n = static_cast<double>(x.size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < x.size(); ++i)
    sx += x[i], sy += y[i], sxx += x[i] * x[i], sxy += x[i] * y[i];
  if (n == 0.0) return {};
  const double det = n * sxx - sx * sx;
  if (!(det > 1e-12 * n * sxx)) return {sy / n, 0.0};
  return {(sxx * sy - sx * sxy) / det, (n * sxy - sx * sy) / det};
}

/// The spread sigma(x) = a + b x (a, b >= 0) of zero-mean errors e at x, by maximum likelihood:
/// a line through binned standard deviations would be pulled by the bins' own widths.
LineFit fit_spread(const std::vector<double>& x, const std::vector<double>& e);

/// Bins of (about) equal counts of `order` (indices sorted by range).
std::vector<std::pair<std::size_t, std::size_t>> equal_bins(std::size_t n, std::size_t bins) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  bins = std::max<std::size_t>(1, std::min(bins, n / 50));
  for (std::size_t b = 0; b < bins && n > 0; ++b)
    out.emplace_back(b * n / bins, (b + 1) * n / bins);
  return out;
}

LineFit fit_spread(const std::vector<double>& x, const std::vector<double>& e) {
  double ee = 0.0;
  for (const double v : e) ee += v * v;
  const double rms = std::sqrt(ee / static_cast<double>(std::max<std::size_t>(1, e.size())));
  if (!(rms > 0.0)) return {};
  const auto nll = [&](const std::vector<double>& p) {
    const double a = rms * std::exp(std::clamp(p[0], -30.0, 5.0));
    const double b = rms * std::exp(std::clamp(p[1], -30.0, 5.0));
    double sum = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) {
      const double sigma = a + b * x[i];
      sum += std::log(sigma) + 0.5 * e[i] * e[i] / (sigma * sigma);
    }
    return sum / static_cast<double>(x.size());
  };
  // Scaled by the overall spread, so that the simplex starts where the answer is.
  const MinimizeResult best = minimize_restarted(nll, {-1.0, -2.0}, 1.0, 2000);
  return {rms * std::exp(std::clamp(best.x[0], -30.0, 5.0)),
          rms * std::exp(std::clamp(best.x[1], -30.0, 5.0))};
}

/// A residual in a range model: x (the true distance, or in depth the true depth r cos(bearing))
/// and the measured range minus x. The camera's axis is taken as the robot's x axis, as the
/// residuals are in the robot frame (what the filters see; MRCLAM's cameras look straight ahead).
struct InModel {
  double x_m, error_m;
};
InModel in_model(const Residual& r, bool depth) {
  if (!depth) return {r.range_m, r.range_error_m};
  const double x_m = r.range_m * std::cos(r.bearing_rad);
  return {x_m, r.range_m + r.range_error_m - x_m};
}

/// The depth model fitted to the inliers `kept`: as the distance model's lines (least squares
/// bias line, maximum-likelihood spread about it), in the true depth.
RangeModelFit fit_depth_model(const std::vector<Residual>& r,
                              const std::vector<std::size_t>& kept) {
  std::vector<double> x, e;
  for (const std::size_t i : kept) {
    const InModel m = in_model(r[i], true);
    x.push_back(m.x_m), e.push_back(m.error_m);
  }
  RangeModelFit fit;
  fit.bias_m = fit_line(x, e);
  double ee = 0.0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    e[k] -= fit.bias_m.at(x[k]);
    ee += e[k] * e[k];
  }
  fit.spread_m = fit_spread(x, e);
  fit.residual_rms_m = std::sqrt(ee / static_cast<double>(std::max<std::size_t>(1, x.size())));
  return fit;
}

/// What the landmark localizers are given for a camera (localizer_params): the chosen range
/// model's bias and the bearing's, taken out of each detection (sdk::DetectionBias), the spreads
/// about them (the range's in the model's distance or depth), and the noise correlation.
struct LocalizerNoise {
  sdk::DetectionBias bias;
  LineFit range_spread_m;
  double bearing_spread_rad = 0.0;
  double correlation_s = 0.0, slow_correlation_s = 0.0, slow_share = 0.0;
  // The bearing's own, when calibrate measured it apart from the range's.
  std::optional<DetectionCalibration::TwoCorrelations> bearing_correlation;
  sdk::CorrelatedRangeBearing correlated() const {
    const auto& b = bearing_correlation;
    return {sdk::CorrelatedDetections(correlation_s, slow_correlation_s, slow_share),
            b ? std::optional(sdk::CorrelatedDetections(b->fast_s, b->slow_s, b->slow_share))
              : std::nullopt};
  }
};
LocalizerNoise localizer_noise(const DetectionCalibration& c) {
  const bool depth = c.range_model == "depth" && c.depth_model;
  const LineFit& bias = depth ? c.depth_model->bias_m : c.range_bias_m;
  LocalizerNoise noise{sdk::DetectionBias{depth, bias.at_zero, bias.per_unit, c.bearing_bias_rad},
                       depth ? c.depth_model->spread_m : c.range_spread_m,
                       c.bearing_spread_rad,
                       c.noise_correlation_s.value_or(0.0),
                       0.0,
                       0.0,
                       std::nullopt};
  if (const auto& apart = c.channel_correlations) {
    noise.correlation_s = apart->range.fast_s;
    noise.slow_correlation_s = apart->range.slow_s;
    noise.slow_share = apart->range.slow_share;
    noise.bearing_correlation = apart->bearing;
  } else if (const auto& two = c.noise_correlation_two) {
    noise.correlation_s = two->fast_s;
    noise.slow_correlation_s = two->slow_s;
    noise.slow_share = two->slow_share;
  }
  return noise;
}

/// The motion noise the localizers are given (the parameter file's k_left, k_right,
/// motion_floor_*, gain_wander_*): beyond the command response where the odometry reports the
/// command and calibrate measured the response, else the odometry's own wheel model.
struct LocalizerMotion {
  double k_left = 0.0, k_right = 0.0;                      // [m^1/2]
  double floor_position_m = 0.0, floor_heading_rad = 0.0;  // per perception step
  const CommandResponseFit* command = nullptr;             // followed through its response
  // The gains' wander, when calibrate found any (sigma [-], tau [s]).
  std::optional<std::pair<CommandResponseFit::GainWander, CommandResponseFit::GainWander>> wander;
};
std::optional<LocalizerMotion> localizer_motion(const std::optional<MotionCalibration>& motion) {
  if (!motion) return std::nullopt;
  const auto& command = motion->command;
  if (command && command->leads && command->k_left && command->localizer) {
    const WheelModelFit& w = *command->localizer;
    LocalizerMotion m{w.k_left, w.k_right, w.floor_position_m, w.floor_heading_rad, &*command, {}};
    const auto& v = command->gain_wander_v;
    const auto& omega = command->gain_wander_omega;
    if (v && omega && (v->sigma > 0.0 || omega->sigma > 0.0)) m.wander = std::pair(*v, *omega);
    return m;
  }
  return LocalizerMotion{motion->k_left,
                         motion->k_right,
                         motion->k_floor_position_m,
                         motion->k_floor_heading_rad,
                         nullptr,
                         {}};
}

Eigen::Matrix3d floor_covariance(double position_m, double heading_rad);

/// How far a localizer that tracks a robot is from it, as a covariance along the robot's true
/// path over (x, y, theta, the gains' wander g_v, g_omega): grown by the localizers' motion noise
/// over each interval between perception steps (the wheel model, its floor, the gains' wander
/// moving the true displacement and turn), shrunk by each step's detections with the localizers'
/// noise, as the EKF with the calibrated parameters does; a particle filter's cloud spreads alike.
/// A localizer weighs a step's detections over that spread, not at the truth: after seconds of
/// coasting its cloud explains them worse than the truth does, though it tracks.
class BeliefAlongTruth {
 public:
  using Matrix = Eigen::Matrix<double, 5, 5>;
  explicit BeliefAlongTruth(const LocalizerMotion& motion) : motion_(motion) { start(); }

  /// A new robot: the truth, its gains' wander at its stationary spread.
  void start() {
    p_.setZero();
    if (motion_.wander) {
      p_(3, 3) = std::pow(motion_.wander->first.sigma, 2);
      p_(4, 4) = std::pow(motion_.wander->second.sigma, 2);
    }
  }
  /// One interval of the robot's motion (its samples' wheel covariances per unit k^2).
  void move(const MotionSample& s) {
    const Eigen::Vector3d d(s.true_end(0) - s.true_start(0), s.true_end(1) - s.true_start(1),
                            sdk::wrap(s.true_end(2) - s.true_start(2)));
    Matrix f = Matrix::Identity();
    f(0, 2) = -d(1);
    f(1, 2) = d(0);
    f(0, 3) = d(0);  // a gain error scales the displacement and the turn
    f(1, 3) = d(1);
    f(2, 4) = d(2);
    Matrix q = Matrix::Zero();
    q.topLeftCorner<3, 3>() = motion_.k_left * motion_.k_left * s.wheel_p_left +
                              motion_.k_right * motion_.k_right * s.wheel_p_right +
                              floor_covariance(motion_.floor_position_m, motion_.floor_heading_rad);
    if (motion_.wander) {
      const auto& [v, omega] = *motion_.wander;
      const double phi = v.correlation_s > 0.0 ? std::exp(-s.dt_s / v.correlation_s) : 0.0;
      f(3, 3) = f(4, 4) = phi;
      q(3, 3) = v.sigma * v.sigma * (1.0 - phi * phi);
      q(4, 4) = omega.sigma * omega.sigma * (1.0 - phi * phi);
    }
    p_ = f * p_ * f.transpose() + q;
  }
  /// The log of a step's likelihood averaged over the belief (detections `errors` with their
  /// Jacobians `h` and noise `r`, stacked), Gaussian in the errors; then the step's update.
  double weigh_and_update(const Eigen::VectorXd& errors, const Eigen::MatrixXd& h,
                          const Eigen::VectorXd& r) {
    const Eigen::MatrixXd s = h * p_ * h.transpose() + Eigen::MatrixXd(r.asDiagonal());
    const Eigen::LLT<Eigen::MatrixXd> llt(s);
    if (llt.info() != Eigen::Success) return -std::numeric_limits<double>::infinity();
    const Eigen::VectorXd whitened = llt.matrixL().solve(errors);
    double log_det_s = 0.0;
    for (Eigen::Index i = 0; i < s.rows(); ++i) log_det_s += 2.0 * std::log(llt.matrixL()(i, i));
    // Scaled as the filters scale a match: 1 at a perfect one with the belief at the truth.
    const double log_likelihood =
        -0.5 * whitened.squaredNorm() + 0.5 * (r.array().log().sum() - log_det_s);
    const Eigen::MatrixXd ph = p_ * h.transpose();
    const Eigen::MatrixXd gain = llt.solve(ph.transpose()).transpose();
    const Matrix joseph = Matrix::Identity() - gain * h;
    p_ = joseph * p_ * joseph.transpose() + gain * r.asDiagonal() * gain.transpose();
    return log_likelihood;
  }
  const Matrix& covariance() const { return p_; }

 private:
  LocalizerMotion motion_;
  Matrix p_;
};

/// The landmark particle filters' outlier_likelihood: a detection is false with probability eps
/// (the false ones among all), and a false one falls anywhere in the measured span of ranges and
/// bearings. Its mixture with the match (scaled to 1 at a perfect match, a Gaussian of peak
/// density 1 / (2 pi sigma_r sigma_b)) adds eps / (1 - eps) times the uniform density over the
/// peak density to every detection's likelihood.
void outlier_likelihood(const CameraData& data, DetectionCalibration& c) {
  if (c.detections == 0 || !(data.max_range_m > data.min_range_m)) return;
  const double eps =
      std::min(static_cast<double>(c.false_detections) / static_cast<double>(c.detections), 0.5);
  if (eps <= 0.0) return;
  const double middle_m = 0.5 * (data.min_range_m + data.max_range_m);
  const LocalizerNoise noise = localizer_noise(c);
  const double sigma_range = std::max(noise.range_spread_m.at(middle_m), 1e-9);
  const double sigma_bearing = std::max(noise.bearing_spread_rad, 1e-9);
  const double bearing_span = std::max(2.0 * data.max_abs_bearing_rad, sigma_bearing);
  const double uniform = 1.0 / ((data.max_range_m - data.min_range_m) * bearing_span);
  const double peak = 1.0 / (2.0 * std::numbers::pi * sigma_range * sigma_bearing);
  c.outlier_likelihood = std::min(eps / (1.0 - eps) * uniform / peak, 1.0);
}

/// Consecutive errors of one target farther apart than this are unrelated at any time constant the
/// scans can find. [s]
constexpr double kMaxCorrelationGapS = 60.0;

/// Two standardised errors of one target a time dt apart: range (r) and bearing (b; 0 for a
/// sensor without one).
struct ErrorPair {
  double dt_s, r1, r2, b1, b2;
};

/// The time constant tau over which `pairs` decorrelate (jointly normal per channel with
/// correlation exp(-dt / tau); `channels` 2 for range and bearing, 1 for one of them, the other
/// zero in every pair), by maximum likelihood on a logarithmic grid 1 ms .. 1000 s (one
/// parameter; the likelihood is cheap). 0 (independent errors) unless the correlation explains
/// the pairs significantly better (likelihood ratio, chi-square with one degree of freedom at
/// 95 %: 3.84 / 2 nats). With it, the negative log-likelihood of the best tau (of independent
/// errors when none beats them).
struct TimeConstantFit {
  double tau_s = 0.0;
  double nll = 0.0;
};
TimeConstantFit single_time_constant(const std::vector<ErrorPair>& pairs, int channels) {
  const auto nll = [&](double tau_s) {
    double sum = 0.0;
    for (const ErrorPair& p : pairs) {
      const double rho = std::exp(-p.dt_s / tau_s);
      const double v = std::max(1.0 - rho * rho, 1e-12);
      sum += 0.5 * channels * std::log(v) + ((p.r2 - rho * p.r1) * (p.r2 - rho * p.r1) +
                                             (p.b2 - rho * p.b1) * (p.b2 - rho * p.b1)) /
                                                (2.0 * v);
    }
    return sum;
  };
  double independent = 0.0;
  for (const ErrorPair& p : pairs) independent += 0.5 * (p.r2 * p.r2 + p.b2 * p.b2);
  double best_tau = 0.0, best = independent;
  for (int k = 0; k <= 300; ++k) {
    const double tau_s = std::pow(10.0, -3.0 + 6.0 * k / 300.0);
    const double value = nll(tau_s);
    if (value < best) best = value, best_tau = tau_s;
  }
  return {independent - best > 1.92 ? best_tau : 0.0, best};
}

/// The pairs' correlation as one time constant, or two when they explain the pairs better
/// (CorrelatedDetections' slow part: a share w of the variance decorrelating over slow_s, the
/// rest over fast_s < slow_s), on a grid of four points a decade (the pairs' exp(-dt / tau)
/// computed once per tau) and w in steps of 0.05; two are kept over one when they explain the
/// pairs better by more than chi-square with two more degrees of freedom at 95 % (5.99 / 2
/// nats). `channels` as single_time_constant's.
struct CorrelationFit {
  TimeConstantFit single;
  std::optional<DetectionCalibration::TwoCorrelations> two;
  double nll() const { return two ? single.nll - two->gain_nats : single.nll; }
  DetectionCalibration::TwoCorrelations as_process() const {
    return two.value_or(DetectionCalibration::TwoCorrelations{single.tau_s, 0.0, 0.0, 0.0});
  }
};
CorrelationFit fit_correlation(const std::vector<ErrorPair>& pairs, int channels) {
  CorrelationFit fit{single_time_constant(pairs, channels), std::nullopt};
  if (fit.single.tau_s == 0.0) return fit;
  constexpr int kPerDecade = 4, kDecades = 6;  // 1 ms .. 1000 s
  std::vector<double> taus;
  std::vector<std::vector<double>> decay;  // [tau][pair]
  for (int k = 0; k <= kPerDecade * kDecades; ++k) {
    taus.push_back(std::pow(10.0, -3.0 + static_cast<double>(k) / kPerDecade));
    std::vector<double>& d = decay.emplace_back(pairs.size());
    for (std::size_t i = 0; i < pairs.size(); ++i) d[i] = std::exp(-pairs[i].dt_s / taus.back());
  }
  DetectionCalibration::TwoCorrelations two;
  double two_best = fit.single.nll;
  for (std::size_t f = 0; f < taus.size(); ++f) {
    for (std::size_t l = f + 1; l < taus.size(); ++l) {
      for (int step = 1; step < 20; ++step) {
        const double w = 0.05 * step;
        double sum = 0.0;
        for (std::size_t i = 0; i < pairs.size(); ++i) {
          const ErrorPair& p = pairs[i];
          const double rho = w * decay[l][i] + (1.0 - w) * decay[f][i];
          const double v = std::max(1.0 - rho * rho, 1e-12);
          sum += 0.5 * channels * std::log(v) + ((p.r2 - rho * p.r1) * (p.r2 - rho * p.r1) +
                                                 (p.b2 - rho * p.b1) * (p.b2 - rho * p.b1)) /
                                                    (2.0 * v);
        }
        if (sum < two_best) {
          two_best = sum;
          two = {taus[f], taus[l], w, 0.0};
        }
      }
    }
  }
  two.gain_nats = fit.single.nll - two_best;
  if (two.gain_nats > 2.996) fit.two = two;
  return fit;
}

/// The time constant tau of each target's noise, as the simulated sensor's noise_correlation_s
/// models it (a Gauss-Markov process per target): by maximum likelihood over consecutive inlier
/// detections of the same landmark by the same robot, their standardised range and bearing errors
/// z1, z2 a time dt apart being jointly normal with correlation exp(-dt / tau); then two time
/// constants (fit_correlation); then range and bearing each with their own, kept when they
/// explain the pairs better than one process for both.
void noise_correlation(const CameraData& data, DetectionCalibration& c) {
  std::vector<ErrorPair> pairs;
  std::map<std::pair<std::size_t, std::size_t>, std::size_t> last;  // (track, landmark) -> index
  const double sigma_b = std::max(c.bearing_spread_rad, 1e-9);
  // About the chosen range model, whose noise the sensor's process carries: about the other, the
  // model's error (which changes as slowly as the view) would pass for correlated noise.
  const bool depth = c.range_model == "depth";
  const LineFit& bias = depth ? c.depth_model->bias_m : c.range_bias_m;
  const LineFit& spread = depth ? c.depth_model->spread_m : c.range_spread_m;
  const auto z_range = [&](const Residual& x) {
    const InModel m = in_model(x, depth);
    return (m.error_m - bias.at(m.x_m)) / std::max(spread.at(m.x_m), 1e-9);
  };
  for (std::size_t i = 0; i < data.residuals.size(); ++i) {
    const Residual& x = data.residuals[i];
    if (!x.inlier) continue;
    const auto key = std::pair{x.track, x.landmark};
    if (const auto found = last.find(key); found != last.end()) {
      const Residual& p = data.residuals[found->second];
      const double dt = x.t_s - p.t_s;
      if (dt > 0.0 && dt <= kMaxCorrelationGapS) {
        pairs.push_back({dt, z_range(p), z_range(x),
                         (p.bearing_error_rad - c.bearing_bias_rad) / sigma_b,
                         (x.bearing_error_rad - c.bearing_bias_rad) / sigma_b});
      }
    }
    last[key] = i;
  }
  if (pairs.size() < 20) return;
  const CorrelationFit joint = fit_correlation(pairs, 2);
  c.noise_correlation_s = joint.single.tau_s;
  c.noise_correlation_pairs = pairs.size();
  c.noise_correlation_two = joint.two;

  // Each channel alone (the other zeroed); kept apart when that explains the pairs better than
  // the joint fit by more than the Bayesian information criterion asks for the parameters the
  // two processes have beyond the joint one (half of ln(pairs) nats each): with time constants
  // picked from a grid, the likelihood ratio's chi-square does not hold, and a camera whose
  // errors persist alike would too often be split into two near-equal processes.
  std::vector<ErrorPair> range_only = pairs, bearing_only = pairs;
  for (ErrorPair& p : range_only) p.b1 = p.b2 = 0.0;
  for (ErrorPair& p : bearing_only) p.r1 = p.r2 = 0.0;
  const CorrelationFit range = fit_correlation(range_only, 1);
  const CorrelationFit bearing = fit_correlation(bearing_only, 1);
  const auto parameters = [](const CorrelationFit& f) {
    return f.two ? 3 : f.single.tau_s > 0.0 ? 1 : 0;
  };
  const int more = parameters(range) + parameters(bearing) - parameters(joint);
  const double gain_nats = joint.nll() - range.nll() - bearing.nll();
  if (gain_nats > 0.5 * std::max(more, 0) * std::log(static_cast<double>(pairs.size()))) {
    c.channel_correlations = DetectionCalibration::ChannelCorrelations{
        range.as_process(), bearing.as_process(), gain_nats};
  }
}

/// The likelihood a landmark particle filter that tracks the robot gives each step (its own
/// match, sdk::landmark_log_match, with what it is given: each detection corrected by the
/// camera's bias, the spread about it, inflated for a landmark seen again while its errors
/// persist), averaged over its belief's spread about the true pose (BeliefAlongTruth, from the
/// localizers' motion noise `motion`; none: at the truth), and from its low quantile the
/// resetting levels: a reset is meant for a step that a tracking filter would explain worse than
/// it almost ever does. With calibrated noise a single detection's match is about uniform on
/// (0, 1] at the truth, so a fixed level of 0.1 resets on one step in ten; and a filter that has
/// coasted through seconds without detections explains the next ones worse than the truth would,
/// so levels measured at the truth reset it while it tracks (MRCLAM Dataset 6, robot 5: the
/// augmented MCL's own w_fast / w_slow has its 1 % quantile at 0.83, the truth's at 0.92).
void reset_levels(const CameraData& data, const std::vector<MotionSample>& motion,
                  const std::optional<LocalizerMotion>& localizer_motion, DetectionCalibration& c) {
  constexpr double kQuantile = 0.01;
  const LocalizerNoise noise = localizer_noise(c);
  const double outlier = c.outlier_likelihood.value_or(0.0);
  std::vector<double> step_likelihood, per_detection;
  std::vector<std::size_t> step_track;
  std::optional<sdk::CorrelatedRangeBearing> seen;  // of the current track
  BeliefAlongTruth belief(localizer_motion.value_or(LocalizerMotion{}));
  std::size_t next_motion = 0;  // motion is in track order, each track's in time order
  struct Detection {
    double range_error_m, bearing_error_rad, sigma_range_m, sigma_bearing_rad;
    const Residual* residual;
  };
  std::vector<Detection> step;
  for (const auto& [first, count] : data.steps) {
    const std::size_t track = data.residuals[first].track;
    const double t_s = data.residuals[first].t_s;
    if (step_track.empty() || step_track.back() != track) {
      seen.emplace(noise.correlated());
      belief.start();
    }
    step_track.push_back(track);
    for (; next_motion < motion.size(); ++next_motion) {
      const MotionSample& m = motion[next_motion];
      if (m.track > track || (m.track == track && m.t_end_s > t_s)) break;
      if (m.track == track && localizer_motion) belief.move(m);
    }
    step.clear();
    for (std::size_t i = first; i < first + count; ++i) {
      const Residual& r = data.residuals[i];
      locsim_detection target{};
      target.id = static_cast<std::int32_t>(r.landmark);
      const auto inflation = seen->inflation(0, target, r.t_s);
      const auto z =
          noise.bias.corrected(r.range_m + r.range_error_m, r.bearing_rad + r.bearing_error_rad);
      step.push_back({z.range_m - r.range_m, sdk::wrap(z.bearing_rad - r.bearing_rad),
                      std::sqrt(inflation.range) * z.range_scale *
                          std::max(noise.range_spread_m.at(z.model_x_m), 1e-9),
                      std::sqrt(inflation.bearing) * std::max(noise.bearing_spread_rad, 1e-9), &r});
    }
    // Each detection's Jacobian in the pose (the world frame) and its noise; the bearing's error
    // as 2 sin(e / 2), whose square over 2 sigma^2 is the filters' (1 - cos e) / sigma^2.
    const auto jacobian = [](const Residual& r) {
      const double a = r.true_heading_rad + r.bearing_rad;
      const Eigen::Vector2d d = r.range_m * Eigen::Vector2d(std::cos(a), std::sin(a));
      Eigen::Matrix<double, 2, 5> h = Eigen::Matrix<double, 2, 5>::Zero();
      h.row(0).head<2>() = -d / r.range_m;
      h.row(1).head<2>() = Eigen::Vector2d(d.y(), -d.x()) / (r.range_m * r.range_m);
      h(1, 2) = -1.0;
      return h;
    };
    const auto errors = [](const Detection& d) {
      return Eigen::Vector2d(d.range_error_m, 2.0 * std::sin(0.5 * d.bearing_error_rad));
    };
    const auto variances = [](const Detection& d) {
      return Eigen::Vector2d(d.sigma_range_m * d.sigma_range_m,
                             d.sigma_bearing_rad * d.sigma_bearing_rad);
    };
    // As the filters weigh a detection, false ones allowed (their outlier_likelihood): the
    // product over the detections of (match + outlier), taken as the belief's joint match of
    // those it explains better than a false one, times (1 + outlier / match) each, and (match +
    // outlier) for the others.
    double log_p = 0.0;
    std::vector<const Detection*> explained;
    for (const Detection& d : step) {
      const auto h = jacobian(*d.residual);
      const Eigen::Vector2d r = variances(d);
      const Eigen::Matrix2d s =
          h * belief.covariance() * h.transpose() + Eigen::Matrix2d(r.asDiagonal());
      const Eigen::Vector2d e = errors(d);
      const double match = -0.5 * e.dot(s.ldlt().solve(e)) +
                           0.5 * (std::log(r(0) * r(1)) - std::log(s.determinant()));
      if (std::exp(match) >= outlier) {
        explained.push_back(&d);
        log_p += std::log1p(outlier * std::exp(-match));
      } else {
        log_p += std::log(std::exp(match) + outlier);
      }
    }
    if (!explained.empty()) {
      const auto n = static_cast<Eigen::Index>(2 * explained.size());
      Eigen::VectorXd e(n), r(n);
      Eigen::MatrixXd h(n, 5);
      for (std::size_t k = 0; k < explained.size(); ++k) {
        const auto at = static_cast<Eigen::Index>(2 * k);
        e.segment<2>(at) = errors(*explained[k]);
        r.segment<2>(at) = variances(*explained[k]);
        h.middleRows<2>(at) = jacobian(*explained[k]->residual);
      }
      log_p += belief.weigh_and_update(e, h, r);
    }
    step_likelihood.push_back(std::exp(log_p));
    per_detection.push_back(std::exp(log_p / static_cast<double>(count)));
  }
  if (step_likelihood.size() < 10) return;
  const auto quantile = [](std::vector<double> v, double q) {
    const auto at = v.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
    std::nth_element(v.begin(), at, v.end());
    return *at;
  };
  c.reset_quantile = kQuantile;
  c.step_likelihood_median = quantile(step_likelihood, 0.5);
  // SRL resets below `threshold` (its p~); ASRL below mu p_t^(2m), p_t^2 per detection (mu 1).
  c.srl_threshold = std::clamp(quantile(step_likelihood, kQuantile), 1e-300, 1.0);
  c.asrl_p_t = std::clamp(std::sqrt(quantile(per_detection, kQuantile)), 1e-12, 1.0);
  // augmented_mcl injects 1 - w_fast / (level w_slow) of its particles: Thrun's averages of the
  // per-detection likelihood, run here on the tracking filter's, robot by robot. Real detections
  // explain the truth better for a while and worse for a while (their errors persist), so w_fast
  // dips below w_slow without any kidnapping; the level is the ratio's low quantile, under which a
  // tracking filter's own ratio almost never falls. Both averages start from the robot's mean
  // likelihood, where a tracking filter's w_slow settles: started from the first step's, the
  // quantile would depend on how well that one step happened to fit (w_slow takes a thousand
  // steps to forget it).
  std::vector<double> ratios;
  std::map<std::size_t, std::pair<double, std::size_t>> track_sum;
  for (std::size_t k = 0; k < per_detection.size(); ++k) {
    auto& [sum, n] = track_sum[step_track[k]];
    sum += per_detection[k];
    ++n;
  }
  double w_slow = 0.0, w_fast = 0.0;
  for (std::size_t k = 0; k < per_detection.size(); ++k) {
    const double w = per_detection[k];
    if (k == 0 || step_track[k] != step_track[k - 1]) {
      const auto& [sum, n] = track_sum.at(step_track[k]);
      w_slow = w_fast = sum / static_cast<double>(n);
    }
    w_slow += kAugmentedAlphaSlow * (w - w_slow);
    w_fast += kAugmentedAlphaFast * (w - w_fast);
    ratios.push_back(w_fast / std::max(w_slow, 1e-300));
  }
  c.augmented_injection_level = std::clamp(quantile(ratios, kQuantile), 1e-6, 1.0);
}

/// The Gauss-Newton normal equations (J'J, J'e) of the bearing errors of `residuals[indices]`
/// under bearing bias b and camera offset c, p = (b, c_x, c_y): e = error - (atan2(d - c) -
/// atan2(d) + b), d the landmark's true place in the robot frame.
std::pair<Eigen::Matrix3d, Eigen::Vector3d> camera_offset_normal(
    const std::vector<Residual>& residuals, const std::vector<std::size_t>& indices,
    const Eigen::Vector3d& p) {
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  Eigen::Vector3d g = Eigen::Vector3d::Zero();
  for (const std::size_t i : indices) {
    const Residual& r = residuals[i];
    const Eigen::Vector2d from_camera =
        r.range_m * Eigen::Vector2d(std::cos(r.bearing_rad), std::sin(r.bearing_rad)) - p.tail<2>();
    const double squared = from_camera.squaredNorm();
    if (squared < 1e-6) continue;
    const double predicted =
        sdk::wrap(std::atan2(from_camera.y(), from_camera.x()) - r.bearing_rad) + p(0);
    const double error = sdk::wrap(r.bearing_error_rad - predicted);
    const Eigen::Vector3d j(1.0, from_camera.y() / squared, -from_camera.x() / squared);
    h += j * j.transpose();
    g += j * error;
  }
  return {h, g};
}

/// The robot's own bearing bias b and camera offset c (forward, left of the believed mount) that
/// best explain the bearing errors of `residuals[indices]` (least squares, by Gauss-Newton from
/// c = 0); unset when the bearings do not determine them (all landmarks in one direction).
std::optional<Eigen::Vector3d> solve_camera_offset(const std::vector<Residual>& residuals,
                                                   const std::vector<std::size_t>& indices) {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();  // b, c_x, c_y
  for (int iteration = 0; iteration < 10; ++iteration) {
    const auto [h, g] = camera_offset_normal(residuals, indices, p);
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(h);
    // A design without spread in bearing or range over the range of landmarks: no offset.
    if (ldlt.info() != Eigen::Success || !(ldlt.rcond() > 1e-10)) return std::nullopt;
    const Eigen::Vector3d step = ldlt.solve(g);
    p += step;
    if (step.tail<2>().norm() < 1e-7 && std::abs(step(0)) < 1e-9) break;
  }
  return p;
}

/// Each robot's camera offset from its inlier detections' bearings (range_bearing), with a block
/// jackknife over kBlock_s blocks of each of its logs: the errors persist for tens of seconds, so
/// detections are far from independent and a least-squares interval would be far too narrow.
std::vector<CameraOffset> fit_camera_offsets(const std::vector<Residual>& residuals,
                                             const std::vector<std::string>& track_names) {
  constexpr std::size_t kMinDetections = 50;
  std::map<std::string, std::map<std::pair<std::size_t, long long>, std::vector<std::size_t>>>
      blocks;  // robot -> (track, block) -> residuals
  for (std::size_t i = 0; i < residuals.size(); ++i) {
    const Residual& r = residuals[i];
    if (!r.inlier || r.track >= track_names.size()) continue;
    blocks[track_names[r.track]]
          [{r.track, static_cast<long long>(std::floor(r.t_s / CameraOffset::kBlock_s))}]
              .push_back(i);
  }
  std::vector<CameraOffset> out;
  for (const auto& [robot, of_robot] : blocks) {
    std::vector<std::size_t> all;
    for (const auto& [block, indices] : of_robot)
      all.insert(all.end(), indices.begin(), indices.end());
    if (all.size() < kMinDetections) continue;
    const auto fit = solve_camera_offset(residuals, all);
    if (!fit) continue;
    CameraOffset o;
    o.robot = robot;
    o.detections = all.size();
    o.blocks = of_robot.size();
    o.bearing_bias_rad = (*fit)(0);
    o.x_m = (*fit)(1);
    o.y_m = (*fit)(2);
    // Each block left out by one Gauss-Newton step from the whole fit (at which the blocks'
    // gradients sum to zero): the jackknife's values without refitting every block's complement.
    std::vector<std::pair<Eigen::Matrix3d, Eigen::Vector3d>> normals;
    Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
    for (const auto& [block, indices] : of_robot) {
      normals.push_back(camera_offset_normal(residuals, indices, *fit));
      h += normals.back().first;
    }
    std::vector<Eigen::Vector2d> left_out;
    for (const auto& [h_block, g_block] : normals) {
      const Eigen::LDLT<Eigen::Matrix3d> rest(h - h_block);
      if (rest.info() != Eigen::Success || !(rest.rcond() > 1e-10)) continue;
      left_out.push_back((*fit - rest.solve(g_block)).tail<2>());
    }
    if (left_out.size() >= 2) {
      Eigen::Vector2d mean = Eigen::Vector2d::Zero();
      for (const Eigen::Vector2d& v : left_out) mean += v;
      mean /= static_cast<double>(left_out.size());
      Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
      for (const Eigen::Vector2d& v : left_out) cov += (v - mean) * (v - mean).transpose();
      const double k = static_cast<double>(left_out.size());
      cov *= (k - 1.0) / k;
      o.sd_x_m = std::sqrt(cov(0, 0));
      o.sd_y_m = std::sqrt(cov(1, 1));
      if (o.sd_x_m > 0.0 && o.sd_y_m > 0.0) o.correlation = cov(0, 1) / (o.sd_x_m * o.sd_y_m);
      const Eigen::Vector2d c(o.x_m, o.y_m);
      const Eigen::LDLT<Eigen::Matrix2d> ldlt(cov);
      if (ldlt.info() == Eigen::Success && ldlt.rcond() > 1e-12) o.wald = c.dot(ldlt.solve(c));
      o.significant = left_out.size() >= CameraOffset::kMinBlocks && o.wald > CameraOffset::kWald;
    }
    out.push_back(std::move(o));
  }
  return out;
}

/// The bearings' bias and spread over the inliers `kept`, those of the robots whose camera offset
/// is significant taken from where their cameras are; unset when none is.
std::optional<CameraPlaceNoise> bearings_from_camera_places(
    const std::vector<CameraOffset>& offsets, const std::vector<std::string>& track_names,
    const std::vector<Residual>& residuals, const std::vector<std::size_t>& kept) {
  std::map<std::string, Eigen::Vector2d> places;
  for (const CameraOffset& o : offsets)
    if (o.significant) places[o.robot] = Eigen::Vector2d(o.x_m, o.y_m);
  if (places.empty() || kept.empty()) return std::nullopt;
  double sum = 0.0, squares = 0.0;
  for (const std::size_t i : kept) {
    const Residual& r = residuals[i];
    double error = r.bearing_error_rad;
    const auto place =
        r.track < track_names.size() ? places.find(track_names[r.track]) : places.end();
    if (place != places.end()) {
      const Eigen::Vector2d from_camera =
          r.range_m * Eigen::Vector2d(std::cos(r.bearing_rad), std::sin(r.bearing_rad)) -
          place->second;
      error = sdk::wrap(r.bearing_rad + r.bearing_error_rad -
                        std::atan2(from_camera.y(), from_camera.x()));
    }
    sum += error, squares += error * error;
  }
  const double n = static_cast<double>(kept.size());
  CameraPlaceNoise out;
  out.bearing_bias_rad = sum / n;
  out.bearing_spread_rad =
      std::sqrt(std::max(0.0, squares / n - out.bearing_bias_rad * out.bearing_bias_rad) *
                (n > 1 ? n / (n - 1) : 1.0));
  return out;
}

/// How a camera goes blind (the sensor's outage_* keys): `fraction` of the time, in spells of
/// `mean_s` on average, `long_share` of them of `long_mean_s`.
struct Spells {
  double fraction = 0.0, mean_s = 1.0, long_share = 0.0, long_mean_s = 1.0;
  double spell_mean_s() const { return (1.0 - long_share) * mean_s + long_share * long_mean_s; }
};

/// Minus the log-likelihood of the cells under a camera that detects each landmark in view at
/// `rate_hz` while seeing and goes blind as `spells` says (fraction 0: never): the forward
/// algorithm over three states (seeing, in a short spell, in a long one), each stretch starting
/// from the stationary distribution.
double silences_nll(const std::vector<CameraCells>& stretches, double rate_hz,
                    const Spells& spells) {
  const double f = spells.fraction, q = spells.long_share;
  const double spell_mean_s = spells.spell_mean_s();
  double nll = 0.0, scale = 1.0;
  for (const CameraCells& stretch : stretches) {
    const double cell_s = stretch.cell_s;
    const double to_blind =
        f > 0.0 ? 1.0 - std::exp(-cell_s * f / ((1.0 - f) * spell_mean_s)) : 0.0;
    const double short_ends = 1.0 - std::exp(-cell_s / spells.mean_s);
    const double long_ends = 1.0 - std::exp(-cell_s / spells.long_mean_s);
    // Stationary: the silent time split by the time each kind takes.
    double seeing = 1.0 - f;
    double in_short = f * (1.0 - q) * spells.mean_s / spell_mean_s;
    double in_long = f * q * spells.long_mean_s / spell_mean_s;
    bool first = true;
    for (const auto& [in_view, detected] : stretch.cells) {
      if (!first) {
        const double blinds = seeing * to_blind;
        const double next_seeing = seeing - blinds + in_short * short_ends + in_long * long_ends;
        in_short = in_short * (1.0 - short_ends) + blinds * (1.0 - q);
        in_long = in_long * (1.0 - long_ends) + blinds * q;
        seeing = next_seeing;
      }
      first = false;
      // Nothing in view says nothing about the camera (a detection then is of a landmark the
      // field of view's model leaves out).
      if (!(in_view > 0.0)) continue;
      const double p_detect = 1.0 - std::exp(-rate_hz * in_view * cell_s);
      seeing *= detected ? p_detect : 1.0 - p_detect;
      if (detected) in_short = in_long = 0.0;
      const double total = seeing + in_short + in_long;
      if (!(total > 1e-300)) return 1e300;
      // The cells' probabilities multiplied up, their logarithm taken only before the product
      // could underflow: a logarithm per cell is most of the fit's time.
      scale *= total;
      if (scale < 1e-200) {
        nll -= std::log(scale);
        scale = 1.0;
      }
      seeing /= total;
      in_short /= total;
      in_long /= total;
    }
  }
  return nll - std::log(scale);
}

/// The camera's spells of blindness (CameraSilences), unset without cells with a landmark in view:
/// none, one kind of spell, or two, each kept over the simpler by the Bayesian information
/// criterion (half of ln(cells) nats per parameter more).
std::optional<CameraSilences> fit_camera_silences(const std::vector<CameraCells>& stretches) {
  CameraSilences out;
  double exposure = 0.0, detected = 0.0, seconds = 0.0;
  double min_cell_s = std::numeric_limits<double>::infinity();
  for (const CameraCells& stretch : stretches) {
    min_cell_s = std::min(min_cell_s, stretch.cell_s);
    for (const auto& [in_view, seen] : stretch.cells) {
      if (!(in_view > 0.0)) continue;
      ++out.cells;
      exposure += in_view * stretch.cell_s;
      seconds += stretch.cell_s;
      detected += seen ? 1.0 : 0.0;
    }
  }
  if (out.cells < 10 || detected < 1.0) return std::nullopt;
  out.cell_s = seconds / static_cast<double>(out.cells);
  const double start_rate = detected / exposure;
  constexpr double kLarge = 1e300;
  const double two_parameters = std::log(static_cast<double>(out.cells));
  const MinimizeResult never = minimize_restarted(
      [&](const std::vector<double>& x) {
        return std::abs(x[0]) > 30.0 ? kLarge
                                     : silences_nll(stretches, start_rate * std::exp(x[0]), {});
      },
      {0.0}, 1.0, 500);
  out.rate_hz = start_rate * std::exp(never.x[0]);
  const Range& fraction_range = SensorCommon::kOutageFractionRange;
  const Range& mean_range = SensorCommon::kOutageMeanRange;
  // x: log rate (over the start), logit fraction, log mean; then logit long share, log of the long
  // mean's excess ratio over the short one.
  const auto spells_of = [&](const std::vector<double>& x) {
    Spells s;
    s.fraction = 1.0 / (1.0 + std::exp(-x[1]));
    s.mean_s = std::exp(x[2]);
    if (x.size() > 3) {
      s.long_share = 1.0 / (1.0 + std::exp(-x[3]));
      s.long_mean_s = s.mean_s * (1.0 + std::exp(x[4]));
    }
    return s;
  };
  const auto nll = [&](const std::vector<double>& x) {
    const Spells s = spells_of(x);
    if (std::abs(x[0]) > 30.0 || !(s.fraction > 1e-6) || s.fraction > fraction_range.max ||
        s.mean_s < min_cell_s || s.mean_s > mean_range.max || s.long_mean_s > mean_range.max ||
        s.long_share > SensorCommon::kOutageLongShareRange.max)
      return kLarge;
    return silences_nll(stretches, start_rate * std::exp(x[0]), s);
  };
  const MinimizeResult one = minimize_restarted(nll, {never.x[0], -2.0, std::log(10.0)}, 1.0, 3000);
  out.gain_nats = never.value - one.value;
  out.significant = out.gain_nats > two_parameters;
  if (!out.significant) return out;
  const Spells one_kind = spells_of(one.x);
  out.rate_hz = start_rate * std::exp(one.x[0]);
  // Two kinds, from one kind's fit with a few long spells ten times as long.
  const MinimizeResult two =
      minimize_restarted(nll, {one.x[0], one.x[1], one.x[2] - 0.5, -2.0, std::log(9.0)}, 1.0, 6000);
  out.long_gain_nats = one.value - two.value;
  Spells seen = one_kind;
  if (out.long_gain_nats > two_parameters) {
    seen = spells_of(two.x);
    out.rate_hz = start_rate * std::exp(two.x[0]);
  }
  // The cells see a spell only where it covers a whole one: each spell is seen a cell shorter
  // than it is, and one shorter than a cell not at all. Exponential spells seen so keep their
  // mean (they are memoryless) but are fewer by exp(-cell / mean): the fraction and the share of
  // long spells are taken back to the spells' own (on simulated cameras the fraction seen is 0.88
  // of the true one for 3 s spells in 0.4 s cells, and the long share 1.2 times it).
  const double short_per_s = seen.fraction * (1.0 - seen.long_share) / seen.spell_mean_s() *
                             std::exp(std::min(out.cell_s / seen.mean_s, 10.0));
  const double long_per_s = seen.fraction * seen.long_share / seen.spell_mean_s() *
                            std::exp(std::min(out.cell_s / seen.long_mean_s, 10.0));
  out.fraction =
      std::min(short_per_s * seen.mean_s + long_per_s * seen.long_mean_s, fraction_range.max);
  out.mean_s = seen.mean_s;
  if (seen.long_share > 0.0) {
    out.long_share = long_per_s / (short_per_s + long_per_s);
    out.long_mean_s = seen.long_mean_s;
  }
  return out;
}

/// How the chance of detecting a landmark in view falls with its range: p(r) = e^(a - lambda r),
/// by maximum likelihood over every reading and landmark in view (Nelder-Mead over a and
/// lambda). A camera's blind spells blind it at every range, so they scale p and leave the decay
/// alone. A robot whose log holds only readings with a detection (none empty: MRCLAM logs a frame
/// only when it has one) has its readings with a detected landmark weighed given that at least
/// one was: counted as if the others were, its chance comes out high where few are in view.
/// Kept when it beats a constant chance by more than BIC asks for one parameter, and the chance
/// falls with range.
std::optional<DetectionCalibration::DetectionDecay> fit_detection_decay(const CameraData& data) {
  struct Reading {
    std::size_t first = 0, count = 0;  // into range_m and detected
    bool conditioned = false;
  };
  std::set<std::size_t> reports_empty;  // tracks with a reading that reported nothing
  for (const Visibility& v : data.visibility)
    if (v.empty) reports_empty.insert(v.track);
  std::vector<double> range_m;
  std::vector<char> detected;
  std::vector<Reading> readings;
  bool conditioned = false;
  for (const Visibility& v : data.visibility) {
    if (v.visible.empty()) continue;
    std::set<std::size_t> seen;
    for (std::size_t i = v.first; i < v.first + v.count; ++i)
      if (data.residuals[i].inlier) seen.insert(data.residuals[i].landmark);
    Reading reading{range_m.size(), v.visible.size(), false};
    bool any = false;
    for (const LandmarkInView& l : v.visible) {
      range_m.push_back(l.range_m);
      detected.push_back(seen.count(l.index) > 0 ? 1 : 0);
      any = any || detected.back() != 0;
    }
    // Logged for a detection of something else (a false one): no condition on what is in view.
    reading.conditioned = any && reports_empty.count(v.track) == 0;
    conditioned = conditioned || reading.conditioned;
    readings.push_back(reading);
  }
  if (range_m.size() < 100) return std::nullopt;
  constexpr double kLarge = 1e300;
  const auto nll = [&](double a, double lambda) {
    double total = 0.0;
    for (const Reading& g : readings) {
      double log_none = 0.0;  // log P(none of them detected)
      for (std::size_t k = g.first; k < g.first + g.count; ++k) {
        const double log_p = a - lambda * range_m[k];
        if (!(log_p < 0.0)) return kLarge;  // a chance stays below 1
        const double log_q = std::log1p(-std::exp(log_p));
        total -= detected[k] != 0 ? log_p : log_q;
        log_none += log_q;
      }
      if (g.conditioned) {
        const double any = -std::expm1(log_none);
        if (!(any > 0.0)) return kLarge;
        total += std::log(any);
      }
    }
    return total;
  };
  std::size_t hits = 0;
  for (const char d : detected) hits += d != 0 ? 1 : 0;
  if (hits == 0 || hits == detected.size()) return std::nullopt;
  const double a0 = std::log(static_cast<double>(hits) / static_cast<double>(detected.size()));
  const MinimizeResult constant = minimize_restarted(
      [&](const std::vector<double>& x) { return nll(x[0], 0.0); }, {a0}, 0.2, 500);
  const MinimizeResult decay =
      minimize_restarted([&](const std::vector<double>& x) { return nll(x[0], x[1]); },
                         {constant.x[0], 0.0}, 0.2, 2000);
  const double gain_nats = constant.value - decay.value;
  const double lambda = decay.x[1];
  if (!(lambda > 0.0) || !(gain_nats > 0.5 * std::log(static_cast<double>(range_m.size()))))
    return std::nullopt;
  return DetectionCalibration::DetectionDecay{1.0 - std::exp(decay.x[0]), 1.0 / lambda, gain_nats,
                                              conditioned};
}

DetectionCalibration fit_camera(SensorKind kind, CameraData& data,
                                const CalibrationOptions& options,
                                const std::vector<std::string>& track_names,
                                const std::vector<CameraCells>& camera_cells,
                                const std::vector<MotionSample>& motion,
                                const std::optional<LocalizerMotion>& localizer_motion) {
  DetectionCalibration c;
  c.camera = sensor_name(kind);
  c.readings = data.readings;
  c.detections = data.detections;
  std::vector<Residual>& r = data.residuals;
  std::vector<std::size_t> order(r.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return r[a].range_m < r[b].range_m; });
  // Outliers against robust statistics per range bin (the spread grows with range).
  for (const auto& [begin, end] : equal_bins(order.size(), options.range_bins)) {
    std::vector<double> er, eb;
    for (std::size_t i = begin; i < end; ++i)
      er.push_back(r[order[i]].range_error_m), eb.push_back(r[order[i]].bearing_error_rad);
    const double mr = median(er), mb = median(eb);
    for (double& e : er) e = std::abs(e - mr);
    for (double& e : eb) e = std::abs(e - mb);
    const double sr = std::max(1.4826 * median(er), 1e-9);
    const double sb = std::max(1.4826 * median(eb), 1e-9);
    for (std::size_t i = begin; i < end; ++i) {
      Residual& x = r[order[i]];
      x.inlier = std::abs(x.range_error_m - mr) <= options.outlier_sigmas * sr &&
                 std::abs(x.bearing_error_rad - mb) <= options.outlier_sigmas * sb;
    }
  }
  std::vector<std::size_t> kept;
  for (const std::size_t i : order)
    if (r[i].inlier) kept.push_back(i);
  c.inliers = kept.size();
  c.false_detections = data.unmatched + (r.size() - kept.size());
  c.false_per_reading = data.readings > 0 ? static_cast<double>(c.false_detections) /
                                                static_cast<double>(data.readings)
                                          : 0.0;
  if (kept.empty()) return c;
  {
    std::vector<double> x, y;
    double sb = 0, sbb = 0;
    for (const std::size_t i : kept) {
      x.push_back(r[i].range_m), y.push_back(r[i].range_error_m);
      sb += r[i].bearing_error_rad, sbb += r[i].bearing_error_rad * r[i].bearing_error_rad;
    }
    c.range_bias_m = fit_line(x, y);
    const double n = static_cast<double>(kept.size());
    c.bearing_bias_rad = sb / n;
    c.bearing_rms_rad = std::sqrt(sbb / n);
    c.bearing_spread_rad =
        std::sqrt(std::max(0.0, sbb / n - c.bearing_bias_rad * c.bearing_bias_rad) *
                  (n > 1 ? n / (n - 1) : 1.0));
  }
  for (const auto& [begin, end] : equal_bins(kept.size(), options.range_bins)) {
    RangeBin bin;
    bin.count = end - begin;
    const double n = static_cast<double>(bin.count);
    double s = 0, e = 0, ee = 0, d2 = 0, b = 0, bb = 0;
    for (std::size_t k = begin; k < end; ++k) {
      const Residual& x = r[kept[k]];
      const double about_bias = x.range_error_m - c.range_bias_m.at(x.range_m);
      s += x.range_m, e += x.range_error_m, ee += x.range_error_m * x.range_error_m;
      d2 += about_bias * about_bias, b += x.bearing_error_rad;
      bb += x.bearing_error_rad * x.bearing_error_rad;
    }
    const double dof = n > 1 ? n / (n - 1) : 1.0;
    bin.range_m = s / n;
    bin.range_error_mean_m = e / n;
    bin.range_error_std_m = std::sqrt(d2 / n * dof);
    bin.range_error_rms_m = std::sqrt(ee / n);
    bin.bearing_error_mean_rad = b / n;
    bin.bearing_error_std_rad = std::sqrt(std::max(0.0, bb / n - (b / n) * (b / n)) * dof);
    c.bins.push_back(bin);
  }
  {
    std::vector<double> x, about_bias, about_zero;
    for (const std::size_t i : kept) {
      x.push_back(r[i].range_m);
      about_bias.push_back(r[i].range_error_m - c.range_bias_m.at(r[i].range_m));
      about_zero.push_back(r[i].range_error_m);
    }
    c.range_spread_m = fit_spread(x, about_bias);
    c.range_rms_m = fit_spread(x, about_zero);
    if (kind == SensorKind::kRangeBearing) {
      double ee = 0.0;
      for (const double e : about_bias) ee += e * e;
      c.distance_model = RangeModelFit{c.range_bias_m, c.range_spread_m,
                                       std::sqrt(ee / static_cast<double>(about_bias.size()))};
      c.depth_model = fit_depth_model(r, kept);
      // Both are two-parameter lines through the same measured ranges, so neither fits noise
      // better by having more freedom. Where the bearings are small the two models are nearly
      // the same and their residuals differ by chance; depth (the less common camera) is
      // chosen only when it leaves clearly less: under 0.8 of distance's variance
      // (on MRCLAM's cameras it leaves about 0.12: docs/reports/sim_to_real/measurements.md).
      constexpr double kDepthVarianceRatio = 0.8;
      const double distance_variance = std::pow(c.distance_model->residual_rms_m, 2);
      const double depth_variance = std::pow(c.depth_model->residual_rms_m, 2);
      if (depth_variance < kDepthVarianceRatio * distance_variance) c.range_model = "depth";
    }
  }
  if (kind == SensorKind::kRangeBearing) {
    c.camera_offsets = fit_camera_offsets(r, track_names);
    c.from_camera_places = bearings_from_camera_places(c.camera_offsets, track_names, r, kept);
    // The seeing camera's detections fall with range as the decay says, where it has one: a
    // cell with only far landmarks in view and nothing detected is then less of a blind cell.
    c.detection_decay = fit_detection_decay(data);
    if (c.detection_decay) {
      std::vector<CameraCells> weighted;
      for (const CameraCells& stretch : camera_cells)
        weighted.push_back(stretch.weighted(c.detection_decay->decay_m));
      c.silences = fit_camera_silences(weighted);
    } else {
      c.silences = fit_camera_silences(camera_cells);
    }
  }
  outlier_likelihood(data, c);
  noise_correlation(data, c);
  reset_levels(data, motion, localizer_motion, c);
  if (!data.visibility.empty()) {
    std::size_t visible = 0, missed = 0;
    for (const Visibility& v : data.visibility) {
      std::set<std::size_t> seen;
      for (std::size_t i = v.first; i < v.first + v.count; ++i)
        if (r[i].inlier) seen.insert(r[i].landmark);
      visible += v.visible.size();
      for (const LandmarkInView& l : v.visible) missed += seen.count(l.index) == 0 ? 1 : 0;
    }
    c.visible = visible;
    c.missed = missed;
    if (visible > 0)
      c.miss_probability = static_cast<double>(missed) / static_cast<double>(visible);
  }
  return c;
}

/// Covariance of the pose reached by (rot1, trans, rot2), in the start's frame, for spreads s.
Eigen::Matrix3d delta_covariance(const sdk::OdometryDelta& d, const sdk::OdometryDelta& s) {
  Eigen::Matrix3d J;
  const double c = std::cos(d.rot1), sn = std::sin(d.rot1);
  J << -d.trans * sn, c, 0,  //
      d.trans * c, sn, 0,    //
      1, 0, 1;
  const Eigen::Vector3d var(s.rot1 * s.rot1, s.trans * s.trans, s.rot2 * s.rot2);
  return J * var.asDiagonal() * J.transpose();
}

/// Negative log-likelihood of e under N(0, P), without the constant. Eigen's closed-form 3x3
/// determinant and inverse: the fits evaluate this millions of times.
double gaussian_nll(const Eigen::Vector3d& e, const Eigen::Matrix3d& P) {
  const double det = P.determinant();
  if (!(det > 0.0)) return 1e300;
  return 0.5 * (std::log(det) + e.dot(P.inverse() * e));
}

// log(parameter) kept in a box: a fit may drive a noise term to zero, which is its answer.
constexpr double kMinLog = -25.0, kMaxLog = 2.3;  // 1.4e-11 .. 10
double bounded_exp(double p) {
  return std::exp(std::clamp(p, kMinLog, kMaxLog));
}

/// The error every interval has whatever its motion (truth noise, timing, a robot that creeps
/// while its odometry says it stands): fitted beside each model as standard deviations in
/// position and heading, so that it does not inflate the terms that grow with motion.
Eigen::Matrix3d floor_covariance(double position_m, double heading_rad) {
  return Eigen::Vector3d(position_m * position_m + kFloorVariance,
                         position_m * position_m + kFloorVariance,
                         heading_rad * heading_rad + kFloorVariance)
      .asDiagonal();
}

OdometryModelFit fit_odometry_model(const std::vector<MotionSample>& samples, bool variance_form) {
  const auto noise_of = [&](const std::vector<double>& p) {
    return sdk::OdometryNoise{bounded_exp(p[0]), bounded_exp(p[1]), bounded_exp(p[2]),
                              bounded_exp(p[3]), variance_form};
  };
  const auto nll = [&](const std::vector<double>& p) {
    const sdk::OdometryNoise noise = noise_of(p);
    const Eigen::Matrix3d floor = floor_covariance(bounded_exp(p[4]), bounded_exp(p[5]));
    double sum = 0.0;
    for (const MotionSample& s : samples) {
      sum +=
          gaussian_nll(s.local_error,
                       delta_covariance(s.measured, sdk::motion_spread(s.measured, noise)) + floor);
    }
    return sum / static_cast<double>(samples.size());
  };
  const MinimizeResult best =
      minimize_restarted(nll, {-3.0, -3.0, -3.0, -3.0, -7.0, -7.0}, 2.0, 6000);
  const sdk::OdometryNoise noise = noise_of(best.x);
  return {noise.alpha1,           noise.alpha2,           noise.alpha3, noise.alpha4,
          bounded_exp(best.x[4]), bounded_exp(best.x[5]), -best.value};
}

/// Thrun's velocity-model noise: variance of the measured v and omega about the true ones as
/// alpha1 v^2 + alpha2 omega^2 and alpha3 v^2 + alpha4 omega^2 (least squares on the squared
/// errors, coefficients kept non-negative).
std::optional<OdometryModelFit> fit_velocity_model(const std::vector<MotionSample>& samples,
                                                   std::size_t& used) {
  std::vector<const MotionSample*> with;
  for (const MotionSample& s : samples)
    if (s.has_velocity) with.push_back(&s);
  used = with.size();
  if (with.size() < 10) return std::nullopt;
  const auto fit = [&](auto error) {
    Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
    Eigen::Vector2d b = Eigen::Vector2d::Zero();
    for (const MotionSample* s : with) {
      const Eigen::Vector2d f(s->v_mps * s->v_mps, s->omega_radps * s->omega_radps);
      const double e = error(*s);
      A += f * f.transpose(), b += f * e * e;
    }
    Eigen::Vector2d c = A.ldlt().solve(b);
    if (!(c(0) >= 0.0) || !(c(1) >= 0.0)) {
      const int keep =
          A(0, 0) > 0 && b(0) / A(0, 0) * b(0) >= (A(1, 1) > 0 ? b(1) / A(1, 1) * b(1) : 0) ? 0 : 1;
      c.setZero();
      if (A(keep, keep) > 0.0) c(keep) = std::max(0.0, b(keep) / A(keep, keep));
    }
    return c;
  };
  const Eigen::Vector2d v = fit([](const MotionSample& s) { return s.v_mps - s.true_v_mps; });
  const Eigen::Vector2d w =
      fit([](const MotionSample& s) { return s.omega_radps - s.true_omega_radps; });
  OdometryModelFit out{v(0), v(1), w(0), w(1), 0.0, 0.0, 0.0};
  for (const MotionSample* s : with) {
    const double vv =
        v(0) * s->v_mps * s->v_mps + v(1) * s->omega_radps * s->omega_radps + kFloorVariance;
    const double ww =
        w(0) * s->v_mps * s->v_mps + w(1) * s->omega_radps * s->omega_radps + kFloorVariance;
    const double ev = s->v_mps - s->true_v_mps, ew = s->omega_radps - s->true_omega_radps;
    out.log_likelihood -= 0.5 * (std::log(vv * ww) + ev * ev / vv + ew * ew / ww);
  }
  out.log_likelihood /= static_cast<double>(with.size());
  return out;
}

/// The wheel model's covariance of an interval for parameters p: log k_left, log k_right, log
/// floors (position, heading) and, when there is a fifth, the wheels' error correlation through
/// 0.99 tanh.
Eigen::Matrix3d wheel_covariance(const MotionSample& s, const std::vector<double>& p) {
  const double kl = bounded_exp(p[0]), kr = bounded_exp(p[1]);
  const double rho = p.size() > 4 ? 0.99 * std::tanh(p[4]) : 0.0;
  return kl * kl * s.wheel_p_left + kr * kr * s.wheel_p_right + rho * kl * kr * s.wheel_p_cross +
         floor_covariance(bounded_exp(p[2]), bounded_exp(p[3]));
}

double wheel_nll(const std::vector<MotionSample>& samples, const std::vector<double>& p) {
  double sum = 0.0;
  for (const MotionSample& s : samples) sum += gaussian_nll(s.wheel_error, wheel_covariance(s, p));
  return sum / static_cast<double>(samples.size());
}

/// The wheel model's k_left, k_right and floor by maximum likelihood (MotionCalibration's).
void fit_wheel_model(const std::vector<MotionSample>& samples, MotionCalibration& m) {
  const MinimizeResult best =
      minimize_restarted([&](const std::vector<double>& p) { return wheel_nll(samples, p); },
                         {-5.0, -5.0, -7.0, -7.0}, 2.0, 4000);
  m.k_left = std::min(bounded_exp(best.x[0]), 1.0);
  m.k_right = std::min(bounded_exp(best.x[1]), 1.0);
  m.k_floor_position_m = bounded_exp(best.x[2]);
  m.k_floor_heading_rad = bounded_exp(best.x[3]);
  m.k_log_likelihood = -best.value;
  for (const MotionSample& s : samples) {
    m.k_mean_nees += s.wheel_error.dot(wheel_covariance(s, best.x).ldlt().solve(s.wheel_error)) /
                     static_cast<double>(samples.size());
  }
}

/// The same with the two wheels' errors correlated (the simulated encoders' k_correlation),
/// from `independent`'s fit; kept when the correlation explains the intervals better
/// (likelihood ratio, one more parameter, at 95 %: 3.84 / 2 nats).
std::optional<CorrelatedWheels> fit_correlated_wheels(const std::vector<MotionSample>& samples,
                                                      const MotionCalibration& independent) {
  const auto log_k = [](double k) { return std::log(std::max(k, 1e-12)); };
  const std::vector<double> start = {log_k(independent.k_left), log_k(independent.k_right),
                                     log_k(independent.k_floor_position_m),
                                     log_k(independent.k_floor_heading_rad), 0.0};
  const MinimizeResult best = minimize_restarted(
      [&](const std::vector<double>& p) { return wheel_nll(samples, p); }, start, 1.0, 6000);
  const double gain_nats =
      (-independent.k_log_likelihood - best.value) * static_cast<double>(samples.size());
  if (!(gain_nats > 1.92)) return std::nullopt;
  return CorrelatedWheels{std::min(bounded_exp(best.x[0]), 1.0),
                          std::min(bounded_exp(best.x[1]), 1.0), 0.99 * std::tanh(best.x[4]),
                          gain_nats};
}

/// The gyro bias's random walk [rad/s^3/2] from the intervals' heading errors less the scale's
/// part (error(s); variance(s) each, the gyro model's): each robot's bias fitted over consecutive
/// windows of kBiasWindowS; a random walk of density w sets two neighbouring windows' means apart
/// by w^2 (2 W / 3) in variance beyond their estimates' own. 0 with fewer than three pairs of
/// windows, or none beyond noise.
template <class Variance, class Error>
double heading_bias_walk(const std::vector<MotionSample>& samples, const Variance& variance,
                         const Error& error) {
  // Long enough to average a gyro's white noise down, short enough that a recording of minutes
  // has several.
  constexpr double kBiasWindowS = 60.0;
  struct Window {
    std::size_t track = 0;
    double seconds = 0.0, xx = 0.0, xe = 0.0;  // sum dt, dt^2 / v, dt e / v
  };
  std::vector<Window> windows;
  Window open;
  for (const MotionSample& s : samples) {
    if (s.track != open.track) open = Window{s.track};
    const double w = 1.0 / variance(s);
    open.seconds += s.dt_s, open.xx += s.dt_s * s.dt_s * w, open.xe += s.dt_s * error(s) * w;
    if (open.seconds >= kBiasWindowS) {
      if (open.xx > 0.0) windows.push_back(open);
      open = Window{s.track};
    }
  }
  double excess = 0.0;
  std::size_t pairs = 0;
  for (std::size_t i = 1; i < windows.size(); ++i) {
    const Window &a = windows[i - 1], &b = windows[i];
    if (a.track != b.track) continue;
    const double d = b.xe / b.xx - a.xe / a.xx;
    excess += d * d - 1.0 / a.xx - 1.0 / b.xx;
    ++pairs;
  }
  if (pairs < 3 || !(excess > 0.0)) return 0.0;
  return std::sqrt(excess / static_cast<double>(pairs) / (2.0 * kBiasWindowS / 3.0));
}

/// The heading errors' two models (MotionCalibration::HeadingFit) by maximum likelihood, each
/// model's systematic terms solved in closed form inside (they are linear given the variances):
/// the wheels' wheel-base error of each robot, in proportion to the turn, and a gyro's bias of
/// each robot, times the interval. A gyro's scale error is fitted once the gyro is told: it is
/// in proportion to the turn too, the wheels' term by another name, and would take the wheels'
/// part in telling them apart (a gyro is told by its drift with time, on the straights).
MotionCalibration::HeadingFit fit_heading(const std::vector<MotionSample>& samples) {
  std::size_t tracks = 0;
  for (const MotionSample& s : samples) tracks = std::max(tracks, s.track + 1);
  // The measured turn, wrapped: rot1 and rot2 are each wrapped, and a turn on the spot (rot1
  // the direction of a step of millimetres) can make their sum 2 pi off.
  const auto turn = [](const MotionSample& s) {
    return sdk::wrap(s.measured.rot1 + s.measured.rot2);
  };
  const auto time = [](const MotionSample& s) { return s.dt_s; };
  using Regressor = double (*)(const MotionSample&);
  // -log-likelihood per interval of e_i ~ N(sum_r c_{track, r} x_r + sum_g k_g z_g, var_i): the
  // coefficients at their optimum by weighted least squares (each interval touches its track's
  // and the global ones only); `coefficients` gets them, each track's first, then the global.
  const auto profiled = [&](const std::vector<Regressor>& own, const std::vector<Regressor>& global,
                            const auto& variance, std::vector<double>* coefficients) {
    const std::size_t per = own.size(), n = tracks * per + global.size();
    Eigen::MatrixXd normal =
        Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n));
    std::vector<std::pair<Eigen::Index, double>> terms;
    const auto terms_of = [&](const MotionSample& s) {
      terms.clear();
      for (std::size_t r = 0; r < per; ++r)
        terms.emplace_back(static_cast<Eigen::Index>(s.track * per + r), own[r](s));
      for (std::size_t g = 0; g < global.size(); ++g)
        terms.emplace_back(static_cast<Eigen::Index>(tracks * per + g), global[g](s));
    };
    for (const MotionSample& s : samples) {
      const double w = 1.0 / variance(s);
      terms_of(s);
      for (const auto& [a, xa] : terms) {
        rhs(a) += w * xa * s.local_error(2);
        for (const auto& [b, xb] : terms) normal(a, b) += w * xa * xb;
      }
    }
    // A term no interval excites (a robot that never turned) stays at zero.
    normal.diagonal().array() += 1e-12 * (normal.diagonal().array().maxCoeff() + 1.0);
    const Eigen::VectorXd c = normal.ldlt().solve(rhs);
    double sum = 0.0;
    for (const MotionSample& s : samples) {
      terms_of(s);
      double e = s.local_error(2);
      for (const auto& [a, x] : terms) e -= c(a) * x;
      const double v = variance(s);
      sum += 0.5 * (std::log(2.0 * std::numbers::pi * v) + e * e / v);
    }
    if (coefficients != nullptr) coefficients->assign(c.data(), c.data() + c.size());
    return sum / static_cast<double>(samples.size());
  };
  const std::vector<Regressor> wheels_own{+turn}, gyro_own{+time}, gyro_scale{+turn};
  const auto wheels_variance = [](const MotionSample& s, const std::vector<double>& p) {
    const double kl = bounded_exp(p[0]), kr = bounded_exp(p[1]), f = bounded_exp(p[2]);
    return kl * kl * s.wheel_p_left(2, 2) + kr * kr * s.wheel_p_right(2, 2) + f * f;
  };
  const auto gyro_variance = [](const MotionSample& s, const std::vector<double>& p) {
    const double q = bounded_exp(p[0]), f = bounded_exp(p[1]);
    return q * q * s.dt_s + f * f;
  };
  const MinimizeResult wheels = minimize_restarted(
      [&](const std::vector<double>& p) {
        return profiled(
            wheels_own, {}, [&](const MotionSample& s) { return wheels_variance(s, p); }, nullptr);
      },
      {-5.0, -5.0, -7.0}, 2.0, 3000);
  const auto fit_gyro = [&](const std::vector<Regressor>& global) {
    return minimize_restarted(
        [&](const std::vector<double>& p) {
          return profiled(
              gyro_own, global, [&](const MotionSample& s) { return gyro_variance(s, p); },
              nullptr);
        },
        {-6.0, -7.0}, 2.0, 3000);
  };
  const MinimizeResult told = fit_gyro({});
  MotionCalibration::HeadingFit fit;
  fit.wheels_log_likelihood = -wheels.value;
  fit.gyro_log_likelihood = -told.value;
  fit.gyro = fit.gyro_log_likelihood > fit.wheels_log_likelihood;
  const MinimizeResult gyro = fit.gyro ? fit_gyro(gyro_scale) : told;
  const std::vector<Regressor> gyro_global = fit.gyro ? gyro_scale : std::vector<Regressor>{};
  std::vector<double> coefficients;
  profiled(
      gyro_own, gyro_global, [&](const MotionSample& s) { return gyro_variance(s, gyro.x); },
      &coefficients);
  // Against the measured turn m = (1 + s) t + b dt + n the error e = m - t fits c m + b' dt + n'
  // with c = s / (1 + s): s = c / (1 - c), b = b' / (1 - c), n = n' / (1 - c).
  const double c = fit.gyro ? coefficients.back() : 0.0;
  const double to_true = 1.0 / (1.0 - c);
  fit.scale_error = c * to_true;
  fit.bias_by_track_radps.assign(coefficients.begin(),
                                 coefficients.begin() + static_cast<std::ptrdiff_t>(tracks));
  for (double& b : fit.bias_by_track_radps) b *= to_true;
  fit.noise_density = bounded_exp(gyro.x[0]) * to_true;
  fit.floor_rad = bounded_exp(gyro.x[1]) * to_true;
  const auto n = static_cast<double>(fit.bias_by_track_radps.size());
  for (const double b : fit.bias_by_track_radps) fit.bias_radps += b / n;
  if (n > 1.0) {
    double ss = 0.0;
    for (const double b : fit.bias_by_track_radps)
      ss += (b - fit.bias_radps) * (b - fit.bias_radps);
    fit.bias_sigma = std::sqrt(ss / (n - 1.0));
  }
  fit.bias_walk =
      to_true * heading_bias_walk(
                    samples, [&](const MotionSample& s) { return gyro_variance(s, gyro.x); },
                    [&](const MotionSample& s) { return s.local_error(2) - c * turn(s); });
  // The distance's error: the increments' lengths, variance k^2 (|d_l| + |d_r|) / 4 + floor^2.
  const auto distance_nll = [&](const std::vector<double>& p) {
    const double k = bounded_exp(p[0]), f = bounded_exp(p[1]);
    double sum = 0.0;
    for (const MotionSample& s : samples) {
      const double v = 0.25 * k * k * (s.rolled_left_m + s.rolled_right_m) + f * f;
      // The odometry's increment is trans along rot1; the true one is that less the error.
      const double e = s.measured.trans -
                       std::hypot(s.measured.trans * std::cos(s.measured.rot1) - s.local_error(0),
                                  s.measured.trans * std::sin(s.measured.rot1) - s.local_error(1));
      sum += 0.5 * (std::log(v) + e * e / v);
    }
    return sum / static_cast<double>(samples.size());
  };
  const MinimizeResult distance = minimize_restarted(distance_nll, {-5.0, -7.0}, 2.0, 2000);
  fit.distance_k = std::min(bounded_exp(distance.x[0]), EncodersDef::kKRange.max);
  fit.distance_floor_m = bounded_exp(distance.x[1]);
  return fit;
}

MotionCalibration fit_motion(const std::vector<MotionSample>& samples) {
  MotionCalibration m;
  m.intervals = samples.size();
  for (const MotionSample& s : samples) {
    m.mean_interval_s += s.dt_s / static_cast<double>(samples.size());
    m.mean_travel_m += s.measured.trans / static_cast<double>(samples.size());
  }
  m.odometry_std = fit_odometry_model(samples, false);
  m.odometry_variance = fit_odometry_model(samples, true);
  m.variance_form = m.odometry_variance.log_likelihood > m.odometry_std.log_likelihood;
  fit_wheel_model(samples, m);
  m.correlated_wheels = fit_correlated_wheels(samples, m);
  m.velocity = fit_velocity_model(samples, m.velocity_intervals);
  return m;
}

// ---- the command response --------------------------------------------------------------------

constexpr double kResponseGridS = 0.02;  // the fit's time step: the dead time's resolution [s]
constexpr double kMaxDeadTimeS = 0.6;
// Time constants tried [s]: the grid is coarse where the fit is flat.
constexpr double kResponseTimeConstantsS[] = {0.0,  0.05, 0.1, 0.15, 0.2, 0.25, 0.3,
                                              0.35, 0.4,  0.5, 0.6,  0.7, 0.85, 1.0};
// A reading older than this no longer says what the robot is told (a gap in the log). [s]
constexpr double kStaleReadingS = 1.0;
// Both sides of the fit are averaged over +-this (a zero-phase filter, which the model commutes
// with), so that noise in the reported velocity weighs less against the signal. [s]
constexpr double kFitSmoothingS = 0.3;
// The lag is kept when it leaves at most this share of what the best zero-phase smoothing of
// the reported velocity (with a gain) leaves, normalised by each channel's variance and summed:
// a lag that only smooths noise explains no more than a smoother does, and a wheel odometry,
// whose velocity is a mean over its last period, lags the truth rather than leads it.
constexpr double kLeadShare = 0.8;

/// A robot's reported velocity (the latest reading's, held) and its true velocity (central
/// differences of the truth, then a mean over +-kFitSmoothingS) on a regular grid.
struct VelocitySeries {
  double t0_s = 0.0;
  std::vector<double> reported_v, reported_omega;
  std::vector<double> true_v, true_omega;
  std::vector<char> valid;  // a true velocity and a fresh reading over the whole mean
  // The true velocity is a difference over +-difference_steps: a mean of the velocity over
  // them, which the model's output gets too before they are compared (else the fit would take
  // the mean's spread for an earlier start and a longer lag); then both a mean over
  // +-smoothing_steps.
  std::size_t difference_steps = 0, smoothing_steps = 0;
  // The reported values' own noise (a wheel noise added to a reported command): its variance per
  // reading, from the spread of consecutive readings' differences (robust: a command that steps
  // now and then has none), and how many grid steps a reading is held. [(m/s)^2], [(rad/s)^2]
  double noise_variance[2] = {0.0, 0.0};  // v, omega
  std::size_t hold_steps = 1;
  /// What a model's output x is compared as.
  std::vector<double> as_compared(const std::vector<double>& x) const;
};

/// The centred moving mean of x over +-half steps (shorter at the ends).
std::vector<double> centred_mean(const std::vector<double>& x, std::size_t half) {
  if (half == 0) return x;
  std::vector<double> prefix(x.size() + 1, 0.0);
  for (std::size_t k = 0; k < x.size(); ++k) prefix[k + 1] = prefix[k] + x[k];
  std::vector<double> out(x.size());
  for (std::size_t k = 0; k < x.size(); ++k) {
    const std::size_t from = k >= half ? k - half : 0, to = std::min(x.size(), k + half + 1);
    out[k] = (prefix[to] - prefix[from]) / static_cast<double>(to - from);
  }
  return out;
}

std::vector<double> VelocitySeries::as_compared(const std::vector<double>& x) const {
  return centred_mean(centred_mean(x, difference_steps), smoothing_steps);
}

std::optional<VelocitySeries> velocity_series(const RobotLog& robot) {
  std::vector<std::pair<double, const locsim_odometry*>> readings;
  for (const auto& [t_s, o] : robot.odometry) {
    if ((o.fields & LOCSIM_ODOMETRY_VELOCITY) != 0) readings.emplace_back(t_s, &o);
  }
  if (readings.size() < 2) return std::nullopt;
  const double h_s = difference_half_width_s(robot.truth);
  VelocitySeries out;
  out.t0_s = readings.front().first;
  out.difference_steps = static_cast<std::size_t>(std::lround(h_s / kResponseGridS));
  out.smoothing_steps = static_cast<std::size_t>(std::lround(kFitSmoothingS / kResponseGridS));
  const auto steps = static_cast<std::size_t>((readings.back().first - out.t0_s) / kResponseGridS);
  std::vector<double> valid;
  std::size_t held = 0;
  for (std::size_t k = 0; k <= steps; ++k) {
    const double t_s = out.t0_s + static_cast<double>(k) * kResponseGridS;
    while (held + 1 < readings.size() && readings[held + 1].first <= t_s) ++held;
    const locsim_odometry& r = *readings[held].second;
    out.reported_v.push_back(r.v_mps);
    out.reported_omega.push_back(r.omega_radps);
    sdk::Pose pose;
    const auto velocity = true_velocity(robot.truth, t_s, h_s, pose);
    const bool fresh = velocity && t_s - readings[held].first < kStaleReadingS;
    out.true_v.push_back(fresh ? velocity->first : 0.0);
    out.true_omega.push_back(fresh ? velocity->second : 0.0);
    valid.push_back(fresh ? 1.0 : 0.0);
  }
  std::vector<double> periods;
  for (std::size_t i = 1; i < readings.size(); ++i)
    periods.push_back(readings[i].first - readings[i - 1].first);
  out.hold_steps = std::max<std::size_t>(
      1, static_cast<std::size_t>(std::lround(median(periods) / kResponseGridS)));
  for (int c = 0; c < 2; ++c) {
    std::vector<double> differences;
    for (std::size_t i = 1; i < readings.size(); ++i) {
      const locsim_odometry& a = *readings[i - 1].second;
      const locsim_odometry& b = *readings[i].second;
      differences.push_back(c == 0 ? b.v_mps - a.v_mps : b.omega_radps - a.omega_radps);
    }
    const double middle = median(differences);
    for (double& d : differences) d = std::abs(d - middle);
    // A difference of two independent readings has twice their variance.
    out.noise_variance[c] = std::pow(1.4826 * median(differences), 2) / 2.0;
  }
  out.true_v = centred_mean(out.true_v, out.smoothing_steps);
  out.true_omega = centred_mean(out.true_omega, out.smoothing_steps);
  // Valid where every sample of the mean is (the mean of the flags is 1).
  for (const double share : centred_mean(valid, out.smoothing_steps))
    out.valid.push_back(share > 1.0 - 1e-9 ? 1 : 0);
  return out;
}

/// u through a first-order lag of time constant tau_s (exact for a signal held over each step),
/// from rest at u's first value.
std::vector<double> lag(const std::vector<double>& u, double tau_s) {
  std::vector<double> y(u.size());
  const double a = tau_s > 0.0 ? std::exp(-kResponseGridS / tau_s) : 0.0;
  double state = u.empty() ? 0.0 : u.front();
  for (std::size_t k = 0; k < u.size(); ++k) {
    state = a * state + (1.0 - a) * u[k];
    y[k] = state;
  }
  return y;
}

/// One channel's least squares through the origin: truth y = gain * model output f, where f is
/// a filter's output of a reported signal with noise of its own. That noise adds `noise` to
/// f.f (what the filter passes of it), and would pull the gain down and favour filters that
/// smooth it (a longer lag for a shorter dead time): the sums are of the noise-free f.
struct ChannelSums {
  double fy = 0.0, ff = 0.0, yy = 0.0, noise = 0.0;
  double signal_ff() const { return std::max(ff - noise, 0.1 * ff); }
  double gain() const { return ff > 0.0 ? fy / signal_ff() : 1.0; }
  double residual() const { return ff > 0.0 ? std::max(0.0, yy - fy * fy / signal_ff()) : yy; }
};

/// The variance a filter passes of a reading's unit-variance noise, per grid step: its response
/// to one reading held `hold` steps, squared and summed, over `hold`.
template <class Filter>
double passed_noise(std::size_t hold, std::size_t span, const Filter& filter) {
  std::vector<double> x(2 * span + hold, 0.0);
  std::fill(x.begin() + static_cast<std::ptrdiff_t>(span),
            x.begin() + static_cast<std::ptrdiff_t>(span + hold), 1.0);
  double energy = 0.0;
  for (const double y : filter(x)) energy += y * y;
  return energy / static_cast<double>(hold);
}

std::optional<CommandResponseFit> fit_command_response(const std::vector<RobotLog>& robots) {
  std::vector<VelocitySeries> series;
  std::size_t valid = 0;
  for (const RobotLog& robot : robots) {
    if (auto s = velocity_series(robot)) {
      valid += static_cast<std::size_t>(std::count(s->valid.begin(), s->valid.end(), 1));
      series.push_back(std::move(*s));
    }
  }
  // Ten seconds of motion at least: the lag is a fraction of a second.
  if (static_cast<double>(valid) * kResponseGridS < 10.0) return std::nullopt;
  CommandResponseFit fit;
  fit.seconds = static_cast<double>(valid) * kResponseGridS;
  const auto max_delay = static_cast<std::size_t>(std::lround(kMaxDeadTimeS / kResponseGridS));
  constexpr std::size_t kTaus = std::size(kResponseTimeConstantsS);
  // Per channel: the sums of each (delay, time constant), and of each zero-phase smoother (a
  // centred mean as wide as a time constant), over every series. The filters are linear and
  // time-invariant, so a delay is a shift of the lagged output.
  std::vector<std::array<ChannelSums, kTaus>> lagged[2];
  std::array<ChannelSums, kTaus> smoothed[2];
  double as_is[2] = {0.0, 0.0};
  for (int c = 0; c < 2; ++c) lagged[c].resize(max_delay + 1);
  for (const VelocitySeries& s : series) {
    for (int c = 0; c < 2; ++c) {
      const std::vector<double>& u = c == 0 ? s.reported_v : s.reported_omega;
      const std::vector<double>& y = c == 0 ? s.true_v : s.true_omega;
      // f delayed by `delay` steps (its first value before the start) against y.
      std::size_t n_valid = 0;
      for (const char v : s.valid) n_valid += v != 0 ? 1 : 0;
      // Long enough for the slowest filter's response to fade (lag, means).
      const auto span = static_cast<std::size_t>(
          (8.0 * kResponseTimeConstantsS[std::size(kResponseTimeConstantsS) - 1] +
           2.0 * kFitSmoothingS + 1.0) /
          kResponseGridS);
      // The valid samples as weights 1 and 0, so that the sums below run without branches (the
      // delays make 31 of them per time constant).
      std::vector<double> weight(y.size()), weighted_y(y.size());
      double yy = 0.0;
      for (std::size_t k = 0; k < y.size(); ++k) {
        weight[k] = s.valid[k] ? 1.0 : 0.0;
        weighted_y[k] = weight[k] * y[k];
        yy += weighted_y[k] * y[k];
      }
      // f delayed by `delay` steps (its first value before the start) against y.
      const auto add = [&](ChannelSums& sums, const std::vector<double>& f, std::size_t delay,
                           double passed) {
        const std::size_t head = std::min(delay, f.size());
        double fy = 0.0, ff = 0.0;
        for (std::size_t k = 0; k < head; ++k)
          fy += f[0] * weighted_y[k], ff += f[0] * f[0] * weight[k];
        for (std::size_t k = head; k < f.size(); ++k) {
          const double x = f[k - delay];
          fy += x * weighted_y[k], ff += x * x * weight[k];
        }
        sums.fy += fy, sums.ff += ff, sums.yy += yy;
        sums.noise += static_cast<double>(n_valid) * s.noise_variance[c] * passed;
      };
      const std::vector<double> u_compared = s.as_compared(u);
      for (std::size_t k = 0; k < u.size(); ++k) {
        if (s.valid[k]) as_is[c] += std::pow(y[k] - u_compared[k], 2);
      }
      for (std::size_t i = 0; i < kTaus; ++i) {
        const double tau_s = kResponseTimeConstantsS[i];
        const auto lagged_filter = [&](const std::vector<double>& x) {
          return s.as_compared(lag(x, tau_s));
        };
        const auto width = static_cast<std::size_t>(std::lround(tau_s / kResponseGridS));
        const auto smoother = [&](const std::vector<double>& x) {
          return s.as_compared(centred_mean(x, width));
        };
        const std::vector<double> f = lagged_filter(u);
        const double passed = passed_noise(s.hold_steps, span, lagged_filter);
        for (std::size_t delay = 0; delay <= max_delay; ++delay)
          add(lagged[c][delay][i], f, delay, passed);
        add(smoothed[c][i], smoother(u), 0, passed_noise(s.hold_steps, span, smoother));
      }
    }
  }
  // Each channel's cost relative to its own variance, so that neither unit dominates.
  const double scale[2] = {std::max(smoothed[0][0].yy, 1e-300),
                           std::max(smoothed[1][0].yy, 1e-300)};
  const auto best_of = [](const std::array<ChannelSums, kTaus>& sums) {
    std::size_t best = 0;
    for (std::size_t i = 1; i < kTaus; ++i)
      if (sums[i].residual() < sums[best].residual()) best = i;
    return best;
  };
  double best_cost = std::numeric_limits<double>::infinity();
  ChannelSums best_sums[2];
  for (std::size_t delay = 0; delay <= max_delay; ++delay) {
    const std::size_t v = best_of(lagged[0][delay]), omega = best_of(lagged[1][delay]);
    const double cost =
        lagged[0][delay][v].residual() / scale[0] + lagged[1][delay][omega].residual() / scale[1];
    if (cost < best_cost) {
      best_cost = cost;
      best_sums[0] = lagged[0][delay][v], best_sums[1] = lagged[1][delay][omega];
      fit.dead_time_s = static_cast<double>(delay) * kResponseGridS;
      fit.time_constant_v_s = kResponseTimeConstantsS[v];
      fit.time_constant_omega_s = kResponseTimeConstantsS[omega];
    }
  }
  fit.gain_v = best_sums[0].gain();
  fit.gain_omega = best_sums[1].gain();
  const auto ratio = [](double a, double b) { return b > 0.0 ? a / b : 0.0; };
  fit.residual_v = ratio(best_sums[0].residual(), as_is[0]);
  fit.residual_omega = ratio(best_sums[1].residual(), as_is[1]);
  fit.residual_gain_only_v = ratio(smoothed[0][0].residual(), as_is[0]);
  fit.residual_gain_only_omega = ratio(smoothed[1][0].residual(), as_is[1]);
  const double smoother_cost = smoothed[0][best_of(smoothed[0])].residual() / scale[0] +
                               smoothed[1][best_of(smoothed[1])].residual() / scale[1];
  fit.leads = best_cost < kLeadShare * smoother_cost;
  return fit;
}

/// The gain wander of each channel (CommandResponseFit::GainWander): windows of W = 2, 5, 10 and
/// 20 s, robot by robot, where the response moved at least 0.05 m/s or 0.05 rad/s on average, and
/// in each the true motion over the response's M, less 1. A first-order Gauss-Markov gain gives
/// that ratio the variance sigma^2 f(W / tau), f(x) = 2 (x - 1 + e^-x) / x^2 (flat for W << tau,
/// falling as 2 tau / W beyond); noise independent from step to step (the wheels', the truth's
/// own) adds c W / M^2, the more the less the window moved. Fitted by maximum likelihood over every
/// window (ratios about their window length's mean), sigma^2 and c on logarithmic grids per tau,
/// tau on one grid of 0.5 .. 1000 s shared by both channels, then all three refined locally; kept
/// when it explains the windows better than the step-to-step noise alone by more than chi-square at
/// 95 % (three degrees of freedom, two with one channel measured), else no wander (sigma 0). Only
/// windows that move one way count (see below); a channel with fewer than three window lengths gets
/// no wander.
void fit_gain_wander(const std::vector<RobotLog>& robots, CommandResponseFit& fit) {
  constexpr double kWindowsS[] = {2.0, 5.0, 10.0, 20.0};
  constexpr double kMinMeanMotion = 0.05;  // m/s, rad/s
  constexpr double kOneWay = 0.9;          // |net motion| over motion
  constexpr std::size_t kMinWindows = 10;
  struct Window {
    std::size_t w;  // index into kWindowsS
    double ratio;   // true over responded motion, less 1
    double motion;  // M: the response's motion over the window [m], [rad]
  };
  std::vector<Window> windows[2];
  const auto delay = static_cast<std::size_t>(std::lround(fit.dead_time_s / kResponseGridS));
  for (const RobotLog& robot : robots) {
    const std::optional<VelocitySeries> series = velocity_series(robot);
    if (!series) continue;
    for (int c = 0; c < 2; ++c) {
      const std::vector<double> lagged =
          lag(c == 0 ? series->reported_v : series->reported_omega,
              c == 0 ? fit.time_constant_v_s : fit.time_constant_omega_s);
      const double gain = c == 0 ? fit.gain_v : fit.gain_omega;
      const std::vector<double>& truth = c == 0 ? series->true_v : series->true_omega;
      for (std::size_t w = 0; w < std::size(kWindowsS); ++w) {
        const auto width = static_cast<std::size_t>(std::lround(kWindowsS[w] / kResponseGridS));
        for (std::size_t start = delay; start + width <= lagged.size(); start += width) {
          double moved = 0.0, along = 0.0, net = 0.0;
          bool valid = true;
          for (std::size_t k = start; k < start + width && valid; ++k) {
            valid = series->valid[k] != 0;
            const double u = gain * lagged[k - delay];
            moved += std::abs(u);
            net += u;
            along += u < 0.0 ? -truth[k] : truth[k];
          }
          // One way: where the command swings back and forth, what the response's model leaves
          // of each swing (the wheels' own ramp) would pass for a wandering gain.
          if (valid && moved * kResponseGridS >= kMinMeanMotion * kWindowsS[w] &&
              std::abs(net) >= kOneWay * moved)
            windows[c].push_back({w, along / moved - 1.0, moved * kResponseGridS});
        }
      }
    }
  }
  // Per channel: the ratios about their window length's mean, and what is reported per length.
  CommandResponseFit::GainWander wander[2];
  for (int c = 0; c < 2; ++c) {
    std::vector<Window> kept;
    for (std::size_t w = 0; w < std::size(kWindowsS); ++w) {
      double mean = 0.0, square = 0.0;
      std::size_t n = 0;
      for (const Window& x : windows[c]) n += x.w == w;
      if (n < kMinWindows) continue;
      for (const Window& x : windows[c])
        if (x.w == w) mean += x.ratio / static_cast<double>(n);
      for (const Window& x : windows[c]) {
        if (x.w != w) continue;
        square += (x.ratio - mean) * (x.ratio - mean);
        kept.push_back({w, x.ratio - mean, x.motion});
      }
      wander[c].windows.push_back(
          {kWindowsS[w], std::sqrt(square / static_cast<double>(n - 1)), n});
    }
    windows[c] = std::move(kept);
  }
  // A channel with fewer than three window lengths (a robot that never turns one way for
  // seconds) is not measured: it gets no wander.
  const bool measured[2] = {wander[0].windows.size() >= 3, wander[1].windows.size() >= 3};
  if (!measured[0] && !measured[1]) return;
  const auto f = [](double x) { return 2.0 * (x - 1.0 + std::exp(-x)) / (x * x); };
  // -log-likelihood of a channel's windows, Gaussian of variance s f(W / tau) + c W / M^2.
  const auto nll = [&](const std::vector<Window>& ws, double s, double c, double tau_s) {
    double fw[std::size(kWindowsS)];
    for (std::size_t w = 0; w < std::size(kWindowsS); ++w) fw[w] = s * f(kWindowsS[w] / tau_s);
    double sum = 0.0;
    for (const Window& x : ws) {
      const double v = std::max(fw[x.w] + c * kWindowsS[x.w] / (x.motion * x.motion), 1e-300);
      sum += 0.5 * (std::log(v) + x.ratio * x.ratio / v);
    }
    return sum;
  };
  // The grids: sigma^2 from 1e-6 to 1 and c about its scale, five points a decade, and 0.
  struct Best {
    double nll = std::numeric_limits<double>::infinity(), s = 0.0, c = 0.0;
  };
  const auto best_at = [&](const std::vector<Window>& ws, double tau_s, bool wander_allowed) {
    std::vector<double> scaled;
    for (const Window& x : ws)
      scaled.push_back(x.ratio * x.ratio * x.motion * x.motion / kWindowsS[x.w]);
    std::nth_element(scaled.begin(), scaled.begin() + scaled.size() / 2, scaled.end());
    const double c_scale = std::max(scaled[scaled.size() / 2], 1e-12);
    Best best;
    for (int i = wander_allowed ? 0 : 30; i <= 30; ++i) {
      const double s = i < 30 ? std::pow(10.0, -6.0 + i / 5.0) : 0.0;  // i == 30: none
      for (int j = 0; j <= 25; ++j) {
        const double c = j < 25 ? c_scale * std::pow(10.0, -3.0 + j / 5.0) : 0.0;
        if (s == 0.0 && c == 0.0) continue;
        const double value = nll(ws, s, c, tau_s);
        if (value < best.nll) best = {value, s, c};
      }
    }
    return best;
  };
  const auto both = [&](double tau_s, bool wander_allowed, Best(&out)[2]) {
    double total = 0.0;
    for (int c = 0; c < 2; ++c) {
      if (!measured[c]) continue;
      out[c] = best_at(windows[c], tau_s, wander_allowed);
      total += out[c].nll;
    }
    return total;
  };
  Best best[2], scratch[2];
  const double white = both(1.0, false, scratch);
  double best_total = std::numeric_limits<double>::infinity(), best_tau_s = 1.0;
  for (int k = 0; k <= 40; ++k) {
    const double tau_s = 0.5 * std::pow(2000.0, k / 40.0);  // 0.5 .. 1000 s
    const double total = both(tau_s, true, scratch);
    if (total < best_total) {
      best_total = total;
      best_tau_s = tau_s;
      std::copy(std::begin(scratch), std::end(scratch), std::begin(best));
    }
  }
  // Refined about the grid's best: tau, sigma^2 and c each within half a grid step either way,
  // ten times finer.
  if (best_total < white) {
    const double coarse_tau_s = best_tau_s;
    const Best coarse[2] = {best[0], best[1]};
    for (int k = -5; k <= 5; ++k) {
      const double tau_s = coarse_tau_s * std::pow(2000.0, k / 400.0);
      double total = 0.0;
      for (int c = 0; c < 2; ++c) {
        if (!measured[c]) continue;
        Best local;
        for (int i = -5; i <= 5; ++i) {
          for (int j = -5; j <= 5; ++j) {
            const double sv = coarse[c].s * std::pow(10.0, i / 50.0);
            const double cv = coarse[c].c * std::pow(10.0, j / 50.0);
            const double value = nll(windows[c], sv, cv, tau_s);
            if (value < local.nll) local = {value, sv, cv};
          }
        }
        scratch[c] = local;
        total += local.nll;
      }
      if (total < best_total) {
        best_total = total;
        best_tau_s = tau_s;
        std::copy(std::begin(scratch), std::end(scratch), std::begin(best));
      }
    }
  }
  // Three parameters more (two with one channel) than the step-to-step noise alone.
  const bool wanders = white - best_total > (measured[0] && measured[1] ? 3.907 : 2.996);
  for (int c = 0; c < 2; ++c) {
    wander[c].correlation_s = best_tau_s;
    wander[c].sigma = wanders && measured[c] ? std::sqrt(best[c].s) : 0.0;
    wander[c].log_likelihood_gain = white - best_total;
    (c == 0 ? fit.gain_wander_v : fit.gain_wander_omega) = wander[c];
  }
}

/// The side slip (SideSlipFit) over every robot's truth.
std::optional<SideSlipFit> fit_side_slip(const std::vector<RobotLog>& robots) {
  constexpr double kWindowsS[] = {1.0, 2.0, 4.0, 8.0};
  struct Window {
    double w_s;                            // its length [s]
    double across, along, turn, distance;  // D, S, C [m], M [m]
  };
  std::vector<Window> windows;
  SideSlipFit fit;
  for (const RobotLog& robot : robots) {
    const TruthTrack& truth = robot.truth;
    for (const double w_s : kWindowsS) {
      Window x{w_s, 0.0, 0.0, 0.0, 0.0};
      double start_s = truth.size() > 0 ? truth.time(0) : 0.0;
      for (std::size_t i = 1; i < truth.size(); ++i) {
        if (!truth.joined(i)) {
          x = Window{w_s, 0.0, 0.0, 0.0, 0.0};
          start_s = truth.time(i);
          continue;
        }
        const Pose2& a = truth.pose(i - 1);
        const Pose2& b = truth.pose(i);
        const double dt_s = truth.time(i) - truth.time(i - 1);
        const double turn_rad = wrap_angle(b.theta - a.theta);
        const double mid_rad = a.theta + 0.5 * turn_rad;
        const double dx = b.x - a.x, dy = b.y - a.y;
        const double ds = std::cos(mid_rad) * dx + std::sin(mid_rad) * dy;
        x.across += -std::sin(mid_rad) * dx + std::cos(mid_rad) * dy;
        x.along += ds;
        x.distance += std::abs(ds);
        if (dt_s > 0.0) x.turn += ds * turn_rad / dt_s;
        if (truth.time(i) - start_s >= w_s - 1e-9) {
          windows.push_back(x);
          if (w_s == kWindowsS[0]) fit.distance_m += x.distance;
          x = Window{w_s, 0.0, 0.0, 0.0, 0.0};
          start_s = truth.time(i);
        }
      }
    }
  }
  if (windows.size() < 20 || fit.distance_m <= 0.0) return std::nullopt;
  std::vector<char> used(windows.size(), 1);
  // Which parts a fit has: the crab, the cornering, the wander.
  struct Parts {
    bool crab, cornering, wander;
  };
  struct Result {
    double nll = std::numeric_limits<double>::infinity();
    double tan_crab = 0.0, c = 0.0, k2 = 0.0, tau_s = 1.0, p2 = 0.0;
  };
  const auto g = [](double x) { return x < 1e-6 ? 0.5 * x : (x - 1.0 + std::exp(-x)) / x; };
  // The variances given (k^2, tau, sigma_p^2), the mean by weighted least squares over the parts'
  // regressors, and the negative log-likelihood.
  const auto evaluate = [&](Parts parts, double k2, double tau_s, double p2) {
    Result r{0.0, 0.0, 0.0, k2, tau_s, p2};
    Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
    Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
    std::vector<double> variance(windows.size());
    for (std::size_t i = 0; i < windows.size(); ++i) {
      if (!used[i]) continue;
      const Window& x = windows[i];
      variance[i] = std::max(k2 * x.distance * g(x.w_s / tau_s) + 2.0 * p2, 1e-300);
      const Eigen::Vector2d h(parts.crab ? x.along : 0.0, parts.cornering ? -x.turn : 0.0);
      normal += h * h.transpose() / variance[i];
      rhs += h * x.across / variance[i];
    }
    for (int j = 0; j < 2; ++j)
      if (normal(j, j) == 0.0) normal(j, j) = 1.0;  // a part left out: its coefficient stays 0
    const Eigen::Vector2d beta = normal.ldlt().solve(rhs);
    r.tan_crab = beta(0);
    r.c = beta(1);
    for (std::size_t i = 0; i < windows.size(); ++i) {
      if (!used[i]) continue;
      const Window& x = windows[i];
      const double e = x.across - r.tan_crab * x.along + r.c * x.turn;
      r.nll += 0.5 * (std::log(variance[i]) + e * e / variance[i]);
    }
    return r;
  };
  // The noise's scale from the windows themselves: sigma_p^2 starts at a tenth of the shortest
  // windows' mean square, k^2 at the longest's per metre.
  double short_square = 0.0, long_per_m = 0.0;
  std::size_t n_short = 0, n_long = 0;
  for (const Window& x : windows) {
    if (x.w_s == kWindowsS[0]) short_square += x.across * x.across, ++n_short;
    if (x.w_s == kWindowsS[3] && x.distance > 0.0)
      long_per_m += x.across * x.across / x.distance, ++n_long;
  }
  short_square =
      std::max(short_square / static_cast<double>(std::max<std::size_t>(n_short, 1)), 1e-12);
  long_per_m = std::max(long_per_m / static_cast<double>(std::max<std::size_t>(n_long, 1)), 1e-12);
  const auto fit_parts = [&](Parts parts) {
    if (!parts.wander) {
      const MinimizeResult m = minimize_restarted(
          [&](const std::vector<double>& p) {
            return evaluate(parts, 0.0, 1.0, std::exp(p[0])).nll;
          },
          {std::log(0.5 * short_square)}, 1.0);
      return evaluate(parts, 0.0, 1.0, std::exp(m.x[0]));
    }
    const auto at = [&](const std::vector<double>& p) {
      return evaluate(parts, std::exp(p[0]), std::exp(p[1]), std::exp(p[2]));
    };
    // tau from 0.1 to 100 s: started at 1 s, the simplex steps by e.
    const MinimizeResult m = minimize_restarted(
        [&](const std::vector<double>& p) {
          return std::abs(p[1]) > std::log(1000.0) ? 1e300 : at(p).nll;
        },
        {std::log(long_per_m), 0.0, std::log(0.1 * short_square)}, 1.0);
    return at(m.x);
  };
  const Parts all{true, true, true};
  Result full = fit_parts(all);
  // Once: windows beyond 5 sigma of the full fit are the truth's jumps, not the robot's motion.
  for (std::size_t i = 0; i < windows.size(); ++i) {
    const Window& x = windows[i];
    const double variance = full.k2 * x.distance * g(x.w_s / full.tau_s) + 2.0 * full.p2;
    const double e = x.across - full.tan_crab * x.along + full.c * x.turn;
    if (e * e > 25.0 * variance) used[i] = 0, ++fit.dropped;
  }
  if (fit.dropped > 0) full = fit_parts(all);
  fit.windows = windows.size() - fit.dropped;
  const double penalty = 0.5 * std::log(static_cast<double>(fit.windows));
  const Result no_crab = fit_parts({false, true, true});
  const Result no_cornering = fit_parts({true, false, true});
  const Result no_wander = fit_parts({true, true, false});
  fit.crab_gain = no_crab.nll - full.nll;
  fit.cornering_gain = no_cornering.nll - full.nll;
  fit.wander_gain = no_wander.nll - full.nll;
  // The parts kept, refitted without those that are not.
  const Parts kept{fit.crab_gain > penalty, fit.cornering_gain > penalty,
                   fit.wander_gain > 2.0 * penalty};
  const Result best = fit_parts(kept);
  fit.crab_angle_rad = kept.crab ? std::atan(best.tan_crab) : 0.0;
  fit.cornering_compliance_s = kept.cornering ? best.c : 0.0;
  fit.wander_k = kept.wander ? std::sqrt(best.k2) : 0.0;
  fit.wander_correlation_s = kept.wander ? best.tau_s : 1.0;
  // Below a micrometre (a simulated truth): none.
  fit.truth_noise_m = best.p2 > 1e-12 ? std::sqrt(best.p2) : 0.0;
  return fit;
}

/// The robot's odometry as a base that follows `response` would move (sdk::CommandFollower, as
/// a localizer with command_* runs it): velocity readings at the same times, the pose integrated
/// through the response.
std::vector<std::pair<double, locsim_odometry>> followed(const RobotLog& robot,
                                                         const CommandResponseFit& fit) {
  sdk::CommandFollower follower(sdk::CommandResponse{fit.dead_time_s, fit.time_constant_v_s,
                                                     fit.time_constant_omega_s, fit.gain_v,
                                                     fit.gain_omega});
  std::vector<std::pair<double, locsim_odometry>> out;
  out.reserve(robot.odometry.size());
  for (const auto& [t_s, o] : robot.odometry) out.emplace_back(t_s, follower.follow(t_s, o));
  return out;
}

/// The command response and, when it leads, the wheel noise of what it leaves, measured where a
/// simulated base that reports its command adds it: on the command. The odometry times the
/// gain against the truth run backwards through the response (TruthView) leaves the gain times
/// that noise, whose variance grows with the gain times the distance: k over sqrt(gain).
void fit_command(const std::vector<RobotLog>& robots, MotionCalibration& m) {
  m.command = fit_command_response(robots);
  if (!m.command || !m.command->leads) return;
  fit_gain_wander(robots, *m.command);
  CommandResponseFit gain_only;
  gain_only.gain_v = m.command->gain_v;
  gain_only.gain_omega = m.command->gain_omega;
  std::vector<MotionSample> samples;
  for (const RobotLog& robot : robots) {
    collect_motion(robot, followed(robot, gain_only), TruthView{robot.truth, &*m.command}, samples);
  }
  if (samples.size() < 10) return;
  MotionCalibration residual;
  fit_wheel_model(samples, residual);
  m.command->k_left = residual.k_left / std::sqrt(m.command->gain_v);
  m.command->k_right = residual.k_right / std::sqrt(m.command->gain_v);
  if (auto wheels = fit_correlated_wheels(samples, residual)) {
    wheels->k_left /= std::sqrt(m.command->gain_v);
    wheels->k_right /= std::sqrt(m.command->gain_v);
    m.command->correlated_wheels = wheels;
  }
  // What a localizer that follows the response (command_*) is left with: its odometry through
  // the whole response against the truth, over the same intervals as the raw odometry's fit.
  std::vector<MotionSample> through;
  for (const RobotLog& robot : robots)
    collect_motion(robot, followed(robot, *m.command), TruthView{robot.truth}, through);
  if (through.size() < 10) return;
  MotionCalibration localizer;
  fit_wheel_model(through, localizer);
  // The same over 2, 4, 8 steps: white noise would keep k; errors correlated from step to step
  // make it grow (a filter that takes the one-step k is then overconfident over longer spans).
  for (const std::size_t stride : {2, 4, 8}) {
    std::vector<MotionSample> longer;
    for (const RobotLog& robot : robots)
      collect_motion(robot, followed(robot, *m.command), TruthView{robot.truth}, longer, stride);
    if (longer.size() < 10) break;
    MotionCalibration fit;
    fit_wheel_model(longer, fit);
    double mean_s = 0.0;
    for (const MotionSample& x : longer) mean_s += x.dt_s / static_cast<double>(longer.size());
    m.command->localizer_by_span.push_back({stride, mean_s, fit.k_left, fit.k_right});
  }
  m.command->localizer =
      WheelModelFit{localizer.k_left, localizer.k_right, localizer.k_floor_position_m,
                    localizer.k_floor_heading_rad, localizer.k_mean_nees};
}

json line_json(const LineFit& line, const char* at_zero, const char* per_unit) {
  return {{at_zero, line.at_zero}, {per_unit, line.per_unit}};
}

json model_json(const OdometryModelFit& f) {
  return {{"alpha1", f.alpha1},
          {"alpha2", f.alpha2},
          {"alpha3", f.alpha3},
          {"alpha4", f.alpha4},
          {"floor_position_m", f.floor_position_m},
          {"floor_heading_rad", f.floor_heading_rad},
          {"log_likelihood", f.log_likelihood}};
}

std::string four_digits(double value) {
  return rounded_number(value, 4);
}

/// The encoders' k_left, k_right (and k_correlation) keys: the correlated fit's when there is
/// one, else the independent wheels'.
std::string wheel_noise(double k_left, double k_right,
                        const std::optional<CorrelatedWheels>& correlated) {
  if (correlated) {
    return "k_left: " + four_digits(correlated->k_left) +
           ", k_right: " + four_digits(correlated->k_right) +
           ", k_correlation: " + four_digits(correlated->k_correlation);
  }
  return "k_left: " + four_digits(k_left) + ", k_right: " + four_digits(k_right);
}

/// The beam model's parameters by EM on the simulated sensor's mixture. Per beam with a mapped
/// range z* within the maximum M: a hit N(z*, sigma) (weight p_hit), a short reading from
/// something unmapped in front, exponential of rate lambda on [0, z*) and the hit itself when the
/// exponential falls beyond it (weight p_short; the sensor returns the nearer), M itself (p_max),
/// uniform on [0, M] (p_random). With nothing mapped within M the hit reads M, and the short
/// reading's exponential is cut at M. A reading at M is a probability, any other a density; every
/// beam is one or the other whatever the parameters, so the likelihood is well defined.
LaserCalibration fit_laser(const LaserData& data) {
  LaserCalibration out;
  out.scans = data.scans;
  out.beams = data.beams.size();
  out.max_range_m = data.max_range_m;
  const double M = data.max_range_m;
  const auto at_max = [&](const BeamSample& b) { return b.measured_m >= static_cast<float>(M); };
  for (const BeamSample& b : data.beams) out.beams_mapped += std::isfinite(b.mapped_m) ? 1 : 0;
  double p_hit = 0.91, p_short = 0.03, p_max = 0.03, p_random = 0.03;
  double sigma = 0.05 * M / 8.0, lambda = 1.0;
  const double sqrt_2pi = std::sqrt(2.0 * std::numbers::pi);
  double previous = -std::numeric_limits<double>::infinity();
  for (out.iterations = 1; out.iterations <= 500; ++out.iterations) {
    // Expected counts of each branch; the hit's and the short's exact-hit share carry the error,
    // the short's continuous share its range (and the exact hit's, beyond which it fell).
    double n_hit = 0, n_short = 0, n_max = 0, n_random = 0;
    double noisy = 0, noisy_e2 = 0, short_cont = 0, short_length = 0;
    double log_likelihood = 0.0;
    for (const BeamSample& b : data.beams) {
      const double z = b.measured_m;
      const bool mapped = std::isfinite(b.mapped_m) && b.mapped_m < M;
      const double zs = mapped ? static_cast<double>(b.mapped_m) : M;  // where the short is cut
      const double beyond = std::exp(-lambda * zs);  // the exponential falls beyond the cut
      double hit = 0, cont = 0, atom = 0, mx = 0, rnd = 0;
      if (at_max(b)) {
        mx = p_max;
        if (mapped) {
          hit = p_hit * 0.5 * std::erfc((M - zs) / (sigma * std::sqrt(2.0)));
        } else {
          hit = p_hit;
          atom = p_short * beyond;
        }
      } else {
        rnd = p_random / M;
        if (z < zs) cont = p_short * lambda * std::exp(-lambda * z);
        if (mapped) {
          const double e = (z - zs) / sigma;
          const double g = std::exp(-0.5 * e * e) / (sigma * sqrt_2pi);
          hit = p_hit * g;
          atom = p_short * beyond * g;
        }
      }
      const double total = hit + cont + atom + mx + rnd;
      if (!(total > 0.0)) continue;
      log_likelihood += std::log(total);
      const double r_hit = hit / total, r_cont = cont / total, r_atom = atom / total;
      n_hit += r_hit, n_short += r_cont + r_atom, n_max += mx / total, n_random += rnd / total;
      if (mapped && !at_max(b)) {
        const double e2 = (z - zs) * (z - zs);
        noisy += r_hit + r_atom, noisy_e2 += (r_hit + r_atom) * e2;
      }
      short_cont += r_cont, short_length += r_cont * z + r_atom * zs;
    }
    const double n = n_hit + n_short + n_max + n_random;
    if (!(n > 0.0)) break;
    p_hit = n_hit / n, p_short = n_short / n, p_max = n_max / n, p_random = n_random / n;
    if (noisy > 0.0) sigma = std::max(std::sqrt(noisy_e2 / noisy), 1e-6);
    if (short_length > 0.0 && short_cont > 0.0)
      lambda = std::clamp(short_cont / short_length, LaserDef::kLambdaShortRange.min,
                          LaserDef::kLambdaShortRange.max);
    out.log_likelihood = log_likelihood / n;
    if (log_likelihood - previous < 1e-9 * std::abs(log_likelihood)) break;
    previous = log_likelihood;
  }
  out.sigma_m = sigma, out.lambda_short = lambda;
  out.p_short = p_short, out.p_max = p_max, out.p_random = p_random;
  // The hits' mean error: a map drawn a few centimetres off shows here, not in the fit.
  double sum = 0, weight = 0;
  for (const BeamSample& b : data.beams) {
    if (!std::isfinite(b.mapped_m) || b.mapped_m >= M || at_max(b)) continue;
    const double e = static_cast<double>(b.measured_m) - b.mapped_m;
    if (std::abs(e) > 3.0 * sigma) continue;
    sum += e, weight += 1.0;
  }
  out.hit_bias_m = weight > 0.0 ? sum / weight : 0.0;
  return out;
}

/// The ranges' bias line and spread, as the detections' (fit_camera): outliers against the median
/// and MAD of each bin of true range (the bias grows with range), then the least-squares line
/// through the inliers and their standard deviation about it; the long outliers' excess (echoes)
/// for the simulated sensor's non-line-of-sight path; each beacon's mean residual about the line;
/// the errors' time constant over consecutive ranges to a beacon.
RangingCalibration fit_ranging(RangingData& data, const CalibrationOptions& options) {
  RangingCalibration c;
  std::vector<RangeSample>& r = data.samples;
  c.readings = data.readings;
  c.ranges = r.size();
  c.beacons = data.beacons.size();
  c.ranges_per_reading =
      data.receiver_readings > 0
          ? static_cast<double>(r.size()) / static_cast<double>(data.receiver_readings)
          : 0.0;
  std::vector<std::size_t> order(r.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return r[a].true_m < r[b].true_m; });
  std::vector<double> bin_median(r.size());
  for (const auto& [begin, end] : equal_bins(order.size(), options.range_bins)) {
    std::vector<double> e;
    for (std::size_t i = begin; i < end; ++i) e.push_back(r[order[i]].error_m);
    const double m = median(e);
    for (double& v : e) v = std::abs(v - m);
    const double sigma = std::max(1.4826 * median(e), 1e-9);
    for (std::size_t i = begin; i < end; ++i) {
      RangeSample& x = r[order[i]];
      x.inlier = std::abs(x.error_m - m) <= options.outlier_sigmas * sigma;
      bin_median[order[i]] = m;
    }
  }
  std::vector<double> x, y;
  for (const std::size_t i : order) {
    if (r[i].inlier) x.push_back(r[i].true_m), y.push_back(r[i].error_m);
  }
  c.inliers = x.size();
  if (x.empty()) return c;
  c.bias_m = fit_line(x, y);
  double about_line = 0.0, about_zero = 0.0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    about_line += std::pow(y[k] - c.bias_m.at(x[k]), 2);
    about_zero += y[k] * y[k];
  }
  const double n = static_cast<double>(x.size());
  c.spread_m = std::sqrt(about_line / std::max(1.0, n - 2.0));
  c.rms_m = std::sqrt(about_zero / n);
  std::vector<double> excess;
  for (const RangeSample& s : r) {
    if (s.inlier) continue;
    const double beyond = s.error_m - c.bias_m.at(s.true_m);
    if (beyond > 0.0) {
      ++c.long_outliers;
      excess.push_back(beyond);
    } else {
      ++c.short_outliers;
    }
  }
  c.outlier_share = static_cast<double>(r.size() - c.inliers) / static_cast<double>(r.size());
  if (excess.size() >= 5) {
    c.excess_min_m = *std::min_element(excess.begin(), excess.end());
    c.excess_mean_m =
        std::accumulate(excess.begin(), excess.end(), 0.0) / static_cast<double>(excess.size());
  }
  std::map<int, RangingCalibration::Beacon> beacons;
  std::map<int, double> sum2;
  for (const RangeSample& s : r) {
    if (!s.inlier) continue;
    RangingCalibration::Beacon& b = beacons[s.beacon];
    b.id = s.beacon;
    const double e = s.error_m - c.bias_m.at(s.true_m);
    ++b.inliers;
    b.mean_residual_m += e;
    sum2[s.beacon] += e * e;
  }
  for (auto& [id, b] : beacons) {
    const double count = static_cast<double>(b.inliers);
    b.mean_residual_m /= count;
    b.spread_m = std::sqrt(std::max(0.0, sum2[id] / count - b.mean_residual_m * b.mean_residual_m));
    c.by_beacon.push_back(b);
  }
  std::vector<std::size_t> kept;
  for (const std::size_t i : order)
    if (r[i].inlier) kept.push_back(i);
  for (const auto& [begin, end] : equal_bins(kept.size(), options.range_bins)) {
    RangingCalibration::Bin bin;
    bin.count = end - begin;
    double s = 0.0, e = 0.0, ee = 0.0;
    for (std::size_t k = begin; k < end; ++k) {
      const RangeSample& v = r[kept[k]];
      const double about = v.error_m - c.bias_m.at(v.true_m);
      s += v.true_m, e += about, ee += about * about;
    }
    const double count = static_cast<double>(bin.count);
    bin.range_m = s / count;
    bin.mean_residual_m = e / count;
    bin.spread_m = std::sqrt(std::max(0.0, ee / count - bin.mean_residual_m * bin.mean_residual_m));
    c.bins.push_back(bin);
  }
  // The samples are in the logs' order, each robot's in time.
  std::vector<ErrorPair> pairs;
  std::map<std::pair<std::size_t, int>, std::size_t> last;  // (track, beacon) -> index
  const auto z = [&](const RangeSample& s) {
    return (s.error_m - c.bias_m.at(s.true_m)) / std::max(c.spread_m, 1e-9);
  };
  for (std::size_t i = 0; i < r.size(); ++i) {
    if (!r[i].inlier) continue;
    const auto key = std::pair{r[i].track, r[i].beacon};
    if (const auto found = last.find(key); found != last.end()) {
      const RangeSample& p = r[found->second];
      const double dt = r[i].t_s - p.t_s;
      if (dt > 0.0 && dt <= kMaxCorrelationGapS) pairs.push_back({dt, z(p), z(r[i]), 0.0, 0.0});
    }
    last[key] = i;
  }
  if (pairs.size() >= 20) {
    c.noise_correlation_s = single_time_constant(pairs, 1).tau_s;
    c.noise_correlation_pairs = pairs.size();
  }
  std::vector<std::vector<double>> times;
  for (const auto& [track, t] : data.reading_times_s) times.push_back(t);
  c.outages = fit_outages(times);
  return c;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
OutageFit fit_outages(const std::vector<std::vector<double>>& reading_times_s) {
  OutageFit fit;
  std::vector<double> intervals_s;
  double span_s = 0.0;
  for (const std::vector<double>& times : reading_times_s) {
    for (std::size_t k = 1; k < times.size(); ++k) {
      if (times[k] > times[k - 1]) intervals_s.push_back(times[k] - times[k - 1]);
    }
    if (times.size() >= 2) span_s += times.back() - times.front();
  }
  if (intervals_s.empty() || span_s <= 0.0) return fit;
  std::vector<double> sorted = intervals_s;
  const auto middle = sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2);
  std::nth_element(sorted.begin(), middle, sorted.end());
  fit.median_interval_s = *middle;
  // A spell silences the interval less one median; those shorter than the threshold less that
  // median, tau, pass for dropped readings. Spells exponential in length (as the simulator draws
  // them) beyond tau are tau plus the whole mean: the mean is their excess over tau, and the
  // spells not seen are exp(tau / mean) times as many as those seen, less those.
  const double tau_s = (OutageFit::kPeriods - 1.0) * fit.median_interval_s;
  double excess_s = 0.0;
  std::size_t count = 0;
  for (const double dt : intervals_s) {
    if (dt - fit.median_interval_s > tau_s) {
      excess_s += dt - fit.median_interval_s - tau_s;
      ++count;
    }
  }
  if (count < OutageFit::kMinOutages || excess_s <= 0.0) return fit;
  fit.outages = count;
  fit.mean_s = std::max(excess_s / static_cast<double>(count), SensorCommon::kOutageMeanRange.min);
  const double all_spells =
      static_cast<double>(count) * std::exp(std::min(tau_s / fit.mean_s, 10.0));
  fit.fraction = std::min(all_spells * fit.mean_s / span_s, SensorCommon::kOutageFractionRange.max);
  return fit;
}

// ---------------------------------------------------------------------------------------------
Calibration calibrate(const std::vector<std::filesystem::path>& logs,
                      const CalibrationOptions& options) {
  if (logs.empty()) throw InputError("calibrate: give at least one log");
  Calibration out;
  Pooled pooled;
  std::vector<RobotLog> used_robots;  // of every log, for the fits over robots' whole logs
  std::set<std::string> unused(options.robots.begin(), options.robots.end());
  for (const std::filesystem::path& file : logs) {
    LogSource source(file);
    const WorldDef& world = source.world();
    std::vector<RobotLog> robots(world.robots.size());
    std::vector<std::optional<ReadingTranslator>> translators(world.robots.size());
    std::vector<std::string> names;
    for (std::size_t i = 0; i < world.robots.size(); ++i) {
      const RobotDef& def = world.robots[i];
      robots[i].def = def;
      if (options.robots.empty() || std::find(options.robots.begin(), options.robots.end(),
                                              def.name) != options.robots.end()) {
        translators[i].emplace(def);
        names.push_back(def.name);
        unused.erase(def.name);
      }
    }
    Record record;
    while (source.next(record)) {
      const int index = record.type == Record::Type::kReading ? record.reading.robot : record.robot;
      if (index < 0 || !translators[static_cast<std::size_t>(index)]) continue;
      RobotLog& robot = robots[static_cast<std::size_t>(index)];
      switch (record.type) {
        case Record::Type::kGroundTruth:
          if (truth_known(record.pose)) robot.truth.add(record.t_s, record.pose);
          break;
        case Record::Type::kEvent:
          if (record.event.kind == "kidnap" || record.event.kind == "put_down")
            robot.truth.cut(record.event.t_s);
          break;
        case Record::Type::kReading:
          if (record.reading.kind == SensorKind::kEncoders) {
            const locsim_reading& translated =
                translators[static_cast<std::size_t>(index)]->translate(record.reading);
            robot.odometry.emplace_back(record.reading.t_s, translated.data.odometry);
          } else if (record.reading.kind == SensorKind::kLaser) {
            // Every stride-th beam: a scan's neighbouring beams see nearly the same, and memory
            // stays bounded on long recordings of dense scanners.
            const auto& ranges = std::get<LaserScan>(record.reading.data).ranges_m;
            robot.scan_stride =
                std::max<std::size_t>(1, (ranges.size() + LaserCalibration::kMaxBeamsPerScan - 1) /
                                             LaserCalibration::kMaxBeamsPerScan);
            RobotLog::Scan scan{record.reading.t_s, {}};
            for (std::size_t b = 0; b < ranges.size(); b += robot.scan_stride)
              scan.ranges_m.push_back(ranges[b]);
            robot.scans.push_back(std::move(scan));
          } else if (record.reading.kind == SensorKind::kUltrasonic) {
            robot.rounds.push_back(
                {record.reading.t_s, std::get<UltrasonicReading>(record.reading.data).ranges});
          } else if (const auto* detections = detections_of(record.reading.data)) {
            robot.seen.push_back({record.reading.t_s, record.reading.kind, *detections});
          }
          break;
        case Record::Type::kEnd:
          break;
      }
    }
    const PhysicsWorld physics(world);
    const StaticRaycaster walls = StaticRaycaster::from_world(physics);
    std::string used;
    for (std::size_t i = 0; i < robots.size(); ++i) {
      if (!translators[i]) continue;
      RobotLog& robot = robots[i];
      robot.truth.finish();
      if (robot.truth.empty()) {
        throw InputError(file.string() + ": robot '" + robot.def.name +
                         "' has no ground truth: calibrating needs the true path");
      }
      robot.steps = perception_steps(robot, world);
      const std::size_t first_sample = pooled.motion.size();
      collect_motion(robot, robot.odometry, TruthView{robot.truth}, pooled.motion);
      for (std::size_t k = first_sample; k < pooled.motion.size(); ++k)
        pooled.motion[k].track = pooled.tracks;
      collect_ranges(robot, world, pooled.tracks, pooled.ranging);
      collect_beams(robot, walls, pooled.laser);
      robot.scans.clear();
      robot.scans.shrink_to_fit();
      collect_detections(robot, world, walls, pooled);
      used_robots.push_back(std::move(robot));
    }
    std::string list;
    for (const std::string& name : names) list += (list.empty() ? "" : ", ") + name;
    out.sources.push_back(file.string() + " (" + list + ")");
  }
  if (!unused.empty()) {
    throw InputError("calibrate --robots: no robot named '" + *unused.begin() +
                     "' in any of the logs");
  }
  if (pooled.motion.size() >= 10) {
    out.motion = fit_motion(pooled.motion);
    fit_command(used_robots, *out.motion);
    out.motion->side_slip = fit_side_slip(used_robots);
    // Not for a base that reports its command: the heading's errors are the response's.
    if (!out.motion->command || !out.motion->command->leads)
      out.motion->heading = fit_heading(pooled.motion);
  }
  for (auto& [kind, data] : pooled.cameras) {
    if (data.residuals.size() >= 10)
      out.cameras.push_back(fit_camera(kind, data, options, pooled.track_names, pooled.camera_cells,
                                       pooled.motion, localizer_motion(out.motion)));
  }
  if (pooled.ranging.samples.size() >= 10) out.ranging = fit_ranging(pooled.ranging, options);
  // The laser's model needs beams that hit something mapped (the hits' noise, what is short of
  // them) and enough of them.
  std::size_t mapped = 0;
  for (const BeamSample& b : pooled.laser.beams) mapped += std::isfinite(b.mapped_m) ? 1 : 0;
  if (mapped >= 100) out.laser = fit_laser(pooled.laser);
  if (!out.motion && out.cameras.empty() && !out.ranging && !out.laser) {
    throw InputError(
        "calibrate: nothing to measure: fewer than 10 odometry intervals between detections of "
        "landmarks on the map (or ranges to beacons), fewer than 10 such detections or ranges "
        "with a true pose, and fewer than 100 laser beams that hit a mapped wall");
  }
  return out;
}

json Calibration::to_json() const {
  json j;
  j["sources"] = sources;
  if (motion) {
    const MotionCalibration& m = *motion;
    j["motion"] = {{"intervals", m.intervals},
                   {"mean_interval_s", m.mean_interval_s},
                   {"mean_travel_m", m.mean_travel_m},
                   {"odometry_model",
                    {{"standard_deviation_form", model_json(m.odometry_std)},
                     {"variance_form", model_json(m.odometry_variance)},
                     {"chosen", m.variance_form ? "variance_form" : "standard_deviation_form"}}},
                   {"wheel_model",
                    {{"k_left", m.k_left},
                     {"k_right", m.k_right},
                     {"floor_position_m", m.k_floor_position_m},
                     {"floor_heading_rad", m.k_floor_heading_rad},
                     {"log_likelihood", m.k_log_likelihood},
                     {"mean_nees", m.k_mean_nees}}}};
    const auto correlated_json = [](const CorrelatedWheels& w) {
      return json{{"k_left", w.k_left},
                  {"k_right", w.k_right},
                  {"k_correlation", w.k_correlation},
                  {"log_likelihood_gain", w.gain_nats}};
    };
    if (const auto& w = m.correlated_wheels)
      j["motion"]["wheel_model"]["correlated"] = correlated_json(*w);
    if (const auto& h = m.heading) {
      j["motion"]["heading"] = {{"source", h->gyro ? "gyro" : "wheels"},
                                {"wheels_log_likelihood", h->wheels_log_likelihood},
                                {"gyro_log_likelihood", h->gyro_log_likelihood},
                                {"gyro_bias_radps", h->bias_radps},
                                {"gyro_bias_sigma", h->bias_sigma},
                                {"gyro_bias_by_robot_radps", h->bias_by_track_radps},
                                {"gyro_bias_walk", h->bias_walk},
                                {"gyro_scale_error", h->scale_error},
                                {"gyro_noise_density", h->noise_density},
                                {"gyro_floor_rad", h->floor_rad},
                                {"distance_k", h->distance_k},
                                {"distance_floor_m", h->distance_floor_m}};
    }
    if (const auto& d = m.side_slip) {
      j["motion"]["side_slip"] = {{"crab_angle_deg", rad_to_deg(d->crab_angle_rad)},
                                  {"cornering_compliance_s", d->cornering_compliance_s},
                                  {"wander_k", d->wander_k},
                                  {"wander_correlation_s", d->wander_correlation_s},
                                  {"truth_noise_m", d->truth_noise_m},
                                  {"windows", d->windows},
                                  {"dropped_windows", d->dropped},
                                  {"distance_m", d->distance_m},
                                  {"crab_log_likelihood_gain", d->crab_gain},
                                  {"cornering_log_likelihood_gain", d->cornering_gain},
                                  {"wander_log_likelihood_gain", d->wander_gain}};
    }
    if (m.velocity) {
      j["motion"]["velocity_model"] = model_json(*m.velocity);
      j["motion"]["velocity_model"]["intervals"] = m.velocity_intervals;
    }
    if (const auto& c = m.command) {
      j["motion"]["command_response"] = {
          {"seconds", c->seconds},
          {"dead_time_s", c->dead_time_s},
          {"time_constant_v_s", c->time_constant_v_s},
          {"time_constant_omega_s", c->time_constant_omega_s},
          {"gain_v", c->gain_v},
          {"gain_omega", c->gain_omega},
          {"residual_variance_share", {{"v", c->residual_v}, {"omega", c->residual_omega}}},
          {"gain_only_residual_variance_share",
           {{"v", c->residual_gain_only_v}, {"omega", c->residual_gain_only_omega}}},
          {"leads", c->leads}};
      if (c->k_left) {
        j["motion"]["command_response"]["k_left"] = *c->k_left;
        j["motion"]["command_response"]["k_right"] = *c->k_right;
      }
      if (const auto& w = c->correlated_wheels)
        j["motion"]["command_response"]["correlated_wheels"] = correlated_json(*w);
      if (const auto& w = c->localizer) {
        j["motion"]["command_response"]["localizer_wheel_model"] = {
            {"k_left", w->k_left},
            {"k_right", w->k_right},
            {"floor_position_m", w->floor_position_m},
            {"floor_heading_rad", w->floor_heading_rad},
            {"mean_nees", w->mean_nees}};
        json spans = json::array();
        for (const auto& span : c->localizer_by_span) {
          spans.push_back({{"steps", span.steps},
                           {"mean_interval_s", span.mean_interval_s},
                           {"k_left", span.k_left},
                           {"k_right", span.k_right}});
        }
        j["motion"]["command_response"]["localizer_wheel_model"]["over_steps"] = spans;
      }
      for (const auto& [name, wander] :
           {std::pair{"v", &c->gain_wander_v}, std::pair{"omega", &c->gain_wander_omega}}) {
        if (!*wander) continue;
        json windows = json::array();
        for (const auto& w : (*wander)->windows)
          windows.push_back({{"window_s", w.window_s}, {"sd", w.sd}, {"count", w.count}});
        j["motion"]["command_response"]["gain_wander"][name] = {
            {"sigma", (*wander)->sigma},
            {"correlation_s", (*wander)->correlation_s},
            {"log_likelihood_gain", (*wander)->log_likelihood_gain},
            {"windows", windows}};
      }
    }
  }
  j["cameras"] = json::array();
  for (const DetectionCalibration& c : cameras) {
    json cj = {{"camera", c.camera},
               {"readings", c.readings},
               {"detections", c.detections},
               {"inliers", c.inliers},
               {"false_detections", c.false_detections},
               {"false_per_reading", c.false_per_reading},
               {"range_bias", line_json(c.range_bias_m, "m", "per_m")},
               {"range_spread", line_json(c.range_spread_m, "m", "per_m")},
               {"range_rms", line_json(c.range_rms_m, "m", "per_m")},
               {"bearing_bias_rad", c.bearing_bias_rad},
               {"bearing_spread_rad", c.bearing_spread_rad},
               {"bearing_rms_rad", c.bearing_rms_rad}};
    if (c.distance_model && c.depth_model) {
      const auto model = [](const RangeModelFit& f) {
        return json{{"bias", line_json(f.bias_m, "m", "per_m")},
                    {"spread", line_json(f.spread_m, "m", "per_m")},
                    {"residual_rms_m", f.residual_rms_m}};
      };
      cj["range_models"] = {{"distance", model(*c.distance_model)},
                            {"depth", model(*c.depth_model)},
                            {"chosen", c.range_model}};
    }
    if (c.miss_probability) {
      cj["visible"] = *c.visible;
      cj["missed"] = *c.missed;
      cj["miss_probability"] = *c.miss_probability;
    }
    if (const auto& decay = c.detection_decay) {
      cj["detection_decay"] = {{"miss_probability_at_zero", decay->miss_probability_at_zero},
                               {"decay_m", decay->decay_m},
                               {"gain_nats", decay->gain_nats},
                               {"conditioned_on_a_detection", decay->conditioned}};
    }
    if (c.srl_threshold) {
      cj["tracking_step_likelihood"] = {
          {"median", *c.step_likelihood_median},
          {"quantile", *c.reset_quantile},
          {"srl_threshold", *c.srl_threshold},
          {"asrl_p_t", *c.asrl_p_t},
          {"augmented_injection_level", *c.augmented_injection_level}};
    }
    if (c.outlier_likelihood) cj["outlier_likelihood"] = *c.outlier_likelihood;
    if (c.noise_correlation_s) {
      cj["noise_correlation"] = {{"tau_s", *c.noise_correlation_s},
                                 {"pairs", c.noise_correlation_pairs}};
      if (const auto& two = c.noise_correlation_two) {
        cj["noise_correlation"]["two_time_constants"] = {{"fast_s", two->fast_s},
                                                         {"slow_s", two->slow_s},
                                                         {"slow_share", two->slow_share},
                                                         {"log_likelihood_gain", two->gain_nats}};
      }
      if (const auto& apart = c.channel_correlations) {
        const auto process = [](const DetectionCalibration::TwoCorrelations& p) {
          return json{{"fast_s", p.fast_s}, {"slow_s", p.slow_s}, {"slow_share", p.slow_share}};
        };
        cj["noise_correlation"]["range_and_bearing_apart"] = {
            {"range", process(apart->range)},
            {"bearing", process(apart->bearing)},
            {"log_likelihood_gain", apart->gain_nats}};
      }
    }
    if (!c.camera_offsets.empty()) {
      cj["camera_offsets"] = json::array();
      for (const CameraOffset& o : c.camera_offsets) {
        cj["camera_offsets"].push_back({{"robot", o.robot},
                                        {"x_m", o.x_m},
                                        {"y_m", o.y_m},
                                        {"sd_x_m", o.sd_x_m},
                                        {"sd_y_m", o.sd_y_m},
                                        {"correlation", o.correlation},
                                        {"bearing_bias_rad", o.bearing_bias_rad},
                                        {"detections", o.detections},
                                        {"blocks", o.blocks},
                                        {"wald", o.wald},
                                        {"significant", o.significant}});
      }
    }
    if (const auto& silent = c.silences) {
      cj["silences"] = {{"cells", silent->cells},
                        {"cell_s", silent->cell_s},
                        {"rate_per_landmark_hz", silent->rate_hz},
                        {"outage_fraction", silent->fraction},
                        {"outage_mean_s", silent->mean_s},
                        {"outage_long_share", silent->long_share},
                        {"outage_long_mean_s", silent->long_mean_s},
                        {"log_likelihood_gain", silent->gain_nats},
                        {"long_log_likelihood_gain", silent->long_gain_nats},
                        {"significant", silent->significant}};
    }
    if (const auto& placed = c.from_camera_places) {
      cj["from_camera_places"] = {{"bearing_bias_rad", placed->bearing_bias_rad},
                                  {"bearing_spread_rad", placed->bearing_spread_rad}};
    }
    cj["bins"] = json::array();
    for (const RangeBin& b : c.bins) {
      cj["bins"].push_back({{"count", b.count},
                            {"range_m", b.range_m},
                            {"range_error_mean_m", b.range_error_mean_m},
                            {"range_error_std_m", b.range_error_std_m},
                            {"range_error_rms_m", b.range_error_rms_m},
                            {"bearing_error_mean_rad", b.bearing_error_mean_rad},
                            {"bearing_error_std_rad", b.bearing_error_std_rad}});
    }
    j["cameras"].push_back(cj);
  }
  if (ranging) {
    const RangingCalibration& r = *ranging;
    json rj = {{"readings", r.readings},
               {"ranges", r.ranges},
               {"beacons", r.beacons},
               {"ranges_per_reading", r.ranges_per_reading},
               {"inliers", r.inliers},
               {"long_outliers", r.long_outliers},
               {"short_outliers", r.short_outliers},
               {"outlier_share", r.outlier_share},
               {"range_bias", line_json(r.bias_m, "m", "per_m")},
               {"spread_m", r.spread_m},
               {"rms_m", r.rms_m}};
    if (r.excess_min_m)
      rj["outlier_excess"] = {{"min_m", *r.excess_min_m}, {"mean_m", *r.excess_mean_m}};
    if (r.noise_correlation_s) {
      rj["noise_correlation"] = {{"tau_s", *r.noise_correlation_s},
                                 {"pairs", r.noise_correlation_pairs}};
    }
    rj["outages"] = {{"count", r.outages.outages},
                     {"fraction", r.outages.fraction},
                     {"mean_s", r.outages.mean_s},
                     {"median_interval_s", r.outages.median_interval_s}};
    rj["by_beacon"] = json::array();
    for (const auto& b : r.by_beacon) {
      rj["by_beacon"].push_back({{"id", b.id},
                                 {"inliers", b.inliers},
                                 {"mean_residual_m", b.mean_residual_m},
                                 {"spread_m", b.spread_m}});
    }
    rj["bins"] = json::array();
    for (const auto& b : r.bins) {
      rj["bins"].push_back({{"count", b.count},
                            {"range_m", b.range_m},
                            {"mean_residual_m", b.mean_residual_m},
                            {"spread_m", b.spread_m}});
    }
    j["ranging"] = rj;
  }
  if (laser) {
    const LaserCalibration& l = *laser;
    j["laser"] = {{"scans", l.scans},
                  {"beams", l.beams},
                  {"beams_mapped", l.beams_mapped},
                  {"max_range_m", l.max_range_m},
                  {"sigma_m", l.sigma_m},
                  {"p_short", l.p_short},
                  {"lambda_short", l.lambda_short},
                  {"p_max", l.p_max},
                  {"p_random", l.p_random},
                  {"hit_bias_m", l.hit_bias_m},
                  {"log_likelihood_per_beam", l.log_likelihood},
                  {"iterations", l.iterations}};
  }
  return j;
}

std::string_view parameter_group(std::string_view key, std::string_view plugin) {
  if (std::find(kBeaconFilters.begin(), kBeaconFilters.end(), plugin) != kBeaconFilters.end()) {
    if (key == "range_bias_m" || key == "range_bias_per_m") return "ranging bias";
    if (key == "sigma_range_m") return "ranging spread";
  }
  static constexpr std::array<std::pair<std::string_view, std::string_view>, 47> kGroupOf{{
      {"command_dead_time_s", "command response"},
      {"command_time_constant_v_s", "command response"},
      {"command_time_constant_omega_s", "command response"},
      {"command_gain_v", "command response"},
      {"command_gain_omega", "command response"},
      {"motion_model", "wheel noise"},
      {"k_left", "wheel noise"},
      {"k_right", "wheel noise"},
      {"motion_floor_m", "wheel noise"},
      {"motion_floor_deg", "wheel noise"},
      {"side_slip_k", "side slip"},
      {"odometry_heading", "gyro heading"},
      {"heading_noise_density", "gyro heading"},
      {"heading_rate_bias_radps", "gyro heading"},
      {"heading_rate_bias_sigma", "gyro heading"},
      {"heading_rate_bias_walk", "gyro heading"},
      {"heading_rate_scale_error", "gyro heading"},
      {"gain_wander_v", "gain wander"},
      {"gain_wander_omega", "gain wander"},
      {"gain_wander_correlation_s", "gain wander"},
      {"alpha1", "odometry model"},
      {"alpha2", "odometry model"},
      {"alpha3", "odometry model"},
      {"alpha4", "odometry model"},
      {"variance_form", "odometry model"},
      {"range_model", "detection bias"},
      {"range_bias_m", "detection bias"},
      {"range_bias_per_m", "detection bias"},
      {"bearing_bias_deg", "detection bias"},
      {"sigma_range_m", "detection spread"},
      {"sigma_range_per_m", "detection spread"},
      {"sigma_range_per_m2", "detection spread"},
      {"sigma_bearing_deg", "detection spread"},
      {"noise_correlation_s", "detection correlation"},
      {"noise_correlation_slow_s", "detection correlation"},
      {"noise_correlation_slow_share", "detection correlation"},
      {"bearing_noise_correlation_s", "detection correlation"},
      {"bearing_noise_correlation_slow_s", "detection correlation"},
      {"bearing_noise_correlation_slow_share", "detection correlation"},
      {"threshold", "resetting levels"},
      {"p_t", "resetting levels"},
      {"reset_min_detections", "resetting levels"},
      {"injection_level", "resetting levels"},
      {"alpha_slow", "resetting levels"},
      {"alpha_fast", "resetting levels"},
      {"outlier_likelihood", "false detections"},
      {"regularization", "regularization"},
  }};
  for (const auto& [k, group] : kGroupOf) {
    if (k == key) return group;
  }
  return {};
}

std::string Calibration::to_yaml() const {
  std::string y = "# Written by `locsim calibrate`: noise measured against the ground truth of\n";
  for (const std::string& source : sources) y += "#   " + source + "\n";
  y += "# Use: locsim replay LOG --localizer NAME --params THIS_FILE (docs/real_data.md);\n"
       "# calibration.json beside it has the fits, bins and counts.\n";
  // The camera whose noise the localizers get: the range-bearing sensor, else the one with the
  // most inliers.
  const DetectionCalibration* camera = nullptr;
  for (const DetectionCalibration& c : cameras) {
    if (camera == nullptr || c.camera == sensor_name(SensorKind::kRangeBearing) ||
        (camera->camera != sensor_name(SensorKind::kRangeBearing) && c.inliers > camera->inliers))
      camera = &c;
  }
  const CommandResponseFit* command =
      motion && motion->command && motion->command->leads && motion->command->k_left
          ? &*motion->command
          : nullptr;
  const std::optional<LocalizerMotion> belief = localizer_motion(motion);
  y += "localizer_params:  # each localizer takes the keys it declares\n";
  if (belief && belief->command != nullptr) {
    // The localizers that follow the response predict with the motion it gives; their wheel
    // noise is what is left beyond it.
    y += "  # motion: the odometry reports the command; the localizers run it through the "
         "robot's response (command_*), then the wheel model at every odometry reading "
         "(ekf_landmarks, odometry, omni_kf; the particle filters with motion_model wheels)\n";
    y += "  command_dead_time_s: " + four_digits(command->dead_time_s) +
         "\n  command_time_constant_v_s: " + four_digits(command->time_constant_v_s) +
         "\n  command_time_constant_omega_s: " + four_digits(command->time_constant_omega_s) +
         "\n  command_gain_v: " + four_digits(command->gain_v) +
         "\n  command_gain_omega: " + four_digits(command->gain_omega) +
         "\n  motion_model: wheels\n";
  } else if (belief) {
    // The wheel model's noise adds up the same whatever the step length; the per-step alphas'
    // does not (they hold for steps as long as the intervals measured here), so the particle
    // filters get the wheel model (docs/real_data.md measures both on MRCLAM).
    y += "  # motion: the wheel model at every odometry reading (ekf_landmarks; the particle "
         "filters with motion_model wheels)\n  motion_model: wheels\n";
  }
  if (belief) {
    y += "  k_left: " + four_digits(belief->k_left) +
         "\n  k_right: " + four_digits(belief->k_right) +
         "\n  motion_floor_m: " + four_digits(belief->floor_position_m) +
         "  # noise of every perception step whatever the motion\n  motion_floor_deg: " +
         four_digits(rad_to_deg(belief->floor_heading_rad)) + "\n";
    if (belief->wander) {
      const auto& [v, omega] = *belief->wander;
      y += "  # the base's gains wander about the response's for seconds (ekf_landmarks, the "
           "landmark particle filters)\n  gain_wander_v: " +
           four_digits(v.sigma) + "\n  gain_wander_omega: " + four_digits(omega.sigma) +
           "\n  gain_wander_correlation_s: " + four_digits(v.correlation_s) + "\n";
    }
  }
  if (motion) {
    const OdometryModelFit& f =
        motion->variance_form ? motion->odometry_variance : motion->odometry_std;
    y += "  # the odometry model per perception step (fastslam; motion_model odometry)\n";
    y += "  alpha1: " + four_digits(f.alpha1) + "\n  alpha2: " + four_digits(f.alpha2) +
         "\n  alpha3: " + four_digits(f.alpha3) + "\n  alpha4: " + four_digits(f.alpha4) +
         "\n  variance_form: " + (motion->variance_form ? "true" : "false") +
         "  # the form that explains the odometry better\n";
  }
  if (camera != nullptr) {
    // The landmark localizers take the bias out of each detection and weigh it with the spread
    // about it; a landmark seen again while its errors persist counts less.
    const LocalizerNoise noise = localizer_noise(*camera);
    y += "  # from the " + camera->camera +
         "'s detections: the bias taken out of each, the spread about it\n";
    y += "  range_model: " + std::string(noise.bias.depth ? "depth" : "distance") +
         "\n  range_bias_m: " + four_digits(noise.bias.range_bias_m) +
         "\n  range_bias_per_m: " + four_digits(noise.bias.range_bias_per_m) +
         "\n  bearing_bias_deg: " + four_digits(rad_to_deg(noise.bias.bearing_bias_rad)) +
         "\n  sigma_range_m: " + four_digits(std::max(noise.range_spread_m.at_zero, 1e-6)) +
         "\n  sigma_range_per_m: " + four_digits(std::max(noise.range_spread_m.per_unit, 0.0)) +
         "\n  sigma_range_per_m2: 0\n  sigma_bearing_deg: " +
         four_digits(std::max(rad_to_deg(noise.bearing_spread_rad), 1e-6)) +
         "\n  noise_correlation_s: " + four_digits(noise.correlation_s) +
         "  # how long a landmark's errors persist\n";
    if (noise.slow_share > 0.0 || noise.bearing_correlation) {
      y += "  noise_correlation_slow_s: " + four_digits(noise.slow_correlation_s) +
           "  # and a slow part of them\n  noise_correlation_slow_share: " +
           four_digits(noise.slow_share) + "\n";
    }
    if (const auto& b = noise.bearing_correlation) {
      y += "  bearing_noise_correlation_s: " + four_digits(b->fast_s) +
           "  # the bearing's errors persist otherwise\n  bearing_noise_correlation_slow_s: " +
           four_digits(b->slow_s) +
           "\n  bearing_noise_correlation_slow_share: " + four_digits(b->slow_share) + "\n";
    }
    // The FastSLAM filters, which take no bias out, get one noise about zero: the range's at the
    // middle bin's range, the bearing's root mean square.
    if (!camera->bins.empty()) {
      const double middle_m = camera->bins[camera->bins.size() / 2].range_m;
      const std::string fixed = four_digits(std::max(camera->range_rms_m.at(middle_m), 1e-6)) +
                                ", sigma_bearing_deg: " +
                                four_digits(std::max(rad_to_deg(camera->bearing_rms_rad), 1e-6));
      for (const char* name : {"fastslam", "fastslam_afsa", "pso_pf"}) {
        y += std::string("  ") + name + ": {sigma_range_m: " + fixed + "}  # at " +
             four_digits(middle_m) + " m\n";
      }
    }
  }
  if (camera != nullptr && camera->srl_threshold) {
    y += "  # resetting levels: the likelihood of a filter that tracks the robot (its belief "
         "spread about the truth) falls below them in " +
         four_digits(100.0 * *camera->reset_quantile) + " % of the steps\n";
    // One detection puts a reset pose anywhere on a ring around its landmark, which later
    // detections of that landmark cannot tell from the truth (docs/real_data.md).
    y += "  # and a reset from two detections or more: one puts the robot on a ring\n";
    y += "  srl: {threshold: " + four_digits(*camera->srl_threshold) +
         ", reset_min_detections: 2}\n";
    y += "  asrl: {p_t: " + four_digits(*camera->asrl_p_t) + ", reset_min_detections: 2}\n";
    y += "  # a tracking filter's w_fast / w_slow falls below injection_level in as few steps\n";
    y += "  augmented_mcl: {injection_level: " + four_digits(*camera->augmented_injection_level) +
         ", alpha_slow: " + four_digits(kAugmentedAlphaSlow) +
         ", alpha_fast: " + four_digits(kAugmentedAlphaFast) + "}\n";
  }
  if (camera != nullptr && camera->outlier_likelihood) {
    y += "  # the landmark particle filters: a detection may be false (" +
         four_digits(100.0 * static_cast<double>(camera->false_detections) /
                     static_cast<double>(camera->detections)) +
         " % of them), anywhere in the measured ranges and bearings\n";
    y += "  outlier_likelihood: " + four_digits(*camera->outlier_likelihood) + "\n";
  }
  if (camera != nullptr) {
    // With noise that fits the data the detections are sharp, and a resampled set of a few
    // hundred particles holds copies of a few: it claims a certainty it cannot represent. Half
    // the optimal kernel width, chosen on a simulated world (a wandering base, a camera with
    // slow errors: truth in the 95 % ellipse 0.68-0.84 -> 0.92-0.95 at the same RMS) and checked
    // on MRCLAM (MCL 0.71 -> 0.89, RMS +7 %); the full width spreads the set too far (MRCLAM
    // MCL 0.136 -> 0.213 m).
    y += "  # the landmark particle filters regularise their sets (half the optimal kernel width)\n"
         "  regularization: 0.5\n";
  }
  if (ranging) {
    // In the beacon filters' own sections: the landmark filters' keys of the same names are the
    // camera's.
    const RangingCalibration& r = *ranging;
    y += "  # ranges to beacons: the bias line taken out of each range, the spread about it\n";
    // A base whose odometry turns by a gyro: the EKF's wheels measure the distance, its state
    // carries the gyro's bias, with a prior as wide as the robots' spread and their mean together
    // (one recording's bias says how large another's may be, not its sign).
    const MotionCalibration::HeadingFit* gyro =
        command == nullptr && motion && motion->heading && motion->heading->gyro ? &*motion->heading
                                                                                 : nullptr;
    if (gyro != nullptr) {
      y += "  # the odometry turns by a gyro: the beacon filters estimate its bias\n";
    }
    for (const std::string_view plugin : kBeaconFilters) {
      y += "  " + std::string(plugin) +
           ": {sigma_range_m: " + four_digits(std::max(r.spread_m, 1e-6)) +
           ", range_bias_m: " + four_digits(r.bias_m.at_zero) +
           ", range_bias_per_m: " + four_digits(r.bias_m.per_unit);
      if (gyro != nullptr) {
        y += ", odometry_heading: gyro, k_left: " + four_digits(gyro->distance_k) +
             ", k_right: " + four_digits(gyro->distance_k) +
             ", heading_noise_density: " + four_digits(gyro->noise_density) +
             ", heading_rate_scale_error: " + four_digits(gyro->scale_error) +
             ", heading_rate_bias_radps: " + four_digits(gyro->bias_radps) +
             ", heading_rate_bias_sigma: " +
             four_digits(std::hypot(gyro->bias_sigma, gyro->bias_radps)) +
             ", heading_rate_bias_walk: " + four_digits(gyro->bias_walk);
      }
      // The body's drift across its heading, which neither the wheels nor a gyro see.
      if (motion && motion->side_slip && motion->side_slip->wander_k > 0.0)
        y += ", side_slip_k: " + four_digits(motion->side_slip->wander_k);
      y += "}\n";
    }
  }
  const SideSlipFit* slip =
      motion && motion->side_slip && motion->side_slip->any() ? &*motion->side_slip : nullptr;
  if (command != nullptr || slip != nullptr)
    y += "robot:  # how the robots move (docs/worlds.md)\n";
  if (slip != nullptr) {
    y += "  # the body slides off its heading: at an angle, outward in turns, from side to side\n";
    y += "  side_slip: {crab_angle_deg: " + four_digits(rad_to_deg(slip->crab_angle_rad)) +
         ", cornering_compliance_s: " + four_digits(slip->cornering_compliance_s) +
         ", wander_k: " + four_digits(slip->wander_k) +
         ", wander_correlation_s: " + four_digits(slip->wander_correlation_s) + "}\n";
  }
  if (command != nullptr) {
    y += "  # the motion lags and falls short of the velocity the odometry reports\n";
    y += "  command_response: {dead_time_s: " + four_digits(command->dead_time_s) +
         ", time_constant_v_s: " + four_digits(command->time_constant_v_s) +
         ", time_constant_omega_s: " + four_digits(command->time_constant_omega_s) +
         ", gain_v: " + four_digits(command->gain_v) +
         ", gain_omega: " + four_digits(command->gain_omega);
    const auto& v = command->gain_wander_v;
    const auto& omega = command->gain_wander_omega;
    if (v && omega && (v->sigma > 0.0 || omega->sigma > 0.0)) {
      y += ", gain_wander_v: " + four_digits(v->sigma) +
           ", gain_wander_omega: " + four_digits(omega->sigma) +
           ", gain_wander_correlation_s: " + four_digits(v->correlation_s);
    }
    y += "}\n";
  }
  y += "sensors:  # a robot's sensor settings for a world with this noise (docs/sensors.md)\n";
  if (command != nullptr) {
    // The simulated base reports its command, which the robot follows through the response
    // above: the noise is what the motion does beyond the response.
    y += "  encoders: {measures: command, " +
         wheel_noise(*command->k_left, *command->k_right, command->correlated_wheels) + "}\n";
  } else if (motion && motion->heading && motion->heading->gyro) {
    // The heading is a gyro's: the wheels measure only the distance.
    const MotionCalibration::HeadingFit& h = *motion->heading;
    y += "  encoders: {heading: gyro, gyro_bias_radps: " + four_digits(h.bias_radps) +
         ", gyro_bias_sigma: " + four_digits(h.bias_sigma) +
         ", gyro_noise_density: " + four_digits(h.noise_density) +
         ", gyro_scale_error: " + four_digits(h.scale_error) +
         ", k_left: " + four_digits(h.distance_k) + ", k_right: " + four_digits(h.distance_k) +
         "}\n";
  } else if (motion) {
    y += "  encoders: {" + wheel_noise(motion->k_left, motion->k_right, motion->correlated_wheels) +
         "}\n";
  }
  for (const DetectionCalibration& c : cameras) {
    if (c.camera != sensor_name(SensorKind::kRangeBearing)) continue;
    // The chosen range model's lines, so that a world with them makes the errors measured; the
    // model always, so that it replaces a world's own.
    // The chosen range model's lines, so that a world with them makes the errors measured; the
    // model always, so that it replaces a world's own. With cameras off their believed places,
    // the bearings' noise from where they are: the twin puts them there (camera_offsets below),
    // and the noise from the believed places would count the offsets twice. The ranges' stays
    // from the believed places, where a camera's own calibration reports them from (the twin
    // keeps them so: docs/real_data.md).
    const bool depth = c.range_model == "depth" && c.depth_model;
    const LineFit& bias = depth ? c.depth_model->bias_m : c.range_bias_m;
    const LineFit& spread = depth ? c.depth_model->spread_m : c.range_spread_m;
    const CameraPlaceNoise bearing =
        c.from_camera_places.value_or(CameraPlaceNoise{c.bearing_bias_rad, c.bearing_spread_rad});
    y += "  range_bearing:\n    range_model: " + std::string(depth ? "depth" : "distance") +
         "\n    sigma_range_m: " + four_digits(spread.at_zero) +
         "\n    sigma_range_per_m: " + four_digits(spread.per_unit) +
         "\n    range_bias_m: " + four_digits(bias.at_zero) +
         "\n    range_bias_per_m: " + four_digits(bias.per_unit) +
         "\n    sigma_bearing_deg: " + four_digits(rad_to_deg(bearing.bearing_spread_rad)) +
         "\n    bearing_bias_deg: " + four_digits(rad_to_deg(bearing.bearing_bias_rad)) + "\n";
    if (const auto& decay = c.detection_decay) {
      y += "    miss_probability: " + four_digits(decay->miss_probability_at_zero) +
           "  # at zero range: the chance of a detection falls with range\n"
           "    detection_decay_m: " +
           four_digits(decay->decay_m) + "\n";
    } else if (c.miss_probability) {
      y += "    miss_probability: " + four_digits(*c.miss_probability) + "\n";
    }
    if (const auto& silent = c.silences; silent && silent->significant) {
      y += "    outage_fraction: " + four_digits(silent->fraction) +
           "\n    outage_mean_s: " + four_digits(silent->mean_s) + "\n";
      if (silent->long_share > 0.0) {
        y += "    outage_long_share: " + four_digits(silent->long_share) +
             "\n    outage_long_mean_s: " + four_digits(silent->long_mean_s) + "\n";
      }
    }
    y += "    false_detections: " + four_digits(c.false_per_reading) + "\n";
    const auto process = [&](const std::string& prefix,
                             const DetectionCalibration::TwoCorrelations& p) {
      y += "    " + prefix + "noise_correlation_s: " + four_digits(p.fast_s) + "\n    " + prefix +
           "noise_correlation_slow_s: " + four_digits(p.slow_s) + "\n    " + prefix +
           "noise_correlation_slow_share: " + four_digits(p.slow_share) + "\n";
    };
    if (const auto& apart = c.channel_correlations) {
      process("", apart->range);
      process("bearing_", apart->bearing);
    } else if (const auto& two = c.noise_correlation_two) {
      process("", *two);
    } else if (c.noise_correlation_s) {
      y += "    noise_correlation_s: " + four_digits(*c.noise_correlation_s) + "\n";
    }
  }
  if (ranging) {
    const RangingCalibration& r = *ranging;
    y += "  ultrasonic:\n    sigma_m: " + four_digits(r.spread_m) +
         "\n    range_bias_m: " + four_digits(r.bias_m.at_zero) +
         "\n    range_bias_per_m: " + four_digits(r.bias_m.per_unit) +
         "\n    outlier_probability: " +
         four_digits(static_cast<double>(r.long_outliers) / static_cast<double>(r.ranges)) + "\n";
    if (r.excess_min_m) {
      y += "    nlos_bias_min_m: " + four_digits(*r.excess_min_m) +
           "\n    nlos_bias_mean_m: " + four_digits(*r.excess_mean_m) + "\n";
    }
    // A tag that ranges one beacon (or a few) at a time polls them in turn.
    const auto polled = static_cast<long>(std::lround(r.ranges_per_reading));
    if (polled >= 1 && static_cast<std::size_t>(polled) < r.beacons)
      y += "    beacons_per_reading: " + std::to_string(polled) + "\n";
    if (r.outages.outages > 0) {
      y += "    outage_fraction: " + four_digits(r.outages.fraction) +
           "\n    outage_mean_s: " + four_digits(r.outages.mean_s) + "\n";
    }
  }
  if (laser) {
    const LaserCalibration& l = *laser;
    y += "  laser: {sigma_m: " + four_digits(l.sigma_m) + ", p_short: " + four_digits(l.p_short) +
         ", lambda_short: " + four_digits(l.lambda_short) + ", p_max: " + four_digits(l.p_max) +
         ", p_random: " + four_digits(l.p_random) + "}\n";
  }
  // A camera off its believed place is a property of one robot, not of the noise: by name, for
  // `locsim twin` (which mounts that robot's camera there and leaves its believed mount).
  std::string offsets;
  for (const DetectionCalibration& c : cameras) {
    for (const CameraOffset& o : c.camera_offsets) {
      if (!o.significant) continue;
      offsets += "  " + json(o.robot).dump() + ": {x: " + four_digits(o.x_m) +
                 ", y: " + four_digits(o.y_m) + "}\n";
    }
  }
  if (!offsets.empty()) {
    y += "camera_offsets:  # each robot's range-bearing camera from where its detections are given "
         "[m]\n" +
         offsets;
  }
  return y;
}

std::string describe(const Calibration& c) {
  std::string text;
  for (const std::string& source : c.sources) text += source + "\n";
  if (c.motion) {
    const MotionCalibration& m = *c.motion;
    const OdometryModelFit& f = m.variance_form ? m.odometry_variance : m.odometry_std;
    text += "  motion: " + std::to_string(m.intervals) + " intervals (mean " +
            four_digits(m.mean_interval_s) + " s, " + four_digits(m.mean_travel_m) + " m): alpha " +
            four_digits(f.alpha1) + " " + four_digits(f.alpha2) + " " + four_digits(f.alpha3) +
            " " + four_digits(f.alpha4) + (m.variance_form ? " (variance form)" : "") +
            "; k_left " + four_digits(m.k_left) + ", k_right " + four_digits(m.k_right) +
            " m^1/2 (mean NEES " + four_digits(m.k_mean_nees) + "); error whatever the motion " +
            four_digits(f.floor_position_m) + " m, " +
            four_digits(rad_to_deg(f.floor_heading_rad)) + " deg per interval\n";
    const auto correlated = [](const std::optional<CorrelatedWheels>& w) {
      return w ? "    the wheels' errors correlated (" + four_digits(w->gain_nats) +
                     " nats better): k_correlation " + four_digits(w->k_correlation) + ", k_left " +
                     four_digits(w->k_left) + ", k_right " + four_digits(w->k_right) +
                     " m^1/2 (the twin's encoders)\n"
               : std::string();
    };
    text += correlated(m.correlated_wheels);
    if (const auto& h = m.heading) {
      text += "  heading from " + std::string(h->gyro ? "a gyro" : "the wheels") + " (" +
              four_digits(h->gyro_log_likelihood - h->wheels_log_likelihood) +
              " nats per interval for a gyro): as a gyro, bias " + four_digits(h->bias_radps) +
              " rad/s (spread over robots " + four_digits(h->bias_sigma) + ", wander " +
              four_digits(h->bias_walk) + " rad/s per root second), scale error " +
              four_digits(h->scale_error) + ", noise " + four_digits(h->noise_density) +
              " rad/s/sqrt(Hz); the wheels' k from the distance " + four_digits(h->distance_k) +
              " m^1/2\n";
    }
    if (const auto& d = m.side_slip) {
      text += "  the body off its heading (" + std::to_string(d->windows) + " windows, " +
              four_digits(d->distance_m) + " m): crab " +
              four_digits(rad_to_deg(d->crab_angle_rad)) + " deg (" + four_digits(d->crab_gain) +
              " nats), cornering compliance " + four_digits(d->cornering_compliance_s) + " s (" +
              four_digits(d->cornering_gain) + " nats), wander k " + four_digits(d->wander_k) +
              " m^1/2 over " + four_digits(d->wander_correlation_s) + " s (" +
              four_digits(d->wander_gain) + " nats); the truth's own noise " +
              four_digits(d->truth_noise_m) + " m" +
              (d->dropped > 0 ? ", " + std::to_string(d->dropped) + " windows dropped as jumps"
                              : std::string()) +
              (d->any() ? std::string() : "; none kept") + "\n";
    }
    if (const auto& r = m.command) {
      text +=
          "  the motion against the reported velocity (" + four_digits(r->seconds) +
          " s): dead time " + four_digits(r->dead_time_s) + " s, lag " +
          four_digits(r->time_constant_v_s) + " s (v) " + four_digits(r->time_constant_omega_s) +
          " s (omega), gain " + four_digits(r->gain_v) + " (v) " + four_digits(r->gain_omega) +
          " (omega); it leaves " + four_digits(r->residual_v) + " (v) " +
          four_digits(r->residual_omega) + " (omega) of the error variance, a gain alone " +
          four_digits(r->residual_gain_only_v) + " " + four_digits(r->residual_gain_only_omega) +
          (r->leads ? (r->k_left ? "; the odometry leads the motion: k beyond the response " +
                                       four_digits(*r->k_left) + ", " + four_digits(*r->k_right)
                                 : std::string("; the odometry leads the motion"))
                    : std::string("; no lead")) +
          "\n";
      if (r->leads) text += correlated(r->correlated_wheels);
      if (r->leads && r->localizer) {
        text += "  a localizer that follows the response (command_*): k_left " +
                four_digits(r->localizer->k_left) + ", k_right " +
                four_digits(r->localizer->k_right) + " m^1/2 (mean NEES " +
                four_digits(r->localizer->mean_nees) + ")";
        for (const auto& span : r->localizer_by_span) {
          text += "; over " + std::to_string(span.steps) + " steps (" +
                  four_digits(span.mean_interval_s) + " s) " + four_digits(span.k_left) + ", " +
                  four_digits(span.k_right);
        }
        text += "\n";
      }
      if (r->leads && r->gain_wander_v && r->gain_wander_omega) {
        const auto& v = *r->gain_wander_v;
        const auto& omega = *r->gain_wander_omega;
        text += v.sigma > 0.0 || omega.sigma > 0.0
                    ? "  the base's gains wander about the response's (first-order, " +
                          four_digits(v.log_likelihood_gain) + " nats better): v " +
                          four_digits(v.sigma) + ", omega " + four_digits(omega.sigma) + " over " +
                          four_digits(v.correlation_s) + " s\n"
                    : std::string(
                          "  the base's gains do not wander beyond the step-to-step "
                          "noise (windows of 2-20 s)\n");
      }
    }
  }
  if (c.ranging) {
    const RangingCalibration& r = *c.ranging;
    text += "  ranges to beacons: " + std::to_string(r.ranges) + " in " +
            std::to_string(r.readings) + " readings (" + four_digits(r.ranges_per_reading) +
            " per reading and receiver, " + std::to_string(r.beacons) + " beacons), " +
            std::to_string(r.long_outliers) + " long and " + std::to_string(r.short_outliers) +
            " short outliers: bias " + four_digits(r.bias_m.at_zero) + " m + " +
            four_digits(r.bias_m.per_unit) + " r, spread " + four_digits(r.spread_m) +
            " m (rms about zero " + four_digits(r.rms_m) + " m)" +
            (r.noise_correlation_s
                 ? (*r.noise_correlation_s > 0.0
                        ? "; errors correlated over " + four_digits(*r.noise_correlation_s) + " s"
                        : std::string("; errors independent"))
                 : std::string()) +
            "\n";
    if (r.outages.outages > 0) {
      text += "  ranges' silences (gaps beyond " + four_digits(OutageFit::kPeriods) +
              " times the median interval, " + four_digits(r.outages.median_interval_s) +
              " s): " + std::to_string(r.outages.outages) + ", as spells " +
              four_digits(r.outages.fraction) + " of the time, " + four_digits(r.outages.mean_s) +
              " s on average\n";
    }
  }
  if (c.laser) {
    const LaserCalibration& l = *c.laser;
    text += "  laser: " + std::to_string(l.beams) + " beams of " + std::to_string(l.scans) +
            " scans (" + std::to_string(l.beams_mapped) + " with a mapped wall within " +
            four_digits(l.max_range_m) + " m): hits' noise " + four_digits(l.sigma_m) +
            " m (their mean error " + four_digits(l.hit_bias_m) + " m), short " +
            four_digits(l.p_short) + " (rate " + four_digits(l.lambda_short) + " /m), at max " +
            four_digits(l.p_max) + ", random " + four_digits(l.p_random) + "\n";
  }
  for (const DetectionCalibration& d : c.cameras) {
    text += "  " + d.camera + ": " + std::to_string(d.detections) + " detections, " +
            std::to_string(d.false_detections) + " false (" + four_digits(d.false_per_reading) +
            " per reading): range bias " + four_digits(d.range_bias_m.at_zero) + " m + " +
            four_digits(d.range_bias_m.per_unit) + " r, spread " +
            four_digits(d.range_spread_m.at_zero) + " m + " +
            four_digits(d.range_spread_m.per_unit) + " r; bearing bias " +
            four_digits(rad_to_deg(d.bearing_bias_rad)) + " deg, spread " +
            four_digits(rad_to_deg(d.bearing_spread_rad)) + " deg" +
            (d.miss_probability ? "; missed " + four_digits(*d.miss_probability) : std::string()) +
            (d.noise_correlation_s
                 ? "; errors correlated over " + four_digits(*d.noise_correlation_s) + " s"
                 : std::string()) +
            "\n";
    if (const auto& two = d.noise_correlation_two) {
      text += "    errors of two time constants (" + four_digits(two->gain_nats) +
              " nats better): " + four_digits(two->slow_share) + " of the variance persists " +
              four_digits(two->slow_s) + " s, the rest " + four_digits(two->fast_s) + " s\n";
    }
    if (const auto& apart = d.channel_correlations) {
      const auto process = [](const DetectionCalibration::TwoCorrelations& p) {
        return p.slow_share > 0.0 ? four_digits(p.slow_share) + " over " + four_digits(p.slow_s) +
                                        " s, the rest " + four_digits(p.fast_s) + " s"
                                  : "over " + four_digits(p.fast_s) + " s";
      };
      text += "    range and bearing apart (" + four_digits(apart->gain_nats) +
              " nats better): range " + process(apart->range) + "; bearing " +
              process(apart->bearing) + "\n";
    }
    for (const CameraOffset& o : d.camera_offsets) {
      text += "    " + o.robot + "'s camera " + (o.significant ? "" : "not significantly ") +
              "off its believed place: " + four_digits(100.0 * o.x_m) + " ± " +
              four_digits(100.0 * o.sd_x_m) + " cm forward, " + four_digits(100.0 * o.y_m) + " ± " +
              four_digits(100.0 * o.sd_y_m) + " cm left (" + std::to_string(o.detections) +
              " detections)\n";
    }
    if (const auto& silent = d.silences; silent && silent->significant) {
      // "With landmarks in view or not": the spells are the sensor's, silent whatever it faces.
      text += "    blind spells (" + four_digits(silent->gain_nats) +
              " nats better than misses alone): " + four_digits(silent->fraction) +
              " of the time, with landmarks in view or not, in spells of ";
      text += silent->long_share > 0.0
                  ? "two kinds (" + four_digits(silent->long_gain_nats) +
                        " nats better than one): " + four_digits(silent->long_share) + " of them " +
                        four_digits(silent->long_mean_s) + " s on average, the rest " +
                        four_digits(silent->mean_s) + " s"
                  : four_digits(silent->mean_s) + " s on average";
      text += " (the twin's outage_*)\n";
    }
    if (const auto& decay = d.detection_decay) {
      text += "    detections fall with range (" + four_digits(decay->gain_nats) +
              " nats better than a constant chance" +
              (decay->conditioned ? ", given a detection in each logged reading" : "") +
              "): missed " + four_digits(decay->miss_probability_at_zero) +
              " at zero range, the chance of a detection falling by e every " +
              four_digits(decay->decay_m) + " m\n";
    }
    if (const auto& placed = d.from_camera_places) {
      text += "    from the cameras' places: bearing bias " +
              four_digits(rad_to_deg(placed->bearing_bias_rad)) + " deg, spread " +
              four_digits(rad_to_deg(placed->bearing_spread_rad)) + " deg (the twin's)\n";
    }
    if (d.distance_model && d.depth_model) {
      const RangeModelFit& depth = *d.depth_model;
      text += "    range model: " + d.range_model + " (residual rms " +
              four_digits(d.distance_model->residual_rms_m) + " m as distance, " +
              four_digits(depth.residual_rms_m) + " m as depth)";
      if (d.range_model == "depth") {
        text += ": bias " + four_digits(depth.bias_m.at_zero) + " m + " +
                four_digits(depth.bias_m.per_unit) + " x, spread " +
                four_digits(depth.spread_m.at_zero) + " m + " +
                four_digits(depth.spread_m.per_unit) + " x in the depth x";
      }
      text += "\n";
    }
  }
  return text;
}

}  // namespace locsim
