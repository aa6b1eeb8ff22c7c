// The Python SDK (python/locsim/models.py, particles.py) computes what the C++ SDK computes: each
// deterministic function is called on the same inputs in both (the Python side by
// tests/python_sdk_eval.py) and the results agree to 1e-12 (relative, or absolute near zero;
// numpy's SIMD sin and cos differ from the C library's in the last bits). The random ones
// (sample_motion, the resamplers) are checked by their statistics in python/tests/test_sdk.py.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "locsim/models.hpp"
#include "locsim/particles.hpp"
#include "test_support.hpp"

namespace locsim::sdk {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

json to_json(const Eigen::MatrixXd& m) {
  if (m.cols() == 1) return std::vector<double>(m.data(), m.data() + m.size());
  json rows = json::array();
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    json row = json::array();
    for (Eigen::Index c = 0; c < m.cols(); ++c) row.push_back(m(r, c));
    rows.push_back(row);
  }
  return rows;
}

/// Every number of `actual` (Python's) within 1e-12 of `expected`'s (C++'s), same shape.
void expect_close(const json& expected, const json& actual, const std::string& where) {
  if (expected.is_number()) {
    ASSERT_TRUE(actual.is_number()) << where << ": " << actual;
    const double e = expected.get<double>(), a = actual.get<double>();
    EXPECT_NEAR(a, e, 1e-12 * std::max(1.0, std::abs(e))) << where;
    return;
  }
  ASSERT_TRUE(actual.is_array()) << where << ": " << actual;
  ASSERT_EQ(actual.size(), expected.size()) << where;
  for (std::size_t i = 0; i < expected.size(); ++i)
    expect_close(expected[i], actual[i], where + "[" + std::to_string(i) + "]");
}

struct Case {
  json call;      // {"fn", "args"[, "kwargs"]}
  json expected;  // C++'s result
};

TEST(PythonSdk, MatchesTheCppSdk) {
  std::vector<Case> cases;
  const auto add = [&](json call, json expected) {
    cases.push_back({std::move(call), std::move(expected)});
  };
  const std::vector<Pose> poses = {
      {0.0, 0.0, 0.0}, {1.5, -2.0, 0.7}, {-3.2, 4.1, -2.9}, {0.3, 0.2, 3.1}};
  const std::vector<std::pair<double, double>> travels = {
      {0.1, 0.12}, {-0.05, 0.05}, {0.2, 0.2}, {0.0, 0.0}, {-0.1, -0.08}};
  const double b = 0.35;
  for (const Pose& x : poses) {
    const json jx = to_json(x);
    for (const auto& [dl, dr] : travels) {
      Eigen::Matrix3d F;
      Eigen::Matrix<double, 3, 2> G;
      const Pose moved = diff_drive_motion(x, dl, dr, b, &F, &G);
      add({{"fn", "diff_drive_motion"},
           {"args", {jx, dl, dr, b}},
           {"kwargs", {{"jacobians", true}}}},
          {to_json(moved), to_json(F), to_json(G)});
      Pose xp = x;
      Eigen::Matrix3d P = Eigen::Vector3d(0.01, 0.02, 0.003).asDiagonal();
      P(0, 1) = P(1, 0) = 0.004;
      const json jP = to_json(P);
      predict_by_wheels(xp, P, dl, dr, b, 0.0013, 0.0012, 0.002);
      add({{"fn", "predict_by_wheels"}, {"args", {jx, jP, dl, dr, b, 0.0013, 0.0012, 0.002}}},
          {to_json(xp), to_json(P)});
      const auto [left, right] = wheel_travel_from_increment(between(x, moved), b);
      add({{"fn", "wheel_travel_from_increment"}, {"args", {to_json(between(x, moved)), b}}},
          {left, right});
    }
    for (const Pose& y : poses) {
      add({{"fn", "compose"}, {"args", {jx, to_json(y)}}}, to_json(compose(x, y)));
      add({{"fn", "between"}, {"args", {jx, to_json(y)}}}, to_json(between(x, y)));
      const OdometryDelta d = decompose(x, y);
      add({{"fn", "decompose"}, {"args", {jx, to_json(y)}}}, {d.rot1, d.trans, d.rot2});
      for (const bool variance_form : {false, true}) {
        OdometryNoise noise;
        noise.alpha4 = 0.3, noise.variance_form = variance_form;
        const OdometryDelta s = motion_spread({d.rot1, d.trans, d.rot2, 0.05}, noise);
        add({{"fn", "motion_spread"},
             {"args",
              {json{d.rot1, d.trans, d.rot2},
               {{"OdometryNoise",
                 {{"alpha1", noise.alpha1},
                  {"alpha2", noise.alpha2},
                  {"alpha3", noise.alpha3},
                  {"alpha4", noise.alpha4},
                  {"variance_form", variance_form}}}},
               0.05}}},
            {s.rot1, s.trans, s.rot2});
      }
    }
    for (const auto& [v, w] :
         std::vector<std::pair<double, double>>{{0.5, 0.0}, {0.3, 1.2}, {-0.2, 1e-6}})
      add({{"fn", "advance_by_velocity"}, {"args", {jx, v, w, 0.1}}},
          to_json(advance_by_velocity(x, v, w, 0.1)));
    Eigen::Matrix<double, 2, 3> H;
    const Eigen::Vector2d z = range_bearing(x, {2.0, 1.0}, &H);
    add({{"fn", "range_bearing"}, {"args", {jx, {2.0, 1.0}}}, {"kwargs", {{"jacobian", true}}}},
        {to_json(z), to_json(H)});
  }
  for (const double x : {0.0, 5e-5, -3e-4, 0.7, -2.5})
    add({{"fn", "sinc"}, {"args", json::array({x})}}, sinc(x));

  // Particles: landmark likelihoods (scalar and Eigen batch forms), weights, the estimate.
  ParticleSet p;
  p.resize(7);
  json particles = json::array();
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double k = static_cast<double>(i);
    p.x[i] = 0.4 * k - 1.0, p.y[i] = 0.3 * std::sin(k), p.theta[i] = wrap(0.9 * k - 2.0);
    p.weight[i] = 0.05 + 0.1 * std::cos(k) * std::cos(k);
    particles.push_back({p.x[i], p.y[i], p.theta[i]});
  }
  const std::vector<Eigen::Vector2d> landmarks = {{3.0, 1.0}, {-2.0, 2.5}, {0.5, -4.0}};
  json jlandmarks = json::array();
  for (const auto& m : landmarks) jlandmarks.push_back({m.x(), m.y()});
  Headings headings;
  headings.compute(p);
  for (const auto& [range, bearing] :
       std::vector<std::pair<double, double>>{{2.5, 0.3}, {4.0, -2.8}}) {
    json match = json::array(), likelihood = json::array();
    for (std::size_t i = 0; i < p.size(); ++i) {
      json mrow = json::array(), lrow = json::array();
      for (const auto& m : landmarks) {
        mrow.push_back(
            landmark_log_match(p.x[i], p.y[i], p.theta[i], range, bearing, m.x(), m.y(), 0.3, 0.1));
        lrow.push_back(landmark_log_likelihood(p.x[i], p.y[i], p.theta[i], range, bearing, m.x(),
                                               m.y(), 0.3, 0.1));
      }
      match.push_back(mrow), likelihood.push_back(lrow);
    }
    add({{"fn", "landmark_log_match"}, {"args", {particles, range, bearing, jlandmarks, 0.3, 0.1}}},
        match);
    add({{"fn", "landmark_log_likelihood"},
         {"args", {particles, range, bearing, jlandmarks, 0.3, 0.1}}},
        likelihood);
    // The C++ batch form agrees with its scalar form (the Python one is checked against both).
    std::vector<double> batch;
    landmark_log_match(p, headings, range, bearing, landmarks[0].x(), landmarks[0].y(), 0.3, 0.1,
                       batch);
    for (std::size_t i = 0; i < p.size(); ++i)
      EXPECT_NEAR(batch[i], match[i][0].get<double>(), 1e-12);
  }
  for (const double sigma : {0.01, 0.1, 0.5})  // both branches of the normaliser's series
    add({{"fn", "landmark_log_likelihood"},
         {"args",
          {json::array({json{0.0, 0.0, 0.0}}), 1.0, 0.2, json::array({json{1.0, 0.0}}), 0.2,
           sigma}}},
        json::array(
            {json::array({landmark_log_likelihood(0, 0, 0, 1.0, 0.2, 1.0, 0.0, 0.2, sigma)})}));
  const json weights = p.weight;
  std::vector<double> normalized = p.weight;
  normalize(normalized);
  add({{"fn", "normalize"}, {"args", {weights}}}, normalized);
  add({{"fn", "effective_sample_size"}, {"args", {normalized}}}, effective_sample_size(normalized));
  Pose mean;
  Eigen::Matrix3d covariance;
  mean_and_covariance(p, mean, covariance);
  add({{"fn", "mean_and_covariance"}, {"args", {particles, weights}}},
      {to_json(mean), to_json(covariance)});

  const fs::path dir = testing::temp_dir("python_sdk");
  json calls = json::array();
  for (const Case& c : cases) calls.push_back(c.call);
  std::ofstream(dir / "cases.json") << calls.dump();
  const testing::Outcome python = testing::run_command(
      std::string("PYTHONDONTWRITEBYTECODE=1 PYTHONPATH=") + LOCSIM_SOURCE_DIR + "/python " +
      LOCSIM_PYTHON_EXECUTABLE + " " + LOCSIM_SOURCE_DIR + "/tests/python_sdk_eval.py " +
      (dir / "cases.json").string());
  ASSERT_EQ(python.exit_code, 0) << python.output;
  const json results = json::parse(python.output);
  ASSERT_EQ(results.size(), cases.size());
  for (std::size_t i = 0; i < cases.size(); ++i)
    expect_close(cases[i].expected, results[i], cases[i].call.dump());
}

}  // namespace
}  // namespace locsim::sdk
