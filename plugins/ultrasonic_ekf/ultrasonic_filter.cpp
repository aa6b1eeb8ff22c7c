#include "ultrasonic_filter.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>

namespace ultrasonic {

namespace {
double sq(double v) {
  return v * v;
}
}  // namespace

UltrasonicEkfDef ultrasonic_def(const sdk::Params& params) {
  UltrasonicEkfDef def;
  const std::string mode = params.string("mode");
  if (mode == "trilateration")
    def.mode = UltrasonicEkfDef::Mode::kTrilateration;
  else if (mode == "ranges")
    def.mode = UltrasonicEkfDef::Mode::kRanges;
  else
    throw std::invalid_argument("mode must be trilateration or ranges, not '" + mode + "'");
  def.sigma_accel = params.number("sigma_accel");
  def.sigma_gyro = params.number("sigma_gyro");
  def.sigma_position_m = params.number("sigma_position_m");
  def.sigma_yaw_rad = params.number("sigma_yaw_deg") * std::numbers::pi / 180.0;
  def.sigma_velocity = params.number("sigma_velocity");
  def.sigma_range_m = params.number("sigma_range_m");
  def.range_bias_m = params.number("range_bias_m");
  def.range_bias_per_m = params.number("range_bias_per_m");
  def.gate_chi2 = params.number("gate_chi2");
  def.fix_gate_chi2 = params.number("fix_gate_chi2");
  def.lost_after_rounds = static_cast<int>(params.integer("lost_after_rounds"));
  const std::string motion = params.string("motion");
  if (motion == "auto")
    def.motion = UltrasonicEkfDef::Motion::kAuto;
  else if (motion == "imu")
    def.motion = UltrasonicEkfDef::Motion::kImu;
  else if (motion == "wheels")
    def.motion = UltrasonicEkfDef::Motion::kWheels;
  else
    throw std::invalid_argument("motion must be auto, imu or wheels, not '" + motion + "'");
  def.k_left = params.number("k_left");
  def.k_right = params.number("k_right");
  def.side_slip_k = params.number("side_slip_k");
  def.motion_floor_m = params.number("motion_floor_m");
  def.motion_floor_rad = params.number("motion_floor_deg") * std::numbers::pi / 180.0;
  def.gyro = sdk::GyroHeading::from(params);
  return def;
}

UltrasonicEkf::UltrasonicEkf(const UltrasonicEkfDef& def, const locsim_init& init)
    : def_(def),
      wheel_base_m_(init.robot != nullptr ? init.robot->wheel_base_m : 0.0),
      wheels_(wheel_base_m_) {
  if (def_.motion != UltrasonicEkfDef::Motion::kImu && !(wheel_base_m_ > 0.0))
    throw std::invalid_argument("motion by the wheels needs the robot's wheel base");
  if (init.map == nullptr || init.map->beacon_count < 3)
    throw std::invalid_argument("needs at least three ultrasonic beacons on the map");
  for (std::size_t i = 0; i < init.map->beacon_count; ++i) {
    const locsim_beacon& b = init.map->beacons[i];
    beacons_[b.id] = {Eigen::Vector2d(b.x, b.y), b.height_m};
  }
  // The bias starts at its prior, uncorrelated with the rest (held when its spread is 0).
  state_(5) = def_.gyro.bias_radps;
  covariance_.row(5).setZero();
  covariance_.col(5).setZero();
  covariance_(5, 5) = sq(def_.gyro.bias_sigma);
  if (init.initial_pose_known) {
    Eigen::Matrix3d c;
    for (int i = 0; i < 9; ++i) c(i / 3, i % 3) = init.initial_covariance[i];
    reset({init.initial_pose.x, init.initial_pose.y, init.initial_pose.theta}, c);
    covariance_(2, 2) = covariance_(3, 3) = 0.01;  // it starts standing
  }
}

void UltrasonicEkf::on_imu(double t_s, const locsim_imu& imu) {
  if (def_.motion == UltrasonicEkfDef::Motion::kWheels) return;
  if (last_imu_s_ && initialised_) {
    const double dt = t_s - *last_imu_s_;
    if (dt > 0.0) predict(dt);
  }
  last_imu_s_ = t_s;
  // The IMU's axes turned into the robot's (forward, left).
  const double c = std::cos(imu.mount_theta), sn = std::sin(imu.mount_theta);
  accel_ = {c * imu.accel_x_mps2 - sn * imu.accel_y_mps2,
            sn * imu.accel_x_mps2 + c * imu.accel_y_mps2};
  yaw_rate_ = imu.yaw_rate_radps;
}

void UltrasonicEkf::on_odometry(double t_s, const locsim_odometry& odometry) {
  if (def_.motion == UltrasonicEkfDef::Motion::kImu) return;
  const std::optional<sdk::OdometryStep> step = wheels_.update(t_s, odometry);
  if (step && initialised_ && by_wheels()) predict_by_wheels(*step);
}

bool UltrasonicEkf::by_wheels() const {
  return def_.motion == UltrasonicEkfDef::Motion::kWheels ||
         (def_.motion == UltrasonicEkfDef::Motion::kAuto && !last_imu_s_);
}

void UltrasonicEkf::predict_by_wheels(const sdk::OdometryStep& step) {
  // (x, y, theta, b) are the state's components 0, 1, 4, 5; the velocities stay as they are.
  constexpr int kMoved[4] = {0, 1, 4, 5};
  sdk::PoseHeadingBias x;
  for (int i = 0; i < 4; ++i) x(i) = state_(kMoved[i]);
  Eigen::Matrix4d f_moved;
  Eigen::Matrix<double, 4, 2> l_moved;
  const sdk::PoseHeadingBias moved =
      sdk::move_with_heading_bias(x, step.d_left_m, step.d_right_m, wheel_base_m_, step.dt_s,
                                  def_.gyro.scale_error, &f_moved, &l_moved);
  Covariance f = Covariance::Identity();
  Eigen::Matrix<double, 6, 2> l = Eigen::Matrix<double, 6, 2>::Zero();
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) f(kMoved[i], kMoved[j]) = f_moved(i, j);
    l.row(kMoved[i]) = l_moved.row(i);
  }
  const Eigen::Vector2d noise(sq(def_.k_left) * std::abs(step.d_left_m),
                              sq(def_.k_right) * std::abs(step.d_right_m));
  for (int i = 0; i < 4; ++i) state_(kMoved[i]) = moved(i);
  if (def_.gyro.active) {
    // The wheels measure only the distance D = (dl + dr) / 2: an error in D moves both wheels
    // alike, with variance (k_left^2 |dl| + k_right^2 |dr|) / 4.
    const Eigen::Matrix<double, 6, 1> l_distance = l.col(0) + l.col(1);
    covariance_ = f * covariance_ * f.transpose() +
                  l_distance * (0.25 * noise.sum()) * l_distance.transpose();
  } else {
    covariance_ = f * covariance_ * f.transpose() + l * noise.asDiagonal() * l.transpose();
  }
  covariance_(4, 4) += sq(def_.gyro.noise_density) * std::max(step.dt_s, 0.0);
  if (def_.side_slip_k > 0.0) {
    covariance_.topLeftCorner<2, 2>() += sdk::side_slip_covariance(
        state_(4), 0.5 * (step.d_left_m + step.d_right_m), def_.side_slip_k);
  }
  walk_bias(step.dt_s);
}

void UltrasonicEkf::predict(double dt) {
  // The IMU's motion with the yaw rate less the bias: d theta' / d b = -dt.
  const sdk::ImuState s = imu_state();
  Covariance f = Covariance::Identity();
  f.topLeftCorner<5, 5>() = sdk::imu_motion_jacobian(s, accel_, dt);
  f(4, 5) = -dt;
  Eigen::Matrix<double, 6, 3> g = Eigen::Matrix<double, 6, 3>::Zero();
  g.topRows<5>() = sdk::imu_noise_jacobian(s, dt);
  state_.head<5>() = sdk::imu_motion(s, accel_, yaw_rate_ - state_(5), dt);
  const Eigen::Vector3d noise(sq(def_.sigma_accel), sq(def_.sigma_accel), sq(def_.sigma_gyro));
  covariance_ = f * covariance_ * f.transpose() + g * noise.asDiagonal() * g.transpose();
  walk_bias(dt);
}

void UltrasonicEkf::walk_bias(double dt) {
  if (def_.gyro.bias_sigma > 0.0 && dt > 0.0) covariance_(5, 5) += sq(def_.gyro.bias_walk) * dt;
}

void UltrasonicEkf::on_beacon_ranges(double t_s, const locsim_beacon_ranges& reading) {
  std::vector<Range> ranges;
  for (std::size_t i = 0; i < reading.count; ++i) {
    const locsim_beacon_range& r = reading.ranges[i];
    const auto beacon = beacons_.find(r.beacon_id);
    if (!std::isfinite(r.range_m) || beacon == beacons_.end()) continue;
    ranges.push_back({Eigen::Vector2d(r.receiver_x, r.receiver_y), r.receiver, &beacon->second,
                      beacon->second.height_m - r.receiver_height_m,
                      def_.corrected_range_m(r.range_m)});
  }
  round_ranges_ = static_cast<int>(ranges.size());
  round_accepted_ = 0;
  // The ranges belong to the pose of their own time, which may lie after the last odometry.
  if (initialised_ && by_wheels()) {
    if (const std::optional<sdk::OdometryStep> step = wheels_.advance_to(t_s))
      predict_by_wheels(*step);
  }
  // The floor is measured per round (between perception steps), as it is added here.
  if (initialised_ && by_wheels() && (def_.motion_floor_m > 0.0 || def_.motion_floor_rad > 0.0)) {
    covariance_(0, 0) += sq(def_.motion_floor_m);
    covariance_(1, 1) += sq(def_.motion_floor_m);
    covariance_(4, 4) += sq(def_.motion_floor_rad);
  }
  if (def_.mode == UltrasonicEkfDef::Mode::kTrilateration) {
    update_trilateration(t_s, ranges);
  } else if (!initialised_) {
    restart(ranges);
  } else {
    update_ranges(ranges);
  }
}

int UltrasonicEkf::explained(const sdk::Pose& pose, const std::vector<Range>& ranges) const {
  const double tolerance = std::sqrt(def_.gate_chi2) * def_.corrected_sigma_m();
  int inliers = 0;
  for (const Range& r : ranges) {
    const double predicted =
        sdk::beacon_range(pose, r.receiver, r.beacon->position, r.dz_m).range_m;
    if (std::abs(r.range_m - predicted) <= tolerance) ++inliers;
  }
  return inliers;
}

bool UltrasonicEkf::restart(const std::vector<Range>& ranges) {
  std::optional<sdk::Pose> fix = trilaterate_pose(ranges);
  // Only from a round that the fix explains: a non-line-of-sight range drags the least-squares
  // solution (and the yaw, from receivers 0.3 m apart, most), so such a round is skipped.
  const int inliers = fix ? explained(*fix, ranges) : 0;
  if (inliers < 4 || 4 * inliers < 3 * static_cast<int>(ranges.size())) {
    // Echoes outnumber the direct paths: the fix most ranges agree with, if it explains the
    // round more than twice as well as the estimate it would replace (one that has drifted a
    // little still explains some: a restart would cost it its heading and velocity).
    const auto robust = echo_robust_fix(ranges);
    if (!robust || robust->second < 4) return false;
    if (initialised_ && 2 * explained(pose(), ranges) >= explained(robust->first, ranges))
      return false;
    fix = robust->first;
    ++echo_restarts_;
  }
  // Wider than one fix's noise, so that the gate lets the next rounds' good ranges in.
  const double sigma = 3.0 * def_.sigma_position_m;
  reset(*fix, Eigen::Vector3d(sq(sigma), sq(sigma), sq(def_.sigma_yaw_rad)).asDiagonal());
  return true;
}

std::optional<std::pair<sdk::Pose, int>> UltrasonicEkf::echo_robust_fix(
    const std::vector<Range>& ranges) const {
  const double tolerance = std::sqrt(def_.gate_chi2) * def_.corrected_sigma_m();
  struct Found {
    Eigen::Vector2d world, in_robot;
    int inliers;
  };
  std::map<int, std::vector<const Range*>> by_receiver;
  for (const Range& r : ranges) by_receiver[r.receiver_index].push_back(&r);
  std::vector<Found> found;
  for (const auto& [index, own] : by_receiver) {
    std::vector<Eigen::Vector2d> anchors;
    std::vector<double> distances;
    for (const Range* r : own) {
      anchors.push_back(r->beacon->position);
      distances.push_back(std::sqrt(std::max(0.0, sq(r->range_m) - sq(r->dz_m))));
    }
    // The ranges that agree with a position; none when one contradicts it: an echo only
    // lengthens a range, so no range may be shorter than the direct distance allows (a few
    // echoes agree with a wrong position by chance; across a round's ranges, one contradicts it).
    const auto agreeing = [&](const Eigen::Vector2d& p) {
      std::vector<std::size_t> out;
      for (std::size_t m = 0; m < anchors.size(); ++m) {
        const double excess = distances[m] - (p - anchors[m]).norm();
        if (excess < -tolerance) return std::vector<std::size_t>{};
        if (excess <= tolerance) out.push_back(m);
      }
      return out;
    };
    // Three circles meet where the two lines their differences make cross: a 2x2 solve, no
    // iterations, as a round of twelve beacons has 220 triples (the refinement below is exact).
    const auto meet = [&](std::size_t i, std::size_t j,
                          std::size_t k) -> std::optional<Eigen::Vector2d> {
      const Eigen::Vector2d u = 2.0 * (anchors[j] - anchors[i]),
                            v = 2.0 * (anchors[k] - anchors[i]);
      const double det = u.x() * v.y() - u.y() * v.x();
      if (std::abs(det) < 1e-6 * std::sqrt(u.squaredNorm() * v.squaredNorm())) return std::nullopt;
      const double di = sq(distances[i]) - anchors[i].squaredNorm();
      const double bu = di - sq(distances[j]) + anchors[j].squaredNorm(),
                   bv = di - sq(distances[k]) + anchors[k].squaredNorm();
      return Eigen::Vector2d((bu * v.y() - bv * u.y()) / det, (u.x() * bv - v.x() * bu) / det);
    };
    std::vector<std::size_t> best;
    const std::size_t n = anchors.size();
    for (std::size_t i = 0; i < n; ++i) {
      for (std::size_t j = i + 1; j < n; ++j) {
        for (std::size_t k = j + 1; k < n; ++k) {
          const auto p = meet(i, j, k);
          if (!p || !p->allFinite()) continue;
          if (auto inliers = agreeing(*p); inliers.size() > best.size()) best = std::move(inliers);
        }
      }
    }
    if (best.size() < 3) continue;
    std::vector<Eigen::Vector2d> best_anchors;
    std::vector<double> best_distances;
    for (const std::size_t m : best) {
      best_anchors.push_back(anchors[m]);
      best_distances.push_back(distances[m]);
    }
    if (const auto p = sdk::trilaterate(best_anchors, best_distances)) {
      found.push_back({*p, own.front()->receiver, static_cast<int>(agreeing(*p).size())});
    }
  }
  if (found.size() < 2) return std::nullopt;
  // The two receivers' positions must be as far apart as they are mounted.
  const double apart_world = (found[0].world - found[1].world).norm(),
               apart_robot = (found[0].in_robot - found[1].in_robot).norm();
  if (std::abs(apart_world - apart_robot) > 2.0 * tolerance) return std::nullopt;
  return std::pair{
      sdk::align_two_points(found[0].world, found[1].world, found[0].in_robot, found[1].in_robot),
      std::min(found[0].inliers, found[1].inliers)};
}

std::optional<sdk::Pose> UltrasonicEkf::trilaterate_pose(const std::vector<Range>& ranges) const {
  // Per receiver: the beacons' positions and the horizontal distances to them.
  struct Receiver {
    Eigen::Vector2d in_robot;
    std::vector<Eigen::Vector2d> anchors;
    std::vector<double> distances;
  };
  std::map<int, Receiver> receivers;
  for (const Range& r : ranges) {
    Receiver& receiver = receivers[r.receiver_index];
    receiver.in_robot = r.receiver;
    receiver.anchors.push_back(r.beacon->position);
    receiver.distances.push_back(std::sqrt(std::max(0.0, sq(r.range_m) - sq(r.dz_m))));
  }
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> found;  // (world, robot frame)
  for (const auto& [index, receiver] : receivers) {
    if (const auto p = sdk::trilaterate(receiver.anchors, receiver.distances))
      found.emplace_back(*p, receiver.in_robot);
  }
  if (found.size() < 2) return std::nullopt;
  return sdk::align_two_points(found[0].first, found[1].first, found[0].second, found[1].second);
}

void UltrasonicEkf::update_trilateration(double t_s, const std::vector<Range>& ranges) {
  const std::optional<sdk::Pose> fix = trilaterate_pose(ranges);
  if (!fix) {
    ++missed_;
    return;
  }
  const sdk::Pose& pose = *fix;
  Eigen::Vector2d velocity = Eigen::Vector2d::Zero();
  if (last_fix_ && t_s > last_fix_s_)
    velocity = (pose.head<2>() - last_fix_->head<2>()) / (t_s - last_fix_s_);
  const bool had_fix = last_fix_.has_value();
  last_fix_ = pose, last_fix_s_ = t_s;
  ++fixes_;
  if (!initialised_) {
    reset(pose, Eigen::Vector3d(sq(def_.sigma_position_m), sq(def_.sigma_position_m),
                                sq(def_.sigma_yaw_rad))
                    .asDiagonal());
    return;
  }
  // z = (x, y, theta, vx, vy) observes the state directly: H picks the components.
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(5, 6);
  h(0, 0) = h(1, 1) = h(2, 4) = h(3, 2) = h(4, 3) = 1.0;
  Eigen::VectorXd z(5);
  z << pose(0), pose(1), pose(2), velocity.x(), velocity.y();
  const double sigma_v = had_fix ? def_.sigma_velocity : 1e3;  // no velocity from the first fix
  const Eigen::Vector<double, 5> r(sq(def_.sigma_position_m), sq(def_.sigma_position_m),
                                   sq(def_.sigma_yaw_rad), sq(sigma_v), sq(sigma_v));
  Eigen::VectorXd innovation = z - h * state_;
  innovation(2) = sdk::wrap(innovation(2));
  if (def_.fix_gate_chi2 > 0.0) {
    const Eigen::Vector2d d = innovation.head<2>();
    const Eigen::Matrix2d s =
        covariance_.topLeftCorner<2, 2>() + Eigen::Matrix2d::Identity() * sq(def_.sigma_position_m);
    if (d.dot(s.ldlt().solve(d)) > def_.fix_gate_chi2) {
      ++fixes_gated_;
      last_fix_.reset();  // the next velocity would difference against a bad fix
      // Fix after fix refused: the estimate is what is wrong (a kidnapping); start over.
      if (++lost_rounds_ >= def_.lost_after_rounds && restart(ranges)) ++restarts_;
      return;
    }
  }
  lost_rounds_ = 0;
  correct(h, innovation, r.asDiagonal().toDenseMatrix());
  round_accepted_ = round_ranges_;
}

void UltrasonicEkf::update_ranges(const std::vector<Range>& ranges) {
  // Each range gated alone against the prediction, then the accepted ones in one update.
  const sdk::Pose prior = pose();
  const double r = sq(def_.corrected_sigma_m());
  std::vector<Eigen::Matrix<double, 1, 6>> rows;
  std::vector<double> innovations;
  for (const Range& range : ranges) {
    const sdk::BeaconRangeModel model =
        sdk::beacon_range(prior, range.receiver, range.beacon->position, range.dz_m);
    Eigen::Matrix<double, 1, 6> h = Eigen::Matrix<double, 1, 6>::Zero();
    h(0) = model.jacobian(0), h(1) = model.jacobian(1), h(4) = model.jacobian(2);
    const double s = (h * covariance_ * h.transpose())(0, 0) + r;
    const double innovation = range.range_m - model.range_m;
    if (innovation * innovation > def_.gate_chi2 * s) {
      ++ranges_gated_;
      continue;
    }
    rows.push_back(h);
    innovations.push_back(innovation);
  }
  round_accepted_ = static_cast<int>(rows.size());
  ranges_used_ += round_accepted_;
  // Lost: most of a round's ranges disagree with the estimate, round after round. People block a
  // few beams at a time; a kidnapping moves all of them.
  if (round_ranges_ >= 3 && 2 * round_accepted_ < round_ranges_) {
    if (++lost_rounds_ >= def_.lost_after_rounds && restart(ranges)) {
      ++restarts_;
      return;
    }
  } else {
    lost_rounds_ = 0;
  }
  if (rows.empty()) return;
  const auto m = static_cast<Eigen::Index>(rows.size());
  Eigen::MatrixXd h(m, 6);
  Eigen::VectorXd innovation(m);
  for (Eigen::Index i = 0; i < m; ++i) {
    h.row(i) = rows[static_cast<std::size_t>(i)];
    innovation(i) = innovations[static_cast<std::size_t>(i)];
  }
  correct(h, innovation, Eigen::MatrixXd::Identity(m, m) * r);
}

void UltrasonicEkf::correct(const Eigen::MatrixXd& h, const Eigen::VectorXd& innovation,
                            const Eigen::MatrixXd& r) {
  const Eigen::MatrixXd s = h * covariance_ * h.transpose() + r;
  const Eigen::MatrixXd gain = covariance_ * h.transpose() * s.inverse();
  state_ += gain * innovation;
  state_(4) = sdk::wrap(state_(4));
  // Joseph form: stays symmetric and positive.
  const Covariance i_kh = Covariance::Identity() - gain * h;
  covariance_ = i_kh * covariance_ * i_kh.transpose() + gain * r * gain.transpose();
}

bool UltrasonicEkf::update_pose(const sdk::Pose& pose, const Eigen::Matrix3d& covariance,
                                double gate_chi2) {
  if (!initialised_) return false;
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(3, 6);
  h(0, 0) = h(1, 1) = h(2, 4) = 1.0;
  Eigen::VectorXd innovation(3);
  innovation << pose(0) - state_(0), pose(1) - state_(1), sdk::wrap(pose(2) - state_(4));
  const Eigen::MatrixXd s = h * covariance_ * h.transpose() + covariance;
  if (innovation.dot(s.ldlt().solve(innovation)) > gate_chi2) return false;
  correct(h, innovation, covariance);
  return true;
}

void UltrasonicEkf::reset(const sdk::Pose& pose, const Eigen::Matrix3d& covariance) {
  state_.head<5>() << pose(0), pose(1), 0.0, 0.0, sdk::wrap(pose(2));
  const double bias_variance = covariance_(5, 5);
  covariance_.setZero();
  covariance_(5, 5) = bias_variance;
  const int index[3] = {0, 1, 4};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) covariance_(index[i], index[j]) = covariance(i, j);
  covariance_(2, 2) = covariance_(3, 3) = 1.0;
  lost_rounds_ = 0;
  last_fix_.reset();
  initialised_ = true;
}

Eigen::Matrix3d UltrasonicEkf::pose_covariance() const {
  const int index[3] = {0, 1, 4};
  Eigen::Matrix3d c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c(i, j) = covariance_(index[i], index[j]);
  return c;
}

sdk::Estimate UltrasonicEkf::estimate() const {
  sdk::Estimate e;
  e.pose = {state_(0), state_(1), state_(4)};
  e.covariance = pose_covariance();
  return e;
}

std::vector<std::pair<std::string, double>> UltrasonicEkf::diagnostics() const {
  std::vector<std::pair<std::string, double>> out{
      {"fixes", static_cast<double>(fixes_)},
      {"missed", static_cast<double>(missed_)},
      {"fixes_gated", static_cast<double>(fixes_gated_)},
      {"ranges_used", static_cast<double>(ranges_used_)},
      {"ranges_gated", static_cast<double>(ranges_gated_)},
      {"restarts", static_cast<double>(restarts_)},
      {"echo_restarts", static_cast<double>(echo_restarts_)}};
  if (def_.gyro.bias_sigma > 0.0) {
    out.emplace_back("heading_rate_bias_radps", heading_rate_bias());
    out.emplace_back("heading_rate_bias_sigma", heading_rate_bias_sigma());
  }
  return out;
}

}  // namespace ultrasonic
