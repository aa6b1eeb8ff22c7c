// Landmark SLAM maths for plugin authors (FastSLAM, paper 001; SPEC section 3): the range-bearing
// observation of a point landmark with its Jacobians, a landmark's first estimate from one
// observation, and the per-landmark EKF update with the innovation's likelihood.
//   z = h(x, m) = (sqrt(dx^2 + dy^2), atan2(dy, dx) - theta),  (dx, dy) = m - (x, y).
// Every Jacobian is tested against finite differences (tests/slam_test.cpp, with
// locsim/numeric_jacobian.hpp).
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <numbers>

#include "locsim/models.hpp"

namespace locsim::sdk {

/// h(x, m) (models.hpp's range_bearing), with d h / d m (2x2) as well as d h / d x (2x3).
struct RangeBearing {
  Eigen::Vector2d z;  // (range [m], bearing [rad], in (-pi, pi])
  Eigen::Matrix2d h_landmark;
  Eigen::Matrix<double, 2, 3> h_pose;
};

inline RangeBearing observe_landmark(const Pose& x, const Eigen::Vector2d& m) {
  const double dx = m.x() - x(0), dy = m.y() - x(1);
  const double q = std::max(dx * dx + dy * dy, 1e-18), r = std::sqrt(q);
  RangeBearing out;
  out.z << r, wrap(std::atan2(dy, dx) - x(2));
  out.h_landmark << dx / r, dy / r,  //
      -dy / q, dx / q;
  out.h_pose << -dx / r, -dy / r, 0.0,  //
      dy / q, -dx / q, -1.0;
  return out;
}

/// The point seen at z = (range, bearing) from pose x, and d m / d z when asked for:
///   m = (x + r cos(theta + phi), y + r sin(theta + phi)).
inline Eigen::Vector2d landmark_from(const Pose& x, const Eigen::Vector2d& z,
                                     Eigen::Matrix2d* dm_dz = nullptr) {
  const double a = x(2) + z(1), c = std::cos(a), s = std::sin(a);
  if (dm_dz != nullptr) *dm_dz << c, -z(0) * s, s, z(0) * c;
  return {x(0) + z(0) * c, x(1) + z(0) * s};
}

/// One landmark's Gaussian: each FastSLAM particle holds one per landmark it has seen.
struct LandmarkEstimate {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();  // [m]
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();
  int observations = 0;
};

/// A new landmark from its first observation z with noise R: the inverse observation, covariance
/// J R J^T with J = d m / d z.
inline LandmarkEstimate init_landmark(const Pose& x, const Eigen::Vector2d& z,
                                      const Eigen::Matrix2d& r) {
  Eigen::Matrix2d j;
  LandmarkEstimate e;
  e.mean = landmark_from(x, z, &j);
  e.covariance = j * r * j.transpose();
  e.observations = 1;
  return e;
}

/// The innovation of observing `landmark` at z from x: nu = z - h (bearing wrapped), its
/// covariance S = H P H^T + R, and the squared Mahalanobis distance nu^T S^-1 nu.
struct LandmarkInnovation {
  Eigen::Vector2d nu;
  Eigen::Matrix2d s;
  Eigen::Matrix2d h;  // d h / d m
  double mahalanobis2 = 0.0;
  /// log N(nu; 0, S).
  double log_likelihood() const {
    return -0.5 * mahalanobis2 - std::log(2.0 * std::numbers::pi) - 0.5 * std::log(s.determinant());
  }
};

inline LandmarkInnovation landmark_innovation(const LandmarkEstimate& landmark, const Pose& x,
                                              const Eigen::Vector2d& z, const Eigen::Matrix2d& r) {
  const RangeBearing predicted = observe_landmark(x, landmark.mean);
  LandmarkInnovation out;
  out.nu << z(0) - predicted.z(0), wrap(z(1) - predicted.z(1));
  out.h = predicted.h_landmark;
  out.s = out.h * landmark.covariance * out.h.transpose() + r;
  out.mahalanobis2 = out.nu.dot(out.s.ldlt().solve(out.nu));
  return out;
}

/// The landmark's EKF update with that innovation (Joseph form):
///   K = P H^T S^-1,  m' = m + K nu,  P' = (I - K H) P (I - K H)^T + K R K^T.
inline void update_landmark(LandmarkEstimate& landmark, const LandmarkInnovation& innovation,
                            const Eigen::Matrix2d& r) {
  const Eigen::Matrix2d k = landmark.covariance * innovation.h.transpose() * innovation.s.inverse();
  landmark.mean += k * innovation.nu;
  const Eigen::Matrix2d i_kh = Eigen::Matrix2d::Identity() - k * innovation.h;
  landmark.covariance = i_kh * landmark.covariance * i_kh.transpose() + k * r * k.transpose();
  ++landmark.observations;
}

}  // namespace locsim::sdk
