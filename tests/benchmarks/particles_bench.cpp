// Particle updates per second for the landmark model from the SDK's pieces: motion sampling,
// weighting by 6 landmark detections (the batch likelihood), normalisation, N_eff and
// resampling. landmark_pf_bench.cpp measures the same through a plugin. Target (issue 6):
// >= 10 million particle updates per second per core; 10 000 particles well under a millisecond.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <optional>
#include <vector>

#include "locsim/models.hpp"
#include "locsim/particle_filter.hpp"
#include "locsim/particles.hpp"
#include "locsim/vector_math.hpp"

namespace {

using namespace locsim::sdk;

void BM_ParticleUpdateLandmarks(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  Random random(1);
  ParticleSet particles, scratch;
  particles.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    particles.x[i] = random.uniform(0, 6), particles.y[i] = random.uniform(0, 4);
    particles.theta[i] = random.uniform(-3.14, 3.14);
  }
  const double landmarks[6][2] = {{0, 0}, {3, 0}, {6, 0}, {6, 4}, {3, 4}, {0, 4}};
  const OdometryDelta delta{0.01, 0.03, -0.01};
  const OdometryNoise noise;
  std::vector<std::size_t> chosen;
  std::vector<double> log_w(n), match, spacings;
  Headings headings;
  for (auto _ : state) {
    sample_motion(particles, delta, noise, random);
    headings.compute(particles);
    std::fill(log_w.begin(), log_w.end(), 0.0);
    for (const auto& l : landmarks) {
      landmark_log_match(particles, headings, 2.5, 0.3, l[0], l[1], 0.3, 0.1, match);
      for (std::size_t i = 0; i < n; ++i) log_w[i] += match[i];
    }
    const double top = *std::max_element(log_w.begin(), log_w.end());
    for (std::size_t i = 0; i < n; ++i) particles.weight[i] = std::exp(log_w[i] - top);
    normalize(particles.weight);
    benchmark::DoNotOptimize(effective_sample_size(particles.weight));
    if (state.range(1) == 0) {
      roulette_resample(particles.weight, random, chosen, spacings);
    } else {
      low_variance_resample(particles.weight, random, chosen);
    }
    apply_resample(particles, chosen, scratch);
  }
  state.counters["particle_updates_per_s"] =
      benchmark::Counter(static_cast<double>(n) * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate);
}
// Args: particles, resampler (0 roulette as in the paper, 1 low variance).
BENCHMARK(BM_ParticleUpdateLandmarks)
    ->ArgsProduct({{400, 10000}, {0, 1}})
    ->ArgNames({"particles", "low_variance"})
    ->Unit(benchmark::kMicrosecond);

// The pieces alone, per particle: where a step's time goes.
void BM_NormalVariates(benchmark::State& state) {
  Random random(1);
  for (auto _ : state) benchmark::DoNotOptimize(random.normal());
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_NormalVariates);

void BM_RouletteResample(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  Random random(1);
  std::vector<double> w(n);
  for (double& v : w) v = random.uniform();
  std::vector<std::size_t> chosen;
  std::vector<double> spacings;
  for (auto _ : state) roulette_resample(w, random, chosen, spacings);
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_RouletteResample)->Arg(10000);

// The skeleton's share of a step (locsim/particle_filter.hpp): weights from per-particle log
// likelihoods (the evidence, N_eff) and a low-variance resample carrying one vector of the
// filter's own data (FastSLAM's maps are such a vector). Measured on the 2-core VM: 0.20 ms at
// 10 000 particles (a tenth of it drawing the test's likelihoods), against 0.56-0.66 ms for a
// whole landmark step above: the sensor model is the larger part, as it should be.
void BM_ParticleFilterWeighAndResample(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  ParticleFilter pf(n, 1);
  pf.place_all(Pose::Zero());
  Random random(2);
  std::vector<double> log_likelihood(n);
  std::vector<int> own(n, 0);
  for (auto _ : state) {
    for (double& v : log_likelihood) v = -3.0 * random.uniform();
    benchmark::DoNotOptimize(pf.weigh(log_likelihood));
    pf.resample(own);
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_ParticleFilterWeighAndResample)->Arg(1000)->Arg(10000);

// The SDK's StableMode (the landmark filters' and amcl's estimate) on a set split between the
// belief and a recovery's guesses 5 m away, the guesses spread over many bins: clustering, the
// choice and the second moment, per update.
void BM_StableModeUpdate(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  ParticleSet p;
  Random random(3);
  for (std::size_t i = 0; i < n; ++i) {
    const bool guess = i % 3 == 0;
    p.x.push_back((guess ? 6.0 : 1.0) + random.normal(guess ? 1.0 : 0.1));
    p.y.push_back(2.0 + random.normal(guess ? 1.0 : 0.1));
    p.theta.push_back(wrap(random.normal(guess ? 1.0 : 0.05)));
    p.weight.push_back(1.0 / static_cast<double>(n));
  }
  PoseBins bins(0.5, 10.0 * std::numbers::pi / 180.0);
  StableMode mode;
  mode.update(p, n, bins, std::nullopt);
  for (auto _ : state) {
    mode.update(p, n, bins, mode.mean());
    benchmark::DoNotOptimize(mode.covariance());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_StableModeUpdate)->Arg(200)->Arg(5000)->Unit(benchmark::kMicrosecond);

// The SDK's OdometryTracker on a velocity-only source (the host integrated odom_pose): pose
// increment, and the wheel travel that makes it (the arc inverted), per reading.
void BM_OdometryTrackerVelocityOnly(benchmark::State& state) {
  locsim::sdk::OdometryTracker tracker(0.35);
  locsim::sdk::VelocityOdometry odometry;
  locsim_odometry reading{};
  reading.fields = LOCSIM_ODOMETRY_POSE | LOCSIM_ODOMETRY_VELOCITY;
  reading.v_mps = 0.3;
  reading.omega_radps = 0.2;
  double t_s = 0.0, travel_m = 0.0;
  for (auto _ : state) {
    t_s += 0.05;
    const locsim::sdk::Pose& pose = odometry.update(t_s, reading.v_mps, reading.omega_radps);
    reading.odom_pose = {pose(0), pose(1), pose(2)};
    if (const auto step = tracker.update(t_s, reading)) travel_m += step->d_left_m;
    benchmark::DoNotOptimize(travel_m);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_OdometryTrackerVelocityOnly);

// A pose source with three readings of another sensor between two odometry readings (a range
// every 12.5 ms against odometry every 50 ms): per odometry reading, the update and the three
// advance_to() that bring the motion to those readings' times.
void BM_OdometryTrackerAdvance(benchmark::State& state) {
  locsim::sdk::OdometryTracker tracker(0.35);
  locsim::sdk::VelocityOdometry odometry;
  locsim_odometry reading{};
  reading.fields = LOCSIM_ODOMETRY_POSE;  // a pose source: advanced at the last step's rate
  double t_s = 0.0, travel_m = 0.0;
  for (auto _ : state) {
    t_s += 0.05;
    const locsim::sdk::Pose& pose = odometry.update(t_s, 0.3, 0.2);
    reading.odom_pose = {pose(0), pose(1), pose(2)};
    if (const auto step = tracker.update(t_s, reading)) travel_m += step->d_left_m;
    for (const double between_s : {0.0125, 0.025, 0.0375}) {
      if (const auto step = tracker.advance_to(t_s + between_s)) travel_m += step->d_left_m;
    }
    benchmark::DoNotOptimize(travel_m);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_OdometryTrackerAdvance);

// The SDK's CommandFollower on MRCLAM-like commanded velocities (a reading every 15 ms, the
// response calibrate fits there), then the tracker: what a landmark filter with command_* adds
// per odometry reading over BM_OdometryTrackerVelocityOnly.
void BM_CommandFollowerThenTracker(benchmark::State& state) {
  locsim::sdk::CommandFollower follower(locsim::sdk::CommandResponse{0.08, 0.25, 0.2, 0.93, 0.95});
  // On the heap: GCC's inlining of both otherwise warns (wrongly) of the tracker's empty
  // std::optional being read.
  const auto tracker = std::make_unique<locsim::sdk::OdometryTracker>(0.35);
  locsim_odometry reading{};
  reading.fields = LOCSIM_ODOMETRY_POSE | LOCSIM_ODOMETRY_VELOCITY;
  double t_s = 0.0, travel_m = 0.0;
  std::size_t k = 0;
  for (auto _ : state) {
    t_s += 0.015;
    reading.v_mps = 0.1 + 0.05 * static_cast<double>(++k % 7);
    reading.omega_radps = 0.2 - 0.1 * static_cast<double>(k % 5);
    if (const auto step = tracker->update(t_s, follower.follow(t_s, reading)))
      travel_m += step->d_left_m;
    benchmark::DoNotOptimize(travel_m);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_CommandFollowerThenTracker);

// A Kalman prediction by one odometry reading's wheel travel: the pose alone
// (predict_by_wheels), and the pose with the base's wandering gains (x, y, theta, g_v, g_omega):
// what ekf_landmarks pays per reading for gain_wander_*.
void BM_PredictByWheels(benchmark::State& state) {
  const bool gains = state.range(0) != 0;
  Pose x(1.0, 2.0, 0.3);
  Eigen::Matrix3d P = Eigen::Matrix3d::Identity() * 1e-3;
  PoseGains xg;
  xg << x, 0.01, -0.02;
  PoseGainsCovariance Pg = PoseGainsCovariance::Identity() * 1e-3;
  const GainWander wander{0.15, 0.15, 2.0};
  std::size_t k = 0;
  for (auto _ : state) {
    const double dl = 0.004 + 1e-4 * static_cast<double>(++k % 7), dr = 0.005;
    if (gains) {
      predict_by_wheels_and_gains(xg, Pg, dl, dr, 0.35, 0.03, 0.03, 0.0, wander, 0.015);
      benchmark::DoNotOptimize(Pg.data());
    } else {
      predict_by_wheels(x, P, dl, dr, 0.35, 0.03, 0.03);
      benchmark::DoNotOptimize(P.data());
    }
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_PredictByWheels)->ArgName("gains")->Arg(0)->Arg(1);

// LostWatch per detection: a tracking filter's (arg 0: one rejection in ten, the count never
// reaching lost) and a lost one's (arg 1: every detection rejected, each widening the pose's
// covariance): what ekf_landmarks pays per detection for lost_*.
void BM_LostWatch(benchmark::State& state) {
  const bool lost = state.range(0) != 0;
  LostWatch watch{LostWatchDef{}};
  Eigen::Matrix3d P = Eigen::Matrix3d::Identity() * 1e-3;
  double t_s = 0.0;
  std::size_t k = 0;
  for (auto _ : state) {
    t_s += 0.1;
    if (lost || ++k % 10 == 0)
      benchmark::DoNotOptimize(watch.rejected(t_s, P));
    else
      watch.accepted();
    benchmark::DoNotOptimize(P.data());
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_LostWatch)->ArgName("lost")->Arg(0)->Arg(1);

// Eight landmarks seen in turn every 0.1 s, each detection's variance factors summed by
// `factors` from what `seen.inflation` gives.
template <class Seen, class Factors>
void detections_in_turn(benchmark::State& state, Seen& seen, Factors factors) {
  locsim_detection d{};
  double t_s = 0.0, sum = 0.0;
  std::int32_t k = 0;
  for (auto _ : state) {
    d.id = ++k % 8;
    t_s += 0.1;
    sum += factors(seen.inflation(LOCSIM_CAMERA_RANGE_BEARING, d, t_s));
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations());
}

// CorrelatedDetections per detection: the first-order rule (arg 0) and the slow part's
// per-target Kalman filter (arg 1).
void BM_CorrelatedDetections(benchmark::State& state) {
  CorrelatedDetections seen =
      state.range(0) != 0 ? CorrelatedDetections(0.4, 40.0, 0.5) : CorrelatedDetections(1.0);
  detections_in_turn(state, seen, [](double factor) { return factor; });
}
BENCHMARK(BM_CorrelatedDetections)->ArgName("slow")->Arg(0)->Arg(1);

// CorrelatedRangeBearing per detection, with the slow part: the bearing persisting as the range
// (arg 0: one filter serves both) or its own way (arg 1: a second filter).
void BM_CorrelatedRangeBearing(benchmark::State& state) {
  CorrelatedRangeBearing seen(
      CorrelatedDetections(0.4, 40.0, 0.5),
      state.range(0) != 0 ? std::optional(CorrelatedDetections(0.02, 18.0, 0.65)) : std::nullopt);
  detections_in_turn(state, seen, [](const CorrelatedRangeBearing::Inflation& factor) {
    return factor.range + factor.bearing;
  });
}
BENCHMARK(BM_CorrelatedRangeBearing)->ArgName("bearing_apart")->Arg(0)->Arg(1);

// The SDK's OdometryFollower per odometry reading and the IMU's two readings before it (as the
// host streams them: 50 and 100 Hz), with the gyro turning the odometry (Arg 1) or not (0).
void BM_OdometryFollowerGyro(benchmark::State& state) {
  locsim::sdk::OdometryFollower follower;
  follower.use_gyro(state.range(0) != 0);
  locsim::sdk::VelocityOdometry wheels;
  locsim_odometry reading{};
  locsim_imu imu{};
  imu.yaw_rate_radps = 0.15;  // the wheels say 0.2 rad/s: they slip
  double t_s = 0.0, slip_rad = 0.0;
  for (auto _ : state) {
    follower.observe_imu(t_s + 0.01, imu);
    t_s += 0.02;
    follower.observe_imu(t_s, imu);
    const locsim::sdk::Pose& pose = wheels.update(t_s, 0.3, 0.2);
    reading.odom_pose = {pose(0), pose(1), pose(2)};
    follower.observe(t_s, reading);
    slip_rad += follower.since_mark().slip_rad;
    follower.mark_now();
    benchmark::DoNotOptimize(slip_rad);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_OdometryFollowerGyro)->Arg(0)->Arg(1);

// The SDK's vector maths (locsim/vector_math.hpp) over 10 000 elements, a particle set's worth,
// per version against libm one element at a time (version -1). Arguments as a filter's: headings,
// exp of log-likelihood differences down to underflow, log1p of likelihood ratios in (0, 1].
enum class MathOp { kSinCos, kExp, kLog1p };
void BM_VectorMath(benchmark::State& state, MathOp op) {
  namespace vm = locsim::sdk::vector_math;
  const auto version = state.range(0);
  if (version > static_cast<int>(vm::widest_isa())) {
    state.SkipWithError("this processor does not run that version");
    return;
  }
  constexpr std::size_t kCount = 10000;
  std::vector<double> x(kCount), a(kCount), b(kCount);
  Random random(3);
  for (double& v : x)
    v = op == MathOp::kSinCos ? random.uniform(-3.2, 3.2)
        : op == MathOp::kExp  ? random.uniform(-800.0, 0.0)
                              : random.uniform();
  for (auto _ : state) {
    if (version < 0) {
      for (std::size_t i = 0; i < kCount; ++i) {
        if (op == MathOp::kSinCos) {
          const double angle = x[i];  // one argument in a local: the compiler fuses a sincos
          a[i] = std::sin(angle), b[i] = std::cos(angle);
        } else {
          a[i] = op == MathOp::kExp ? std::exp(x[i]) : std::log1p(x[i]);
        }
      }
    } else {
      const auto isa = static_cast<vm::Isa>(version);
      if (op == MathOp::kSinCos) vm::sincos(isa, x, a, b);
      if (op == MathOp::kExp) vm::exp(isa, x, a);
      if (op == MathOp::kLog1p) vm::log1p(isa, x, a);
    }
    benchmark::DoNotOptimize(a.data());
    benchmark::DoNotOptimize(b.data());
  }
  state.counters["elements_per_s"] =
      benchmark::Counter(static_cast<double>(kCount) * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate);
  state.SetLabel(version < 0 ? "libm" : vm::isa_name(static_cast<vm::Isa>(version)));
}
BENCHMARK_CAPTURE(BM_VectorMath, sincos, MathOp::kSinCos)->DenseRange(-1, 3)->ArgName("version");
BENCHMARK_CAPTURE(BM_VectorMath, exp, MathOp::kExp)->DenseRange(-1, 3)->ArgName("version");
BENCHMARK_CAPTURE(BM_VectorMath, log1p, MathOp::kLog1p)->DenseRange(-1, 3)->ArgName("version");

}  // namespace

// The SDK's fit_pose_to_points as omni_kf's default fix runs it once per omni frame: the pose
// that best explains Arg landmarks seen along and across their rays (the omni camera's 0.25 /
// 0.08 m ellipse), Gauss-Newton from a start 0.3 m and 6 degrees off; Arg 0 is omni_kf's
// paper fix for comparison, the two-landmark triangulation alone.
void BM_FitPoseToPoints(benchmark::State& state) {
  namespace sdk = locsim::sdk;
  const auto n = static_cast<std::size_t>(std::max<std::int64_t>(state.range(0), 2));
  const sdk::Pose truth(4.0, 3.0, 0.6);
  std::vector<Eigen::Vector2d> world;
  std::vector<sdk::PointEstimate> seen;
  for (std::size_t k = 0; k < n; ++k) {
    const double a = 2.0 * M_PI * static_cast<double>(k) / static_cast<double>(n) + 0.3;
    world.emplace_back(truth(0) + (2.0 + 0.5 * static_cast<double>(k)) * std::cos(a),
                       truth(1) + 3.0 * std::sin(a));
    const Eigen::Vector2d p = sdk::point_in_robot_frame(truth, world.back());
    const Eigen::Vector2d along = p.normalized(), across(-along.y(), along.x());
    // Off by a few centimetres, as fused observations are.
    seen.push_back({p + 0.03 * across,
                    0.0625 * along * along.transpose() + 0.0064 * across * across.transpose()});
  }
  const sdk::Pose start = truth + sdk::Pose(0.2, -0.22, 0.1);
  double sum = 0.0;
  for (auto _ : state) {
    if (state.range(0) == 0) {
      sum += (*sdk::two_landmark_pose(world[0], world[1], seen[0].p, seen[1].p))(0);
    } else {
      sum += sdk::fit_pose_to_points(world, seen, start)->pose(0);
    }
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_FitPoseToPoints)->Arg(0)->Arg(2)->Arg(4)->Arg(8);
