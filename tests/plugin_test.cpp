// Localizer plugins: every loading failure has its own message (and exit code 3 on the command
// line), parameters are checked against declarations, a plugin that throws or returns NaN fails
// alone, every filter sees the same readings, the SDK's Jacobians are right, and the first two
// filters do what they are for.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "locsim/models.hpp"
#include "locsim/numeric_jacobian.hpp"
#include "locsim/particles.hpp"
#include "sim/common/math.hpp"
#include "sim/metrics/error_metrics.hpp"
#include "sim/metrics/scorer.hpp"
#include "sim/plugin_host/localizer_host.hpp"
#include "sim/run/runner.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;

using testing::test_plugin;

std::string load_error(const fs::path& file) {
  try {
    const PluginLibrary library(file);
  } catch (const PluginError& e) {
    return e.what();
  }
  return "loaded";
}

using testing::expect_contains;

TEST(PluginLoading, EachFailureHasItsOwnMessage) {
  expect_contains(load_error("/nonexistent/locsim_x.so"),
                  "plugin file '/nonexistent/locsim_x.so' does not exist");
  expect_contains(load_error(test_plugin("no_entry")),
                  "is not a locsim plugin: it exports no locsim_localizer_entry");
  expect_contains(load_error(test_plugin("bad_abi")),
                  "was built for localizer ABI version 99; this locsim speaks versions 1 to 3");
  expect_contains(load_error(test_plugin("bad_size")), "has a localizer table of 24 bytes");
  const std::string unresolved = load_error(test_plugin("unresolved"));
  expect_contains(unresolved, "cannot load plugin");
  expect_contains(unresolved, "undefined symbol: locsim_function_nobody_defines");
  const fs::path not_elf = testing::temp_dir("plugins") / "locsim_text.so";
  std::ofstream(not_elf) << "not a shared library";
  expect_contains(load_error(not_elf), "cannot load plugin");
  EXPECT_EQ(load_error(test_plugin("noop")), "loaded");
}

TEST(PluginLoading, NotFoundSaysWhereItLooked) {
  try {
    find_plugin("no_such_filter");
    FAIL();
  } catch (const PluginError& e) {
    expect_contains(
        e.what(),
        "no localizer plugin 'no_such_filter' (locsim_no_such_filter.so) found; looked in:");
    expect_contains(e.what(), "/plugins");
  }
  EXPECT_TRUE(fs::exists(find_plugin("odometry")));
  std::vector<std::string> names;
  for (const fs::path& file : list_plugin_files()) names.push_back(file.filename().string());
  EXPECT_NE(std::find(names.begin(), names.end(), "locsim_ekf_landmarks.so"), names.end());
}

TEST(PluginLoading, CreateFailureIsAPluginErrorWithThePluginsMessage) {
  WorldDef world = testing::world_from_yaml("robots:\n  - start: {x: 0, y: 0}\n");
  const OccupancyGrid grid;
  try {
    LocalizerHost host({parse_localizer_spec(test_plugin("create_fails"))}, world,
                       LocalizationDef{}, grid, 1);
    FAIL();
  } catch (const PluginError& e) {
    expect_contains(e.what(), "localizer 'test_create_fails'");
    expect_contains(e.what(), "create failed: needs a map with at least 100 landmarks");
  }
}

TEST(Params, AreCheckedAgainstTheDeclarations) {
  const PluginLibrary library(test_plugin("probe"));
  const LocalizerSpec spec =
      parse_localizer_spec("probe:gain=0.25,count=7,verbose=true,mode=slow@p1");
  EXPECT_EQ(spec.label, "p1");
  const ParamSet params(library.table(), spec);
  const auto values = params.to_json();
  EXPECT_EQ(values["gain"], 0.25);
  EXPECT_EQ(values["count"], 7);
  EXPECT_EQ(values["verbose"], true);
  EXPECT_EQ(values["mode"], "slow");
  EXPECT_EQ(ParamSet(library.table(), parse_localizer_spec("probe")).to_json()["mode"], "fast");
  const auto error = [&](const std::string& text) {
    try {
      ParamSet(library.table(), parse_localizer_spec(text));
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  expect_contains(error("probe:gian=1"), "has no parameter 'gian'; did you mean 'gain'?");
  expect_contains(error("probe:gain=2"), "parameter 'gain': 2 is outside [0");
  expect_contains(error("probe:gain=abc"), "expected a number, got 'abc'");
  expect_contains(error("probe:count=2.5"), "expected an integer");
  expect_contains(error("probe:verbose=maybe"), "expected true or false");
  expect_contains(error("probe:gain"), "expected key=value");
  EXPECT_THROW(parse_localizer_spec("probe@Bad Label"), InputError);
}

/// Runs the demo world for `seconds` with the given localizers; returns metrics.json.
nlohmann::json run_demo(const fs::path& out, double seconds, std::vector<std::string> localizers) {
  RunOptions options;
  options.world_file = fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml";
  options.duration_s = seconds;
  options.out_dir = out;
  options.localizers = std::move(localizers);
  run_simulation(options);
  return nlohmann::json::parse(testing::read_file(out / "metrics.json"));
}

const nlohmann::json& entry(const nlohmann::json& metrics, const std::string& label) {
  for (const auto& e : metrics["localizers"]) {
    if (e["label"] == label) return e;
  }
  throw std::runtime_error("no localizer " + label);
}

TEST(LocalizerRun, ThrowingAndNanPluginsFailAloneWithTheReasonRecorded) {
  const fs::path out = testing::temp_dir("run") / "out";
  const auto metrics = run_demo(out, 4.0, {test_plugin("throws"), test_plugin("nan"), "odometry"});
  const auto& throws = entry(metrics, "test_throws");
  EXPECT_EQ(throws["status"], "failed");
  EXPECT_DOUBLE_EQ(throws["failure"]["t_s"].get<double>(), 1.0);
  EXPECT_EQ(throws["failure"]["call"], "update");
  EXPECT_EQ(throws["failure"]["message"], "deliberate failure at one second");
  const auto& nan = entry(metrics, "test_nan");
  EXPECT_EQ(nan["status"], "failed");
  EXPECT_EQ(nan["failure"]["call"], "estimate");
  expect_contains(nan["failure"]["message"], "non-finite");
  EXPECT_EQ(entry(metrics, "odometry")["status"], "ok");
  EXPECT_EQ(entry(metrics, "odometry")["samples"], 4 * 50 + 1);
  // The failed filter's estimates stop where it failed.
  const std::string tum = testing::read_file(out / "test_throws.tum");
  const std::size_t last = tum.rfind('\n', tum.size() - 2) + 1;
  EXPECT_LE(std::stod(tum.substr(last)), 1.0);
  const auto run = nlohmann::json::parse(testing::read_file(out / "run.json"));
  EXPECT_EQ(run["status"], "completed");
}

TEST(LocalizerRun, ACovarianceThatIsNotOneFailsThePluginLikeANan) {
  const fs::path out = testing::temp_dir("run") / "out";
  const std::string nan = test_plugin("nan");
  const auto metrics =
      run_demo(out, 4.0,
               {nan + ":mode=asymmetric@asymmetric", nan + ":mode=negative@negative",
                nan + ":mode=collapsed@collapsed", nan + ":mode=beyond_tolerance@beyond",
                nan + ":mode=within_tolerance@within", "odometry"});
  const auto& asymmetric = entry(metrics, "asymmetric");
  EXPECT_EQ(asymmetric["status"], "failed");
  EXPECT_EQ(asymmetric["failure"]["call"], "estimate");
  EXPECT_DOUBLE_EQ(asymmetric["failure"]["t_s"].get<double>(), 2.0);
  expect_contains(asymmetric["failure"]["message"],
                  "returned a covariance that is not symmetric: (x, y) and (y, x) are 0.5 and 0");
  const auto& negative = entry(metrics, "negative");
  EXPECT_EQ(negative["status"], "failed");
  expect_contains(negative["failure"]["message"],
                  "is not positive semidefinite: it has an eigenvalue of -0.01");
  // A cloud collapsed onto one pose is a covariance (its asymmetry is underflow), not a failure.
  EXPECT_EQ(entry(metrics, "collapsed")["status"], "ok");
  // Either side of the tolerance on the lowest eigenvalue (1e-6 of the largest variance): -3e-6
  // fails, -8e-7 (a Cholesky factorisation's quick proof fails there; the eigenvalues decide) is
  // rounding.
  expect_contains(entry(metrics, "beyond")["failure"]["message"],
                  "is not positive semidefinite: it has an eigenvalue of -");
  EXPECT_EQ(entry(metrics, "within")["status"], "ok");
  // Before it failed, its estimates were scored, an identity covariance among them.
  EXPECT_GT(asymmetric["consistency"]["samples"].get<double>(), 0.0);
  EXPECT_EQ(entry(metrics, "odometry")["status"], "ok");
}

TEST(Metrics, NeesAndThe95PercentEllipseSayWhetherACovarianceIsHonest) {
  // Errors drawn from N(0, P): the mean NEES is the dimension, 95 % fall in the 95 % ellipse. A
  // filter claiming P / 4 is overconfident: NEES four times larger, far fewer inside.
  Eigen::Matrix3d p;
  p << 0.04, 0.01, 0.002, 0.01, 0.09, -0.003, 0.002, -0.003, 0.01;
  const Eigen::Matrix3d root = p.llt().matrixL();
  std::mt19937_64 engine(5);
  std::normal_distribution<double> normal;
  ErrorAccumulator honest, overconfident, singular;
  std::array<double, 9> claimed{}, quarter{};
  for (int i = 0; i < 9; ++i) {
    claimed[static_cast<std::size_t>(i)] = p(i / 3, i % 3);
    quarter[static_cast<std::size_t>(i)] = p(i / 3, i % 3) / 4.0;
  }
  for (int k = 0; k < 20000; ++k) {
    const Eigen::Vector3d e =
        root * Eigen::Vector3d(normal(engine), normal(engine), normal(engine));
    const double t = 0.02 * k;
    honest.add({t, e(0), e(1), e(2), 0, claimed});
    overconfident.add({t, e(0), e(1), e(2), 0, quarter});
    singular.add({t, e(0), e(1), e(2), 0, std::array<double, 9>{}});  // zero: claims nothing
  }
  const ErrorSummary h = honest.summary(), o = overconfident.summary();
  EXPECT_EQ(h.consistency_samples, 20000u);
  EXPECT_NEAR(h.nees_mean, 3.0, 0.1);
  EXPECT_NEAR(h.nees_median, 2.366, 0.03 * 2.366);  // chi-square, 3 degrees of freedom
  EXPECT_NEAR(h.position_nees_mean, 2.0, 0.1);
  EXPECT_NEAR(h.inside_95_fraction, 0.95, 0.005);
  EXPECT_NEAR(o.nees_mean, 12.0, 0.4);
  EXPECT_NEAR(o.nees_median, 4 * 2.366, 0.03 * 4 * 2.366);
  // One lost sample decides the mean, not the median.
  honest.add({400.0, 1e6, 0.0, 0.0, 0, claimed});
  EXPECT_GT(honest.summary().nees_mean, 1e9);
  EXPECT_NEAR(honest.summary().nees_median, h.nees_median, 0.03 * h.nees_median);
  EXPECT_LT(o.inside_95_fraction, 0.6);
  EXPECT_EQ(singular.summary().consistency_samples, 0u);
  // A positive definite covariance of 1e-300 and a metre of error: a NEES past any double,
  // counted as kNeesCap (found by fuzz_log: it was an undefined cast of infinity).
  ErrorAccumulator tiny;
  std::array<double, 9> minute{};
  minute[0] = minute[4] = minute[8] = 1e-300;
  tiny.add({0.0, 1.0, 1.0, 1.0, 0, minute});
  tiny.add({0.02, 1.0, 1.0, 1.0, 0, minute});
  EXPECT_EQ(tiny.summary().consistency_samples, 2u);
  EXPECT_DOUBLE_EQ(tiny.summary().nees_mean, kNeesCap);
  EXPECT_DOUBLE_EQ(tiny.summary().nees_median, kNeesCap);
  EXPECT_EQ(tiny.summary().inside_95_fraction, 0.0);
  EXPECT_EQ(singular.summary().samples, 20000u);
}

TEST(LocalizerRun, EveryFilterSeesTheSameReadings) {
  const fs::path out = testing::temp_dir("run") / "out";
  const std::string probe = test_plugin("probe");
  const auto metrics = run_demo(out, 3.0, {probe + "@first", probe + ":gain=0.9@second"});
  const auto& a = entry(metrics, "first")["diagnostics"];
  const auto& b = entry(metrics, "second")["diagnostics"];
  EXPECT_GT(a["readings"].get<double>(), 3.0 * (50 + 100 + 10 + 10 + 20 + 10) - 10);
  EXPECT_EQ(a["readings"], b["readings"]);
  EXPECT_EQ(a["hash"], b["hash"]);
}

TEST(LocalizerRun, CommandLineExitsWithThreeForPluginErrorsAndWritesNothing) {
  const fs::path dir = testing::temp_dir("cli");
  const std::string demo = std::string(LOCSIM_SOURCE_DIR) + "/worlds/demo/demo.yaml";
  for (const std::string& plugin : {std::string("no_such_filter"), test_plugin("create_fails"),
                                    test_plugin("bad_abi"), test_plugin("unresolved")}) {
    const std::string command = std::string(LOCSIM_BINARY) + " run " + demo +
                                " --duration 1 --out " + (dir / "out").string() + " --localizer " +
                                plugin + " 2>/dev/null";
    const int status = std::system(command.c_str());
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 3) << plugin;
    EXPECT_FALSE(fs::exists(dir / "out")) << plugin;
  }
  const std::string bad_param = std::string(LOCSIM_BINARY) + " run " + demo + " --out " +
                                (dir / "out").string() +
                                " --localizer odometry:k_lef=1 2>/dev/null";
  const int status = std::system(bad_param.c_str());
  EXPECT_EQ(WEXITSTATUS(status), 2);
}

// --------------------------------------------------------------------------- SDK maths
TEST(Models, JacobiansMatchFiniteDifferences) {
  std::mt19937_64 engine(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  // Per entry, stricter than the per-column bounds these replaced (F: 1e-7 absolute or 1e-6
  // relative, G: 1e-6, H: 1e-5 (1 + |column|)); the differences err by at most 6e-10 here.
  constexpr sdk::JacobianTolerance kTolerance{.abs_tol = 2e-8, .rel_tol = 1e-8};
  for (int trial = 0; trial < 50; ++trial) {
    const sdk::Pose x(3 * u(engine), 3 * u(engine), 3 * u(engine));
    const double dl = 0.2 * u(engine), dr = 0.2 * u(engine), b = 0.35;
    Eigen::Matrix3d F;
    Eigen::Matrix<double, 3, 2> G;
    sdk::diff_drive_motion(x, dl, dr, b, &F, &G);
    const auto from_pose = [&](const sdk::Pose& p) { return sdk::diff_drive_motion(p, dl, dr, b); };
    const auto from_wheels = [&](const Eigen::Vector2d& d) {
      return sdk::diff_drive_motion(x, d(0), d(1), b);
    };
    const sdk::JacobianCheck f =
        sdk::check_jacobian(F, from_pose, x, sdk::WrapAngles{2}, kTolerance);
    EXPECT_TRUE(f.ok) << "F, trial " << trial << ": " << f.report();
    const sdk::JacobianCheck g = sdk::check_jacobian(G, from_wheels, Eigen::Vector2d(dl, dr),
                                                     sdk::WrapAngles{2}, kTolerance);
    EXPECT_TRUE(g.ok) << "G, trial " << trial << ": " << g.report();

    const Eigen::Vector2d landmark(4 * u(engine), 4 * u(engine));
    Eigen::Matrix<double, 2, 3> H;
    sdk::range_bearing(x, landmark, &H);
    const auto observe = [&](const sdk::Pose& p) { return sdk::range_bearing(p, landmark); };
    const sdk::JacobianCheck h = sdk::check_jacobian(H, observe, x, sdk::WrapAngles{1}, kTolerance);
    EXPECT_TRUE(h.ok) << "H, trial " << trial << ": " << h.report();

    // The state with the base's gain errors (x, y, theta, g_v, g_omega): F by the state, L by
    // the measured wheel travel.
    sdk::PoseGains xg;
    xg << x, 0.2 * u(engine), 0.2 * u(engine);
    const double phi = 0.5 + 0.5 * std::abs(u(engine));
    Eigen::Matrix<double, 5, 5> Fg;
    Eigen::Matrix<double, 5, 2> L;
    sdk::move_with_gains(xg, dl, dr, b, phi, &Fg, &L);
    const auto from_state = [&](const sdk::PoseGains& s) {
      return sdk::move_with_gains(s, dl, dr, b, phi);
    };
    const auto from_measured = [&](const Eigen::Vector2d& d) {
      return sdk::move_with_gains(xg, d(0), d(1), b, phi);
    };
    const sdk::JacobianCheck fg =
        sdk::check_jacobian(Fg, from_state, xg, sdk::WrapAngles{2}, kTolerance);
    EXPECT_TRUE(fg.ok) << "F with gains, trial " << trial << ": " << fg.report();
    const sdk::JacobianCheck l = sdk::check_jacobian(L, from_measured, Eigen::Vector2d(dl, dr),
                                                     sdk::WrapAngles{2}, kTolerance);
    EXPECT_TRUE(l.ok) << "L, trial " << trial << ": " << l.report();

    // The state with a gyro's heading-rate bias (x, y, theta, b), the gyro's scale error given:
    // F by the state, L by the measured wheel travel.
    sdk::PoseHeadingBias xb;
    xb << x, 0.05 * u(engine);
    const double dt = 0.05 + 0.2 * std::abs(u(engine)), scale = 0.05 * u(engine);
    Eigen::Matrix4d Fb;
    Eigen::Matrix<double, 4, 2> Lb;
    sdk::move_with_heading_bias(xb, dl, dr, b, dt, scale, &Fb, &Lb);
    const auto from_biased = [&](const sdk::PoseHeadingBias& s) {
      return sdk::move_with_heading_bias(s, dl, dr, b, dt, scale);
    };
    const auto from_travel = [&](const Eigen::Vector2d& d) {
      return sdk::move_with_heading_bias(xb, d(0), d(1), b, dt, scale);
    };
    const sdk::JacobianCheck fb =
        sdk::check_jacobian(Fb, from_biased, xb, sdk::WrapAngles{2}, kTolerance);
    EXPECT_TRUE(fb.ok) << "F with the heading bias, trial " << trial << ": " << fb.report();
    const sdk::JacobianCheck lb = sdk::check_jacobian(Lb, from_travel, Eigen::Vector2d(dl, dr),
                                                      sdk::WrapAngles{2}, kTolerance);
    EXPECT_TRUE(lb.ok) << "L with the heading bias, trial " << trial << ": " << lb.report();
    // The true turn is the measured one less the bias, over the scale.
    const sdk::PoseHeadingBias moved = from_biased(xb);
    EXPECT_NEAR(sdk::wrap(moved(2) - xb(2)), sdk::wrap(((dr - dl) / b - xb(3) * dt) / (1 + scale)),
                1e-12);
  }
}

// Without wander the state with gains predicts the pose as the plain state does; with it, the
// filter's covariance is what the particles' spread becomes (the same model drawn): one model,
// two filters.
TEST(Models, TheGainWanderPredictsAsItsParticlesSpread) {
  const double b = 0.33, k = 0.005, dt = 0.02;
  sdk::Pose x(1.0, 2.0, 0.3);
  Eigen::Matrix3d P = Eigen::Matrix3d::Identity() * 1e-4;
  sdk::PoseGains xg;
  xg << x, 0.0, 0.0;
  sdk::PoseGainsCovariance Pg = sdk::PoseGainsCovariance::Zero();
  Pg.topLeftCorner<3, 3>() = P;
  for (int i = 0; i < 50; ++i) {
    sdk::predict_by_wheels(x, P, 0.010, 0.012, b, k, k);
    sdk::predict_by_wheels_and_gains(xg, Pg, 0.010, 0.012, b, k, k, 0.0, sdk::GainWander{}, dt);
  }
  EXPECT_LT((xg.head<3>() - x).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((Pg.topLeftCorner<3, 3>() - P).cwiseAbs().maxCoeff(), 1e-15);

  // 10 s along an arc, gains wandering 0.15 and 0.10 over 2 s, wheels of k 0.005 (MRCLAM's
  // 0.03 over steps a sixth as long): the EKF's covariance against 20000 particles' (a
  // linearisation: within 10 % on the diagonal, the means within a seventh of a deviation).
  const sdk::GainWander wander{0.15, 0.10, 2.0};
  const std::size_t n = 20000;
  sdk::ParticleSet particles;
  particles.resize(n);
  sdk::ParticleGains gains;
  sdk::Random random(11);
  xg << 0.0, 0.0, 0.0, 0.0, 0.0;
  Pg = sdk::PoseGainsCovariance::Zero();
  Pg(3, 3) = wander.sigma_v * wander.sigma_v;
  Pg(4, 4) = wander.sigma_omega * wander.sigma_omega;
  for (std::size_t i = 0; i < n; ++i) particles.x[i] = particles.y[i] = particles.theta[i] = 0.0;
  for (int step = 0; step < 500; ++step) {
    sdk::predict_by_wheels_and_gains(xg, Pg, 0.010, 0.011, b, k, k, 0.0, wander, dt);
    sdk::sample_wheel_motion(particles, gains, wander, dt, 0.010, 0.011, b, k, k, random);
  }
  Eigen::Matrix<double, 5, 1> mean = Eigen::Matrix<double, 5, 1>::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    mean += Eigen::Matrix<double, 5, 1>(particles.x[i], particles.y[i], particles.theta[i],
                                        gains.v[i], gains.omega[i]) /
            static_cast<double>(n);
  }
  Eigen::Matrix<double, 5, 5> spread = Eigen::Matrix<double, 5, 5>::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Matrix<double, 5, 1> e =
        Eigen::Matrix<double, 5, 1>(particles.x[i], particles.y[i], particles.theta[i], gains.v[i],
                                    gains.omega[i]) -
        mean;
    spread += e * e.transpose() / static_cast<double>(n - 1);
  }
  EXPECT_LT((mean - xg).head<2>().norm(), std::sqrt(Pg(0, 0) + Pg(1, 1)) / 7.0);
  for (int d = 0; d < 5; ++d) EXPECT_NEAR(spread(d, d) / Pg(d, d), 1.0, 0.1) << "entry " << d;
  // The wander is most of it: without it the pose spreads far less.
  sdk::Pose plain(0.0, 0.0, 0.0);
  Eigen::Matrix3d plain_P = Eigen::Matrix3d::Zero();
  for (int step = 0; step < 500; ++step)
    sdk::predict_by_wheels(plain, plain_P, 0.010, 0.011, b, k, k);
  EXPECT_GT(Pg(0, 0), 4.0 * plain_P(0, 0));
}

TEST(Models, ALostFilterWidensItsCovarianceWhileItRejectsMoreThanItAccepts) {
  const sdk::LostWatchDef def{3, 0.5, 0.2, 1.0, 0.3};  // three rejections in excess: lost
  sdk::LostWatch watch(def);
  Eigen::Matrix<double, 5, 5> P = Eigen::Matrix<double, 5, 5>::Identity() * 0.01;
  const Eigen::Matrix<double, 5, 5> before = P;
  // Outliers among accepted detections: the count returns to 0 each time.
  for (int i = 0; i < 20; ++i) {
    EXPECT_FALSE(watch.rejected(0.1 * i, P));
    watch.accepted();
    watch.accepted();
  }
  EXPECT_EQ(P, before);
  // Rejections, the odd one let through: 1, 2, 1, 2 (the count left 0 at 3.0 s) ...
  EXPECT_FALSE(watch.rejected(3.0, P));
  EXPECT_FALSE(watch.rejected(3.1, P));
  watch.accepted();
  EXPECT_FALSE(watch.rejected(3.2, P));
  EXPECT_EQ(P, before);
  EXPECT_FALSE(watch.lost());
  // ... 3: lost, widened by the random walk since the count left 0.
  EXPECT_TRUE(watch.rejected(3.4, P));
  EXPECT_TRUE(watch.lost());
  EXPECT_EQ(watch.times_lost(), 1);
  EXPECT_NEAR(P(0, 0), 0.01 + 0.25 * 0.4, 1e-12);
  EXPECT_NEAR(P(1, 1), 0.01 + 0.25 * 0.4, 1e-12);
  EXPECT_NEAR(P(2, 2), 0.01 + 0.04 * 0.4, 1e-12);
  // The pose block alone; the rest of the state (a filter's gains) is not the pose's.
  EXPECT_EQ(P(3, 3), 0.01);
  EXPECT_EQ(P(0, 1), 0.0);
  // Let through meanwhile (4, then 3): still lost; the next rejection widens from the last
  // widening on, up to the limits, which it never narrows.
  EXPECT_TRUE(watch.rejected(3.5, P));
  watch.accepted();
  EXPECT_TRUE(watch.lost());
  EXPECT_TRUE(watch.rejected(4.5, P));
  EXPECT_NEAR(P(0, 0), 0.11 + 0.25 * 0.1 + 0.25, 1e-12);
  EXPECT_NEAR(P(2, 2), 0.026 + 0.04 * 0.1 + 0.04, 1e-12);
  EXPECT_TRUE(watch.rejected(100.0, P));
  EXPECT_NEAR(P(0, 0), 1.0, 1e-12);
  EXPECT_NEAR(P(2, 2), 0.09, 1e-12);
  P(2, 2) = 0.5;
  EXPECT_TRUE(watch.rejected(101.0, P));
  EXPECT_EQ(P(2, 2), 0.5);
  EXPECT_EQ(watch.times_lost(), 1);
  // Detections that fit again end it; being lost again counts anew.
  for (int i = 0; i < 5; ++i) watch.accepted();
  EXPECT_FALSE(watch.lost());
  EXPECT_FALSE(watch.rejected(102.0, P));
  EXPECT_TRUE(watch.rejected(103.0, P));
  EXPECT_EQ(watch.times_lost(), 2);
  // after_rejections 0: never lost.
  sdk::LostWatch off(sdk::LostWatchDef{0});
  for (int i = 0; i < 100; ++i) EXPECT_FALSE(off.rejected(i, P));
  EXPECT_FALSE(off.lost());
}

TEST(Metrics, ErrorSummaryCountsConvergenceAndTimeLost) {
  // 50 Hz samples: 1 m off for 1 s, then on target; a 2 s gap (carried) at t = 3 s while lost.
  std::vector<ErrorSample> samples;
  for (int i = 0; i < 150; ++i) {
    const double t = i * 0.02;
    samples.push_back({t, t < 1.0 ? 1.0 : 0.0, 0.0, 0.0, i / 5, {}});  // a frame every 0.1 s
  }
  samples.push_back({5.0, 2.0, 0.0, 0.0, 0, {}});
  samples.push_back({5.02, 0.0, 0.0, 0.0, 0, {}});
  const ErrorSummary s = summarize_errors(samples);
  ASSERT_TRUE(s.converged_at_s.has_value());
  EXPECT_NEAR(*s.converged_at_s, 1.0, 1e-9);
  EXPECT_EQ(s.converged_at_steps, 10);
  EXPECT_NEAR(s.time_lost_s, 1.0 + 0.02, 1e-9);  // the carried gap counts one interval, not 2 s
  EXPECT_DOUBLE_EQ(s.position_max_m, 2.0);
  EXPECT_NEAR(s.x_rms_m, std::sqrt((50 * 1.0 + 4.0) / 152.0), 1e-12);
  // Tracking: from the convergence at 1 s on, the 2 m sample after the gap included.
  EXPECT_EQ(s.tracking_samples, 102u);
  EXPECT_NEAR(s.tracking_position_rms_m, std::sqrt(4.0 / 102.0), 1e-12);
  const ErrorSummary never = summarize_errors({samples.begin(), samples.begin() + 50});
  EXPECT_EQ(never.tracking_samples, 0u);
}

TEST(Metrics, AJumpWhileTrackingIsCountedAndASlowDriftIsNot) {
  // 10 Hz samples within 0.05 m; at 5 s the estimate leaps 15 m (a wrong guess winning) and
  // stays there until 8 s, then is back; from 10 s it drifts off at 0.5 m/s (lost slowly);
  // at 20 s it is back, and at 21 s the error steps 1.5 m (not a jump: under 2 m).
  const ConvergenceCriterion criterion{0.25, deg_to_rad(10.0), 10};
  ErrorAccumulator errors(criterion);
  for (int i = 0; i < 250; ++i) {
    const double t = 0.1 * i;
    double dx = 0.05;
    if (t >= 5.0 && t < 8.0) dx = 15.0;
    if (t >= 10.0 && t < 20.0) dx = 0.05 + 0.5 * (t - 10.0);
    if (t >= 21.0) dx = 1.55;
    errors.add({t, dx, 0.0, 0.0, 0, {}});
  }
  const ErrorSummary s = errors.summary();
  EXPECT_EQ(s.jumps, 1u);
  ASSERT_TRUE(s.first_jump_s.has_value());
  EXPECT_NEAR(*s.first_jump_s, 4.9, 1e-9);  // the last sample within the bound before it
  // A leap within the window of the last sample within the bound counts; after a gap longer
  // than the window (a carry) it does not.
  ErrorAccumulator carried(criterion);
  carried.add({0.0, 0.0, 0.0, 0.0, 0, {}});
  carried.add({kJumpWindowS + 0.5, 5.0, 0.0, 0.0, 0, {}});
  EXPECT_EQ(carried.summary().jumps, 0u);
}

TEST(Metrics, TheEllipseWhileConvergedCountsFromTheConvergenceOn) {
  // 1 s lost with an honest wide covariance (truth inside), then on target for 2 s with a tight
  // one that holds the truth, then 1 s off by 0.5 m with the same tight covariance (outside).
  const ConvergenceCriterion criterion{0.25, deg_to_rad(10.0), 10};
  ErrorAccumulator errors(criterion);
  std::array<double, 9> wide{}, tight{};
  wide[0] = wide[4] = 100.0;
  wide[8] = 1.0;
  tight[0] = tight[4] = 0.01;
  tight[8] = 0.01;
  for (int i = 0; i < 40; ++i) {
    const double t = 0.1 * i;
    if (t < 1.0)
      errors.add({t, 3.0, 0.0, 0.0, 0, wide});
    else if (t < 3.0)
      errors.add({t, 0.02, 0.0, 0.0, 0, tight});
    else
      errors.add({t, 0.5, 0.0, 0.0, 0, tight});
  }
  const ErrorSummary s = errors.summary();
  ASSERT_TRUE(s.converged_at_s.has_value());
  EXPECT_NEAR(*s.converged_at_s, 1.0, 1e-9);
  EXPECT_EQ(s.tracking_consistency_samples, 30u);
  EXPECT_NEAR(s.tracking_inside_95_fraction, 20.0 / 30.0, 1e-12);
  EXPECT_NEAR(s.inside_95_fraction, 30.0 / 40.0, 1e-12);  // the lost second was honest
  ErrorAccumulator never(criterion);
  never.add({0.0, 3.0, 0.0, 0.0, 0, wide});
  EXPECT_EQ(never.summary().tracking_consistency_samples, 0u);
}

TEST(Metrics, AKidnapIsRecoverableByWhatTheFiltersOwnSensorsShowAfterTheLanding) {
  // One robot, two kidnaps. After the first landing its camera shows one landmark (besides a
  // false detection and another robot) and two beacons answer in line of sight (a third through
  // a wall): nothing can find it again. After the second, two landmarks and a laser scan.
  // Readings while carried count for nothing.
  WorldDef world;
  world.robots.emplace_back().name = "robot";
  for (int id = 1; id <= 3; ++id) world.landmarks.push_back({id, Vec2(id, 0.0)});
  const auto bit = [](int kind) { return LOCSIM_READING_BIT(kind); };
  const std::uint32_t odometry = bit(LOCSIM_READING_ODOMETRY);
  std::vector<LocalizerInfo> infos;
  for (const auto& [label, readings] :
       {std::pair{"landmarks", odometry | bit(LOCSIM_READING_LANDMARKS)},
        {"beacons", odometry | bit(LOCSIM_READING_BEACON_RANGES)},
        {"laser", odometry | bit(LOCSIM_READING_LASER)},
        {"dead_reckoning", odometry},
        {"unsaid", 0u}}) {
    infos.push_back({0, "robot", label, label, "", "{}", readings});
  }
  Scorer scorer(world, infos, ConvergenceCriterion{});
  const auto event = [&](double t_s, const char* kind) {
    Record r;
    r.type = Record::Type::kEvent;
    r.event = {0, t_s, kind, "robot", ""};
    scorer.consume(r);
  };
  const auto reading = [&](double t_s, SensorKind kind, ReadingData data) {
    Record r;
    r.type = Record::Type::kReading;
    r.reading = {t_s, 0, kind, std::move(data)};
    scorer.consume(r);
  };
  const auto camera = [&](double t_s, std::vector<std::pair<int, DetectionTarget>> truths) {
    PtzReading ptz;
    for (const auto& [truth, target] : truths) {
      Detection d;
      d.truth_id = truth;
      d.target = target;
      ptz.detections.push_back(d);
    }
    reading(t_s, SensorKind::kPtzCamera, ptz);
  };
  const auto samples = [&](double from_s, double to_s) {
    for (double t = from_s; t < to_s - 1e-9; t += 0.1) {
      for (std::size_t k = 0; k < infos.size(); ++k) {
        EstimateSample sample;
        sample.localizer = k;
        sample.t_s = t;
        sample.truth = {t, 0.0, 0.0};
        sample.pose = {t + 5.0, 0.0, 0.0};
        scorer.estimate(sample);
      }
    }
  };
  const auto lm = DetectionTarget::kLandmark;
  samples(0.0, 1.0);
  event(1.0, "kidnap");
  camera(1.5, {{1, lm}, {2, lm}});  // carried: not counted
  reading(1.5, SensorKind::kLaser, LaserScan{{1.0f}});
  event(2.0, "put_down");
  camera(2.1, {{1, lm}, {-1, lm}, {2, DetectionTarget::kRobot}});
  camera(2.5, {{1, lm}});
  UltrasonicReading ultrasonic;
  ultrasonic.ranges = {{0, 7, 2.0, RangeStatus::kLineOfSight},
                       {0, 8, 3.0, RangeStatus::kLineOfSight},
                       {0, 9, 4.0, RangeStatus::kNonLineOfSight},
                       {0, 10, std::nan(""), RangeStatus::kLineOfSight}};
  reading(2.2, SensorKind::kUltrasonic, ultrasonic);
  samples(2.0, 4.0);
  event(4.0, "kidnap");
  event(4.0, "put_down");
  camera(4.1, {{1, lm}, {3, lm}});
  reading(4.2, SensorKind::kLaser, LaserScan{{1.0f}});
  samples(4.0, 5.0);

  const fs::path dir = testing::temp_dir("recoverable");
  std::vector<LocalizerFinal> ends(infos.size());
  scorer.write({dir}, ends);
  const auto metrics = nlohmann::json::parse(testing::read_file(dir / "metrics.json"));
  const auto& localizers = metrics["localizers"];
  ASSERT_EQ(localizers.size(), infos.size());
  const nlohmann::json first = localizers[0]["segments"][1]["sensed"];
  EXPECT_EQ(first["landmarks"], 1);
  EXPECT_EQ(first["beacons"], 2);
  EXPECT_EQ(first["laser_scans"], 0);
  const nlohmann::json second = localizers[0]["segments"][2]["sensed"];
  EXPECT_EQ(second["landmarks"], 2);
  EXPECT_EQ(second["laser_scans"], 1);
  const std::vector<std::pair<bool, bool>> expected = {
      {false, true}, {false, false}, {false, true}, {false, false}, {false, true}};
  for (std::size_t k = 0; k < infos.size(); ++k) {
    const auto& segments = localizers[k]["segments"];
    ASSERT_EQ(segments.size(), 3u);
    EXPECT_FALSE(segments[0].contains("recoverable"));
    EXPECT_EQ(segments[1]["recoverable"], expected[k].first) << infos[k].label;
    EXPECT_EQ(segments[2]["recoverable"], expected[k].second) << infos[k].label;
  }
  EXPECT_EQ(localizers[0]["readings"], nlohmann::json({"odometry", "landmarks"}));
  EXPECT_TRUE(localizers[4]["readings"].is_null());
}

TEST(Models, ComposeAndBetweenAreInverse) {
  const sdk::Pose a(1, 2, 2.5), b(-3, 0.5, -2.9);
  const sdk::Pose back = sdk::compose(a, sdk::between(a, b));
  EXPECT_LT((back.head<2>() - b.head<2>()).norm(), 1e-12);
  EXPECT_NEAR(sdk::wrap(back(2) - b(2)), 0.0, 1e-12);
}

// --------------------------------------------------------------------------- first filters
TEST(Filters, EkfBeatsOdometryUntilTheKidnapAndThenSaysItIsLost) {
  const fs::path out = testing::temp_dir("run") / "out";
  const auto metrics = run_demo(out, 30.0, {"odometry", "ekf_landmarks"});
  const auto& odometry = entry(metrics, "odometry");
  const auto& ekf = entry(metrics, "ekf_landmarks");
  ASSERT_EQ(odometry["segments"].size(), 2u);  // split by the kidnap at 20 s
  const double odometry_rms = odometry["segments"][0]["position_error_m"]["rms"];
  const double ekf_rms = ekf["segments"][0]["position_error_m"]["rms"];
  EXPECT_LT(ekf_rms, 0.1);
  EXPECT_LT(ekf_rms, 0.25 * odometry_rms)
      << "ekf " << ekf_rms << " m, odometry " << odometry_rms << " m";
  EXPECT_GT(odometry["segments"][1]["position_error_m"]["rms"].get<double>(), 1.0);
  EXPECT_GT(ekf["segments"][1]["position_error_m"]["rms"].get<double>(), 1.0);
  // Within the 10 s left, neither finds the robot again; the EKF rejects what it sees, and says
  // it is lost (its covariance widens: the demo's full minute, it finds the pose after 18 s).
  EXPECT_TRUE(ekf["segments"][1]["recovery_s"].is_null());
  EXPECT_GT(ekf["diagnostics"]["updates_accepted"].get<double>(), 100.0);
  EXPECT_GE(ekf["diagnostics"]["times_lost"].get<double>(), 1.0);
  // How far the kidnap carried the robot: from where it was lifted to where it was put down,
  // as events.csv has them, to within what the robot drives between samples.
  const std::string events = testing::read_file(out / "events.csv");
  double from_x = 0, from_y = 0, from_theta = 0, to_x = 0, to_y = 0, to_theta = 0;
  ASSERT_EQ(std::sscanf(events.c_str() + events.find("from=("), "from=(%lf,%lf,%lf)", &from_x,
                        &from_y, &from_theta),
            3);
  ASSERT_EQ(std::sscanf(events.c_str() + events.find("put_down,robot,\"to=("),
                        "put_down,robot,\"to=(%lf,%lf,%lf)", &to_x, &to_y, &to_theta),
            3);
  for (const auto* l : {&odometry, &ekf}) {
    EXPECT_FALSE((*l)["segments"][0].contains("carried_m"));  // no kidnap before the first
    EXPECT_NEAR((*l)["segments"][1]["carried_m"].get<double>(),
                std::hypot(to_x - from_x, to_y - from_y), 0.05);
    EXPECT_NEAR((*l)["segments"][1]["turned_deg"].get<double>(),
                std::abs(rad_to_deg(wrap_angle(to_theta - from_theta))), 1.0);
  }
  // What each reads, and so whether the kidnap was recoverable for it: dead reckoning never
  // finds a kidnapped robot; the EKF's camera showed it landmarks after the landing (and it
  // did not recover: a failure that counts against it).
  EXPECT_EQ(odometry["readings"], nlohmann::json({"odometry"}));
  EXPECT_EQ(ekf["readings"], nlohmann::json({"odometry", "imu", "landmarks"}));  // imu: its gyro
  EXPECT_FALSE(odometry["segments"][1]["recoverable"].get<bool>());
  EXPECT_GE(ekf["segments"][1]["sensed"]["landmarks"].get<int>(), 2);
  EXPECT_TRUE(ekf["segments"][1]["recoverable"].get<bool>());
  // The EKF tracks before the kidnap: its tracking RMS is that of the converged samples.
  EXPECT_GT(ekf["segments"][0]["tracking"]["samples"].get<int>(), 100);
  EXPECT_LT(ekf["segments"][0]["tracking"]["position_rms_m"].get<double>(), ekf_rms + 1e-9);
  EXPECT_TRUE(ekf["segments"][1]["tracking"]["position_rms_m"].is_null());
}

/// The demo world's loop for 30 s with one push at 8 s (`push`: the event's flow map, e.g.
/// "impulse_ns: [0, 0], angular_impulse_nms: -1.5"), run with `localizers`; metrics.json.
nlohmann::json run_demo_pushed(const fs::path& dir, const std::string& push,
                               std::vector<std::string> localizers) {
  std::ofstream(dir / "push.yaml") << "name: push\nduration_s: 30\ndrive:\n  mode: waypoints\n"
                                      "  path: [[8.5, 1.5], [8.5, 5.0], [6.0, 5.0], [6.0, 3.2], "
                                      "[1.5, 3.2], [1.5, 1.5]]\n  loop: true\n  speed_mps: 0.4\n"
                                      "ptz: {policy: nearest_landmark}\nevents:\n  - at_s: 8\n"
                                      "    push: {robot: robot, "
                                   << push << "}\n";
  RunOptions options;
  options.world_file = fs::path(LOCSIM_SOURCE_DIR) / "worlds/demo/demo.yaml";
  options.scenario_file = dir / "push.yaml";
  options.out_dir = dir / "out";
  options.localizers = std::move(localizers);
  run_simulation(options);
  return nlohmann::json::parse(testing::read_file(dir / "out" / "metrics.json"));
}

// Issue 53: a push turns the robot 40-50 degrees where the EKF has no gyro to see it. Blind to
// being lost, the gate then rejects every detection and the EKF stays off and sure of itself; with
// the LostWatch its covariance widens until the landmarks fit, and it tracks again.
TEST(Filters, AnEkfThatAPushLeftRejectingWhatItSeesWidensAndFindsThePoseAgain) {
  const auto metrics =
      run_demo_pushed(testing::temp_dir("push"), "impulse_ns: [0, 0], angular_impulse_nms: -1.5",
                      {"ekf_landmarks:use_gyro=false,lost_after_rejections=0@blind",
                       "ekf_landmarks:use_gyro=false@watching"});
  const auto& blind = entry(metrics, "blind");
  const auto& watching = entry(metrics, "watching");
  const auto rms = [](const nlohmann::json& l) {
    return l["position_error_m"]["rms"].get<double>();
  };
  const auto inside = [](const nlohmann::json& l) {
    return l["consistency"]["inside_95_ellipse"].get<double>();
  };
  EXPECT_GT(blind["heading_error_deg"]["max"].get<double>(), 30.0);  // measured: 46
  EXPECT_GT(rms(blind), 1.0);                                        // measured: 2.2 m
  EXPECT_LT(inside(blind), 0.5);                                     // measured: 0.27
  EXPECT_EQ(blind["diagnostics"]["times_lost"].get<double>(), 0.0);
  EXPECT_LT(rms(watching), 0.1);     // measured: 0.024 m
  EXPECT_GT(inside(watching), 0.8);  // measured: 0.89
  EXPECT_GE(watching["diagnostics"]["times_lost"].get<double>(), 1.0);
  EXPECT_LT(watching["diagnostics"]["updates_rejected"].get<double>(),
            0.2 * blind["diagnostics"]["updates_rejected"].get<double>());  // measured: 25, 565
}

// Issue 53: a shove the gyro sees turns and slides the robot; the wheels, slipping against the
// gyro, show neither the slide nor its direction. Widened by the slip (slide_per_slip), the EKF
// takes the landmarks' word for where the shove left it; without, it rejects them for a while.
TEST(Filters, AnEkfWithAGyroWidensItsPositionByTheWheelsSlipAndAbsorbsAShove) {
  const auto metrics =
      run_demo_pushed(testing::temp_dir("shove"), "impulse_ns: [-30, 20], angular_impulse_nms: 1.0",
                      {"ekf_landmarks:slide_per_slip=0@plain", "ekf_landmarks@sliding"});
  const auto& plain = entry(metrics, "plain");
  const auto& sliding = entry(metrics, "sliding");
  const auto error = [](const nlohmann::json& l, const char* what) {
    return l["position_error_m"][what].get<double>();
  };
  EXPECT_GT(error(plain, "max"), 0.5);                                 // measured: 0.89 m
  EXPECT_LT(error(sliding, "max"), 0.5);                               // measured: 0.27 m
  EXPECT_LT(error(sliding, "rms"), 0.5 * error(plain, "rms"));         // measured: 0.028, 0.12 m
  EXPECT_EQ(sliding["diagnostics"]["times_lost"].get<double>(), 0.0);  // plain: lost once
  EXPECT_GT(sliding["consistency"]["inside_95_ellipse"].get<double>(), 0.95);  // measured: 0.997
}

}  // namespace
}  // namespace locsim
