// Small geometric value types shared by every layer. SI units throughout: metres, radians.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <numbers>

namespace locsim {

using Vec2 = Eigen::Vector2d;  // [m] unless the name says otherwise

/// Wraps an angle to (-pi, pi]. [rad] An angle already there is returned as it is, which is what
/// std::remainder would give (no multiple of 2 pi is nearer), without its call: most angles
/// wrapped are in range, and the call was 1.5 % of a demo run. sdk::wrap does the same.
inline double wrap_angle(double angle_rad) {
  if (angle_rad > -std::numbers::pi && angle_rad <= std::numbers::pi) return angle_rad;
  double wrapped = std::remainder(angle_rad, 2.0 * std::numbers::pi);
  if (wrapped <= -std::numbers::pi) wrapped += 2.0 * std::numbers::pi;
  return wrapped;
}

inline constexpr double deg_to_rad(double deg) {
  return deg * std::numbers::pi / 180.0;
}
inline constexpr double rad_to_deg(double rad) {
  return rad * 180.0 / std::numbers::pi;
}

/// Planar pose: position [m] and heading [rad] of a body frame in the world frame.
struct Pose2 {
  double x = 0.0;      // [m]
  double y = 0.0;      // [m]
  double theta = 0.0;  // [rad], counter-clockwise from the world x axis

  Vec2 position() const { return {x, y}; }
  /// Maps a point from this pose's frame to the world frame.
  Vec2 transform(const Vec2& local) const {
    const double c = std::cos(theta), s = std::sin(theta);
    return {x + c * local.x() - s * local.y(), y + s * local.x() + c * local.y()};
  }
  bool operator==(const Pose2&) const = default;
};

/// A pose at a time: a trajectory's sample (ground truth, a path to follow).
struct StampedPose {
  double t_s = 0.0;  // [s]
  Pose2 pose;
};

/// 2D cross product (z component of the 3D one).
inline double cross(const Vec2& a, const Vec2& b) {
  return a.x() * b.y() - a.y() * b.x();
}

}  // namespace locsim
