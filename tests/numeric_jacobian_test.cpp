// The SDK's finite-difference Jacobian check (locsim/numeric_jacobian.hpp), which the models'
// tests rely on: it recovers known Jacobians (fixed, dynamic and scalar-valued functions), wraps
// angles across +-pi only when told to, and rejects a wrong Jacobian naming the wrong entry.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <locsim/models.hpp>
#include <locsim/numeric_jacobian.hpp>
#include <numbers>
#include <string>
#include <type_traits>

namespace {

namespace sdk = locsim::sdk;

// f(x, y, z) = (x y, sin z + x^2, e^y z) and its Jacobian.
Eigen::Vector3d known(const Eigen::Vector3d& v) {
  return {v.x() * v.y(), std::sin(v.z()) + v.x() * v.x(), std::exp(v.y()) * v.z()};
}
Eigen::Matrix3d known_jacobian(const Eigen::Vector3d& v) {
  Eigen::Matrix3d j;
  j << v.y(), v.x(), 0.0,                 //
      2.0 * v.x(), 0.0, std::cos(v.z()),  //
      0.0, std::exp(v.y()) * v.z(), std::exp(v.y());
  return j;
}

TEST(NumericJacobian, RecoversAKnownJacobian) {
  const Eigen::Vector3d v(0.7, -1.3, 2.1);
  const auto numeric = sdk::numeric_jacobian(known, v);
  static_assert(std::is_same_v<std::remove_const_t<decltype(numeric)>, Eigen::Matrix3d>,
                "fixed sizes in, fixed sizes out");
  // Central differences: O(h^2) truncation, ~1e-16 |f| / h rounding; far below 1e-8 here.
  EXPECT_LT((numeric - known_jacobian(v)).cwiseAbs().maxCoeff(), 1e-8);
  const sdk::JacobianCheck check = sdk::check_jacobian(known_jacobian(v), known, v);
  EXPECT_TRUE(check.ok) << check.report();
  EXPECT_LT(check.max_abs_error, 1e-8);
  // A larger step is less accurate (truncation grows as h^2) but still close.
  const auto coarse = sdk::numeric_jacobian(known, v, sdk::Subtract{}, 1e-3);
  EXPECT_LT((coarse - known_jacobian(v)).cwiseAbs().maxCoeff(), 1e-5);
}

TEST(NumericJacobian, TakesDynamicSizesAndScalarOutputs) {
  // A linear map: its Jacobian is the matrix itself.
  Eigen::MatrixXd a(4, 3);
  a << 1, 2, 3, -4, 5, -6, 0.5, 0, 7, 8, -9, 0.25;
  const auto linear = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return a * x; };
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(3, -1.0, 2.0);
  const auto numeric = sdk::numeric_jacobian(linear, x);
  static_assert(std::is_same_v<std::remove_const_t<decltype(numeric)>, Eigen::MatrixXd>);
  ASSERT_EQ(numeric.rows(), 4);
  ASSERT_EQ(numeric.cols(), 3);
  EXPECT_TRUE(sdk::compare_jacobian(a, numeric).ok) << sdk::compare_jacobian(a, numeric).report();

  // A scalar function has a 1 x n Jacobian, its gradient as a row: |x|^2 -> 2 x^T.
  const auto squared_norm = [](const Eigen::Vector3d& p) { return p.squaredNorm(); };
  const Eigen::Vector3d p(0.3, -2.0, 1.5);
  const sdk::JacobianCheck gradient =
      sdk::check_jacobian(Eigen::RowVector3d(2.0 * p.transpose()), squared_norm, p);
  EXPECT_TRUE(gradient.ok) << gradient.report();
  EXPECT_EQ(gradient.numeric.rows(), 1);
  EXPECT_EQ(gradient.numeric.cols(), 3);
}

TEST(NumericJacobian, WrapsAnglesAcrossPi) {
  // compose(a, b) with the result's heading at pi: a step in a's heading crosses to -pi.
  const sdk::Pose b(0.5, -0.2, std::numbers::pi - 3.0);
  const sdk::Pose a(1.0, 2.0, 3.0);
  const auto compose_with_b = [&](const sdk::Pose& pose) { return sdk::compose(pose, b); };
  const double c = std::cos(a(2)), s = std::sin(a(2));
  Eigen::Matrix3d d_compose_d_a;
  d_compose_d_a << 1.0, 0.0, -s * b(0) - c * b(1),  //
      0.0, 1.0, c * b(0) - s * b(1),                //
      0.0, 0.0, 1.0;
  const sdk::JacobianCheck wrapped =
      sdk::check_jacobian(d_compose_d_a, compose_with_b, a, sdk::WrapAngles{2});
  EXPECT_TRUE(wrapped.ok) << wrapped.report();
  // Unwrapped, the heading's difference is 2 h - 2 pi instead of 2 h, so the entry comes out as
  // 1 - pi / h, and the check blames it.
  const sdk::JacobianCheck plain = sdk::check_jacobian(d_compose_d_a, compose_with_b, a);
  EXPECT_FALSE(plain.ok);
  EXPECT_EQ(plain.worst_row, 2);
  EXPECT_EQ(plain.worst_col, 2);
  EXPECT_NEAR(plain.numeric(2, 2), 1.0 - std::numbers::pi / sdk::kJacobianStep, 1e-3);

  // Any callable(y1, y2) is a difference: here one that wraps by hand.
  const auto heading_difference = [](const sdk::Pose& y1, const sdk::Pose& y2) {
    return sdk::Pose(y1(0) - y2(0), y1(1) - y2(1), sdk::wrap(y1(2) - y2(2)));
  };
  EXPECT_TRUE(sdk::check_jacobian(d_compose_d_a, compose_with_b, a, heading_difference).ok);
}

TEST(NumericJacobian, RejectsAWrongJacobianAndNamesTheEntry) {
  const Eigen::Vector3d v(0.7, -1.3, 2.1);
  Eigen::Matrix3d wrong = known_jacobian(v);
  wrong(1, 2) = -wrong(1, 2);  // a flipped sign, the usual slip
  const sdk::JacobianCheck check = sdk::check_jacobian(wrong, known, v);
  EXPECT_FALSE(check.ok);
  EXPECT_EQ(check.worst_row, 1);
  EXPECT_EQ(check.worst_col, 2);
  EXPECT_NEAR(check.worst_error, 2.0 * std::abs(std::cos(v.z())), 1e-8);
  EXPECT_NEAR(check.max_abs_error, check.worst_error, 1e-15);
  const std::string report = check.report();
  EXPECT_NE(report.find("MISMATCH"), std::string::npos) << report;
  EXPECT_NE(report.find("row 1, col 2"), std::string::npos) << report;

  // A small error still counts once it is beyond the tolerance; below it, it does not.
  Eigen::Matrix3d close = known_jacobian(v);
  close(0, 0) += 1e-5;
  EXPECT_FALSE(sdk::check_jacobian(close, known, v).ok);
  close(0, 0) = known_jacobian(v)(0, 0) + 1e-9;
  EXPECT_TRUE(sdk::check_jacobian(close, known, v).ok);
}

TEST(NumericJacobian, ToleranceIsAbsolutePlusRelative) {
  const sdk::JacobianTolerance tolerance{.abs_tol = 1e-7, .rel_tol = 1e-6};
  const auto agree = [&](double a, double n) {
    return sdk::compare_jacobian(Eigen::Matrix<double, 1, 1>(a), Eigen::Matrix<double, 1, 1>(n),
                                 tolerance)
        .ok;
  };
  // Near zero the absolute part decides.
  EXPECT_TRUE(agree(0.0, 5e-8));
  EXPECT_FALSE(agree(0.0, 2e-7));
  // Large entries get the relative part: 1e-7 + 1e-6 * 1000 ~ 1e-3.
  EXPECT_TRUE(agree(1000.0, 1000.0 + 5e-4));
  EXPECT_FALSE(agree(1000.0, 1000.0 + 2e-3));
  // Either side NaN fails, and so do different sizes.
  EXPECT_FALSE(agree(std::numeric_limits<double>::quiet_NaN(), 1.0));
  EXPECT_FALSE(agree(1.0, std::numeric_limits<double>::quiet_NaN()));
  const sdk::JacobianCheck sizes =
      sdk::compare_jacobian(Eigen::Matrix2d::Zero(), Eigen::Matrix<double, 2, 3>::Zero());
  EXPECT_FALSE(sizes.ok);
  EXPECT_NE(sizes.report().find("sizes differ"), std::string::npos) << sizes.report();
}

}  // namespace
