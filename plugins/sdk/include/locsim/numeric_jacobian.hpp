// Finite-difference Jacobians, to test the analytic ones of a model (manif's approach: one
// generic check, the model under test written as a lambda, instead of a loop per test). Eigen, the
// standard library and models.hpp (for wrap) only, no test framework: the result is a plain
// struct with a report string, for GoogleTest, Catch2 or an assert alike.
//
//   const auto f = [&](const Pose& p) { return diff_drive_motion(p, d_left, d_right, base); };
//   const JacobianCheck check = check_jacobian(F, f, x, WrapAngles{2});
//   EXPECT_TRUE(check.ok) << check.report();
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "locsim/models.hpp"

namespace locsim::sdk {

/// The default step h of numeric_jacobian, for inputs of order 1 (metres, radians, seconds).
/// Central differences (f(x + h) - f(x - h)) / 2h cancel the even terms of the Taylor series, so
/// they err by h^2 f''' / 6 (forward differences: h f'' / 2), plus the rounding of f, about
/// eps |f| / h. At h = 1e-6 that is ~2e-13 |f'''| + ~2e-10 |f|: far below any real mistake in an
/// analytic Jacobian (a wrong term is usually of the order of the entry itself). A much smaller h
/// loses to rounding, a much larger one to truncation.
inline constexpr double kJacobianStep = 1e-6;

/// The plain difference y1 - y2 of two outputs: numeric_jacobian's default.
struct Subtract {
  template <class Vector>
  Vector operator()(const Vector& y1, const Vector& y2) const {
    return y1 - y2;
  }
};

/// y1 - y2 with the listed components wrapped to (-pi, pi]: for outputs that are angles. A
/// heading near +-pi on one side of the step and -+pi on the other differs by about 2 pi, not
/// by 2 h f': unwrapped, that column's derivative would be off by pi / h.
class WrapAngles {
 public:
  WrapAngles(std::initializer_list<Eigen::Index> angle_indices) : indices_(angle_indices) {}

  template <class Vector>
  Vector operator()(const Vector& y1, const Vector& y2) const {
    Vector d = y1 - y2;
    for (const Eigen::Index i : indices_) d(i) = wrap(d(i));
    return d;
  }

 private:
  std::vector<Eigen::Index> indices_;
};

namespace detail {
/// f's value as an evaluated Eigen column: a scalar output becomes a 1-vector (a 1 x n Jacobian).
template <class Value>
auto as_column(const Value& y) {
  if constexpr (std::is_arithmetic_v<Value>) {
    return Eigen::Matrix<double, 1, 1>(static_cast<double>(y));
  } else {
    return typename Value::PlainObject(y);
  }
}
}  // namespace detail

/// d f / d x at x by central differences, column j = difference(f(x + h e_j), f(x - h e_j)) / 2h.
/// f maps an Eigen column vector (fixed or dynamic size, the type of x) to an Eigen column vector
/// or a scalar; `difference` subtracts two outputs (Subtract, WrapAngles, or any callable(y1,
/// y2), e.g. a manifold's minus). The Jacobian has fixed sizes when both vectors do.
template <class Function, class Derived, class Difference = Subtract>
auto numeric_jacobian(Function&& f, const Eigen::MatrixBase<Derived>& x,
                      const Difference& difference = {}, double step = kJacobianStep) {
  using Input = typename Derived::PlainObject;
  static_assert(Input::ColsAtCompileTime == 1, "x must be a column vector");
  const Input x0 = x;
  const auto y0 = detail::as_column(f(x0));
  using Output = std::remove_const_t<decltype(y0)>;
  static_assert(Output::ColsAtCompileTime == 1, "f must return a column vector or a scalar");
  // Default-constructed, then sized: Eigen reads a two-argument constructor of a fixed 2-vector
  // as its coefficients.
  Eigen::Matrix<double, Output::RowsAtCompileTime, Input::RowsAtCompileTime> jacobian;
  jacobian.resize(y0.size(), x0.size());
  for (Eigen::Index j = 0; j < x0.size(); ++j) {
    Input up = x0, down = x0;
    up(j) += step, down(j) -= step;
    const Output dy = difference(detail::as_column(f(up)), detail::as_column(f(down)));
    jacobian.col(j) = dy / (2.0 * step);
  }
  return jacobian;
}

/// When an analytic entry a and its numeric value n agree: |a - n| <= abs_tol + rel_tol max(|a|,
/// |n|). The absolute part covers entries that are (near) zero, where the rounding of the
/// differences dominates; the relative part covers large entries, whose rounding error grows
/// with them.
struct JacobianTolerance {
  double abs_tol = 1e-7;
  double rel_tol = 1e-6;
};

/// An analytic Jacobian against a numeric one.
struct JacobianCheck {
  bool ok = false;
  /// max |a - n| over all entries (infinite when an entry is NaN or the sizes differ).
  double max_abs_error = std::numeric_limits<double>::infinity();
  /// The entry furthest beyond its allowance (or, when ok, closest to it): the one to look at.
  Eigen::Index worst_row = -1, worst_col = -1;
  double worst_error = std::numeric_limits<double>::infinity();  // its |a - n|
  double worst_allowed = 0.0;                                    // and its allowance
  JacobianTolerance tolerance;
  Eigen::MatrixXd analytic, numeric;

  /// One line naming the worst entry with both values, then both matrices.
  std::string report() const {
    std::ostringstream out;
    out.precision(10);
    if (analytic.rows() != numeric.rows() || analytic.cols() != numeric.cols()) {
      out << "Jacobian sizes differ: analytic " << analytic.rows() << "x" << analytic.cols()
          << ", numeric " << numeric.rows() << "x" << numeric.cols();
      return out.str();
    }
    out << (ok ? "Jacobian matches" : "Jacobian MISMATCH");
    if (worst_row >= 0) {
      out << "; worst entry (row " << worst_row << ", col " << worst_col << "): analytic "
          << analytic(worst_row, worst_col) << ", numeric " << numeric(worst_row, worst_col)
          << ", |difference| " << worst_error << (ok ? " <= " : " > ") << "allowed "
          << worst_allowed << " (abs_tol " << tolerance.abs_tol << " + rel_tol "
          << tolerance.rel_tol << " * max(|a|, |n|)); max |difference| " << max_abs_error;
    }
    out << "\nanalytic:\n" << analytic << "\nnumeric:\n" << numeric;
    return out.str();
  }
};

/// Compares an analytic Jacobian with a numeric one entry by entry (JacobianTolerance's rule). A
/// NaN on either side fails.
template <class AnalyticDerived, class NumericDerived>
JacobianCheck compare_jacobian(const Eigen::MatrixBase<AnalyticDerived>& analytic,
                               const Eigen::MatrixBase<NumericDerived>& numeric,
                               const JacobianTolerance& tolerance = {}) {
  JacobianCheck check;
  check.tolerance = tolerance;
  check.analytic = analytic.template cast<double>();
  check.numeric = numeric.template cast<double>();
  if (analytic.rows() != numeric.rows() || analytic.cols() != numeric.cols()) return check;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  check.ok = true;
  check.max_abs_error = 0.0;
  double worst_ratio = -1.0;  // |a - n| / allowed of the worst entry so far (the first wins ties)
  for (Eigen::Index col = 0; col < check.analytic.cols(); ++col) {
    for (Eigen::Index row = 0; row < check.analytic.rows(); ++row) {
      const double a = check.analytic(row, col), n = check.numeric(row, col);
      double error = std::abs(a - n);
      if (std::isnan(error)) error = kInf;
      const double allowed =
          tolerance.abs_tol + tolerance.rel_tol * std::max(std::abs(a), std::abs(n));
      const bool within = error <= allowed;  // false for NaN allowances too
      check.ok = check.ok && within;
      check.max_abs_error = std::max(check.max_abs_error, error);
      const double ratio = allowed > 0.0 ? error / allowed : (error > 0.0 ? kInf : 0.0);
      if (ratio > worst_ratio) {
        worst_ratio = ratio;
        check.worst_row = row, check.worst_col = col;
        check.worst_error = error, check.worst_allowed = allowed;
      }
    }
  }
  return check;
}

/// compare_jacobian(analytic, numeric_jacobian(f, x, difference, step), tolerance): an analytic
/// Jacobian of f at x checked in one call.
template <class AnalyticDerived, class Function, class Derived, class Difference = Subtract>
JacobianCheck check_jacobian(const Eigen::MatrixBase<AnalyticDerived>& analytic, Function&& f,
                             const Eigen::MatrixBase<Derived>& x, const Difference& difference = {},
                             const JacobianTolerance& tolerance = {}, double step = kJacobianStep) {
  return compare_jacobian(analytic, numeric_jacobian(f, x, difference, step), tolerance);
}

}  // namespace locsim::sdk
